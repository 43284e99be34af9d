//! `manifest.json` of a bake folder: what was baked, how, with which conventions, and how
//! long it took. Infinite distances never appear in JSON (serde_json would write `null`):
//! misses are described in words and stored as +inf only inside EXR distance layers.

use crate::bake::BakeStats;
use crate::scene::SceneFile;
use serde::{Deserialize, Serialize};

pub const BAKE_FORMAT: &str = "warpfit-bake";
/// Version 2: distance layers are named `distance_mip{m}` (the fitted grid's names).
/// Version 3: the content key of the scene and per-file checksums.
pub const BAKE_VERSION: u32 = 4;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BakeManifest {
    pub format: String,
    pub version: u32,
    pub generator: String,
    pub conventions: Conventions,
    pub scene: SceneSummary,
    pub probe: ProbeManifest,
    /// The scene's other specular probes (`[probes]`), after probe A, each in a file of
    /// its own with probe A's layout (`probe_1.exr`, …).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub others: Vec<ProbeManifest>,
    pub grid: GridManifest,
    pub stats: BakeStats,
    /// The scene file exactly as parsed (every setting that made this bake).
    pub settings: SceneFile,
    /// `Scene::content_key`: tool version, settings and every input file's bytes. A bake is
    /// reused only for a scene with the same key.
    pub key: String,
    /// The scene's input files and their checksums when baked.
    pub inputs: Vec<(String, String)>,
    /// Size and checksum of each payload, checked before a reuse.
    pub files: Vec<FileEntry>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FileEntry {
    pub file: String,
    pub bytes: u64,
    pub checksum: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Conventions {
    pub octahedral: String,
    pub up_axis: String,
    pub handedness: String,
    pub units: String,
    pub distance: String,
    pub radiance: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SceneSummary {
    pub name: String,
    pub file: String,
    pub triangles: usize,
    pub spheres: usize,
    pub degenerate_triangles_skipped: usize,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct MipInfo {
    pub level: u32,
    pub layer: String,
    pub resolution: u32,
    /// Perceptual roughness r; GGX alpha = r².
    pub perceptual_roughness: f32,
    pub alpha: f32,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ProbeManifest {
    pub file: String,
    pub position: [f32; 3],
    pub resolution: u32,
    pub samples_per_texel: u32,
    pub ggx_samples: u32,
    pub radiance_mips: Vec<MipInfo>,
    /// Distance layer names, level 0 first (level 0 = texel-centre distances).
    pub distance_mips: Vec<String>,
    pub depth_mip_filter: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct GridManifest {
    pub file: String,
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub counts: [u32; 3],
    pub cell_size: [f32; 3],
    pub cell_index: String,
    pub irradiance_resolution: u32,
    pub depth_resolution: u32,
    pub depth_samples: u32,
    pub atlas_layout: String,
    pub far_distance: f32,
    pub active_cells: usize,
    /// Linear indices of cells whose probe is inside geometry.
    pub inside_cells: Vec<u32>,
    /// Cells whose probe was moved off its centre (relocation), sorted, with the offset.
    pub relocated: Vec<(u32, [f32; 3])>,
}
