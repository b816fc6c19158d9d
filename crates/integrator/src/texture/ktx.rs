//! KTX 2.0 images (glTF `KHR_texture_basisu`, and textures that name a `.ktx2` file directly) whose texels
//! are stored as plain 8-bit channels, raw or Zstandard-supercompressed: what `toktx --zcmp` and
//! glTF Transform's `ktxfix`/`uastc --zstd` pipelines leave when the texture is not transcoded to a GPU
//! block format (the Khronos *AnisotropyBarnLamp* sample's data textures are `R8G8B8_UNORM` + zstd). Basis
//! Universal (ETC1S/UASTC) and block-compressed formats are not decoded (a warning with a way forward): they
//! need a transcoder, which has no maintained pure-Rust implementation.
//!
//! Only the base level of a 2D image is read (the renderer has no mip-maps). The header and level index are
//! read here with checked arithmetic (the `ktx2` crate was tried first: it panics on a malformed data format
//! descriptor, which this reader does not need); zstd is decoded by `ruzstd`, its output capped at the size
//! the header implies and its window at that size, so a forged stream cannot expand past it.

use std::io::Read;

use geometry::{ImageDesc, MemoryBudget};

use crate::texture::texels::Image8;

/// The KTX 2.0 file identifier (KTX 2.0 specification §3.1): «KTX 20»\r\n\x1A\n.
const IDENTIFIER: [u8; 12] = [0xAB, b'K', b'T', b'X', b' ', b'2', b'0', 0xBB, b'\r', b'\n', 0x1A, b'\n'];

/// Bytes of the header and its section index (§3.1–3.3), before the level index.
const HEADER_BYTES: usize = 80;

/// Smallest zstd window the decoder is allowed (bytes); a frame that asks for more than the level's own size
/// (rounded up to a power of two, at least this) is refused before the window is allocated: an encoder never
/// needs a window larger than its input.
const MIN_WINDOW: u64 = 1 << 20;

/// Whether `bytes` is a KTX 2.0 file.
pub(crate) fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&IDENTIFIER)
}

/// Channels per texel and whether they are stored blue first, for the 8-bit VkFormats that are decoded
/// (`_UNORM` and `_SRGB` alike: the bytes are kept as stored).
fn layout(vk_format: u32) -> Option<(usize, bool)> {
    Some(match vk_format {
        9 | 15 => (1, false),  // R8
        16 | 22 => (2, false), // R8G8
        23 | 29 => (3, false), // R8G8B8
        30 | 36 => (3, true),  // B8G8R8
        37 | 43 => (4, false), // R8G8B8A8
        44 | 50 => (4, true),  // B8G8R8A8
        _ => return None,
    })
}

/// The header fields and the base level this decoder reads; `None` for a file too short for them.
struct Header {
    vk_format: u32,
    width: u32,
    height: u32,
    depth: u32,
    layers: u32,
    faces: u32,
    supercompression: u32,
    /// Byte offset and length of level 0 (the base level: the level index lists the largest first).
    level: (u64, u64),
}

impl Header {
    fn read(bytes: &[u8]) -> Option<Self> {
        let u32_at = |at: usize| Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?));
        let u64_at = |at: usize| Some(u64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?));
        Some(Self {
            vk_format: u32_at(12)?,
            width: u32_at(20)?,
            height: u32_at(24)?,
            depth: u32_at(28)?,
            layers: u32_at(32)?,
            faces: u32_at(36)?,
            supercompression: u32_at(44)?,
            level: (u64_at(HEADER_BYTES)?, u64_at(HEADER_BYTES + 8)?),
        })
    }
}

