# A small test scene for spectrace: a white diffuse floor, a 100 W point lamp 1 m above it, an
# emissive cube (Emission shader, strength 8) and a camera. Renders it with Cycles (linear EXR,
# Standard view, plus an sRGB PNG preview), exports it to glTF with the exporter's defaults
# (lighting mode SPEC) plus lights and cameras, saves the .blend, and prints the luminance
# Y = 0.2126 R + 0.7152 G + 0.0722 B of the emissive face and of the floor under the lamp.
#
# Run: blender -b --factory-startup --python make_scene.py -- [samples] [world]
#   world: "default" (Blender's default world grey 0.050876, as a new Blender scene) or "black"
import math
import os
import sys

import bpy
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
SAMPLES = int(argv[0]) if len(argv) > 0 else 1024
WORLD = argv[1] if len(argv) > 1 else "default"
W, H = 200, 150
BASE = os.path.join(HERE, "blender_lamp_emitter")
SUFFIX = "" if WORLD == "default" else "_" + WORLD

LAMP_W = 100.0
LAMP_HEIGHT = 1.0
EMISSION = 8.0
FLOOR_ALBEDO = 0.8  # Blender's default base colour
CUBE_SIZE = 0.4
CUBE_AT = (1.2, 0.3, CUBE_SIZE / 2)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.name = "Scene"
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = SAMPLES
scene.cycles.use_adaptive_sampling = False
scene.cycles.use_denoising = False
scene.cycles.seed = 1
scene.render.threads_mode = "FIXED"
scene.render.threads = 1
scene.render.resolution_x = W
scene.render.resolution_y = H
scene.render.resolution_percentage = 100
scene.display_settings.display_device = "sRGB"
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0

world = bpy.data.worlds.new("World")
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
grey = 0.050876 if WORLD == "default" else 0.0  # Blender's default world colour (sRGB 0.25 linearised)
bg.inputs["Color"].default_value = (grey, grey, grey, 1)
bg.inputs["Strength"].default_value = 1.0
scene.world = world

# Floor: Principled BSDF, base 0.8, Specular 0 (so Cycles' floor is purely diffuse; the exporter
# writes KHR_materials_specular specularColorFactor [0,0,0]), roughness 1: under the lamp, seen from this
# camera, Cycles' Principled diffuse is Lambertian to <0.1 % (its retro-reflection lifts the cube's grazing
# light by ~15 %, +0.4 % of the floor) and spectrace's glTF BRDF is closest to Lambert (at roughness 0.5 it
# reads 1.8 % above).
floor_mat = bpy.data.materials.new("Floor")
floor_mat.use_nodes = True
p = floor_mat.node_tree.nodes["Principled BSDF"]
p.inputs["Base Color"].default_value = (FLOOR_ALBEDO, FLOOR_ALBEDO, FLOOR_ALBEDO, 1)
p.inputs["Specular"].default_value = 0.0
p.inputs["Roughness"].default_value = 1.0
p.inputs["Metallic"].default_value = 0.0
bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, 0))
floor = bpy.context.active_object
floor.name = "Floor"
floor.data.materials.append(floor_mat)

# Emitter: a cube with a pure Emission shader (the exporter writes emissiveFactor [1,1,1],
# KHR_materials_emissive_strength 8 and a black base colour).
emit_mat = bpy.data.materials.new("Emitter")
emit_mat.use_nodes = True
nt = emit_mat.node_tree
nt.nodes.clear()
out = nt.nodes.new("ShaderNodeOutputMaterial")
e = nt.nodes.new("ShaderNodeEmission")
e.inputs["Color"].default_value = (1, 1, 1, 1)
e.inputs["Strength"].default_value = EMISSION
nt.links.new(e.outputs["Emission"], out.inputs["Surface"])
bpy.ops.mesh.primitive_cube_add(size=CUBE_SIZE, location=CUBE_AT)
cube = bpy.context.active_object
cube.name = "Emitter"
cube.data.materials.append(emit_mat)

