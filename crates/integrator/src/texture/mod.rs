//! Image textures: decoded once at assembly, looked up per hit.
//!
//! A colour texture (base colour, specular colour) becomes spectra at load time: each distinct RGBA texel of
//! the image, multiplied by the material's factor in linear RGB, is fitted once to a
//! Jakob–Hanika sigmoid ([`RgbSigmoid::refined`], ΔE00 below 0.001 round trip under D65) and
//! the image keeps a palette index per texel. A hit then reads up to four indices (bilinear)
//! and evaluates four sigmoids at the path's wavelengths: the blend of the texels' spectra,
//! which is the reflectance of a surface covered by the texels in those proportions.
//! Data textures (metallic–roughness, normal maps, coverage) keep their linear bytes.
//!
//! Addressing follows glTF 2.0: uv (0, 0) is the image's top-left corner, texel centres at
//! half-integers, `KHR_texture_transform` applied before wrapping (`docs/scene-format.md`).

use std::collections::HashMap;
use std::io::Cursor;
use std::sync::Arc;

use colorimetry::{RgbSigmoid, RgbUnboundedSpectrum, SampledSpectrum, SampledWavelengths, srgb_decode};
use geometry::{AlphaMode, ImageDesc, MaterialDesc, MemoryBudget, TextureDesc, WrapMode};
use glam::{Vec2, Vec3, Vec4};
use materials::Coat;

use rayon::prelude::*;

use crate::surface::HitTangent;

mod ktx;
mod shared;
mod texels;

pub(crate) use texels::Image8;

/// Largest image side decoded (pixels): 16 K, the largest texture GPUs address; beyond it a
/// file is more likely a memory bomb than a texture.
const MAX_IMAGE_SIDE: u32 = 16_384;

/// Bytes the decoder may allocate for one image: an RGBA 16-bit 16 K² image is 2 GiB, so an
/// 8-bit one fits and a hostile header cannot ask for more.
const MAX_DECODE_BYTES: u64 = 1 << 30;

/// Distinct colours of one texture fitted exactly ([`RgbSigmoid::refined`], about 11 µs each on
/// one core when this bound was set, about half that since its sigmoid runs in vector lanes;
/// ΔE00 < 0.001). Beyond, the texture takes the table lookup ([`RgbSigmoid::from_rgb`],
/// a few ns; ΔE00 mean 0.045, max 1.2) with a warning: a 4096² image of noise has 13 M distinct
/// colours, 210 s to fit on this project's 2-core machine then; photographs and paintings of
/// 2048² have a few hundred thousand (FlightHelmet's 15 images: 1.1 s in all then).
pub(crate) const MAX_REFINED_COLOURS: usize = 1 << 20;

/// Images passed through a surface before a path stops treating further cut-outs as holes:
/// stacked foliage cards rarely exceed a few dozen, and a bound keeps a pathological file
/// from looping.
pub(crate) const MAX_ALPHA_SKIPS: u32 = 256;

/// Working bytes per texel of the hash table that finds a colour texture's distinct colours, at most
/// (every texel distinct): a hashbrown bucket of key `[u8; 4]` and value `u32` (8 bytes) plus its
/// control byte, at ≥ 8/7 buckets per entry, with the old and the doubled table both alive while it
/// grows (3 × 9 × 8/7 ≈ 31), and the list of distinct colours (4, twice while it grows).
const COLOUR_COUNT_BYTES_PER_TEXEL: u64 = 40;

/// Bytes per texel of [`Image8`].
const IMAGE8_BYTES_PER_TEXEL: u64 = 4;

/// Decodes `image` (PNG, JPEG, WebP or an 8-bit KTX2 ([`ktx`]), chosen by content) with bounded dimensions and allocation; 16-bit
/// channels are reduced to 8 bits (a warning names the image). The decoded size is read from the
/// header and charged to `memory` before any texel is decoded: the decoder's output and the 8-bit
/// copy as working memory, the kept texels for good. `Ok(None)` (with a warning) for an image that
/// cannot be decoded; an error only when it would pass the scene's memory budget.
fn decode(
    image: &ImageDesc,
    memory: &mut MemoryBudget,
    warnings: &mut Vec<String>,
) -> geometry::Result<Option<Image8>> {
    use image::ImageDecoder;
    if ktx::is_ktx2(&image.bytes) {
        return ktx::decode_ktx2(image, MAX_IMAGE_SIDE, memory, warnings);
    }
    let skip = |e: &dyn std::fmt::Display, warnings: &mut Vec<String>| {
        warnings.push(format!("{}: cannot decode ({e}); the material's factor is used", image.label));
        Ok(None)
    };
    let mut reader = match image::ImageReader::new(Cursor::new(&image.bytes[..])).with_guessed_format() {
        Ok(reader) => reader,
        Err(e) => return skip(&e, warnings),
    };
    if reader.format() == Some(image::ImageFormat::Jpeg) && !jpeg_is_complete(&image.bytes) {
        return skip(&"truncated: the JPEG data ends before its end-of-image marker", warnings);
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    reader.limits(limits);
    let decoder = match reader.into_decoder() {
        Ok(decoder) => decoder,
        Err(e) => return skip(&e, warnings),
    };
    let (width, height) = decoder.dimensions();
    if width == 0 || height == 0 {
        warnings.push(format!("{}: empty image; the material's factor is used", image.label));
        return Ok(None);
    }
    let color = decoder.color_type();
    let kept = u64::from(width) * u64::from(height) * IMAGE8_BYTES_PER_TEXEL;
    let path = std::path::Path::new(&image.label);
    let what = || format!("decoding a {width}×{height} {color:?} image");
    memory.fits(path, what, decoder.total_bytes().saturating_add(2 * kept))?;
    memory.charge(path, what, kept)?;
    let decoded = match image::DynamicImage::from_decoder(decoder) {
        Ok(decoded) => decoded,
        Err(e) => return skip(&e, warnings),
    };
    if color.bytes_per_pixel() > color.channel_count() {
        warnings.push(format!("{}: {color:?} texels read at 8 bits per channel", image.label));
    }
    // `into_rgba8` keeps the buffer when the image is RGBA8 already.
    let texels = decoded.into_rgba8().into_raw().chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
    Ok(Some(Image8 { width, height, texels }))
}

/// Whether a JPEG stream (`bytes` from its start-of-image marker) reaches its end-of-image marker
/// (FF D9). The decoder fills the rows of a file cut short with grey and reports no error, so this is
/// what tells a truncated file from a whole one. The walk skips each marker segment by its length (an
/// EXIF thumbnail's own FF D9 inside APP1 is passed over) and, in the entropy-coded data after a start of
/// scan, skips stuffed bytes (FF 00), fill bytes (FF FF) and restart markers (FF D0–D7); whatever follows
/// the end-of-image marker (padding, appended data) is not read.
fn jpeg_is_complete(bytes: &[u8]) -> bool {
    let mut i = 2;
    while i + 1 < bytes.len() {
        if bytes[i] != 0xFF {
            i += 1;
            continue;
        }
        match bytes[i + 1] {
            0xD9 => return true,
            // Fill byte: the marker code follows.
            0xFF => i += 1,
            // A stuffed FF, a restart marker, a second SOI or TEM: no length follows.
            0x00 | 0xD0..=0xD8 | 0x01 => i += 2,
            _ => {
                let Some(length) = bytes.get(i + 2..i + 4) else { return false };
                i += 2 + usize::from(u16::from_be_bytes([length[0], length[1]]));
            }
        }
    }
    false
}

/// Where a texture is read: its size, wrap modes, filter and uv transform.
#[derive(Debug, Clone, Copy)]
struct Sampler {
    width: u32,
    height: u32,
    wrap: [WrapMode; 2],
    nearest: bool,
    /// Rows of the 2×3 affine map uv → uv' (`KHR_texture_transform`), identity when absent.
    transform: [[f32; 3]; 2],
    /// Whether the texture reads the mesh's second uv set ([`Uv::second`]): its `tex_coord` is 1 once the
    /// assembly has numbered the material's sets 0 (primary) and 1.
    second: bool,
}

/// A hit's uvs in both of its mesh's sets: `primary` (the hit record's `uv`) and `second` (the mesh's second
/// set, the primary one where it has none). Each texture reads the set it addresses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Uv {
    pub(crate) primary: Vec2,
    pub(crate) second: Vec2,
}

#[cfg(test)]
impl From<Vec2> for Uv {
    /// [`Uv::same`].
    fn from(uv: Vec2) -> Self {
        Self::same(uv)
    }
}

impl Uv {
    /// The same uv for both sets: a mesh with one set.
    #[inline]
    pub(crate) fn same(uv: Vec2) -> Self {
        Self { primary: uv, second: uv }
    }
}

impl Sampler {
    fn new(desc: &TextureDesc, width: u32, height: u32) -> Self {
        let transform = match desc.transform {
            // glTF: T · R · S with R = [[cos, sin], [−sin, cos]] acting on (u, v).
            Some(t) => {
                let (s, c) = t.rotation.sin_cos();
                [[c * t.scale[0], s * t.scale[1], t.offset[0]], [-s * t.scale[0], c * t.scale[1], t.offset[1]]]
            }
            None => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        };
        Self { width, height, wrap: desc.wrap, nearest: desc.nearest, transform, second: desc.tex_coord == 1 }
    }

    /// The uv of the set this texture reads.
    #[inline]
    fn pick(&self, uv: Uv) -> Vec2 {
        if self.second { uv.second } else { uv.primary }
    }

    /// The steps in u and in v that move one texel across the image (through the uv transform): where a
    /// bump map's height is differenced.
    fn texel_step(&self) -> (f32, f32) {
        let [r0, r1] = self.transform;
        let (w, h) = (self.width as f32, self.height as f32);
        let step = |a: f32, b: f32| {
            let texels = (w * a).hypot(h * b);
            if texels > 0.0 && texels.is_finite() { 1.0 / texels } else { 1.0 / w.max(h) }
        };
        (step(r0[0], r1[0]), step(r0[1], r1[1]))
    }

    /// The texels under `uv` (in the set this texture reads) and their weights (bilinear; nearest puts all
    /// weight on one).
    #[inline]
    fn footprint(&self, uv: Uv) -> [(usize, f32); 4] {
        let uv = self.pick(uv);
        let [r0, r1] = self.transform;
        let u = r0[0] * uv.x + r0[1] * uv.y + r0[2];
        let v = r1[0] * uv.x + r1[1] * uv.y + r1[2];
        // A non-finite coordinate (overflowing transform) reads the first texel.
        let (u, v) = if u.is_finite() && v.is_finite() { (u, v) } else { (0.0, 0.0) };
        let (w, h) = (self.width as i64, self.height as i64);
        // Clamped to ±2⁵², where every f64 is an integer and i64 arithmetic (`x0 + 1`, the wrap's
        // `2n`) cannot overflow (uv near 1e30 overflowed it: found by the GLB fuzz target); repeated
        // textures that far out have lost all sub-texel precision in f32 anyway.
        const FAR: f64 = 4_503_599_627_370_496.0;
        let x = (f64::from(u) * w as f64 - 0.5).clamp(-FAR, FAR);
        let y = (f64::from(v) * h as f64 - 0.5).clamp(-FAR, FAR);
        if self.nearest {
            // The texel containing (u, v): floor(u w) = floor(x + ½).
            let (i, j) = ((x + 0.5).floor() as i64, (y + 0.5).floor() as i64);
            let i = wrap(i, w, self.wrap[0]) + wrap(j, h, self.wrap[1]) * w as usize;
            return [(i, 1.0), (i, 0.0), (i, 0.0), (i, 0.0)];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (xa, xb) = (wrap(x0, w, self.wrap[0]), wrap(x0 + 1, w, self.wrap[0]));
        let (ya, yb) = (wrap(y0, h, self.wrap[1]) * w as usize, wrap(y0 + 1, h, self.wrap[1]) * w as usize);
        [(xa + ya, (1.0 - fx) * (1.0 - fy)), (xb + ya, fx * (1.0 - fy)), (xa + yb, (1.0 - fx) * fy), (xb + yb, fx * fy)]
    }
}

/// Texel index `i` of a row or column of `n` texels under `mode`.
#[inline]
fn wrap(i: i64, n: i64, mode: WrapMode) -> usize {
    (match mode {
        WrapMode::Repeat => i.rem_euclid(n),
        WrapMode::ClampToEdge => i.clamp(0, n - 1),
        WrapMode::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m >= n { 2 * n - 1 - m } else { m }
        }
    }) as usize
}

