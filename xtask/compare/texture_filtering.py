"""What texture prefiltering (mip-maps, ray differentials) could gain, measured before adding it: the
error at equal samples of a point-sampled (bilinear) texture against that of its ideal prefilter
where the texture is minified everywhere, which is where a mip-map helps most.

The scene: a 400 × 400 floor (an OBJ quad, Lambertian, `map_Kd -s 4000 4000` of a 2 × 2 checker of sRGB 230
and 40) seen straight down from 100 units (vfov 40°, 320 × 240): about 9 texels per pixel, so the
point-sampled texture is noise within each pixel. Its ideal prefilter there is the texture's mean colour: the
same floor with `Kd` = the mean of the decoded texels (the bias of that stand-in against the converged
textured image is printed). Three lightings: `sun-only` (one directional light and nothing else: no
light-transport noise at all, so the texture is the only noise: the most a prefilter can win), `sun` (the
same with a uniform environment: the light each sample picks is now random) and `lamp` (a small spherical
lamp above the floor with a box on it: soft shadows and their noise, as in most scenes). Each render is scored against its own
2048-spp reference; relMSE = mean((x − ref)² / (ref² + 0.01)) over pixels and channels.

    python3 xtask/compare/texture_filtering.py SPECTRACE_BINARY [OUT_DIR]

Prints, per lighting and spp, relMSE point-sampled, relMSE prefiltered and their ratio (the factor in time
to equal error a perfect, free prefilter would give). Needs numpy, Pillow and OpenEXR (outside the
project's dependencies, like the Mitsuba scripts).
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

SPPS = [1, 4, 16, 64]
REFERENCE_SPP = 2048
TEXELS = (230, 40)


def srgb_decode(v):
    v = v / 255.0
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4


def write_scene(out, lighting, textured):
    out.mkdir(parents=True, exist_ok=True)
    a, b = TEXELS
    Image.fromarray(np.array([[a, b], [b, a]], dtype=np.uint8)).convert("RGB").save(out / "checker.png")
    mean = 0.5 * (srgb_decode(a) + srgb_decode(b))
    kd = f"map_Kd -s 4000 4000 checker.png" if textured else f"Kd {mean} {mean} {mean}"
    (out / "floor.mtl").write_text(f"newmtl floor\n{kd}\n")
    (out / "floor.obj").write_text(
        "mtllib floor.mtl\nusemtl floor\n"
        "v -200 0 -200\nv 200 0 -200\nv 200 0 200\nv -200 0 200\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 1 0\n"
        "f 1/1/1 4/4/1 3/3/1\nf 1/1/1 3/3/1 2/2/1\n"
    )
    camera = '"camera": {"position": [0, 100, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "vfov_deg": 40}'
    sun = '"lights": [{"type": "directional", "direction": [-0.3, -1, -0.2], "spectrum": "D65", "intensity": 3, "unit": "lux"}]'
    if lighting == "sun":
        lights = sun + ', "background": {"spectrum": "D65", "intensity": 0.2}'
        extra = ""
    elif lighting == "sun-only":
        lights, extra = sun, ""
    else:
        lights = '"lights": []'
        extra = (
            ', {"type": "sphere", "center": [10, 40, 5], "radius": 2, "material": "lamp"}'
            ', {"type": "mesh", "file": "box.obj", "material": "grey"}'
        )
        (out / "box.obj").write_text(box_obj(-10, 0, -8, 12, 15, 10))
    (out / "scene.json").write_text(
        f'{{{camera}, {lights},'
        '"materials": {"lamp": {"base_color": 0, "emission": "D65", "emission_strength": 30},'
        '              "grey": {"base_color": 0.5, "diffuse": 1, "ks": 0}},'
        f'"objects": [{{"type": "mesh", "file": "floor.obj"}}{extra}]}}'
    )
    return out / "scene.json", mean


def box_obj(x, y, z, sx, sy, sz):
    v = [(x + dx * sx, y + dy * sy, z + dz * sz) for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)]
    faces = [(1, 3, 7, 5), (2, 6, 8, 4), (1, 5, 6, 2), (3, 4, 8, 7), (1, 2, 4, 3), (5, 7, 8, 6)]
    text = "".join(f"v {a} {b} {c}\n" for a, b, c in v)
    for f in faces:
        text += f"f {f[0]} {f[1]} {f[2]}\nf {f[0]} {f[2]} {f[3]}\n"
    return text


def render(binary, scene, spp, seed, out):
    subprocess.run(
        [binary, "render", str(scene), "-q", "--integrator", "path", "--spp", str(spp), "--seed", str(seed),
         "--width", "320", "--height", "240", "--exposure", "0", "-o", str(out)],
        check=True,
    )
    exr = OpenEXR.File(str(out))
    channels = exr.parts[0].channels
    if "RGB" in channels:
        return np.asarray(channels["RGB"].pixels, dtype=np.float64)
    return np.stack([np.asarray(channels[c].pixels, dtype=np.float64) for c in "RGB"], axis=-1)


def rel_mse(x, ref):
    return float(np.mean((x - ref) ** 2 / (ref**2 + 0.01)))


def main():
    binary = sys.argv[1]
    root = Path(sys.argv[2] if len(sys.argv) > 2 else "target/texture-filtering")
    for lighting in ["sun-only", "sun", "lamp"]:
        scenes = {t: write_scene(root / lighting / ("textured" if t else "mean"), lighting, t)[0] for t in (True, False)}
        refs = {t: render(binary, scenes[t], REFERENCE_SPP, 7, scenes[t].parent / "ref.exr") for t in (True, False)}
        print(f"{lighting}: stand-in bias, relMSE(mean-colour reference, textured reference) = {rel_mse(refs[False], refs[True]):.2e}")
        print(f"{lighting}: spp  relMSE point-sampled  relMSE prefiltered  ratio")
        for spp in SPPS:
            errors = {}
            for t in (True, False):
                runs = [render(binary, scenes[t], spp, seed, scenes[t].parent / f"s{spp}-{seed}.exr") for seed in (1, 2, 3)]
                errors[t] = np.mean([rel_mse(r, refs[t]) for r in runs])
            print(f"{lighting}: {spp:4d}  {errors[True]:.3e}  {errors[False]:.3e}  {errors[True] / errors[False]:.1f}")


if __name__ == "__main__":
    main()
