//! Closest-hit and occlusion queries over a scene's triangles and exact spheres, on an obvhs
//! CWBVH (built by obvhs, walked by `trace::cwbvh`).
//!
//! Three guards against pitfalls of obvhs 0.4 live here:
//! - **Scale.** The CWBVH node test clamps ray entry at a fixed 1e-4, and PLOC's Morton codes
//!   depend on absolute bounds. Geometry is therefore stored in a normalised frame:
//!   `(p − centre) · scale` with `scale` a power of two chosen so the scene's extent is in
//!   [512, 1024). Power-of-two scaling is exact in floating point, so a scene scaled by any
//!   factor is traced in (nearly) the same normalised frame: no absolute epsilon leaks out.
//! - **Morton wrap.** A primitive whose centroid lies exactly on the build bounds' max face
//!   wraps to Morton code 0, which wrecks the tree of a closed room (walls on the bounds). The
//!   build list gets one tiny padding box beyond the max corner; it is never reported as hit.
//! - **Conservative boxes.** The node slab test is exact-or-miss, so primitive boxes are
//!   padded by `BOX_PAD` (about 1e-6 of the scene) before building.
//! - **Watertightness.** `Triangle::intersect` lets rays escape through shared edges, so
//!   triangles use the watertight test of Woop, Benthin & Wald (JCGT 2013).

use super::cwbvh::{self, NodeRay, NodeTest};
use super::streams;
use crate::scene::Scene;
use glam::{Vec3, Vec3A, Vec4};
use obvhs::{BvhBuildParams, aabb::Aabb, cwbvh::CwBvh, ray::Ray, ray::RayHit};
use std::time::Duration;

/// AABB padding in the normalised frame (extent 512..1024): ~16 ulps at the frame's edge.
const BOX_PAD: f32 = 1e-3;

/// Slot tags (bits of `slot_tri[s][0].w`); any other value is a sphere's index.
const SLOT_TRIANGLE: u32 = u32::MAX;
const SLOT_PADDING: u32 = u32::MAX - 1;

/// What a closest-hit query found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction, in world units.
    pub t: f32,
    /// World position of the hit.
    pub position: Vec3,
    /// Geometric normal of the front side (unit).
    pub normal: Vec3,
    /// Material index.
    pub material: u32,
    /// The ray arrived at the back side of the surface.
    pub backface: bool,
    /// The primitive is an exact sphere (not a triangle).
    pub sphere: bool,
    /// Index of the triangle (or of the sphere, when `sphere`).
    pub prim: u32,
}

/// Which BVH builder preset to use (measured in `benches/trace.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildQuality {
    Fast,
    #[default]
    Medium,
    Slow,
}

impl BuildQuality {
    fn params(self) -> BvhBuildParams {
        match self {
            BuildQuality::Fast => BvhBuildParams::fast_build(),
            BuildQuality::Medium => BvhBuildParams::medium_build(),
            BuildQuality::Slow => BvhBuildParams::slow_build(),
        }
    }
}

/// Acceleration structure plus primitives in the normalised frame.
pub struct Tracer {
    bvh: CwBvh,
    /// The first `cwbvh::TOP_NODES` nodes (breadth first) with float boxes.
    top: Vec<cwbvh::FloatNode>,
    /// Per leaf slot (the order of `bvh.primitive_indices`), so a leaf's primitives are
    /// read from consecutive memory: a triangle's vertices in the normalised frame, and in
    /// the first vertex's `w` the slot's kind (`SLOT_TRIANGLE`, `SLOT_PADDING` or the
    /// sphere's index), so the hot loop never reads `primitive_indices`; a triangle's second
    /// and third `w` hold its index and material (as bits), so a hit reads them from the
    /// vertices it was just tested with rather than from two arrays in input order.
    slot_tri: Vec<[Vec4; 3]>,
    tri_count: usize,
    sphere_center: Vec<Vec3A>,
    sphere_radius: Vec<f32>,
    sphere_inward: Vec<bool>,
    sphere_material: Vec<u32>,
    /// World → normalised: `(p − centre) · scale`.
    centre: Vec3,
    scale: f32,
    /// The node test this CPU runs (see `trace::cwbvh`).
    node_test: NodeTest,
    /// Time spent building the BVH.
    pub build_time: Duration,
}

