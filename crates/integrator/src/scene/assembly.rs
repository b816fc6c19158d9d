//! Scene assembly: the geometry crate's plain descriptions become spectral materials and
//! lights, and primitives are tied to materials. This is the first place that sees both a
//! mesh and a spectrum.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use colorimetry::DenselySampledSpectrum;
use geometry::{
    Camera, CameraDesc, EnvironmentMapDesc, LightAmount, LightDesc, LightUnit, LoadOptions, MaterialDesc,
    MaterialFormat, Projection, Scene, SceneDescription, SceneFormat, Settings, SpectrumDesc,
};
use glam::{Vec2, Vec3};
use materials::{Material, MaterialModel};

use crate::error::{Error, Result};
use crate::lights::cie_sky::{CIE_SKY_MAP_SIZE, CieSky, CieSkyScale};
use crate::lights::envmap::EnvironmentMap;
use crate::lights::{Emitters, Light, LightKind, Luminaire};
use crate::material_desc::{
    emission_spectrum, emission_spectrum_scaled, hall_params, material_from_desc, solid_glass_model,
};
use crate::options::{DEFAULT_RESOLUTION, IntegratorKind};
use crate::output::{Exposure, Tonemap, ViewPlan};
use crate::scene::camera::{CameraOptions, choose_camera};
use crate::scene::solids::placed_meshes;
use crate::scene::survey::{EmitterLight, Survey};
use crate::texture::{MaterialTextures, VertexColors, load_material_textures, texture_bytes, vertex_color_bytes};

/// What the user asks of the assembly, beyond the file (the command line's scene options).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AssemblyOptions {
    /// Camera choice and overrides (`--camera`, `--up`, `--look-from`, `--look-at`, `--fov`).
    pub camera: CameraOptions,
    /// An environment map that lights the scene instead of the file's environment and background
    /// (`--env FILE --env-intensity X`); a glTF or OBJ file then gets no default lights.
    pub environment: Option<EnvironmentOption>,
    /// What assembly may add to a scene without lights (`--light-env none`, `--no-default-lights`).
    pub default_lights: DefaultLights,
    /// The analytic daylight sky (`--light-env sky`): it replaces the file's environment and background
    /// like `environment` (which must then be `None`).
    pub sky: Option<SkyOption>,
    /// The CIE standard general sky (`--light-env cie-sky:N`): it replaces the file's environment and
    /// background like `sky` (`environment` and `sky` must then be `None`).
    pub cie_sky: Option<CieSkyOption>,
    /// Read glTF transmission without `KHR_materials_volume` as thin walls everywhere, as the specification
    /// does (`--thin-glass`); by default such a material on a closed mesh is solid glass.
    pub thin_glass: bool,
}

/// `--light-env sky`: a Preetham et al. 1999 sky (and sun), in nits and lux (`docs/defaults.md`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkyOption {
    /// Atmospheric turbidity T, 2–10 (2: very clear, 3: clear, 6: hazy, 10: thin overcast).
    pub turbidity: f32,
    /// Sun elevation above the horizon, degrees, 0–90.
    pub sun_elevation_deg: f32,
    /// Sun azimuth, degrees, in the environment maps' φ (0 towards −Z, 90 towards +X); `None`: the key
    /// light's azimuth (behind, above and right of the camera).
    pub sun_azimuth_deg: Option<f32>,
    /// Whether the sun is a light (a directional light of the model's spectrum); without it the key light
    /// is kept, scaled to the sky.
    pub sun: bool,
    /// Factor on the sky's and sun's radiance (1: absolute).
    pub intensity: f32,
}

impl Default for SkyOption {
    fn default() -> Self {
        Self { turbidity: 3.0, sun_elevation_deg: 45.0, sun_azimuth_deg: None, sun: true, intensity: 1.0 }
    }
}

/// `--light-env cie-sky:N`: one of the fifteen relative luminance distributions of the CIE standard
/// general sky (ISO 15469:2004 / CIE S 011/E:2003), of CIE daylight at one CCT, in absolute units, with
/// an optional sun (`docs/defaults.md`).
#[derive(Debug, Clone, PartialEq)]
pub struct CieSkyOption {
    /// The standard's sky type, 1–15.
    pub sky_type: u8,
    /// Sun elevation above the horizon, degrees, 0–90 (it places the indicatrix even without a sun light).
    pub sun_elevation_deg: f32,
    /// Sun azimuth, degrees, in the environment maps' φ (0 towards −Z, 90 towards +X); `None`: the key
    /// light's azimuth (behind, above and right of the camera), as for `--light-env sky`.
    pub sun_azimuth_deg: Option<f32>,
    /// The sky's absolute scale: its diffuse horizontal illuminance (lux) or its zenith luminance (nits).
    pub scale: CieSkyScale,
    /// Correlated colour temperature of the sky's CIE daylight spectrum, kelvin (4000–25000).
    pub cct: f32,
    /// The sun as a directional light, if any.
    pub sun: Option<CieSunOption>,
}

impl Default for CieSkyOption {
    fn default() -> Self {
        Self {
            sky_type: 5,
            sun_elevation_deg: 45.0,
            sun_azimuth_deg: None,
            scale: CieSkyScale::DiffuseHorizontalLux(CIE_SKY_DEFAULT_LUX),
            cct: 6500.0,
            sun: None,
        }
    }
}

/// The default diffuse horizontal illuminance of `--light-env cie-sky:N`, lux: a bright overcast day
/// (CIE 110-1994's overcast-sky diffuse illuminances run from about 5 to 30 klx at mid solar elevations).
pub const CIE_SKY_DEFAULT_LUX: f32 = 10_000.0;

/// The sun beside a CIE sky: a directional light (the 0.53° disc treated as a direction, as the Preetham
/// sky's sun) of a given illuminance and spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct CieSunOption {
    /// Its illuminance, lux: at normal incidence (`horizontal` false) or on a horizontal plane.
    pub illuminance_lux: f32,
    /// Whether `illuminance_lux` is on a horizontal plane (E_v = E_vn sin elevation) rather than normal.
    pub horizontal: bool,
    /// Its spectrum: an illuminant name (`D55`, `D5800`, `bb5778`, …; `colorimetry::Illuminant::parse`).
    pub spectrum: String,
}

/// The lights assembly may add to a scene's own (`docs/defaults.md`, "Lights"; decided in
/// `decide_lights`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum DefaultLights {
    /// By rule: a glTF or OBJ file without lights, or lit only by emitters too weak to read what the
    /// camera sees, gets a uniform D65 environment and a key light; emitters that light it readably,
    /// and photometric lights (`KHR_lights_punctual`) of a file not written by Blender's exporter, get
    /// nothing; a Blender file's lamps get Blender's default world around them. A manifest without any
    /// light gets a D65 point light. The default.
    #[default]
    Auto,
    /// `--light-env uniform` said: a glTF or OBJ file without lights or lit by emitters gets the
    /// environment and the key light however bright its emitters; one with lights of its own gets the
    /// world around them (Blender's default world, at most a fill three stops below the brightest); a
    /// manifest as [`DefaultLights::Auto`].
    EnvironmentAndKey,
    /// A glTF or OBJ file: what [`DefaultLights::Auto`] adds without the environment: the key light
    /// alone over black where it adds the key light, else nothing; a manifest as
    /// [`DefaultLights::Auto`]. `--light-env none`.
    KeyOnly,
    /// Nothing: a scene with no light, emitter or background is an error. `--no-default-lights`.
    None,
}

/// `--env FILE [--env-intensity X]`: the scene is lit by this equirectangular map.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentOption {
    /// The map (`.hdr` or `.exr`).
    pub path: PathBuf,
    /// Factor on the texels (whose luminance is then in nits).
    pub intensity: f32,
    /// Rotation about +Y, degrees.
    pub rotation_deg: f32,
}

/// A scene ready to render: acceleration structure, materials, lights, camera, background.
#[derive(Debug)]
pub struct RenderScene {
    pub(crate) geometry: Scene,
    pub(crate) materials: Vec<Material>,
    /// The textures of each material, in its order (`None`: untextured); empty when no material has any.
    pub(crate) textures: Vec<Option<MaterialTextures>>,
    /// The vertex colours of each mesh of `geometry` by mesh id (`Scene::mesh_by_id`: placed objects' meshes
    /// after the others), as spectra (`None`: the mesh has none, or its material does not take them); empty
    /// when no mesh has any.
    pub(crate) vertex_colors: Vec<Option<VertexColors>>,
    /// Whether some material has a cut-out or blended alpha: shadow rays then look through it.
    pub(crate) alpha_cutouts: bool,
    /// Material of primitives that name none: a grey Lambertian ([`default_material`]).
    pub(crate) default_material: Material,
    pub(crate) lights: Vec<Light>,
    /// Every light, including emissive primitives and the environment, behind one interface.
    pub(crate) emitters: Emitters,
    pub(crate) camera: CameraDesc,
    /// Where the camera comes from (the file's, which one, the default view, overrides), for notes and `info`.
    pub(crate) camera_source: String,
    /// The integrator `--integrator auto` picks, and why.
    pub(crate) auto_integrator: (IntegratorKind, String),
    /// Whether the file's lights are photometric (glTF `KHR_lights_punctual`: candela and lux), so that the
    /// image is in absolute units and auto-exposure is the PNG's default.
    pub(crate) photometric_lights: bool,
    /// The scene is a glTF or OBJ file (not a manifest): made for display, so its PNG gets a highlight
    /// shoulder by default.
    pub(crate) gltf_or_obj: bool,
    pub(crate) resolution: (u32, u32),
    pub(crate) background: Option<DenselySampledSpectrum>,
    /// The manifest's `settings`, checked when it was read; the kernels read their limits from here.
    pub(crate) settings: Settings,
    /// The lights as descriptions, including a default light assembly added (for `spectrace info`).
    pub(crate) light_descs: Vec<LightDesc>,
    /// What assembly added to the file's lights and why, in one line (for `spectrace info`).
    pub(crate) lights_why: String,
    /// Notes for the user (defaults that were filled in), printed by the CLI.
    pub warnings: Vec<String>,
    /// Digest of the scene's files ([`SceneDescription::source_hash`]).
    pub(crate) source_hash: u64,
    /// The files the scene was read from ([`SceneDescription::source_files`], and the environment map).
    pub(crate) source_files: Vec<std::path::PathBuf>,
    /// What loading and assembly charged to the scene's memory budget (files, geometry, decoded
    /// images), and the budget: `info` reports it, so a user can size `--max-memory`.
    pub(crate) memory: geometry::MemoryBudget,
}

