//! The scene file: a TOML document under `data/scenes/`, read with serde. Every table rejects
//! unknown keys so a typo is an error naming the key and line, never a silent default.
//!
//! Units are scene units (metres in the built-in scenes); up is +Y; right-handed.

use serde::{Deserialize, Serialize};

pub type V3 = [f32; 3];

/// Top level of a scene file.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Scene name used in reports; defaults to the file stem.
    #[serde(default)]
    pub name: Option<String>,
    /// Seed of every sampling decision of the bake.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Diffuse bounces after the first hit (0 = direct light only).
    #[serde(default = "default_bounces")]
    pub bounces: u32,
    pub probe: ProbeConfig,
    /// More specular probes besides `[probe]` (probe A, always the first): explicit
    /// positions and/or automatic placement. Absent: probe A alone.
    #[serde(default, skip_serializing_if = "ProbesConfig::is_single")]
    pub probes: ProbesConfig,
    pub grid: GridConfig,
    #[serde(default)]
    pub sky: SkyConfig,
    #[serde(default)]
    pub sun: Option<SunConfig>,
    #[serde(default)]
    pub sphere_lights: Vec<SphereLightConfig>,
    #[serde(default)]
    pub geometry: Vec<GeometryConfig>,
    /// Reflection probes attached to a surface (seed 003): judged against the volume grid
    /// for points on that surface. Not part of the bake: changing them re-bakes nothing.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub surface_probes: Vec<SurfaceProbesConfig>,
    /// Cameras the evaluation judges the level from (its views and their ꟻLIP), instead of
    /// the ones it places itself. Not part of the bake: changing them re-bakes nothing.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cameras: Vec<CameraConfig>,
    /// Let mesh files reference files (buffers, MTLs) outside their own folder.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub allow_outside_paths: bool,
    /// Up axis of the mesh files (`"y"`, glTF's, or `"z"`, many DCC and CAD tools'): a Z-up
    /// mesh is turned so that its +Z points along the scene's +Y.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up_axis: Option<String>,
    /// Scene units per mesh unit (0.01 for meshes in centimetres in a scene in metres):
    /// every mesh file is scaled by it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub units: Option<f32>,
}

fn default_seed() -> u64 {
    1
}
fn default_bounces() -> u32 {
    1
}

/// A camera of the evaluation: where it stands and the point it looks at (its image and
/// field of view are the evaluation's).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    pub position: V3,
    pub look_at: V3,
}

/// The specular probe A.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeConfig {
    pub position: V3,
    /// N of the N×N octahedral radiance/distance map (even, 16..=2048). Default 256.
    #[serde(default = "default_probe_res")]
    pub resolution: u32,
    /// Stratified radiance samples per texel. Default 16.
    #[serde(default = "default_probe_spp")]
    pub samples_per_texel: u32,
    /// GGX importance samples per texel of each prefiltered mip. Default 128.
    #[serde(default = "default_ggx_samples")]
    pub ggx_samples: u32,
    /// Smallest mip resolution of the GGX and depth chains. Default 8.
    #[serde(default = "default_min_mip")]
    pub min_mip_resolution: u32,
}

/// More specular probes, baked as probe A is (its resolution and samples), each lookup of
/// the fitted grid choosing one per map texel.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProbesConfig {
    /// Probes at these positions, after probe A.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub positions: Vec<V3>,
    /// Place more probes automatically (`bake::placement`): greedily, where they see most
    /// of what the probes so far miss, until the next would see less than `min_gain`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub auto: bool,
    /// Most probes in all, probe A and `positions` included. Default 16.
    #[serde(default = "default_max_probes")]
    pub max: u32,
    /// The share of the sampled reflection hits a placed probe must add to what the
    /// probes so far see. Default 0.01.
    #[serde(default = "default_min_gain")]
    pub min_gain: f32,
}

impl Default for ProbesConfig {
    fn default() -> Self {
        ProbesConfig { positions: Vec::new(), auto: false, max: default_max_probes(), min_gain: default_min_gain() }
    }
}

