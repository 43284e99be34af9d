//! Scenes: geometry (triangles and exact spheres), Lambertian materials, lights and the bake
//! settings, loaded from a TOML scene file that may reference glTF and OBJ meshes.
//!
//! Owns validation of everything a user writes: a bad scene is a [`SceneError`] naming the
//! file and the key, line or element, never a panic. Does not trace rays (see `trace`).

pub mod config;
mod mesh_io;
pub use mesh_io::MAX_MESH_FILE_BYTES;
mod procedural;

pub use config::SceneFile;
use config::{GeometryConfig, MaterialConfig, V3};
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};

/// Lambertian surface description.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub albedo: Vec3,
    pub emission: Vec3,
    pub two_sided: bool,
    /// Base-colour texture (index into `Scene::textures`), multiplied with `albedo` at the
    /// hit's texture coordinates.
    pub texture: Option<u32>,
}

/// A base-colour texture, decoded to linear RGB (row 0 at v = 0), sampled bilinearly with
/// repeat wrapping.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec3>,
}

impl Texture {
    /// Bilinear sample at texture coordinates `uv` (repeat wrapping; finite for any input).
    #[must_use]
    pub fn sample(&self, uv: glam::Vec2) -> Vec3 {
        let (w, h) = (self.width.max(1) as f32, self.height.max(1) as f32);
        if self.texels.is_empty() || !uv.is_finite() {
            return Vec3::ONE;
        }
        let x = (uv.x - uv.x.floor()) * w - 0.5;
        let y = (uv.y - uv.y.floor()) * h - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: f32, j: f32| {
            let i = (i as i64).rem_euclid(self.width as i64) as usize;
            let j = (j as i64).rem_euclid(self.height as i64) as usize;
            self.texels[j * self.width as usize + i]
        };
        let top = at(x0, y0).lerp(at(x0 + 1.0, y0), fx);
        let bottom = at(x0, y0 + 1.0).lerp(at(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }
}

/// Triangle soup as a struct of arrays. Front faces are counter-clockwise: the geometric
/// normal is `(v1 − v0) × (v2 − v0)`.
#[derive(Clone, Debug, Default)]
pub struct Triangles {
    pub v0: Vec<Vec3>,
    pub v1: Vec<Vec3>,
    pub v2: Vec<Vec3>,
    pub material: Vec<u32>,
    /// Texture coordinates of the three corners (zero where the mesh has none).
    pub uv: Vec<[glam::Vec2; 3]>,
}

impl Triangles {
    pub fn len(&self) -> usize {
        self.v0.len()
    }
    pub fn is_empty(&self) -> bool {
        self.v0.is_empty()
    }
}

/// Exact spheres as a struct of arrays. `inward` spheres face their centre.
#[derive(Clone, Debug, Default)]
pub struct Spheres {
    pub center: Vec<Vec3>,
    pub radius: Vec<f32>,
    pub inward: Vec<bool>,
    pub material: Vec<u32>,
}

impl Spheres {
    pub fn len(&self) -> usize {
        self.center.len()
    }
    pub fn is_empty(&self) -> bool {
        self.center.is_empty()
    }
}

/// Sky radiance on rays that miss: horizon→zenith gradient above the horizon, `ground` below.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sky {
    pub zenith: Vec3,
    pub horizon: Vec3,
    pub ground: Vec3,
}

impl Sky {
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let up = dir.y;
        if up >= 0.0 { self.horizon.lerp(self.zenith, up.min(1.0)) } else { self.ground }
    }
}

/// Directional light of finite angular size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit direction towards the sun.
    pub direction: Vec3,
    /// cos of the angular radius.
    pub cos_angular_radius: f32,
    pub irradiance: Vec3,
}

/// Spherical area light (not part of the BVH; camera rays see it analytically).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereLight {
    pub position: Vec3,
    pub radius: f32,
    pub radiance: Vec3,
    /// A spot light's cone (glTF `KHR_lights_punctual` spot): emission towards directions
    /// outside it fades to zero.
    pub spot: Option<Spot>,
}