/// The base level of the KTX2 image `image` as RGBA8 (one channel → grey, two → grey + alpha as PNG does;
/// a missing alpha is 255). `Ok(None)` with a warning for what is not decoded or is malformed; an error only
/// when the texels would pass the scene's memory budget (charged before decompression: the decompressed
/// level and the zstd window as working memory, the kept texels for good). The bytes are kept as stored:
/// whether they are sRGB is the texture role's decision, as for PNG (glTF defines it per role, not per file).
/// The header, the level index and the level's bounds are read here with checked arithmetic; the data
/// format descriptor is not needed (the VkFormat says all) and not parsed.
pub(crate) fn decode_ktx2(
    image: &ImageDesc,
    max_side: u32,
    memory: &mut MemoryBudget,
    warnings: &mut Vec<String>,
) -> geometry::Result<Option<Image8>> {
    let skip = |why: String, warnings: &mut Vec<String>| {
        warnings.push(format!("{}: KTX2 {why}; the material's factor is used", image.label));
        Ok(None)
    };
    let bytes = &image.bytes[..];
    let Some(header) = Header::read(bytes).filter(|_| is_ktx2(bytes)) else {
        return skip("file is too short for its header or not KTX 2.0".to_owned(), warnings);
    };
    let Some((channels, bgr)) = layout(header.vk_format) else {
        let format = match header.vk_format {
            0 => "VK_FORMAT_UNDEFINED (Basis Universal)".to_owned(),
            n => format!("VkFormat {n}"),
        };
        return skip(
            format!(
                "format {format} is not decoded (only 8-bit R, RG, RGB, BGR, RGBA, BGRA, raw or zstd); transcode it, e.g. `ktx transcode --target rgba8 IN OUT` or `gltf-transform ktxdecompress IN OUT`"
            ),
            warnings,
        );
    };
    if header.depth > 1 || header.layers > 1 || header.faces > 1 {
        return skip("3D, array or cube-map texture is not decoded".to_owned(), warnings);
    }
    let (width, height) = (header.width, header.height.max(1));
    if width == 0 || width > max_side || height > max_side {
        return skip(format!("{width}×{height} texels: not within 1–{max_side} a side"), warnings);
    }
    let (offset, length) = header.level;
    let Some(data) =
        offset.checked_add(length).and_then(|end| bytes.get(usize::try_from(offset).ok()?..usize::try_from(end).ok()?))
    else {
        return skip("base level lies outside the file".to_owned(), warnings);
    };
    let expected = u64::from(width) * u64::from(height) * channels as u64;
    let kept = u64::from(width) * u64::from(height) * 4;
    let window = expected.next_power_of_two().max(MIN_WINDOW);
    let zstd = header.supercompression == 2;
    let path = std::path::Path::new(&image.label);
    let what = || format!("decoding a {width}×{height} KTX2 image (VkFormat {})", header.vk_format);
    memory.fits(path, what, expected.saturating_add(kept).saturating_add(if zstd { window } else { 0 }))?;
    memory.charge(path, what, kept)?;
    let texels = match header.supercompression {
        0 => data.get(..expected as usize).map(<[u8]>::to_vec),
        2 => match ruzstd::decoding::StreamingDecoder::new_with_max_window_size(data, window) {
            Ok(decoder) => {
                // One byte past the expected length tells a stream that is too long.
                let mut out = Vec::with_capacity(expected as usize);
                match decoder.take(expected + 1).read_to_end(&mut out) {
                    Ok(_) if out.len() as u64 == expected => Some(out),
                    Ok(_) => None,
                    Err(e) => return skip(format!("zstd data cannot be decoded ({e})"), warnings),
                }
            }
            Err(e) => return skip(format!("zstd data cannot be decoded ({e})"), warnings),
        },
        1 => return skip("BasisLZ supercompression is not decoded (transcode it, as above)".to_owned(), warnings),
        n => return skip(format!("supercompression scheme {n} is not decoded"), warnings),
    };
    let Some(texels) = texels else {
        return skip(format!("base level does not hold {width}×{height} texels of {channels} byte(s)"), warnings);
    };
    let texels = texels
        .chunks_exact(channels)
        .map(|c| match (c, bgr) {
            ([g], _) => [*g, *g, *g, 255],
            ([g, a], _) => [*g, *g, *g, *a],
            ([r, g, b], false) | ([b, g, r], true) => [*r, *g, *b, 255],
            ([r, g, b, a], false) | ([b, g, r, a], true) => [*r, *g, *b, *a],
            _ => unreachable!("chunks of 1–4 bytes"),
        })
        .collect();
    Ok(Some(Image8 { width, height, texels }))
}

#[cfg(test)]
pub(crate) mod tests {
    use std::sync::Arc;

    use super::*;

    /// A KTX2 file of one 2D level: `format` (a VkFormat), `texels` as stored, zstd-compressed when `zstd`.
    /// Its data format descriptor is empty (the reader needs only its length field).
    pub(crate) fn ktx2_file(format: u32, width: u32, height: u32, texels: &[u8], zstd: bool) -> Vec<u8> {
        let data = if zstd {
            ruzstd::encoding::compress_to_vec(texels, ruzstd::encoding::CompressionLevel::Fastest)
        } else {
            texels.to_vec()
        };
        let (dfd_offset, data_offset) = (104u32, 112u64);
        let mut out = IDENTIFIER.to_vec();
        // vkFormat, typeSize, width, height, depth, layers, faces, levels, supercompression.
        for v in [format, 1, width, height, 0, 0, 1, 1, if zstd { 2 } else { 0 }] {
            out.extend(v.to_le_bytes());
        }
        // DFD offset and length, KVD offset and length (none), SGD offset and length (none).
        for v in [dfd_offset, 4, 0, 0] {
            out.extend(v.to_le_bytes());
        }
        out.extend([0u8; 16]);
        for v in [data_offset, data.len() as u64, texels.len() as u64] {
            out.extend(v.to_le_bytes());
        }
        out.extend(4u32.to_le_bytes());
        out.resize(data_offset as usize, 0);
        out.extend(&data);
        out
    }