impl ProbesConfig {
    /// Whether the scene has probe A alone (nothing to write back to a scene file).
    #[must_use]
    pub fn is_single(&self) -> bool {
        self.positions.is_empty()
            && !self.auto
            && self.max == default_max_probes()
            && self.min_gain == default_min_gain()
    }
}

/// The most specular probes a scene can have (the fitted grid's probe index is 4 bits).
pub const MAX_PROBES: u32 = 16;

fn default_max_probes() -> u32 {
    MAX_PROBES
}
fn default_min_gain() -> f32 {
    0.01
}

fn default_probe_res() -> u32 {
    256
}
fn default_probe_spp() -> u32 {
    16
}
fn default_ggx_samples() -> u32 {
    128
}
fn default_min_mip() -> u32 {
    8
}

/// The dense probe grid (Black Ops 3 / DDGI style).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GridConfig {
    pub min: V3,
    pub max: V3,
    /// Cells along x, y, z (each ≥ 1).
    pub counts: [u32; 3],
    /// N of each cell's N×N cosine-convolved irradiance map. Default 8.
    #[serde(default = "default_irr_res")]
    pub irradiance_resolution: u32,
    /// N of each cell's N×N distance-moment map, 8..=16. Default 16.
    #[serde(default = "default_depth_res")]
    pub depth_resolution: u32,
    /// Rays per distance texel (stratified inside the texel), 1..=255. Default 4.
    #[serde(default = "default_depth_spp")]
    pub depth_samples: u32,
    /// A cell is inside geometry when more than this fraction of its rays hit back faces.
    #[serde(default = "default_backface")]
    pub inside_backface_fraction: f32,
    /// A cell's probe inside geometry, or nearer to it than this fraction of the cell's
    /// smallest extent, moves within its cell to the nearest clear point (DDGI's relocation,
    /// Unity's virtual offset); 0 keeps every probe at its cell centre. Default 0.15.
    #[serde(default = "default_relocate")]
    pub relocate_clearance: f32,
}

fn default_relocate() -> f32 {
    0.15
}

fn default_irr_res() -> u32 {
    8
}
fn default_depth_res() -> u32 {
    16
}
fn default_depth_spp() -> u32 {
    4
}
fn default_backface() -> f32 {
    0.25
}

/// A grid of hemi-octahedral reflection probes on a parallelogram `corner + s·edge_u +
/// t·edge_v` (s, t in [0, 1]) facing along `edge_u × edge_v`: a water plane or a polished
/// floor (seed 003, "Baked Surface Reflections"). Probe (i, j) sits at the centre of its
/// patch, `s = (i + ½)/counts[0]`, `t = (j + ½)/counts[1]`, just off the surface.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceProbesConfig {
    pub corner: V3,
    pub edge_u: V3,
    pub edge_v: V3,
    /// Probes along edge_u and edge_v (each 1..=256).
    pub counts: [u32; 2],
    /// N of each probe's N×N hemi-octahedral tile (even, 4..=64). Default 16.
    #[serde(default = "default_surface_res")]
    pub resolution: u32,
    /// Stratified radiance samples per texel. Default 16.
    #[serde(default = "default_probe_spp")]
    pub samples_per_texel: u32,
}

fn default_surface_res() -> u32 {
    16
}

/// Radiance of rays that miss all geometry: a gradient over the up (+Y) component.
/// `color` sets all three at once (a constant sky).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SkyConfig {
    #[serde(default)]
    pub color: Option<V3>,
    #[serde(default)]
    pub zenith: Option<V3>,
    #[serde(default)]
    pub horizon: Option<V3>,
    #[serde(default)]
    pub ground: Option<V3>,
}

impl Default for SkyConfig {
    fn default() -> Self {
        Self { color: Some([0.0; 3]), zenith: None, horizon: None, ground: None }
    }
}

/// Directional sun with a finite angular size.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SunConfig {
    /// Direction from the scene towards the sun.
    pub direction: V3,
    /// Angular radius in degrees (the real sun: 0.27).
    #[serde(default = "default_sun_radius")]
    pub angular_radius_deg: f32,
    /// Irradiance on a surface facing the sun (RGB).
    pub irradiance: V3,
}

