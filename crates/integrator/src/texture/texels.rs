//! The decoded form every texture image takes, whatever its file format.

/// An image decoded to 8-bit RGBA as stored (sRGB-encoded or linear, as its role says).
#[derive(Debug)]
pub(crate) struct Image8 {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) texels: Vec<[u8; 4]>,
}
