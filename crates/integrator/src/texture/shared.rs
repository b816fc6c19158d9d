//! What a scene's textures share. Each distinct image is decoded once however many textures,
//! materials or `images` entries name it (a texture atlas, or an exporter writing one entry per
//! texture for the same file), and is charged to the memory budget once; what is computed from an
//! image and a factor alone (a colour texture's palette, an image's mean colour) is computed once
//! per distinct image and factor. Each result is what a separate computation from the same inputs
//! gives, so sharing changes no rendered value, only the time and memory taken.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

use geometry::{ImageDesc, MemoryBudget, SpecularLayer, TextureDesc};

use super::{
    ColorTexture, EmissiveEntry, EmissiveTexture, Image8, Palette, SpecularColorTexture, decode, mean_linear_rgb,
    reads_as_normal_map, roughness_from_shininess_map, table_lookup_warning,
};

/// A decoded image as materials receive it: which distinct image it is, and its texels.
#[derive(Clone)]
pub(super) struct Decoded {
    /// Index of the distinct image (the key of what is derived from it).
    id: usize,
    pub(super) image: Arc<Image8>,
}

/// A factor as its bits: the key of a derived result, so that only the very same factor shares one.
fn bits<const N: usize>(factor: [f32; N]) -> [u32; N] {
    factor.map(f32::to_bits)
}

/// The images of a scene, decoded as materials ask for them, and what is derived from them.
pub(super) struct SharedImages<'a> {
    images: &'a [ImageDesc],
    /// Image index → its distinct image (an index into `decoded`), once asked for.
    distinct: HashMap<usize, usize>,
    /// Hash of the encoded bytes → the distinct images with that hash.
    by_hash: HashMap<u64, Vec<usize>>,
    /// Per distinct image: the first image index holding its bytes, and its texels (`None` when it
    /// cannot be decoded: the warning was given once).
    decoded: Vec<(usize, Option<Arc<Image8>>)>,
    /// Reflectance palettes by (image, factor, whether alpha tells texels apart).
    reflectance: HashMap<(usize, [u32; 4], bool), Arc<Palette>>,
    /// A specular palette's largest values, by the palette's key.
    specular_max: HashMap<(usize, [u32; 4], bool), Arc<[f32]>>,
    /// Emission palettes by (image, factor × strength).
    emission: HashMap<(usize, [u32; 3]), Arc<Palette<EmissiveEntry>>>,
    /// The mean linear RGB of an image.
    mean: HashMap<usize, [f32; 3]>,
    /// Whether an MTL `map_Bump` image reads as a normal map.
    normal_like: HashMap<usize, bool>,
    /// MTL `map_Ns` images as roughness, by (image, `Ns`).
    roughness: HashMap<(usize, Option<u32>), Arc<Image8>>,
}

impl<'a> SharedImages<'a> {
    pub(super) fn new(images: &'a [ImageDesc]) -> Self {
        Self {
            images,
            distinct: HashMap::new(),
            by_hash: HashMap::new(),
            decoded: Vec::new(),
            reflectance: HashMap::new(),
            specular_max: HashMap::new(),
            emission: HashMap::new(),
            mean: HashMap::new(),
            normal_like: HashMap::new(),
            roughness: HashMap::new(),
        }
    }

