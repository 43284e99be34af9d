//! Mesh files: glTF 2.0 (node transforms applied; base colour = factor × texture at the
//! hit's texture coordinates; emissive factor × strength as emission; `doubleSided`;
//! `KHR_lights_punctual` point, spot and directional lights) and Wavefront OBJ+MTL (Kd ×
//! map_Kd as albedo, Ke as emission). Every mesh is read in the scene's mesh frame
//! (`up_axis`, `units`), and a scene entry may replace its material or sidedness.
//!
//! Light units: glTF's photometric values are taken as the scene's radiometric units,
//! candela for point and spot lights (a sphere of 2 cm radius of radiance I/(π r²)) and lux
//! for directional lights (the sun's irradiance, 0.27° angular radius).
//!
//! Every vertex is checked for NaN/Inf and every index for range; problems are errors naming
//! the file and the element. Degenerate triangles go through `Builder::add_triangle`, which
//! skips and counts them.

use super::procedural::{Builder, MeshLight};
use super::{Material, SceneError, SphereLight, Sun, Texture};
use glam::{Mat4, Vec2, Vec3};
use std::path::Path;

/// How a mesh file enters the scene: the transform from its frame to the scene's (the
/// entry's transform after the scene's up axis and units), and the entry's overrides.
#[derive(Clone, Copy, Debug)]
pub struct MeshOptions {
    pub xf: Mat4,
    /// Replaces every material of the file.
    pub material: Option<Material>,
    /// Replaces every material's sidedness.
    pub two_sided: Option<bool>,
}

impl MeshOptions {
    /// The material a primitive gets: the override, or `own` with the sidedness override.
    fn material(&self, own: Material) -> Material {
        let m = self.material.unwrap_or(own);
        Material { two_sided: self.two_sided.unwrap_or(m.two_sided), ..m }
    }
}

/// Radius of the sphere a point or spot light becomes, in metres.
const POINT_LIGHT_RADIUS_M: f32 = 0.02;
/// Angular radius of a directional light, degrees (the real sun's).
const DIRECTIONAL_RADIUS_DEG: f32 = 0.27;
/// Largest texture side decoded.
const MAX_TEXTURE_SIDE: u32 = 8192;

/// sRGB-encoded 8-bit texels to linear RGB.
fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 { c / 12.92 } else { libm::powf((c + 0.055) / 1.055, 2.4) }
}

/// Decodes an image (PNG or JPEG) into a texture; `what` names it in errors.
fn decode_texture(bytes: &[u8], what: &str) -> Result<Texture, String> {
    let img = image::load_from_memory(bytes).map_err(|e| format!("{what}: {e}"))?;
    let (w, h) = (img.width(), img.height());
    if w == 0 || h == 0 || w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE {
        return Err(format!("{what}: {w}×{h} is not a texture size this tool reads (1..={MAX_TEXTURE_SIDE})"));
    }
    let rgb = img.to_rgb8();
    let texels =
        rgb.pixels().map(|p| Vec3::new(srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]))).collect();
    Ok(Texture { width: w, height: h, texels })
}

fn mesh_err(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Mesh { path: path.to_path_buf(), message: message.into() }
}

fn clamp_albedo(c: [f32; 3]) -> Vec3 {
    Vec3::from_array(c).clamp(Vec3::ZERO, Vec3::ONE)
}

/// Adds the triangles of an indexed mesh, validating vertices and indices.
fn add_indexed(
    b: &mut Builder,
    path: &Path,
    what: &str,
    (positions, uvs): (&[Vec3], &[Vec2]),
    indices: &[u32],
    xf: Mat4,
    material: u32,
) -> Result<(), SceneError> {
    if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
        return Err(mesh_err(path, format!("{what}: vertex {k} is not finite ({})", positions[k])));
    }
    if !indices.len().is_multiple_of(3) {
        return Err(mesh_err(path, format!("{what}: index count {} is not a multiple of 3", indices.len())));
    }
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
        return Err(mesh_err(
            path,
            format!("{what}: index {bad} out of range (mesh has {} vertices)", positions.len()),
        ));
    }
    // Mirroring transforms flip winding; keep front faces front.
    let flip = xf.determinant() < 0.0;
    for t in indices.chunks_exact(3) {
        let p = |i: u32| xf.transform_point3(positions[i as usize]);
        let (a, bb, c) = (p(t[0]), p(t[1]), p(t[2]));
        let lim = super::MAX_COORDINATE;
        let ok = |v: Vec3| v.is_finite() && v.abs().max_element() <= lim;
        if !(ok(a) && ok(bb) && ok(c)) {
            return Err(mesh_err(path, format!("{what}: a transformed vertex is not finite or beyond ±{lim:e}")));
        }
        let uv = |i: u32| uvs.get(i as usize).copied().filter(|u| u.is_finite()).unwrap_or(Vec2::ZERO);
        let (ua, ub, uc) = (uv(t[0]), uv(t[1]), uv(t[2]));
        if flip {
            b.add_triangle_uv(a, c, bb, material, [ua, uc, ub]);
        } else {
            b.add_triangle_uv(a, bb, c, material, [ua, ub, uc]);
        }
    }
    Ok(())
}

