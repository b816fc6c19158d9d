#!/usr/bin/env python3
"""Trace the geometry benchmark's rays with Embree (robust and default scene flags) and
compare throughput with spectrace's criterion results.

An optional comparison tool: the project does not need it. It needs `pip install embreex
numpy` (Embree 4 with its own runtime ISA dispatch; `rtcIntersect1`/`rtcOccluded1` per ray).

    SPECTRACE_EXPORT_RAYS=target/rays taskset -c 1 cargo bench -p geometry --bench bvh -- \
        --warm-up-time 1 --measurement-time 3
    taskset -c 1 python3 xtask/compare/embree_bvh.py --rays target/rays --criterion target/criterion

The benchmark writes each scene's triangles, its primary and incoherent rays and our hit
counts; this script builds the same triangles in Embree, traces the same rays on one thread
(pin it with taskset, like the benchmark) and reports the median of `--rounds` rounds, in
thread CPU time like `traversal_table`.

embreex loops over the rays in Cython and copies each result to numpy, which costs time
Embree's own benchmarks do not pay. That per-ray overhead is measured on the same number of
rays against a one-triangle scene the rays all miss at the root, and reported; "net" figures
subtract it (favouring Embree), "gross" figures do not.

The "net" figures favour Embree by far more than the loop: a root-miss query is also Embree's
own fixed cost per query (about 22 ns of one here, `docs/perf.md`), which the
subtraction removes too. `embree_direct.c` calls the same library from C in a plain loop and
measures Embree as it runs; `trace_ab.py` alternates it with ours on the same rays. Its rates
fall between this script's two (closer to "gross"), and they are the ones to compare with.
"""

import argparse
import json
import statistics
import time
from pathlib import Path

import embreex.mesh_construction as mc
import embreex.rtcore_scene as rs
import numpy as np

KINDS = [("primary", "INTERSECT", "primary_closest_hit"),
         ("incoherent", "INTERSECT", "incoherent_closest_hit"),
         ("incoherent", "OCCLUDED", "incoherent_any_hit")]


# A scene whose one triangle every exported ray misses at the root: embreex's per-ray overhead.
MISS_TRIANGLE = np.array([[[1e6, 1e6, 1e6], [1e6 + 1, 1e6, 1e6], [1e6, 1e6 + 1, 1e6]]], np.float32)


def load_rays(path):
    r = np.fromfile(path, dtype="<f4").reshape(-1, 6)
    return np.ascontiguousarray(r[:, :3]), np.ascontiguousarray(r[:, 3:])


def timed(scene, o, d, query, rounds):
    times, hits = [], None
    for _ in range(rounds):
        t = time.thread_time()
        res = scene.run(o, d, query=query)
        times.append(time.thread_time() - t)
        hits = int((res != -1).sum())
    return statistics.median(times), hits


def ours(criterion, scene, level, bench):
    """Median time per iteration (s) of one of our criterion benchmarks, if present."""
    if criterion is None:
        return None
    p = Path(criterion) / scene / level / bench / "new" / "estimates.json"
    if not p.exists():
        return None
    return json.loads(p.read_text())["median"]["point_estimate"] * 1e-9


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rays", required=True, help="directory written by SPECTRACE_EXPORT_RAYS")
    ap.add_argument("--criterion", help="target/criterion of the same benchmark run")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--levels", default="sse2,avx2,avx512")
    args = ap.parse_args()
    rays_dir = Path(args.rays)
    levels = args.levels.split(",")
    header = "| scene | rays | Embree robust (net / gross) | Embree default (net) | " + \
        " | ".join(f"ours {l}" for l in levels) + " | " + " | ".join(f"{l} / robust net" for l in levels) + " |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for tris_path in sorted(rays_dir.glob("*.tris")):
        name = tris_path.stem
        tris = np.fromfile(tris_path, dtype="<f4").reshape(-1, 3, 3)
        ours_hits = json.loads((rays_dir / f"{name}.hits.json").read_text())
        scenes = {}
        for flag in ["robust", "default"]:
            s = rs.EmbreeScene(robust=(flag == "robust"))
            mc.TriangleMesh(s, tris)
            t = time.thread_time()
            s.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))  # commit (build)
            scenes[flag] = (s, time.thread_time() - t)
        empty = rs.EmbreeScene(robust=True)
        mc.TriangleMesh(empty, MISS_TRIANGLE)
        for kind, query, bench in KINDS:
            o, d = load_rays(rays_dir / f"{name}_{kind}.rays")
            n = len(o)
            overhead, _ = timed(empty, o, d, query, args.rounds)
            t_rob, h_rob = timed(scenes["robust"][0], o, d, query, args.rounds)
            t_def, h_def = timed(scenes["default"][0], o, d, query, args.rounds)
            key = {"primary_closest_hit": "primary", "incoherent_closest_hit": "incoherent",
                   "incoherent_any_hit": "incoherent_any"}[bench]
            net_rob, net_def = max(t_rob - overhead, 1e-9), max(t_def - overhead, 1e-9)
            cells = [f"{n / net_rob / 1e6:.2f} / {n / t_rob / 1e6:.2f} M/s", f"{n / net_def / 1e6:.2f}"]
            mine = [ours(args.criterion, name, l, bench) for l in levels]
            cells += [f"{n / m / 1e6:.2f}" if m else "—" for m in mine]
            cells += [f"{net_rob / m:.2f}" if m else "—" for m in mine]
            print(f"| {name} | {bench} | " + " | ".join(cells) + " |")
            print(f"    hits: ours {ours_hits[key]}, Embree robust {h_rob}, default {h_def}; "
                  f"embreex overhead {overhead / n * 1e9:.0f} ns/ray", flush=True)
        print(f"    Embree build (commit) robust {scenes['robust'][1]:.2f} s, default {scenes['default'][1]:.2f} s")


if __name__ == "__main__":
    main()
