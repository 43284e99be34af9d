//! Mesh files: glTF 2.0 (node transforms applied, base-colour factor as albedo, emissive
//! factor as emission) and Wavefront OBJ+MTL (Kd as albedo, Ke as emission).
//!
//! Every vertex is checked for NaN/Inf and every index for range; problems are errors naming
//! the file and the element. Degenerate triangles go through `Builder::add_triangle`, which
//! skips and counts them.

use super::procedural::Builder;
use super::{Material, SceneError};
use glam::{Mat4, Vec3};
use std::path::Path;

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
    positions: &[Vec3],
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
        if flip {
            b.add_triangle(a, c, bb, material);
        } else {
            b.add_triangle(a, bb, c, material);
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

/// Loads every triangle primitive of the default scene (or the first) of a glTF or GLB file.
/// Only geometry and material factors are read: buffers come from the GLB chunk, data URIs
/// or files in the scene's folder; images are never opened (textures are not used). Nodes
/// must form a tree: a node reached twice (a cycle, or a child shared by two parents) is an
/// error naming it.
pub fn load_gltf(b: &mut Builder, sources: &Sources, path: &Path, xf: Mat4) -> Result<(), SceneError> {
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
    let mut visited = vec![false; doc.nodes().len()];
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, xf)).collect();
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
                let m = b.material(Material {
                    albedo: clamp_albedo([c[0], c[1], c[2]]),
                    emission: e,
                    two_sided: mat.double_sided(),
                });
                add_indexed(b, path, &what, &positions, &indices, world, m)?;
            }
        }
        for child in node.children() {
            stack.push((child, world));
        }
    }
    Ok(())
}

/// Loads an OBJ file (triangulated), with its MTL materials (Kd albedo, Ke emission) when
/// present. An empty or unparseable file is an error naming it; a missing MTL is a warning
/// naming it; non-finite or out-of-range MTL values are errors.
pub fn load_obj(b: &mut Builder, sources: &Sources, path: &Path, xf: Mat4) -> Result<(), SceneError> {
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
    for model in &models {
        let mesh = &model.mesh;
        let what = format!("object {:?}", model.name);
        let positions: Vec<Vec3> = mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let mat = mesh.material_id.and_then(|k| materials.get(k));
        let albedo = mat.and_then(|m| m.diffuse).unwrap_or([0.7, 0.7, 0.7]);
        let emission = Vec3::from_array(mat.and_then(|m| m.emissive).unwrap_or([0.0; 3]));
        let m = b.material(Material { albedo: clamp_albedo(albedo), emission, two_sided: false });
        add_indexed(b, path, &what, &positions, &mesh.indices, xf, m)?;
    }
    Ok(())
}