/// One distinct colour of a colour texture, times the material's factor.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PaletteEntry {
    sigmoid: RgbSigmoid,
    /// Linear sRGB (the value RGB lanes carry).
    rgb: [f32; 3],
    alpha: f32,
}

/// A palette entry's linear sRGB, whatever else it holds: what [`ColorTexture::rgb`] blends.
pub(crate) trait EntryRgb {
    fn rgb(&self) -> [f32; 3];
}

impl EntryRgb for PaletteEntry {
    fn rgb(&self) -> [f32; 3] {
        self.rgb
    }
}

impl EntryRgb for EmissiveEntry {
    fn rgb(&self) -> [f32; 3] {
        self.rgb
    }
}

/// A colour image as spectra, whatever samples it: an entry per distinct texel and each texel's entry.
/// It depends on the texels, the factor and whether alpha tells texels apart, not on the sampler: every
/// texture reading the same image with the same factor shares one (`Arc`), as the materials of a texture
/// atlas do.
#[derive(Debug)]
pub(crate) struct Palette<E = PaletteEntry> {
    index: Vec<u32>,
    entries: Vec<E>,
}

impl<E> Palette<E> {
    /// The entry of texel `i`.
    #[inline]
    fn at(&self, i: usize) -> &E {
        &self.entries[self.index[i] as usize]
    }

    /// Whether every entry was fitted exactly: at most [`MAX_REFINED_COLOURS`] distinct colours (beyond,
    /// the table lookup was used).
    fn exact(&self) -> bool {
        self.entries.len() <= MAX_REFINED_COLOURS
    }

    /// Bytes held: 4 per texel and the entries.
    fn bytes(&self) -> usize {
        self.index.len() * 4 + self.entries.len() * std::mem::size_of::<E>()
    }
}

impl Palette {
    /// Of an sRGB-encoded image as reflectances; `factor` (linear RGBA) multiplies every texel before the
    /// fit. Without `alpha`, texels differing only in alpha share an entry (whose alpha is then one of
    /// theirs: the caller does not read it).
    fn reflectance(
        image: &Image8,
        label: &str,
        factor: [f32; 4],
        alpha: bool,
        memory: &mut MemoryBudget,
    ) -> geometry::Result<Self> {
        Self::fit(image, label, alpha, memory, |linear, alpha, exact| {
            let c = |i: usize| linear[i] * factor[i];
            palette_entry([c(0), c(1), c(2)], alpha * factor[3], exact)
        })
    }
}

impl Palette<EmissiveEntry> {
    /// Of an sRGB-encoded image as light colours: each texel × `factor` (linear RGB, clamped below at 0).
    fn emission(image: &Image8, label: &str, factor: [f32; 3], memory: &mut MemoryBudget) -> geometry::Result<Self> {
        Self::fit(image, label, false, memory, |linear, _, exact| {
            let rgb = [0, 1, 2].map(|i| (linear[i] * factor[i]).max(0.0));
            let spectrum = if exact {
                RgbUnboundedSpectrum::fit(rgb.map(f64::from))
            } else {
                RgbUnboundedSpectrum::from_rgb(colorimetry::RgbToSpectrumTable::srgb(), rgb)
            };
            EmissiveEntry { spectrum, rgb }
        })
    }
}

impl<E: Send> Palette<E> {
    /// Of an sRGB-encoded image, each distinct texel's entry made by `entry` from its linear RGB, its
    /// alpha and whether the exact fit is wanted (at most [`MAX_REFINED_COLOURS`] distinct colours);
    /// texels are distinct by their RGBA, or by their RGB alone without `alpha`.
    fn fit(
        image: &Image8,
        label: &str,
        alpha: bool,
        memory: &mut MemoryBudget,
        entry: impl Fn([f32; 3], f32, bool) -> E + Sync,
    ) -> geometry::Result<Self> {
        let path = std::path::Path::new(label);
        let texels = image.texels.len() as u64;
        let index_bytes = texels * 4;
        memory.fits(
            path,
            || format!("finding the distinct colours of a {}×{} texture", image.width, image.height),
            index_bytes.saturating_add(texels.saturating_mul(COLOUR_COUNT_BYTES_PER_TEXEL)),
        )?;
        let (index, distinct) = index_distinct(&image.texels, |t| if alpha { *t } else { [t[0], t[1], t[2], 0] });
        let palette_bytes = (distinct.len() * std::mem::size_of::<E>()) as u64;
        memory.charge(
            path,
            || format!("the {} colours of a {}×{} texture as spectra", distinct.len(), image.width, image.height),
            index_bytes.saturating_add(palette_bytes),
        )?;
        let exact = distinct.len() <= MAX_REFINED_COLOURS;
        let entries = distinct
            .par_iter()
            .map(|t| {
                let c = |i: usize| srgb_decode(f64::from(t[i]) / 255.0) as f32;
                entry([c(0), c(1), c(2)], f32::from(t[3]) / 255.0, exact)
            })
            .collect();
        Ok(Self { index, entries })
    }
}

/// A colour texture as spectra: where it is read, and its image's [`Palette`] (reflectances
/// ([`PaletteEntry`]) but for emissive textures ([`EmissiveEntry`])).
#[derive(Debug)]
pub(crate) struct ColorTexture<E = PaletteEntry> {
    sampler: Sampler,
    palette: Arc<Palette<E>>,
}

impl<E> ColorTexture<E> {
    /// `palette` (of an image of `width` × `height`) read as `desc` says.
    fn with_palette(desc: &TextureDesc, width: u32, height: u32, palette: Arc<Palette<E>>) -> Self {
        Self { sampler: Sampler::new(desc, width, height), palette }
    }
}

impl ColorTexture {
    /// From an sRGB-encoded image; `factor` (linear RGBA) multiplies every texel before the fit.
    /// `exact` is false when the image had more than [`MAX_REFINED_COLOURS`] distinct colours and
    /// the table lookup was used. Without `alpha`, texels differing only in alpha share an entry
    /// (whose alpha is then one of theirs: the caller does not read it).
    #[cfg(test)]
    fn new(
        image: &Image8,
        label: &str,
        desc: &TextureDesc,
        factor: [f32; 4],
        alpha: bool,
        memory: &mut MemoryBudget,
    ) -> geometry::Result<(Self, bool)> {
        let palette = Palette::reflectance(image, label, factor, alpha, memory)?;
        let exact = palette.exact();
        Ok((Self::with_palette(desc, image.width, image.height, Arc::new(palette)), exact))
    }
}

impl<E: EntryRgb> ColorTexture<E> {
    /// The linear RGB at `uv` (the blend of the texels' colours × factor).
    #[inline]
    fn rgb(&self, uv: Uv) -> [f32; 3] {
        let mut rgb = [0.0; 3];
        for (i, w) in self.sampler.footprint(uv) {
            let e = self.palette.at(i).rgb();
            for (sum, value) in rgb.iter_mut().zip(e) {
                *sum += w * value;
            }
        }
        rgb
    }
}

impl ColorTexture {
    /// The reflectance at `uv` at the path's wavelengths (linear RGB on RGB lanes), and the alpha.
    #[inline]
    pub(crate) fn eval<const N: usize>(
        &self,
        uv: Uv,
        lambda: &SampledWavelengths<N>,
        rgb_lanes: bool,
    ) -> (SampledSpectrum<N>, f32) {
        let mut r = SampledSpectrum([0.0; N]);
        let mut alpha = 0.0;
        for (i, w) in self.sampler.footprint(uv) {
            if w == 0.0 {
                continue;
            }
            let e = self.palette.at(i);
            if rgb_lanes {
                for c in 0..3.min(N) {
                    r.0[c] += w * e.rgb[c];
                }
            } else {
                r += e.sigmoid.sample(lambda) * w;
            }
            alpha += w * e.alpha;
        }
        (r, alpha)
    }

    /// Only the alpha at `uv` (shadow rays and cut-outs need no spectrum).
    #[inline]
    fn alpha(&self, uv: Uv) -> f32 {
        self.sampler.footprint(uv).iter().map(|&(i, w)| w * self.palette.at(i).alpha).sum()
    }
}

/// `KHR_materials_specular`'s colour texture: the texels × `specularColorFactor` ÷ its largest component
/// (`SpecularLayer::color_scale`) as reflectance spectra, and each palette entry's largest value over
/// 360–830 nm. At a hit, with k = F0 of the index × that largest component, F0(λ) = Σᵢ wᵢ min(k sᵢ(λ), 1)
/// over the texels under uv and F0_max = Σᵢ wᵢ min(k maxᵢ, 1). The layer's Fresnel and the energy it takes
/// from the base are linear in F0 and F0_max, so this is the blend of the texels' layers, as a colour
/// texture's reflectance is the blend of its texels'; without the texture the layer is the factor's
/// (`assembly::dielectric_specular`), which a white texel reproduces (on RGB lanes up to F0_max, the
/// largest channel here and the largest over the spectrum there).
#[derive(Debug)]
pub(crate) struct SpecularColorTexture {
    color: ColorTexture,
    /// `max_value` of each palette entry's sigmoid (shared with the palette's other users).
    max: Arc<[f32]>,
}

impl SpecularColorTexture {
    /// What the texels are multiplied by before the fit: `specularColorFactor` ÷ its largest component.
    fn factor(layer: &geometry::SpecularLayer) -> [f32; 4] {
        let scale = layer.color_scale();
        let factor = layer.color.map(|c| if scale > 0.0 { c / scale } else { 0.0 });
        [factor[0], factor[1], factor[2], 1.0]
    }

    /// The largest value over the spectrum of each entry of `palette` (charged to `memory`).
    fn max_values(palette: &Palette, label: &str, memory: &mut MemoryBudget) -> geometry::Result<Arc<[f32]>> {
        memory.charge(
            std::path::Path::new(label),
            || format!("the largest F0 of each of {} specular colours", palette.entries.len()),
            (palette.entries.len() * 4) as u64,
        )?;
        Ok(palette.entries.iter().map(|e| e.sigmoid.max_value() as f32).collect())
    }

    #[cfg(test)]
    fn new(
        image: &Image8,
        label: &str,
        desc: &TextureDesc,
        layer: &geometry::SpecularLayer,
        memory: &mut MemoryBudget,
    ) -> geometry::Result<(Self, bool)> {
        let palette = Palette::reflectance(image, label, Self::factor(layer), false, memory)?;
        let max = Self::max_values(&palette, label, memory)?;
        let exact = palette.exact();
        Ok((Self { color: ColorTexture::with_palette(desc, image.width, image.height, Arc::new(palette)), max }, exact))
    }

