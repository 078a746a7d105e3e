"""Time per frame of the Blender add-on's bake (object.gshell_bake) on a ~40K-vertex mesh.

    blender/headless/run bench/blender_bake.py build/gshell_blender.zip [MESH] [--frames K] [--runs R]

MESH: any file gshell reads (e.g. models/bunny00.off, 37.7K vertices); default a built-in quad
capsule (a cube's faces cut into 82x82 quads, pushed onto the unit sphere and stretched 2.5x along
z: 40,346 vertices, 40,344 quads). The base gets a shell (ratio 0.02), 400 small balls (4,800 vertices, one
object) are bound in its layer, and a Simple Deform modifier bends it 90 degrees over K frames
(default 24); the bake runs R times (default 3). Prints the sizes, the generate and factor times,
the median over all baked frames of each part of a frame (evaluate the base with its modifiers,
solve the top, carry the detail, write the caches) and of a whole frame, and the playback time of a
frame (frame change with and without the Mesh Cache modifiers).
"""
import json
import os
import statistics
import sys
import time

import numpy as np

import bpy
import bmesh
from mathutils import Matrix

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "blender", "headless"))
import addon_session  # noqa: E402


def option(args, name, default):
    return int(args[args.index(name) + 1]) if name in args else default


def base_mesh(gshell, path):
    if path is None:
        bpy.ops.mesh.primitive_cube_add(size=2.0)
        obj = bpy.context.active_object
        obj.name = "Capsule"
        bm = bmesh.new()
        bm.from_mesh(obj.data)
        bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=81, use_grid_fill=True)
        for v in bm.verts:
            v.co = v.co.normalized()
        bm.to_mesh(obj.data)
        bm.free()
        obj.data.transform(Matrix.Diagonal((1.0, 1.0, 2.5, 1.0)))
        return obj
    V, F = gshell.read_mesh(path)
    mesh = bpy.data.meshes.new(os.path.basename(path))
    mesh.from_pydata(V.tolist(), [], F.tolist())
    obj = bpy.data.objects.new(mesh.name, mesh)
    bpy.context.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    return obj


def balls(gshell, base, count, rng):
    """`count` small balls in the middle of the base's shell layer, as one object."""
    top = base.gshell.top
    V = np.array([v.co[:] for v in base.data.vertices])
    T = np.array([v.co[:] for v in top.data.vertices])
    F = np.asarray(top["gshell_faces"]).reshape(-1, 3)
    eta = top.gshell.thickness
    bm = bmesh.new()
    for f in rng.choice(len(F), size=count, replace=False):
        w = rng.dirichlet((2.0, 2.0, 2.0))
        centre = 0.5 * (w @ V[F[f]] + w @ T[F[f]])
        ball = bmesh.ops.create_icosphere(bm, subdivisions=1, radius=0.3 * eta)
        bmesh.ops.translate(bm, vec=centre, verts=ball["verts"])
    return addon_session.object_from_bmesh(bm, "Balls")


def median_ms(values):
    return f"{1000 * statistics.median(values):8.1f} ms"


def main():
    args = addon_session.script_args()
    gshell = addon_session.install_addon(args[0])
    path = args[1] if len(args) > 1 and not args[1].startswith("--") else None
    frames = option(args, "--frames", 24)
    runs = option(args, "--runs", 3)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)

    base = base_mesh(gshell, path)
    start = time.perf_counter()
    bpy.ops.object.gshell_generate(thickness_ratio=0.02)
    generate_seconds = time.perf_counter() - start
    detail = balls(gshell, base, 400, np.random.default_rng(1))
    addon_session.select([detail, base], base)
    bpy.ops.object.gshell_bind()
    addon_session.animate_bend(base, 90, 1, frames)

    stats, factor, iterations = [], [], []
    for _ in range(runs):
        bpy.ops.object.gshell_bake(frame_start=1, frame_end=frames)
        report = json.loads(base.gshell.top["gshell_bake"])
        factor.append(report["factor_seconds"])
        stats += [frame["seconds"] for frame in report["frames"]]
        iterations += [frame["iterations"] for frame in report["frames"]]

    scene = bpy.context.scene
    cached = [base.gshell.top, detail]

    def playback():
        times = []
        for f in range(1, frames + 1):
            start = time.perf_counter()
            scene.frame_set(f)
            for obj in [base] + cached:  # what a viewport redraw asks for
                obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
            times.append(time.perf_counter() - start)
        return times

    with_caches = playback()
    for obj in cached:
        obj.modifiers["gshell bake"].show_viewport = False
    without_caches = playback()

    print(f"\nbench_blender_bake: {base.name}: {len(base.data.vertices)} vertices, {len(base.data.polygons)} polygons "
          f"({len(base.gshell.top['gshell_faces']) // 3} triangles); detail {len(detail.data.vertices)} vertices; "
          f"{frames} frames x {runs} runs")
    print(f"  generate (rigid, ratio 0.02)      {1000 * generate_seconds:8.1f} ms")
    print(f"  factor (once per bake)            {median_ms(factor)}")
    for part in ("evaluate", "solve", "carry", "write", "total"):
        print(f"  per frame: {part:<22} {median_ms([s[part] for s in stats])}")
    print(f"  solver iterations per frame       {statistics.median(iterations):8.1f}")
    print(f"  playback: frame change, caches    {median_ms(with_caches)}")
    print(f"  playback: frame change, no caches {median_ms(without_caches)}")


main()
