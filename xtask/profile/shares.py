#!/usr/bin/env python3
"""Self-time shares of a spectrace profile by part of the renderer (docs/perf.md).

    xtask/profile/shares.py perf.data   BINARY   # a `perf record` of BINARY
    xtask/profile/shares.py callgrind.out BINARY # `valgrind --tool=callgrind --dump-instr=yes` of it

Each sample (perf) or instruction (callgrind) is charged to the innermost frame of its inline
chain that lies in the workspace (`addr2line -i`), so inlined `SampledSpectrum` arithmetic counts
as spectral arithmetic even inside the path tracer's loop; a library function (libm, libc) is
charged to its first caller in the binary. Needs perf, addr2line and readelf (binutils).

perf 6.1 (Debian 12) cannot symbolise LLD-linked binaries (the text segment's file offset is not
its address), so addresses are symbolised here from the map-relative offsets `perf script`
prints, shifted by the segment's address - offset.
"""
import collections
import re
import subprocess
import sys

# Where a frame's source file puts it (path below crates/). First match wins.
CATEGORIES = [
    ("film", r"^geometry/src/camera\.rs"),  # camera rays belong to the pixel loop
    ("traversal", r"^geometry/"),  # BVH traversal, triangle and sphere tests, spawn offsets
    ("spectral", r"^materials/src/absorption\.rs"),  # Beer-Lambert's per-lane exp
    ("bsdf", r"^materials/"),  # shading: BSDFs, frames, warps
    ("film", r"^colorimetry/src/spectrum\.rs:.*(to_xyz|SampledWavelengths)"),
    ("spectral", r"^colorimetry/"),  # SampledSpectrum ops, spectrum interpolation, exp
    # (A module is a file or a folder: `lights.rs` or `lights/`, `path.rs` under `integrators/`.)
    ("lights", r"^integrator/src/lights(\.rs|/)"),
    ("lights", r"^integrator/src/sampling\.rs:.*(power_heuristic|triangle)"),
    ("rng", r"^integrator/src/sampling\.rs"),
    ("film", r"^integrator/src/(film|render|spectral)(\.rs|/)"),  # pixel loop, Lanes::xyz, film sums
    ("path loop", r"^integrator/src/(integrators/)?path\.rs"),  # the path tracer's own code
    ("whitted", r"^integrator/src/(integrators/)?whitted\.rs"),
]
COLUMNS = ["traversal", "bsdf", "lights", "spectral", "rng", "film", "path loop", "whitted", "other"]


def text_delta(binary):
    """Address minus file offset of the executable segment."""
    out = subprocess.run(["readelf", "-lW", binary], capture_output=True, text=True, check=True).stdout
    m = re.search(r"LOAD\s+0x([0-9a-f]+) 0x([0-9a-f]+) 0x[0-9a-f]+ 0x[0-9a-f]+ 0x[0-9a-f]+ R E", out)
    return int(m.group(2), 16) - int(m.group(1), 16), int(m.group(2), 16)