/// A spot cone: unit axis, cosines of the inner (full) and outer (zero) angles; between them
/// the falloff is glTF's `t²`, `t = (cos − cos_outer) / (cos_inner − cos_outer)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spot {
    pub direction: Vec3,
    pub cos_inner: f32,
    pub cos_outer: f32,
}

impl SphereLight {
    /// Emission factor towards unit direction `towards` (from the light): 1 without a cone.
    #[inline]
    #[must_use]
    pub fn falloff(&self, towards: Vec3) -> f32 {
        match self.spot {
            None => 1.0,
            Some(s) => {
                let t = ((towards.dot(s.direction) - s.cos_outer) / (s.cos_inner - s.cos_outer)).clamp(0.0, 1.0);
                if t.is_finite() { t * t } else { 0.0 }
            }
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Lights {
    pub sphere_lights: Vec<SphereLight>,
    pub sun: Option<Sun>,
}

/// Revision of what a bake computes from the same inputs: bumped whenever the same scene
/// would bake different values (2: every sample dimension its own generator; 3: probe
/// relocation), so the bake cache never serves a bake of an older revision.
pub const BAKE_REVISION: u32 = 3;

/// A loaded, validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    /// The scene file it came from (empty for scenes built in code).
    pub source: PathBuf,
    pub config: SceneFile,
    pub triangles: Triangles,
    pub spheres: Spheres,
    pub materials: Vec<Material>,
    pub sky: Sky,
    pub lights: Lights,
    /// Degenerate (zero-area) triangles skipped while loading.
    pub degenerate_skipped: usize,
    /// Exact duplicate triangles dropped while loading.
    pub duplicates_skipped: usize,
    /// Every file the scene was built from besides the scene file, with its checksum.
    pub inputs: Vec<(PathBuf, String)>,
    /// Base-colour textures of the materials.
    pub textures: Vec<Texture>,
}

/// Largest coordinate (scene units) a scene may use: squared distances stay far inside f32.
pub const MAX_COORDINATE: f32 = 1e12;
/// Largest radiance, irradiance or emission a scene may set: sums over millions of samples
/// stay finite.
pub const MAX_RADIANCE_INPUT: f32 = 1e9;
/// Largest sample count of any kind.
pub const MAX_SAMPLES: u32 = 1 << 16;
/// Largest `grid.depth_samples`: a distance texel's hit count is kept in a byte (the grid's
/// memory per cell; 255 rays per texel is far past what a distance texel needs).
pub const MAX_DEPTH_SAMPLES: u32 = u8::MAX as u32;
/// Largest scene file.
pub const MAX_SCENE_FILE_BYTES: u64 = 64 << 20;

/// Everything that can be wrong with a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: {field}: {message}")]
    Invalid { path: PathBuf, field: String, message: String },
    #[error("{path}: {message}")]
    Mesh { path: PathBuf, message: String },
    #[error("{path}: the scene has no geometry (no triangles or spheres after loading)")]
    Empty { path: PathBuf },
}

impl Scene {
    /// Loads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let bytes = crate::files::read_regular(path, MAX_SCENE_FILE_BYTES).map_err(|e| match e {
            crate::files::FileError::Io { path, source } => SceneError::Io { path, source },
            other => SceneError::Parse { path: path.to_path_buf(), message: other.to_string() },
        })?;
        let text = String::from_utf8(bytes)
            .map_err(|_| SceneError::Parse { path: path.to_path_buf(), message: "not UTF-8 text".into() })?;
        Scene::parse(&text, path)
    }

    /// The bake's cache key: a checksum of the tool version and [`BAKE_REVISION`], every setting, and the
    /// bytes of every file the scene was built from. Equal keys mean the bake would come out
    /// bit for bit the same.
    #[must_use]
    pub fn content_key(&self) -> String {
        let mut text = format!("warpfit {} bake, revision {BAKE_REVISION}\n", env!("CARGO_PKG_VERSION"));
        // surface probes and cameras are baked or judged apart: adding one re-bakes nothing
        let baked = SceneFile { surface_probes: Vec::new(), cameras: Vec::new(), ..self.config.clone() };
        text += &serde_json::to_string(&baked).unwrap_or_default();
        for (path, sum) in &self.inputs {
            text += &format!("\n{} {sum}", path.display());
        }
        crate::files::checksum(text.as_bytes())
    }

    /// Parses scene-file text; `path` names it in errors and anchors relative mesh paths.
    pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
        let file: SceneFile =
            toml::from_str(text).map_err(|e| SceneError::Parse { path: path.to_path_buf(), message: e.to_string() })?;
        check_array_lengths(text, &file, path)?;
        let name = file
            .name
            .clone()
            .unwrap_or_else(|| path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default());
        Scene::from_config(file, &name, path)
    }

    /// Builds a scene from an already parsed file; `path` names it in errors and resolves
    /// relative mesh paths.
    pub fn from_config(file: SceneFile, name: &str, path: &Path) -> Result<Scene, SceneError> {
        validate_settings(&file, path)?;
        let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let sources = mesh_io::Sources { allow_outside: file.allow_outside_paths };
        let frame = mesh_frame(&file, path)?;
        let mut builder = procedural::Builder::default();
        for (k, geom) in file.geometry.iter().enumerate() {
            let field = format!("geometry[{k}]");
            add_geometry(&mut builder, sources, frame, geom, &base_dir, path, &field)?;
        }
        if builder.triangles.is_empty() && builder.spheres.is_empty() {
            return Err(SceneError::Empty { path: path.to_path_buf() });
        }
        // (skipped and dropped triangles are counted in the scene, and `jobs::check`, which
        // every command runs on a scene it bakes, reports them once, naming the scene file)
        let sky = sky_from(&file, path)?;
        let mut lights = lights_from(&file, path)?;
        for l in builder.lights.drain(..) {
            match l {
                procedural::MeshLight::Sphere(s) => lights.sphere_lights.push(s),
                procedural::MeshLight::Sun(sun) if lights.sun.is_none() => lights.sun = Some(sun),
                procedural::MeshLight::Sun(_) => {
                    tracing::warn!("{}: a second directional light is ignored (one sun per scene)", path.display())
                }
            }
        }
        Ok(Scene {
            name: name.to_string(),
            source: path.to_path_buf(),
            triangles: builder.triangles,
            spheres: builder.spheres,
            materials: builder.materials,
            degenerate_skipped: builder.degenerate_skipped,
            duplicates_skipped: builder.duplicates_skipped,
            inputs: builder.inputs,
            textures: builder.textures,
            sky,
            lights,
            config: file,
        })
    }

    /// Axis-aligned bounds of all geometry (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for v in self.triangles.v0.iter().chain(&self.triangles.v1).chain(&self.triangles.v2) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        for (c, r) in self.spheres.center.iter().zip(&self.spheres.radius) {
            lo = lo.min(*c - Vec3::splat(*r));
            hi = hi.max(*c + Vec3::splat(*r));
        }
        (lo, hi)
    }

    /// Length of the bounds' diagonal: the scene's natural length scale.
    pub fn extent(&self) -> f32 {
        let (lo, hi) = self.bounds();
        (hi - lo).length().max(f32::MIN_POSITIVE)
    }

    /// Uniformly scales the whole scene (geometry, lights, probe and grid placement) about
    /// the origin. Radiances are unchanged, so a correct pipeline gives the same relative
    /// results at any scale.
    pub fn scaled(&self, factor: f32) -> Scene {
        let mut s = self.clone();
        for v in s.triangles.v0.iter_mut().chain(&mut s.triangles.v1).chain(&mut s.triangles.v2) {
            *v *= factor;
        }
        for (c, r) in s.spheres.center.iter_mut().zip(&mut s.spheres.radius) {
            *c *= factor;
            *r *= factor;
        }
        for l in &mut s.lights.sphere_lights {
            l.position *= factor;
            l.radius *= factor;
        }
        let scale3 = |v: &mut V3| v.iter_mut().for_each(|x| *x *= factor);
        scale3(&mut s.config.probe.position);
        s.config.probes.positions.iter_mut().for_each(scale3);
        for c in &mut s.config.cameras {
            scale3(&mut c.position);
            scale3(&mut c.look_at);
        }
        for sp in &mut s.config.surface_probes {
            scale3(&mut sp.corner);
            scale3(&mut sp.edge_u);
            scale3(&mut sp.edge_v);
        }
        scale3(&mut s.config.grid.min);
        scale3(&mut s.config.grid.max);
        s
    }
}

