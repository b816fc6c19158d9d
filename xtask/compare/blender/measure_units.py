# Measure Cycles' units for lamps and emission.
# Run: blender -b --factory-startup --python measure_units.py -- [samples]
# Each case renders a small orthographic top view of a white Lambertian floor (Diffuse BSDF,
# colour 1, i.e. albedo 1) in a black world, writes a linear EXR and prints the mean RGB / Y of
# the central pixels next to the value expected from the stated hypothesis.
import math
import os
import sys

import bpy

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)) if "__file__" in globals() else "/work/blender-study", "units")
os.makedirs(OUT, exist_ok=True)
argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
SAMPLES = int(argv[0]) if argv else 64
RES = 64


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = SAMPLES
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 4
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 1
    scene.render.resolution_x = RES
    scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    vs = scene.view_settings
    scene.display_settings.display_device = "sRGB"
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    img = scene.render.image_settings
    img.file_format = "OPEN_EXR"
    img.color_depth = "32"
    img.exr_codec = "ZIP"
    world = bpy.data.worlds.new("Black")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0, 0, 0, 1)
    bg.inputs["Strength"].default_value = 0.0
    scene.world = world
    return scene


def diffuse_material(name, albedo=1.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (albedo, albedo, albedo, 1)
    d.inputs["Roughness"].default_value = 0.0
    nt.links.new(d.outputs["BSDF"], out.inputs["Surface"])
    return mat


def emission_material(name, strength):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = (1, 1, 1, 1)
    e.inputs["Strength"].default_value = strength
    nt.links.new(e.outputs["Emission"], out.inputs["Surface"])
    return mat


def plane(name, size, z, mat):
    bpy.ops.mesh.primitive_plane_add(size=size, location=(0, 0, z))
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(mat)
    return obj


def camera(scene, z, ortho_scale=0.2):
    cam_data = bpy.data.cameras.new("Cam")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = ortho_scale
    cam_data.clip_start = 0.001
    cam_data.clip_end = 100
    cam = bpy.data.objects.new("Cam", cam_data)
    cam.location = (0, 0, z)  # looks down -Z by default
    scene.collection.objects.link(cam)
    scene.camera = cam


def render_and_measure(scene, tag, expected, half=3):
    path = os.path.join(OUT, tag + ".exr")
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    w, h = img.size
    px = img.pixels[:]
    cx, cy = w // 2, h // 2
    acc = [0.0, 0.0, 0.0]
    n = 0
    for y in range(cy - half, cy + half):
        for x in range(cx - half, cx + half):
            i = 4 * (y * w + x)
            for c in range(3):
                acc[c] += px[i + c]
            n += 1
    r, g, b = (a / n for a in acc)
    Y = 0.2126 * r + 0.7152 * g + 0.0722 * b
    print(f"RESULT {tag}: centre {2*half}x{2*half} px mean RGB ({r:.5f}, {g:.5f}, {b:.5f}) Y {Y:.5f}; "
          f"expected {expected:.5f}; ratio {Y/expected:.5f}")
    return Y


results = {}

# (a) point lamp of P W, radius 0, at height d over the white floor.
for P, d in ((100.0, 2.0), (1000.0, 3.0)):
    scene = reset()
    plane("Floor", 40, 0.0, diffuse_material("White"))
    ld = bpy.data.lights.new("Point", "POINT")
    ld.energy = P
    ld.shadow_soft_size = 0.0
    lo = bpy.data.objects.new("Point", ld)
    lo.location = (0, 0, d)
    scene.collection.objects.link(lo)
    camera(scene, d + 1.0)
    # hypothesis: intensity I = P/(4π) [W/sr], E = I/d², L = E/π
    results[f"point_{int(P)}W_{d:g}m"] = render_and_measure(
        scene, f"point_{int(P)}W_{d:g}m", P / (4 * math.pi) / d**2 / math.pi)

# (a') spot lamp of P W pointing down (spot_size 60°, blend 0), same as a point inside its cone?
scene = reset()
plane("Floor", 40, 0.0, diffuse_material("White"))
ld = bpy.data.lights.new("Spot", "SPOT")
ld.energy = 100.0
ld.shadow_soft_size = 0.0
ld.spot_size = math.radians(60)
ld.spot_blend = 0.0
lo = bpy.data.objects.new("Spot", ld)
lo.location = (0, 0, 2.0)  # default orientation points down -Z
scene.collection.objects.link(lo)
camera(scene, 3.0)
results["spot_100W_2m"] = render_and_measure(scene, "spot_100W_2m", 100 / (4 * math.pi) / 4 / math.pi)

# (b) emission strength S seen directly (camera looks at an emissive plane).
scene = reset()
plane("Emitter", 2, 0.0, emission_material("Emit5", 5.0))
camera(scene, 1.0)
results["emission_5_direct"] = render_and_measure(scene, "emission_5_direct", 5.0)

# (b') a large emissive ceiling (strength S, 400 m square, 1 m up) lighting the white floor:
# E = π S (minus a view factor of ~1e-5), so the floor reads L = S.
scene = reset()
plane("Floor", 400, 0.0, diffuse_material("White"))
ceiling = plane("Ceiling", 400, 1.0, emission_material("Emit2", 2.0))
ceiling.rotation_euler = (math.pi, 0, 0)  # face down (Cycles mesh emission is two-sided anyway)
camera(scene, 0.5)
results["emission_2_ceiling_lit_floor"] = render_and_measure(scene, "emission_2_ceiling_lit_floor", 2.0)

# (c) sun of strength S W/m² straight down: E = S, L = S/π.
scene = reset()
plane("Floor", 40, 0.0, diffuse_material("White"))
ld = bpy.data.lights.new("Sun", "SUN")
ld.energy = 3.0
ld.angle = 0.0
lo = bpy.data.objects.new("Sun", ld)
lo.location = (0, 0, 5)
scene.collection.objects.link(lo)
camera(scene, 1.0)
results["sun_3"] = render_and_measure(scene, "sun_3", 3.0 / math.pi)

print("SUMMARY", results)