/// Per-ray constants of the watertight test: the axis permutation that makes z the
/// dominant direction axis (as lane indices, read with an indexed load, not a branch: a
/// `match` on the permutation was a jump table whose target changed with every ray) and
/// the shear.
#[derive(Clone, Copy)]
struct Shear {
    k: [usize; 3],
    sx: f32,
    sy: f32,
    sz: f32,
}

/// (v[kx], v[ky], v[kz]).
#[inline(always)]
fn permute(v: Vec3A, k: [usize; 3]) -> Vec3A {
    let a = v.to_array();
    Vec3A::new(a[k[0]], a[k[1]], a[k[2]])
}

impl Shear {
    #[inline]
    fn new(dir: Vec3A) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // Swap kx and ky when the dominant component is negative, to keep winding.
        let k = if dir[kz] < 0.0 { [ky, kx, kz] } else { [kx, ky, kz] };
        let d = permute(dir, k);
        Shear { k, sx: d.x / d.z, sy: d.y / d.z, sz: 1.0 / d.z }
    }
}

/// The edge functions of [`intersect_watertight`] in double precision, for a ray through a
/// vertex or along an edge (some single-precision function exactly 0): shared edges stay
/// exact. Rare, so kept out of line and out of the hot test.
#[cold]
#[inline(never)]
fn edge_functions_f64(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> (f32, f32, f32) {
    (
        (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32,
        (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32,
        (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32,
    )
}

/// Watertight ray/triangle test (Woop, Benthin & Wald 2013). Returns t or +inf.
#[inline(always)]
fn intersect_watertight(s: &Shear, org: Vec3A, v0: Vec3A, v1: Vec3A, v2: Vec3A, tmin: f32, tmax: f32) -> f32 {
    let a = permute(v0 - org, s.k);
    let b = permute(v1 - org, s.k);
    let c = permute(v2 - org, s.k);
    let ax = a.x - s.sx * a.z;
    let ay = a.y - s.sy * a.z;
    let bx = b.x - s.sx * b.z;
    let by = b.y - s.sy * b.z;
    let cx = c.x - s.sx * c.z;
    let cy = c.y - s.sy * c.z;
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    // (`&` and `|` on the comparisons rather than `&&` and `||`: no branch per comparison)
    if (u == 0.0) | (v == 0.0) | (w == 0.0) {
        (u, v, w) = edge_functions_f64(ax, ay, bx, by, cx, cy);
    }
    if ((u < 0.0) | (v < 0.0) | (w < 0.0)) & ((u > 0.0) | (v > 0.0) | (w > 0.0)) {
        return f32::INFINITY;
    }
    let det = u + v + w;
    if det == 0.0 {
        return f32::INFINITY;
    }
    let t = (u * a.z + v * b.z + w * c.z) * s.sz / det;
    if t > tmin && t < tmax { t } else { f32::INFINITY }
}

/// Distance along the ray (origin, dir) to sphere light `light` within `tmax` (+inf: it
/// misses): [`intersect_sphere`] from 0.
#[inline]
#[must_use]
pub fn light_distance(light: &crate::scene::SphereLight, origin: Vec3, dir: Vec3, tmax: f32) -> f32 {
    intersect_sphere(Vec3A::from(origin), Vec3A::from(dir), Vec3A::from(light.position), light.radius, 0.0, tmax)
}

/// Ray/sphere distance (nearest root beyond `tmin`), with the precision improvements of
/// Haines et al., "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing Gems 7).
#[inline]
pub fn intersect_sphere(org: Vec3A, dir: Vec3A, center: Vec3A, radius: f32, tmin: f32, tmax: f32) -> f32 {
    let f = org - center;
    let b = -f.dot(dir);
    let perp = f + dir * b;
    let r2 = radius * radius;
    let disc = r2 - perp.length_squared();
    if disc < 0.0 {
        return f32::INFINITY;
    }
    let c = f.length_squared() - r2;
    let q = b + b.signum() * disc.sqrt();
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q) };
    let (near, far) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
    if near > tmin && near < tmax {
        near
    } else if far > tmin && far < tmax {
        far
    } else {
        f32::INFINITY
    }
}

impl Tracer {
    pub fn new(scene: &Scene) -> Tracer {
        Self::with_quality(scene, BuildQuality::default())
    }

    pub fn with_quality(scene: &Scene, quality: BuildQuality) -> Tracer {
        streams::set_triangles(&scene.triangles.v0, &scene.triangles.v1, &scene.triangles.v2);
        let (lo, hi) = scene.bounds();
        let centre = (lo + hi) * 0.5;
        let extent = (hi - lo).max_element().max(f32::MIN_POSITIVE);
        // Power of two so that normalising is exact: extent·scale ∈ [512, 1024).
        let scale = 2f32.powi(9 - libm::log2f(extent).floor() as i32);
        let to_n = |p: Vec3| Vec3A::from((p - centre) * scale);
        let tri_v0: Vec<Vec3A> = scene.triangles.v0.iter().map(|&p| to_n(p)).collect();
        let tri_v1: Vec<Vec3A> = scene.triangles.v1.iter().map(|&p| to_n(p)).collect();
        let tri_v2: Vec<Vec3A> = scene.triangles.v2.iter().map(|&p| to_n(p)).collect();
        let sphere_center: Vec<Vec3A> = scene.spheres.center.iter().map(|&p| to_n(p)).collect();
        let sphere_radius: Vec<f32> = scene.spheres.radius.iter().map(|r| r * scale).collect();

        let mut aabbs: Vec<Aabb> = Vec::with_capacity(tri_v0.len() + sphere_center.len() + 1);
        let mut build_hi = Vec3A::splat(f32::NEG_INFINITY);
        // Boxes are padded by a few ulps of the normalised frame: obvhs's slab test is not
        // conservative, so a ray aimed exactly at a crease between two flat boxes (a room's
        // corner) could miss both.
        let pad = Vec3A::splat(BOX_PAD);
        for k in 0..tri_v0.len() {
            let b = Aabb::from_points(&[tri_v0[k], tri_v1[k], tri_v2[k]]);
            let b = Aabb { min: b.min - pad, max: b.max + pad };
            build_hi = build_hi.max(b.max);
            aabbs.push(b);
        }
        for (c, r) in sphere_center.iter().zip(&sphere_radius) {
            let b = Aabb { min: *c - Vec3A::splat(*r) - pad, max: *c + Vec3A::splat(*r) + pad };
            build_hi = build_hi.max(b.max);
            aabbs.push(b);
        }
        // Padding primitive beyond the max corner (see module docs).
        let pad = build_hi + Vec3A::splat(8.0);
        aabbs.push(Aabb { min: pad, max: pad + Vec3A::splat(1e-3) });

        let mut build_time = Duration::default();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&aabbs, quality.params(), &mut build_time);
        let slot_tri = bvh
            .primitive_indices
            .iter()
            .map(|&p| {
                let p = p as usize;
                let nt = tri_v0.len();
                let tag = |v: Vec3A, tag: u32| v.extend(f32::from_bits(tag));
                if p < nt {
                    let material = scene.triangles.material.get(p).copied().unwrap_or(0);
                    [tag(tri_v0[p], SLOT_TRIANGLE), tag(tri_v1[p], p as u32), tag(tri_v2[p], material)]
                } else if p - nt < sphere_center.len() {
                    [tag(Vec3A::ZERO, (p - nt) as u32), Vec4::ZERO, Vec4::ZERO]
                } else {
                    [tag(Vec3A::ZERO, SLOT_PADDING), Vec4::ZERO, Vec4::ZERO]
                }
            })
            .collect();
        let mut bvh = bvh;
        bvh.nodes = cwbvh::breadth_first(&bvh.nodes);
        let top = bvh.nodes.iter().take(cwbvh::TOP_NODES).map(cwbvh::FloatNode::from_cwbvh).collect();
        Tracer {
            bvh,
            top,
            slot_tri,
            tri_count: tri_v0.len(),
            sphere_center,
            sphere_radius,
            sphere_inward: scene.spheres.inward.clone(),
            sphere_material: scene.spheres.material.clone(),
            centre,
            scale,
            node_test: NodeTest::Auto.resolve(),
            build_time,
        }
    }

    /// The same tracer with another node test (tests and benchmarks compare them; every
    /// test gives the same hits).
    #[doc(hidden)]
    pub fn with_node_test(mut self, test: NodeTest) -> Tracer {
        self.node_test = test.resolve();
        self
    }

    /// The node test this tracer runs on this CPU.
    pub fn node_test(&self) -> NodeTest {
        self.node_test
    }

    /// Number of CWBVH nodes.
    #[doc(hidden)]
    pub fn node_count(&self) -> usize {
        self.bvh.nodes.len()
    }

    /// Number of real primitives (triangles + spheres).
    pub fn primitive_count(&self) -> usize {
        self.tri_count + self.sphere_center.len()
    }

    /// Scene units per normalised unit, times a small factor: the offset applied to
    /// secondary-ray origins to leave the surface they start on.
    #[inline]
    pub fn surface_offset(&self, p: Vec3) -> f32 {
        let pn = (p - self.centre) * self.scale;
        (pn.abs().max_element() + 1.0) * 2e-5 / self.scale
    }

    /// The frame [`Tracer::surface_offset`] measures in: its centre and scale (a shader
    /// that offsets shaded points as the tracer does needs them).
    #[must_use]
    pub fn offset_frame(&self) -> (Vec3, f32) {
        (self.centre, self.scale)
    }

    /// The ray in the normalised frame. A direction component of −0.0 becomes +0.0: obvhs
    /// takes the ray's octant from `d < 0.0` (false for −0.0) but its inverse from the sign
    /// bit (`signum(−0.0) = −1`), and with the two disagreeing every node test misses, so a
    /// ray along −Y written as `-Vec3::Y` (components −0, −1, −0) saw nothing. The node test
    /// here follows obvhs's conventions, so the rule stays.
    #[inline]
    fn normalised_ray(&self, origin: Vec3, dir: Vec3, tmax: f32) -> NodeRay {
        let o = Vec3A::from((origin - self.centre) * self.scale);
        let tmax_n = if tmax.is_finite() { tmax * self.scale } else { f32::INFINITY };
        // x + 0.0 is +0.0 for x = −0.0 and x otherwise (IEEE 754, round to nearest)
        NodeRay::new(o, Vec3A::from(dir) + Vec3A::ZERO, tmax_n)
    }

    /// The tree the walks read.
    #[inline(always)]
    fn tree(&self) -> cwbvh::Tree<'_> {
        cwbvh::Tree { nodes: &self.bvh.nodes, top: &self.top }
    }

    /// The leaf slots as `ray` sees them (its origin, direction and watertight shear).
    #[inline(always)]
    fn leaves(&self, ray: &NodeRay) -> SlotLeaves<'_> {
        SlotLeaves { tracer: self, shear: Shear::new(ray.dir), origin: ray.origin, dir: ray.dir }
    }

    /// Closest hit along the unit direction `dir` from `origin`, up to `tmax` (world units).
    /// Non-finite inputs return `None`.
    #[inline]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        self.closest_hit_as(streams::Kind::Primary, origin, dir, tmax)
    }

    /// [`Tracer::closest_hit`], kept as a ray of `kind` when the streams are dumped
    /// ([`streams`]).
    #[inline]
    pub fn closest_hit_as(&self, kind: streams::Kind, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        streams::record(kind, origin, dir, tmax);
        if !origin.is_finite() || !dir.is_finite() || dir == Vec3::ZERO {
            return None;
        }
        let mut ray = self.normalised_ray(origin, dir, tmax);
        let leaves = self.leaves(&ray);
        let slot = cwbvh::traverse::<false>(self.tree(), &mut ray, self.node_test, &leaves)?;
        self.hit_record(origin, dir, &ray, slot)
    }

    /// Closest hits of many rays (origin, unit direction; up to `tmax` world units), each
    /// the same as [`Tracer::closest_hit`] of that ray, walked [`cwbvh::PACKET`]
    /// consecutive rays at a time: rays that start at one point in neighbouring directions
    /// (sorted by [`coherent_order`]) share the node loads a single walk waits on. Rays in
    /// any order give the same hits, but diverging rays share few nodes and are slower in
    /// packets than one at a time.
    #[must_use]
    pub fn closest_hits(&self, rays: &[(Vec3, Vec3)], tmax: f32) -> Vec<Option<Hit>> {
        let mut out = vec![None; rays.len()];
        if streams::on() {
            for &(o, d) in rays {
                streams::record(streams::Kind::Primary, o, d, tmax);
            }
        }
        let placeholder = self.normalised_ray(Vec3::ZERO, Vec3::X, 0.0);
        for (batch, out) in rays.chunks(cwbvh::PACKET).zip(out.chunks_mut(cwbvh::PACKET)) {
            let mut node_rays = [placeholder; cwbvh::PACKET];
            let mut active: cwbvh::RayMask = 0;
            for (i, &(o, d)) in batch.iter().enumerate() {
                if o.is_finite() && d.is_finite() && d != Vec3::ZERO {
                    node_rays[i] = self.normalised_ray(o, d, tmax);
                    active |= 1 << i;
                }
            }
            let leaves: [SlotLeaves<'_>; cwbvh::PACKET] = std::array::from_fn(|i| self.leaves(&node_rays[i]));
            let slots = cwbvh::traverse_packet(self.tree(), &mut node_rays, active, self.node_test, &leaves);
            for (i, &(o, d)) in batch.iter().enumerate() {
                out[i] = slots[i].and_then(|slot| self.hit_record(o, d, &node_rays[i], slot));
            }
        }
        out
    }

    /// The hit record of the walk that ended with `ray` at leaf `slot`.
    #[inline(always)]
    fn hit_record(&self, origin: Vec3, dir: Vec3, ray: &NodeRay, slot: u32) -> Option<Hit> {
        let (o, d) = (ray.origin, ray.dir);
        let t = ray.tmax;
        if !t.is_finite() {
            return None;
        }
        let t_world = t / self.scale;
        let position = origin + dir * t_world;
        let nt = self.tri_count;
        let [w0, w1, w2] = self.slot_tri[slot as usize];
        let prim = if w0.w.to_bits() == SLOT_TRIANGLE {
            w1.w.to_bits() as usize
        } else {
            self.bvh.primitive_indices[slot as usize] as usize
        };
        let (normal, material) = if prim < nt {
            let [v0, v1, v2] = [w0, w1, w2].map(Vec3A::from_vec4);
            (Vec3::from((v1 - v0).cross(v2 - v0).normalize_or_zero()), w2.w.to_bits())
        } else {
            let k = prim - nt;
            let p = o + d * t;
            let out = Vec3::from((p - self.sphere_center[k]).normalize_or_zero());
            (if self.sphere_inward[k] { -out } else { out }, self.sphere_material[k])
        };
        let (sphere, index) = if prim < nt { (false, prim) } else { (true, prim - nt) };
        Some(Hit {
            t: t_world,
            position,
            normal,
            material,
            backface: normal.dot(dir) > 0.0,
            sphere,
            prim: index as u32,
        })
    }

    /// True when something lies along `dir` from `origin` closer than `tmax` (world units).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        streams::record(streams::Kind::Shadow, origin, dir, tmax);
        if !origin.is_finite() || !dir.is_finite() {
            return true;
        }
        let mut ray = self.normalised_ray(origin, dir, tmax);
        let leaves = self.leaves(&ray);
        cwbvh::traverse::<true>(self.tree(), &mut ray, self.node_test, &leaves).is_some()
    }

    /// The same query walked by obvhs's own traversal (`CwBvh::ray_traverse`) with the same
    /// primitive tests: distance (normalised frame) and leaf slot. Tests check that the
    /// tracer's walk finds the same distance, and the same slot unless several primitives
    /// are hit at exactly that distance (then the tracer's faces the ray if any does, and
    /// is the lowest slot of those).
    #[doc(hidden)]
    pub fn closest_slot_obvhs(&self, origin: Vec3, dir: Vec3) -> Option<(f32, u32)> {
        let ray = self.normalised_ray(origin, dir, f32::INFINITY);
        let leaves = self.leaves(&ray);
        let mut hit = RayHit::none();
        let found = self.bvh.ray_traverse(Ray::new(ray.origin, ray.dir, 0.0, ray.tmax), &mut hit, |r, slot| {
            cwbvh::Leaves::intersect(&leaves, slot as u32, r.tmax)
        });
        found.then_some((hit.t, hit.primitive_id))
    }

    /// Distance (normalised frame) at which the primitive in leaf `slot` is hit (+∞: not
    /// hit), and whether the ray meets its back side.
    #[doc(hidden)]
    pub fn slot_distance(&self, origin: Vec3, dir: Vec3, slot: u32) -> (f32, bool) {
        let ray = self.normalised_ray(origin, dir, f32::INFINITY);
        let leaves = self.leaves(&ray);
        (cwbvh::Leaves::intersect(&leaves, slot, ray.tmax), cwbvh::Leaves::back(&leaves, slot))
    }

    /// The closest hit's distance (normalised frame) and leaf slot, as `closest_hit` finds it.
    #[doc(hidden)]
    pub fn closest_slot(&self, origin: Vec3, dir: Vec3) -> Option<(f32, u32)> {
        let mut ray = self.normalised_ray(origin, dir, f32::INFINITY);
        let leaves = self.leaves(&ray);
        let slot = cwbvh::traverse::<false>(self.tree(), &mut ray, self.node_test, &leaves)?;
        Some((ray.tmax, slot))
    }

    /// The bare obvhs path on the same BVH: `Triangle::intersect` (not watertight) and no
    /// normalisation of inputs. Exists only so benchmarks can compare against it.
    #[doc(hidden)]
    pub fn bare_closest_t(&self, tris: &[obvhs::triangle::Triangle], origin: Vec3A, dir: Vec3A) -> f32 {
        let ray = Ray::new_inf(origin, dir);
        let mut hit = RayHit::none();
        self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            let prim = self.bvh.primitive_indices[id] as usize;
            match tris.get(prim) {
                Some(t) => t.intersect(r),
                None => f32::INFINITY,
            }
        });
        hit.t
    }

    /// Triangles in the normalised frame as obvhs `Triangle`s, for the bare benchmark path.
    #[doc(hidden)]
    pub fn normalised_triangles(&self) -> Vec<obvhs::triangle::Triangle> {
        let zero = obvhs::triangle::Triangle { v0: Vec3A::ZERO, v1: Vec3A::ZERO, v2: Vec3A::ZERO };
        let mut tris = vec![zero; self.tri_count];
        for (slot, &p) in self.bvh.primitive_indices.iter().enumerate() {
            if let Some(t) = tris.get_mut(p as usize) {
                let [v0, v1, v2] = self.slot_tri[slot].map(Vec3A::from_vec4);
                *t = obvhs::triangle::Triangle { v0, v1, v2 };
            }
        }
        tris
    }

    /// World → normalised point (benchmarks feed the bare path in this frame).
    #[doc(hidden)]
    pub fn to_normalised(&self, p: Vec3) -> Vec3A {
        Vec3A::from((p - self.centre) * self.scale)
    }
}