    /// (F0 at the path's wavelengths, F0_max) at `uv`, `f0_scale` being k above (linear RGB on RGB lanes,
    /// where F0_max is the largest channel's, as the extension computes it).
    #[inline]
    fn f0<const N: usize>(
        &self,
        uv: Uv,
        lambda: &SampledWavelengths<N>,
        rgb_lanes: bool,
        f0_scale: f32,
    ) -> (SampledSpectrum<N>, f32) {
        let mut f0 = SampledSpectrum([0.0; N]);
        let mut f0_max = 0.0;
        for (i, w) in self.color.sampler.footprint(uv) {
            if w == 0.0 {
                continue;
            }
            let entry = self.color.palette.index[i] as usize;
            let e = &self.color.palette.entries[entry];
            if rgb_lanes {
                for c in 0..3.min(N) {
                    f0.0[c] += w * (f0_scale * e.rgb[c]).min(1.0);
                }
                f0_max += w * (f0_scale * e.rgb[0].max(e.rgb[1]).max(e.rgb[2])).min(1.0);
            } else {
                let s = e.sigmoid.sample(lambda);
                for (out, v) in f0.0.iter_mut().zip(s.0) {
                    *out += w * (f0_scale * v).min(1.0);
                }
                f0_max += w * (f0_scale * self.max[entry]).min(1.0);
            }
        }
        (f0, f0_max)
    }
}

/// One distinct colour of an emissive texture, times the material's emission (factor × strength): the
/// light's colour without its illuminant, pbrt-v4's split of an unbounded RGB into a brightness and a
/// sigmoid ([`RgbUnboundedSpectrum`]), so that with D65 at luminance 1 it is the RGB light
/// `materials::illuminant_from_rgb` makes of the colour (before that function's luminance rescaling, a
/// correction of the fit's own error: under 1e-3 for the exact fit).
#[derive(Debug, Clone, Copy)]
pub(crate) struct EmissiveEntry {
    spectrum: RgbUnboundedSpectrum,
    /// Linear sRGB (the value RGB lanes carry).
    rgb: [f32; 3],
}

/// An emissive texture as light spectra: texel × `emissiveFactor` × `emissiveStrength` (MTL `map_Ke` ×
/// `Ke`), so that emission varies over the surface as the image does. Light sampling chooses the surface
/// by its mean emission (the material's spectrum), its triangles by the texels they cover (assembly's
/// `weigh_textured_lights`), and points on a triangle uniformly by area; the texel under the sampled point
/// gives the radiance, so the estimate stays unbiased where the image is dark.
#[derive(Debug)]
pub(crate) struct EmissiveTexture(ColorTexture<EmissiveEntry>);

impl EmissiveTexture {
    #[cfg(test)]
    fn new(
        image: &Image8,
        label: &str,
        desc: &TextureDesc,
        factor: [f32; 3],
        memory: &mut MemoryBudget,
    ) -> geometry::Result<(Self, bool)> {
        let palette = Palette::emission(image, label, factor, memory)?;
        let exact = palette.exact();
        Ok((Self(ColorTexture::with_palette(desc, image.width, image.height, Arc::new(palette))), exact))
    }

    /// The radiance at `uv` at the path's wavelengths, `illuminant` being D65 at luminance 1 there
    /// (linear RGB on RGB lanes, where the illuminant is white).
    #[inline]
    fn eval<const N: usize>(
        &self,
        uv: Uv,
        lambda: &SampledWavelengths<N>,
        illuminant: &SampledSpectrum<N>,
        rgb_lanes: bool,
    ) -> SampledSpectrum<N> {
        let mut l = SampledSpectrum([0.0; N]);
        for (i, w) in self.0.sampler.footprint(uv) {
            if w == 0.0 {
                continue;
            }
            let e = self.0.palette.at(i);
            if rgb_lanes {
                for c in 0..3.min(N) {
                    l.0[c] += w * e.rgb[c];
                }
            } else {
                l += e.spectrum.sample(lambda) * w;
            }
        }
        if rgb_lanes { l } else { l * *illuminant }
    }

    /// The luminance (linear sRGB's Y, per unit of the D65 illuminant's) at `uv`: what light sampling weighs
    /// the surface's triangles by.
    fn luminance(&self, uv: Uv) -> f32 {
        let rgb = self.0.rgb(uv);
        (0..3).map(|c| materials::REC709_LUMINANCE[c] * rgb[c]).sum()
    }
}

/// The linear RGB × factor of one colour, clamped to reflectances, fitted as texels are.
fn palette_entry(rgb: [f32; 3], alpha: f32, exact: bool) -> PaletteEntry {
    let rgb = rgb.map(|c| c.clamp(0.0, 1.0));
    PaletteEntry {
        sigmoid: if exact {
            RgbSigmoid::refined(rgb)
        } else {
            RgbSigmoid::from_rgb(colorimetry::RgbToSpectrumTable::srgb(), rgb)
        },
        rgb,
        alpha: alpha.clamp(0.0, 1.0),
    }
}

/// A mesh's vertex colours (glTF `COLOR_0`, OBJ `v x y z r g b`) as spectra, built like a colour
/// texture: each distinct colour (times the material's base colour factor where it can be folded
/// in) fitted once at assembly, a palette index per vertex. A hit blends its triangle's three
/// vertices' spectra with the barycentric weights, as a texture blends its texels' (bilinear).
#[derive(Debug)]
pub(crate) struct VertexColors {
    index: Vec<u32>,
    palette: Vec<PaletteEntry>,
    /// Whether the palette holds colour × the material's RGB factor and so replaces the base colour;
    /// else (a base colour texture, or a base colour given as a spectrum) it multiplies it.
    replaces_base: bool,
}

/// The distinct values of `values` (equal when their `key`s are), in order of first appearance, and the
/// index of each value's among them: what texel and vertex-colour palettes are fitted from.
fn index_distinct<T: Copy, K: std::hash::Hash + Eq>(values: &[T], key: impl Fn(&T) -> K) -> (Vec<u32>, Vec<T>) {
    let mut ids: HashMap<K, u32> = HashMap::new();
    let mut distinct: Vec<T> = Vec::new();
    let index = values
        .iter()
        .map(|v| {
            *ids.entry(key(v)).or_insert_with(|| {
                distinct.push(*v);
                (distinct.len() - 1) as u32
            })
        })
        .collect();
    (index, distinct)
}

impl VertexColors {
    /// From linear RGBA per vertex; `factor` is the material's base colour factor (linear RGB) when
    /// it is folded into the fit (glTF: base colour = factor × texture × COLOR_0, an RGB product,
    /// exact here when there is no texture). `exact` is false when the mesh had more than
    /// [`MAX_REFINED_COLOURS`] distinct colours and the table lookup was used.
    pub(crate) fn new(
        colors: &[Vec4],
        factor: Option<[f32; 3]>,
        label: &str,
        memory: &mut MemoryBudget,
    ) -> geometry::Result<(Self, bool)> {
        let (index, distinct) = index_distinct(colors, |c| c.to_array().map(f32::to_bits));
        let bytes = (index.len() * 4 + distinct.len() * std::mem::size_of::<PaletteEntry>()) as u64;
        memory.charge(
            std::path::Path::new(label),
            || format!("the {} vertex colours of a mesh as spectra", distinct.len()),
            bytes,
        )?;
        let exact = distinct.len() <= MAX_REFINED_COLOURS;
        let f = factor.unwrap_or([1.0; 3]);
        let palette =
            distinct.par_iter().map(|c| palette_entry([c.x * f[0], c.y * f[1], c.z * f[2]], c.w, exact)).collect();
        Ok((Self { index, palette, replaces_base: factor.is_some() }, exact))
    }

    /// The colour at barycentric `weights` of the triangle with vertex indices `vertices`.
    #[inline]
    pub(crate) fn at(&self, vertices: [u32; 3], weights: [f32; 3]) -> VertexColorHit<'_> {
        VertexColorHit {
            entries: vertices.map(|v| &self.palette[self.index[v as usize] as usize]),
            weights,
            replaces_base: self.replaces_base,
        }
    }

    fn bytes(&self) -> usize {
        self.index.len() * 4 + self.palette.len() * std::mem::size_of::<PaletteEntry>()
    }
}

/// Bytes the vertex colours' palettes and indices hold (for `info`).
pub(crate) fn vertex_color_bytes(colors: &[Option<VertexColors>]) -> usize {
    colors.iter().flatten().map(VertexColors::bytes).sum()
}

/// The vertex colour at one hit: its triangle's three palette entries and their weights.
#[derive(Debug, Clone, Copy)]
pub(crate) struct VertexColorHit<'a> {
    entries: [&'a PaletteEntry; 3],
    weights: [f32; 3],
    replaces_base: bool,
}

impl VertexColorHit<'_> {
    /// The interpolated alpha (multiplying the material's).
    #[inline]
    pub(crate) fn alpha(&self) -> f32 {
        (0..3).map(|k| self.weights[k] * self.entries[k].alpha).sum()
    }

    /// The blend of the vertices' reflectances at the path's wavelengths (linear RGB on RGB lanes).
    #[inline]
    pub(crate) fn eval<const N: usize>(&self, lambda: &SampledWavelengths<N>, rgb_lanes: bool) -> SampledSpectrum<N> {
        let mut r = SampledSpectrum([0.0; N]);
        for (e, &w) in self.entries.iter().zip(&self.weights) {
            if rgb_lanes {
                for c in 0..3.min(N) {
                    r.0[c] += w * e.rgb[c];
                }
            } else {
                r += e.sigmoid.sample(lambda) * w;
            }
        }
        r
    }

    /// Whether [`VertexColorHit::eval`] is the base colour itself (the factor folded in), rather than a
    /// tint multiplying the material's texture or spectrum.
    #[inline]
    pub(crate) fn replaces_base(&self) -> bool {
        self.replaces_base
    }
}

/// A texture of linear values in [0, 1] per channel.
#[derive(Debug)]
pub(crate) struct DataTexture {
    sampler: Sampler,
    /// The decoded image, shared with every other role that uses it (an ORM image serves
    /// metallic–roughness and occlusion, one file may be several materials' normal map).
    image: Arc<Image8>,
    /// glTF `normalTexture.scale` (1 for other roles).
    scale: f32,
}

impl DataTexture {
    fn new(image: Arc<Image8>, desc: &TextureDesc) -> Self {
        Self { sampler: Sampler::new(desc, image.width, image.height), image, scale: desc.scale }
    }

    /// The four channels at `uv`, each in [0, 1].
    #[inline]
    fn eval(&self, uv: Uv) -> Vec4 {
        let mut out = Vec4::ZERO;
        for (i, w) in self.sampler.footprint(uv) {
            out += Vec4::from_array(self.image.texels[i].map(f32::from)) * w;
        }
        out / 255.0
    }
}