impl RenderScene {
    /// Load a scene file (manifest `.json`, `.gltf`/`.glb` or `.obj`) and assemble it.
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_with(path, &LoadOptions::default())
    }

    /// Load a scene file within the memory budget and file rules of `options`, and assemble it.
    pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Self> {
        Self::load_with_options(path, options, &AssemblyOptions::default())
    }

    /// [`RenderScene::load_with`], with the user's camera choice and overrides.
    pub fn load_with_options(path: &Path, options: &LoadOptions, assembly: &AssemblyOptions) -> Result<Self> {
        Self::from_description_with(geometry::load_scene_with(path, options)?, assembly)
            .map_err(|e| Error::SceneFile { path: path.to_owned(), source: Box::new(e) })
    }

    /// The paper's five transparent spheres (Lee, Lee, Lee & Ha 2004, Table 1), embedded in
    /// the binary so `spectrace render` works with no arguments.
    pub fn default_scene() -> Result<Self> {
        Self::from_description(Self::default_description()?)
    }

    /// The description of the default scene (see [`RenderScene::default_scene`]).
    pub fn default_description() -> Result<SceneDescription> {
        let text = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/paper/five_spheres.json"));
        // The embedded manifest references no files, so its base folder is never read.
        Ok(geometry::parse_manifest(text, Path::new("."), "<embedded scenes/paper/five_spheres.json>")?)
    }

    /// Assemble a loaded description: spectra for every material and light, a BVH over all
    /// primitives, and defaults (camera, light) where the file has none.
    pub fn from_description(desc: SceneDescription) -> Result<Self> {
        Self::from_description_with(desc, &AssemblyOptions::default())
    }

    /// [`RenderScene::from_description`], with the user's camera choice and overrides.
    pub fn from_description_with(desc: SceneDescription, options: &AssemblyOptions) -> Result<Self> {
        // The one place defaults are decided: a camera framing the bounds of the description and a D65
        // light when the file has none (computed before the BVH takes the meshes).
        let bounds = desc.bounds();
        let up_axis = options.camera.up.unwrap_or_default();
        let (framing, framing_note) = crate::scene::camera::framing_bounds(&desc, up_axis);
        let SceneDescription {
            format,
            spheres,
            mut meshes,
            mut instances,
            materials: mut material_descs,
            images,
            lights: mut light_descs,
            camera,
            mut cameras,
            background,
            settings,
            generator,
            mut warnings,
            mut source_hash,
            mut source_files,
            mut memory,
        } = desc;
        let started = std::time::Instant::now();
        let blender = format == SceneFormat::Gltf && generator.as_deref().is_some_and(written_by_blender);
        if let Some(generator) = generator.as_deref().filter(|_| blender) {
            blender_emission_units(generator, &mut light_descs, &mut material_descs, &mut warnings);
        }
        let solid = crate::scene::solids::solid_glass(
            &mut meshes,
            &mut instances,
            &mut material_descs,
            options.thin_glass,
            &mut warnings,
        );
        let vertex_colored = vertex_colored_materials(&mut meshes, &mut instances, &mut material_descs, &mut warnings);
        let (mut textures, decoded) =
            load_material_textures(&images, &mut material_descs, &vertex_colored, &mut memory, &mut warnings)?;
        if textures.iter().all(Option::is_none) {
            textures.clear();
        } else if textures.iter().flatten().any(MaterialTextures::is_textured) {
            let bytes = texture_bytes(&textures);
            warnings.push(format!(
                "textures: {} images, {:.1} MiB of texel data, decoded and fitted to spectra in {:.2} s; rendered by the path integrator (whitted-hall uses the factors and an emissive texture's mean colour)",
                decoded,
                bytes as f64 / (1024.0 * 1024.0),
                started.elapsed().as_secs_f64()
            ));
        }
        drop(images);
        let alpha_cutouts = textures.iter().flatten().any(MaterialTextures::has_alpha);
        let mut background = background;
        let mut materials = material_descs.iter().map(material_from_desc).collect::<Result<Vec<_>>>()?;
        for (i, m) in materials.iter_mut().enumerate().filter(|(i, _)| solid.get(*i).copied().unwrap_or(false)) {
            m.model = solid_glass_model(&material_descs[i], m.model);
        }
        warn_unused_keys(&material_descs, &mut warnings);
        warn_isotropic_parts(&material_descs, &materials, &mut warnings);
        add_mikktspace_tangents(
            meshes.iter_mut().chain(placed_meshes(&mut instances)),
            &textures,
            &material_descs,
            &mut memory,
            &mut warnings,
        )?;
        let mut geometry = Scene::build_with_instances(spheres, meshes, instances)?;
        // Surface coordinates on spheres serve textures only: without any, sphere hits skip them.
        geometry.set_sphere_uvs(!textures.is_empty());
        let vertex_colors = if vertex_colored.contains(&true) {
            let started = std::time::Instant::now();
            let colors = fit_vertex_colors(&geometry, &textures, &material_descs, &mut memory, &mut warnings)?;
            let meshes = colors.iter().flatten().count();
            warnings.push(format!(
                "vertex colours: {meshes} mesh(es), {:.1} MiB as spectra, fitted in {:.2} s; rendered by the path integrator (whitted-hall uses the factors and an emissive texture's mean colour)",
                vertex_color_bytes(&colors) as f64 / (1024.0 * 1024.0),
                started.elapsed().as_secs_f64()
            ));
            colors
        } else {
            Vec::new()
        };
        let (center, radius) = framing_sphere(framing.or(bounds));
        // A description built by hand may set `camera` without `cameras`.
        if let (Some(c), true) = (camera, cameras.is_empty()) {
            cameras.push(("camera".to_owned(), c));
        }
        // The cheap pass over the built BVH: which default view shows most, and what the emitters light.
        let double_sided: Vec<bool> =
            material_descs.iter().map(|d| d.format == MaterialFormat::Gltf && d.double_sided == Some(true)).collect();
        let framed = framing.or(bounds).unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
        let survey = Survey::new(&geometry, &materials, double_sided, &light_descs, framed);
        let chosen = choose_camera(format, &cameras, bounds, framing, &options.camera, Some(&survey), &mut warnings)?;
        if cameras.is_empty() || chosen.source.contains("command line") {
            warnings.push(format!("camera: {}", chosen.source));
            if let Some(note) = framing_note.filter(|_| cameras.is_empty()) {
                warnings.push(format!("camera: {note}"));
            }
        }
        let (camera, camera_source) = (chosen.desc, chosen.source);
        let settings_integrator = auto_integrator(&settings)?;
        // glTF lights are KHR_lights_punctual: candela (point, spot) and lux (directional).
        let photometric_lights = (format == geometry::SceneFormat::Gltf && !light_descs.is_empty())
            || options.sky.is_some()
            || options.cie_sky.is_some();
        let resolution = image_size(&camera, None, None);

        let sky_lights =
            replace_environment(options, &mut light_descs, &mut background, &camera, &materials, &mut warnings)?;
        let mut lights = build_lights(&light_descs, &mut memory, &mut source_hash, &mut source_files, &mut warnings)?;
        if let Some((added, descs)) = sky_lights {
            lights.extend(added);
            light_descs.extend(descs);
        }
        let emissive = materials.iter().any(Material::emits);
        // How brightly the emitters alone light what the camera sees, where the rule asks.
        let emitter_light = (emissive
            && lights.is_empty()
            && background.is_none()
            && matches!(format, SceneFormat::Gltf | SceneFormat::Obj)
            && survey.has_emitters())
        .then(|| {
            let aspect = options.camera.aspect.unwrap_or(resolution.0 as f32 / resolution.1 as f32);
            survey.emitter_light(&camera, aspect)
        })
        .flatten();
        drop(survey);
        let world = World {
            format,
            camera: &camera,
            center,
            radius,
            emissive,
            has_background: background.is_some(),
            blender,
            emitter_light,
        };
        let lights_why =
            add_default_lights(options.default_lights, &world, &mut lights, &mut light_descs, &mut warnings)?;
        let orthographic = matches!(camera.projection, geometry::Projection::Orthographic { .. });
        let auto_integrator = match (settings.integrator.is_none(), orthographic) {
            (true, false) => caustic_integrator(&lights, &materials).unwrap_or(settings_integrator),
            _ => settings_integrator,
        };

        let background = match background {
            Some((spectrum, intensity)) => Some(
                emission_spectrum(&spectrum, intensity)
                    .map_err(|source| Error::Spectrum { what: "background", source })?,
            ),
            None => None,
        };

        let mut scene = Self {
            geometry,
            materials,
            textures,
            vertex_colors,
            alpha_cutouts,
            default_material: default_material(format),
            lights,
            emitters: Emitters::default(),
            camera,
            camera_source,
            auto_integrator,
            photometric_lights,
            gltf_or_obj: matches!(format, SceneFormat::Gltf | SceneFormat::Obj),
            resolution,
            background,
            settings,
            light_descs,
            lights_why,
            warnings,
            source_hash,
            source_files,
            memory,
        };
        scene.emitters = Emitters::new(
            &scene.lights,
            scene.background.as_ref(),
            &scene.geometry,
            |id| scene.primitive_material(id),
            |m| {
                let m = scene.materials.get(m as usize).filter(|m| m.emits())?;
                Some((m.emission.as_ref()?, m.two_sided))
            },
        );
        weigh_textured_lights(&mut scene);
        Ok(scene)
    }

    /// The material index of a primitive (spheres first, then triangles), `None` if it has none.
    pub(crate) fn primitive_material(&self, id: u32) -> Option<u32> {
        match self.geometry.primitive(id) {
            geometry::Primitive::Sphere { index } => self.geometry.spheres().get(index as usize)?.material(),
            geometry::Primitive::Triangle { mesh, .. } => self.geometry.meshes().get(mesh as usize)?.material(),
        }
    }

    /// Digest (XXH64) of the bytes of the scene file and every file it refers to; film files
    /// record it so that parts are known to come from the same scene.
    pub fn source_hash(&self) -> u64 {
        self.source_hash
    }

    /// The files the scene was read from: the scene file, the files it refers to (meshes, MTL,
    /// buffers, textures, spectrum CSVs) and the environment map, as resolved (relative to the
    /// working folder unless absolute); none for a scene built in code. No output may replace one.
    pub fn input_files(&self) -> &[std::path::PathBuf] {
        &self.source_files
    }

    /// The image size the scene asks for (the paper's 640×480 if it does not say; a camera's aspect
    /// ratio sets the height from the width).
    pub fn resolution(&self) -> (u32, u32) {
        self.resolution
    }

    /// The image size for a requested `width` and `height`, each filled in when missing: from the
    /// camera's fixed size, else the one side from the other by the camera's aspect ratio, else the
    /// default 640×480.
    pub fn resolution_for(&self, width: Option<u32>, height: Option<u32>) -> (u32, u32) {
        image_size(&self.camera, width, height)
    }

    /// The acceleration structure and primitives.
    pub fn geometry(&self) -> &Scene {
        &self.geometry
    }

    /// All materials, in description order.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// The camera a render uses, and where it comes from (the file's, the default view, overrides).
    pub fn camera_desc(&self) -> (&CameraDesc, &str) {
        (&self.camera, &self.camera_source)
    }

    /// The scene's lights as descriptions: the file's, and what assembly added (default lights, a world, the
    /// sky), in order. Emissive surfaces are not among them (see [`RenderScene::materials`]).
    pub fn light_descs(&self) -> &[LightDesc] {
        &self.light_descs
    }

    /// What `--integrator auto` renders this scene with, and why (one line for the user).
    pub fn auto_integrator(&self) -> (IntegratorKind, &str) {
        (self.auto_integrator.0, &self.auto_integrator.1)
    }

    /// The first fluorescent material, if the scene has one (only the path tracer shifts wavelengths).
    pub fn fluorescent_material(&self) -> Option<&str> {
        self.materials.iter().find(|m| m.fluorescence.is_some()).map(|m| m.name.as_str())
    }

    /// Whether the file's lights are photometric (glTF: candela and lux), so the image is absolute and the
    /// PNG is auto-exposed by default.
    pub fn has_photometric_lights(&self) -> bool {
        self.photometric_lights
    }

    /// Whether the scene is a glTF or OBJ file rather than a manifest. Such files are authored for
    /// display (their PNG defaults to the PBR Neutral tone curve); manifests are colour-accuracy work
    /// (clamp).
    pub fn is_gltf_or_obj(&self) -> bool {
        self.gltf_or_obj
    }

    /// How this scene's PNG is shown, and why (a note for the user): `ev` (a fixed exposure) or `auto`
    /// if asked for, else auto-exposure for photometric lights (absolute values) and EV 0 otherwise;
    /// `tonemap` if asked for, else PBR Neutral for glTF and OBJ files (authored for display:
    /// highlights roll off instead of clipping, as in the Khronos sample viewer) and clamp for
    /// manifests (colour-accuracy work: every colour below white exact).
    pub fn view_plan(&self, ev: Option<f32>, auto: bool, tonemap: Option<Tonemap>) -> Result<(ViewPlan, &'static str)> {
        let tonemap = tonemap.unwrap_or(if self.gltf_or_obj { Tonemap::PbrNeutral } else { Tonemap::Clamp });
        let (exposure, why) = match ev {
            Some(ev) if !(ev.is_finite() && ev.abs() <= 100.0) => {
                return Err(Error::OutOfRange { what: "exposure", value: ev.into(), range: "[-100, 100] stops" });
            }
            Some(ev) => (Exposure::Fixed(ev), "--exposure"),
            None if auto => (Exposure::Auto, "--auto-exposure"),
            None if self.photometric_lights => {
                (Exposure::Auto, "the file's lights are photometric (candela, lux): its values are absolute")
            }
            None => (Exposure::Fixed(0.0), "the default for relative units"),
        };
        Ok((ViewPlan { exposure, tonemap }, why))
    }

    /// A camera for an image of the given size.
    pub(crate) fn camera(&self, width: u32, height: u32) -> Result<Camera> {
        let c = &self.camera;
        let aspect = width as f32 / height as f32;
        match c.projection {
            Projection::Perspective => Camera::look_at(c.position, c.look_at, c.up, c.vfov_deg, aspect),
            Projection::Orthographic { ymag, .. } => Camera::orthographic(c.position, c.look_at, c.up, ymag, aspect),
        }
        .map_err(|e| Error::Camera(e.to_string()))
    }
}

