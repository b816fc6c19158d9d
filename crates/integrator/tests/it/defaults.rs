//! What a file renders with when the user gives no flags (integrator, camera, exposure).

use std::path::Path;

use geometry::LightDesc;
use glam::Vec3;
use integrator::{AssemblyOptions, CameraOptions, IntegratorKind, RenderScene, SpectralMode, Tonemap, View};

fn repo(path: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

const SPHERE: &str = r#"{"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]"#;

#[test]
fn auto_integrator_is_the_papers_model_only_where_the_scene_asks_for_it() {
    let default = RenderScene::default_scene().unwrap();
    assert_eq!(default.auto_integrator().0, IntegratorKind::WhittedHall);
    for file in ["five_spheres", "four_spheres_mesh", "gltf_mesh", "one_sphere_mesh"] {
        let scene = RenderScene::load(&repo(&format!("scenes/paper/{file}.json"))).unwrap();
        assert_eq!(scene.auto_integrator().0, IntegratorKind::WhittedHall, "{file}");
    }
    for file in ["scenes/reference/cornell_box.json", "scenes/meshes/gem.gltf", "scenes/obj/cube_and_sphere.obj"] {
        let scene = RenderScene::load(&repo(file)).unwrap();
        assert_eq!(scene.auto_integrator().0, IntegratorKind::Path, "{file}");
    }
    let path = crate::scene(&format!(r#"{SPHERE}, "settings": {{"integrator": "path"}}}}"#));
    assert_eq!(
        path.auto_integrator(),
        (IntegratorKind::Path, r#"path: the scene's settings ask for it ("integrator": "path")"#)
    );
    // A setting that names no model is an error that says what it accepts: a string when the scene is
    // assembled (the integrators know the names), anything else already when the manifest is read.
    for (bad, when_read) in [(r#""photons""#, false), ("3", true)] {
        let err = match geometry::parse_manifest(
            &format!(r#"{SPHERE}, "settings": {{"integrator": {bad}}}}}"#),
            Path::new("."),
            "t",
        ) {
            Ok(desc) => RenderScene::from_description(desc).unwrap_err().to_string(),
            Err(e) if when_read => e.to_string(),
            Err(e) => panic!("{bad}: {e}"),
        };
        assert!(err.contains("settings.integrator") && err.contains("whitted-hall"), "{err}");
    }
}

#[test]
fn a_file_camera_is_kept_and_overrides_apply_to_it() {
    let torus = repo("scenes/gltf/glass_torus.gltf");
    let scene = RenderScene::load(&torus).unwrap();
    let (camera, source) = scene.camera_desc();
    assert_eq!(camera.position, Vec3::new(0.0, 2.2, 5.5));
    assert_eq!(source, "the file's camera 'camera'");
    assert!(scene.has_photometric_lights());
    let options = AssemblyOptions {
        camera: CameraOptions { look_from: Some(Vec3::new(3.0, 0.0, 0.0)), vfov_deg: Some(20.0), ..Default::default() },
        ..Default::default()
    };
    let moved = RenderScene::load_with_options(&torus, &geometry::LoadOptions::default(), &options).unwrap();
    let (camera, source) = moved.camera_desc();
    // Moving the eye alone looks at the bounds' centre (the description's; the BVH's box is padded by
    // rounding, hence the tolerance); the file's fov is replaced.
    let (lo, hi) = moved.geometry().bounds();
    assert_eq!((camera.position, camera.vfov_deg), (Vec3::new(3.0, 0.0, 0.0), 20.0));
    assert!((camera.look_at - 0.5 * (lo + hi)).length() < 1e-4, "{} vs {}", camera.look_at, 0.5 * (lo + hi));
    assert!(source.contains("command line"), "{source}");
    // Manifests with a camera are unchanged by the new default (it only fills in a missing camera).
    let cornell = RenderScene::load(&repo("scenes/reference/cornell_box.json")).unwrap();
    assert!(cornell.camera_desc().1.starts_with("the file's camera"));
    assert!(!cornell.has_photometric_lights());
}

#[test]
fn the_exr_records_the_pngs_exposure_only_when_there_is_one() {
    let dir = std::env::temp_dir().join(format!("spectrace-exposure-attr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let key = exr::prelude::Text::from(integrator::EXR_VIEW_ATTRIBUTE);
    let read = |path: &Path| {
        let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
        let layer = &image.layer_data[0];
        let view = layer.attributes.other.get(&key).cloned();
        (view, layer.channel_data.list[0].sample_data.values_as_f32().next())
    };
    let mut image = integrator::Image::new(2, 2);
    image.write_exr(&dir.join("plain.exr"), integrator::Display::Srgb).unwrap();
    assert_eq!(read(&dir.join("plain.exr")).0, None);
    image.set_view(View { ev: -3.25, tonemap: Tonemap::PbrNeutral });
    image.write_exr(&dir.join("exposed.exr"), integrator::Display::Srgb).unwrap();
    let (view, first) = read(&dir.join("exposed.exr"));
    assert!(
        matches!(&view, Some(exr::prelude::AttributeValue::Text(t)) if t.eq("exposure -3.25 EV; tonemap pbr-neutral")),
        "{view:?}"
    );
    assert_eq!(first, Some(0.0), "the pixels are not scaled");
    // The same image written twice gives the same bytes (one custom attribute: no hash-map order).
    image.write_exr(&dir.join("again.exr"), integrator::Display::Srgb).unwrap();
    assert_eq!(std::fs::read(dir.join("exposed.exr")).unwrap(), std::fs::read(dir.join("again.exr")).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An orthographic camera 2·1.6 wide and 2 high at z = 5, looking at a black unit quad centred
/// at the origin before a white background, on a 32×20 image (0.1 scene units per pixel): the quad covers
/// exactly pixels x = 11..=20, y = 5..=14 (x = −1.6 + 0.1·(px + ½) within ±0.5), whatever the depth. The
/// camera was ignored (the default view used) before.
#[test]
fn an_orthographic_camera_fills_exactly_the_predicted_pixels() {
    let json = r#"{"background": {"spectrum": "E", "intensity": 1},
        "materials": {"black": {"diffuse": 0, "ks": 0}},
        "objects": [{"type": "quad", "corner": [-0.5, -0.5, 0], "edge_u": [1, 0, 0], "edge_v": [0, 1, 0],
                     "material": "black"}]}"#;
    for eye_z in [5.0, 500.0] {
        let mut desc = geometry::parse_manifest(json, Path::new("."), "<ortho>").unwrap();
        desc.camera = Some(geometry::CameraDesc {
            position: Vec3::new(0.0, 0.0, eye_z),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 40.0,
            projection: geometry::Projection::Orthographic { xmag: 1.6, ymag: 1.0 },
            aspect_ratio: Some(1.6),
            width: None,
            height: None,
        });
        let scene = RenderScene::from_description(desc).unwrap();
        // The camera's aspect sets the default height: 640 × 400.
        assert_eq!(scene.resolution(), (640, 400));
        assert_eq!(scene.resolution_for(Some(32), None), (32, 20));
        let (image, _) = crate::render_with(&scene, &crate::options(32, 20));
        for y in 0..20 {
            for x in 0..32 {
                let inside = (11..=20).contains(&x) && (5..=14).contains(&y);
                let luminance = image.xyz(x, y)[1];
                let expected = if inside { 0.0 } else { 1.0 };
                assert!((luminance - expected).abs() < 1e-4, "eye z {eye_z}, pixel ({x}, {y}): Y = {luminance}");
            }
        }
    }
}

/// A glTF camera's `aspectRatio` (and an orthographic camera's xmag / ymag) sets the default
/// height from the default width, and the other side when only one is given; an explicit size wins.
#[test]
fn a_cameras_aspect_ratio_drives_the_default_image_size() {
    let dir = std::env::temp_dir().join(format!("spectrace-aspect-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // One triangle (positions in a base64 data URI: (0,0,0), (1,0,0), (0,1,0) as f32).
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect();
    let b64 = base64_encode(&positions);
    for (camera, size, for_width_100) in [
        (
            r#"{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1, "aspectRatio": 2.0}}"#,
            (640, 320),
            (100, 50),
        ),
        (r#"{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}}"#, (640, 480), (100, 480)),
        (
            r#"{"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 4.0, "znear": 0, "zfar": 10}}"#,
            (640, 2560),
            (100, 400),
        ),
    ] {
        let gltf = format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
            "nodes": [{{"mesh": 0}}, {{"camera": 0, "translation": [0.3, 0.3, 3]}}],
            "cameras": [{camera}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
            "buffers": [{{"byteLength": 36, "uri": "data:application/octet-stream;base64,{b64}"}}]}}"#
        );
        let path = dir.join("cam.gltf");
        std::fs::write(&path, gltf).unwrap();
        let scene = RenderScene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.resolution(), size, "{camera}");
        assert_eq!(scene.resolution_for(Some(100), None), for_width_100, "{camera}");
        assert_eq!(scene.resolution_for(Some(100), Some(7)), (100, 7));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Standard base64 (RFC 4648, with padding), for data URIs in test files.
fn base64_encode(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * i)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A mesh placed by transforms (two-level BVH) renders as its world-space copies do: 12
/// tilted, scaled (some mirrored) boxes under a point light, whitted-hall at pixel centres; every pixel
/// within 1e-3 of the copies' image but for silhouette pixels (at most 1 %).
#[test]
fn instanced_meshes_render_like_their_world_space_copies() {
    let json = r#"{"camera": {"position": [0, 4, 14], "look_at": [0, 0, 0], "vfov_deg": 45},
        "lights": [{"type": "point", "position": [3, 8, 6], "spectrum": "D65", "intensity": 80}],
        "background": {"spectrum": "E", "intensity": 0.2},
        "materials": {"white": {"diffuse": 0.8, "ks": 0.2, "shininess": 30}}}"#;
    // A unit box (12 triangles, outward winding) with the manifest's only material.
    let p: Vec<Vec3> =
        (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) - 0.5).collect();
    let faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let tris: Vec<[u32; 3]> = faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect();
    let cube = geometry::Mesh::new(p, None, None, tris, Some(0)).unwrap();
    let transforms: Vec<glam::Mat4> = (0..12)
        .map(|k| {
            let x = (k % 4) as f32 * 2.5 - 3.75;
            let z = (k / 4) as f32 * 2.5 - 2.5;
            let s = if k % 3 == 0 { Vec3::new(-1.0, 1.2, 0.8) } else { Vec3::new(1.1, 0.7, 1.3) };
            glam::Mat4::from_scale_rotation_translation(
                s,
                glam::Quat::from_rotation_y(0.4 * k as f32),
                Vec3::new(x, 0.0, z),
            )
        })
        .collect();
    let copies: Vec<geometry::Mesh> = transforms
        .iter()
        .map(|m| {
            let t = cube.transformed(*m);
            let mut idx = t.indices().to_vec();
            if m.determinant() < 0.0 {
                idx.iter_mut().for_each(|tri| tri.swap(1, 2));
            }
            geometry::Mesh::new(t.positions().to_vec(), None, None, idx, Some(0)).unwrap()
        })
        .collect();
    let render = |desc: geometry::SceneDescription| {
        let scene = RenderScene::from_description(desc).unwrap();
        crate::render_with(&scene, &crate::options(192, 128)).0
    };
    let mut flat = geometry::parse_manifest(json, Path::new("."), "<flat>").unwrap();
    flat.meshes = copies;
    let mut placed = geometry::parse_manifest(json, Path::new("."), "<instanced>").unwrap();
    placed.instances = vec![geometry::Instances::new(vec![cube], transforms).unwrap()];
    let (a, b) = (render(flat), render(placed));
    let (mut differ, mut lit) = (0, 0);
    for (pa, pb) in a.pixels().iter().zip(b.pixels()) {
        // Not the background (Y = 0.2): a box.
        lit += usize::from((pa[1] - 0.2).abs() > 0.01);
        if (pa[1] - pb[1]).abs() > 1e-3 * pa[1].max(1.0) {
            differ += 1;
        }
    }
    assert!(lit > 1200, "{lit} pixels see a box");
    assert!(differ * 100 <= a.pixels().len(), "{differ} pixels differ");
}

/// A scratch folder for one test's files.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("spectrace-defaults-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The quads of a box from `lo` to `hi` facing inwards (a room's walls), as OBJ faces over the vertices
/// from `first` (1-based) on, leaving out the sides named in `open` ("+x", "-x", "+y", "-y", "+z", "-z").
fn obj_box(lo: Vec3, hi: Vec3, first: usize, inward: bool, open: &[&str]) -> String {
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let mut out = String::new();
    for i in 0..8 {
        let c = corner(i);
        out.push_str(&format!("v {} {} {}\n", c.x, c.y, c.z));
    }
    // Counter-clockwise seen from outside: outward normals.
    let sides = [
        ("-x", [0, 4, 6, 2]),
        ("+x", [1, 3, 7, 5]),
        ("-y", [0, 1, 5, 4]),
        ("+y", [2, 6, 7, 3]),
        ("-z", [0, 2, 3, 1]),
        ("+z", [4, 5, 7, 6]),
    ];
    for (name, mut quad) in sides {
        if open.contains(&name) {
            continue;
        }
        if inward {
            quad.reverse();
        }
        let ids: Vec<String> = quad.iter().map(|i| (first + i).to_string()).collect();
        out.push_str(&format!("f {}\n", ids.join(" ")));
    }
    out
}

/// Of a grid of rays from the scene's camera, the fraction that meet a surface from its front (against its
/// winding), and the number that meet anything.
fn front_fraction(scene: &RenderScene) -> (f32, usize) {
    let (c, _) = scene.camera_desc();
    let camera = geometry::Camera::look_at(c.position, c.look_at, c.up, c.vfov_deg, 4.0 / 3.0).unwrap();
    let (mut front, mut hits) = (0usize, 0usize);
    for y in 0..24 {
        for x in 0..32 {
            let ray = camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, 32, 24);
            if let Some(hit) = scene.geometry().intersect(&ray, f32::INFINITY) {
                hits += 1;
                front += usize::from(hit.n.dot(ray.dir) < 0.0);
            }
        }
    }
    (front as f32 / hits.max(1) as f32, hits)
}

/// A room open on its +x side (walls facing inwards) with a cube in it: the three-quarter view from the
/// front (+z) would see the outside of the back wall; the default view looks in through the open side.
#[test]
fn an_open_box_is_seen_through_its_open_side() {
    let dir = scratch("open-box");
    let obj = format!(
        "{}{}",
        obj_box(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), 1, true, &["+x"]),
        obj_box(Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 0.6, 0.3), 9, false, &[])
    );
    std::fs::write(dir.join("room.obj"), obj).unwrap();
    let scene = RenderScene::load(&dir.join("room.obj")).unwrap();
    let (camera, source) = scene.camera_desc();
    // Outside the open side, looking at the centre, framed as the three-quarter view is.
    assert!(camera.position.x > 1.0 && camera.position.y.abs() < 3.0, "{camera:?}");
    assert!((camera.look_at - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-5, "{camera:?}");
    assert!(source.contains("+X"), "{source}");
    // It sees the inside: every surface it meets faces it (walls from inside, the cube from outside).
    let (front, hits) = front_fraction(&scene);
    assert!(hits > 400 && front > 0.99, "{hits} hits, {front} front-facing");
    assert!(scene.warnings.iter().any(|w| w.starts_with("camera: ") && w.contains("+X")), "{:?}", scene.warnings);
    // The same box open on the front keeps the three-quarter view: it sees the inside through the front.
    let front_open = obj_box(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), 1, true, &["+z"]);
    std::fs::write(dir.join("front.obj"), front_open).unwrap();
    let scene = RenderScene::load(&dir.join("front.obj")).unwrap();
    assert!(scene.camera_desc().0.position.z > 1.0, "{:?}", scene.camera_desc());
    assert!(front_fraction(&scene).0 > 0.99);
    // --look-from is the user's eye: no view is chosen.
    let options = AssemblyOptions {
        camera: CameraOptions { look_from: Some(Vec3::new(0.0, 1.0, -5.0)), ..Default::default() },
        ..Default::default()
    };
    let scene =
        RenderScene::load_with_options(&dir.join("room.obj"), &geometry::LoadOptions::default(), &options).unwrap();
    assert_eq!(scene.camera_desc().0.position, Vec3::new(0.0, 1.0, -5.0));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A closed room (six walls facing inwards, a cube inside): every outside view sees walls from behind, so
/// the camera stands inside.
#[test]
fn a_closed_room_is_seen_from_inside() {
    let dir = scratch("closed-room");
    let obj = format!(
        "{}{}",
        obj_box(Vec3::new(-2.0, 0.0, -2.0), Vec3::new(2.0, 2.5, 2.0), 1, true, &[]),
        obj_box(Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 0.6, 0.3), 9, false, &[])
    );
    std::fs::write(dir.join("room.obj"), obj).unwrap();
    let scene = RenderScene::load(&dir.join("room.obj")).unwrap();
    let (camera, source) = scene.camera_desc();
    let p = camera.position;
    assert!(p.x.abs() < 2.0 && p.y > 0.0 && p.y < 2.5 && p.z.abs() < 2.0, "{camera:?}");
    assert!(source.contains("inside"), "{source}");
    let (front, hits) = front_fraction(&scene);
    assert!(hits == 768 && front > 0.99, "{hits} hits, {front} front-facing");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A cube on a floor a hundred times its size: the floor does not set the framing distance.
#[test]
fn a_ground_plane_much_larger_than_the_rest_is_left_out_of_the_framing() {
    let dir = scratch("ground");
    let obj = format!(
        "{}o ground\nv -50 0 -50\nv 50 0 -50\nv 50 0 50\nv -50 0 50\nf 9 12 11 10\n",
        obj_box(Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5), 1, false, &[])
    );
    std::fs::write(dir.join("ground.obj"), obj).unwrap();
    let scene = RenderScene::load(&dir.join("ground.obj")).unwrap();
    let (camera, _) = scene.camera_desc();
    // Framed on the cube (centre (0, 0.5, 0), diagonal 1.7): a few units away, not a hundred.
    assert!((camera.look_at - Vec3::new(0.0, 0.5, 0.0)).length() < 1e-5, "{camera:?}");
    let distance = camera.position.distance(camera.look_at);
    assert!((1.0..6.0).contains(&distance), "{distance}");
    assert!(scene.warnings.iter().any(|w| w.contains("ground plane")), "{:?}", scene.warnings);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The real OBJ Cornell boxes (in the shared asset folder, not in the repository) are seen through their
/// open side: McGuire's is open towards +z, tinyobjloader's (the Cornell data, 0–556 mm) towards −z.
/// McGuire's is lit by its ceiling light alone; tinyobjloader's has none and gets the default lights.
#[test]
fn the_real_obj_cornell_boxes_are_seen_through_their_open_side() {
    let root = Path::new("/work/shared/real_assets");
    let (mcguire, tinyobj) = (root.join("mcguire/CornellBox-Original.obj"), root.join("tinyobj/cornell_box.obj"));
    if !(mcguire.is_file() && tinyobj.is_file()) {
        eprintln!("skipped: the real Cornell boxes are not in {}", root.display());
        return;
    }
    let scene = RenderScene::load(&mcguire).unwrap();
    let (camera, source) = scene.camera_desc();
    assert!(camera.position.z > 0.99 && camera.position.x.abs() < 0.1, "{source}: {camera:?}");
    assert!(front_fraction(&scene).0 > 0.99);
    // Its own light only: nothing added, and the note says why.
    assert!(scene.light_descs().is_empty(), "{:?}", scene.light_descs());
    assert!(scene.warnings.iter().any(|w| w.contains("readably")), "{:?}", scene.warnings);
    let scene = RenderScene::load(&tinyobj).unwrap();
    let (camera, source) = scene.camera_desc();
    assert!(camera.position.z < 0.0 && (camera.position.x - 278.0).abs() < 1.0, "{source}: {camera:?}");
    assert!(front_fraction(&scene).0 > 0.99);
    assert_eq!(scene.light_descs().len(), 2);
}

/// What each rule lights a box of emitters with: the box of [`an_open_box_is_seen_through_its_open_side`]
/// open at the front, an emitter under its ceiling.
fn emitter_box(dir: &Path, half_width: f32, ke: f32) -> RenderScene {
    // As Blender's OBJ exporter writes it (header, MTL with Kd 0.8 and Ke).
    let w = half_width;
    let obj = format!(
        "# Blender 3.4.1\n# www.blender.org\nmtllib lamp.mtl\n{}o Lamp\nv {} 1.99 {}\nv {} 1.99 {}\nv {} 1.99 {}\nv {} 1.99 {}\nusemtl Lamp\nf 9 10 11 12\n",
        obj_box(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), 1, true, &["+z"]),
        -w,
        -w,
        w,
        -w,
        w,
        w,
        -w,
        w
    );
    std::fs::write(dir.join("lamp.obj"), obj).unwrap();
    std::fs::write(
        dir.join("lamp.mtl"),
        format!("# Blender 3.4.1 MTL File\nnewmtl Lamp\nNs 250\nKd 0.8 0.8 0.8\nKe {ke} {ke} {ke}\nillum 1\n"),
    )
    .unwrap();
    RenderScene::load(&dir.join("lamp.obj")).unwrap()
}

#[test]
fn emitters_that_light_the_view_readably_get_nothing_added_weak_ones_the_default_lights() {
    let dir = scratch("emitters");
    // A 10 cm lamp of emission 1 (Blender's default strength) under the ceiling of a 2 m room: about
    // 1 × 0.01 / (π · 2²) = 8e-4 nits on a white floor, far below readable (0.05).
    let weak = emitter_box(&dir, 0.05, 1.0);
    let kinds: Vec<&str> = weak.light_descs().iter().map(LightDesc::kind).collect();
    assert_eq!(kinds, ["environment", "directional"], "{:?}", weak.warnings);
    assert!(weak.warnings.iter().any(|w| w.contains("too little to read by")), "{:?}", weak.warnings);
    // A 1 m lamp of 4: 4 × 1 / (π · 2²) = 0.32 nits below it.
    let bright = emitter_box(&dir, 0.5, 4.0);
    assert!(bright.light_descs().is_empty(), "{:?}", bright.light_descs());
    assert!(bright.warnings.iter().any(|w| w.contains("readably")), "{:?}", bright.warnings);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A mesh for [`write_gltf`]: positions, triangles and the index of its material.
type TestMesh = (Vec<Vec3>, Vec<[u32; 3]>, usize);

/// A glTF file `name`.gltf (and .bin) in `dir`: one mesh node per `(positions, triangles, material)`, the
/// `materials` (JSON objects), `nodes` further nodes (JSON, e.g. lights and cameras), `root` further members
/// of the root object (JSON, with a leading comma) and the asset's `generator`.
fn write_gltf(
    dir: &Path,
    name: &str,
    generator: &str,
    meshes: &[TestMesh],
    materials: &[String],
    nodes: &[String],
    root: &str,
) -> std::path::PathBuf {
    let (mut bin, mut views, mut accessors, mut gltf_meshes, mut node_list) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, (positions, triangles, material)) in meshes.iter().enumerate() {
        let offset = bin.len();
        for p in positions {
            for v in p.to_array() {
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
        views.push(format!(r#"{{"buffer": 0, "byteOffset": {offset}, "byteLength": {}}}"#, bin.len() - offset));
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": 5126, "count": {}, "type": "VEC3"}}"#,
            views.len() - 1,
            positions.len()
        ));
        let offset = bin.len();
        for i in triangles.iter().flatten() {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        views.push(format!(r#"{{"buffer": 0, "byteOffset": {offset}, "byteLength": {}}}"#, bin.len() - offset));
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": 5125, "count": {}, "type": "SCALAR"}}"#,
            views.len() - 1,
            3 * triangles.len()
        ));
        gltf_meshes.push(format!(
            r#"{{"primitives": [{{"attributes": {{"POSITION": {}}}, "indices": {}, "material": {material}}}]}}"#,
            accessors.len() - 2,
            accessors.len() - 1
        ));
        node_list.push(format!(r#"{{"mesh": {k}}}"#));
    }
    node_list.extend(nodes.iter().cloned());
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0", "generator": "{generator}"}}, "scene": 0,
        "scenes": [{{"nodes": [{}]}}], "nodes": [{}], "meshes": [{}], "materials": [{}],
        "accessors": [{}], "bufferViews": [{}], "buffers": [{{"uri": "{name}.bin", "byteLength": {}}}]{root}}}"#,
        (0..node_list.len()).map(|i| i.to_string()).collect::<Vec<_>>().join(", "),
        node_list.join(", "),
        gltf_meshes.join(", "),
        materials.join(", "),
        accessors.join(", "),
        views.join(", "),
        bin.len()
    );
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, gltf).unwrap();
    path
}

/// A white Lambertian floor for glTF: base colour 1, metallic 0, and no specular layer
/// (`KHR_materials_specular` factor 0), so it reflects E/π.
const WHITE_LAMBERTIAN: &str = r#"{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 1},
    "extensions": {"KHR_materials_specular": {"specularFactor": 0}}}"#;

/// A 20 m white floor (y = 0, facing +y), a camera 0.5 m above its centre looking straight down with a
/// narrow lens, and `light` (a `KHR_lights_punctual` light JSON) at `light_node` (node members).
fn photometric_floor(dir: &Path, name: &str, light: &str, light_node: &str) -> RenderScene {
    let floor = vec![
        Vec3::new(-10.0, 0.0, -10.0),
        Vec3::new(10.0, 0.0, -10.0),
        Vec3::new(10.0, 0.0, 10.0),
        Vec3::new(-10.0, 0.0, 10.0),
    ];
    // Counter-clockwise seen from above: facing +y.
    let triangles = vec![[0, 2, 1], [0, 3, 2]];
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let path = write_gltf(
        dir,
        name,
        "spectrace test",
        &[(floor, triangles, 0)],
        &[WHITE_LAMBERTIAN.to_owned()],
        &[
            // A camera looks along its −z: turned −90° about x, it looks down −y.
            format!(r#"{{"camera": 0, "translation": [0, 0.5, 0], "rotation": [{}, 0, 0, {s}]}}"#, -s),
            format!(r#"{{"extensions": {{"KHR_lights_punctual": {{"light": 0}}}}, {light_node}}}"#),
        ],
        &format!(
            r#", "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.0002, "znear": 0.01, "aspectRatio": 1}}}}],
            "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_specular"],
            "extensions": {{"KHR_lights_punctual": {{"lights": [{light}]}}}}"#
        ),
    );
    RenderScene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Y of the single pixel, path-traced with many wavelengths (a delta light over a lone floor: every
/// sample is exact up to the spectral sampling).
fn centre_luminance(scene: &RenderScene) -> f64 {
    let opts =
        integrator::RenderOptions { spectral: SpectralMode::Bins(16), spp: 16, ..crate::options(1, 1) }.path(|_| {});
    let (image, stats) = crate::render_with(scene, &opts);
    crate::assert_all_finite(&image, &stats);
    f64::from(image.xyz(0, 0)[1])
}

/// glTF photometric lights are the scene's answer: nothing is added to a file whose lights are
/// `KHR_lights_punctual` (unless Blender wrote it), so 1 cd at 1 m reads 1/π nits on a white Lambertian
/// floor, and 100 lux 100/π.
#[test]
fn gltf_punctual_lights_light_alone_one_candela_reads_one_over_pi() {
    let dir = scratch("photometric");
    let pi = std::f64::consts::PI;
    let point = photometric_floor(&dir, "point", r#"{"type": "point", "intensity": 1}"#, r#""translation": [0, 1, 0]"#);
    assert_eq!(point.light_descs().len(), 1, "{:?}", point.light_descs());
    assert!(point.warnings.iter().any(|w| w.contains("nothing added")), "{:?}", point.warnings);
    let y = centre_luminance(&point);
    // Tolerance: the spectral sampling of D65-white through 16 bins (1e-4 in units.rs's analytic tests)
    // and the floor's reflectance fit to white (1 within 1e-3); 1 % is the issue's bound.
    assert!((y * pi - 1.0).abs() < 0.01, "1 cd at 1 m: Y = {y}, expected 1/π = {}", 1.0 / pi);
    // A directional light of 100 lux straight down (a light points along its node's −z: turned −90° about x).
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let sun = photometric_floor(
        &dir,
        "sun",
        r#"{"type": "directional", "intensity": 100}"#,
        &format!(r#""rotation": [{}, 0, 0, {s}]"#, -s),
    );
    assert_eq!(sun.light_descs().len(), 1);
    let y = centre_luminance(&sun);
    assert!((y * pi / 100.0 - 1.0).abs() < 0.01, "100 lux: Y = {y}, expected 100/π = {}", 100.0 / pi);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A unit cube's 8 corners and 12 triangles wound outwards, offset by `at`; with `open`, its +y face left
/// out.
fn cube_mesh(at: Vec3, open: bool) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let corners =
        (0..8).map(|i| at + Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)).collect();
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let triangles = quads
        .iter()
        .enumerate()
        .filter(|(k, _)| !(open && *k == 3))
        .flat_map(|(_, q)| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    (corners, triangles)
}

/// `KHR_materials_transmission` without `KHR_materials_volume`: solid glass on a closed mesh (its index
/// from `KHR_materials_ior`), a thin wall on an open one, thin everywhere with `--thin-glass`.
#[test]
fn glass_without_a_volume_is_solid_on_closed_meshes_and_thin_on_open_ones() {
    let dir = scratch("glass");
    let glass = |name: &str| {
        format!(
            r#"{{"name": "{name}", "pbrMetallicRoughness": {{"metallicFactor": 0, "roughnessFactor": 0}},
            "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}}, "KHR_materials_ior": {{"ior": 1.33}}}}}}"#
        )
    };
    let (closed, closed_triangles) = cube_mesh(Vec3::ZERO, false);
    let (open, open_triangles) = cube_mesh(Vec3::new(2.0, 0.0, 0.0), true);
    let path = write_gltf(
        &dir,
        "glass",
        "spectrace test",
        &[(closed, closed_triangles, 0), (open, open_triangles, 1)],
        &[glass("closed"), glass("open")],
        &[],
        r#", "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior"]"#,
    );
    let model = |scene: &RenderScene, name: &str| {
        scene.materials().iter().find(|m| m.name == name).map(|m| m.model).unwrap_or_else(|| panic!("{name}"))
    };
    let scene = RenderScene::load(&path).unwrap();
    assert_eq!(model(&scene, "closed"), materials::MaterialModel::Dielectric { roughness: 0.0 });
    assert_eq!(model(&scene, "open"), materials::MaterialModel::ThinDielectric);
    let closed = scene.materials().iter().find(|m| m.name == "closed").unwrap();
    assert!((closed.ior.eval(materials::LAMBDA_D) - 1.33).abs() < 1e-6);
    assert!(scene.warnings.iter().any(|w| w.contains("'closed'") && w.contains("solid glass")), "{:?}", scene.warnings);
    let thin = AssemblyOptions { thin_glass: true, ..Default::default() };
    let scene = RenderScene::load_with_options(&path, &geometry::LoadOptions::default(), &thin).unwrap();
    assert_eq!(model(&scene, "closed"), materials::MaterialModel::ThinDielectric);
    let _ = std::fs::remove_dir_all(&dir);
}
