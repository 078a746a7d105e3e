#!/usr/bin/env python3
"""The curvature method's clamp [s_min, s_max] judged over many models (docs/design.md, "Clamps").

For every closed model that loads, every ratio and every clamp, generates the guarded curvature
shell and the unguarded one (allow_invalid) and prints, per clamp, against the first clamp given:
the mean fraction of top vertices thinned below 0.9 eta per row and the rows where it is lower /
higher, the stretch against the clamp's own prisms relative to the first clamp's (median, max),
the unguarded inverted tets summed, the guarded rows certified valid and the guarded seconds summed.
--rigid adds the rigid method as a row of the same table (its own-prism column is empty).

    PYTHONPATH=build/python /usr/bin/python3 bench/curvature_clamp.py \\
        --clamp 0.5,2 --clamp 0.333,3 --clamp 0.667,1.5 --rigid models/*.off

--tsv FILE keeps every run's figures (one line per model, ratio, clamp, guarded or not).
"""
import argparse
import statistics
import sys
import time

import gshell
import numpy as np


def closed(F):
    """No boundary edge: every undirected edge is shared by two faces."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return bool((counts == 2).all())


def run(V, F, ratio, clamp, guarded):
    kw = dict(thickness_ratio=ratio, allow_invalid=not guarded)
    if clamp is None:
        kw["method"] = "rigid"
    else:
        kw.update(method="curvature", s_min=clamp[0], s_max=clamp[1])
    start = time.time()
    report = gshell.generate(V, F, **kw).report
    own = report.get("curvature", {}).get("own_prisms", {}).get("stretch", {}).get("volume_mean")
    return {
        "valid": bool(report["valid"]),
        "inverted": report["certificate"]["inverted_tets"],
        "thinned": report["thinned_vertices"] / report["vertices"],
        "own": own,
        "seconds": time.time() - start,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+")
    ap.add_argument("--clamp", action="append", default=[], help="S_MIN,S_MAX (repeatable; the first is the reference)")
    ap.add_argument("--ratio", action="append", type=float, default=[], help="thickness ratio (default 0.01 0.03 0.05)")
    ap.add_argument("--rigid", action="store_true", help="also the rigid method")
    ap.add_argument("--tsv", help="write every run's figures here")
    a = ap.parse_args()
    clamps = [tuple(float(x) for x in c.split(",")) for c in a.clamp] or [(0.5, 2.0)]
    configs = [(f"{c[0]:g},{c[1]:g}", c) for c in clamps] + ([("rigid", None)] if a.rigid else [])
    ratios = a.ratio or [0.01, 0.03, 0.05]
    rows = {}  # (model, ratio) -> {config name: (guarded, unguarded)}
    tsv = open(a.tsv, "w") if a.tsv else None
    if tsv:
        tsv.write("model\tratio\tconfig\tguarded\tvalid\tinverted\tthinned_fraction\town_stretch\tseconds\n")
    for path in a.models:
        try:
            V, F = gshell.read_mesh(path)
        except Exception as e:  # the reader's one-line message names the file
            print(f"skipped: {e}", file=sys.stderr)
            continue
        if not closed(np.asarray(F)):
            print(f"skipped: {path}: has a boundary", file=sys.stderr)
            continue
        for ratio in ratios:
            try:
                rows[(path, ratio)] = {name: (run(V, F, ratio, c, True), run(V, F, ratio, c, False)) for name, c in configs}
            except Exception as e:
                print(f"skipped: {path} at {ratio}: {e}", file=sys.stderr)
                continue
            if tsv:
                for name, pair in rows[(path, ratio)].items():
                    for guarded, r in zip((1, 0), pair):
                        tsv.write(f"{path}\t{ratio}\t{name}\t{guarded}\t{int(r['valid'])}\t{r['inverted']}\t"
                                  f"{r['thinned']:.6g}\t{r['own']}\t{r['seconds']:.3f}\n")
                tsv.flush()
    reference = configs[0][0]
    print(f"{len(rows)} rows (closed models x ratios {', '.join(f'{r:g}' for r in ratios)}); reference clamp {reference}")
    print("config        thinned/row  fewer  more   own/ref med    max   unguarded inverted  guarded valid  guarded s")
    for name, _ in configs:
        thin = [rows[k][name][0]["thinned"] for k in rows]
        ref = [rows[k][reference][0]["thinned"] for k in rows]
        fewer = sum(t < r - 1e-12 for t, r in zip(thin, ref))
        more = sum(t > r + 1e-12 for t, r in zip(thin, ref))
        own = [rows[k][name][0]["own"] / rows[k][reference][0]["own"] for k in rows
               if rows[k][name][0]["own"] and rows[k][reference][0]["own"]]
        own_text = f"{statistics.median(own):10.3f} {max(own):6.3f}" if own else f"{'-':>10s} {'-':>6s}"
        inverted = sum(rows[k][name][1]["inverted"] for k in rows)
        valid = sum(rows[k][name][0]["valid"] for k in rows)
        seconds = sum(rows[k][name][0]["seconds"] for k in rows)
        print(f"{name:12s} {statistics.mean(thin):11.3f} {fewer:6d} {more:5d} {own_text} {inverted:19d} {valid:14d} {seconds:10.1f}")


if __name__ == "__main__":
    main()