/// The image size: `width` and `height` if given, else the camera's fixed size; a side still missing comes
/// from the other through the camera's aspect ratio (rounded, at least 1 pixel) when the file gives one,
/// else from the default 640×480.
fn image_size(camera: &CameraDesc, width: Option<u32>, height: Option<u32>) -> (u32, u32) {
    let (width, height) = (width.or(camera.width), height.or(camera.height));
    let from = |side: u32, scale: f32| ((side as f32 * scale).round() as u32).max(1);
    match (width, height, camera.aspect_ratio) {
        (Some(w), Some(h), _) => (w, h),
        (Some(w), None, Some(a)) => (w, from(w, 1.0 / a)),
        (None, Some(h), Some(a)) => (from(h, a), h),
        (None, None, Some(a)) => (DEFAULT_RESOLUTION.0, from(DEFAULT_RESOLUTION.0, 1.0 / a)),
        (w, h, None) => (w.unwrap_or(DEFAULT_RESOLUTION.0), h.unwrap_or(DEFAULT_RESOLUTION.1)),
    }
}

/// Centre and radius of the bounding sphere of the bounds' box; a unit box at the origin when the scene has
/// no geometry, and at least a tiny positive radius so a single point works.
fn framing_sphere(bounds: Option<(Vec3, Vec3)>) -> (Vec3, f32) {
    let (lo, hi) = bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3))
}

/// What `--integrator auto` picks: the scene's `settings.integrator` when it names one (the paper's scenes ask
/// for `whitted-hall`), else the path tracer, which handles emissive surfaces and energy-conserving glass.
fn auto_integrator(settings: &Settings) -> Result<(IntegratorKind, String)> {
    match &settings.integrator {
        None => Ok((
            IntegratorKind::Path,
            "path: the default for scenes whose settings do not ask for the paper's model".to_owned(),
        )),
        Some(name) => {
            let kind = name.parse::<IntegratorKind>().map_err(|_| Error::InvalidOption {
                option: "settings.integrator",
                value: name.clone(),
                expected: "whitted-hall, path, bdpt or sppm",
            })?;
            let label = match kind {
                IntegratorKind::WhittedHall => "whitted-hall",
                IntegratorKind::Path => "path",
                IntegratorKind::Bdpt => "bdpt",
                IntegratorKind::Sppm => "sppm",
            };
            Ok((kind, format!("{label}: the scene's settings ask for it (\"integrator\": \"{name}\")")))
        }
    }
}

/// Bidirectional path tracing, with the reason, where the scene has caustics the path tracer cannot find: a
/// point, spot or luminaire light (a delta light: no path from the camera can hit it) and a smooth surface
/// that refracts or mirrors (glass, a thin pane, a mirror or polished metal of roughness below
/// [`CAUSTIC_ROUGHNESS`]), through which that light reaches whatever lies beyond. Otherwise `None`: the path
/// tracer, and the scene pays nothing for BDPT.
fn caustic_integrator(lights: &[Light], materials: &[Material]) -> Option<(IntegratorKind, String)> {
    let delta = lights.iter().filter(|l| l.kind.is_delta() && !matches!(l.kind, LightKind::Directional { .. })).count();
    // (Bidirectional path tracing does not shift wavelengths: a fluorescent scene stays with the path tracer.)
    if delta == 0 || materials.iter().any(|m| m.fluorescence.is_some()) {
        return None;
    }
    let smooth = |m: &&Material| match m.model {
        MaterialModel::Mirror | MaterialModel::ThinDielectric => true,
        MaterialModel::Dielectric { roughness } | MaterialModel::Conductor { roughness, .. } => {
            roughness < CAUSTIC_ROUGHNESS
        }
        MaterialModel::GltfTransmission { roughness, transmission, .. } => {
            transmission > 0.0 && roughness < CAUSTIC_ROUGHNESS
        }
        _ => false,
    };
    let caster = materials.iter().find(smooth)?;
    let lights =
        if delta == 1 { "a point, spot or luminaire light shines" } else { "point, spot or luminaire lights shine" };
    Some((
        IntegratorKind::Bdpt,
        format!(
            "bdpt: {lights} through or off a smooth surface (material `{}`): caustics the path tracer cannot find",
            caster.name
        ),
    ))
}

/// Roughness (α = roughness²) below which a refracting or mirroring surface focuses a point light into a
/// caustic the path tracer misses: at 0.3 (α 0.09) a glossy lobe still concentrates the light into a
/// spot a few degrees wide, which camera paths find only by chance.
const CAUSTIC_ROUGHNESS: f32 = 0.3;

/// The light of a scene that has neither lights nor emitters: D65, up-left-front, ten bounding radii away
/// (as the paper's light), intensity d² so the irradiance at the centre is 1. Coordinates are bounded by
/// `geometry::MAX_COORDINATE` (1e18), so d² ≤ (10 · √3 · 1e18)² = 3e38 stays finite in f32.
fn default_light(center: Vec3, radius: f32) -> LightDesc {
    let (position, candela) = default_point_light(center, radius);
    LightDesc::Point {
        position,
        spectrum: SpectrumDesc::Named("D65".into()),
        intensity: LightAmount { value: candela, unit: LightUnit::Candela },
    }
}

/// Where [`default_light`] stands and its intensity in candela: 10 radii out, above, left and in
/// front, giving 1 lux at the centre.
fn default_point_light(center: Vec3, radius: f32) -> (Vec3, f32) {
    let distance = 10.0 * radius;
    (center + distance * Vec3::new(-1.0, 1.0, 1.0).normalize(), distance * distance)
}

/// Luminance the default environment gives a white Lambertian surface (it sees the whole hemisphere).
const ENVIRONMENT_NITS: f32 = 0.3;
/// Luminance the default key light adds to a white Lambertian surface facing the camera.
const KEY_NITS: f32 = 0.5;
/// Blender's default world colour (0.050876, the sRGB grey 0.25 linearised), in W/(m² sr).
const BLENDER_WORLD: f32 = 0.050_876;
/// Blender's default world around a file's lamps: [`BLENDER_WORLD`] in the units its lamps are
/// exported in. Blender's exporter writes a lamp of P watts as P · 683 / 4π cd (a 1,500 W lamp is
/// 81,527 cd): watts at K_m = 683 lm/W, so its world of 0.050876 W/(m² sr) is 34.7 nits beside them.
const LAMP_WORLD_NITS: f32 = BLENDER_WORLD * colorimetry::K_M as f32;
/// The world around a file's own lamps: [`LAMP_WORLD_NITS`], but never more than a fill three stops below the
/// brightest lamp's illuminance E at the scene's centre (a white surface it lights head-on reads E/π, the
/// world E/8π), so that a scene lit by weak lamps keeps its pools of light instead of drowning in the
/// world: Khronos' *AnimateAllTheThings* (blenderio/24_animation_pointer) is lit by 3–16 cd spots.
fn lamp_world_nits(lights: &[LightDesc], center: Vec3) -> f32 {
    let illuminance = |l: &LightDesc| match l {
        LightDesc::Point { position, intensity, .. } | LightDesc::Spot { position, intensity, .. }
            if intensity.unit == LightUnit::Candela =>
        {
            intensity.value / position.distance_squared(center).max(1e-6)
        }
        LightDesc::Directional { intensity, .. } if intensity.unit == LightUnit::Lux => intensity.value,
        _ => 0.0,
    };
    let brightest = lights.iter().map(illuminance).filter(|e| e.is_finite()).fold(0.0, f32::max);
    if brightest > 0.0 { LAMP_WORLD_NITS.min(brightest / (8.0 * std::f32::consts::PI)) } else { LAMP_WORLD_NITS }
}

/// The key light comes from up, and to the right, behind the camera: (−forward + up + ½ right), normalised.
const KEY_FROM: [f32; 3] = [1.0, 1.0, 0.5];

/// cos θ between the key light and the normal of a surface facing the camera: 1 / |(1, 1, ½)| = 2/3.
fn key_cos() -> f32 {
    1.0 / Vec3::from(KEY_FROM).length()
}

/// Illuminance of the key light (lux) such that a white Lambertian surface facing the camera gets
/// `KEY_NITS` from it: L = E cos θ / π.
fn key_illuminance() -> f32 {
    KEY_NITS * std::f32::consts::PI / key_cos()
}

/// The unit direction towards the default key light: behind, above and to the right of the camera
/// (`KEY_FROM` in the camera's frame).
fn towards_key_light(camera: &CameraDesc) -> Vec3 {
    let forward = (camera.look_at - camera.position).normalize_or(Vec3::NEG_Z);
    let right = forward.cross(camera.up).normalize_or(Vec3::X);
    let up = right.cross(forward);
    let [b, u, r] = KEY_FROM;
    (-forward * b + up * u + right * r).normalize()
}

/// The default lights of a glTF or OBJ file ([`decide_lights`]): a uniform D65 environment and a D65 key light
/// placed relative to the camera, so a white Lambertian surface facing the camera has luminance 0.8
/// (0.3 + 0.5); without `environment` (`--light-env none`) only the key light.
fn default_lights(camera: &CameraDesc, environment: bool) -> Vec<LightDesc> {
    let key = LightDesc::Directional {
        direction: -towards_key_light(camera),
        spectrum: SpectrumDesc::Named("D65".into()),
        intensity: LightAmount { value: key_illuminance(), unit: LightUnit::Lux },
    };
    if environment { vec![uniform_environment(ENVIRONMENT_NITS), key] } else { vec![key] }
}

