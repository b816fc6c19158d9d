//! Scaling: render time against triangles, image size, threads and wavelength count.

use super::*;

use super::speed::{PALETTE, plot_loglog};

/// Four tables with a log–log plot each: time against triangles, image size, threads and
/// wavelength count. Timings are one render each on a possibly shared machine; the only
/// pass/fail check here is that the thread count does not change the image.
pub(crate) fn scaling(report: &mut Report, out: &Path, quick: bool) -> anyhow::Result<()> {
    let mut md = String::from(
        "## Scaling\n\nOne render each (wall time of `integrator::render`, BVH built before); the machine may \
         be shared, so read timings to within ±20 %.\n\n",
    );
    // Time vs triangles: a bumpy terrain under the paper's model, one D65 light.
    md.push_str("### Time vs triangles (whitted-hall, 320×240, bins:16, all cores)\n\n| triangles | BVH build (ms) | render (s) | Mrays/s |\n| --- | --- | --- | --- |\n");
    // 2n² triangles: 10k, 100k, 1M.
    let sizes: &[u32] = if quick { &[71, 224] } else { &[71, 224, 708] };
    let (mut build_line, mut render_line) = (Vec::new(), Vec::new());
    for &n in sizes {
        let mesh = terrain(n);
        let triangles = mesh.triangle_count();
        let desc = geometry::SceneDescription {
            meshes: vec![mesh],
            camera: Some(geometry::CameraDesc {
                position: glam::Vec3::new(0.0, 1.6, 1.6),
                look_at: glam::Vec3::ZERO,
                up: glam::Vec3::Y,
                vfov_deg: 50.0,
                projection: geometry::Projection::Perspective,
                aspect_ratio: None,
                width: None,
                height: None,
            }),
            ..geometry::parse_manifest("{}", Path::new("."), "<terrain>")?
        };
        let s = RenderScene::from_description(desc)?;
        let build = s.geometry().stats().build_time.as_secs_f64();
        let (_, stats) = render(&s, &RenderOptions { spectral: SpectralMode::Bins(16), ..small(320, 240) })?;
        let secs = stats.elapsed.as_secs_f64();
        writeln!(md, "| {triangles} | {:.1} | {secs:.3} | {:.2} |", build * 1e3, stats.rays as f64 / secs / 1e6)?;
        build_line.push((triangles as f64, build));
        render_line.push((triangles as f64, secs));
    }
    plot_loglog(&out.join("scaling_triangles.png"), &[build_line, render_line], None)?;
    writeln!(
        md,
        "\n![time vs triangles](scaling_triangles.png)\n\nx: triangles (log), y: seconds (log): BVH build {}, render {}.\n",
        PALETTE[0].0, PALETTE[1].0
    )?;

    let five = RenderScene::default_scene()?;
    let run = |(w, h): (u32, u32), threads: usize, spectral: SpectralMode| {
        let options =
            RenderOptions { width: w, height: h, threads: Some(threads), spectral, ..RenderOptions::default() };
        render(&five, &options)
    };
    // Time vs image size.
    md.push_str("### Time vs image size (default scene, whitted-hall, bins:32, 2 threads)\n\n| size | pixels | time (s) | Mrays/s |\n| --- | --- | --- | --- |\n");
    let image_sizes: &[(u32, u32)] =
        if quick { &[(80, 60), (160, 120), (320, 240)] } else { &[(160, 120), (320, 240), (640, 480), (1280, 960)] };
    let mut line = Vec::new();
    for &(w, h) in image_sizes {
        let (_, stats) = run((w, h), 2, SpectralMode::Bins(32))?;
        let secs = stats.elapsed.as_secs_f64();
        writeln!(md, "| {w}×{h} | {} | {secs:.3} | {:.2} |", w * h, stats.rays as f64 / secs / 1e6)?;
        line.push((f64::from(w * h), secs));
    }
    plot_loglog(&out.join("scaling_image_size.png"), &[line], None)?;
    md.push_str("\n![time vs image size](scaling_image_size.png)\n\nx: pixels (log), y: seconds (log).\n\n");

    // Time vs threads; the image must not depend on the thread count (rows are independent
    // and samplers are seeded per pixel).
    let size = if quick { (160, 120) } else { (640, 480) };
    md.push_str(&format!(
        "### Time vs threads (default scene, whitted-hall, bins:32, {}×{})\n\n| threads | time (s) | speed-up |\n| --- | --- | --- |\n",
        size.0, size.1
    ));
    let (one, one_stats) = run(size, 1, SpectralMode::Bins(32))?;
    let (two, two_stats) = run(size, 2, SpectralMode::Bins(32))?;
    let (t1, t2) = (one_stats.elapsed.as_secs_f64(), two_stats.elapsed.as_secs_f64());
    writeln!(md, "| 1 | {t1:.3} | 1.00 |\n| 2 | {t2:.3} | {:.2} |\n", t1 / t2.max(1e-9))?;
    let differing = one.pixels().iter().zip(two.pixels()).filter(|(a, b)| a != b).count();
    report.check(
        "scaling",
        "1 and 2 threads give the same image (default scene)",
        format!("{differing} differing pixels; speed-up {:.2}×", t1 / t2.max(1e-9)),
        "0 (bit-identical)".into(),
        "analytic",
        differing == 0,
    );

    // Time vs wavelength count.
    md.push_str("### Time vs spectral bins (default scene, whitted-hall, 2 threads)\n\n| spectral | time (s) | Mrays/s |\n| --- | --- | --- |\n");
    let (bins_size, modes): ((u32, u32), &[SpectralMode]) = if quick {
        ((160, 120), &[SpectralMode::Rgb, SpectralMode::Bins(8), SpectralMode::Bins(32), SpectralMode::Bins(95)])
    } else {
        (
            (640, 480),
            &[
                SpectralMode::Rgb,
                SpectralMode::Bins(8),
                SpectralMode::Bins(16),
                SpectralMode::Bins(32),
                SpectralMode::Bins(64),
                SpectralMode::Bins(95),
            ],
        )
    };
    let mut line = Vec::new();
    for &mode in modes {
        let (_, stats) = run(bins_size, 2, mode)?;
        let secs = stats.elapsed.as_secs_f64();
        writeln!(md, "| {mode} | {secs:.3} | {:.2} |", stats.rays as f64 / secs / 1e6)?;
        if let SpectralMode::Bins(n) = mode {
            line.push((n as f64, secs));
        }
    }
    plot_loglog(&out.join("scaling_bins.png"), &[line], None)?;
    writeln!(
        md,
        "\n![time vs bins](scaling_bins.png)\n\nx: wavelength bins (log), y: seconds (log), at {}×{}.\n",
        bins_size.0, bins_size.1
    )?;
    report.sections.push_str(&md);
    Ok(())
}

/// A bumpy heightfield of n×n quads (2n² triangles).
fn terrain(n: u32) -> geometry::Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
            positions.push(glam::Vec3::new(x, 0.1 * (7.0 * x).sin() * (5.0 * z).cos(), z));
        }
    }
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            indices.push([a, a + n + 1, a + 1]);
            indices.push([a + 1, a + n + 1, a + n + 2]);
        }
    }
    geometry::Mesh::new(positions, None, None, indices, None).expect("finite terrain")
}
