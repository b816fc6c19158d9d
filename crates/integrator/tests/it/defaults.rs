//! Issue 13: what a file renders with when the user gives no flags (integrator, camera, exposure).

use std::path::Path;

use glam::Vec3;
use integrator::{AssemblyOptions, CameraOptions, IntegratorKind, RenderScene, Tonemap, View};

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
    // A setting that names no model is an error that says what it accepts.
    for bad in [r#""bdpt""#, "3"] {
        let desc = geometry::parse_manifest(
            &format!(r#"{SPHERE}, "settings": {{"integrator": {bad}}}}}"#),
            Path::new("."),
            "t",
        )
        .unwrap();
        let err = RenderScene::from_description(desc).unwrap_err().to_string();
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