/// A uniform D65 environment of `nits`.
fn uniform_environment(nits: f32) -> LightDesc {
    LightDesc::Environment {
        spectrum: SpectrumDesc::Named("D65".into()),
        intensity: LightAmount { value: nits, unit: LightUnit::Nit },
        map: None,
    }
}

/// The lights of `--light-env sky`: the baked sky map, and the sun as a directional light (or, without the
/// sun, the key light of [`default_lights`] scaled so that it is to the sky what it is to the uniform
/// default environment; none when the file is `lit` by lights or emitters of its own); their
/// descriptions (for `info`) and a note.
fn sky_lights(sky: &SkyOption, camera: &CameraDesc, lit: bool) -> Result<(Vec<Light>, Vec<LightDesc>, String)> {
    let fail = |reason: String| Error::EnvironmentMap { path: PathBuf::from("--light-env sky"), reason };
    if !(sky.intensity.is_finite() && sky.intensity >= 0.0) {
        return Err(fail(format!("intensity {} must be finite and ≥ 0", sky.intensity)));
    }
    let key = default_lights(camera, false);
    // The key light's azimuth in the maps' φ (towards the light: d = (sin φ, ·, −cos φ)).
    let towards_key = towards_key_light(camera);
    let azimuth = sky.sun_azimuth_deg.unwrap_or_else(|| towards_key.x.atan2(-towards_key.z).to_degrees());
    let model = crate::lights::sky::PreethamSky::new(sky.turbidity, sky.sun_elevation_deg, azimuth).map_err(fail)?;
    let (width, height) = crate::lights::sky::SKY_MAP_SIZE;
    let map = model.bake(width, height, f64::from(sky.intensity))?;
    let sky_desc = LightDesc::Environment {
        spectrum: SpectrumDesc::Named(format!(
            "Preetham sky T={} sun {}° at azimuth {azimuth:.1}°",
            sky.turbidity, sky.sun_elevation_deg
        )),
        intensity: LightAmount { value: sky.intensity, unit: LightUnit::Nit },
        map: None,
    };
    let horizontal = model.horizontal_illuminance(256, 512) * f64::from(sky.intensity);
    let mut lights = vec![Light::environment_map(map)];
    let mut descs = vec![sky_desc];
    let mut note = format!(
        "--light-env sky: Preetham sky, turbidity {}, sun {}° above the horizon at azimuth {azimuth:.1}°; the sky gives {horizontal:.0} lux on a horizontal plane",
        sky.turbidity, sky.sun_elevation_deg
    );
    if sky.sun {
        // K_m Σ E ȳ Δλ (1 nm): the sun's illuminance at normal incidence, lux.
        let irradiance = model.sun_irradiance();
        let lux = colorimetry::K_M
            * colorimetry::y_sum()
            * colorimetry::relative_luminance(&irradiance)
            * f64::from(sky.intensity);
        let spectrum = colorimetry::luminance_normalized(&irradiance).scaled(lux);
        let direction = -model.sun_direction();
        lights.push(Light::new(LightKind::Directional { direction }, spectrum));
        descs.push(LightDesc::Directional {
            direction,
            spectrum: SpectrumDesc::Named(format!("Preetham sun T={} at {}°", sky.turbidity, sky.sun_elevation_deg)),
            intensity: LightAmount { value: lux as f32, unit: LightUnit::Lux },
        });
        note.push_str(&format!(", the sun (a directional light) {lux:.0} lux at normal incidence"));
    } else if !lit {
        // The key light's share as with the uniform default: KEY_NITS against ENVIRONMENT_NITS of a white
        // plane's luminance, here E_h / π.
        let scale = horizontal / PI / f64::from(ENVIRONMENT_NITS);
        for k in key {
            if let LightDesc::Directional { direction, spectrum, intensity } = k {
                let intensity =
                    LightAmount { value: (f64::from(intensity.value) * scale) as f32, unit: LightUnit::Lux };
                let desc = LightDesc::Directional { direction, spectrum, intensity };
                lights
                    .push(light_from_desc(&desc).map_err(|source| Error::Spectrum { what: "the key light", source })?);
                note.push_str(&format!(", no sun (--no-sun): a D65 key light of {:.0} lux", intensity.value));
                descs.push(desc);
            }
        }
    }
    Ok((lights, descs, note))
}

/// The lights of `--light-env cie-sky:N`: the sky as an analytic environment map and, if asked for, the sun
/// as a directional light (no key light: the standard sky is the scene's light, in absolute units); their
/// descriptions (for `info`) and a note.
fn cie_sky_lights(cie: &CieSkyOption, camera: &CameraDesc) -> Result<(Vec<Light>, Vec<LightDesc>, String)> {
    let fail = |reason: String| Error::EnvironmentMap { path: PathBuf::from("--light-env cie-sky"), reason };
    let towards_key = towards_key_light(camera);
    let azimuth = cie.sun_azimuth_deg.unwrap_or_else(|| towards_key.x.atan2(-towards_key.z).to_degrees());
    let model = CieSky::new(cie.sky_type, cie.sun_elevation_deg, azimuth, cie.scale).map_err(fail)?;
    let (width, height) = CIE_SKY_MAP_SIZE;
    let map = model.environment_map(f64::from(cie.cct), width, height)?;
    let horizontal = model.horizontal_illuminance();
    let zenith = model.zenith_luminance();
    let sky_desc = LightDesc::Environment {
        spectrum: SpectrumDesc::Named(format!(
            "CIE sky type {} D{} sun {}° at azimuth {azimuth:.1}°",
            cie.sky_type, cie.cct, cie.sun_elevation_deg
        )),
        intensity: LightAmount { value: zenith as f32, unit: LightUnit::Nit },
        map: None,
    };
    let mut lights = vec![Light::environment_map(map)];
    let mut descs = vec![sky_desc];
    let mut note = format!(
        "--light-env cie-sky:{}: CIE standard general sky type {}, CIE daylight of {} K, the sun {}° above the horizon at azimuth {azimuth:.1}°; zenith {zenith:.0} nits, {horizontal:.0} lux on a horizontal plane",
        cie.sky_type, cie.sky_type, cie.cct, cie.sun_elevation_deg
    );
    if let Some(sun) = &cie.sun {
        let sin_elevation = f64::from(cie.sun_elevation_deg).to_radians().sin();
        let normal = if sun.horizontal {
            if !(sin_elevation > 1e-6) {
                return Err(fail("a horizontal sun illuminance needs the sun above the horizon".to_owned()));
            }
            f64::from(sun.illuminance_lux) / sin_elevation
        } else {
            f64::from(sun.illuminance_lux)
        };
        if !(normal.is_finite() && normal >= 0.0) {
            return Err(fail(format!("sun illuminance {} must be finite and ≥ 0", sun.illuminance_lux)));
        }
        colorimetry::Illuminant::parse(&sun.spectrum).map_err(|e| fail(format!("sun spectrum: {e}")))?;
        let desc = LightDesc::Directional {
            direction: -model.sun_direction(),
            spectrum: SpectrumDesc::Named(sun.spectrum.clone()),
            intensity: LightAmount { value: normal as f32, unit: LightUnit::Lux },
        };
        lights.push(light_from_desc(&desc).map_err(|source| Error::Spectrum { what: "the sun", source })?);
        descs.push(desc);
        note.push_str(&format!(
            "; the sun (a directional light, {}) {normal:.0} lux at normal incidence, {:.0} lux on a horizontal plane",
            sun.spectrum,
            normal * sin_elevation
        ));
    }
    Ok((lights, descs, note))
}

/// MikkTSpace tangents for every mesh whose material has a normal map or is anisotropic
/// (`KHR_materials_anisotropy`, whose direction is given in tangent space) and whose file gives no
/// `TANGENT` (`tangents.rs`), charged to the scene's memory budget (16 bytes per vertex, and each
/// vertex a uv seam splits); one warning says how many meshes got them, and one names the anisotropic
/// meshes that have neither tangents nor UVs.
fn add_mikktspace_tangents<'a>(
    meshes: impl Iterator<Item = &'a mut geometry::Mesh>,
    textures: &[Option<MaterialTextures>],
    descs: &[MaterialDesc],
    memory: &mut geometry::MemoryBudget,
    warnings: &mut Vec<String>,
) -> Result<()> {
    let mut generated = 0;
    let mut undirected = Vec::new();
    for (i, mesh) in meshes.enumerate() {
        let Some(m) = mesh.material().map(|m| m as usize) else { continue };
        let anisotropic = descs.get(m).is_some_and(|d| d.anisotropy.is_some());
        let normal_mapped = textures.get(m).and_then(Option::as_ref).is_some_and(MaterialTextures::has_normal_map);
        if !(normal_mapped || anisotropic) || mesh.tangents().is_some() {
            continue;
        }
        if mesh.uvs().is_none() {
            if anisotropic {
                undirected.push(i);
            }
            continue;
        }
        // Tangents (16 B) for every vertex, and at most one split vertex (position, normal, uv,
        // tangent: 48 B) per triangle corner.
        let worst = 16 * mesh.positions().len() as u64 + 48 * 3 * mesh.triangle_count() as u64;
        let label = format!("mesh {i}");
        memory.fits(std::path::Path::new(&label), || "MikkTSpace tangents".to_owned(), worst)?;
        if let Some(with) = crate::scene::tangents::with_mikktspace_tangents(mesh) {
            let bytes =
                16 * with.positions().len() as u64 + 32 * (with.positions().len() - mesh.positions().len()) as u64;
            memory.charge(std::path::Path::new(&label), || "MikkTSpace tangents".to_owned(), bytes)?;
            *mesh = with;
            generated += 1;
        }
    }
    if generated > 0 {
        warnings.push(format!(
            "normal maps: MikkTSpace tangents generated for {generated} mesh(es) the file gives none (glTF 2.0 §3.7.2.1)"
        ));
    }
    if !undirected.is_empty() {
        warnings.push(format!(
            "KHR_materials_anisotropy: mesh(es) {undirected:?} have neither TANGENT nor UVs; their direction of anisotropy is an arbitrary one about the normal"
        ));
    }
    Ok(())
}