fn invalid(path: &Path, field: &str, message: impl Into<String>) -> SceneError {
    SceneError::Invalid { path: path.to_path_buf(), field: field.to_string(), message: message.into() }
}

fn finite3(path: &Path, field: &str, v: V3) -> Result<Vec3, SceneError> {
    if v.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORDINATE) {
        Ok(Vec3::from_array(v))
    } else {
        Err(invalid(path, field, format!("must be finite and within ±{MAX_COORDINATE:e}, got {v:?}")))
    }
}

/// A radiance-like value: finite, ≥ 0, ≤ [`MAX_RADIANCE_INPUT`].
fn nonneg3(path: &Path, field: &str, v: V3) -> Result<Vec3, SceneError> {
    if v.iter().all(|x| x.is_finite() && (0.0..=MAX_RADIANCE_INPUT).contains(x)) {
        Ok(Vec3::from_array(v))
    } else {
        Err(invalid(path, field, format!("must be finite, ≥ 0 and ≤ {MAX_RADIANCE_INPUT:e}, got {v:?}")))
    }
}

fn positive(path: &Path, field: &str, x: f32) -> Result<f32, SceneError> {
    if x.is_finite() && x > 0.0 && x <= MAX_COORDINATE {
        Ok(x)
    } else {
        Err(invalid(path, field, format!("must be a finite number in (0, {MAX_COORDINATE:e}], got {x}")))
    }
}