/// One ray's view of the tracer's leaf slots (see `trace::cwbvh::Leaves`).
struct SlotLeaves<'a> {
    tracer: &'a Tracer,
    shear: Shear,
    origin: Vec3A,
    dir: Vec3A,
}

impl cwbvh::Leaves for SlotLeaves<'_> {
    fn back(&self, slot: u32) -> bool {
        match self.tracer.slot_tri.get(slot as usize) {
            Some(&[v0, v1, v2]) if v0.w.to_bits() == SLOT_TRIANGLE => {
                let (v0, v1, v2) = (Vec3A::from_vec4(v0), Vec3A::from_vec4(v1), Vec3A::from_vec4(v2));
                (v1 - v0).cross(v2 - v0).dot(self.dir) > 0.0
            }
            _ => false,
        }
    }

    #[inline(always)]
    fn intersect(&self, slot: u32, tmax: f32) -> f32 {
        let Some([v0, v1, v2]) = self.tracer.slot_tri.get(slot as usize) else {
            return f32::INFINITY;
        };
        match v0.w.to_bits() {
            SLOT_TRIANGLE => intersect_watertight(
                &self.shear,
                self.origin,
                Vec3A::from_vec4(*v0),
                Vec3A::from_vec4(*v1),
                Vec3A::from_vec4(*v2),
                0.0,
                tmax,
            ),
            SLOT_PADDING => f32::INFINITY,
            k => {
                let t = self.tracer;
                match (t.sphere_center.get(k as usize), t.sphere_radius.get(k as usize)) {
                    (Some(&c), Some(&r)) => intersect_sphere(self.origin, self.dir, c, r, 0.0, tmax),
                    _ => f32::INFINITY,
                }
            }
        }
    }
}

