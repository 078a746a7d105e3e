#!/usr/bin/python3
"""Generate a shell over a built-in mesh, then bend its base over a few frames and let the top
follow (base-driven deformation), carrying a detail mesh embedded in the shell along.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/generate_and_deform.py [-o DIR] [--quick]

Writes DIR/base.obj, DIR/top.obj (the generated shell), DIR/frame_K_base.obj, DIR/frame_K_top.obj,
DIR/frame_K_detail.obj for every frame, and prints the stretch of each frame.
"""
import argparse
import math
import os

import numpy as np

import gshell


def bend(V, angle):
    """Bends the mesh around the y axis: x stays the arc length on a circle of radius 1/curvature."""
    if angle == 0:
        return V.copy()
    span = V[:, 0].max() - V[:, 0].min()
    radius = span / angle  # the whole x range turns by `angle`
    theta = V[:, 0] / radius
    out = V.copy()
    out[:, 0] = (radius + V[:, 2]) * np.sin(theta)
    out[:, 2] = (radius + V[:, 2]) * np.cos(theta) - radius
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-o", "--output", default="gshell_python_example", help="output folder")
    parser.add_argument("--quick", action="store_true", help="small mesh, few frames (for tests)")
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)

    V, F = gshell.builtin("torus:24" if args.quick else "torus:96")
    shell = gshell.generate(V, F, thickness_ratio=0.05)
    r = shell.report
    print(f"generated: {len(V)} vertices, {len(shell.tets)} tets, eta {shell.thickness:.4g}, "
          f"{r['iterations']} iterations, stretch mean {r['stretch']['volume_mean']:.3g} "
          f"max {r['stretch']['max']:.3g}, valid {r['valid']} "
          f"({r['certificate']['inverted_tets']} inverted tets, "
          f"{r['certificate']['top_self_intersections']} top self-intersections)")
    gshell.write_mesh(os.path.join(args.output, "base.obj"), shell.base, shell.faces)
    gshell.write_mesh(os.path.join(args.output, "top.obj"), shell.top, shell.faces)

    # Detail inside the shell: a small sphere of "bumps" half-way between base and top.
    ball_V, ball_F = gshell.builtin("sphere:1")
    midway = 0.5 * (shell.base + shell.top)
    centres = midway[:: max(1, len(V) // 12)]
    detail_V = np.vstack([c + 0.4 * shell.thickness * ball_V for c in centres])
    detail_F = np.vstack([ball_F + k * len(ball_V) for k in range(len(centres))])
    embedding = gshell.embed(shell, detail_V)
    print(f"embedded {len(embedding)} detail points, {len(embedding.outside)} outside the shell")

    deformer = gshell.Deformer(shell)
    frames = 3 if args.quick else 8
    for k in range(1, frames + 1):
        base = bend(shell.base, 0.5 * math.pi * k / frames)
        top = deformer.solve(base)  # GIL released: other Python threads keep running
        info = deformer.last
        detail = embedding.carry(deformer.vertices)
        name = os.path.join(args.output, f"frame_{k}")
        gshell.write_mesh(name + "_base.obj", base, shell.faces)
        gshell.write_mesh(name + "_top.obj", top, shell.faces)
        gshell.write_mesh(name + "_detail.obj", detail, detail_F)
        quality = gshell.metrics(base, shell.faces, top, shell.thickness, count_intersections=False)
        print(f"frame {k}: {info['iterations']} iterations, {1e3 * info['seconds']:.1f} ms, stretch vs rest "
              f"mean {info['stretch']['volume_mean']:.3g} max {info['stretch']['max']:.3g}, "
              f"{info['inverted_tets']} inverted; thickness min {quality['thickness']['min']:.3f} eta")
        if info["inverted_tets"] != 0:
            raise SystemExit("an inverted tet: the deformation failed")
    print(f"wrote {args.output}/")


if __name__ == "__main__":
    main()