    fn decode(bytes: Vec<u8>) -> (Option<Image8>, Vec<String>) {
        let image = ImageDesc { label: "t.ktx2".into(), mime: None, bytes: Arc::from(bytes) };
        let mut warnings = Vec::new();
        let mut memory = MemoryBudget::new(1 << 30);
        let decoded = decode_ktx2(&image, 16_384, &mut memory, &mut warnings).expect("within budget");
        (decoded, warnings)
    }

    #[test]
    fn raw_and_zstd_levels_decode_to_the_stored_texels() {
        // 3×2 RGB (VK_FORMAT_R8G8B8_UNORM = 23), as the barn lamp's textures.
        let rgb: Vec<u8> = (0..18u8).map(|i| i * 13).collect();
        for zstd in [false, true] {
            let (image, warnings) = decode(ktx2_file(23, 3, 2, &rgb, zstd));
            let image = image.unwrap_or_else(|| panic!("{warnings:?}"));
            assert_eq!((image.width, image.height), (3, 2));
            for (t, texel) in image.texels.iter().enumerate() {
                assert_eq!(*texel, [rgb[3 * t], rgb[3 * t + 1], rgb[3 * t + 2], 255], "texel {t}, zstd {zstd}");
            }
        }
        // BGRA (VK_FORMAT_B8G8R8A8_SRGB = 50) is reordered, grey + alpha (R8G8 = 16) spread.
        let (image, _) = decode(ktx2_file(50, 1, 1, &[1, 2, 3, 4], true));
        assert_eq!(image.expect("BGRA").texels, vec![[3, 2, 1, 4]]);
        let (image, _) = decode(ktx2_file(16, 1, 1, &[9, 200], false));
        assert_eq!(image.expect("RG").texels, vec![[9, 9, 9, 200]]);
    }

    #[test]
    fn undecoded_formats_and_malformed_files_are_warnings_not_panics() {
        // A data format descriptor a reader would choke on (texel block dimensions of 255) is not read.
        let mut odd = ktx2_file(23, 1, 1, &[1, 2, 3], false);
        // A basic block's first words (vendor/type, version/size, model/primaries/transfer/flags), then texel
        // block dimensions of 255 each and empty planes.
        let block: Vec<u8> = [[0u8; 4], [2, 0, 40, 0], [1, 1, 0, 0], [255; 4], [0; 4], [0; 4]].concat();
        let total = 4 + block.len() as u32;
        odd.splice(104..108, total.to_le_bytes().into_iter().chain(block));
        odd[52..56].copy_from_slice(&total.to_le_bytes());
        let level = u64::from_le_bytes(odd[80..88].try_into().unwrap()) + u64::from(total) - 4;
        odd[80..88].copy_from_slice(&level.to_le_bytes());
        let (image, warnings) = decode(odd);
        assert_eq!(image.map(|i| i.texels), Some(vec![[1, 2, 3, 255]]), "{warnings:?}");
        // Basis Universal (VK_FORMAT_UNDEFINED = 0) and BC7 (145) name a way forward.
        for format in [0, 145] {
            let (image, warnings) = decode(ktx2_file(format, 4, 4, &[0; 16], false));
            assert!(image.is_none());
            assert!(warnings.iter().any(|w| w.contains("ktxdecompress")), "{warnings:?}");
        }
        // A level shorter than the header says, and a zstd stream that decodes to too many bytes.
        let (image, warnings) = decode(ktx2_file(23, 4, 4, &[7; 47], false));
        assert!(image.is_none() && warnings.iter().any(|w| w.contains("does not hold 4×4")), "{warnings:?}");
        let mut long = ktx2_file(23, 1, 1, &[7; 300], true);
        long[20..24].copy_from_slice(&1u32.to_le_bytes());
        let (image, warnings) = decode(long);
        assert!(image.is_none() && warnings.iter().any(|w| w.contains("does not hold 1×1")), "{warnings:?}");
        // Every truncation and every single-byte corruption of a valid file decodes or warns.
        let valid = ktx2_file(23, 5, 3, &(0..45u8).collect::<Vec<_>>(), true);
        for cut in 0..valid.len() {
            let (image, warnings) = decode(valid[..cut].to_vec());
            assert!(image.is_some() || !warnings.is_empty(), "cut at {cut}");
        }
        for at in 0..valid.len() {
            for flip in [0x01u8, 0x80, 0xff] {
                let mut bytes = valid.clone();
                bytes[at] ^= flip;
                let (image, warnings) = decode(bytes);
                assert!(image.is_some() || !warnings.is_empty(), "byte {at} ^ {flip:#x}");
            }
        }
    }
}