/// An order of `rays` (indices) in which neighbours point in neighbouring directions:
/// their directions' octahedral coordinates ([`crate::octa::encode`]) on a 4096 × 4096
/// grid, in Morton order, ties in input order (a stable radix sort in two passes, linear
/// in the rays). What [`Tracer::closest_hits`] wants of rays that start at one point.
#[must_use]
pub fn coherent_order(rays: &[(Vec3, Vec3)]) -> Vec<u32> {
    const BITS: u32 = 12;
    let key = |d: Vec3| {
        let uv = crate::octa::encode(d);
        let q = |x: f32| if x.is_finite() { (x.clamp(0.0, 1.0) * ((1 << BITS) - 1) as f32) as u32 } else { 0 };
        morton2(q(uv.x), q(uv.y))
    };
    let keys: Vec<u32> = rays.iter().map(|&(_, d)| key(d)).collect();
    let mut order: Vec<u32> = (0..rays.len() as u32).collect();
    let mut scratch = vec![0u32; order.len()];
    let mut start = vec![0usize; (1 << BITS) + 1];
    for pass in 0..2 {
        let digit = |k: u32| ((keys[k as usize] >> (BITS * pass)) & ((1 << BITS) - 1)) as usize;
        start.fill(0);
        for &k in &order {
            start[digit(k) + 1] += 1;
        }
        for b in 0..1 << BITS {
            start[b + 1] += start[b];
        }
        for &k in &order {
            let b = digit(k);
            scratch[start[b]] = k;
            start[b] += 1;
        }
        std::mem::swap(&mut order, &mut scratch);
    }
    order
}

/// The bits of `x` and `y` (16 each) interleaved, x in the even bits.
fn morton2(x: u32, y: u32) -> u32 {
    let spread = |v: u32| {
        let mut v = v & 0xffff;
        v = (v | (v << 8)) & 0x00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333;
        (v | (v << 1)) & 0x5555_5555
    };
    spread(x) | (spread(y) << 1)
}