/// Largest mesh, MTL or buffer file read (bytes).
pub const MAX_MESH_FILE_BYTES: u64 = 4 << 30;

/// How a scene reads the files its meshes reference.
#[derive(Clone, Copy, Debug)]
pub struct Sources {
    /// Let a mesh file reference files outside its own folder (`allow_outside_paths`).
    pub allow_outside: bool,
}

impl Sources {
    /// Reads `path`, named by `referrer`: a regular file (never a FIFO or device), recorded
    /// among the scene's inputs. A file a mesh references (`referenced`: its MTL, buffers)
    /// must lie in the referring file's folder or below, unless the scene allows others.
    pub fn read(&self, b: &mut Builder, path: &Path, referrer: &Path, referenced: bool) -> Result<Vec<u8>, SceneError> {
        let meta = std::fs::metadata(path).map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
        if !meta.is_file() {
            return Err(mesh_err(path, "not a regular file (a FIFO, device or folder)"));
        }
        if referenced && !self.allow_outside {
            let dir = referrer.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
            let root = dir.canonicalize().map_err(|source| SceneError::Io { path: dir.to_path_buf(), source })?;
            let canonical =
                path.canonicalize().map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
            if !canonical.starts_with(&root) {
                return Err(mesh_err(
                    referrer,
                    format!(
                        "{} is outside the folder {} of the file that references it (set allow_outside_paths = true in the scene to allow it)",
                        path.display(),
                        root.display()
                    ),
                ));
            }
        }
        let bytes = crate::files::read_regular(path, MAX_MESH_FILE_BYTES)
            .map_err(|e| mesh_err(path, e.to_string().replace(&format!("{}: ", path.display()), "")))?;
        b.inputs.push((path.to_path_buf(), crate::files::checksum(&bytes)));
        Ok(bytes)
    }
}

/// A relative reference inside a mesh file (`%20` and friends decoded), resolved against the
/// referring file's folder; absolute paths, `file:` and other schemes are refused.
fn resolve(referrer: &Path, uri: &str) -> Result<std::path::PathBuf, SceneError> {
    if uri.contains("://") || uri.starts_with("file:") || Path::new(uri).is_absolute() || uri.starts_with('/') {
        return Err(mesh_err(referrer, format!("reference {uri:?}: only relative paths are allowed")));
    }
    let mut bytes = Vec::with_capacity(uri.len());
    let raw = uri.as_bytes();
    let mut k = 0;
    while k < raw.len() {
        if raw[k] == b'%' && k + 2 < raw.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(raw[k + 1]), hex(raw[k + 2])) {
                bytes.push((h * 16 + l) as u8);
                k += 3;
                continue;
            }
        }
        bytes.push(raw[k]);
        k += 1;
    }
    let decoded =
        String::from_utf8(bytes).map_err(|_| mesh_err(referrer, format!("reference {uri:?} is not UTF-8")))?;
    let dir = referrer.parent().unwrap_or(Path::new(""));
    Ok(dir.join(decoded))
}

/// A buffer's bytes: the GLB blob, a base64 `data:` URI or a file beside the glTF.
fn buffer_data(
    b: &mut Builder,
    sources: &Sources,
    path: &Path,
    buffer: &gltf::Buffer,
    blob: &Option<Vec<u8>>,
) -> Result<Vec<u8>, SceneError> {
    use base64::Engine as _;
    let what = format!("buffer {}", buffer.index());
    let mut data = match buffer.source() {
        gltf::buffer::Source::Bin => blob
            .clone()
            .ok_or_else(|| mesh_err(path, format!("{what}: refers to the GLB binary chunk, which is missing")))?,
        gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
            let (_, payload) = uri
                .split_once(";base64,")
                .ok_or_else(|| mesh_err(path, format!("{what}: only base64 data URIs are supported")))?;
            base64::engine::general_purpose::STANDARD
                .decode(payload)
                .map_err(|e| mesh_err(path, format!("{what}: invalid base64: {e}")))?
        }
        gltf::buffer::Source::Uri(uri) => {
            let file = resolve(path, uri)?;
            sources.read(b, &file, path, true)?
        }
    };
    if data.len() < buffer.length() {
        return Err(mesh_err(path, format!("{what}: {} bytes, the glTF says {}", data.len(), buffer.length())));
    }
    data.truncate(buffer.length());
    Ok(data)
}

