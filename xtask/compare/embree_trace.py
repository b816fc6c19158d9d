#!/usr/bin/env python3
"""Trace one exported ray set with Embree 4 (robust mode, `rtcIntersect1` per ray through
embreex), PASSES times: the Embree side of an instruction count, like
`crates/geometry/examples/trace_exported.rs` for ours. An optional comparison tool: it needs
`pip install embreex numpy`, which the project does not.

    PY=$(python3 -c 'import sys; print(sys.executable)')
    valgrind --tool=callgrind $PY xtask/compare/embree_trace.py DIR terrain_2k primary 1
    valgrind --tool=callgrind $PY xtask/compare/embree_trace.py DIR terrain_2k primary 3

(valgrind needs the interpreter itself, not a pyenv shim.) Half the difference of the two
totals, over the ray count, is one pass's instructions per ray, embreex's Cython loop and its
per-ray copies included. With --miss the scene is one far-away triangle the rays all miss:
that loop plus Embree's fixed cost per query. With --any the queries are `rtcOccluded1`, as
`trace_exported --any` runs `Scene::occluded`. valgrind reports no AVX-512, so Embree runs its
AVX2 kernels there, as ours do.
"""

import argparse

import embreex.mesh_construction as mc
import embreex.rtcore_scene as rs
import numpy as np

from embree_bvh import MISS_TRIANGLE, load_rays


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("scene")
    ap.add_argument("kind", choices=["primary", "incoherent"])
    ap.add_argument("passes", type=int)
    ap.add_argument("--miss", action="store_true")
    ap.add_argument("--any", action="store_true")
    args = ap.parse_args()
    if args.miss:
        tris = MISS_TRIANGLE
    else:
        tris = np.fromfile(f"{args.dir}/{args.scene}.tris", dtype="<f4").reshape(-1, 3, 3)
    o, d = load_rays(f"{args.dir}/{args.scene}_{args.kind}.rays")
    scene = rs.EmbreeScene(robust=True)
    mc.TriangleMesh(scene, tris)
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))  # commit (build)
    hits = 0
    query = "OCCLUDED" if args.any else "INTERSECT"
    for _ in range(args.passes):
        hits += int((scene.run(o, d, query=query) != -1).sum())
    print(f"{len(o)} rays x {args.passes} passes: {hits} hits")


if __name__ == "__main__":
    main()
