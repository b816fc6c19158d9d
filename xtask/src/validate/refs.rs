//! Converged reference images, rendered by the project itself at high spp and cached on disk
//! (default `target/validate-refs/`, `--refs DIR`), regenerated with `--regen` or whenever the
//! cached file does not match what is asked (its key or size differ, or it is unreadable).
//!
//! These are used only where no analytic answer exists; analytic answers always win.
//! A file is a text header line `spectrace-validate-ref 1\t<key>\t<width>\t<height>\n` followed
//! by width × height × 3 little-endian `f32` XYZ values, row-major (the film's layout). A PNG
//! of the reference is written beside it, for a person to look at.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use integrator::{Display, Image};

const MAGIC: &str = "spectrace-validate-ref 1";

/// A converged reference: XYZ pixels (white Y = 1), and whether this run rendered it.
#[derive(Debug)]
pub(crate) struct Reference {
    pub(crate) pixels: Vec<[f32; 3]>,
    /// `Some(seconds)` when this run rendered it, `None` when read from the cache.
    pub(crate) rendered_in: Option<f64>,
    /// Where it is stored.
    pub(crate) path: PathBuf,
}

/// The cache folder and whether to ignore what is in it.
#[derive(Debug)]
pub(crate) struct RefCache {
    dir: PathBuf,
    regen: bool,
}

impl RefCache {
    pub(crate) fn new(dir: PathBuf, regen: bool) -> anyhow::Result<Self> {
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(Self { dir, regen })
    }

    /// The reference named `key` (it must describe everything the image depends on: scene,
    /// size, integrator, strategy, spp, seed), from the cache or rendered by `make`.
    pub(crate) fn get(
        &self,
        key: &str,
        (width, height): (u32, u32),
        make: impl FnOnce() -> anyhow::Result<Image>,
    ) -> anyhow::Result<Reference> {
        let stem: String = key.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
        let path = self.dir.join(format!("{stem}.ref"));
        if !self.regen
            && let Some(pixels) = read(&path, key, width, height)
        {
            return Ok(Reference { pixels, rendered_in: None, path });
        }
        let start = Instant::now();
        let image = make()?;
        let seconds = start.elapsed().as_secs_f64();
        anyhow::ensure!(
            (image.width(), image.height()) == (width, height),
            "reference {key}: rendered {}×{}, expected {width}×{height}",
            image.width(),
            image.height()
        );
        write(&path, key, &image)?;
        image.write_png(&path.with_extension("png"), Display::Srgb)?;
        Ok(Reference { pixels: image.pixels().to_vec(), rendered_in: Some(seconds), path })
    }
}

/// The cached pixels if the file exists and matches key and size exactly.
fn read(path: &Path, key: &str, width: u32, height: u32) -> Option<Vec<[f32; 3]>> {
    let bytes = std::fs::read(path).ok()?;
    let newline = bytes.iter().position(|b| *b == b'\n')?;
    let header = std::str::from_utf8(&bytes[..newline]).ok()?;
    if header != format!("{MAGIC}\t{key}\t{width}\t{height}") {
        return None;
    }
    let data = &bytes[newline + 1..];
    if data.len() != width as usize * height as usize * 12 {
        return None;
    }
    let values: Vec<f32> = data.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    Some(values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// Write through a temporary file and a rename, so an interrupted run leaves no half file.
fn write(path: &Path, key: &str, image: &Image) -> anyhow::Result<()> {
    let mut bytes = format!("{MAGIC}\t{key}\t{}\t{}\n", image.width(), image.height()).into_bytes();
    for p in image.pixels() {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let tmp = path.with_extension("ref.tmp");
    std::fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_round_trips_and_rejects_other_keys() {
        let dir = crate::project_root().join("target/test-output/validate-refs-unit");
        let mut calls = 0;
        let mut make = || {
            calls += 1;
            Ok(Image::new(3, 2))
        };
        // --regen renders whatever is cached from an earlier run.
        let first = RefCache::new(dir.clone(), true).expect("cache dir").get("unit test key", (3, 2), &mut make);
        let first = first.expect("rendered");
        let cache = RefCache::new(dir, false).expect("cache dir");
        let second = cache.get("unit test key", (3, 2), &mut make).expect("cached");
        assert_eq!(second.rendered_in, None, "the second call reads the cache");
        assert_eq!(first.pixels, second.pixels);
        // Same file name (the space and the colon both map to '_'), different key: rendered again.
        let third = cache.get("unit:test key", (3, 2), &mut make).expect("re-rendered");
        assert!(third.rendered_in.is_some());
        assert_eq!(calls, 2);
    }
}