/// The texture of glTF image `index` (decoded once per file), or `None` with a warning
/// naming what is missing or broken: the material then uses its factor alone.
fn gltf_texture(
    b: &mut Builder,
    sources: &Sources,
    path: &Path,
    (doc, buffers, blob): (&gltf::Document, &[Vec<u8>], &Option<Vec<u8>>),
    index: usize,
    cache: &mut std::collections::HashMap<usize, Option<u32>>,
) -> Option<u32> {
    if let Some(t) = cache.get(&index) {
        return *t;
    }
    let image = doc.images().nth(index)?;
    let bytes: Result<Vec<u8>, String> = match image.source() {
        gltf::image::Source::View { view, .. } => buffers
            .get(view.buffer().index())
            .and_then(|d| d.get(view.offset()..view.offset() + view.length()))
            .map(<[u8]>::to_vec)
            .ok_or_else(|| format!("image {index}: its buffer view is out of range")),
        gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
            use base64::Engine as _;
            uri.split_once(";base64,")
                .ok_or_else(|| format!("image {index}: only base64 data URIs are supported"))
                .and_then(|(_, d)| {
                    base64::engine::general_purpose::STANDARD.decode(d).map_err(|e| format!("image {index}: {e}"))
                })
        }
        gltf::image::Source::Uri { uri, .. } => match resolve(path, uri) {
            Ok(file) if !file.exists() => Err(format!("image {index}: {} not found", file.display())),
            Ok(file) => sources.read(b, &file, path, true).map_err(|e| e.to_string()),
            Err(e) => Err(e.to_string()),
        },
    };
    let _ = blob;
    let texture = bytes.and_then(|bytes| decode_texture(&bytes, &format!("image {index}")));
    let out = match texture {
        Ok(t) => {
            b.textures.push(t);
            Some((b.textures.len() - 1) as u32)
        }
        Err(e) => {
            tracing::warn!("{}: {e}; the material uses its base colour factor alone", path.display());
            None
        }
    };
    cache.insert(index, out);
    out
}