/// Light choice over the triangles of emissive textures: each triangle's power is its area × the mean
/// emission of its material (all the light knows), so its share is redistributed by the texels it covers.
/// Its weight is 0.1 + 0.9 · Y_t / Ȳ, where Y_t is the mean texel luminance over the triangle (16 stratified
/// points) and Ȳ the area-weighted mean of Y_t over the material's emissive triangles. The material's total
/// power is unchanged, and every triangle keeps a positive probability (16 points can miss bright texels:
/// the estimate stays unbiased however wrong the weight).
fn weigh_textured_lights(scene: &mut RenderScene) {
    if scene.textures.iter().flatten().all(|t| !t.has_emissive_texture()) {
        return;
    }
    let mut mean_luminance = Vec::new();
    for (primitive, light) in scene.emitters.area_lights() {
        let Some(material) = scene.primitive_material(primitive) else { continue };
        let Some(t) = scene.textures.get(material as usize).and_then(Option::as_ref) else { continue };
        if !t.has_emissive_texture() {
            continue;
        }
        let geometry::Primitive::Triangle { mesh, triangle } = scene.geometry.primitive(primitive) else { continue };
        let mesh = &scene.geometry.meshes()[mesh as usize];
        let uv = crate::surface::triangle_uvs(mesh, triangle as usize, t.emissive_reads_second_uvs());
        let mut sum = 0.0f64;
        for k in 0..16 {
            // A 4 × 4 grid on the unit square, mapped to the triangle as light sampling maps its points.
            let u = Vec2::new((k % 4) as f32 * 0.25 + 0.125, (k / 4) as f32 * 0.25 + 0.125);
            let (b0, b1) = crate::sampling::uniform_triangle(u);
            let at = crate::texture::Uv::same(b0 * uv[0] + b1 * uv[1] + (1.0 - b0 - b1) * uv[2]);
            sum += f64::from(t.emissive_luminance(at).unwrap_or(0.0));
        }
        mean_luminance.push((light, material, sum / 16.0, f64::from(scene.geometry.primitive_area(primitive))));
    }
    // Per material: Σ Y_t A_t and Σ A_t.
    let mut totals = vec![(0.0f64, 0.0f64); scene.materials.len()];
    for &(_, material, y, area) in &mean_luminance {
        let entry = &mut totals[material as usize];
        entry.0 += y * area;
        entry.1 += area;
    }
    // A material whose texels overflow (an infinite luminance) keeps its triangles as they were, all of them,
    // so that its total power stays what its mean emission says.
    let weights: Vec<(usize, f64)> = mean_luminance
        .iter()
        .filter_map(|&(light, material, y, _)| {
            let (sum, area) = totals[material as usize];
            (sum > 0.0 && sum.is_finite() && area > 0.0).then(|| (light, 0.1 + 0.9 * y * area / sum))
        })
        .collect();
    scene.emitters.reweight(&weights);
}

/// One line per anisotropic material (`KHR_materials_anisotropy`) whose model, or part of it, renders
/// isotropic: the extension stretches the glTF metallic–roughness lobes and rough glass, not the thin-walled
/// slab (which has no roughness) or the other models.
fn warn_isotropic_parts(descs: &[MaterialDesc], materials: &[Material], warnings: &mut Vec<String>) {
    for (d, m) in descs.iter().zip(materials).filter(|(d, _)| d.anisotropy.is_some()) {
        match m.model {
            MaterialModel::GltfMetalRough { .. }
            | MaterialModel::Dielectric { .. }
            | MaterialModel::GltfTransmission { thin: false, .. } => {}
            MaterialModel::GltfTransmission { thin: true, .. } => warnings.push(format!(
                "material {:?}: KHR_materials_anisotropy stretches its reflection; its thin-walled transmitting part has no roughness and renders unstretched",
                d.name
            )),
            _ => warnings.push(format!(
                "material {:?}: KHR_materials_anisotropy is not rendered by its {} model; ignored",
                d.name,
                m.model.name()
            )),
        }
    }
}

/// Which materials have a base colour varying per hit through vertex colours (decided once, as for
/// textures: the path tracer's textured instantiation then reads them). Meshes with vertex colours
/// and no material get a white diffuse one (an OBJ without MTL: its colours are the surface's as
/// written). Placed objects' meshes count as the others do: their hits find their vertex data too.
fn vertex_colored_materials(
    meshes: &mut [geometry::Mesh],
    instances: &mut [geometry::Instances],
    material_descs: &mut Vec<MaterialDesc>,
    warnings: &mut Vec<String>,
) -> Vec<bool> {
    let without_material = meshes
        .iter()
        .chain(instances.iter().flat_map(geometry::Instances::meshes))
        .filter(|m| tinting_colors(m).is_some() && m.material().is_none())
        .count();
    if without_material > 0 {
        // An OBJ without MTL: its colours are the surface's as written, so they take a white diffuse
        // base rather than tinting the default grey.
        let index = material_descs.len() as u32;
        let mut white = MaterialDesc::new("vertex colours", MaterialFormat::Manifest);
        white.base_color = Some(SpectrumDesc::Rgb([1.0; 3]));
        material_descs.push(white);
        for m in meshes
            .iter_mut()
            .chain(placed_meshes(instances))
            .filter(|m| tinting_colors(m).is_some() && m.material().is_none())
        {
            m.set_material(Some(index));
        }
        warnings.push(format!(
            "{without_material} mesh(es) with vertex colours and no material: rendered as white diffuse × their colours"
        ));
    }
    let mut vertex_colored = vec![false; material_descs.len()];
    for m in meshes
        .iter()
        .chain(instances.iter().flat_map(geometry::Instances::meshes))
        .filter(|m| tinting_colors(m).is_some())
        .filter_map(geometry::Mesh::material)
    {
        if let Some(flag) = vertex_colored.get_mut(m as usize) {
            *flag = true;
        }
    }
    vertex_colored
}

/// The lights that replace the file's environments and background (what escaping rays would have
/// seen): `--env`'s map, added to `light_descs`, or `--light-env sky`, returned as built lights and
/// their descriptions (at most one of them).
fn replace_environment(
    options: &AssemblyOptions,
    light_descs: &mut Vec<LightDesc>,
    background: &mut Option<(SpectrumDesc, f32)>,
    camera: &CameraDesc,
    materials: &[Material],
    warnings: &mut Vec<String>,
) -> Result<Option<(Vec<Light>, Vec<LightDesc>)>> {
    if let Some(env) = &options.environment {
        let replaced = drop_environments(light_descs, background);
        warnings.push(format!(
            "--env: the scene is lit by the environment map {} × {}{replaced}",
            env.path.display(),
            env.intensity,
        ));
        light_descs.push(LightDesc::Environment {
            spectrum: SpectrumDesc::Named("D65".into()),
            intensity: LightAmount { value: env.intensity, unit: LightUnit::Nit },
            map: Some(EnvironmentMapDesc { path: env.path.clone(), rotation_deg: env.rotation_deg }),
        });
    }
    if let Some(cie) = &options.cie_sky {
        if options.environment.is_some() || options.sky.is_some() {
            return Err(Error::EnvironmentMap {
                path: PathBuf::from("--light-env cie-sky"),
                reason: "the CIE sky cannot light a scene beside an environment map or the Preetham sky".to_owned(),
            });
        }
        let replaced = drop_environments(light_descs, background);
        let (added, descs, note) = cie_sky_lights(cie, camera)?;
        warnings.push(format!("{note}{replaced}"));
        return Ok(Some((added, descs)));
    }
    Ok(match &options.sky {
        Some(_) if options.environment.is_some() => {
            return Err(Error::EnvironmentMap {
                path: PathBuf::from("--light-env sky"),
                reason: "the sky and an environment map cannot both light a scene (at most one map)".to_owned(),
            });
        }
        Some(sky) => {
            let replaced = drop_environments(light_descs, background);
            let lit = !light_descs.is_empty() || materials.iter().any(Material::emits);
            let (added, descs, note) = sky_lights(sky, camera, lit)?;
            warnings.push(format!("{note}{replaced}"));
            Some((added, descs))
        }
        None => None,
    })
}

/// Remove the file's environment lights and background; the note's tail saying what was replaced.
fn drop_environments(light_descs: &mut Vec<LightDesc>, background: &mut Option<(SpectrumDesc, f32)>) -> String {
    let replaced = light_descs.iter().filter(|l| matches!(l, LightDesc::Environment { .. })).count();
    light_descs.retain(|l| !matches!(l, LightDesc::Environment { .. }));
    let had_background = background.take().is_some();
    match (replaced, had_background) {
        (0, false) => String::new(),
        (n, b) => {
            format!(" (replacing the file's {n} environment light(s){})", if b { " and its background" } else { "" })
        }
    }
}

/// The lights the descriptions ask for; an environment map is loaded (at most one) and its bytes
/// join the scene's digest, which films record.
fn build_lights(
    light_descs: &[LightDesc],
    memory: &mut geometry::MemoryBudget,
    source_hash: &mut u64,
    source_files: &mut Vec<PathBuf>,
    warnings: &mut Vec<String>,
) -> Result<Vec<Light>> {
    let mut lights = Vec::with_capacity(light_descs.len());
    let mut map_seen: Option<usize> = None;
    for (index, l) in light_descs.iter().enumerate() {
        lights.push(match l {
            LightDesc::Environment { intensity, map: Some(m), .. } => {
                if let Some(first) = map_seen {
                    return Err(Error::EnvironmentMap {
                        path: m.path.clone(),
                        reason: format!(
                            "light {index}: a scene has at most one environment map (light {first} is one)"
                        ),
                    });
                }
                map_seen = Some(index);
                let map = EnvironmentMap::load(&m.path, intensity.value, m.rotation_deg, memory, warnings)?;
                // Films record the scene's digest: the map's bytes are part of the scene.
                *source_hash = geometry::xxh64(&map.digest().to_le_bytes(), *source_hash);
                // `--env` names a map the loaders never saw.
                if !source_files.contains(&m.path) {
                    source_files.push(m.path.clone());
                }
                Light::environment_map(map)
            }
            _ => light_from_desc(l).map_err(|source| Error::Light { index, source })?,
        });
    }
    Ok(lights)
}

/// What the default lights depend on besides the file's lights.
struct World<'a> {
    format: SceneFormat,
    camera: &'a CameraDesc,
    center: Vec3,
    radius: f32,
    emissive: bool,
    has_background: bool,
    /// Written by Blender's glTF exporter ([`written_by_blender`]).
    blender: bool,
    /// How the emitters alone light what the camera sees (`survey.rs`); measured only for a glTF or OBJ
    /// file lit by nothing else.
    emitter_light: Option<EmitterLight>,
}

/// Emitters light what the camera sees readably when they reach at least [`READABLE_LIT_FRACTION`] of the
/// surfaces it sees and the median of those lit surfaces, were it white, gets at least this luminance from
/// them directly (nits): a tenth of what the default key light gives a white surface facing the camera
/// ([`KEY_NITS`]), 3.3 stops below it. At the default exposure of relative units (EV 0) such a surface shows
/// at 8-bit sRGB 63 or more for white before the light it bounces (a grey card of 0.18 at 29): dim but
/// legible, as a room lit by its ceiling lamp is.
pub(crate) const READABLE_EMITTER_NITS: f64 = KEY_NITS as f64 / 10.0;
/// See [`READABLE_EMITTER_NITS`]: emitters that reach less than a quarter of what the camera sees leave most
/// of the image black, however bright the pool of light around them.
pub(crate) const READABLE_LIT_FRACTION: f64 = 0.25;

/// What assembly adds to the file's lights: decided in one place ([`decide_lights`]), done by
/// [`add_default_lights`].
#[derive(Debug, Clone, PartialEq)]
enum Addition {
    /// Nothing, and why (for `info`); `note`: also a note on stderr, where the user could have expected
    /// something.
    Nothing { why: String, note: bool },
    /// The uniform D65 environment (unless `environment` is false) and the key light; `why` opens the note.
    EnvironmentAndKey { environment: bool, why: Option<String> },
    /// A uniform D65 world of this many nits around the file's own lamps.
    World(f32),
    /// A manifest without light: a D65 point light.
    PointLight,
}

