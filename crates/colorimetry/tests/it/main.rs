//! Integration tests of the colorimetry crate against independent and published data.

mod colorchecker;
mod csv_files;
