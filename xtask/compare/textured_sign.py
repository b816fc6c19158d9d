"""Light choice over an emissive texture's triangles: relative MSE at equal samples of two spectrace
binaries on a sign whose few lit texels lie among dark ones (docs/perf.md, "Textured emitters").

The scene: a 4 × 4 sign at z = 2 made of 16 × 16 quads, each at the centre of one texel of a 16 × 16
emissive texture (`map_Ke`, `Ke 4`) with 4 white texels and the rest black, over a 12 × 12 white
diffuse floor. Each binary renders it at 320 × 240 with the path tracer, 16 spp, seeds 1–3; the
reference is the second binary at 2048 spp. relMSE = mean((x − ref)² / (ref² + 0.01)) over pixels and
channels.

    python3 xtask/compare/textured_sign.py OLD_BINARY NEW_BINARY [OUT_DIR]

Needs numpy, Pillow and OpenEXR (outside the project's dependencies, like the Mitsuba scripts).
"""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

N = 16
LIT = [(2, 3), (12, 5), (7, 11), (14, 14)]


def write_scene(out):
    out.mkdir(parents=True, exist_ok=True)
    img = Image.new("RGBA", (N, N), (0, 0, 0, 255))
    for x, y in LIT:
        img.putpixel((x, y), (255, 255, 255, 255))
    img.save(out / "sign.png")
    (out / "sign.mtl").write_text("newmtl sign\nKd 0 0 0\nKe 4 4 4\nmap_Ke sign.png\n")
    lines, faces, v = ["mtllib sign.mtl", "usemtl sign"], [], 1
    for j in range(N):
        for i in range(N):
            x0, x1, y0, y1 = -2 + 4 * i / N, -2 + 4 * (i + 1) / N, -2 + 4 * j / N, -2 + 4 * (j + 1) / N
            lines += [f"v {x} {y} 2" for x, y in [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]]
            lines.append(f"vt {(i + 0.5) / N} {1 - (j + 0.5) / N}")
            t = j * N + i + 1
            faces += [f"f {v}/{t} {v + 2}/{t} {v + 1}/{t}", f"f {v}/{t} {v + 3}/{t} {v + 2}/{t}"]
            v += 4
    (out / "sign.obj").write_text("\n".join(lines + faces) + "\n")
    (out / "floor.obj").write_text("v -6 -6 0\nv 6 -6 0\nv 6 6 0\nv -6 6 0\nf 1 2 3\nf 1 3 4\n")
    scene = {
        "camera": {"position": [0, -7, 4], "look_at": [0, 0, 0.5], "up": [0, 0, 1], "vfov_deg": 50},
        "materials": {"white": {"base_color": 0.8, "diffuse": 1, "ks": 0}},
        "objects": [{"type": "mesh", "file": "sign.obj"}, {"type": "mesh", "file": "floor.obj", "material": "white"}],
    }
    (out / "sign.json").write_text(json.dumps(scene))


def render(binary, out, name, spp, seed):
    exr = out / f"{name}.exr"
    args = [binary, "render", str(out / "sign.json"), "-q", "--integrator", "path", "--spp", str(spp)]
    args += ["--width", "320", "--height", "240", "--seed", str(seed), "-o", str(exr)]
    start = time.perf_counter()
    subprocess.run(args, check=True)
    return exr, time.perf_counter() - start


def read(path):
    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels, dtype=np.float64)
        return np.stack([np.asarray(ch[k].pixels, dtype=np.float64) for k in "RGB"], -1)


def main():
    old, new = sys.argv[1], sys.argv[2]
    out = Path(sys.argv[3] if len(sys.argv) > 3 else "target/textured-sign")
    write_scene(out)
    ref = read(render(new, out, "ref", 2048, 0)[0])
    for seed in (1, 2, 3):
        for label, binary in (("old", old), ("new", new)):
            exr, seconds = render(binary, out, f"{label}{seed}", 16, seed)
            rel = float(((read(exr) - ref) ** 2 / (ref**2 + 1e-2)).mean())
            print(f"seed {seed} {label}: relMSE {rel:.3e}, {seconds:.2f} s")


if __name__ == "__main__":
    main()