def inline_chains(binary, addrs):
    """addr -> [(function, file:line)], innermost first."""
    addrs = sorted(addrs)
    chains = {}
    for start in range(0, len(addrs), 20000):
        batch = addrs[start : start + 20000]
        out = subprocess.run(
            ["addr2line", "-f", "-i", "-C", "-a", "-e", binary] + [hex(a) for a in batch],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.splitlines()
        cur, i = None, 0
        while i < len(out):
            if out[i].startswith("0x"):
                cur = int(out[i], 16)
                chains[cur] = []
                i += 1
            else:
                chains[cur].append((out[i], out[i + 1] if i + 1 < len(out) else "?"))
                i += 2
    return chains


def categorise(chain):
    for fn, loc in chain:
        if "/crates/" not in loc:
            continue
        path = loc.split("/crates/", 1)[1].split(" (")[0]
        for name, pattern in CATEGORIES:
            if re.search(pattern, f"{path}:{fn}"):
                return name, fn, path
        return "other", fn, path
    return "other", chain[0][0] if chain else "?", chain[0][1].split("/")[-1] if chain else "?"


def perf_costs(data, binary):
    """[(cost, leaf symbol or None, [binary addresses from the leaf outwards])] from perf script."""
    delta, _ = text_delta(binary)
    name = binary.split("/")[-1]
    out = subprocess.run(["perf", "script", "-i", data, "-F", "ip,sym,dso"], capture_output=True, text=True).stdout
    samples, frames = [], []
    for line in out.splitlines() + [""]:
        s = line.strip()
        if not s:
            if frames:
                leaf = None if frames[0][2] else frames[0][1]
                samples.append((1, leaf, [a + delta for a, _, ours in frames if ours]))
            frames = []
            continue
        m = re.match(r"([0-9a-f]+)\s+(.*?)\s*\((.*)\)$", s)
        if not m:
            continue
        addr, sym, dso = int(m.group(1), 16), m.group(2), m.group(3)
        if dso == "inlined":
            # perf names a library's inlined frame before (or instead of) the real one.
            if sym != "[unknown]" and not any(f[0] == addr for f in frames):
                frames.append((addr, sym, False))
            continue
        if frames and frames[-1][0] == addr:
            # An inlined frame's line comes first, then the real frame at the same address: if
            # that is in our binary, so is the address (addr2line reads its whole inline chain).
            # Left as a library frame, the path loop inlined into `PixelSampler::sample` was
            # charged to the film in earlier profiles.
            if dso.endswith(name) and not frames[-1][2]:
                frames[-1] = (addr, frames[-1][1], True)
            continue
        frames.append((addr, sym, dso.endswith(name)))
    return samples


def callgrind_costs(path, binary):
    """[(Ir, function name if outside the binary, [address])] from a --dump-instr=yes output."""
    names, objects = {}, {}
    ob = fn = None
    addr, skip = 0, False
    ours, theirs = collections.Counter(), collections.Counter()
    for raw in open(path):
        raw = raw.rstrip("\n")
        m = re.match(r"(c?)(ob|fn)=\((\d+)\)(?: (.*))?", raw)
        if m:
            table = objects if m.group(2) == "ob" else names
            if m.group(4):
                table[m.group(3)] = m.group(4)
            if not m.group(1):
                if m.group(2) == "ob":
                    ob = table[m.group(3)]
                else:
                    fn = table[m.group(3)]
            continue
        if raw.startswith("calls="):
            skip = True  # the next cost line is the call's inclusive cost
            continue
        if raw and (raw[0].isdigit() or raw[0] in "+-*"):
            parts = raw.split()
            p = parts[0]
            if p[0] in "+-":
                addr += int(p, 16) if p[1:].startswith("0x") else int(p)
            elif p != "*":
                addr = int(p, 16)
            if skip:
                skip = False
                continue
            ir = int(parts[2]) if len(parts) > 2 else 0
            if ob and ob.endswith(binary.split("/")[-1]):
                ours[addr] += ir
            else:
                theirs[fn] += ir
    # The PIE's load base: the lowest executed address is in the text segment.
    _, text_start = text_delta(binary)
    base = (min(ours) - text_start) & ~0xFFF
    return [(ir, None, [a - base]) for a, ir in ours.items()] + [(ir, f, []) for f, ir in theirs.items()]


def main():
    source, binary = sys.argv[1], sys.argv[2]
    with open(source, "rb") as f:
        is_perf = f.read(8) == b"PERFILE2"
    costs = perf_costs(source, binary) if is_perf else callgrind_costs(source, binary)
    chains = inline_chains(binary, {a for _, _, addrs in costs for a in addrs})
    cats, funcs, libs = collections.Counter(), collections.Counter(), collections.Counter()
    total = sum(c for c, _, _ in costs)
    for cost, leaf, addrs in costs:
        if addrs:
            cat, fn, where = categorise(chains.get(addrs[0], []))
        else:
            cat, fn, where = "other", leaf or "?", "library"
        if leaf is not None:
            libs[leaf.split("+")[0]] += cost
            fn = f"{leaf.split('+')[0]} <- {fn}"
        cats[cat] += cost
        funcs[(cat, fn, where.split(":")[0])] += cost
    unit = "samples" if is_perf else "instructions"
    print(f"{total:,} {unit}")
    print("| " + " | ".join(COLUMNS) + " |")
    print("| " + " | ".join(f"{100 * cats[c] / total:.1f}" for c in COLUMNS) + " |")
    print("top functions (innermost workspace frame; self share):")
    for (cat, fn, where), n in funcs.most_common(15):
        print(f"  {100 * n / total:5.1f}%  {cat:10s} {fn[:70]}  ({where})")
    print("library functions (charged to their callers above):")
    for fn, n in libs.most_common(6):
        print(f"  {100 * n / total:5.1f}%  {fn}")


if __name__ == "__main__":
    main()