/// Every texture a material uses, and how its alpha is applied.
#[derive(Debug)]
pub(crate) struct MaterialTextures {
    /// Base colour × `baseColorFactor` (MTL `map_Kd` replaces `Kd`).
    pub(crate) base_color: Option<ColorTexture>,
    /// B = metalness, G = roughness (multiplying the factors).
    metallic_roughness: Option<DataTexture>,
    /// MTL `map_Ns` turned into roughness at load: G is the roughness itself (of `Ns` × the texel's
    /// luminance, by the exponent's mapping), in place of the material's.
    roughness: Option<DataTexture>,
    /// Tangent-space normal map.
    normal: Option<DataTexture>,
    /// MTL `map_Bump` read as a height field (luminance × `-bm`, in scene units): it tilts the shading
    /// normal by the height's gradient ([`bumped`]). Never together with `normal`.
    bump: Option<DataTexture>,
    /// MTL `map_d`: coverage from the R channel.
    coverage: Option<DataTexture>,
    /// glTF `transmissionTexture`: R multiplies the transmission factor.
    transmission: Option<DataTexture>,
    /// `specularTexture`: A multiplies `specularFactor`.
    specular: Option<DataTexture>,
    /// `specularColorTexture` × `specularColorFactor`: the layer's F0 colour per texel.
    specular_color: Option<SpecularColorTexture>,
    /// `emissiveTexture` × the material's emission: its radiance per texel.
    emissive: Option<EmissiveTexture>,
    /// `sheenColorTexture` × `sheenColorFactor` and `sheenRoughnessTexture` (A × its factor).
    sheen_color: Option<ColorTexture>,
    sheen_roughness: Option<DataTexture>,
    /// `clearcoatTexture` (R × the coat's weight) and `clearcoatRoughnessTexture` (G × its roughness).
    clearcoat: Option<DataTexture>,
    clearcoat_roughness: Option<DataTexture>,
    /// `clearcoatNormalTexture`: the coat's tangent-space normal map.
    clearcoat_normal: Option<DataTexture>,
    /// `anisotropyTexture`: RG the direction in tangent space, B × `anisotropyStrength`.
    anisotropy: Option<DataTexture>,
    /// How alpha is used; `Opaque` skips every alpha lookup.
    alpha_mode: AlphaMode,
    /// The material's alpha factor where no texture gives alpha.
    alpha_factor: f32,
    /// Whether a mesh with vertex colours uses the material (they multiply its base colour and alpha).
    vertex_colors: bool,
    /// Whether some texture reads the mesh's second uv set (hits then interpolate it: [`Uv`]).
    second_uvs: bool,
}

impl MaterialTextures {
    /// Whether the surface can let light through uncovered (cut-out or blended).
    pub(crate) fn has_alpha(&self) -> bool {
        !matches!(self.alpha_mode, AlphaMode::Opaque)
    }

    /// The probability that a ray meets the surface at `uv` (1 for opaque materials), before the
    /// base colour is looked up: MASK is 0 or 1 by the cutoff, BLEND the alpha itself;
    /// `vertex_alpha` (the vertex colours', 1 without) multiplies the material's alpha.
    #[inline]
    pub(crate) fn coverage(&self, uv: Uv, vertex_alpha: f32) -> f32 {
        let alpha = match (&self.coverage, &self.base_color) {
            (Some(t), _) => t.eval(uv).x * self.alpha_factor,
            (None, Some(t)) => t.alpha(uv),
            (None, None) => self.alpha_factor,
        } * vertex_alpha;
        match self.alpha_mode {
            AlphaMode::Opaque => 1.0,
            AlphaMode::Mask(cutoff) => {
                if alpha >= cutoff {
                    1.0
                } else {
                    0.0
                }
            }
            AlphaMode::Blend => alpha.clamp(0.0, 1.0),
        }
    }

    /// (metallic, roughness) at `uv` from the factors.
    #[inline]
    pub(crate) fn metallic_roughness(&self, uv: Uv, metallic: f32, roughness: f32) -> (f32, f32) {
        let roughness = self.roughness_map(uv).unwrap_or(roughness);
        match &self.metallic_roughness {
            Some(t) => {
                let v = t.eval(uv);
                (metallic * v.z, roughness * v.y)
            }
            None => (metallic, roughness),
        }
    }

    /// The roughness at `uv` of an MTL `map_Ns`, `None` without one.
    #[inline]
    pub(crate) fn roughness_map(&self, uv: Uv) -> Option<f32> {
        self.roughness.as_ref().map(|t| t.eval(uv).y)
    }

    /// The transmission factor `factor` at `uv`, times the texture's R where there is one.
    #[inline]
    pub(crate) fn transmission(&self, uv: Uv, factor: f32) -> f32 {
        scaled_by_channel(&self.transmission, uv, factor, 0)
    }

    /// The specular layer's strength `factor` at `uv`, times the texture's A where there is one.
    #[inline]
    pub(crate) fn specular_weight(&self, uv: Uv, factor: f32) -> f32 {
        scaled_by_channel(&self.specular, uv, factor, 3)
    }

    /// The coat at `uv`: its weight times the coat texture's R, its roughness times the roughness
    /// texture's G, where there are such textures.
    #[inline]
    pub(crate) fn coat(&self, uv: Uv, coat: Coat) -> Coat {
        Coat {
            weight: scaled_by_channel(&self.clearcoat, uv, coat.weight, 0),
            roughness: scaled_by_channel(&self.clearcoat_roughness, uv, coat.roughness, 1),
        }
    }

    /// The F0 of `KHR_materials_specular` at `uv` and the path's wavelengths, and its largest value over
    /// the spectrum (see [`SpecularColorTexture::f0`]); `None` without a specular colour texture.
    #[inline]
    pub(crate) fn specular_f0<const N: usize>(
        &self,
        uv: Uv,
        lambda: &SampledWavelengths<N>,
        rgb_lanes: bool,
        f0_scale: f32,
    ) -> Option<(SampledSpectrum<N>, f32)> {
        self.specular_color.as_ref().map(|t| t.f0(uv, lambda, rgb_lanes, f0_scale))
    }

    /// The base's shading normal: `ns` with the normal map applied (see [`normal_mapped`]); `ns` itself
    /// without a map.
    #[inline]
    pub(crate) fn shading_normal(&self, uv: Uv, ns: Vec3, tangent: &HitTangent, n: Vec3) -> Vec3 {
        match &self.bump {
            Some(bump) => bumped(bump, uv, ns, tangent.uv_derivatives(), n),
            None => normal_mapped(&self.normal, uv, ns, tangent.get(), n),
        }
    }

    /// The coat's shading normal: `ns` with the coat's own normal map applied; `ns` itself without one,
    /// even where the base has a map (`KHR_materials_clearcoat`: the coat is a separate surface).
    #[inline]
    pub(crate) fn coat_normal(&self, uv: Uv, ns: Vec3, tangent: Option<Vec4>, n: Vec3) -> Vec3 {
        normal_mapped(&self.clearcoat_normal, uv, ns, tangent, n)
    }

    /// The sheen colour at `uv` at the path's wavelengths (linear RGB on RGB lanes) and its largest linear RGB
    /// channel; `None` without a sheen colour texture.
    #[inline]
    pub(crate) fn sheen_color<const N: usize>(
        &self,
        uv: Uv,
        lambda: &SampledWavelengths<N>,
        rgb_lanes: bool,
    ) -> Option<(SampledSpectrum<N>, f32)> {
        let t = self.sheen_color.as_ref()?;
        let rgb = t.rgb(uv);
        Some((t.eval(uv, lambda, rgb_lanes).0, rgb[0].max(rgb[1]).max(rgb[2])))
    }

    /// The sheen roughness `factor` at `uv`, times the texture's A where there is one.
    #[inline]
    pub(crate) fn sheen_roughness(&self, uv: Uv, factor: f32) -> f32 {
        scaled_by_channel(&self.sheen_roughness, uv, factor, 3)
    }

    /// `KHR_materials_anisotropy`'s texel at `uv`: the direction in tangent space (RG mapped from [0, 1] to
    /// [−1, 1], not normalised) and the strength's multiplier (B); `None` without the texture.
    #[inline]
    pub(crate) fn anisotropy(&self, uv: Uv) -> Option<(Vec2, f32)> {
        let c = self.anisotropy.as_ref()?.eval(uv);
        Some((Vec2::new(2.0 * c.x - 1.0, 2.0 * c.y - 1.0), c.z))
    }

    /// The emitted luminance at `uv` (relative: the texel's linear sRGB Y × factor); `None` without an
    /// emissive texture.
    pub(crate) fn emissive_luminance(&self, uv: Uv) -> Option<f32> {
        self.emissive.as_ref().map(|t| t.luminance(uv))
    }

    /// The emitted radiance at `uv` (see [`EmissiveTexture::eval`]); `None` without an emissive texture.
    #[inline]
    pub(crate) fn emission<const N: usize>(
        &self,
        uv: Uv,
        lambda: &SampledWavelengths<N>,
        illuminant: &SampledSpectrum<N>,
        rgb_lanes: bool,
    ) -> Option<SampledSpectrum<N>> {
        self.emissive.as_ref().map(|t| t.eval(uv, lambda, illuminant, rgb_lanes))
    }

    /// Whether the emission varies per texel.
    #[inline]
    pub(crate) fn has_emissive_texture(&self) -> bool {
        self.emissive.is_some()
    }

    /// Whether the emissive texture reads the mesh's second uv set.
    pub(crate) fn emissive_reads_second_uvs(&self) -> bool {
        self.emissive.as_ref().is_some_and(|t| t.0.sampler.second)
    }

    /// Whether some texture reads the mesh's second uv set.
    #[inline]
    pub(crate) fn reads_second_uvs(&self) -> bool {
        self.second_uvs
    }

    /// Whether the base has a normal map or a bump map (its tangent frame or uv derivatives are needed only
    /// then).
    #[inline]
    pub(crate) fn has_base_normal_map(&self) -> bool {
        self.normal.is_some() || self.bump.is_some()
    }

    /// Whether the coat has a normal map.
    #[inline]
    pub(crate) fn has_coat_normal_map(&self) -> bool {
        self.clearcoat_normal.is_some()
    }

    /// Whether any normal map (the base's or the coat's) is present: the mesh then needs tangents.
    pub(crate) fn has_normal_map(&self) -> bool {
        self.normal.is_some() || self.clearcoat_normal.is_some()
    }

    /// Whether the material has a texture or a non-opaque alpha (what it would need an entry for
    /// without vertex colours).
    pub(crate) fn is_textured(&self) -> bool {
        self.base_color.is_some()
            || self.specular_color.is_some()
            || self.emissive.is_some()
            || self.sheen_color.is_some()
            || self.data_images().next().is_some()
            || self.has_alpha()
    }

    /// Whether meshes with vertex colours use the material (hits then look their colour up).
    #[inline]
    pub(crate) fn has_vertex_colors(&self) -> bool {
        self.vertex_colors
    }

    /// Whether the base colour comes from an image (vertex colours then multiply its spectrum).
    pub(crate) fn has_base_color_texture(&self) -> bool {
        self.base_color.is_some()
    }

    /// What the colour textures hold (for `info`), each as its address and size in bytes: palettes and a
    /// specular texture's largest values, shared between textures and materials that read the same image
    /// with the same factor (the address tells a shared one).
    fn color_data(&self) -> impl Iterator<Item = (usize, usize)> {
        fn palette<E>(p: &Arc<Palette<E>>) -> (usize, usize) {
            (Arc::as_ptr(p) as usize, p.bytes())
        }
        [
            self.base_color.as_ref().map(|t| palette(&t.palette)),
            self.specular_color.as_ref().map(|t| palette(&t.color.palette)),
            self.specular_color.as_ref().map(|t| (t.max.as_ptr() as usize, t.max.len() * 4)),
            self.emissive.as_ref().map(|t| palette(&t.0.palette)),
            self.sheen_color.as_ref().map(|t| palette(&t.palette)),
        ]
        .into_iter()
        .flatten()
    }

    /// The decoded images the data textures read (shared between roles and materials).
    fn data_images(&self) -> impl Iterator<Item = &Arc<Image8>> {
        [
            &self.metallic_roughness,
            &self.roughness,
            &self.normal,
            &self.bump,
            &self.coverage,
            &self.transmission,
            &self.specular,
            &self.clearcoat,
            &self.clearcoat_roughness,
            &self.clearcoat_normal,
            &self.sheen_roughness,
            &self.anisotropy,
        ]
        .into_iter()
        .flatten()
        .map(|t| &t.image)
    }
}

