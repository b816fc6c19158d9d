//! Scenes and ray sets shared by the geometry benchmarks, the integration tests
//! (`tests/it/main.rs` includes this file, and the integrator's `tests/it/terminator.rs`) and the
//! `trace_exported` example, so they trace the same generated geometry; and the exported ray
//! sets' writer and reader, side by side.
#![allow(dead_code)] // each benchmark (and the tests) uses a part of it

use std::io::Write;
use std::path::Path;

use geometry::{Camera, Mesh, Ray, Scene, load_scene, spawn_ray};
use glam::Vec3;

/// A bumpy heightfield of `n`×`n` quads (2n² triangles): a terrain seen from above.
pub(crate) fn terrain(n: u32) -> Mesh {
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
            let y = 0.1 * (7.0 * x).sin() * (5.0 * z).cos() + 0.03 * (31.0 * x + 17.0 * z).sin();
            positions.push(Vec3::new(x, y, z));
        }
    }
    let mut indices = Vec::with_capacity((2 * n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            indices.push([a, c, b]);
            indices.push([b, c, d]);
        }
    }
    Mesh::new(positions, None, None, indices, None).unwrap()
}

/// A closed icosphere of radius `r` centred at `c`: 20·4ⁿ triangles sharing edges and vertices.
pub(crate) fn icosphere(subdivisions: u32, c: Vec3, r: f32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from_array(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    let positions = v.iter().map(|p| c + *p * r).collect();
    Mesh::new(positions, None, None, f, None).unwrap()
}

/// A deterministic stream of numbers in [0, 1) (xorshift; benchmarks and tests must not depend
/// on a crate's RNG).
pub(crate) struct Xorshift(pub(crate) u64);
impl Xorshift {
    pub(crate) fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `scenes/reference/cornell_box.json` as the renderer loads it (five walls and the lamp as
/// quads, 12 triangles, and two spheres), and its camera. The path tracer's small-scene regime:
/// a tree of one node, where a ray's fixed cost (set-up, dispatch, hit record) is most of its
/// traversal time.
pub(crate) fn cornell_box() -> (Scene, Camera) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/reference/cornell_box.json");
    let desc = load_scene(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let c = desc.camera.expect("the Cornell box's manifest has a camera");
    let camera = Camera::look_at(c.position, c.look_at, c.up, c.vfov_deg, 1.0).unwrap();
    (Scene::build(desc.spheres, desc.meshes).unwrap(), camera)
}

/// Primary rays (1024² pixel centres) and incoherent rays (one cosine bounce per hit) from the
/// terrain's and icosphere's camera.
pub(crate) fn rays(scene: &Scene) -> (Vec<Ray>, Vec<Ray>) {
    rays_from(scene, &Camera::look_at(Vec3::new(0.0, 1.6, 1.6), Vec3::ZERO, Vec3::Y, 50.0, 1.0).unwrap())
}

/// Primary rays through 1024² pixel centres of `camera`, and one cosine-weighted bounce from
/// every primary hit.
pub(crate) fn rays_from(scene: &Scene, camera: &Camera) -> (Vec<Ray>, Vec<Ray>) {
    let (w, h) = (1024u32, 1024u32);
    let primary: Vec<Ray> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h))
        .collect();
    // Incoherent: cosine-weighted hemisphere directions from every primary hit, spawned robustly.
    let mut rng = Xorshift(0x2545_F491_4F6C_DD1D);
    let mut incoherent = Vec::new();
    for r in &primary {
        if let Some(hit) = scene.intersect(r, f32::INFINITY) {
            let (u1, u2) = (rng.next(), rng.next());
            let (rad, phi) = (u1.sqrt(), std::f32::consts::TAU * u2);
            let n = if hit.n.dot(r.dir) < 0.0 { hit.n } else { -hit.n };
            let (t, b) = n.any_orthonormal_pair();
            let dir = t * (rad * phi.cos()) + b * (rad * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt();
            incoherent.push(spawn_ray(&hit, dir));
        }
    }
    (primary, incoherent)
}

fn write_f32(path: &std::path::Path, values: impl Iterator<Item = f32>) {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    for v in values {
        out.write_all(&v.to_le_bytes()).unwrap();
    }
}

/// What [`export`] wrote for scene `name` in `dir`: its triangles (three vertices each) and its
/// `kind` ("primary" or "incoherent") rays. An error names the file that is missing or whose
/// length is not whole triangles or rays.
pub(crate) fn read_exported(dir: &str, name: &str, kind: &str) -> Result<(Vec<[Vec3; 3]>, Vec<Ray>), String> {
    let read = |file: String, per: usize| -> Result<Vec<f32>, String> {
        let path = Path::new(dir).join(file);
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        if bytes.len() % (4 * per) != 0 {
            return Err(format!("{}: {} bytes, not a whole number of {per} f32", path.display(), bytes.len()));
        }
        Ok(bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    };
    let v = |c: &[f32]| Vec3::from_slice(c);
    let tris =
        read(format!("{name}.tris"), 9)?.chunks_exact(9).map(|c| [v(&c[..3]), v(&c[3..6]), v(&c[6..])]).collect();
    let rays = read(format!("{name}_{kind}.rays"), 6)?
        .chunks_exact(6)
        .map(|c| Ray { origin: v(&c[..3]), dir: v(&c[3..]) })
        .collect();
    Ok((tris, rays))
}

pub(crate) fn export(dir: &str, name: &str, mesh: &Mesh, primary: &[Ray], incoherent: &[Ray], hits: &str) {
    let dir = std::path::Path::new(dir);
    std::fs::create_dir_all(dir).unwrap();
    let p = mesh.positions();
    write_f32(
        &dir.join(format!("{name}.tris")),
        mesh.indices().iter().flat_map(|t| t.map(|i| p[i as usize])).flat_map(|v| v.to_array()),
    );
    for (kind, rays) in [("primary", primary), ("incoherent", incoherent)] {
        write_f32(
            &dir.join(format!("{name}_{kind}.rays")),
            rays.iter().flat_map(|r| [r.origin.to_array(), r.dir.to_array()]).flatten(),
        );
    }
    std::fs::write(dir.join(format!("{name}.hits.json")), hits).unwrap();
}

/// A named scene generator.
pub(crate) type SceneMaker = (&'static str, fn() -> Mesh);

/// The benchmark scenes: 2·224² ≈ 100k and 2·708² ≈ 1.0M terrain triangles, a closed
/// 20·4⁸ = 1,310,720-triangle icosphere.
pub(crate) const SCENES: [SceneMaker; 3] = [
    ("terrain_100k", || terrain(224)),
    ("terrain_1m", || terrain(708)),
    ("icosphere_1_3m", || icosphere(8, Vec3::ZERO, 1.0)),
];

/// Small terrains (2·32² = 2k and 2·70² ≈ 10k triangles, whose trees fit in L1 and L2) for
/// `traversal_table`: whether a gap to Embree is a matter of memory (it would shrink here) or of
/// the work per node and leaf (it would not).
pub(crate) const SMALL_SCENES: [SceneMaker; 2] = [("terrain_2k", || terrain(32)), ("terrain_10k", || terrain(70))];

/// CPU time this thread has run, in seconds (`/proc/thread-self/schedstat`, Linux): on a
/// shared machine it leaves out the time other processes hold the core, which wall time
/// does not. `None` elsewhere.
pub(crate) fn thread_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(s.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
}
