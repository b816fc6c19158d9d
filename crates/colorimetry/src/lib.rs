//! `colorimetry`: in progress.