/// `ns` with the tangent-space normal map `map` applied, given the tangent (xyz) with the bitangent sign (w)
/// and the geometric normal `n`; `ns` itself when there is no map or tangent, or the mapped normal would
/// face away from `n`.
#[inline]
fn normal_mapped(map: &Option<DataTexture>, uv: Uv, ns: Vec3, tangent: Option<Vec4>, n: Vec3) -> Vec3 {
    let (Some(map), Some(tangent)) = (map, tangent) else { return ns };
    let Some((t, b)) = crate::surface::tangent_frame(tangent, ns) else { return ns };
    let c = map.eval(uv);
    let local = Vec3::new((2.0 * c.x - 1.0) * map.scale, (2.0 * c.y - 1.0) * map.scale, 2.0 * c.z - 1.0);
    match (t * local.x + b * local.y + ns * local.z).try_normalize() {
        Some(mapped) if mapped.dot(n) > 1e-4 => mapped,
        _ => ns,
    }
}

/// Rec. 709 luminance weights (`materials::REC709_LUMINANCE`): an MTL bump map's height is the luminance
/// of its texels (`-imfchan l`, the specification's default for `bump`), as is a `map_Ns`'s value.
const LUMINANCE: Vec3 = Vec3::from_array(materials::REC709_LUMINANCE);

/// `ns` tilted by the height field `map` at `uv` (pbrt-v4's `BumpMap`): the surface displaced by h along
/// `ns` has tangents ∂p/∂u + (∂h/∂u) ns and ∂p/∂v + (∂h/∂v) ns, whose cross product is the bumped normal;
/// the derivatives of h are central differences one texel apart. ∂p/∂u and ∂p/∂v are taken in the plane
/// normal to `ns`, so that the bump tilts the smooth normal rather than the facet's, and the change of
/// `ns` across the triangle (pbrt's h·∂n/∂u term) is left out. `ns` itself without uv derivatives, or
/// where the bumped normal would face away from `n`.
#[inline]
fn bumped(map: &DataTexture, uv: Uv, ns: Vec3, derivatives: Option<(Vec3, Vec3)>, n: Vec3) -> Vec3 {
    let Some((dpdu, dpdv)) = derivatives else { return ns };
    let (du, dv) = map.sampler.texel_step();
    let uv = map.sampler.pick(uv);
    let height = |p: Vec2| map.eval(Uv::same(p)).truncate().dot(LUMINANCE);
    let gu = map.scale * (height(uv + Vec2::new(du, 0.0)) - height(uv - Vec2::new(du, 0.0))) / (2.0 * du);
    let gv = map.scale * (height(uv + Vec2::new(0.0, dv)) - height(uv - Vec2::new(0.0, dv))) / (2.0 * dv);
    bump_normal(dpdu, dpdv, ns, n, Vec2::new(gu, gv))
}

/// The normal of the surface through the hit displaced by a height with gradient `g` = (∂h/∂u, ∂h/∂v)
/// along `ns` (see [`bumped`]), on the side of `ns`; `ns` where the uv derivatives are degenerate, the
/// result is not finite, or it faces away from `n`.
#[inline]
fn bump_normal(dpdu: Vec3, dpdv: Vec3, ns: Vec3, n: Vec3, g: Vec2) -> Vec3 {
    let t = dpdu - ns * ns.dot(dpdu);
    let b = dpdv - ns * ns.dot(dpdv);
    // The uv mapping's handedness: which way t × b points along ns.
    let side = t.cross(b).dot(ns);
    if !(side != 0.0 && side.is_finite()) {
        return ns;
    }
    match ((t + ns * g.x).cross(b + ns * g.y) * side.signum()).try_normalize() {
        Some(m) if m.dot(n) > 1e-4 => m,
        _ => ns,
    }
}

/// Whether an MTL `map_Bump` image is a tangent-space normal map rather than a height field: not grey
/// (fewer than 99 % of texels with R = G = B within 2/255), blue-dominant (mean B ≥ 0.7, mean R and G
/// within 0.15 of one half: a normal map's z is near 1 and its x, y average about 0) and with B ≥ ½
/// (z ≥ 0) at ≥ 99 % of texels.
fn reads_as_normal_map(img: &Image8) -> bool {
    let count = img.texels.len().max(1) as f64;
    let (mut grey, mut upward, mut sum) = (0usize, 0usize, [0u64; 3]);
    for &[r, g, b, _] in &img.texels {
        grey += usize::from(r.abs_diff(g) <= 2 && g.abs_diff(b) <= 2);
        upward += usize::from(b >= 127);
        for (s, v) in sum.iter_mut().zip([r, g, b]) {
            *s += u64::from(v);
        }
    }
    let mean = sum.map(|s| s as f64 / count / 255.0);
    (grey as f64) < 0.99 * count
        && mean[2] >= 0.7
        && (mean[0] - 0.5).abs() <= 0.15
        && (mean[1] - 0.5).abs() <= 0.15
        && upward as f64 >= 0.99 * count
}

/// A material factor at `uv` times `channel` (0 R … 3 A) of its texture, or the factor alone without one.
#[inline]
fn scaled_by_channel(texture: &Option<DataTexture>, uv: Uv, factor: f32, channel: usize) -> f32 {
    texture.as_ref().map_or(factor, |t| factor * t.eval(uv)[channel])
}

/// Bytes of texel data the textures hold: each colour palette and each decoded data image once however
/// many roles and materials share it.
pub(crate) fn texture_bytes(textures: &[Option<MaterialTextures>]) -> usize {
    let mut held: Vec<(usize, usize)> = textures.iter().flatten().flat_map(MaterialTextures::color_data).collect();
    held.extend(
        textures
            .iter()
            .flatten()
            .flat_map(MaterialTextures::data_images)
            .map(|i| (Arc::as_ptr(i) as usize, i.texels.len() * 4)),
    );
    held.sort_unstable();
    held.dedup_by_key(|&mut (address, _)| address);
    held.iter().map(|&(_, bytes)| bytes).sum()
}

/// The textures of each material (`None` where a material has none), decoded from `images`. An
/// image that cannot be decoded is named in a warning and the material keeps its factor. An
/// emissive texture over an RGB emission factor (or an MTL `map_Ke` without `Ke`) also sets the material's
/// emission (`desc.emission`) to its mean colour × factor, the surface's power for light sampling (the
/// texels give the radiance per hit); over a spectral emission it is not applied (a warning). Materials marked in
/// `vertex_colored` (used by a mesh with vertex colours) get an entry even without textures: their
/// base colour varies per hit as a texture's does. Each distinct image is decoded once, and what is
/// derived from it once per factor ([`shared`]); the count of images decoded comes with the textures.
pub(crate) fn load_material_textures(
    images: &[ImageDesc],
    materials: &mut [MaterialDesc],
    vertex_colored: &[bool],
    memory: &mut MemoryBudget,
    warnings: &mut Vec<String>,
) -> geometry::Result<(Vec<Option<MaterialTextures>>, usize)> {
    // Decoded images live until every material has taken its share: each is charged once, when
    // first decoded, and kept charged.
    let mut shared = shared::SharedImages::new(images);
    let mut out = Vec::with_capacity(materials.len());
    for (index, m) in materials.iter_mut().enumerate() {
        let vertex_colors = vertex_colored.get(index).copied().unwrap_or(false);
        let entry = {
            let alpha_mode = match (m.alpha_mode, m.textures.alpha.is_some()) {
                (Some(mode), _) => mode,
                // MTL `map_d`: coverage, cut out at one half (as viewers treat leaf cards).
                (None, true) => AlphaMode::Mask(0.5),
                (None, false) => AlphaMode::Opaque,
            };
            mtl_specular_maps(m, warnings);
            if !m.textures.any() && matches!(alpha_mode, AlphaMode::Opaque) && !vertex_colors {
                out.push(None);
                continue;
            }
            // The sets numbered as the meshes hold them: 0 the primary (the hits' uv), 1 the second.
            let mut textures = m.textures.clone();
            let (primary, _) = m.textures.uv_sets();
            for t in textures.roles_mut().into_iter().flatten() {
                t.tex_coord = u32::from(t.tex_coord != primary);
            }
            let second_uvs = textures.roles().into_iter().flatten().any(|t| t.tex_coord == 1);
            let mut emissive = None;
            if let Some(t) = &textures.emissive
                && let Some(img) = shared.image(t.image, memory, warnings)?
            {
                // glTF multiplies by `emissiveFactor`, whose default black means no emission (the
                // loader leaves `emission` unset then); MTL's `map_Ke` without `Ke` stands alone.
                let factor = match (&m.emission, m.format) {
                    (Some(geometry::SpectrumDesc::Rgb(c)), _) => *c,
                    (None, geometry::MaterialFormat::Mtl) => [1.0; 3],
                    (Some(spectrum), _) => {
                        // A spectral emission (an MTL `Ke` spectrum, a glTF `extras` override) has no RGB for
                        // the texels to multiply: the spectrum is kept, uniform over the surface.
                        warnings.push(format!(
                            "material {:?}: its emission is the spectrum {}, so the emissive texture is not applied (the surface emits it uniformly)",
                            m.name,
                            spectrum.label()
                        ));
                        [0.0; 3]
                    }
                    (None, _) => [0.0; 3],
                };
                let strength = m.emission_strength.unwrap_or(1.0).max(0.0);
                if factor != [0.0; 3] && strength > 0.0 {
                    // The material's own emission becomes the mean over the image: what light sampling
                    // chooses the surface by, and what the hero wavelengths' density follows.
                    let mean = shared.mean(&img);
                    m.emission = Some(geometry::SpectrumDesc::Rgb([0, 1, 2].map(|i| factor[i] * mean[i])));
                    let label = shared.label(t.image);
                    let factor = factor.map(|f| f * strength);
                    emissive = Some(shared.emissive_texture(&img, label, t, factor, memory, warnings)?);
                }
            }
            let factor_rgb = match (&m.base_color, m.format) {
                // MTL: `map_Kd` replaces `Kd` (as Blender's importer does; exporters write Kd 0.8 beside it).
                (_, geometry::MaterialFormat::Mtl) => [1.0; 3],
                (Some(geometry::SpectrumDesc::Rgb(c)), _) => *c,
                _ => [1.0; 3],
            };
            let alpha_factor = m.alpha.unwrap_or(1.0);
            let mut base_color = None;
            if let Some(t) = &textures.base_color
                && let Some(img) = shared.image(t.image, memory, warnings)?
            {
                let factor = [factor_rgb[0], factor_rgb[1], factor_rgb[2], alpha_factor];
                let label = shared.label(t.image);
                base_color = Some(shared.color_texture(&img, label, t, factor, true, memory, warnings)?);
            }
            let mut specular_color = None;
            // A black factor makes F0 0 whatever the texels (no fit needed).
            if let (Some(t), Some(layer)) = (&textures.specular_color, &m.specular_layer)
                && layer.color_scale() > 0.0
                && let Some(img) = shared.image(t.image, memory, warnings)?
            {
                let label = shared.label(t.image);
                specular_color = Some(shared.specular_texture(&img, label, t, layer, memory, warnings)?);
            }
            let mut sheen_color = None;
            if let (Some(t), Some(sheen)) = (&textures.sheen_color, &m.sheen)
                && let Some(img) = shared.image(t.image, memory, warnings)?
            {
                let label = shared.label(t.image);
                let c = sheen.color;
                let factor = [c[0], c[1], c[2], 1.0];
                sheen_color = Some(shared.color_texture(&img, label, t, factor, false, memory, warnings)?);
            }
            // MTL `map_Bump`: a height field, or a normal map in Blender's files (decided from the texels).
            let (mut bump, mut bump_as_normal) = (None, None);
            if let Some(t) = &textures.bump
                && textures.normal.is_some()
            {
                // Not decoded (nor charged): the `norm` map wins.
                let label = shared.label(t.image);
                warnings.push(format!(
                    "material {:?}: `map_Bump` {label} not used: the material has a `norm` normal map",
                    m.name
                ));
            } else if let Some(t) = &textures.bump
                && let Some(img) = shared.image(t.image, memory, warnings)?
            {
                let label = shared.label(t.image);
                let name = &m.name;
                if shared.reads_as_normal_map(&img) {
                    warnings.push(format!(
                        "material {name:?}: `map_Bump` {label} read as a tangent-space normal map of strength {} (its texels are blue-dominant, as Blender's exporter writes normal maps there)",
                        t.scale
                    ));
                    bump_as_normal = Some(DataTexture::new(img.image, t));
                } else {
                    warnings.push(format!(
                        "material {name:?}: `map_Bump` {label} read as a height field: luminance × {} scene units",
                        t.scale
                    ));
                    bump = Some(DataTexture::new(img.image, t));
                }
            }
            let roughness = match &textures.shininess {
                Some(t) => match shared.image(t.image, memory, warnings)? {
                    Some(img) => {
                        let label = shared.label(t.image);
                        Some(DataTexture::new(shared.roughness(&img, label, m.shininess, memory)?, t))
                    }
                    None => None,
                },
                None => None,
            };
            let mut data = |t: &Option<TextureDesc>,
                            memory: &mut MemoryBudget,
                            warnings: &mut Vec<String>|
             -> geometry::Result<Option<DataTexture>> {
                let Some(t) = t else { return Ok(None) };
                Ok(shared.image(t.image, memory, warnings)?.map(|img| DataTexture::new(img.image, t)))
            };
            let metallic_roughness = data(&textures.metallic_roughness, memory, warnings)?;
            let normal = match bump_as_normal {
                Some(n) => Some(n),
                None => data(&textures.normal, memory, warnings)?,
            };
            let coverage = data(&textures.alpha, memory, warnings)?;
            let transmission = data(&textures.transmission, memory, warnings)?;
            let specular = data(&textures.specular, memory, warnings)?;
            let clearcoat = data(&textures.clearcoat, memory, warnings)?;
            let clearcoat_roughness = data(&textures.clearcoat_roughness, memory, warnings)?;
            let clearcoat_normal = data(&textures.clearcoat_normal, memory, warnings)?;
            let sheen_roughness = data(&textures.sheen_roughness, memory, warnings)?;
            let anisotropy = data(&textures.anisotropy, memory, warnings)?;
            let set = MaterialTextures {
                base_color,
                metallic_roughness,
                roughness,
                normal,
                bump,
                coverage,
                transmission,
                specular,
                specular_color,
                emissive,
                sheen_color,
                sheen_roughness,
                clearcoat,
                clearcoat_roughness,
                clearcoat_normal,
                anisotropy,
                alpha_mode,
                alpha_factor,
                vertex_colors,
                second_uvs,
            };
            (set.is_textured() || set.vertex_colors).then_some(set)
        };
        out.push(entry);
    }
    Ok((out, shared.decoded_count()))
}

