//! Procedural primitives (box, room, sphere, quad, column, arch) so built-in scenes need no
//! binary assets, and the one place triangles enter a scene (degenerates are skipped there).

use super::{Material, Spheres, Triangles};
use glam::Vec3;

/// Face names of a box, in the order [`Builder::add_box`] emits them.
pub const FACE_NAMES: [&str; 6] = ["-x", "+x", "-y", "+y", "-z", "+z"];

/// An arch: two rectangular piers and a semicircular vault of `segments` pieces.
#[derive(Clone, Copy, Debug)]
pub struct Arch {
    /// Centre of the opening at floor level.
    pub base: Vec3,
    /// Clear width of the opening.
    pub span: f32,
    /// Height of the piers (spring line of the vault).
    pub pier_height: f32,
    /// Thickness of piers and vault ring.
    pub thickness: f32,
    /// Depth along the walking direction.
    pub depth: f32,
    /// The walking direction is +x (else +z).
    pub along_x: bool,
    pub segments: u32,
}

/// A light read from a mesh file (glTF's `KHR_lights_punctual`), collected by the
/// [`Builder`] with the geometry.
#[derive(Clone, Copy, Debug)]
pub enum MeshLight {
    Sphere(super::SphereLight),
    Sun(super::Sun),
}

/// Accumulates geometry and deduplicated materials while a scene loads.
#[derive(Default)]
pub struct Builder {
    pub triangles: Triangles,
    pub spheres: Spheres,
    pub materials: Vec<Material>,
    pub degenerate_skipped: usize,
    /// Exact duplicates of an earlier triangle (same corners, any rotation, same material)
    /// dropped: they change nothing but the BVH's cost.
    pub duplicates_skipped: usize,
    /// Every file read while building, with its checksum (the bake's cache key hashes them).
    pub inputs: Vec<(std::path::PathBuf, String)>,
    /// Bit patterns of the triangles added so far (for duplicate removal).
    seen: std::collections::HashSet<[u32; 10]>,
    /// Base-colour textures decoded so far.
    pub textures: Vec<super::Texture>,
    /// Lights read from mesh files (glTF `KHR_lights_punctual`).
    pub lights: Vec<MeshLight>,
}

impl Builder {
    /// Index of `m`, adding it if new.
    pub fn material(&mut self, m: Material) -> u32 {
        if let Some(k) = self.materials.iter().position(|x| *x == m) {
            return k as u32;
        }
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }

    /// Adds one triangle unless it is degenerate (zero or numerically negligible area
    /// relative to its edges), which is counted instead.
    pub fn add_triangle(&mut self, v0: Vec3, v1: Vec3, v2: Vec3, material: u32) {
        self.add_triangle_uv(v0, v1, v2, material, [glam::Vec2::ZERO; 3]);
    }

    /// [`Builder::add_triangle`] with texture coordinates of the corners.
    pub fn add_triangle_uv(&mut self, v0: Vec3, v1: Vec3, v2: Vec3, material: u32, uv: [glam::Vec2; 3]) {
        let e1 = v1 - v0;
        let e2 = v2 - v0;
        let n = e1.cross(e2);
        let scale = e1.length_squared().max(e2.length_squared()).max((v2 - v1).length_squared());
        if !(n.length() > 1e-7 * scale) {
            self.degenerate_skipped += 1;
            return;
        }
        // the same triangle again (same winding, any starting corner) adds nothing
        let key = |a: Vec3, b: Vec3, c: Vec3| {
            let k = [a, b, c].map(|v| v.to_array().map(f32::to_bits));
            [k[0][0], k[0][1], k[0][2], k[1][0], k[1][1], k[1][2], k[2][0], k[2][1], k[2][2], material]
        };
        let rotations = [key(v0, v1, v2), key(v1, v2, v0), key(v2, v0, v1)];
        let canonical = *rotations.iter().min().expect("three rotations");
        if !self.seen.insert(canonical) {
            self.duplicates_skipped += 1;
            return;
        }
        self.triangles.v0.push(v0);
        self.triangles.v1.push(v1);
        self.triangles.v2.push(v2);
        self.triangles.material.push(material);
        self.triangles.uv.push(uv);
    }

    /// Adds the planar quad a-b-c-d as two triangles whose front faces along `facing`.
    pub fn add_quad_facing(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, facing: Vec3, m: u32) {
        if (b - a).cross(c - a).dot(facing) >= 0.0 {
            self.add_triangle(a, b, c, m);
            self.add_triangle(a, c, d, m);
        } else {
            self.add_triangle(a, c, b, m);
            self.add_triangle(a, d, c, m);
        }
    }