/// Loads every triangle primitive of the default scene (or the first) of a glTF or GLB file,
/// and its `KHR_lights_punctual` lights. Buffers come from the GLB chunk, data URIs or files
/// in the file's folder; a base-colour image that is missing or broken is a warning naming
/// it (the factor alone is used). Nodes must form a tree: a node reached twice (a cycle, or a
/// child shared by two parents) is an error naming it.
pub fn load_gltf(b: &mut Builder, sources: &Sources, path: &Path, o: &MeshOptions) -> Result<(), SceneError> {
    let bytes = sources.read(b, path, path, false)?;
    let gltf::Gltf { document: doc, blob } =
        gltf::Gltf::from_slice(&bytes).map_err(|e| mesh_err(path, format!("invalid glTF: {e}")))?;
    let mut buffers = Vec::new();
    for buffer in doc.buffers() {
        buffers.push(buffer_data(b, sources, path, &buffer, &blob)?);
    }
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let Some(scene) = scene else {
        return Err(mesh_err(path, "glTF has no scene"));
    };
    let mut textures = std::collections::HashMap::new();
    let mut visited = vec![false; doc.nodes().len()];
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, o.xf)).collect();
    while let Some((node, parent)) = stack.pop() {
        let seen = visited
            .get_mut(node.index())
            .ok_or_else(|| mesh_err(path, format!("node {} out of range", node.index())))?;
        if *seen {
            return Err(mesh_err(
                path,
                format!(
                    "node {}{} is reached twice (a cycle or a child of two parents): glTF nodes must form a tree",
                    node.index(),
                    node.name().map(|n| format!(" ({n:?})")).unwrap_or_default()
                ),
            ));
        }
        *seen = true;
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(mesh_err(path, format!("node {} has a non-finite transform", node.index())));
        }
        if let Some(light) = node.light() {
            b.lights.extend(gltf_light(path, &light, world)?);
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    tracing::warn!("{}: {what}: mode {:?} skipped (only triangles)", path.display(), prim.mode());
                    continue;
                }
                let reader = prim.reader(|buf| buffers.get(buf.index()).map(|d| &d[..]));
                let positions: Vec<Vec3> = reader
                    .read_positions()
                    .ok_or_else(|| mesh_err(path, format!("{what}: no POSITION attribute")))?
                    .map(Vec3::from_array)
                    .collect();
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(ix) => ix.into_u32().collect(),
                    None => (0..positions.len() as u32).collect(),
                };
                let mat = prim.material();
                let pbr = mat.pbr_metallic_roughness();
                let c = pbr.base_color_factor();
                let strength = mat.emissive_strength().unwrap_or(1.0);
                let e = Vec3::from_array(mat.emissive_factor()) * strength;
                if !e.is_finite() || e.min_element() < 0.0 || e.max_element() > super::MAX_RADIANCE_INPUT {
                    return Err(mesh_err(
                        path,
                        format!("{what}: emission must be finite, ≥ 0 and ≤ {:e}", super::MAX_RADIANCE_INPUT),
                    ));
                }
                if !c.iter().all(|x| x.is_finite()) {
                    return Err(mesh_err(path, format!("{what}: base colour factor is not finite")));
                }
                // the base-colour texture and its texture coordinates (set 0 or the one named)
                let (texture, uvs) = match pbr.base_color_texture().filter(|_| o.material.is_none()) {
                    Some(info) => {
                        let t = gltf_texture(
                            b,
                            sources,
                            path,
                            (&doc, &buffers, &blob),
                            info.texture().source().index(),
                            &mut textures,
                        );
                        let uvs: Vec<Vec2> = reader
                            .read_tex_coords(info.tex_coord())
                            .map(|tc| tc.into_f32().map(Vec2::from_array).collect())
                            .unwrap_or_default();
                        if t.is_some() && uvs.is_empty() {
                            tracing::warn!("{}: {what}: textured but has no texture coordinates", path.display());
                        }
                        (t.filter(|_| !uvs.is_empty()), uvs)
                    }
                    None => (None, Vec::new()),
                };
                let own = Material {
                    albedo: clamp_albedo([c[0], c[1], c[2]]),
                    emission: e,
                    two_sided: mat.double_sided(),
                    texture,
                };
                let m = b.material(o.material(own));
                add_indexed(b, path, &what, (&positions, &uvs), &indices, world, m)?;
            }
        }
        for child in node.children() {
            stack.push((child, world));
        }
    }
    Ok(())
}

/// A `KHR_lights_punctual` light at a node with world transform `world` (see the module
/// docs for units).
fn gltf_light(
    path: &Path,
    light: &gltf::khr_lights_punctual::Light,
    world: Mat4,
) -> Result<Option<MeshLight>, SceneError> {
    use gltf::khr_lights_punctual::Kind;
    let what = format!("light {}{}", light.index(), light.name().map(|n| format!(" ({n:?})")).unwrap_or_default());
    let colour = Vec3::from_array(light.color()) * light.intensity();
    if !colour.is_finite() || colour.min_element() < 0.0 {
        return Err(mesh_err(path, format!("{what}: colour × intensity must be finite and ≥ 0")));
    }
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    if !position.is_finite() || forward == Vec3::ZERO {
        return Err(mesh_err(path, format!("{what}: its node's transform is degenerate")));
    }
    let radius = POINT_LIGHT_RADIUS_M;
    let sphere = |spot| {
        let radiance = colour / (std::f32::consts::PI * radius * radius);
        let radiance = radiance.min(Vec3::splat(super::MAX_RADIANCE_INPUT));
        MeshLight::Sphere(SphereLight { position, radius, radiance, spot })
    };
    Ok(Some(match light.kind() {
        Kind::Point => sphere(None),
        Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            let (ci, co) = (libm::cosf(inner_cone_angle), libm::cosf(outer_cone_angle));
            sphere(Some(super::Spot { direction: forward, cos_inner: ci.max(co + 1e-4), cos_outer: co }))
        }
        Kind::Directional => MeshLight::Sun(Sun {
            direction: -forward,
            cos_angular_radius: libm::cosf(DIRECTIONAL_RADIUS_DEG.to_radians()),
            irradiance: colour.min(Vec3::splat(super::MAX_RADIANCE_INPUT)),
        }),
    }))
}

