//! `spectrace color`: colour math from the command line (owned by the colorimetry work).

use std::path::PathBuf;

/// Arguments of `spectrace color`.
#[derive(Debug, clap::Args)]
pub(crate) struct ColorArgs {
    /// CSV file: header line, first column wavelength in nm, one column per spectrum.
    reflectance: PathBuf,
}

pub(crate) fn run(args: &ColorArgs) -> anyhow::Result<()> {
    anyhow::bail!("{}: `spectrace color` is not implemented yet", args.reflectance.display())
}