/// MTL `map_Ns` where it can apply (a material with a specular lobe; a warning otherwise), and `map_Ks` (the
/// specular colour per texel) as the specular layer's colour texture: MTL's Kd + Ks is the
/// glTF dielectric layer over the diffuse one (its Fresnel from `Ni`), so the texels tint its F0 as
/// `KHR_materials_specular`'s `specularColorTexture` does (black: no highlight at normal incidence). A
/// conductor (black `Kd`, or `illum 5`) reflects `Ks` itself, which is not textured: a warning.
fn mtl_specular_maps(m: &mut MaterialDesc, warnings: &mut Vec<String>) {
    if m.format != geometry::MaterialFormat::Mtl {
        return;
    }
    if m.textures.shininess.is_none() && m.textures.specular_map.is_none() {
        return;
    }
    // The model the assembly will build (the one rule, `material_desc::model_of`): the maps apply to the GGX
    // layer over the diffuse one, and `map_Ns` to the conductor too; glass (smooth) and Lambertian surfaces
    // have no lobe for either (a material that fails to build fails later, with its own error).
    use materials::MaterialModel as M;
    let model = crate::material_desc::model_of(m).ok();
    let (layered, conductor) =
        (matches!(model, Some(M::GltfMetalRough { .. })), matches!(model, Some(M::Conductor { .. })));
    if !(layered || conductor) && m.textures.shininess.take().is_some() {
        warnings.push(format!(
            "material {:?}: `map_Ns` not used: the material has no rough specular lobe (glass, or no `Ks`)",
            m.name
        ));
    }
    let Some(texture) = m.textures.specular_map.take() else { return };
    if !layered {
        warnings.push(format!(
            "material {:?}: `map_Ks` not used: the material is glass, has no specular lobe (no `Ks`), or is a conductor reflecting `Ks` (black `Kd` or `illum 5`), whose colour is not textured",
            m.name
        ));
        return;
    }
    m.textures.specular_color = Some(texture);
    m.specular_layer.get_or_insert(geometry::SpecularLayer { factor: 1.0, color: [1.0; 3] });
}

/// MTL `map_Ns` (`Ns` × the texels' luminance) as an image of roughness in G, by the exponent's mapping
/// (`material_desc::roughness_from_shininess`); `ns` the material's `Ns` (without one, the exponent of the default
/// roughness). The map's own image stays for other roles; this one is charged to `memory`.
fn roughness_from_shininess_map(
    img: &Image8,
    label: &str,
    ns: Option<f32>,
    memory: &mut MemoryBudget,
) -> geometry::Result<Image8> {
    use crate::material_desc::{DEFAULT_ROUGHNESS, roughness_from_shininess, shininess_from_roughness};
    let ns = ns.map_or(shininess_from_roughness(DEFAULT_ROUGHNESS), |n| n.max(0.0));
    let bytes = img.texels.len() as u64 * IMAGE8_BYTES_PER_TEXEL;
    memory.charge(std::path::Path::new(label), || "`map_Ns` as roughness".to_owned(), bytes)?;
    let table: Vec<u8> =
        (0..=255u8).map(|v| (255.0 * roughness_from_shininess(ns * f32::from(v) / 255.0)).round() as u8).collect();
    let luminance = |[r, g, b, _]: [u8; 4]| {
        (LUMINANCE.dot(Vec3::new(f32::from(r), f32::from(g), f32::from(b)))).round().clamp(0.0, 255.0) as u8
    };
    let texels = img.texels.iter().map(|&t| [0, table[luminance(t) as usize], 0, 255]).collect();
    Ok(Image8 { width: img.width, height: img.height, texels })
}

/// What a texture with more than [`MAX_REFINED_COLOURS`] (`count`) distinct colours says.
fn table_lookup_warning(label: &str, count: usize) -> String {
    format!(
        "{label}: {count} distinct colours, more than {MAX_REFINED_COLOURS} fitted exactly: texels use the table lookup (ΔE00 mean 0.045, max 1.2)"
    )
}

