#!/usr/bin/env python3
"""Load and build time of spectrace against Embree 4's BVH build on the same triangles: one
command for `docs/perf.md`'s "Loading and building" table.

An optional comparison tool: the project does not need it. It needs `pip install embreex numpy`
(Embree 4 as a library, its own threads) and GNU time (`/usr/bin/time`).

    python3 xtask/compare/terrain_obj.py 894 /tmp/terrain_1m6.obj
    python3 xtask/compare/embree_build.py --runs 5 target/release/spectrace /tmp/terrain_1m6.obj \\
        ../shared/real_assets/alec/nefertiti.obj
    python3 xtask/compare/embree_build.py --runs 5 OLD_BINARY NEW_BINARY FILES...   # before/after

For each file and run, each binary's `spectrace info FILE` (whole process: parse, removal of
unhittable triangles, assembly, BVH build, summary) is timed by wall clock with its peak
resident memory (`/usr/bin/time`), and its `bvh.build_ms` read; then Embree builds the file's
triangles (an `.obj` of `v`/`f` lines, read here with numpy): `rtcCommitScene` through embreex
(robust flag, its default build quality and thread count), by wall clock. Binaries and Embree
alternate run by run, so that a machine shared with other jobs slows all of them alike; the
table gives medians and the ratios of medians. Files that are not `.obj` are timed for our side
only.
"""

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def read_obj(path):
    """Positions (n, 3) float32 and triangles (m, 3) int32 of an OBJ's `v` and `f` lines (polygons
    as fans, `v/vt/vn` corners by their position index, negative indices resolved)."""
    vertices, faces = [], []
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"v "):
                vertices.append(line[2:])
            elif line.startswith(b"f "):
                faces.append(line[2:])
    positions = np.array(b" ".join(vertices).split(), np.float32).reshape(-1, 4 if len(vertices[0].split()) == 4 else 3)[:, :3]
    simple = all(b"/" not in fc for fc in faces[:1000]) and all(len(fc.split()) == 3 for fc in faces[:1000])
    if simple:
        try:
            tris = np.array(b" ".join(faces).split(), np.int64).reshape(-1, 3)
        except ValueError:
            simple = False
    if not simple:
        out = []
        for fc in faces:
            idx = [int(w.split(b"/")[0]) for w in fc.split()]
            idx = [i if i > 0 else len(positions) + i + 1 for i in idx]
            out.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
        tris = np.array(out, np.int64)
    return np.ascontiguousarray(positions), np.ascontiguousarray(tris - 1, np.int32)


def embree_build(positions, tris):
    import embreex.mesh_construction as mc
    import embreex.rtcore_scene as rs

    scene = rs.EmbreeScene(robust=True)
    mc.TriangleMesh(scene, positions, tris)
    start = time.perf_counter()
    # The first query commits the scene (rtcCommitScene: the build).
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
    return time.perf_counter() - start


def ours(binary, path):
    """(wall s, peak RSS bytes, build ms, triangles) of `binary info path`."""
    start = time.perf_counter()
    run = subprocess.run(["/usr/bin/time", "-f", "%M", binary, "info", str(path)], capture_output=True, text=True)
    wall = time.perf_counter() - start
    if run.returncode != 0:
        sys.exit(f"{binary} info {path}: {run.stderr}")
    rss = int(run.stderr.strip().splitlines()[-1]) * 1024
    info = json.loads(run.stdout)
    triangles = info.get("triangles") or info.get("geometry", {}).get("triangles")
    return wall, rss, info["bvh"]["build_ms"], triangles


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("binaries_and_files", nargs="+", help="one or more spectrace binaries, then scene files")
    args = ap.parse_args()
    binaries = [a for a in args.binaries_and_files if Path(a).is_file() and not Path(a).suffix]
    files = [Path(a) for a in args.binaries_and_files if a not in binaries]
    if not binaries or not files:
        sys.exit("give at least one spectrace binary (a file without extension) and one scene file")
    print("| file | triangles | binary | info wall s | bvh.build_ms | Embree build ms | build / Embree | peak RSS MB | bytes / triangle |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in files:
        mesh = read_obj(path) if path.suffix.lower() == ".obj" else None
        results = {b: [] for b in binaries}
        embree = []
        for _ in range(args.runs):
            for b in binaries:
                results[b].append(ours(b, path))
            if mesh is not None:
                embree.append(embree_build(*mesh))
        embree_ms = statistics.median(embree) * 1e3 if embree else None
        for b in binaries:
            walls, rss, build, _ = zip(*results[b])
            triangles = len(mesh[1]) if mesh is not None else None
            wall, peak, build_ms = statistics.median(walls), statistics.median(rss), statistics.median(build)
            ratio = f"{build_ms / embree_ms:.2f}" if embree_ms else "–"
            per_tri = f"{peak / triangles:.0f}" if triangles else "–"
            print(f"| {path.name} | {triangles or '–'} | {b} | {wall:.3f} ({min(walls):.3f}–{max(walls):.3f}) | "
                  f"{build_ms:.0f} ({min(build):.0f}–{max(build):.0f}) | "
                  f"{f'{embree_ms:.0f} ({min(embree) * 1e3:.0f}–{max(embree) * 1e3:.0f})' if embree_ms else '–'} | "
                  f"{ratio} | {peak / 2**20:.0f} | {per_tri} |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