# Lamp: 100 W point, radius 0 (glTF's punctual light has none), white.
ld = bpy.data.lights.new("Lamp", "POINT")
ld.energy = LAMP_W
ld.shadow_soft_size = 0.0
ld.color = (1, 1, 1)
lamp = bpy.data.objects.new("Lamp", ld)
lamp.location = (0, 0, LAMP_HEIGHT)
scene.collection.objects.link(lamp)

# Camera: 50 mm on a 36 mm sensor, looking down (about 35° from vertical) at the floor between lamp and
# cube, so the floor under the lamp is seen near normal incidence (Principled diffuse retro-reflection
# and Fresnel there are below 0.1 %).
cd = bpy.data.cameras.new("Camera")
cd.lens = 50
cd.sensor_width = 36
cd.clip_start = 0.1
cd.clip_end = 100
cam = bpy.data.objects.new("Camera", cd)
cam.location = (0.6, -2.2, 3.3)
target = Vector((0.6, 0.2, 0.0))
cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
scene.collection.objects.link(cam)
scene.camera = cam
bpy.context.view_layer.update()


def pixel_of(point):
    """EXR pixel (column, row from the top) that sees world point `point`."""
    v = world_to_camera_view(scene, cam, Vector(point))
    return int(v.x * W), int((1 - v.y) * H)


# Render.
exr = BASE + SUFFIX + ".exr"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.exr_codec = "ZIP"
scene.render.filepath = exr
bpy.ops.render.render(write_still=True)
png = BASE + SUFFIX + ".png"
result = bpy.data.images["Render Result"]
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_depth = "8"
scene.view_settings.exposure = -2.0  # the preview only (the EXR above is scene-linear, exposure 0)
result.save_render(png, scene=scene)  # Standard view transform (sRGB), 2 stops down
scene.view_settings.exposure = 0.0

img = bpy.data.images.load(exr)
px = img.pixels[:]  # bottom-up rows, RGBA


def patch(col, row, half):
    """Mean Y over the (2·half+1)² pixels around (col, row from the top)."""
    ys = []
    for r in range(row - half, row + half + 1):
        for c in range(col - half, col + half + 1):
            i = 4 * ((H - 1 - r) * W + c)
            ys.append(0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2])
    m = sum(ys) / len(ys)
    sd = (sum((y - m) ** 2 for y in ys) / len(ys)) ** 0.5
    return m, sd, len(ys)


under = pixel_of((0, 0, 0))
face_centre = (CUBE_AT[0], CUBE_AT[1] - CUBE_SIZE / 2, CUBE_AT[2])  # the face towards the camera (−y)
face = pixel_of(face_centre)
fy, fs, fn = patch(*face, 2)
ly, ls, ln = patch(*under, 1)
analytic_floor = FLOOR_ALBEDO * LAMP_W / (4 * math.pi) / LAMP_HEIGHT**2 / math.pi
print(f"RESULT world={WORLD} samples={SAMPLES}")
print(f"RESULT emissive face centre {face_centre} -> pixel (col,row from top) {face}: 5x5 mean Y {fy:.5f} (sd {fs:.5f})")
print(f"RESULT floor under lamp (0,0,0) -> pixel {under}: 3x3 mean Y {ly:.5f} (sd {ls:.5f}); direct-lamp-only analytic {analytic_floor:.5f}")
print(f"RESULT ratio emissive/floor {fy/ly:.5f}")

if WORLD == "default":
    # Export with the defaults (export_import_convert_lighting_mode SPEC), lights and cameras on.
    bpy.ops.wm.save_as_mainfile(filepath=BASE + ".blend")
    bpy.ops.export_scene.gltf(
        filepath=BASE + ".gltf",
        export_format="GLTF_SEPARATE",
        export_lights=True,
        export_cameras=True,
    )