    /// The label of image `index` for messages.
    pub(super) fn label(&self, index: usize) -> &'a str {
        self.images.get(index).map_or("?", |i| i.label.as_str())
    }

    /// How many distinct images were decoded.
    pub(super) fn decoded_count(&self) -> usize {
        self.decoded.iter().filter(|(_, image)| image.is_some()).count()
    }

    /// Image `index` decoded: the first time its bytes are seen, decoded and charged to `memory` (the
    /// bytes decide: identical bytes decode to identical texels, whatever entry or file holds them);
    /// `None` (with a warning, once) when it cannot be decoded or there is no such image.
    pub(super) fn image(
        &mut self,
        index: usize,
        memory: &mut MemoryBudget,
        warnings: &mut Vec<String>,
    ) -> geometry::Result<Option<Decoded>> {
        let Some(desc) = self.images.get(index) else { return Ok(None) };
        let id = match self.distinct.get(&index) {
            Some(&id) => id,
            None => {
                let mut hasher = std::collections::hash_map::DefaultHasher::new();
                desc.bytes.hash(&mut hasher);
                let same = self.by_hash.entry(hasher.finish()).or_default();
                let images = self.images;
                let id = match same.iter().copied().find(|&id| {
                    let other = &images[self.decoded[id].0].bytes;
                    Arc::ptr_eq(other, &desc.bytes) || other[..] == desc.bytes[..]
                }) {
                    Some(id) => id,
                    None => {
                        let image = decode(desc, memory, warnings)?.map(Arc::new);
                        self.decoded.push((index, image));
                        same.push(self.decoded.len() - 1);
                        self.decoded.len() - 1
                    }
                };
                self.distinct.insert(index, id);
                id
            }
        };
        Ok(self.decoded[id].1.clone().map(|image| Decoded { id, image }))
    }

    /// The reflectance palette of `image` × `factor` ([`Palette::reflectance`]), fitted and charged the
    /// first time (with the table lookup's warning when it is not exact), shared after.
    fn reflectance(
        &mut self,
        image: &Decoded,
        label: &str,
        factor: [f32; 4],
        alpha: bool,
        memory: &mut MemoryBudget,
        warnings: &mut Vec<String>,
    ) -> geometry::Result<Arc<Palette>> {
        let key = (image.id, bits(factor), alpha);
        if let Some(palette) = self.reflectance.get(&key) {
            return Ok(palette.clone());
        }
        let palette = Arc::new(Palette::reflectance(&image.image, label, factor, alpha, memory)?);
        if !palette.exact() {
            warnings.push(table_lookup_warning(label, palette.entries.len()));
        }
        self.reflectance.insert(key, palette.clone());
        Ok(palette)
    }

    /// A colour texture (base colour, sheen colour) reading `image` × `factor` as `desc` says.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn color_texture(
        &mut self,
        image: &Decoded,
        label: &str,
        desc: &TextureDesc,
        factor: [f32; 4],
        alpha: bool,
        memory: &mut MemoryBudget,
        warnings: &mut Vec<String>,
    ) -> geometry::Result<ColorTexture> {
        let palette = self.reflectance(image, label, factor, alpha, memory, warnings)?;
        Ok(ColorTexture::with_palette(desc, image.image.width, image.image.height, palette))
    }

    /// A specular colour texture of `layer` reading `image` as `desc` says.
    pub(super) fn specular_texture(
        &mut self,
        image: &Decoded,
        label: &str,
        desc: &TextureDesc,
        layer: &SpecularLayer,
        memory: &mut MemoryBudget,
        warnings: &mut Vec<String>,
    ) -> geometry::Result<SpecularColorTexture> {
        let factor = SpecularColorTexture::factor(layer);
        let palette = self.reflectance(image, label, factor, false, memory, warnings)?;
        let key = (image.id, bits(factor), false);
        let max = match self.specular_max.get(&key) {
            Some(max) => max.clone(),
            None => {
                let max = SpecularColorTexture::max_values(&palette, label, memory)?;
                self.specular_max.insert(key, max.clone());
                max
            }
        };
        let color = ColorTexture::with_palette(desc, image.image.width, image.image.height, palette);
        Ok(SpecularColorTexture { color, max })
    }

    /// An emissive texture reading `image` × `factor` (the emission × strength) as `desc` says.
    pub(super) fn emissive_texture(
        &mut self,
        image: &Decoded,
        label: &str,
        desc: &TextureDesc,
        factor: [f32; 3],
        memory: &mut MemoryBudget,
        warnings: &mut Vec<String>,
    ) -> geometry::Result<EmissiveTexture> {
        let key = (image.id, bits(factor));
        let palette = match self.emission.get(&key) {
            Some(palette) => palette.clone(),
            None => {
                let palette = Arc::new(Palette::emission(&image.image, label, factor, memory)?);
                if !palette.exact() {
                    warnings.push(table_lookup_warning(label, palette.entries.len()));
                }
                self.emission.insert(key, palette.clone());
                palette
            }
        };
        Ok(EmissiveTexture(ColorTexture::with_palette(desc, image.image.width, image.image.height, palette)))
    }

    /// The mean linear sRGB of `image` ([`mean_linear_rgb`]).
    pub(super) fn mean(&mut self, image: &Decoded) -> [f32; 3] {
        *self.mean.entry(image.id).or_insert_with(|| mean_linear_rgb(&image.image))
    }

    /// Whether `image` reads as a tangent-space normal map ([`reads_as_normal_map`]).
    pub(super) fn reads_as_normal_map(&mut self, image: &Decoded) -> bool {
        *self.normal_like.entry(image.id).or_insert_with(|| reads_as_normal_map(&image.image))
    }

    /// `image` as an MTL `map_Ns` of exponent `ns` turned into roughness ([`roughness_from_shininess_map`]),
    /// made and charged the first time.
    pub(super) fn roughness(
        &mut self,
        image: &Decoded,
        label: &str,
        ns: Option<f32>,
        memory: &mut MemoryBudget,
    ) -> geometry::Result<Arc<Image8>> {
        let key = (image.id, ns.map(f32::to_bits));
        if let Some(done) = self.roughness.get(&key) {
            return Ok(done.clone());
        }
        let done = Arc::new(roughness_from_shininess_map(&image.image, label, ns, memory)?);
        self.roughness.insert(key, done.clone());
        Ok(done)
    }
}
