"""Blender meshes as NumPy arrays (libigl conventions: V float64 (n, 3), F int (m, 3)), and back."""
import numpy as np

import bpy


def vertex_positions(mesh):
    """float64 (n, 3): the mesh's vertex coordinates in its object's local space."""
    co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def set_vertex_positions(mesh, V):
    mesh.vertices.foreach_set("co", np.ascontiguousarray(V, dtype=np.float32).ravel())
    mesh.update()


def triangles(mesh):
    """The mesh cut into triangles without touching its vertices: (F int32 (m, 3), polygon int32 (m,)).

    Blender's own triangulation (the one the viewport draws): quads split along their 0-2 diagonal,
    n-gons by ear clipping; winding kept, so F is counter-clockwise where the polygons are. polygon[t]
    is the polygon triangle t came from (to name polygons in error messages).
    """
    mesh.calc_loop_triangles()
    m = len(mesh.loop_triangles)
    F = np.empty(3 * m, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", F)
    polygon = np.empty(m, dtype=np.int32)
    mesh.loop_triangles.foreach_get("polygon_index", polygon)
    return F.reshape(-1, 3), polygon


def polygon_loops(mesh):
    """(loop_start, loop_total, loop vertex ids) int32 arrays: the polygons as Blender stores them."""
    start = np.empty(len(mesh.polygons), dtype=np.int32)
    total = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", total)
    loops = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", loops)
    return start, total, loops


def mesh_like(source, name, V):
    """A new mesh with `source`'s polygons and UV maps and the vertex positions V (n, 3).

    Shape keys, modifiers' data and custom attributes are not copied: the new mesh is a plain
    surface over the same vertices, in the same order.
    """
    start, total, loops = polygon_loops(source)
    mesh = bpy.data.meshes.new(name)
    try:
        _fill_like(mesh, source, V, start, total, loops)
    except Exception:  # nothing half-made stays in the file
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def _fill_like(mesh, source, V, start, total, loops):
    mesh.vertices.add(len(source.vertices))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(V, dtype=np.float32).ravel())
    mesh.loops.add(len(loops))
    mesh.loops.foreach_set("vertex_index", loops)
    mesh.polygons.add(len(start))
    mesh.polygons.foreach_set("loop_start", start)
    mesh.polygons.foreach_set("loop_total", total)
    smooth = np.empty(len(source.polygons), dtype=bool)
    source.polygons.foreach_get("use_smooth", smooth)
    mesh.polygons.foreach_set("use_smooth", smooth)
    for layer in source.uv_layers:
        uv = np.empty(2 * len(loops), dtype=np.float32)
        layer.data.foreach_get("uv", uv)
        mesh.uv_layers.new(name=layer.name).data.foreach_set("uv", uv)
    mesh.update(calc_edges=True)