/// Blender's glTF exporter names itself so in `asset.generator` ("Khronos glTF Blender I/O v4.0.44"; before
/// its version 0.9, "Khronos Blender glTF 2.0 I/O").
fn written_by_blender(generator: &str) -> bool {
    generator.starts_with("Khronos glTF Blender I/O") || generator.starts_with("Khronos Blender glTF 2.0 I/O")
}

/// Blender's glTF exporter (since its version 3.4, glTF-Blender-IO PR #1760) writes its lamps in
/// photometric units at K_m = 683 lm/W (a lamp of P W as P · 683 / 4π cd; a sun of S W/m² as 683 S lux) but
/// its emission strengths as Blender's own W/(m² sr), unconverted (KhronosGroup/glTF-Blender-IO issue
/// #1766): beside its lamps its emitters are this many times too dim. Measured with Blender 3.4.1 and Cycles
/// over a white Lambertian floor (`docs/defaults.md`, "Blender's units"): an emission strength S is radiance
/// S W/(m² sr) in the units in which a P W point lamp has intensity P/4π W/sr, so 683 puts both on the
/// exporter's photometric scale (not the 683/2π the issue proposes); spectrace then renders an exported test
/// scene's emitter-to-lamp-lit-floor ratio within 0.2 % of Cycles'.
pub(crate) const BLENDER_EMISSION_FACTOR: f32 = 683.0;

/// The exporter's version (major, minor) from its `asset.generator` ("Khronos glTF Blender I/O v4.0.44");
/// `None` where it writes none (its name before version 0.9).
fn blender_exporter_version(generator: &str) -> Option<(u32, u32)> {
    let version = generator.split_once(" v")?.1;
    let mut parts = version.split('.').map(|p| p.trim().parse::<u32>().ok());
    Some((parts.next()??, parts.next()??))
}

/// The first exporter version that writes lamps in candela and lux (Blender 3.4, glTF-Blender-IO PR #1760);
/// before it lamps were written in Blender's watts, P for a point or spot lamp and S for a sun.
const BLENDER_PHOTOMETRIC_LAMPS: (u32, u32) = (3, 4);

/// In a file written by Blender's glTF exporter with lamps, the lamps and the emitters are brought to one
/// photometric scale, 683 × Cycles' values ([`BLENDER_EMISSION_FACTOR`]): emission strengths × 683, and the
/// lamps of exporters before version 3.4, written in watts, × 683 / 4π (point, spot) and × 683 (sun); with a
/// note. Without lamps there is nothing to match (the emitters keep Blender's units, Cycles' own values).
fn blender_emission_units(
    generator: &str,
    lights: &mut [LightDesc],
    descs: &mut [MaterialDesc],
    warnings: &mut Vec<String>,
) {
    if !lights.iter().any(|l| !matches!(l, LightDesc::Environment { .. })) {
        return;
    }
    let factor = BLENDER_EMISSION_FACTOR;
    let mut scaled = Vec::new();
    for d in descs.iter_mut().filter(|d| d.emission.is_some()) {
        d.emission_strength = Some(d.emission_strength.unwrap_or(1.0) * factor);
        scaled.push(format!("'{}'", d.name));
    }
    if !scaled.is_empty() {
        warnings.push(format!(
            "written by Blender's glTF exporter, which converts lamps to candela and lux but writes emission strengths unconverted (glTF-Blender-IO issue #1766): the emission of material(s) {} × {factor} to match its lamps",
            scaled.join(", ")
        ));
    }
    let version = blender_exporter_version(generator);
    if version.is_none_or(|v| v < BLENDER_PHOTOMETRIC_LAMPS) {
        for l in lights.iter_mut() {
            match l {
                LightDesc::Point { intensity, .. } | LightDesc::Spot { intensity, .. } => {
                    intensity.value *= factor / (4.0 * std::f32::consts::PI);
                }
                LightDesc::Directional { intensity, .. } => intensity.value *= factor,
                // Luminaires come from manifests only, environments have no Blender watts.
                LightDesc::Luminaire { .. } | LightDesc::Environment { .. } => {}
            }
        }
        warnings.push(format!(
            "written by Blender's glTF exporter {}, before version 3.4, which wrote lamps in Blender's watts (glTF-Blender-IO PR #1760): point and spot lamps × {factor}/4π (to candela), suns × {factor} (to lux)",
            version.map_or_else(|| "(no version)".to_owned(), |(major, minor)| format!("v{major}.{minor}"))
        ));
    }
}

/// The material of primitives that name none: a Lambertian grey of 0.8 for an OBJ file (what Blender gives
/// an OBJ without materials or MTL: its default material's base colour), 0.5 for glTF and manifests (glTF
/// primitives without a material get glTF's default material instead; the paper's scenes name theirs).
fn default_material(format: SceneFormat) -> Material {
    let grey = if format == SceneFormat::Obj { OBJ_DEFAULT_GREY } else { 0.5 };
    Material::diffuse("default grey", DenselySampledSpectrum::constant(grey))
}

/// Blender's default material's base colour (0.8, 0.8, 0.8), which its OBJ importer gives faces without a
/// material.
const OBJ_DEFAULT_GREY: f64 = 0.8;

/// What to add to a scene's own lights (`docs/defaults.md`, "Lights"): the one place the rules are.
/// `lights`: the scene's lights so far (the file's, `--env`'s map, the sky); `descs` their descriptions.
fn decide_lights(default: DefaultLights, world: &World<'_>, lights: &[Light], descs: &[LightDesc]) -> Result<Addition> {
    let own_lights = !lights.is_empty();
    let nothing = |why: &str| Ok(Addition::Nothing { why: why.to_owned(), note: false });
    if default == DefaultLights::None {
        return if !own_lights && !world.has_background && !world.emissive {
            Err(Error::NoLight)
        } else {
            nothing("--no-default-lights: nothing added")
        };
    }
    if world.format == SceneFormat::Manifest {
        return if !own_lights && !world.emissive {
            Ok(Addition::PointLight)
        } else {
            nothing("the scene's own lights and emitters: nothing added")
        };
    }
    // A glTF or OBJ file has no way to say "lit by the world": light it as a viewer would, unless what it
    // has lights it.
    if world.has_background || descs.iter().any(|l| matches!(l, LightDesc::Environment { .. })) {
        return nothing("an environment (the file's, --env's map or --light-env sky) lights it: nothing added");
    }
    let environment = default != DefaultLights::KeyOnly;
    if own_lights {
        return Ok(match default {
            // The file's own lights, but no world: glTF cannot carry one, and a Blender scene exported with
            // its lamps lost the world it was lit in.
            DefaultLights::EnvironmentAndKey => Addition::World(lamp_world_nits(descs, world.center)),
            _ if !environment => Addition::Nothing {
                why: "--light-env none: nothing added to the file's lights".to_owned(),
                note: false,
            },
            _ if world.blender => Addition::World(lamp_world_nits(descs, world.center)),
            _ => Addition::Nothing {
                why: "the file's lights are photometric (KHR_lights_punctual, candela and lux) and it was not written by Blender's exporter: nothing added, its image is its lights' alone (--light-env uniform adds a world around them)".to_owned(),
                note: true,
            },
        });
    }
    if !world.emissive {
        return Ok(Addition::EnvironmentAndKey { environment, why: None });
    }
    if default == DefaultLights::EnvironmentAndKey {
        return Ok(Addition::EnvironmentAndKey {
            environment,
            why: Some("--light-env uniform adds the default lights".to_owned()),
        });
    }
    let (threshold, fraction) = (READABLE_EMITTER_NITS, READABLE_LIT_FRACTION);
    let measured = |e: &EmitterLight| {
        format!(
            "they reach {:.0} % of the surfaces the camera sees, where a white surface would read {:.3} nits at the median",
            100.0 * e.lit_fraction,
            e.median_lit_nits
        )
    };
    Ok(match &world.emitter_light {
        Some(e) if e.lit_fraction >= fraction && e.median_lit_nits >= threshold => Addition::Nothing {
            why: format!(
                "no light in the file but its emitters, which light what the camera sees readably ({}; readable: ≥ {:.0} % and ≥ {threshold} nits): nothing added (--light-env uniform adds the default lights)",
                measured(e),
                100.0 * fraction
            ),
            note: true,
        },
        Some(e) => Addition::EnvironmentAndKey {
            environment,
            why: Some(format!(
                "they light what the camera sees too little to read by ({}; readable: ≥ {:.0} % and ≥ {threshold} nits)",
                measured(e),
                100.0 * fraction
            )),
        },
        None => Addition::EnvironmentAndKey { environment, why: Some("they light nothing the camera sees".to_owned()) },
    })
}

/// Light a scene that has too little light as a viewer would ([`decide_lights`] decides what), and say so;
/// returns the decision in one line (`info`'s `lights_why`).
fn add_default_lights(
    default: DefaultLights,
    world: &World<'_>,
    lights: &mut Vec<Light>,
    light_descs: &mut Vec<LightDesc>,
    warnings: &mut Vec<String>,
) -> Result<String> {
    let (added, why) = match decide_lights(default, world, lights, light_descs)? {
        Addition::Nothing { why, note } => {
            if note {
                warnings.push(why.clone());
            }
            return Ok(why);
        }
        Addition::EnvironmentAndKey { environment, why } => {
            let added = default_lights(world.camera, environment);
            let opening = match why {
                Some(why) => format!("no light in the file but its emitters: {why}"),
                None => "no light in the file".to_owned(),
            };
            let why = if environment {
                format!(
                    "{opening}: added a uniform D65 environment of {ENVIRONMENT_NITS} nits and a D65 key light of {:.3} lux from above and to the right of the camera (a white surface facing the camera reads {:.1})",
                    key_illuminance(),
                    ENVIRONMENT_NITS + KEY_NITS
                )
            } else {
                format!(
                    "{opening}: added a D65 key light of {:.3} lux from above and to the right of the camera over a black background (--light-env none; a white surface facing the camera reads {KEY_NITS:.1})",
                    key_illuminance()
                )
            };
            (added, why)
        }
        Addition::World(nits) => (
            vec![uniform_environment(nits)],
            format!(
                "the file's lights have no world around them: added a uniform D65 environment of {nits:.4} nits (Blender's default world in its lamps' units, {LAMP_WORLD_NITS:.1}, at most a fill 3 stops below the brightest lamp; --light-env none: none)"
            ),
        ),
        Addition::PointLight => {
            let (position, candela) = default_point_light(world.center, world.radius);
            let why = format!(
                "no light in the scene: added a D65 point light at ({:.3}, {:.3}, {:.3}) with intensity {candela:.4} cd (illuminance 1 lux at the centre)",
                position.x, position.y, position.z
            );
            (vec![default_light(world.center, world.radius)], why)
        }
    };
    warnings.push(why.clone());
    for light in &added {
        lights.push(light_from_desc(light).map_err(|source| Error::Spectrum {
            what: "the default lights (added because the file has too little light)",
            source,
        })?);
    }
    light_descs.extend(added);
    Ok(why)
}

/// A mesh's vertex colours unless every one is opaque white: exporters write those (Blender's for
/// any mesh with a colour attribute), and multiplying by 1 changes nothing, so such meshes render
/// exactly as without colours, at no cost.
fn tinting_colors(mesh: &geometry::Mesh) -> Option<&[glam::Vec4]> {
    mesh.colors().filter(|c| c.iter().any(|&v| v != glam::Vec4::ONE))
}

