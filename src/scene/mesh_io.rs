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
        if !(a.is_finite() && bb.is_finite() && c.is_finite()) {
            return Err(mesh_err(path, format!("{what}: transformed vertex is not finite")));
        }
        if flip {
            b.add_triangle(a, c, bb, material);
        } else {
            b.add_triangle(a, bb, c, material);
        }
    }
    Ok(())
}

/// Loads every triangle primitive of the default scene (or all root nodes) of a glTF file.
pub fn load_gltf(b: &mut Builder, path: &Path, xf: Mat4) -> Result<(), SceneError> {
    if !path.exists() {
        return Err(SceneError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "file not found"),
        });
    }
    let (doc, buffers, _images) = gltf::import(path).map_err(|e| mesh_err(path, format!("invalid glTF: {e}")))?;
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let Some(scene) = scene else {
        return Err(mesh_err(path, "glTF has no scene"));
    };
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, xf)).collect();
    while let Some((node, parent)) = stack.pop() {
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
                let reader = prim.reader(|buf| buffers.get(buf.index()).map(|d| &d.0[..]));
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
                if !e.is_finite() || e.min_element() < 0.0 {
                    return Err(mesh_err(path, format!("{what}: emissive factor must be finite and ≥ 0")));
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

/// Loads an OBJ file (triangulated), with its MTL materials when present.
pub fn load_obj(b: &mut Builder, path: &Path, xf: Mat4) -> Result<(), SceneError> {
    if !path.exists() {
        return Err(SceneError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "file not found"),
        });
    }
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, materials) = tobj::load_obj(path, &opts).map_err(|e| mesh_err(path, format!("invalid OBJ: {e}")))?;
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            tracing::warn!("{}: materials not loaded ({e}); using default albedo", path.display());
            Vec::new()
        }
    };
    for model in &models {
        let mesh = &model.mesh;
        let what = format!("object {:?}", model.name);
        let positions: Vec<Vec3> = mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let mat = mesh.material_id.and_then(|k| materials.get(k));
        let albedo = mat.and_then(|m| m.diffuse).unwrap_or([0.7, 0.7, 0.7]);
        let emission = Vec3::from_array(mat.and_then(|m| m.emissive).unwrap_or([0.0; 3]));
        if !emission.is_finite() || emission.min_element() < 0.0 {
            return Err(mesh_err(path, format!("{what}: Ke must be finite and ≥ 0")));
        }
        let m = b.material(Material { albedo: clamp_albedo(albedo), emission, two_sided: false });
        add_indexed(b, path, &what, &positions, &mesh.indices, xf, m)?;
    }
    Ok(())
}