fn default_sun_radius() -> f32 {
    0.27
}

/// Spherical area light with uniform radiance.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SphereLightConfig {
    pub position: V3,
    pub radius: f32,
    pub radiance: V3,
}

/// Lambertian material: albedo and emitted radiance. One-sided unless `two_sided`: a ray
/// hitting the back of a one-sided surface sees black and counts towards "inside geometry".
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialConfig {
    #[serde(default = "default_albedo")]
    pub albedo: V3,
    #[serde(default)]
    pub emission: V3,
    #[serde(default)]
    pub two_sided: Option<bool>,
}

fn default_albedo() -> V3 {
    [0.7, 0.7, 0.7]
}

impl Default for MaterialConfig {
    fn default() -> Self {
        Self { albedo: default_albedo(), emission: [0.0; 3], two_sided: None }
    }
}

/// Affine transform applied to loaded meshes: scale, then rotate (XYZ Euler, degrees), then
/// translate.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TransformConfig {
    #[serde(default)]
    pub translate: Option<V3>,
    #[serde(default)]
    pub rotate_deg: Option<V3>,
    #[serde(default)]
    pub scale: Option<V3>,
}

/// One piece of geometry.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum GeometryConfig {
    /// Closed axis-aligned box, faces pointing out.
    Box {
        min: V3,
        max: V3,
        #[serde(default)]
        material: MaterialConfig,
    },
    /// Axis-aligned room: a box whose faces point in.
    Room {
        min: V3,
        max: V3,
        #[serde(default)]
        material: MaterialConfig,
        /// Faces to leave open: any of "-x","+x","-y","+y","-z","+z".
        #[serde(default)]
        open: Vec<String>,
    },
    /// Exact (analytic) sphere; `inward` for a closed sphere seen from inside.
    Sphere {
        center: V3,
        radius: f32,
        #[serde(default)]
        inward: bool,
        #[serde(default)]
        material: MaterialConfig,
    },
    /// Parallelogram `corner + s·edge_u + t·edge_v`, front along edge_u × edge_v.
    /// Two-sided unless the material says otherwise.
    Quad {
        corner: V3,
        edge_u: V3,
        edge_v: V3,
        #[serde(default)]
        material: MaterialConfig,
    },
    /// Vertical capped cylinder standing on `base`.
    Column {
        base: V3,
        radius: f32,
        height: f32,
        #[serde(default = "default_segments")]
        segments: u32,
        #[serde(default)]
        material: MaterialConfig,
    },
    /// Two rectangular piers joined by a semicircular vault; the opening faces along `axis`
    /// ("x" or "z").
    Arch {
        /// Centre of the opening at floor level.
        base: V3,
        /// Clear width of the opening.
        span: f32,
        /// Height of the piers (spring line of the vault).
        pier_height: f32,
        /// Thickness of piers and vault ring.
        thickness: f32,
        /// Depth along `axis`.
        depth: f32,
        #[serde(default = "default_axis")]
        axis: String,
        #[serde(default = "default_segments")]
        segments: u32,
        #[serde(default)]
        material: MaterialConfig,
    },
    /// glTF 2.0 file (.gltf or .glb), relative to the scene file: geometry, base colour
    /// (factor × texture), emission, `doubleSided`, and `KHR_lights_punctual` lights.
    Gltf {
        path: String,
        #[serde(default)]
        transform: TransformConfig,
        /// One material for every primitive, replacing the file's.
        #[serde(default)]
        material: Option<MaterialConfig>,
        /// Sidedness for every primitive, replacing the file's `doubleSided`.
        #[serde(default)]
        two_sided: Option<bool>,
    },
    /// Wavefront OBJ (+MTL), relative to the scene file.
    Obj {
        path: String,
        #[serde(default)]
        transform: TransformConfig,
        /// One material for every face, replacing the MTL's.
        #[serde(default)]
        material: Option<MaterialConfig>,
        /// Sidedness for every face (OBJ faces are one-sided by default).
        #[serde(default)]
        two_sided: Option<bool>,
    },
}

fn default_segments() -> u32 {
    16
}
fn default_axis() -> String {
    "z".to_string()
}
