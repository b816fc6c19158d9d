//! `cargo xtask exr-diff A.exr B.exr`: the largest difference between two OpenEXR files with
//! the same layers and channels, for showing that a change moved no rendered number (or by
//! how little). Used by `xtask/compare/same_renders.sh` when two files differ in bytes.

use std::path::PathBuf;

use anyhow::{Context as _, bail};

/// Arguments of `exr-diff`.
#[derive(Debug, clap::Args)]
pub(crate) struct ExrDiffArgs {
    /// The reference image.
    a: PathBuf,
    /// The image compared with it.
    b: PathBuf,
}

pub(crate) fn run(args: &ExrDiffArgs) -> anyhow::Result<()> {
    let read = |p: &PathBuf| {
        exr::prelude::read_all_flat_layers_from_file(p).with_context(|| format!("reading {}", p.display()))
    };
    let (a, b) = (read(&args.a)?, read(&args.b)?);
    let (mut max_abs, mut max_rel, mut differing, mut total) = (0.0f64, 0.0f64, 0usize, 0usize);
    if a.layer_data.len() != b.layer_data.len() {
        bail!("different layer counts");
    }
    for (la, lb) in a.layer_data.iter().zip(&b.layer_data) {
        if la.channel_data.list.len() != lb.channel_data.list.len() {
            bail!("different channel counts");
        }
        for (ca, cb) in la.channel_data.list.iter().zip(&lb.channel_data.list) {
            if ca.name != cb.name {
                bail!("channel {} vs {}", ca.name, cb.name);
            }
            let (va, vb): (Vec<f32>, Vec<f32>) =
                (ca.sample_data.values_as_f32().collect(), cb.sample_data.values_as_f32().collect());
            if va.len() != vb.len() {
                bail!("channel {}: different sizes", ca.name);
            }
            for (x, y) in va.iter().zip(&vb) {
                total += 1;
                if x.to_bits() != y.to_bits() {
                    differing += 1;
                    let d = f64::from((x - y).abs());
                    max_abs = max_abs.max(d);
                    let scale = f64::from(x.abs().max(y.abs()));
                    if scale > 0.0 {
                        max_rel = max_rel.max(d / scale);
                    }
                }
            }
        }
    }
    println!("{differing} of {total} values differ; max abs {max_abs:.3e}, max rel {max_rel:.3e}");
    Ok(())
}