    /// Quad a-b-c-d (counter-clockwise seen from the front).
    pub fn add_quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, m: u32) {
        self.add_triangle(a, b, c, m);
        self.add_triangle(a, c, d, m);
    }

    /// Axis-aligned box; `inward` makes faces point in (a room). Faces named in `open`
    /// are left out.
    pub fn add_box(&mut self, lo: Vec3, hi: Vec3, m: u32, inward: bool, open: &[String]) {
        let corner = |k: usize| {
            Vec3::new(
                if k & 1 != 0 { hi.x } else { lo.x },
                if k & 2 != 0 { hi.y } else { lo.y },
                if k & 4 != 0 { hi.z } else { lo.z },
            )
        };
        // Counter-clockwise seen from outside (normals −x, +x, −y, +y, −z, +z).
        const FACES: [[usize; 4]; 6] =
            [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
        for (face, name) in FACES.iter().zip(FACE_NAMES) {
            if open.iter().any(|o| o == name) {
                continue;
            }
            let [a, b, c, d] = face.map(corner);
            if inward {
                self.add_quad(a, d, c, b, m);
            } else {
                self.add_quad(a, b, c, d, m);
            }
        }
    }

    pub fn add_sphere(&mut self, center: Vec3, radius: f32, inward: bool, m: u32) {
        self.spheres.center.push(center);
        self.spheres.radius.push(radius);
        self.spheres.inward.push(inward);
        self.spheres.material.push(m);
    }

    /// Vertical capped cylinder.
    pub fn add_column(&mut self, base: Vec3, radius: f32, height: f32, segments: u32, m: u32) {
        let top = base + Vec3::Y * height;
        let ring = |k: u32| {
            let a = k as f32 / segments as f32 * std::f32::consts::TAU;
            Vec3::new(libm::cosf(a), 0.0, libm::sinf(a)) * radius
        };
        for k in 0..segments {
            let (r0, r1) = (ring(k), ring(k + 1));
            let out = (r0 + r1).normalize_or(Vec3::X);
            self.add_quad_facing(base + r0, base + r1, top + r1, top + r0, out, m);
            self.add_triangle_facing(top, top + r0, top + r1, Vec3::Y, m);
            self.add_triangle_facing(base, base + r0, base + r1, -Vec3::Y, m);
        }
    }

    fn add_triangle_facing(&mut self, a: Vec3, b: Vec3, c: Vec3, facing: Vec3, m: u32) {
        if (b - a).cross(c - a).dot(facing) >= 0.0 {
            self.add_triangle(a, b, c, m);
        } else {
            self.add_triangle(a, c, b, m);
        }
    }

    /// Two piers and a semicircular vault. Local frame: `across` spans the opening, +Y up,
    /// `along` is the walking direction through the arch.
    pub fn add_arch(&mut self, arch: &Arch, m: u32) {
        let Arch { base, span, pier_height, thickness, depth, along_x, segments } = *arch;
        let to_world = |across: f32, up: f32, along: f32| {
            if along_x { base + Vec3::new(along, up, across) } else { base + Vec3::new(across, up, along) }
        };
        let half = span * 0.5;
        let hd = depth * 0.5;
        for side in [-1.0f32, 1.0] {
            let a0 = side * half;
            let a1 = side * (half + thickness);
            let (lo_a, hi_a) = (a0.min(a1), a0.max(a1));
            let lo = to_world(lo_a, 0.0, -hd);
            let hi = to_world(hi_a, pier_height, hd);
            self.add_box(lo.min(hi), lo.max(hi), m, false, &[]);
        }
        let r_in = half;
        let r_out = half + thickness;
        let facing = |across: f32, up: f32, along: f32| to_world(across, up, along) - base;
        for k in 0..segments {
            let t0 = k as f32 / segments as f32 * std::f32::consts::PI;
            let t1 = (k + 1) as f32 / segments as f32 * std::f32::consts::PI;
            let (c0, s0, c1, s1) = (libm::cosf(t0), libm::sinf(t0), libm::cosf(t1), libm::sinf(t1));
            let p = |r: f32, c: f32, s: f32, d: f32| to_world(r * c, pier_height + r * s, d);
            let mid_c = (c0 + c1) * 0.5;
            let mid_s = (s0 + s1) * 0.5;
            let radial = facing(mid_c, mid_s, 0.0);
            // inner surface faces the opening (towards the centre)
            self.add_quad_facing(
                p(r_in, c0, s0, -hd),
                p(r_in, c1, s1, -hd),
                p(r_in, c1, s1, hd),
                p(r_in, c0, s0, hd),
                -radial,
                m,
            );
            self.add_quad_facing(
                p(r_out, c0, s0, -hd),
                p(r_out, c1, s1, -hd),
                p(r_out, c1, s1, hd),
                p(r_out, c0, s0, hd),
                radial,
                m,
            );
            let front = facing(0.0, 0.0, 1.0);
            self.add_quad_facing(
                p(r_in, c0, s0, hd),
                p(r_out, c0, s0, hd),
                p(r_out, c1, s1, hd),
                p(r_in, c1, s1, hd),
                front,
                m,
            );
            self.add_quad_facing(
                p(r_in, c0, s0, -hd),
                p(r_out, c0, s0, -hd),
                p(r_out, c1, s1, -hd),
                p(r_in, c1, s1, -hd),
                -front,
                m,
            );
        }
    }
}
