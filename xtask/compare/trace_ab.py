#!/usr/bin/env python3
"""Alternate several tracers on the same exported rays, one core, and report each one's median
rate and its median ratio to the first: the A/B of two builds of
`crates/geometry/examples/trace_exported.rs`, or ours against Embree (`embree_direct.c`).

    python3 xtask/compare/trace_ab.py --rays /tmp/rays --rounds 3 --passes 8 \\
        ours=target/release/examples/trace_exported \\
        embree_avx2="env EMBREE_CONFIG=max_isa=avx2 /tmp/embree_direct" \\
        embree=/tmp/embree_direct \\
        -- terrain_2k terrain_100k

Each tracer is `LABEL=COMMAND` (split like a shell line); every one is run as
`taskset -c 1 COMMAND DIR SCENE primary|incoherent PASSES [--any]` and must print
"... R M/s over P passes; H hits", as both tracers do. In every round, for every scene and
kind (primary, incoherent, incoherent any-hit), the tracers run one after another, in reverse
order every other round, so that a drift of the shared machine falls on all alike. A ratio is
the median over rounds of the round's rate over the first tracer's in that round; the range
follows in brackets. Differing hit counts are flagged. An optional tool outside the project.
"""

import argparse
import re
import shlex
import statistics
import subprocess
import sys

KINDS = [["primary"], ["incoherent"], ["incoherent", "--any"]]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rays", required=True)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--passes", type=int, default=8)
    ap.add_argument("--core", default="1")
    ap.add_argument("tracers", nargs="+", help="LABEL=COMMAND ...")
    # (argparse drops a bare `--`, so the scenes are split off first.)
    if "--" not in sys.argv:
        sys.exit("error: give the scenes after --")
    split = sys.argv.index("--")
    args = ap.parse_args(sys.argv[1:split])
    tracers = [t.split("=", 1) for t in args.tracers]
    scenes = sys.argv[split + 1:]
    if not tracers or any(len(t) != 2 for t in tracers) or not scenes:
        sys.exit("error: expected LABEL=COMMAND ... -- SCENE ...")
    res = {}
    for r in range(args.rounds):
        for scene in scenes:
            for kind in KINDS:
                for label, command in (tracers if r % 2 == 0 else tracers[::-1]):
                    cmd = ["taskset", "-c", args.core] + shlex.split(command) + \
                        [args.rays, scene, kind[0], str(args.passes)] + kind[1:]
                    out = subprocess.run(cmd, capture_output=True, text=True)
                    m = re.search(r"([\d.]+) M/s over \d+ passes; (\d+) hits", out.stdout)
                    if not m:
                        sys.exit(f"error: {label} printed no rate: {out.stdout}{out.stderr}")
                    res.setdefault((scene, " ".join(kind), label), []).append((float(m.group(1)), int(m.group(2))))
    for scene in scenes:
        for kind in KINDS:
            key = " ".join(kind)
            base = res[(scene, key, tracers[0][0])]
            line = f"{scene:15s} {key:17s} {tracers[0][0]} {statistics.median(x for x, _ in base):.3f}"
            for label, _ in tracers[1:]:
                other = res[(scene, key, label)]
                ratios = [b[0] / a[0] for a, b in zip(base, other)]
                same = "" if other[0][1] == base[0][1] else f" HITS DIFFER {other[0][1]} vs {base[0][1]}"
                line += (f" | {label} {statistics.median(x for x, _ in other):.3f}"
                         f" ratio {statistics.median(ratios):.3f} [{min(ratios):.3f}-{max(ratios):.3f}]{same}")
            print(line, flush=True)


if __name__ == "__main__":
    main()