/// The vertex colours of each mesh of `geometry` (by mesh id) whose material takes them, fitted to spectra
/// ([`VertexColors`]). The material's base colour factor is folded into the fit where it is an RGB
/// colour and no texture gives the base colour (glTF: factor × COLOR_0, an RGB product); otherwise
/// the colours multiply the texture's or the spectrum's reflectance.
fn fit_vertex_colors(
    geometry: &Scene,
    textures: &[Option<MaterialTextures>],
    materials: &[MaterialDesc],
    memory: &mut geometry::MemoryBudget,
    warnings: &mut Vec<String>,
) -> Result<Vec<Option<VertexColors>>> {
    let mut out = Vec::new();
    for (i, mesh) in geometry.all_meshes().enumerate() {
        let material = mesh.material().map(|m| m as usize);
        let taken = material.and_then(|m| textures.get(m)).and_then(Option::as_ref);
        let (Some(colors), Some(m), Some(t)) = (tinting_colors(mesh), material, taken) else {
            out.push(None);
            continue;
        };
        let factor = match (t.has_base_color_texture(), hall_params(&materials[m]).base_color) {
            (true, _) => None,
            (false, SpectrumDesc::Rgb(c)) => Some(c),
            (false, SpectrumDesc::Constant(v)) => Some([v; 3]),
            (false, _) => None,
        };
        let label = format!("mesh {i}");
        let (fitted, exact) = VertexColors::new(colors, factor, &label, memory)?;
        if !exact {
            warnings.push(format!(
                "{label}: more than {} distinct vertex colours: they use the table lookup (ΔE00 mean 0.045, max 1.2)",
                crate::texture::MAX_REFINED_COLOURS
            ));
        }
        out.push(Some(fitted));
    }
    Ok(out)
}

/// One warning for the keys a scene writes that the renderer reads but does not honour yet.
fn warn_unused_keys(materials: &[MaterialDesc], warnings: &mut Vec<String>) {
    let names = |f: &dyn Fn(&MaterialDesc) -> bool| -> Vec<&str> {
        materials.iter().filter(|m| f(m)).map(|m| m.name.as_str()).collect()
    };
    let one_sided =
        names(&|m| m.double_sided == Some(false) && m.format != MaterialFormat::Gltf && m.emission.is_none());
    if !one_sided.is_empty() {
        warnings.push(format!(
            "material(s) {}: `double_sided: false` only makes emission one-sided; both sides are shaded",
            one_sided.join(", ")
        ));
    }
    let specular_glass =
        names(&|m| m.transmission.is_some_and(|t| t > 0.0) && m.specular_layer.is_some_and(|l| !l.is_default()));
    if !specular_glass.is_empty() {
        warnings.push(format!(
            "material(s) {}: KHR_materials_specular changes the reflection of the opaque part only; the transmitting part keeps the Fresnel of its index",
            specular_glass.join(", ")
        ));
    }
    let thick = names(&|m| m.thickness.is_some_and(|t| t > 0.0));
    if !thick.is_empty() {
        warnings.push(format!(
            "material(s) {}: `thickness` only chooses a solid over a thin wall (absorption follows the path length inside the closed mesh)",
            thick.join(", ")
        ));
    }
}

/// A light's emission on the renderer's photometric scale, where relative luminance is the light's
/// cd (point, spot), lux (directional) or nits (environment) — so the film's Y is in nits. `steradians`
/// is the solid angle a point or spot light's flux spreads over (4π; a spot's cone as pbrt-v4's
/// `SpotLight::Phi`); radiant units (W) become photometric through the spectrum's own luminous efficacy
/// K_m Σ S ȳ / Σ S (not a fixed 1/683).
fn light_spectrum(
    desc: &SpectrumDesc,
    amount: LightAmount,
    steradians: f64,
) -> materials::Result<DenselySampledSpectrum> {
    let value = f64::from(amount.value);
    let efficacy =
        || -> materials::Result<f64> { Ok(colorimetry::luminous_efficacy(&emission_spectrum_scaled(desc, 1.0)?)) };
    let photometric = match amount.unit {
        // The scale spectra are normalised to: unchanged, and bit-identical to before units existed.
        LightUnit::Candela | LightUnit::Lux | LightUnit::Nit => return emission_spectrum(desc, amount.value),
        LightUnit::Lumen => value / steradians,
        // W (point, spot) → lm → cd; W/m² → lux and W/(m² sr) → nits (steradians = 1).
        LightUnit::Watt => value * efficacy()? / steradians,
    };
    emission_spectrum_scaled(desc, photometric)
}

