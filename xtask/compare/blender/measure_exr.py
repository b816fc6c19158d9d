# Mean Y = 0.2126 R + 0.7152 G + 0.0722 B over the test scene's two regions of any 200x150 EXR.
# Run: blender -b --factory-startup --python measure_exr.py -- FILE.exr [FILE.exr ...]
import sys
import bpy

REGIONS = {"emissive face (5x5 at col 143,row 72)": (143, 72, 2), "floor under lamp (3x3 at col 57,row 86)": (57, 86, 1)}
for path in sys.argv[sys.argv.index("--") + 1:]:
    img = bpy.data.images.load(path)
    w, h = img.size
    px = img.pixels[:]
    out = {}
    for name, (col, row, half) in REGIONS.items():
        ys = []
        for r in range(row - half, row + half + 1):
            for c in range(col - half, col + half + 1):
                i = 4 * ((h - 1 - r) * w + c)
                ys.append(0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2])
        out[name] = sum(ys) / len(ys)
    vals = list(out.values())
    print(f"MEASURE {path} ({w}x{h}): " + "; ".join(f"{k} Y {v:.5g}" for k, v in out.items()) + f"; ratio {vals[0]/vals[1]:.5g}")