/// The mean linear sRGB of an sRGB-encoded image.
fn mean_linear_rgb(image: &Image8) -> [f32; 3] {
    let mut sum = [0.0f64; 3];
    for t in &image.texels {
        for c in 0..3 {
            sum[c] += srgb_decode(f64::from(t[c]) / 255.0);
        }
    }
    let n = image.texels.len().max(1) as f64;
    sum.map(|s| (s / n) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(w: u32, h: u32, wrap: WrapMode) -> Sampler {
        let desc = TextureDesc { wrap: [wrap; 2], ..TextureDesc::new(0) };
        Sampler::new(&desc, w, h)
    }

    /// `f` (a spectrum at 16 wavelengths) on the 1 nm grid over 360–830 nm.
    fn on_1nm_grid(
        mut f: impl FnMut(&SampledWavelengths<16>) -> SampledSpectrum<16>,
    ) -> colorimetry::DenselySampledSpectrum {
        let mut values = Vec::new();
        for chunk in 0..30 {
            let lambdas: [f32; 16] = std::array::from_fn(|i| (360 + chunk * 16 + i).min(830) as f32);
            values.extend(f(&SampledWavelengths::from_parts(lambdas, [1.0; 16])).0.iter().map(|&v| f64::from(v)));
        }
        values.truncate(471);
        colorimetry::DenselySampledSpectrum::new(360.0, 1.0, values).expect("1 nm grid")
    }

    /// The spectrum a colour texture gives at a texel centre, sampled on the 1 nm grid.
    fn texel_spectrum(texture: &ColorTexture, uv: Vec2) -> colorimetry::DenselySampledSpectrum {
        on_1nm_grid(|lambda| texture.eval(uv.into(), lambda, false).0)
    }

    fn delta_e00_under_d65(rgb: [f64; 3], reflectance: &colorimetry::DenselySampledSpectrum) -> f64 {
        use colorimetry::{Illuminant, Integration, Lab, Observer, Rgb, RgbColorSpace, Xyz, delta_e_2000};
        let srgb = RgbColorSpace::srgb();
        let white = srgb.rgb_to_xyz(Rgb { r: 1.0, g: 1.0, b: 1.0 });
        let d65 = Illuminant::D65.spectrum().expect("D65");
        let xyz = colorimetry::reflectance_to_xyz(reflectance, &d65, Observer::Cie1931, &Integration::Step(1.0));
        let xyz = Xyz { x: xyz.x / 100.0, y: xyz.y / 100.0, z: xyz.z / 100.0 };
        let target = srgb.rgb_to_xyz(Rgb { r: rgb[0], g: rgb[1], b: rgb[2] });
        delta_e_2000(Lab::from_xyz(target, white), Lab::from_xyz(xyz, white))
    }

    /// A 64×64 gradient (every row different) encoded as `format`.
    fn encoded_gradient(format: image::ImageFormat) -> Vec<u8> {
        let img = image::RgbImage::from_fn(64, 64, |x, y| image::Rgb([(4 * x) as u8, (4 * y) as u8, 128]));
        let mut bytes = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut bytes), format).unwrap();
        bytes
    }

    fn decoded(label: &str, bytes: Vec<u8>) -> (Option<Image8>, Vec<String>) {
        let mut warnings = Vec::new();
        let desc = ImageDesc { label: label.into(), mime: None, bytes: bytes.into() };
        (decode(&desc, &mut MemoryBudget::default(), &mut warnings).unwrap(), warnings)
    }

    /// Identical image bytes, however many entries hold them, are decoded and charged once, and materials
    /// reading them with the same factor share one palette: 20 materials over 3 copies of one image are
    /// charged exactly what one material over one image is. Another factor is another palette, charged
    /// once more.
    #[test]
    fn materials_sharing_an_image_and_factor_share_its_decode_and_palette() {
        let png = encoded_gradient(image::ImageFormat::Png);
        let image = |i: usize| ImageDesc { label: format!("copy{i}.png"), mime: None, bytes: png.clone().into() };
        let material = |image: usize, factor: f32| {
            let mut m = MaterialDesc::new("m", geometry::MaterialFormat::Gltf);
            m.base_color = Some(geometry::SpectrumDesc::Rgb([factor; 3]));
            m.textures.base_color = Some(TextureDesc::new(image));
            m
        };
        let load = |images: &[ImageDesc], materials: &mut [MaterialDesc]| {
            let mut memory = MemoryBudget::default();
            let mut warnings = Vec::new();
            let (textures, decoded) =
                load_material_textures(images, materials, &[], &mut memory, &mut warnings).unwrap();
            assert!(warnings.is_empty(), "{warnings:?}");
            (textures, decoded, memory.used)
        };
        let (_, decoded, one) = load(&[image(0)], &mut [material(0, 0.5)]);
        // 64² texels: 16 KiB kept, 16 KiB of indices, 64 × 64 distinct colours of 28 bytes.
        assert_eq!((decoded, one), (1, 16_384 + 16_384 + 4096 * 28));
        let images = [image(0), image(1), image(2)];
        let mut materials: Vec<MaterialDesc> = (0..20).map(|i| material(i % 3, 0.5)).collect();
        let (textures, decoded, used) = load(&images, &mut materials);
        assert_eq!((decoded, used), (1, one));
        let palette = |i: usize| &textures[i].as_ref().unwrap().base_color.as_ref().unwrap().palette;
        assert!((1..20).all(|i| Arc::ptr_eq(palette(0), palette(i))));
        assert_eq!(texture_bytes(&textures), 16_384 + 4096 * 28, "one palette (colour textures keep no decoded image)");
        materials.push(material(1, 0.25));
        let (textures, decoded, used) = load(&images, &mut materials);
        assert_eq!((decoded, used), (1, one + 16_384 + 4096 * 28));
        assert!(!Arc::ptr_eq(palette(0), &textures[20].as_ref().unwrap().base_color.as_ref().unwrap().palette));
    }

    /// A JPEG cut in half is refused with the note a truncated PNG gets, naming the image; the whole file
    /// decodes, and bytes after its end-of-image marker are not read. Before, the half file decoded without
    /// a word, its missing rows grey.
    #[test]
    fn a_truncated_jpeg_is_named_as_truncated_as_a_truncated_png_is() {
        let jpeg = encoded_gradient(image::ImageFormat::Jpeg);
        let (whole, warnings) = decoded("photo.jpg", jpeg.clone());
        let whole = whole.expect("the whole JPEG decodes");
        assert_eq!((whole.width, whole.height, warnings.len()), (64, 64, 0), "{warnings:?}");
        // Lossy, but the bottom row's green is near 4 × 63.
        assert!(whole.texels[63 * 64 + 32][1] > 230, "{:?}", whole.texels[63 * 64 + 32]);
        let (half, warnings) = decoded("photo.jpg", jpeg[..jpeg.len() / 2].to_vec());
        assert!(half.is_none(), "the half JPEG is not used");
        assert_eq!(
            warnings,
            [
                "photo.jpg: cannot decode (truncated: the JPEG data ends before its end-of-image marker); the material's factor is used"
            ]
        );
        let mut padded = jpeg.clone();
        padded.extend_from_slice(&[0; 64]);
        let (padded, warnings) = decoded("photo.jpg", padded);
        assert_eq!(padded.map(|i| i.texels), Some(whole.texels), "{warnings:?}");
        let png = encoded_gradient(image::ImageFormat::Png);
        let (half, warnings) = decoded("photo.png", png[..png.len() / 2].to_vec());
        assert!(half.is_none());
        assert!(
            warnings.len() == 1
                && warnings[0].starts_with("photo.png: cannot decode (")
                && warnings[0].ends_with("; the material's factor is used"),
            "{warnings:?}"
        );
    }

    /// The end-of-image marker is found by walking the segments: one inside a segment (an EXIF thumbnail's)
    /// does not make a truncated file whole, and stuffed bytes and restart markers in the scan are passed.
    #[test]
    fn jpeg_completeness_walks_segments_and_scan_data() {
        // SOI, APP1 of 6 bytes holding FF D9, SOS of 4 bytes, scan data with FF 00 and RST0, EOI.
        let whole = [
            0xFF, 0xD8, 0xFF, 0xE1, 0x00, 0x06, 0xFF, 0xD9, 0xFF, 0xD9, 0xFF, 0xDA, 0x00, 0x04, 0x01, 0x02, 0x12, 0xFF,
            0x00, 0x34, 0xFF, 0xD0, 0x56, 0xFF, 0xFF, 0xD9,
        ];
        assert!(jpeg_is_complete(&whole));
        for cut in 2..whole.len() - 1 {
            assert!(!jpeg_is_complete(&whole[..cut]), "cut at {cut}");
        }
        // A segment length running past the end.
        assert!(!jpeg_is_complete(&[0xFF, 0xD8, 0xFF, 0xE0, 0xFF, 0xFF, 0xFF, 0xD9]));
    }

    #[test]
    fn map_bump_images_read_as_normal_maps_only_when_they_look_like_one() {
        let image = |texels: Vec<[u8; 4]>| Image8 { width: texels.len() as u32, height: 1, texels };
        // A grey ramp (a height field), a typical normal map (x, y spread about 0, z near 1), a mid-grey
        // image, a blue photograph whose red and green are far from one half, and a normal map with a
        // tenth of its texels pointing below the surface (z < 0: not a tangent-space normal map).
        let ramp = image((0..=255u8).map(|i| [i, i, i, 255]).collect());
        let normal = image((0..256u32).map(|i| [(96 + i % 64) as u8, (160 - i % 64) as u8, 240, 255]).collect());
        let blue_photo = image((0..256u32).map(|i| [20, 40, (180 + i % 60) as u8, 255]).collect());
        let downward = image((0..256u32).map(|i| [128, 128, if i % 10 == 0 { 60 } else { 250 }, 255]).collect());
        assert!(!reads_as_normal_map(&ramp));
        assert!(!reads_as_normal_map(&image(vec![[128, 128, 128, 255]; 64])));
        assert!(reads_as_normal_map(&normal));
        assert!(!reads_as_normal_map(&blue_photo));
        assert!(!reads_as_normal_map(&downward));
    }

    #[test]
    fn bump_normals_tilt_against_the_gradient_and_stay_finite() {
        let (n, dpdu, dpdv) = (Vec3::Z, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0));
        // h rising by g per unit u: the surface z = g x / 2 (x = 2u), normal ∝ (−g/2, 0, 1).
        for g in [0.5f32, -1.5] {
            let m = bump_normal(dpdu, dpdv, n, n, Vec2::new(g, 0.0));
            let want = Vec3::new(-g / 2.0, 0.0, 1.0).normalize();
            assert!((m - want).length() < 1e-6, "{m} vs {want}");
            // Along v: z = g y / 3, and a mirrored uv mapping (v flipped) tilts the same way in space.
            let m = bump_normal(dpdu, dpdv, n, n, Vec2::new(0.0, g));
            assert!((m - Vec3::new(0.0, -g / 3.0, 1.0).normalize()).length() < 1e-6, "{m}");
            let m = bump_normal(dpdu, -dpdv, n, n, Vec2::new(0.0, -g));
            assert!((m - Vec3::new(0.0, -g / 3.0, 1.0).normalize()).length() < 1e-6, "{m}");
        }
        // Degenerate or overflowing input keeps the shading normal; a bump past the horizon too.
        let keeps = |dpdu: Vec3, dpdv: Vec3, g: Vec2| bump_normal(dpdu, dpdv, n, n, g) == n;
        assert!(keeps(dpdu, 2.0 * dpdu, Vec2::new(1.0, 1.0)));
        assert!(keeps(dpdu, dpdv, Vec2::new(f32::NAN, 0.0)));
        assert!(keeps(dpdu, dpdv, Vec2::new(f32::INFINITY, 0.0)));
        assert!(keeps(Vec3::splat(f32::MAX), dpdv, Vec2::new(1.0, 0.0)));
        let steep = bump_normal(dpdu, dpdv, n, n, Vec2::new(1e30, 0.0));
        assert!(steep.is_finite() && (steep == n || steep.dot(n) > 1e-4), "{steep}");
    }

    #[test]
    fn texel_lookup_round_trips_under_d65_within_0_01() {
        // sRGB-encoded texels across the gamut, saturated ones included; one image, 8×2.
        let texels: Vec<[u8; 4]> = [
            [255, 0, 0],
            [0, 255, 0],
            [0, 0, 255],
            [255, 255, 255],
            [128, 128, 128],
            [200, 150, 30],
            [10, 60, 200],
            [250, 240, 5],
            [1, 1, 1],
            [90, 200, 180],
            [180, 40, 120],
            [230, 230, 250],
            [60, 30, 10],
            [0, 128, 255],
            [255, 128, 0],
            [35, 35, 36],
        ]
        .iter()
        .map(|c| [c[0], c[1], c[2], 255])
        .collect();
        let image = Image8 { width: 8, height: 2, texels: texels.clone() };
        let desc = TextureDesc::new(0);
        let (texture, exact) =
            ColorTexture::new(&image, "test", &desc, [1.0; 4], true, &mut MemoryBudget::default()).unwrap();
        assert!(exact);
        let mut worst: f64 = 0.0;
        for (i, t) in texels.iter().enumerate() {
            let uv = Vec2::new(((i % 8) as f32 + 0.5) / 8.0, ((i / 8) as f32 + 0.5) / 2.0);
            let rgb = [0, 1, 2].map(|c| srgb_decode(f64::from(t[c]) / 255.0));
            worst = worst.max(delta_e00_under_d65(rgb, &texel_spectrum(&texture, uv)));
        }
        assert!(worst < 0.01, "worst ΔE00 {worst}");
        // The factor multiplies in linear RGB before the fit: half of white is linear 0.5 grey.
        let (half, _) =
            ColorTexture::new(&image, "test", &desc, [0.5, 0.5, 0.5, 1.0], true, &mut MemoryBudget::default()).unwrap();
        let uv = Vec2::new(3.5 / 8.0, 0.25);
        assert!(delta_e00_under_d65([0.5; 3], &texel_spectrum(&half, uv)) < 0.01);
        // And a wrong decode (treating the bytes as linear) is far off: the test can fail.
        let grey = Vec2::new(4.5 / 8.0, 0.25);
        assert!(delta_e00_under_d65([128.0 / 255.0; 3], &texel_spectrum(&texture, grey)) > 5.0);
    }

    /// F0 and F0_max of a specular colour texture at `uv`, F0 sampled on the 1 nm grid.
    fn specular_f0_spectrum(
        texture: &SpecularColorTexture,
        uv: Vec2,
        f0_scale: f32,
    ) -> (colorimetry::DenselySampledSpectrum, f32) {
        let mut f0_max = 0.0;
        let f0 = on_1nm_grid(|lambda| {
            let (s, max) = texture.f0(uv.into(), lambda, false, f0_scale);
            f0_max = max;
            s
        });
        (f0, f0_max)
    }

    /// An emissive texture over a spectral emission (no RGB for the texels to multiply) is not applied,
    /// and says so; over an RGB factor it is, and the material's emission becomes the mean × factor.
    #[test]
    fn an_emissive_texture_over_a_spectral_emission_is_named_in_a_warning() {
        let mut png = Vec::new();
        image::RgbaImage::from_pixel(2, 1, image::Rgba([255, 255, 255, 255]))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let images = [ImageDesc { label: "lamp.png".into(), mime: None, bytes: png.into() }];
        let material = |emission: geometry::SpectrumDesc| {
            let mut m = MaterialDesc::new("lamp", geometry::MaterialFormat::Gltf);
            m.emission = Some(emission);
            m.textures.emissive = Some(TextureDesc::new(0));
            m
        };
        let mut materials = [
            material(geometry::SpectrumDesc::Named("D65".into())),
            material(geometry::SpectrumDesc::Rgb([0.5, 0.25, 1.0])),
        ];
        let mut warnings = Vec::new();
        let (textures, _) =
            load_material_textures(&images, &mut materials, &[false; 2], &mut MemoryBudget::default(), &mut warnings)
                .unwrap();
        assert!(textures[0].as_ref().is_none_or(|t| !t.has_emissive_texture()), "spectral: not applied");
        assert!(
            warnings.iter().any(|w| w.contains("\"lamp\"") && w.contains("emissive texture is not applied")),
            "{warnings:?}"
        );
        assert!(textures[1].as_ref().is_some_and(MaterialTextures::has_emissive_texture), "RGB: applied");
        assert_eq!(
            materials[1].emission,
            Some(geometry::SpectrumDesc::Rgb([0.5, 0.25, 1.0])),
            "white texels: mean = factor"
        );
        assert_eq!(warnings.len(), 1, "{warnings:?}");
    }

    #[test]
    fn emissive_texels_are_the_rgb_lights_of_their_colour_times_the_factor() {
        // Saturated, dark and white texels; a factor × strength above 1, as `emissiveStrength` gives.
        let image = Image8 {
            width: 4,
            height: 1,
            texels: vec![[255, 255, 255, 255], [255, 0, 0, 255], [20, 90, 230, 255], [0, 0, 0, 255]],
        };
        let factor = [3.0, 2.0, 1.5];
        let desc = TextureDesc { nearest: true, ..TextureDesc::new(0) };
        let (texture, exact) =
            EmissiveTexture::new(&image, "test", &desc, factor, &mut MemoryBudget::default()).unwrap();
        assert!(exact);
        let d65 = colorimetry::srgb_illuminant();
        let srgb = colorimetry::RgbColorSpace::srgb();
        for (i, t) in image.texels.iter().enumerate() {
            let uv = Vec2::new((i as f32 + 0.5) / 4.0, 0.5);
            let got = on_1nm_grid(|lambda| texture.eval(uv.into(), lambda, &d65.sample(lambda), false));
            let rgb = [0, 1, 2].map(|c| srgb_decode(f64::from(t[c]) / 255.0) as f32 * factor[c]);
            // The untextured emission of that colour (`assembly`'s RGB lights) at every wavelength, within
            // its luminance rescaling of the fit's error.
            let want = materials::illuminant_from_rgb(rgb).unwrap();
            let peak = want.max_value().max(1e-9);
            for l in (360..=830).step_by(5) {
                let (g, w) = (got.eval(f64::from(l)), want.eval(f64::from(l)));
                assert!((g - w).abs() <= 2e-3 * peak, "texel {i} at {l} nm: {g} vs {w}");
            }
            // Its colour: XYZ relative to Σȳ back to linear sRGB is the texel × factor.
            let back = srgb.xyz_to_rgb(colorimetry::relative_xyz(&got));
            for (c, (b, r)) in [back.r, back.g, back.b].into_iter().zip(rgb).enumerate() {
                assert!((b - f64::from(r)).abs() <= 2e-3 * f64::from(factor[0]), "texel {i} channel {c}: {b} vs {r}");
            }
            // RGB lanes carry the colour itself.
            let lanes = texture.eval(
                uv.into(),
                &SampledWavelengths::from_parts([550.0; 4], [1.0; 4]),
                &SampledSpectrum([1.0; 4]),
                true,
            );
            assert_eq!(&lanes.0[..3], &rgb[..], "texel {i} on RGB lanes");
        }
        // The factor alone (the texel ignored, as the mean colour was before) is far from the red texel.
        let red = on_1nm_grid(|lambda| texture.eval(Vec2::new(0.375, 0.5).into(), lambda, &d65.sample(lambda), false));
        let white =
            on_1nm_grid(|lambda| texture.eval(Vec2::new(0.125, 0.5).into(), lambda, &d65.sample(lambda), false));
        assert!((red.eval(450.0) / white.eval(450.0)) < 0.05, "a red texel emits little blue");
        // Alpha plays no part in emission (nor in specular colour): texels differing only there share an entry.
        let alpha_only = Image8 { width: 2, height: 1, texels: vec![[255, 128, 0, 255], [255, 128, 0, 10]] };
        let mut memory = MemoryBudget::default();
        let emissive = EmissiveTexture::new(&alpha_only, "test", &desc, factor, &mut memory).unwrap().0;
        assert_eq!(emissive.0.palette.entries.len(), 1);
        let layer = geometry::SpecularLayer { factor: 1.0, color: [1.0; 3] };
        let specular = SpecularColorTexture::new(&alpha_only, "test", &desc, &layer, &mut memory).unwrap().0;
        assert_eq!(specular.color.palette.entries.len(), 1);
        let base = ColorTexture::new(&alpha_only, "test", &desc, [1.0; 4], true, &mut memory).unwrap().0;
        assert_eq!(base.palette.entries.len(), 2, "base colour keeps its alpha per texel");
    }

    #[test]
    fn specular_colour_texels_tint_f0_by_their_colour_times_the_factor() {
        // White and orange texels; `specularColorFactor` above 1 in red, as the extension allows.
        let image = Image8 { width: 2, height: 1, texels: vec![[255, 255, 255, 255], [255, 128, 0, 255]] };
        let layer = geometry::SpecularLayer { factor: 1.0, color: [2.0, 1.0, 0.5] };
        let desc = TextureDesc { nearest: true, ..TextureDesc::new(0) };
        let (texture, exact) =
            SpecularColorTexture::new(&image, "test", &desc, &layer, &mut MemoryBudget::default()).unwrap();
        assert!(exact);
        // Index 1.5: F0 = 0.04 × colour; the colour is upsampled at its largest component, 2.
        let k = 0.04 * layer.color_scale();
        let linear = |t: [u8; 4]| [0, 1, 2].map(|c| srgb_decode(f64::from(t[c]) / 255.0));
        for (i, uv) in [Vec2::new(0.25, 0.5), Vec2::new(0.75, 0.5)].into_iter().enumerate() {
            let (f0, f0_max) = specular_f0_spectrum(&texture, uv, k);
            // F0 / 0.04 / 2 has the colour texel × factor / 2 under D65.
            let texel = linear(image.texels[i]);
            let want = [0, 1, 2].map(|c| texel[c] * f64::from(layer.color[c]) / 2.0);
            let scaled = f0.map(|v| v / f64::from(k));
            let de = delta_e00_under_d65(want, &scaled);
            assert!(de < 0.01, "texel {i}: ΔE00 {de}");
            // F0_max is the largest F0 over the spectrum.
            assert!((f64::from(f0_max) - f0.max_value()).abs() < 1e-4, "texel {i}: {f0_max} vs {}", f0.max_value());
            // The factor alone (the texture ignored) is far from the orange texel.
            if i == 1 {
                assert!(delta_e00_under_d65([1.0, 0.5, 0.25], &scaled) > 5.0);
            }
        }
        // Bilinear between the texels: the blend of their F0s and of their F0_max.
        let bilinear =
            SpecularColorTexture::new(&image, "test", &TextureDesc::new(0), &layer, &mut MemoryBudget::default())
                .unwrap()
                .0;
        let (mid, mid_max) = specular_f0_spectrum(&bilinear, Vec2::new(0.5, 0.5), k);
        let ((a, a_max), (b, b_max)) = (
            specular_f0_spectrum(&texture, Vec2::new(0.25, 0.5), k),
            specular_f0_spectrum(&texture, Vec2::new(0.75, 0.5), k),
        );
        for l in [400.0, 550.0, 700.0] {
            assert!((mid.eval(l) - 0.5 * (a.eval(l) + b.eval(l))).abs() < 1e-6, "{l} nm");
        }
        assert!((mid_max - 0.5 * (a_max + b_max)).abs() < 1e-6);
        // A scale past 1/F0 clamps F0 to 1 per texel, never beyond.
        let (clamped, clamped_max) = specular_f0_spectrum(&texture, Vec2::new(0.25, 0.5), 40.0);
        assert!(clamped.max_value() <= 1.0 && clamped_max == 1.0, "{} {clamped_max}", clamped.max_value());
    }

    #[test]
    fn wrap_modes_follow_opengl() {
        assert_eq!([-1, 0, 3, 4, 5].map(|i| wrap(i, 4, WrapMode::Repeat)), [3, 0, 3, 0, 1]);
        assert_eq!([-1, 0, 3, 4, 9].map(|i| wrap(i, 4, WrapMode::ClampToEdge)), [0, 0, 3, 3, 3]);
        // Mirrored: … 1 0 | 0 1 2 3 | 3 2 1 0 | 0 …
        assert_eq!([-2, -1, 0, 3, 4, 7, 8].map(|i| wrap(i, 4, WrapMode::MirroredRepeat)), [1, 0, 0, 3, 3, 0, 0]);
    }

    #[test]
    fn coordinates_far_out_stay_inside_the_image() {
        // uv near ±1e30 overflowed `x0 + 1` in i64 (found by the GLB fuzz target:
        // `fuzz/regressions/glb/glb_uv_overflow.glb`).
        for wrap in [WrapMode::Repeat, WrapMode::ClampToEdge, WrapMode::MirroredRepeat] {
            for nearest in [false, true] {
                let s = Sampler { nearest, ..sampler(4, 2, wrap) };
                for uv in [Vec2::splat(1e30), Vec2::splat(-1e30), Vec2::new(f32::MAX, -f32::MAX), Vec2::new(3e15, 1.0)]
                {
                    let f = s.footprint(Uv::same(uv));
                    assert!(f.iter().all(|&(i, w)| i < 8 && w.is_finite()), "{wrap:?} {nearest} {uv}: {f:?}");
                }
            }
        }
    }

    #[test]
    fn bilinear_weights_sum_to_one_and_hit_texel_centres() {
        let s = sampler(4, 2, WrapMode::Repeat);
        // The centre of texel (1, 0) is uv ((1 + ½)/4, ½/2): all weight there.
        let f = s.footprint(Uv::same(Vec2::new(1.5 / 4.0, 0.25)));
        assert_eq!(f[0], (1, 1.0));
        assert!(f[1..].iter().all(|&(_, w)| w == 0.0));
        // Halfway between texels (1, 1) and (2, 1): half each.
        let f = s.footprint(Uv::same(Vec2::new(0.5, 0.75)));
        let total: f32 = f.iter().map(|p| p.1).sum();
        assert!((total - 1.0).abs() < 1e-6);
        assert_eq!((f[0].0, f[1].0), (5, 6));
        assert!((f[0].1 - 0.5).abs() < 1e-6 && (f[1].1 - 0.5).abs() < 1e-6);
    }

    #[test]
    fn texture_transform_moves_texels_as_the_extension_says() {
        // KHR_texture_transform example: offset (0.5, 0) shifts uv 0.1 to 0.6.
        let mut desc = TextureDesc {
            image: 0,
            tex_coord: 0,
            wrap: [WrapMode::ClampToEdge; 2],
            nearest: true,
            transform: Some(geometry::TextureTransform { offset: [0.5, 0.0], rotation: 0.0, scale: [1.0, 1.0] }),
            scale: 1.0,
        };
        let s = Sampler::new(&desc, 10, 1);
        assert_eq!(s.footprint(Uv::same(Vec2::new(0.1, 0.5)))[0].0, 6);
        // Rotation by +90°: (u, v) → (v, −u): uv (0, 0.35) reads u' = 0.35 → texel 3 (v' = 0 clamps).
        desc.transform = Some(geometry::TextureTransform {
            offset: [0.0, 0.0],
            rotation: std::f32::consts::FRAC_PI_2,
            scale: [1.0, 1.0],
        });
        let s = Sampler::new(&desc, 10, 1);
        assert_eq!(s.footprint(Uv::same(Vec2::new(0.0, 0.35)))[0].0, 3);
        // Scale 2 along u: uv 0.3 reads 0.6 → texel 6 (nearest of 5.5 rounds to 6).
        desc.transform = Some(geometry::TextureTransform { offset: [0.0, 0.0], rotation: 0.0, scale: [2.0, 1.0] });
        let s = Sampler::new(&desc, 10, 1);
        assert_eq!(s.footprint(Uv::same(Vec2::new(0.3, 0.5)))[0].0, 6);
    }
}