/// A TOML array longer than the field it fills (`[x, y, z, w]` for a point) would be cut
/// silently by the parser: compare every array of the text with the parsed value's.
fn check_array_lengths(text: &str, file: &SceneFile, path: &Path) -> Result<(), SceneError> {
    fn walk(raw: &toml::Value, parsed: &toml::Value, at: &str, path: &Path) -> Result<(), SceneError> {
        match (raw, parsed) {
            (toml::Value::Table(r), toml::Value::Table(p)) => {
                for (k, v) in r {
                    if let Some(pv) = p.get(k) {
                        let key = if at.is_empty() { k.clone() } else { format!("{at}.{k}") };
                        walk(v, pv, &key, path)?;
                    }
                }
                Ok(())
            }
            (toml::Value::Array(r), toml::Value::Array(p)) => {
                if r.len() != p.len() {
                    return Err(invalid(path, at, format!("{} elements, expected {}", r.len(), p.len())));
                }
                for (k, (rv, pv)) in r.iter().zip(p).enumerate() {
                    walk(rv, pv, &format!("{at}[{k}]"), path)?;
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
    let raw: toml::Value =
        toml::from_str(text).map_err(|e| SceneError::Parse { path: path.to_path_buf(), message: e.to_string() })?;
    let parsed = toml::Value::try_from(file)
        .map_err(|e| SceneError::Parse { path: path.to_path_buf(), message: e.to_string() })?;
    walk(&raw, &parsed, "", path)
}

fn validate_settings(f: &SceneFile, path: &Path) -> Result<(), SceneError> {
    finite3(path, "probe.position", f.probe.position)?;
    let r = f.probe.resolution;
    if !(16..=2048).contains(&r) || !r.is_power_of_two() {
        return Err(invalid(path, "probe.resolution", format!("must be a power of two in 16..=2048, got {r}")));
    }
    for (field, n, max) in [
        ("probe.samples_per_texel", f.probe.samples_per_texel, MAX_SAMPLES),
        ("probe.ggx_samples", f.probe.ggx_samples, MAX_SAMPLES),
        ("grid.depth_samples", f.grid.depth_samples, MAX_DEPTH_SAMPLES),
    ] {
        if !(1..=max).contains(&n) {
            return Err(invalid(path, field, format!("must be in 1..={max}, got {n}")));
        }
    }
    for (k, &p) in f.probes.positions.iter().enumerate() {
        finite3(path, &format!("probes.positions[{k}]"), p)?;
    }
    for (k, c) in f.cameras.iter().enumerate() {
        let eye = finite3(path, &format!("cameras[{k}].position"), c.position)?;
        let at = finite3(path, &format!("cameras[{k}].look_at"), c.look_at)?;
        if (at - eye).length_squared() == 0.0 || !(at - eye).length_squared().is_finite() {
            return Err(invalid(path, &format!("cameras[{k}].look_at"), "must differ from the camera's position"));
        }
    }
    let max = crate::scene::config::MAX_PROBES;
    if !(1..=max).contains(&f.probes.max) {
        return Err(invalid(path, "probes.max", format!("must be in 1..={max}, got {}", f.probes.max)));
    }
    if f.probes.positions.len() as u32 + 1 > f.probes.max {
        return Err(invalid(
            path,
            "probes.positions",
            format!("{} positions and probe A exceed probes.max = {}", f.probes.positions.len(), f.probes.max),
        ));
    }
    if !(f.probes.min_gain > 0.0 && f.probes.min_gain < 1.0) {
        return Err(invalid(path, "probes.min_gain", format!("must be in (0, 1), got {}", f.probes.min_gain)));
    }
    let m = f.probe.min_mip_resolution;
    if !m.is_power_of_two() || m < 2 || m > r {
        return Err(invalid(
            path,
            "probe.min_mip_resolution",
            format!("must be a power of two in 2..=resolution, got {m}"),
        ));
    }
    let lo = finite3(path, "grid.min", f.grid.min)?;
    let hi = finite3(path, "grid.max", f.grid.max)?;
    if !(hi.cmpgt(lo).all()) {
        return Err(invalid(path, "grid", "max must exceed min on every axis"));
    }
    if f.grid.counts.contains(&0) || f.grid.counts.iter().map(|&c| c as u64).product::<u64>() > 4_000_000 {
        return Err(invalid(
            path,
            "grid.counts",
            format!("each count must be ≥ 1 and the total ≤ 4e6, got {:?}", f.grid.counts),
        ));
    }
    let ir = f.grid.irradiance_resolution;
    if !(2..=64).contains(&ir) || !ir.is_multiple_of(2) {
        return Err(invalid(path, "grid.irradiance_resolution", format!("must be even in 2..=64, got {ir}")));
    }
    let dr = f.grid.depth_resolution;
    if !(8..=16).contains(&dr) || !dr.is_multiple_of(2) {
        return Err(invalid(path, "grid.depth_resolution", format!("must be even in 8..=16, got {dr}")));
    }
    let rc = f.grid.relocate_clearance;
    if !(0.0..=0.45).contains(&rc) {
        return Err(invalid(path, "grid.relocate_clearance", format!("must be in [0, 0.45], got {rc}")));
    }
    let bf = f.grid.inside_backface_fraction;
    if !(bf > 0.0 && bf < 1.0) {
        return Err(invalid(path, "grid.inside_backface_fraction", format!("must be in (0,1), got {bf}")));
    }
    if f.bounces > 8 {
        return Err(invalid(path, "bounces", format!("must be ≤ 8, got {}", f.bounces)));
    }
    for k in 0..f.surface_probes.len() {
        surface_probes_from(f, k, path)?;
    }
    Ok(())
}

/// A validated `[[surface_probes]]` entry (seed 003): its parallelogram, probe counts, tile
/// resolution and samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceProbeSpec {
    pub corner: Vec3,
    pub edge_u: Vec3,
    pub edge_v: Vec3,
    pub counts: [u32; 2],
    pub resolution: u32,
    pub samples_per_texel: u32,
}

/// Largest number of texels of one surface-probe atlas (probes × N²).
pub const MAX_SURFACE_TEXELS: u64 = 1 << 24;

fn surface_probes_from(f: &SceneFile, k: usize, path: &Path) -> Result<SurfaceProbeSpec, SceneError> {
    let c = &f.surface_probes[k];
    let field = format!("surface_probes[{k}]");
    let corner = finite3(path, &format!("{field}.corner"), c.corner)?;
    let edge_u = finite3(path, &format!("{field}.edge_u"), c.edge_u)?;
    let edge_v = finite3(path, &format!("{field}.edge_v"), c.edge_v)?;
    // the sine of the angle between the edges, from components scaled to order 1
    let (u, v) = (
        edge_u / edge_u.abs().max_element().max(f32::MIN_POSITIVE),
        edge_v / edge_v.abs().max_element().max(f32::MIN_POSITIVE),
    );
    if !(u.cross(v).length() > 1e-3 * u.length() * v.length()) {
        return Err(invalid(path, &field, "edge_u and edge_v must be non-zero and not parallel"));
    }
    if c.counts.iter().any(|n| !(1..=256).contains(n)) {
        return Err(invalid(path, &format!("{field}.counts"), format!("each must be in 1..=256, got {:?}", c.counts)));
    }
    let r = c.resolution;
    if !(4..=64).contains(&r) || !r.is_multiple_of(2) {
        return Err(invalid(path, &format!("{field}.resolution"), format!("must be even in 4..=64, got {r}")));
    }
    if !(1..=MAX_SAMPLES).contains(&c.samples_per_texel) {
        return Err(invalid(
            path,
            &format!("{field}.samples_per_texel"),
            format!("must be in 1..={MAX_SAMPLES}, got {}", c.samples_per_texel),
        ));
    }
    let texels = c.counts[0] as u64 * c.counts[1] as u64 * (r * r) as u64;
    if texels > MAX_SURFACE_TEXELS {
        return Err(invalid(path, &field, format!("{texels} texels, more than {MAX_SURFACE_TEXELS}")));
    }
    Ok(SurfaceProbeSpec {
        corner,
        edge_u,
        edge_v,
        counts: c.counts,
        resolution: r,
        samples_per_texel: c.samples_per_texel,
    })
}

impl Scene {
    /// The scene's surface-probe atlases (seed 003), validated when the scene was loaded.
    #[must_use]
    pub fn surface_probes(&self) -> Vec<SurfaceProbeSpec> {
        (0..self.config.surface_probes.len())
            .filter_map(|k| surface_probes_from(&self.config, k, &self.source).ok())
            .collect()
    }
}

fn sky_from(f: &SceneFile, path: &Path) -> Result<Sky, SceneError> {
    let s = &f.sky;
    let base = s.color.unwrap_or([0.0; 3]);
    let zenith = nonneg3(path, "sky.zenith", s.zenith.unwrap_or(base))?;
    let horizon = nonneg3(path, "sky.horizon", s.horizon.unwrap_or(base))?;
    let ground = nonneg3(path, "sky.ground", s.ground.unwrap_or(base))?;
    nonneg3(path, "sky.color", base)?;
    Ok(Sky { zenith, horizon, ground })
}

fn lights_from(f: &SceneFile, path: &Path) -> Result<Lights, SceneError> {
    let mut lights = Lights::default();
    if let Some(sun) = &f.sun {
        let d = finite3(path, "sun.direction", sun.direction)?;
        if d.length_squared() == 0.0 {
            return Err(invalid(path, "sun.direction", "must not be zero"));
        }
        let radius = sun.angular_radius_deg;
        if !(radius > 0.0 && radius < 45.0) {
            return Err(invalid(path, "sun.angular_radius_deg", format!("must be in (0,45), got {radius}")));
        }
        lights.sun = Some(Sun {
            direction: d.normalize(),
            cos_angular_radius: libm::cosf(radius.to_radians()),
            irradiance: nonneg3(path, "sun.irradiance", sun.irradiance)?,
        });
    }
    for (k, l) in f.sphere_lights.iter().enumerate() {
        let field = format!("sphere_lights[{k}]");
        lights.sphere_lights.push(SphereLight {
            position: finite3(path, &format!("{field}.position"), l.position)?,
            radius: positive(path, &format!("{field}.radius"), l.radius)?,
            radiance: nonneg3(path, &format!("{field}.radiance"), l.radiance)?,
            spot: None,
        });
    }
    Ok(lights)
}

fn material_from(
    m: &MaterialConfig,
    default_two_sided: bool,
    path: &Path,
    field: &str,
) -> Result<Material, SceneError> {
    let albedo = nonneg3(path, &format!("{field}.material.albedo"), m.albedo)?;
    if albedo.max_element() > 1.0 {
        return Err(invalid(path, &format!("{field}.material.albedo"), "must be ≤ 1 (energy conserving)"));
    }
    Ok(Material {
        albedo,
        emission: nonneg3(path, &format!("{field}.material.emission"), m.emission)?,
        two_sided: m.two_sided.unwrap_or(default_two_sided),
        texture: None,
    })
}

/// The frame every mesh file is read in: `up_axis` and `units` of the scene file.
fn mesh_frame(f: &SceneFile, path: &Path) -> Result<Mat4, SceneError> {
    let units = f.units.unwrap_or(1.0);
    if !(units.is_finite() && units > 0.0 && (1e-6..=1e6).contains(&units)) {
        return Err(invalid(path, "units", format!("must be in [1e-6, 1e6] scene units per mesh unit, got {units}")));
    }
    let turn = match f.up_axis.as_deref().unwrap_or("y") {
        "y" | "Y" | "+y" => Mat4::IDENTITY,
        // +Z up → +Y up (and +Y → −Z): right-handed, a quarter turn about X
        "z" | "Z" | "+z" => Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        other => return Err(invalid(path, "up_axis", format!("must be \"y\" or \"z\", got {other:?}"))),
    };
    Ok(turn * Mat4::from_scale(Vec3::splat(units)))
}

fn add_geometry(
    b: &mut procedural::Builder,
    sources: mesh_io::Sources,
    mesh_frame: Mat4,
    geom: &GeometryConfig,
    base_dir: &Path,
    path: &Path,
    field: &str,
) -> Result<(), SceneError> {
    match geom {
        GeometryConfig::Box { min, max, material } => {
            let (lo, hi) = box_bounds(path, field, *min, *max)?;
            let m = b.material(material_from(material, false, path, field)?);
            b.add_box(lo, hi, m, false, &[]);
        }
        GeometryConfig::Room { min, max, material, open } => {
            let (lo, hi) = box_bounds(path, field, *min, *max)?;
            for face in open {
                if !procedural::FACE_NAMES.contains(&face.as_str()) {
                    return Err(invalid(
                        path,
                        &format!("{field}.open"),
                        format!("unknown face {face:?}; use -x,+x,-y,+y,-z,+z"),
                    ));
                }
            }
            let m = b.material(material_from(material, false, path, field)?);
            b.add_box(lo, hi, m, true, open);
        }
        GeometryConfig::Sphere { center, radius, inward, material } => {
            let c = finite3(path, &format!("{field}.center"), *center)?;
            let r = positive(path, &format!("{field}.radius"), *radius)?;
            let m = b.material(material_from(material, false, path, field)?);
            b.add_sphere(c, r, *inward, m);
        }
        GeometryConfig::Quad { corner, edge_u, edge_v, material } => {
            let c = finite3(path, &format!("{field}.corner"), *corner)?;
            let u = finite3(path, &format!("{field}.edge_u"), *edge_u)?;
            let v = finite3(path, &format!("{field}.edge_v"), *edge_v)?;
            let m = b.material(material_from(material, true, path, field)?);
            b.add_quad(c, c + u, c + u + v, c + v, m);
        }
        GeometryConfig::Column { base, radius, height, segments, material } => {
            let p = finite3(path, &format!("{field}.base"), *base)?;
            let r = positive(path, &format!("{field}.radius"), *radius)?;
            let h = positive(path, &format!("{field}.height"), *height)?;
            if !(3..=1024).contains(segments) {
                return Err(invalid(path, &format!("{field}.segments"), "must be in 3..=1024"));
            }
            let m = b.material(material_from(material, false, path, field)?);
            b.add_column(p, r, h, *segments, m);
        }
        GeometryConfig::Arch { base, span, pier_height, thickness, depth, axis, segments, material } => {
            let p = finite3(path, &format!("{field}.base"), *base)?;
            let span = positive(path, &format!("{field}.span"), *span)?;
            let ph = positive(path, &format!("{field}.pier_height"), *pier_height)?;
            let t = positive(path, &format!("{field}.thickness"), *thickness)?;
            let d = positive(path, &format!("{field}.depth"), *depth)?;
            let along_x = match axis.as_str() {
                "x" => true,
                "z" => false,
                other => {
                    return Err(invalid(
                        path,
                        &format!("{field}.axis"),
                        format!("must be \"x\" or \"z\", got {other:?}"),
                    ));
                }
            };
            if !(2..=256).contains(segments) {
                return Err(invalid(path, &format!("{field}.segments"), "must be in 2..=256"));
            }
            let m = b.material(material_from(material, false, path, field)?);
            let arch = procedural::Arch {
                base: p,
                span,
                pier_height: ph,
                thickness: t,
                depth: d,
                along_x,
                segments: *segments,
            };
            b.add_arch(&arch, m);
        }
        GeometryConfig::Gltf { path: rel, transform, material, two_sided } => {
            let xf = transform_matrix(path, &format!("{field}.transform"), transform)? * mesh_frame;
            let material = material.as_ref().map(|m| material_from(m, false, path, field)).transpose()?;
            let o = mesh_io::MeshOptions { xf, material, two_sided: *two_sided };
            mesh_io::load_gltf(b, &sources, &base_dir.join(rel), &o)?;
        }
        GeometryConfig::Obj { path: rel, transform, material, two_sided } => {
            let xf = transform_matrix(path, &format!("{field}.transform"), transform)? * mesh_frame;
            let material = material.as_ref().map(|m| material_from(m, false, path, field)).transpose()?;
            let o = mesh_io::MeshOptions { xf, material, two_sided: *two_sided };
            mesh_io::load_obj(b, &sources, &base_dir.join(rel), &o)?;
        }
    }
    Ok(())
}

fn box_bounds(path: &Path, field: &str, min: V3, max: V3) -> Result<(Vec3, Vec3), SceneError> {
    let lo = finite3(path, &format!("{field}.min"), min)?;
    let hi = finite3(path, &format!("{field}.max"), max)?;
    if !hi.cmpgt(lo).all() {
        return Err(invalid(path, field, "max must exceed min on every axis"));
    }
    Ok((lo, hi))
}

fn transform_matrix(path: &Path, field: &str, t: &config::TransformConfig) -> Result<Mat4, SceneError> {
    let tr = finite3(path, &format!("{field}.translate"), t.translate.unwrap_or([0.0; 3]))?;
    let rot = finite3(path, &format!("{field}.rotate_deg"), t.rotate_deg.unwrap_or([0.0; 3]))?;
    let sc = finite3(path, &format!("{field}.scale"), t.scale.unwrap_or([1.0; 3]))?;
    if sc.abs().min_element() == 0.0 {
        return Err(invalid(path, &format!("{field}.scale"), "must be non-zero"));
    }
    let q = glam::Quat::from_euler(glam::EulerRot::XYZ, rot.x.to_radians(), rot.y.to_radians(), rot.z.to_radians());
    Ok(Mat4::from_scale_rotation_translation(sc, q, tr))
}
