#!/usr/bin/env python3
"""Writes metal_rough_grid.gltf: the Khronos-style metal/roughness sphere grid (issue 11).

Five rows of metallic (0, 0.25, 0.5, 0.75, 1; bottom to top) by five columns of roughness
(0.1, 0.3, 0.5, 0.7, 0.9; left to right) on UV spheres of radius 0.4, spaced 1 apart, base
colour a light gold, lit by one white point light in front, upper left, seen by a camera on +z.
One UV sphere (smooth normals) is stored once in an embedded base64 buffer and shared by all 25
meshes (one per material). Run from anywhere: `python3 scenes/gltf/metal_rough_grid.py`.
"""
import base64
import json
import math
import os
import struct

SEG_U, SEG_V, RADIUS = 48, 24, 0.4
METALLIC = [0.0, 0.25, 0.5, 0.75, 1.0]
ROUGHNESS = [0.1, 0.3, 0.5, 0.7, 0.9]
BASE = [0.95, 0.75, 0.45, 1.0]

positions, normals, indices = [], [], []
for j in range(SEG_V + 1):
    theta = math.pi * j / SEG_V
    for i in range(SEG_U + 1):
        phi = 2.0 * math.pi * i / SEG_U
        n = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
        normals.append(n)
        positions.append(tuple(RADIUS * c for c in n))
row = SEG_U + 1
for j in range(SEG_V):
    for i in range(SEG_U):
        a, b = j * row + i, j * row + i + 1
        c, d = (j + 1) * row + i, (j + 1) * row + i + 1
        if j != 0:
            indices += [a, c, b]
        if j != SEG_V - 1:
            indices += [b, c, d]

pos_bytes = b"".join(struct.pack("<3f", *p) for p in positions)
nrm_bytes = b"".join(struct.pack("<3f", *n) for n in normals)
idx_bytes = b"".join(struct.pack("<H", k) for k in indices)
buffer = pos_bytes + nrm_bytes + idx_bytes
lo = [min(p[k] for p in positions) for k in range(3)]
hi = [max(p[k] for p in positions) for k in range(3)]

materials, meshes, nodes = [], [], []
for r, metallic in enumerate(METALLIC):
    for c, roughness in enumerate(ROUGHNESS):
        materials.append({
            "name": f"metallic {metallic} roughness {roughness}",
            "pbrMetallicRoughness": {"baseColorFactor": BASE, "metallicFactor": metallic, "roughnessFactor": roughness},
        })
        meshes.append({"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": len(materials) - 1}]})
        nodes.append({"mesh": len(meshes) - 1, "translation": [c - 2.0, r - 2.0, 0.0]})
nodes.append({"camera": 0, "translation": [0.0, 0.0, 9.0]})
nodes.append({"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [-3.0, 3.0, 8.0]})

gltf = {
    "asset": {"version": "2.0", "generator": "scenes/gltf/metal_rough_grid.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 1, 1], "intensity": 90.0}]}},
    "scene": 0,
    "scenes": [{"nodes": list(range(len(nodes)))}],
    "nodes": nodes,
    "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(36.0), "aspectRatio": 1.0, "znear": 0.1}}],
    "materials": materials,
    "meshes": meshes,
    "buffers": [{"byteLength": len(buffer), "uri": "data:application/octet-stream;base64," + base64.b64encode(buffer).decode()}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": len(pos_bytes), "target": 34962},
        {"buffer": 0, "byteOffset": len(pos_bytes), "byteLength": len(nrm_bytes), "target": 34962},
        {"buffer": 0, "byteOffset": len(pos_bytes) + len(nrm_bytes), "byteLength": len(idx_bytes), "target": 34963},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5126, "count": len(normals), "type": "VEC3"},
        {"bufferView": 2, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
    ],
}
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "metal_rough_grid.gltf")
with open(out + ".tmp", "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
os.replace(out + ".tmp", out)
print(f"wrote {out}: {len(indices) // 3} triangles per sphere, {len(materials)} materials")