fn light_from_desc(desc: &LightDesc) -> materials::Result<Light> {
    Ok(match desc {
        LightDesc::Point { position, spectrum, intensity } => {
            Light::new(LightKind::Point { position: *position }, light_spectrum(spectrum, *intensity, 4.0 * PI)?)
        }
        LightDesc::Spot { position, direction, inner_cone_deg, outer_cone_deg, spectrum, intensity } => {
            let (cos_inner, cos_outer) = (inner_cone_deg.to_radians().cos(), outer_cone_deg.to_radians().cos());
            // The cone's effective solid angle: full inside, half through the smooth fall-off.
            let steradians = 2.0 * PI * (1.0 - 0.5 * f64::from(cos_inner + cos_outer));
            if intensity.unit != LightUnit::Candela && !(steradians > 0.0) {
                return Err(materials::Error::OutOfRange {
                    what: "spot cone (a flux needs a cone of positive solid angle)",
                    value: f64::from(*outer_cone_deg),
                    range: "> 0 degrees",
                });
            }
            Light::new(
                LightKind::Spot {
                    position: *position,
                    direction: direction.normalize_or(Vec3::NEG_Y),
                    cos_inner,
                    cos_outer,
                },
                light_spectrum(spectrum, *intensity, steradians)?,
            )
        }
        LightDesc::Luminaire { position, direction, up, spectrum, scale, web } => Light::new(
            LightKind::Luminaire { position: *position, web: Arc::new(Luminaire::new(web, *direction, *up)) },
            // The file's candela are luminous intensity, so the spectrum is only their colour: normalised to
            // luminance 1 as a point light's in cd, times the plain factor `intensity`.
            emission_spectrum(spectrum, *scale)?,
        ),
        LightDesc::Directional { direction, spectrum, intensity } => Light::new(
            LightKind::Directional { direction: direction.normalize_or(Vec3::NEG_Y) },
            light_spectrum(spectrum, *intensity, 1.0)?,
        ),
        // A map's radiance is its texels' (`EnvironmentMap::load`); this is the uniform one.
        LightDesc::Environment { spectrum, intensity, .. } => {
            Light::new(LightKind::Environment, light_spectrum(spectrum, *intensity, 1.0)?)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assemble(json: &str) -> RenderScene {
        RenderScene::from_description(geometry::parse_manifest(json, Path::new("."), "<test>").unwrap()).unwrap()
    }

    /// Two lamp quads share an emissive texture (white texel, black texel), one under each texel: light
    /// choice gives the white quad's triangles 0.1 + 0.9 · 2 of the shared power each and the black one's 0.1
    /// (0.95 and 0.05 of the lamp, from 0.5 and 0.5 by the material's mean alone); the weights average 1
    /// over the lamp, so the point light's share is what the material's mean gives it.
    #[test]
    fn textured_lamp_triangles_are_chosen_by_the_texels_they_cover() {
        let dir = std::env::temp_dir().join(format!("spectrace-weigh-lights-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = image::RgbaImage::new(2, 1);
        img.put_pixel(0, 0, image::Rgba([255, 255, 255, 255]));
        img.put_pixel(1, 0, image::Rgba([0, 0, 0, 255]));
        img.save(dir.join("lamp.png")).unwrap();
        std::fs::write(dir.join("lamp.mtl"), "newmtl lamp\nKd 0 0 0\nKe 1 1 1\nmap_Ke lamp.png\n").unwrap();
        // Quad A (x in [0, 1]) at the white texel's centre u = 0.25, quad B (x in [2, 3]) at the black one's.
        let obj = "mtllib lamp.mtl\nusemtl lamp\n\
                   v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 3 0 0\nv 3 1 0\nv 2 1 0\n\
                   vt 0.25 0.5\nvt 0.75 0.5\n\
                   f 1/1 2/1 3/1\nf 1/1 3/1 4/1\nf 5/2 6/2 7/2\nf 5/2 7/2 8/2\n";
        std::fs::write(dir.join("lamp.obj"), obj).unwrap();
        let manifest = r#"{"lights": [{"type": "point", "position": [0, 0, 5], "spectrum": "D65", "intensity": 1}],
            "objects": [{"type": "mesh", "file": "lamp.obj"}]}"#;
        let scene = RenderScene::from_description(geometry::parse_manifest(manifest, &dir, "m.json").unwrap()).unwrap();
        let e = &scene.emitters;
        let triangles: Vec<(u32, f32)> = e.area_lights().map(|(p, l)| (p, e.probability(l))).collect();
        assert_eq!(triangles.len(), 4);
        let lamp: f32 = triangles.iter().map(|t| t.1).sum();
        let point = e.probability(0);
        assert!((lamp + point - 1.0).abs() < 1e-5, "{triangles:?} + {point}");
        for (primitive, p) in &triangles {
            // Triangles 0, 1 are quad A's (the OBJ's face order).
            let share = if *primitive < 2 { 0.95 / 2.0 } else { 0.05 / 2.0 };
            assert!(
                (p / lamp - share).abs() < 1e-4,
                "triangle {primitive}: {} of the lamp, expected {share}",
                p / lamp
            );
        }
        // The lamp's total is its mean emission's: an untextured lamp of the image's mean (0.5) leaves the
        // point light the same share.
        std::fs::write(dir.join("lamp.mtl"), "newmtl lamp\nKd 0 0 0\nKe 0.5 0.5 0.5\n").unwrap();
        let plain = RenderScene::from_description(geometry::parse_manifest(manifest, &dir, "m.json").unwrap()).unwrap();
        let plain_point = plain.emitters.probability(0);
        assert!((point - plain_point).abs() < 1e-6, "point light {point} textured, {plain_point} untextured");
        let plain_shares: Vec<f32> = plain.emitters.area_lights().map(|(_, l)| plain.emitters.probability(l)).collect();
        assert!(plain_shares.iter().all(|p| (p - plain_shares[0]).abs() < 1e-7), "{plain_shares:?}");
    }

    /// The world around a file's lamps: Blender's 0.050876 × 683 = 34.748 nits, at most E_max / 8π.
    #[test]
    fn the_world_around_lamps_is_blenders_at_most_three_stops_below_the_brightest() {
        let d65 = || SpectrumDesc::Named("D65".into());
        let point = |cd: f32, at: Vec3| LightDesc::Point {
            position: at,
            spectrum: d65(),
            intensity: LightAmount { value: cd, unit: LightUnit::Candela },
        };
        let sun = |lux: f32| LightDesc::Directional {
            direction: -Vec3::Y,
            spectrum: d65(),
            intensity: LightAmount { value: lux, unit: LightUnit::Lux },
        };
        assert!((LAMP_WORLD_NITS - 34.748_31).abs() < 1e-3, "{LAMP_WORLD_NITS}");
        // 4 cd at 2 m: 1 lux, a fill of 1 / 8π = 0.039789 nits.
        let weak = lamp_world_nits(&[point(4.0, Vec3::new(0.0, 2.0, 0.0))], Vec3::ZERO);
        assert!((weak - 0.039_789).abs() < 1e-6, "{weak}");
        // The brightest lamp sets it: 100 lux beside the 1 lux point gives 100 / 8π = 3.9789.
        let two = lamp_world_nits(&[point(4.0, Vec3::new(0.0, 2.0, 0.0)), sun(100.0)], Vec3::ZERO);
        assert!((two - 3.978_87).abs() < 1e-4, "{two}");
        // Blender's 1,500 W lamp (81,527 cd) at 3 m: 9,058 lux, far above the cap.
        let blender = lamp_world_nits(&[point(81_527.0, Vec3::new(3.0, 0.0, 0.0))], Vec3::ZERO);
        assert_eq!(blender, LAMP_WORLD_NITS);
        // Lamps that give no illuminance there leave Blender's world.
        assert_eq!(lamp_world_nits(&[point(0.0, Vec3::Y)], Vec3::ZERO), LAMP_WORLD_NITS);

        // A glTF quad around the origin under that weak lamp, written by Blender's exporter, gets the fill as
        // one more light, as any glTF file does with `--light-env uniform`; with `--light-env none`, as a
        // manifest, or by default from another exporter (photometric lights are the scene's answer), it gets
        // nothing.
        let scene = |format, default_lights, generator: Option<&str>| {
            let mut d = SceneDescription::empty(format);
            d.generator = generator.map(str::to_owned);
            let quad = [
                Vec3::new(-1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(-1.0, 0.0, 1.0),
            ];
            d.meshes.push(geometry::Mesh::new(quad.to_vec(), None, None, vec![[0, 2, 1], [0, 3, 2]], None).unwrap());
            d.lights.push(point(4.0, Vec3::new(0.0, 2.0, 0.0)));
            let options = AssemblyOptions { default_lights, ..Default::default() };
            RenderScene::from_description_with(d, &options).unwrap().light_descs
        };
        let blender = Some("Khronos glTF Blender I/O v4.0.44");
        for lit in [
            scene(SceneFormat::Gltf, DefaultLights::Auto, blender),
            scene(SceneFormat::Gltf, DefaultLights::EnvironmentAndKey, Some("UnityGLTF")),
        ] {
            assert_eq!(lit.len(), 2, "{lit:?}");
            let LightDesc::Environment { intensity, map: None, .. } = &lit[1] else { panic!("{lit:?}") };
            assert!((intensity.value - 0.039_789).abs() < 1e-6 && intensity.unit == LightUnit::Nit, "{intensity:?}");
        }
        assert_eq!(scene(SceneFormat::Gltf, DefaultLights::Auto, Some("UnityGLTF")).len(), 1);
        assert_eq!(scene(SceneFormat::Gltf, DefaultLights::Auto, None).len(), 1);
        assert_eq!(scene(SceneFormat::Gltf, DefaultLights::KeyOnly, blender).len(), 1);
        assert_eq!(scene(SceneFormat::Manifest, DefaultLights::EnvironmentAndKey, None).len(), 1);
    }

    /// Blender's glTF exporter writes lamps in candela and lux but emission strengths unconverted: with lamps,
    /// its emitters are scaled by [`BLENDER_EMISSION_FACTOR`]; another exporter's, or a Blender file without
    /// lamps, keep theirs.
    #[test]
    fn blender_emission_strengths_are_brought_to_its_lamps_units() {
        let emission = |generator: &str, lamp: bool| {
            let mut d = SceneDescription::empty(SceneFormat::Gltf);
            d.generator = Some(generator.to_owned());
            let mut glow = MaterialDesc::new("glow", MaterialFormat::Gltf);
            glow.emission = Some(SpectrumDesc::Rgb([1.0; 3]));
            glow.emission_strength = Some(2.0);
            d.materials.push(glow);
            let quad = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
            d.meshes.push(geometry::Mesh::new(quad.to_vec(), None, None, vec![[0, 1, 2]], Some(0)).unwrap());
            if lamp {
                d.lights.push(LightDesc::Point {
                    position: Vec3::new(0.0, 0.0, 3.0),
                    spectrum: SpectrumDesc::Named("D65".into()),
                    intensity: LightAmount { value: 100.0, unit: LightUnit::Candela },
                });
            }
            let scene = RenderScene::from_description(d).unwrap();
            let y = colorimetry::relative_luminance(scene.materials[0].emission.as_ref().unwrap());
            let noted = scene.warnings.iter().any(|w| w.contains("#1766"));
            (y, noted)
        };
        let (plain, noted) = emission("UnityGLTF", true);
        assert!((plain - 2.0).abs() < 1e-6 && !noted, "{plain}");
        let (blender, noted) = emission("Khronos glTF Blender I/O v3.6.27", true);
        assert!((blender / plain - f64::from(BLENDER_EMISSION_FACTOR)).abs() < 1e-3 && noted, "{blender}");
        let (alone, noted) = emission("Khronos glTF Blender I/O v3.6.27", false);
        assert!((alone - 2.0).abs() < 1e-6 && !noted, "{alone}");
        // Before version 3.4 the lamps were watts too: 100 W becomes 100 · 683/4π = 5435.14 cd.
        let lamp = |generator: &str| {
            let mut d = SceneDescription::empty(SceneFormat::Gltf);
            d.generator = Some(generator.to_owned());
            let quad = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
            d.meshes.push(geometry::Mesh::new(quad.to_vec(), None, None, vec![[0, 1, 2]], None).unwrap());
            d.lights.push(LightDesc::Point {
                position: Vec3::new(0.0, 0.0, 3.0),
                spectrum: SpectrumDesc::Named("D65".into()),
                intensity: LightAmount { value: 100.0, unit: LightUnit::Candela },
            });
            let scene = RenderScene::from_description(d).unwrap();
            let LightDesc::Point { intensity, .. } = &scene.light_descs[0] else { panic!() };
            intensity.value
        };
        assert_eq!(blender_exporter_version("Khronos glTF Blender I/O v3.3.17"), Some((3, 3)));
        assert_eq!(blender_exporter_version("Khronos Blender glTF 2.0 I/O"), None);
        assert!((lamp("Khronos glTF Blender I/O v3.3.17") - 5435.141).abs() < 0.01);
        assert!((lamp("Khronos Blender glTF 2.0 I/O") - 5435.141).abs() < 0.01);
        assert_eq!(lamp("Khronos glTF Blender I/O v3.4.50"), 100.0);
        assert_eq!(lamp("UnityGLTF"), 100.0);
    }

    /// Issue 16: every light or emission spectrum was rescaled to luminance 1, so a measured
    /// radiance could not be used as is. `"normalize": false` keeps the values (× intensity).
    #[test]
    fn a_manifest_dielectric_without_transmittance_is_clear() {
        // Found by the Mitsuba comparison: a bare `{"model": "dielectric"}` was tinted by the default
        // base colour 0.5 (0.125 of the environment through the centre of a sphere instead of 0.5).
        let scene = assemble(
            r#"{"materials": {"glass": {"model": "dielectric", "ior": 1.5}, "grey": {"model": "dielectric", "base_color": 0.3}},
                "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "glass"},
                            {"type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "grey"}]}"#,
        );
        for m in scene.materials() {
            assert!(
                m.transmittance.values().iter().all(|&v| v == 1.0),
                "{}: {:?}",
                m.name,
                m.transmittance.values()[0]
            );
        }
    }

    #[test]
    fn absolute_spectra_keep_their_values_and_normalised_ones_have_unit_luminance() {
        let scene = |normalize: &str| {
            assemble(&format!(
                r#"{{ "camera": {{"position": [0, 0, 10], "look_at": [0, 0, 0], "vfov_deg": 30}},
                "lights": [{{"type": "point", "position": [0, 0, 10], "intensity": 3,
                             "spectrum": {{"samples": [[360, 2], [600, 4], [830, 2]]{normalize}}}}}],
                "materials": {{"lamp": {{"emission": {{"name": "D65"{normalize}}}, "emission_strength": 0.5}}}},
                "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "lamp"}}] }}"#
            ))
        };
        let absolute = scene(r#", "normalize": false"#);
        let light = &absolute.lights[0].spectrum;
        assert!((light.eval(360.0) - 6.0).abs() < 1e-12 && (light.eval(600.0) - 12.0).abs() < 1e-12);
        // D65 as tabulated (100 at 560 nm) × 0.5.
        let lamp = absolute.materials[0].emission.as_ref().unwrap();
        assert!((lamp.eval(560.0) - 50.0).abs() < 1e-9, "{}", lamp.eval(560.0));
        let relative = scene("");
        let y = colorimetry::relative_luminance;
        assert!((y(&relative.lights[0].spectrum) - 3.0).abs() < 1e-9);
        assert!((y(relative.materials[0].emission.as_ref().unwrap()) - 0.5).abs() < 1e-9);
        // The absolute light is brighter by its own luminance (between 2 and 4 here).
        let ratio = y(light) / y(&relative.lights[0].spectrum);
        assert!((2.0..4.0).contains(&ratio), "{ratio}");
    }

    /// Issue 10: one RGB → illuminant recipe. A point light of colour c and an environment-map
    /// texel of colour c are both pbrt-v4's `RGBIlluminantSpectrum` of c: the light by the exact
    /// fit (scaled to its Rec. 709 Y), the texel by the table lookup (a few ns per texel).
    #[test]
    fn rgb_lights_and_environment_texels_are_one_spectrum() {
        let lambda = colorimetry::SampledWavelengths::<8>::from_parts(
            [400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0, 760.0],
            [1.0; 8],
        );
        let mut worst = 0.0f64;
        for c in [[1.0f32, 1.0, 1.0], [1.0, 0.0, 0.0], [0.1, 0.6, 0.2], [0.2, 0.3, 0.9], [2.0, 1.6, 1.2]] {
            let scene = assemble(&format!(
                r#"{{ "camera": {{"position": [0, 0, 10], "look_at": [0, 0, 0], "vfov_deg": 30}},
                "lights": [{{"type": "point", "position": [0, 0, 10], "intensity": 1,
                             "spectrum": {{"rgb": [{}, {}, {}]}}}}],
                "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1}}] }}"#,
                c[0], c[1], c[2]
            ));
            let light = &scene.lights[0].spectrum;
            let (map, _) = EnvironmentMap::from_rgb(Path::new("<test>"), 2, 1, vec![c; 2], 1.0, 0.0).unwrap();
            let texel = map.eval(Vec3::Y, &lambda, false);
            let pbrt = colorimetry::RgbIlluminantSpectrum::fit(c.map(f64::from));
            let factor = light.eval(550.0) / pbrt.eval(550.0);
            let max = light.max_value();
            for i in 0..8 {
                let l = f64::from(lambda.lambda(i));
                // The light is the fit to f32 precision, up to its luminance factor.
                let fitted = factor * pbrt.eval(l);
                assert!((light.eval(l) / fitted - 1.0).abs() < 1e-6, "{c:?} at {l}: {} vs {fitted}", light.eval(l));
                let difference = (f64::from(texel[i]) - light.eval(l)).abs() / max;
                worst = worst.max(difference);
                // The texel is the same spectrum within the table lookup's accuracy.
                assert!(difference < 1e-2, "{c:?} at {l}: texel {} vs light {}", texel[i], light.eval(l));
            }
        }
        // Measured: 2.0e-3 of the peak at most, over these colours and wavelengths.
        assert!(worst < 5e-3, "{worst}");
    }
}
