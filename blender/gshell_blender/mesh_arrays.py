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

    Blender's own triangulation (the one the viewport draws) for triangles and quads (split along
    their 0-2 diagonal); n-gons by Blender's Beauty triangulation (_beauty_ngon_triangles). Winding
    kept, so F is counter-clockwise where the polygons are; triangles in polygon order. polygon[t]
    is the polygon triangle t came from (to name polygons in error messages).
    """
    mesh.calc_loop_triangles()
    m = len(mesh.loop_triangles)
    F = np.empty(3 * m, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", F)
    polygon = np.empty(m, dtype=np.int32)
    mesh.loop_triangles.foreach_get("polygon_index", polygon)
    F = F.reshape(-1, 3)
    total = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", total)
    ngons = np.flatnonzero(total > 4)
    if ngons.size == 0:
        return F, polygon
    beauty_F, beauty_polygon = _beauty_ngon_triangles(mesh, ngons)
    keep = total[polygon] <= 4
    F = np.concatenate([F[keep], beauty_F])
    polygon = np.concatenate([polygon[keep], beauty_polygon])
    order = np.argsort(polygon, kind="stable")
    return np.ascontiguousarray(F[order]), np.ascontiguousarray(polygon[order])


def _beauty_ngon_triangles(mesh, ngons):
    """The n-gons `ngons` (polygon ids) cut by Blender's Beauty triangulation: (F (k, 3), polygon (k,)).

    The viewport's ear clipping cuts off three consecutive corners even where they lie on one line,
    as every side of a subdivided cap does (a cylinder's 24-gon cut 6 times: 73 flat triangles),
    and a flat triangle carries no prism. Beauty keeps the polygon's vertices as well and avoids
    them.
    """
    import bmesh
    bm = bmesh.new()
    try:
        bm.from_mesh(mesh)
        bm.faces.ensure_lookup_table()
        layer = bm.faces.layers.int.new("gshell_polygon")  # copied to each triangle a face is cut into
        faces = [bm.faces[int(i)] for i in ngons]
        for face in faces:
            face[layer] = face.index
        result = bmesh.ops.triangulate(bm, faces=faces, quad_method="BEAUTY", ngon_method="BEAUTY")
        cut = list(result["faces"])
        F = np.array([[v.index for v in face.verts] for face in cut], dtype=np.int32).reshape(-1, 3)
        polygon = np.array([face[layer] for face in cut], dtype=np.int32)
        return F, polygon
    finally:
        bm.free()


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
    """A new mesh with `source`'s polygons, UV maps (the active and render ones too) and materials, and
    the vertex positions V (n, 3).

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
        copy = mesh.uv_layers.new(name=layer.name)
        copy.data.foreach_set("uv", uv)
        copy.active_render = layer.active_render  # the map renders and shader nodes use by default
    if len(source.uv_layers):
        mesh.uv_layers.active_index = source.uv_layers.active_index
    # The materials, polygon by polygon, so the top renders and textures as the base does.
    for material in source.materials:
        mesh.materials.append(material)
    index = np.empty(len(source.polygons), dtype=np.int32)
    source.polygons.foreach_get("material_index", index)
    mesh.polygons.foreach_set("material_index", index)
    mesh.update(calc_edges=True)