/// Loads an OBJ file (triangulated), with its MTL materials (Kd albedo, Ke emission) when
/// present. An empty or unparseable file is an error naming it; a missing MTL is a warning
/// naming it; non-finite or out-of-range MTL values are errors.
pub fn load_obj(b: &mut Builder, sources: &Sources, path: &Path, o: &MeshOptions) -> Result<(), SceneError> {
    let bytes = sources.read(b, path, path, false)?;
    if bytes.iter().all(|c| c.is_ascii_whitespace()) {
        return Err(mesh_err(path, "empty OBJ file"));
    }
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let mtl_inputs = std::cell::RefCell::new(Vec::new());
    let mtl_problem: std::cell::RefCell<Option<SceneError>> = std::cell::RefCell::new(None);
    let loaded = {
        let loader = |rel: &Path| -> tobj::MTLLoadResult {
            let file = match resolve(path, &rel.to_string_lossy()) {
                Ok(f) => f,
                Err(e) => {
                    mtl_problem.borrow_mut().get_or_insert(e);
                    return Err(tobj::LoadError::OpenFileFailed);
                }
            };
            if !file.exists() {
                tracing::warn!(
                    "{}: material library {} not found; using the default albedo",
                    path.display(),
                    file.display()
                );
                return Err(tobj::LoadError::OpenFileFailed);
            }
            let mut scratch = Builder::default();
            match sources.read(&mut scratch, &file, path, true) {
                Ok(mtl) => {
                    mtl_inputs.borrow_mut().extend(scratch.inputs);
                    tobj::load_mtl_buf(&mut std::io::BufReader::new(&mtl[..]))
                }
                Err(e) => {
                    mtl_problem.borrow_mut().get_or_insert(e);
                    Err(tobj::LoadError::OpenFileFailed)
                }
            }
        };
        tobj::load_obj_buf(&mut std::io::BufReader::new(&bytes[..]), &opts, loader)
    };
    if let Some(e) = mtl_problem.into_inner() {
        return Err(e);
    }
    b.inputs.extend(mtl_inputs.into_inner());
    let (models, materials) = loaded.map_err(|e| mesh_err(path, format!("invalid OBJ: {e}")))?;
    let materials = materials.unwrap_or_default();
    if models.iter().all(|m| m.mesh.indices.is_empty()) {
        return Err(mesh_err(path, "no faces: not an OBJ mesh, or an empty one"));
    }
    for (k, m) in materials.iter().enumerate() {
        for (key, v) in [("Kd", m.diffuse), ("Ke", m.emissive)] {
            if let Some(v) = v
                && !v.iter().all(|x| x.is_finite() && *x >= 0.0 && *x <= super::MAX_RADIANCE_INPUT)
            {
                return Err(mesh_err(
                    path,
                    format!(
                        "material {k} ({:?}): {key} {v:?} must be finite, ≥ 0 and ≤ {:e}",
                        m.name,
                        super::MAX_RADIANCE_INPUT
                    ),
                ));
            }
        }
    }
    // map_Kd textures, decoded once each; a missing or broken one is a warning naming it
    let mut textures: std::collections::HashMap<String, Option<u32>> = std::collections::HashMap::new();
    for model in &models {
        let mesh = &model.mesh;
        let what = format!("object {:?}", model.name);
        let positions: Vec<Vec3> = mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let uvs: Vec<Vec2> = mesh.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], 1.0 - t[1])).collect();
        let mat = mesh.material_id.and_then(|k| materials.get(k));
        let albedo = mat.and_then(|m| m.diffuse).unwrap_or([0.7, 0.7, 0.7]);
        let emission = Vec3::from_array(mat.and_then(|m| m.emissive).unwrap_or([0.0; 3]));
        let texture = match mat
            .and_then(|m| m.diffuse_texture.clone())
            .filter(|_| o.material.is_none() && !uvs.is_empty())
        {
            Some(name) => *textures.entry(name.clone()).or_insert_with(|| {
                let loaded = resolve(path, &name).and_then(|file| {
                    if file.exists() { sources.read(b, &file, path, true) } else { Err(mesh_err(&file, "not found")) }
                });
                match loaded.map_err(|e| e.to_string()).and_then(|bytes| decode_texture(&bytes, &name)) {
                    Ok(t) => {
                        b.textures.push(t);
                        Some((b.textures.len() - 1) as u32)
                    }
                    Err(e) => {
                        tracing::warn!("{}: map_Kd {name}: {e}; using Kd alone", path.display());
                        None
                    }
                }
            }),
            None => None,
        };
        let own = Material { albedo: clamp_albedo(albedo), emission, two_sided: false, texture };
        let m = b.material(o.material(own));
        add_indexed(b, path, &what, (&positions, &uvs), &mesh.indices, o.xf, m)?;
    }
    Ok(())
}
