//! Traversal of obvhs's compressed wide BVH (CWBVH: Ylitie, Karras & Laine, HPG 2017) with
//! a node test chosen for the CPU at run time.
//!
//! obvhs builds the tree; this module walks it. Closest-hit rays visit children nearest
//! first, with each pushed child's entry distance on the stack so that a child a nearer hit
//! has ruled out is never visited (Embree's order; obvhs orders children by the ray's
//! octant and keeps no distances); the result is the nearest hit, a tie to the primitive
//! facing the ray and then the lowest leaf slot, whatever the order. Occlusion rays keep obvhs's `traverse!` loop step for step (any
//! hit will do). The node test, where most of a ray's time goes, differs from obvhs's:
//! - the eight children's quantised planes are widened from bytes to floats with one vector
//!   conversion per axis and side (obvhs builds each float from a scalar byte);
//! - the near and far plane of each axis are picked once per ray from the direction's sign
//!   (a byte offset into the node) instead of per node;
//! - on a CPU with AVX2 the eight children are tested in one 8-wide pass, chosen at run time
//!   (`is_x86_feature_detected!`), so a portable binary gets the wide test where the CPU has
//!   it. Both paths do the same IEEE operations in the same order (multiply, add, min, max,
//!   compare, no fused multiply-add), so they give the same bits: `tests/trace.rs` compares
//!   them ray by ray.
//!
//! - the nodes are numbered breadth first, and the first [`TOP_NODES`] of them (the top
//!   levels, which every ray visits and which stay in cache) are also kept with their
//!   children's boxes as floats ([`FloatNode`], rounded outwards): their test reads the
//!   planes instead of dequantising them, while the deep levels keep the 80-byte nodes,
//!   whose memory traffic matters more there than the arithmetic.
//!
//! Primitive tests go through the `Leaves` trait by leaf *slot* (index into
//! `primitive_indices`), so the caller can lay its primitives out in slot order and read
//! them sequentially.

use glam::{UVec2, Vec3A};
use obvhs::cwbvh::node::CwBvhNode;
use std::mem::MaybeUninit;

/// obvhs's node-test entry clamp (its `cwbvh::node::EPSILON`, private there).
const NODE_TMIN: f32 = 1e-4;

/// Which node test runs. `Auto` picks the widest the CPU supports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum NodeTest {
    #[default]
    Auto,
    /// Two 4-wide passes with SSE2 (every x86-64 CPU); a scalar loop elsewhere.
    Portable,
    /// One 8-wide pass with AVX2, when the CPU has it (otherwise `Portable`).
    Wide,
}

impl NodeTest {
    /// The test that will actually run on this CPU.
    pub fn resolve(self) -> NodeTest {
        match self {
            NodeTest::Portable => NodeTest::Portable,
            NodeTest::Auto | NodeTest::Wide => {
                if wide_available() {
                    NodeTest::Wide
                } else {
                    NodeTest::Portable
                }
            }
        }
    }
}

#[inline]
fn wide_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        // every AVX2 CPU has these too; the wide walk counts and scans child masks with them
        std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Per-ray constants of the node test.
#[derive(Clone, Copy, Debug)]
pub struct NodeRay {
    pub origin: Vec3A,
    /// Unit direction (no −0.0 component).
    pub dir: Vec3A,
    /// `obvhs::ray::safe_inverse` of each direction component (finite).
    pub inv_dir: Vec3A,
    /// Byte offsets, inside a node, of the near-plane arrays of x, y and z (the far plane's
    /// array is the next or previous 8 bytes).
    near: [usize; 3],
    /// Index, in a [`FloatNode`]'s planes, of the near-plane array of x, y and z (the far
    /// plane's is the index xor 1).
    near_plane: [usize; 3],
    /// obvhs's octant code, which orders children front to back.
    oct_inv4: u32,
    /// Current far end of the ray (shrinks with each closer hit).
    pub tmax: f32,
}

const MIN_X: usize = std::mem::offset_of!(CwBvhNode, child_min_x);
const MAX_X: usize = std::mem::offset_of!(CwBvhNode, child_max_x);
const MIN_Y: usize = std::mem::offset_of!(CwBvhNode, child_min_y);
const MAX_Y: usize = std::mem::offset_of!(CwBvhNode, child_max_y);
const MIN_Z: usize = std::mem::offset_of!(CwBvhNode, child_min_z);
const MAX_Z: usize = std::mem::offset_of!(CwBvhNode, child_max_z);
// `NodeRay::far` flips between an axis's min and max arrays with one xor.
const _: () = assert!(MIN_X ^ 8 == MAX_X && MIN_Y ^ 8 == MAX_Y && MIN_Z ^ 8 == MAX_Z);

impl NodeRay {
    /// `dir` must be finite with no −0.0 component (see `Tracer::normalised_ray`).
    #[inline]
    pub fn new(origin: Vec3A, dir: Vec3A, tmax: f32) -> NodeRay {
        let neg = [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0];
        let pick = |n: bool, lo: usize, hi: usize| if n { hi } else { lo };
        NodeRay {
            origin,
            dir,
            inv_dir: Vec3A::new(safe_inverse(dir.x), safe_inverse(dir.y), safe_inverse(dir.z)),
            near: [pick(neg[0], MIN_X, MAX_X), pick(neg[1], MIN_Y, MAX_Y), pick(neg[2], MIN_Z, MAX_Z)],
            near_plane: [neg[0] as usize, 2 + neg[1] as usize, 4 + neg[2] as usize],
            oct_inv4: (if neg[0] { 0 } else { 0x0404_0404 })
                | (if neg[1] { 0 } else { 0x0202_0202 })
                | (if neg[2] { 0 } else { 0x0101_0101 }),
            tmax,
        }
    }

    /// The far end the node tests and the walks' culling use: the closest hit so far, but
    /// never below the node test's entry clamp (1e-4, obvhs's). Every entry distance is at
    /// least the clamp, so with a hit closer than it (a ray starting on a surface) a box
    /// holding a still closer hit would otherwise be skipped or not, by the order the walk
    /// met them in; this way every such box is entered and the nearest hit wins whatever
    /// the order.
    #[inline(always)]
    pub fn cull(&self) -> f32 {
        self.tmax.max(NODE_TMIN)
    }

    /// Far-plane array offset of `axis`.
    #[inline(always)]
    fn far(&self, axis: usize) -> usize {
        // min and max arrays of one axis are adjacent 8-byte blocks
        self.near[axis] ^ 8
    }
}

/// A tree to walk: obvhs's CWBVH nodes, numbered breadth first ([`breadth_first`]), and
/// the first of them again as [`FloatNode`]s (`top`), which both walks test instead.
#[derive(Clone, Copy)]
pub struct Tree<'a> {
    pub nodes: &'a [CwBvhNode],
    pub top: &'a [FloatNode],
}

/// How many of a tree's first nodes (breadth first: its top levels) the walks read as
/// [`FloatNode`]s: 2,048 of them, 512 KB. Every ray visits the top levels, where
/// a float node saves the eight children's dequantisation (about a third of the node
/// test's work) and costs no memory traffic, as they stay in cache; the deep levels keep
/// the 80-byte compressed nodes, since three times the bytes there cost a ray more in
/// cache misses than the dequantisation (measured: docs/architecture.md).
pub const TOP_NODES: usize = 2048;

/// obvhs's CWBVH node with its children's boxes as floats: each plane `p + 2^e · q`
/// rounded outwards, so every box holds the quantised one.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct FloatNode {
    /// `planes[2·axis]`: the eight children's minima on `axis`; `planes[2·axis + 1]` their maxima.
    planes: [[f32; 8]; 6],
    child_base_idx: u32,
    primitive_base_idx: u32,
    imask: u32,
    child_meta: [u8; 8],
}

impl FloatNode {
    pub fn from_cwbvh(n: &CwBvhNode) -> FloatNode {
        let e = n.compute_extent();
        let plane = |q: &[u8; 8], p: f32, e: f32, up: bool| {
            q.map(|q| {
                let v = p + e * q as f32;
                if up { v.next_up() } else { v.next_down() }
            })
        };
        FloatNode {
            planes: [
                plane(&n.child_min_x, n.p.x, e.x, false),
                plane(&n.child_max_x, n.p.x, e.x, true),
                plane(&n.child_min_y, n.p.y, e.y, false),
                plane(&n.child_max_y, n.p.y, e.y, true),
                plane(&n.child_min_z, n.p.z, e.z, false),
                plane(&n.child_max_z, n.p.z, e.z, true),
            ],
            child_base_idx: n.child_base_idx,
            primitive_base_idx: n.primitive_base_idx,
            imask: n.imask as u32,
            child_meta: n.child_meta,
        }
    }
}

/// The nodes renumbered breadth first (each node's children stay one contiguous block, in
/// their order), so a tree's top levels are its first nodes.
pub fn breadth_first(nodes: &[CwBvhNode]) -> Vec<CwBvhNode> {
    if nodes.is_empty() {
        return Vec::new();
    }
    let mut order = vec![0usize];
    let mut new_index = vec![u32::MAX; nodes.len()];
    new_index[0] = 0;
    let mut head = 0;
    while head < order.len() {
        let n = &nodes[order[head]];
        head += 1;
        for c in 0..n.imask.count_ones() as usize {
            let old = n.child_base_idx as usize + c;
            if old < nodes.len() && new_index[old] == u32::MAX {
                new_index[old] = order.len() as u32;
                order.push(old);
            }
        }
    }
    order
        .iter()
        .map(|&o| {
            let mut n = nodes[o];
            if n.imask != 0 {
                n.child_base_idx = new_index.get(n.child_base_idx as usize).copied().unwrap_or(u32::MAX);
            }
            n
        })
        .collect()
}

/// obvhs's `ray::safe_inverse`: 1/x, or ±1/ε for |x| ≤ ε.
#[inline]
fn safe_inverse(x: f32) -> f32 {
    if x.abs() <= f32::EPSILON { x.signum() / f32::EPSILON } else { 1.0 / x }
}

/// The 8-byte plane array at `offset` (one of the `MIN_*`/`MAX_*` constants).
#[inline(always)]
fn bytes(node: &CwBvhNode, offset: usize) -> &[u8; 8] {
    debug_assert!([MIN_X, MAX_X, MIN_Y, MAX_Y, MIN_Z, MAX_Z].contains(&offset));
    // SAFETY: `CwBvhNode` is `repr(C)` and `offset` is the `offset_of!` of one of its
    // `[u8; 8]` fields, so the 8 bytes are inside the node, initialised, and u8-aligned.
    unsafe { &*((node as *const CwBvhNode).cast::<u8>().add(offset).cast::<[u8; 8]>()) }
}

/// The node's per-axis scale (`2^e`) and the ray transformed into the node's quantised frame.
#[inline(always)]
fn node_frame(node: &CwBvhNode, ray: &NodeRay) -> (Vec3A, Vec3A) {
    let e = node.compute_extent();
    (e * ray.inv_dir, (Vec3A::from(node.p) - ray.origin) * ray.inv_dir)
}

/// From the bit set of children whose boxes the ray enters to obvhs's hit mask (inner
/// children in the high byte by traversal priority, leaf primitives in the low 24 bits).
#[inline(always)]
fn hit_mask(meta8: u64, oct_inv4: u32, mut entered: u32) -> u32 {
    let (child_bits8, bit_index8) = child_and_index_bits(meta8, oct_inv4);
    let mut mask = 0u32;
    while entered != 0 {
        let j = entered.trailing_zeros();
        let child_bits = ((child_bits8 >> (j * 8)) as u32) & 0xff;
        let bit_index = ((bit_index8 >> (j * 8)) as u32) & 0xff;
        mask |= child_bits << bit_index;
        entered &= entered - 1;
    }
    mask
}

/// obvhs's `CwBvhNode::get_child_and_index_bits` on a node's eight child metas (byte `j`
/// child `j`'s), so float top nodes, which carry the metas, give the same masks.
#[inline(always)]
fn child_and_index_bits(meta8: u64, oct_inv4: u32) -> (u64, u64) {
    let mut oct_inv8 = oct_inv4 as u64;
    oct_inv8 |= oct_inv8 << 32;
    // an inner child's meta is in [24, 32): bits 3 and 4 both set, never both for a leaf's
    let is_inner8 = (meta8 & (meta8 << 1)) & 0x1010_1010_1010_1010;
    let inner_mask8 = (is_inner8 >> 4) * 0xff;
    let bit_index8 = (meta8 ^ (oct_inv8 & inner_mask8)) & 0x1f1f_1f1f_1f1f_1f1f;
    let child_bits8 = (meta8 >> 5) & 0x0707_0707_0707_0707;
    (child_bits8, bit_index8)
}

/// The node test, one child at a time (non-x86 targets, and the reference the vector tests
/// are checked against).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
fn entered_scalar(node: &CwBvhNode, ray: &NodeRay, entry: &mut [f32; 8]) -> u32 {
    let (scale, shift) = node_frame(node, ray);
    let planes = |axis: usize| (bytes(node, ray.near[axis]), bytes(node, ray.far(axis)));
    let (nx, fx) = planes(0);
    let (ny, fy) = planes(1);
    let (nz, fz) = planes(2);
    let mut entered = 0u32;
    for j in 0..8 {
        let t0x = nx[j] as f32 * scale.x + shift.x;
        let t1x = fx[j] as f32 * scale.x + shift.x;
        let t0y = ny[j] as f32 * scale.y + shift.y;
        let t1y = fy[j] as f32 * scale.y + shift.y;
        let t0z = nz[j] as f32 * scale.z + shift.z;
        let t1z = fz[j] as f32 * scale.z + shift.z;
        // operand order as in the vector paths (`max_ps(a, b)` = if a > b { a } else { b })
        let max = |a: f32, b: f32| if a > b { a } else { b };
        let min = |a: f32, b: f32| if a < b { a } else { b };
        let tmin = max(max(t0x, max(t0y, t0z)), NODE_TMIN);
        let tmax = min(min(t1x, min(t1y, t1z)), ray.cull());
        entry[j] = tmin;
        entered |= ((tmin <= tmax) as u32) << j;
    }
    entered
}

/// The top nodes' test one child at a time (non-x86 targets, and the reference the vector
/// tests are checked against).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
fn entered_top_scalar(node: &FloatNode, ray: &NodeRay, entry: &mut [f32; 8]) -> u32 {
    let o = ray.origin.to_array();
    let inv = ray.inv_dir.to_array();
    let t = |a: usize, far: bool, j: usize| (node.planes[ray.near_plane[a] ^ far as usize][j] - o[a]) * inv[a];
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let mut entered = 0u32;
    for j in 0..8 {
        let tmin = max(max(t(0, false, j), max(t(1, false, j), t(2, false, j))), NODE_TMIN);
        let tmax = min(min(t(0, true, j), min(t(1, true, j), t(2, true, j))), ray.cull());
        entry[j] = tmin;
        entered |= ((tmin <= tmax) as u32) << j;
    }
    entered
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    /// Two 4-wide passes (SSE2, part of every x86-64 CPU).
    #[inline(always)]
    pub(super) fn entered_sse2(node: &CwBvhNode, ray: &NodeRay, entry: &mut [f32; 8]) -> u32 {
        let (scale, shift) = node_frame(node, ray);
        // SAFETY: SSE2 is part of the x86-64 baseline; loads read 8 bytes inside the node.
        unsafe {
            let zero = _mm_setzero_si128();
            let widen = |offset: usize| {
                let b = _mm_loadl_epi64(bytes(node, offset).as_ptr() as *const __m128i);
                let w = _mm_unpacklo_epi8(b, zero);
                (_mm_cvtepi32_ps(_mm_unpacklo_epi16(w, zero)), _mm_cvtepi32_ps(_mm_unpackhi_epi16(w, zero)))
            };
            let axis = |a: usize, s: f32, o: f32| {
                let (s, o) = (_mm_set1_ps(s), _mm_set1_ps(o));
                let (n0, n1) = widen(ray.near[a]);
                let (f0, f1) = widen(ray.far(a));
                let t = |q| _mm_add_ps(_mm_mul_ps(q, s), o);
                (t(n0), t(n1), t(f0), t(f1))
            };
            let (nx0, nx1, fx0, fx1) = axis(0, scale.x, shift.x);
            let (ny0, ny1, fy0, fy1) = axis(1, scale.y, shift.y);
            let (nz0, nz1, fz0, fz1) = axis(2, scale.z, shift.z);
            let lo = _mm_set1_ps(NODE_TMIN);
            let hi = _mm_set1_ps(ray.cull());
            let mut test = |nx, ny, nz, fx, fy, fz, half: usize| {
                let tmin = _mm_max_ps(_mm_max_ps(nx, _mm_max_ps(ny, nz)), lo);
                let tmax = _mm_min_ps(_mm_min_ps(fx, _mm_min_ps(fy, fz)), hi);
                _mm_storeu_ps(entry[4 * half..].as_mut_ptr(), tmin);
                _mm_movemask_ps(_mm_cmple_ps(tmin, tmax)) as u32
            };
            test(nx0, ny0, nz0, fx0, fy0, fz0, 0) | (test(nx1, ny1, nz1, fx1, fy1, fz1, 1) << 4)
        }
    }

    /// The top nodes' test in two 4-wide passes (SSE2).
    #[inline(always)]
    pub(super) fn entered_top_sse2(node: &FloatNode, ray: &NodeRay, entry: &mut [f32; 8]) -> u32 {
        // SAFETY: SSE2 is part of the x86-64 baseline; loads read 4 floats of the node's
        // plane arrays, stores write 4 of `entry`.
        unsafe {
            let half = |h: usize| {
                let axis = |a: usize, o: f32, i: f32| {
                    let (o, i) = (_mm_set1_ps(o), _mm_set1_ps(i));
                    let near = _mm_loadu_ps(node.planes[ray.near_plane[a]][4 * h..].as_ptr());
                    let far = _mm_loadu_ps(node.planes[ray.near_plane[a] ^ 1][4 * h..].as_ptr());
                    (_mm_mul_ps(_mm_sub_ps(near, o), i), _mm_mul_ps(_mm_sub_ps(far, o), i))
                };
                let (nx, fx) = axis(0, ray.origin.x, ray.inv_dir.x);
                let (ny, fy) = axis(1, ray.origin.y, ray.inv_dir.y);
                let (nz, fz) = axis(2, ray.origin.z, ray.inv_dir.z);
                let tmin = _mm_max_ps(_mm_max_ps(nx, _mm_max_ps(ny, nz)), _mm_set1_ps(NODE_TMIN));
                let tmax = _mm_min_ps(_mm_min_ps(fx, _mm_min_ps(fy, fz)), _mm_set1_ps(ray.cull()));
                (tmin, _mm_movemask_ps(_mm_cmple_ps(tmin, tmax)) as u32)
            };
            let (t0, m0) = half(0);
            let (t1, m1) = half(1);
            _mm_storeu_ps(entry.as_mut_ptr(), t0);
            _mm_storeu_ps(entry[4..].as_mut_ptr(), t1);
            m0 | (m1 << 4)
        }
    }

    /// The top nodes' test in one 8-wide pass. Callers must have checked that the CPU has
    /// AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn entered_top_avx2(node: &FloatNode, ray: &NodeRay, entry: &mut [f32; 8]) -> u32 {
        // SAFETY: loads read 8 floats of the node's plane arrays; AVX2 is enabled here.
        unsafe {
            let axis = |a: usize, o: f32, i: f32| {
                let (o, i) = (_mm256_set1_ps(o), _mm256_set1_ps(i));
                let near = _mm256_loadu_ps(node.planes[ray.near_plane[a]].as_ptr());
                let far = _mm256_loadu_ps(node.planes[ray.near_plane[a] ^ 1].as_ptr());
                (_mm256_mul_ps(_mm256_sub_ps(near, o), i), _mm256_mul_ps(_mm256_sub_ps(far, o), i))
            };
            let (nx, fx) = axis(0, ray.origin.x, ray.inv_dir.x);
            let (ny, fy) = axis(1, ray.origin.y, ray.inv_dir.y);
            let (nz, fz) = axis(2, ray.origin.z, ray.inv_dir.z);
            let tmin = _mm256_max_ps(_mm256_max_ps(nx, _mm256_max_ps(ny, nz)), _mm256_set1_ps(NODE_TMIN));
            let tmax = _mm256_min_ps(_mm256_min_ps(fx, _mm256_min_ps(fy, fz)), _mm256_set1_ps(ray.cull()));
            _mm256_storeu_ps(entry.as_mut_ptr(), tmin);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32
        }
    }

    /// One 8-wide pass. Callers must have checked that the CPU has AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn entered_avx2(node: &CwBvhNode, ray: &NodeRay, entry: &mut [f32; 8]) -> u32 {
        let (scale, shift) = node_frame(node, ray);
        // SAFETY: loads read 8 bytes inside the node; AVX2 is enabled on this function.
        unsafe {
            let widen = |offset: usize| {
                let b = _mm_loadl_epi64(bytes(node, offset).as_ptr() as *const __m128i);
                _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(b))
            };
            let axis = |a: usize, s: f32, o: f32| {
                let (s, o) = (_mm256_set1_ps(s), _mm256_set1_ps(o));
                let n = _mm256_add_ps(_mm256_mul_ps(widen(ray.near[a]), s), o);
                let f = _mm256_add_ps(_mm256_mul_ps(widen(ray.far(a)), s), o);
                (n, f)
            };
            let (nx, fx) = axis(0, scale.x, shift.x);
            let (ny, fy) = axis(1, scale.y, shift.y);
            let (nz, fz) = axis(2, scale.z, shift.z);
            let tmin = _mm256_max_ps(_mm256_max_ps(nx, _mm256_max_ps(ny, nz)), _mm256_set1_ps(NODE_TMIN));
            let tmax = _mm256_min_ps(_mm256_min_ps(fx, _mm256_min_ps(fy, fz)), _mm256_set1_ps(ray.cull()));
            _mm256_storeu_ps(entry.as_mut_ptr(), tmin);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32
        }
    }

    /// `least_scalar` in two 4-wide passes (SSE2).
    #[inline(always)]
    pub(super) fn least_sse2(hit: u32, entry: &[f32; 8], nearest: &mut [f32; 8]) {
        // SAFETY: SSE2 is part of the x86-64 baseline; loads and stores of 4 floats of the
        // arrays.
        unsafe {
            let h = _mm_set1_epi32(hit as i32);
            for half in 0..2 {
                let bits = if half == 0 { _mm_setr_epi32(1, 2, 4, 8) } else { _mm_setr_epi32(16, 32, 64, 128) };
                let lanes = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(h, bits), bits));
                let e = _mm_loadu_ps(entry[4 * half..].as_ptr());
                let n = _mm_loadu_ps(nearest[4 * half..].as_ptr());
                let lower = _mm_and_ps(lanes, _mm_cmplt_ps(e, n));
                let out = _mm_or_ps(_mm_and_ps(lower, e), _mm_andnot_ps(lower, n));
                _mm_storeu_ps(nearest[4 * half..].as_mut_ptr(), out);
            }
        }
    }

    /// `least_scalar` in one 8-wide pass. Callers must have checked that the CPU has AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn least_avx2(hit: u32, entry: &[f32; 8], nearest: &mut [f32; 8]) {
        // SAFETY: loads and stores of 8 floats of the arrays; AVX2 is enabled here.
        unsafe {
            let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let lanes = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(hit as i32), bits), bits);
            let e = _mm256_loadu_ps(entry.as_ptr());
            let n = _mm256_loadu_ps(nearest.as_ptr());
            let lower = _mm256_and_ps(_mm256_castsi256_ps(lanes), _mm256_cmp_ps::<_CMP_LT_OQ>(e, n));
            _mm256_storeu_ps(nearest.as_mut_ptr(), _mm256_blendv_ps(n, e, lower));
        }
    }
}

/// A small traversal stack: 64 entries inline (deeper than any sane CWBVH), spilling to the
/// heap beyond that so a degenerate tree is slow, not a crash. The inline array is left
/// uninitialised (built with `MaybeUninit::uninit().assume_init()` of the array, which
/// writes nothing): zeroing it cost a 520-byte `memset` per ray.
struct Stack<T: Copy> {
    inline: [MaybeUninit<T>; 64],
    len: usize,
    spill: Vec<T>,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    fn new() -> Stack<T> {
        // SAFETY: an array of `MaybeUninit` needs no initialisation.
        let inline = unsafe { MaybeUninit::<[MaybeUninit<T>; 64]>::uninit().assume_init() };
        Stack { inline, len: 0, spill: Vec::new() }
    }
    #[inline(always)]
    fn push(&mut self, v: T) {
        match self.inline.get_mut(self.len) {
            Some(slot) => {
                slot.write(v);
            }
            None => self.spill.push(v),
        }
        self.len += 1;
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        match self.inline.get(self.len) {
            // SAFETY: every index below the length before this pop was written by `push`.
            Some(slot) => Some(unsafe { slot.assume_init() }),
            None => self.spill.pop(),
        }
    }
}

/// The primitives of the leaves, addressed by leaf slot (index into `primitive_indices`).
pub trait Leaves {
    /// Hit distance of the primitive in `slot` closer than `tmax`, or +∞.
    fn intersect(&self, slot: u32, tmax: f32) -> f32;
    /// The ray meets the primitive in `slot` from its back side (asked only to break ties
    /// between primitives hit at one distance).
    fn back(&self, slot: u32) -> bool;
}

/// Of two primitives hit at exactly one distance, `slot` takes the place of `best` when it
/// faces the ray and `best` does not, or faces it alike with a lower slot: where faces
/// coincide (two boxes touching) the ray sees the one turned towards it, and the choice
/// does not depend on the order the walk finds them in.
#[inline(never)]
#[cold]
fn wins_tie(leaves: &impl Leaves, slot: u32, best: u32) -> bool {
    (leaves.back(slot), slot) < (leaves.back(best), best)
}

/// The primitive in `slot` tested for `ray`: a hit nearer than the closest so far (`best`,
/// at `ray.tmax`), or at exactly that distance and winning the tie ([`wins_tie`]), becomes
/// the closest.
#[inline(always)]
fn test_primitive(leaves: &impl Leaves, slot: u32, ray: &mut NodeRay, best: &mut Option<u32>) {
    // with a hit found, a primitive at exactly its distance is a tie to break
    let limit = if best.is_some() { ray.tmax.next_up() } else { ray.tmax };
    let t = leaves.intersect(slot, limit);
    if t < ray.tmax || (t == ray.tmax && best.is_some_and(|b| wins_tie(leaves, slot, b))) {
        *best = Some(slot);
        ray.tmax = t;
    }
}

/// What a walk needs of the node it is at: the children the ray enters (the
/// node test has written their entry distances), which children are inner nodes, the
/// node's first primitive slot and first child node, and the children's metas (byte `j`
/// is child `j`'s).
#[derive(Clone, Copy)]
struct Visit {
    hit: u32,
    imask: u32,
    primitive_base: u32,
    child_base: u32,
    meta: u64,
}

/// A node's fields the walks read besides its boxes: (inner-child mask, first primitive
/// slot, first child node, the eight child metas).
trait NodeFields {
    fn fields(&self) -> (u32, u32, u32, u64);
}

impl NodeFields for CwBvhNode {
    #[inline(always)]
    fn fields(&self) -> (u32, u32, u32, u64) {
        (self.imask as u32, self.primitive_base_idx, self.child_base_idx, u64::from_le_bytes(self.child_meta))
    }
}

impl NodeFields for FloatNode {
    #[inline(always)]
    fn fields(&self) -> (u32, u32, u32, u64) {
        (self.imask, self.primitive_base_idx, self.child_base_idx, u64::from_le_bytes(self.child_meta))
    }
}

/// [`Visit`] of a node under the node test `entered`.
#[inline(always)]
fn visit<N: NodeFields>(
    node: &N,
    ray: &NodeRay,
    entry: &mut [f32; 8],
    entered: impl Fn(&N, &NodeRay, &mut [f32; 8]) -> u32,
) -> Visit {
    let (imask, primitive_base, child_base, meta) = node.fields();
    Visit { hit: entered(node, ray, entry), imask, primitive_base, child_base, meta }
}

/// Walks the tree for `ray` with the node test `entered` (which also writes each child's
/// entry distance). Closest hit (`ANY` false): the slot of the nearest hit, with `ray.tmax`
/// its distance ([`walk_nearest`]). `ANY`: the first slot hit, in obvhs's order
/// ([`walk_any`]).
#[inline(always)]
fn walk<const ANY: bool>(
    tree: Tree<'_>,
    ray: &mut NodeRay,
    entered: impl Fn(&CwBvhNode, &NodeRay, &mut [f32; 8]) -> u32,
    entered_top: impl Fn(&FloatNode, &NodeRay, &mut [f32; 8]) -> u32,
    leaves: &impl Leaves,
) -> Option<u32> {
    let visit = |k: u32, r: &NodeRay, e: &mut [f32; 8]| match tree.top.get(k as usize) {
        Some(f) => Some(visit(f, r, e, &entered_top)),
        None => tree.nodes.get(k as usize).map(|n| visit(n, r, e, &entered)),
    };
    if ANY { walk_any(ray, visit, leaves) } else { walk_nearest(ray, visit, leaves) }
}

/// Closest hit, nearest child first (Embree's order for closest-hit rays). At each node the
/// leaf children's primitives are intersected at once, so their hits shorten the ray
/// before anything else; the inner children the ray enters are sorted by entry distance,
/// the nearest is walked next and the others are pushed with their distance, and a popped
/// child whose entry lies beyond the closest hit found since is dropped unvisited. obvhs's
/// own order (children by the ray's octant, groups on the stack without distances) visits
/// nodes a nearer hit has already ruled out; this order made the atrium's closest-hit rays
/// about 10% faster. The result does not depend on the order: the nearest distance, and of
/// primitives hit at exactly that distance (coinciding faces, a shared edge) the one facing
/// the ray, then the lowest slot ([`wins_tie`]).
#[inline(always)]
fn walk_nearest(
    ray: &mut NodeRay,
    visit: impl Fn(u32, &NodeRay, &mut [f32; 8]) -> Option<Visit>,
    leaves: &impl Leaves,
) -> Option<u32> {
    let mut best: Option<u32> = None;
    // inner children to visit, as `nearest_key`s
    let mut stack = Stack::<u64>::new();
    let mut entry = [0.0f32; 8];
    let mut current = 0u32;
    // (a malformed tree, or none, ends the walk rather than panic)
    while let Some(node) = visit(current, ray, &mut entry) {
        let hit = node.hit;
        let imask = node.imask;
        // leaf children first, so their hits shorten the ray before the inner children
        // are ordered
        let mut leaf = hit & !imask;
        while leaf != 0 {
            let j = (leaf.trailing_zeros() & 7) as usize;
            leaf &= leaf - 1;
            if entry[j] > ray.cull() {
                continue; // a leaf of this node already hit nearer than this box
            }
            for slot in leaf_slots(node.primitive_base, node.meta, j) {
                test_primitive(leaves, slot, ray, &mut best);
            }
        }
        // the inner children the ray enters before its closest hit so far, as sort keys;
        // an inner child's node follows the inner children of lower slots
        let mut inner = hit & imask;
        let mut keys = [0u64; 8];
        let mut n = 0usize;
        while inner != 0 {
            let j = inner.trailing_zeros() & 7;
            inner &= inner - 1;
            let t = entry[j as usize];
            let index = inner_child(node.child_base, imask, j);
            keys[n & 7] = nearest_key(t, index);
            n += (t <= ray.cull()) as usize;
        }
        // nearest first (equal distances in any order: the result does not depend on it)
        sort_keys(&mut keys, n);
        let next = if n == 0 {
            None
        } else {
            for &k in keys[1..n].iter().rev() {
                stack.push(k);
            }
            Some(keys[0])
        };
        current = match next {
            Some(k) => k as u32,
            None => loop {
                match stack.pop() {
                    Some(k) if key_distance(k) <= ray.cull() => break k as u32,
                    Some(_) => {}
                    None => return best,
                }
            },
        };
    }
    best
}

/// The primitive slots of leaf child `j` of a node whose first slot is `primitive_base`
/// and whose child metas are `meta` (byte `j` is child `j`'s): the meta's high 3 bits
/// count the child's primitives (unary), its low 5 their offset from the node's first.
#[inline(always)]
fn leaf_slots(primitive_base: u32, meta: u64, j: usize) -> std::ops::Range<u32> {
    let m = ((meta >> (8 * j)) & 0xff) as u32;
    let first = primitive_base.wrapping_add(m & 0x1f);
    first..first.saturating_add((m >> 5).count_ones())
}

/// The node index of inner child `j` (of 8) of a node whose first child node is
/// `child_base` and whose inner children are `imask`: it follows the inner children of
/// lower slots.
#[inline(always)]
fn inner_child(child_base: u32, imask: u32, j: u32) -> u32 {
    child_base.wrapping_add((imask & ((1u32 << j) - 1)).count_ones())
}

/// An inner child as one integer that sorts as its entry distance: the distance's bits in
/// the high half (entry distances are positive, at least the node test's clamp, and the
/// bits of positive floats order as the floats do), the node index in the low half.
#[inline(always)]
fn nearest_key(t: f32, index: u32) -> u64 {
    ((t.to_bits() as u64) << 32) | index as u64
}

/// The entry distance of a [`nearest_key`].
#[inline(always)]
fn key_distance(key: u64) -> f32 {
    f32::from_bits((key >> 32) as u32)
}

/// Sorts the first `n` keys ascending: compare-exchanges without branches for the common
/// two and three children (one and three of them), insertion beyond.
#[inline(always)]
fn sort_keys(keys: &mut [u64; 8], n: usize) {
    let exchange = |keys: &mut [u64; 8], a: usize, b: usize| {
        let (x, y) = (keys[a], keys[b]);
        keys[a] = x.min(y);
        keys[b] = x.max(y);
    };
    // (an `if` chain: a `match` here became a jump table, an indirect branch the CPU
    // mispredicted at most nodes)
    if n == 2 {
        exchange(keys, 0, 1);
    } else if n == 3 {
        exchange(keys, 0, 1);
        exchange(keys, 1, 2);
        exchange(keys, 0, 1);
    } else if n > 3 {
        for a in 1..n.min(8) {
            let x = keys[a];
            let mut b = a;
            while b > 0 && keys[b - 1] > x {
                keys[b] = keys[b - 1];
                b -= 1;
            }
            keys[b] = x;
        }
    }
}

/// obvhs's `traverse!` loop over the nodes `visit` tests: the first slot hit. About 40% of
/// its time waits on node and triangle loads; prefetching the hit children and leaf
/// triangles as soon as a node is tested did not pay (measured on the atrium).
#[inline(always)]
fn walk_any(
    ray: &mut NodeRay,
    visit: impl Fn(u32, &NodeRay, &mut [f32; 8]) -> Option<Visit>,
    leaves: &impl Leaves,
) -> Option<u32> {
    let mut stack = Stack::<UVec2>::new();
    let mut current = UVec2::new(0, 0x8000_0000);
    let mut prims = UVec2::ZERO;
    let mut entry = [0.0f32; 8];
    loop {
        while prims.y != 0 {
            let local = 31 - prims.y.leading_zeros();
            prims.y &= !(1u32 << local);
            let slot = prims.x + local;
            if leaves.intersect(slot, ray.tmax) < ray.tmax {
                return Some(slot);
            }
        }
        prims = UVec2::ZERO;
        if current.y & 0xff00_0000 != 0 {
            let hits_imask = current.y;
            let child_offset = 31 - hits_imask.leading_zeros();
            let base = current.x;
            current.y &= !(1u32 << child_offset);
            if current.y & 0xff00_0000 != 0 {
                stack.push(current);
            }
            let slot_index = (child_offset - 24) ^ (ray.oct_inv4 & 0xff);
            let relative = (hits_imask & !(0xffff_ffffu32 << slot_index)).count_ones();
            let Some(node) = visit(base.wrapping_add(relative), ray, &mut entry) else {
                break; // malformed tree, or none: stop rather than panic
            };
            let mask = hit_mask(node.meta, ray.oct_inv4, node.hit);
            current = UVec2::new(node.child_base, (mask & 0xff00_0000) | node.imask);
            prims = UVec2::new(node.primitive_base, mask & 0x00ff_ffff);
        } else {
            current = UVec2::ZERO;
        }
        if prims.y == 0 && current.y & 0xff00_0000 == 0 {
            match stack.pop() {
                Some(group) => current = group,
                None => break,
            }
        }
    }
    None
}

/// Rays a packet walk ([`traverse_packet`]) carries at most: one bit each in its masks.
pub const PACKET: usize = 64;

/// A set of a packet's rays, bit i for ray i.
pub type RayMask = u64;

/// `nearest[j]` lowered to `entry[j]` for each child j in `hit`: the packet walk's least
/// entry per child (the one path off x86-64, and what the vector ones are checked against).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
fn least_scalar(hit: u32, entry: &[f32; 8], nearest: &mut [f32; 8]) {
    for j in 0..8 {
        if (hit >> j) & 1 != 0 && entry[j] < nearest[j] {
            nearest[j] = entry[j];
        }
    }
}

/// Per child slot j, the rays (bit i) whose byte `hits[i]` has bit j set: the packet's
/// hit bytes transposed, eight rays at a time (bit j of each of eight bytes gathered into
/// one byte by a multiply).
#[inline(always)]
fn rays_per_child(hits: &[u8; PACKET]) -> [RayMask; 8] {
    let mut child_rays: [RayMask; 8] = [0; 8];
    for (w, bytes) in hits.chunks_exact(8).enumerate() {
        let word = u64::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3], bytes[4], bytes[5], bytes[6], bytes[7]]);
        if word == 0 {
            continue;
        }
        for (j, rays) in child_rays.iter_mut().enumerate() {
            let bits = ((word >> j) & 0x0101_0101_0101_0101).wrapping_mul(0x0102_0408_1020_4080) >> 56;
            *rays |= (bits as RayMask) << (8 * w);
        }
    }
    child_rays
}

/// The node test of `node` for each ray in `mask`: `hits[i]`, the children ray i enters,
/// and `nearest[j]` lowered to each entering ray's entry distance of child j (the node
/// test has already held each entry to its ray's closest hit); the node's other fields.
#[inline(always)]
fn test_rays<N: NodeFields>(
    node: &N,
    rays: &[NodeRay; PACKET],
    mask: RayMask,
    entered: &impl Fn(&N, &NodeRay, &mut [f32; 8]) -> u32,
    least: &impl Fn(u32, &[f32; 8], &mut [f32; 8]),
    hits: &mut [u8; PACKET],
    nearest: &mut [f32; 8],
) -> (u32, u32, u32, u64) {
    let mut entry = [0.0f32; 8];
    let mut m = mask;
    while m != 0 {
        let i = m.trailing_zeros() as usize % PACKET;
        m &= m - 1;
        let hit = entered(node, &rays[i], &mut entry);
        hits[i] = hit as u8;
        least(hit, &entry, nearest);
    }
    node.fields()
}

/// Closest hits of up to [`PACKET`] rays (those in `active`) walked together: each node is
/// loaded once for every ray of the packet that enters it, and each ray is tested against
/// it with its own node test, so the loads the single walk waits on are shared where the
/// rays are coherent (from one point in neighbouring directions, a probe's texels). A
/// ray's result is what [`walk_nearest`] gives it: every primitive in a box the ray enters
/// before its closest hit so far is tested, the nearest distance wins and exact ties go
/// by [`wins_tie`], whatever the order; the order here is the packet's (children nearest
/// first by the least entry distance among the rays entering them).
#[inline(always)]
fn walk_packet<L: Leaves>(
    tree: Tree<'_>,
    rays: &mut [NodeRay; PACKET],
    active: RayMask,
    entered: impl Fn(&CwBvhNode, &NodeRay, &mut [f32; 8]) -> u32,
    entered_top: impl Fn(&FloatNode, &NodeRay, &mut [f32; 8]) -> u32,
    least: impl Fn(u32, &[f32; 8], &mut [f32; 8]),
    leaves: &[L; PACKET],
) -> [Option<u32>; PACKET] {
    let mut best = [None::<u32>; PACKET];
    // inner children to visit: a `nearest_key` of the least entry distance, and the rays
    let mut stack = Stack::<(u64, RayMask)>::new();
    let (mut current, mut mask) = (0u32, active & (RayMask::MAX >> (RayMask::BITS as usize - PACKET)));
    loop {
        // every ray's node test: its children entered (a byte per ray), and per child the
        // least entry distance of the rays entering it
        let mut hits = [0u8; PACKET];
        let mut nearest = [f32::INFINITY; 8];
        let (imask, primitive_base, child_base, meta) = match tree.top.get(current as usize) {
            Some(node) => test_rays(node, rays, mask, &entered_top, &least, &mut hits, &mut nearest),
            None => match tree.nodes.get(current as usize) {
                Some(node) => test_rays(node, rays, mask, &entered, &least, &mut hits, &mut nearest),
                None => return best, // a malformed tree, or none: stop rather than panic
            },
        };
        let child_rays = rays_per_child(&hits);
        let mut any = 0u32;
        for (j, &r) in child_rays.iter().enumerate() {
            any |= ((r != 0) as u32) << j;
        }
        // leaf children first, for each ray entering them, as the single walk does
        let mut leaf = any & !imask;
        while leaf != 0 {
            let j = (leaf.trailing_zeros() & 7) as usize;
            leaf &= leaf - 1;
            // `leaf_slots` written out: called here, this walk measured 2–5% slower
            // (`ray_rate … packets`, alternated), the same floats
            let m = ((meta >> (8 * j)) & 0xff) as u32;
            let first = primitive_base.wrapping_add(m & 0x1f);
            for slot in first..first.saturating_add((m >> 5).count_ones()) {
                let mut r = child_rays[j];
                while r != 0 {
                    let i = r.trailing_zeros() as usize % PACKET;
                    r &= r - 1;
                    test_primitive(&leaves[i], slot, &mut rays[i], &mut best[i]);
                }
            }
        }
        // the inner children, nearest first by their least entry distance (a key's low
        // bits: the child's slot)
        let mut inner = any & imask;
        let mut keys = [0u64; 8];
        let mut n = 0usize;
        while inner != 0 {
            let j = inner.trailing_zeros() & 7;
            inner &= inner - 1;
            keys[n & 7] = nearest_key(nearest[j as usize], j);
            n += 1;
        }
        sort_keys(&mut keys, n);
        let node_of = |key: u64| {
            let j = (key & 7) as u32;
            (inner_child(child_base, imask, j), child_rays[j as usize])
        };
        for &k in keys[1..n.max(1)].iter().rev() {
            let (index, rays_in) = node_of(k);
            stack.push(((k & !0xffff_ffff) | index as u64, rays_in));
        }
        (current, mask) = if n > 0 {
            node_of(keys[0])
        } else {
            // the next pushed child some ray still reaches before its closest hit
            loop {
                let Some((k, m)) = stack.pop() else { return best };
                let t = key_distance(k);
                let (mut r, mut keep) = (m, 0 as RayMask);
                while r != 0 {
                    let i = r.trailing_zeros() as usize % PACKET;
                    r &= r - 1;
                    keep |= ((t <= rays[i].cull()) as RayMask) << i;
                }
                if keep != 0 {
                    break (k as u32, keep);
                }
            }
        };
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn walk_packet_avx2<L: Leaves>(
    tree: Tree<'_>,
    rays: &mut [NodeRay; PACKET],
    active: RayMask,
    leaves: &[L; PACKET],
) -> [Option<u32>; PACKET] {
    // Runs only after `wide_available()` said the CPU has AVX2, POPCNT and BMI1.
    walk_packet(
        tree,
        rays,
        active,
        |n, r, e| x86::entered_avx2(n, r, e),
        |n, r, e| x86::entered_top_avx2(n, r, e),
        |h, e, n| x86::least_avx2(h, e, n),
        leaves,
    )
}

/// Closest hits of the rays in `active` (bit i: `rays[i]`) walked as one packet with the
/// node test `test`: each node is read once for all the rays that enter it and tested
/// with each ray's own node test, leaf primitives are tested for each ray that enters
/// their box, and children are visited nearest first by the least entry distance among
/// their rays. For each ray the slot and, in its `tmax`, the distance [`traverse`] finds
/// for it alone (every primitive in a box the ray enters before its closest hit so far is
/// tested, and the nearest hit with its ties rule wins whatever the order).
#[inline]
pub fn traverse_packet<L: Leaves>(
    tree: Tree<'_>,
    rays: &mut [NodeRay; PACKET],
    active: RayMask,
    test: NodeTest,
    leaves: &[L; PACKET],
) -> [Option<u32>; PACKET] {
    #[cfg(target_arch = "x86_64")]
    {
        if test == NodeTest::Wide && wide_available() {
            // SAFETY: the CPU has AVX2, POPCNT and BMI1 (checked just above).
            return unsafe { walk_packet_avx2(tree, rays, active, leaves) };
        }
        walk_packet(tree, rays, active, x86::entered_sse2, x86::entered_top_sse2, x86::least_sse2, leaves)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = test;
        walk_packet(tree, rays, active, entered_scalar, entered_top_scalar, least_scalar, leaves)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn walk_avx2<const ANY: bool>(tree: Tree<'_>, ray: &mut NodeRay, leaves: &impl Leaves) -> Option<u32> {
    // Runs only after `wide_available()` said the CPU has AVX2, POPCNT and BMI1 (see
    // `traverse`).
    walk::<ANY>(tree, ray, |n, r, e| x86::entered_avx2(n, r, e), |n, r, e| x86::entered_top_avx2(n, r, e), leaves)
}

/// Walks `tree` for `ray` with the node test `test` (resolved to what the CPU has).
/// Closest hit unless `ANY`; see `walk`.
#[inline(always)]
pub fn traverse<const ANY: bool>(
    tree: Tree<'_>,
    ray: &mut NodeRay,
    test: NodeTest,
    leaves: &impl Leaves,
) -> Option<u32> {
    #[cfg(target_arch = "x86_64")]
    {
        if test == NodeTest::Wide && wide_available() {
            // SAFETY: the CPU has AVX2, POPCNT and BMI1 (checked just above; the check is a
            // cached load).
            return unsafe { walk_avx2::<ANY>(tree, ray, leaves) };
        }
        walk::<ANY>(tree, ray, x86::entered_sse2, x86::entered_top_sse2, leaves)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = test;
        walk::<ANY>(tree, ray, entered_scalar, entered_top_scalar, leaves)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node with pseudo-random planes (min ≤ max per child), origin and exponents.
    fn node(seed: &mut u64) -> CwBvhNode {
        let mut next = || {
            *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (*seed >> 33) as u32
        };
        let p = glam::Vec3::new(next() as f32 / 4e7 - 50.0, next() as f32 / 4e7 - 50.0, next() as f32 / 4e7 - 50.0);
        let e = [120 + (next() % 10) as u8, 120 + (next() % 10) as u8, 120 + (next() % 10) as u8];
        let mut n = CwBvhNode { p, e, ..CwBvhNode::default() };
        for j in 0..8 {
            for (lo, hi) in [(&mut n.child_min_x, &mut n.child_max_x), (&mut n.child_min_y, &mut n.child_max_y)]
                .into_iter()
                .chain([(&mut n.child_min_z, &mut n.child_max_z)])
            {
                let (a, b) = ((next() % 256) as u8, (next() % 256) as u8);
                (lo[j], hi[j]) = (a.min(b), a.max(b));
            }
        }
        n
    }

    /// The packet walk's per-child ray masks (a transposition by multiplies) and least entry
    /// distances (8-wide min-selects) are their plain loops' results.
    #[test]
    fn the_packet_walks_bookkeeping_matches_its_plain_form() {
        let mut seed = 11u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        for _ in 0..2_000 {
            // each ray's children entered, transposed to each child's rays
            let mut hits = [0u8; PACKET];
            for h in hits.iter_mut() {
                *h = if next() % 4 == 0 { 0 } else { next() as u8 };
            }
            let per_child = rays_per_child(&hits);
            for j in 0..8 {
                let want = (0..PACKET).fold(0 as RayMask, |m, i| m | ((((hits[i] >> j) & 1) as RayMask) << i));
                assert_eq!(per_child[j], want, "child {j}");
            }
            // the least entry of the children hit, on every path
            let hit = next() & 0xff;
            let entry: [f32; 8] = std::array::from_fn(|_| 1e-4 + (next() % 1000) as f32 * 0.37);
            let start: [f32; 8] =
                std::array::from_fn(|_| if next() % 3 == 0 { f32::INFINITY } else { (next() % 1000) as f32 * 0.37 });
            let mut want = start;
            least_scalar(hit, &entry, &mut want);
            for j in 0..8 {
                let lowered = if (hit >> j) & 1 != 0 { start[j].min(entry[j]) } else { start[j] };
                assert_eq!(want[j].to_bits(), lowered.to_bits());
            }
            #[cfg(target_arch = "x86_64")]
            {
                let mut sse2 = start;
                x86::least_sse2(hit, &entry, &mut sse2);
                assert_eq!(sse2.map(f32::to_bits), want.map(f32::to_bits));
                if wide_available() {
                    let mut avx2 = start;
                    // SAFETY: the CPU has AVX2 (checked just above).
                    unsafe { x86::least_avx2(hit, &entry, &mut avx2) };
                    assert_eq!(avx2.map(f32::to_bits), want.map(f32::to_bits));
                }
            }
        }
    }

    /// Every node test says the same children are entered, on random nodes and rays
    /// (axis-aligned and grazing directions included, finite and short rays).
    #[test]
    fn vector_node_tests_match_the_scalar_one() {
        let mut seed = 7u64;
        let mut entered_any = 0;
        for k in 0..20_000u32 {
            let n = node(&mut seed);
            let m = node(&mut seed);
            // from a random point, aimed at one child's centre (or along an axis)
            let origin = Vec3A::from(n.p) + Vec3A::from(m.p);
            let j = k as usize % 8;
            let lo = Vec3A::new(n.child_min_x[j] as f32, n.child_min_y[j] as f32, n.child_min_z[j] as f32);
            let hi = Vec3A::new(n.child_max_x[j] as f32, n.child_max_y[j] as f32, n.child_max_z[j] as f32);
            let centre = Vec3A::from(n.p) + n.compute_extent() * (lo + hi) * 0.5;
            let dir = match k % 5 {
                0 => Vec3A::X,
                1 => Vec3A::new(0.0, -1.0, 0.0),
                _ => (centre - origin).normalize_or(Vec3A::Z) + Vec3A::ZERO,
            };
            let tmax = [f32::INFINITY, 60.0, 1e-3][(k % 3) as usize];
            let ray = NodeRay::new(origin, dir, tmax);
            let mut entry = [0.0f32; 8];
            let scalar = entered_scalar(&n, &ray, &mut entry);
            entered_any += (scalar != 0) as u32;
            // the same node as a float top node: the same test on every path
            let top = FloatNode::from_cwbvh(&n);
            let mut top_entry = [0.0f32; 8];
            let top_scalar = entered_top_scalar(&top, &ray, &mut top_entry);
            // (its boxes hold the quantised ones: every child the quantised test enters,
            // it enters; the clamped entry distances differ by rounding alone)
            assert_eq!(top_scalar & scalar, scalar, "node {k}: a float box misses a child");
            #[cfg(target_arch = "x86_64")]
            {
                let bits = |e: [f32; 8]| e.map(f32::to_bits);
                let mut e = [0.0f32; 8];
                assert_eq!(x86::entered_top_sse2(&top, &ray, &mut e), top_scalar, "node {k}");
                assert_eq!(bits(e), bits(top_entry), "node {k}: top entry distances");
                if wide_available() {
                    // SAFETY: the CPU has AVX2.
                    assert_eq!(unsafe { x86::entered_top_avx2(&top, &ray, &mut e) }, top_scalar, "node {k}");
                    assert_eq!(bits(e), bits(top_entry), "node {k}: top entry distances");
                }
                assert_eq!(x86::entered_sse2(&n, &ray, &mut e), scalar, "node {k}");
                assert_eq!(bits(e), bits(entry), "node {k}: entry distances");
                if wide_available() {
                    // SAFETY: the CPU has AVX2.
                    assert_eq!(unsafe { x86::entered_avx2(&n, &ray, &mut e) }, scalar, "node {k}");
                    assert_eq!(bits(e), bits(entry), "node {k}: entry distances");
                }
            }
        }
        assert!(entered_any > 2_000, "only {entered_any} nodes entered: the test would prove little");
    }

    /// A float top node's planes hold the quantised box (each within one rounding of
    /// `p + 2^e · q`, outwards), and its metas give obvhs's masks.
    #[test]
    fn float_nodes_hold_the_quantised_boxes_and_give_obvhs_masks() {
        let mut seed = 11u64;
        for k in 0..5_000 {
            let mut n = node(&mut seed);
            n.child_meta = [0b0010_0000, 0b1110_0001, 24, 25, 0, 0b0110_0100, 30, 0b0010_0111];
            n.imask = 0b0100_1100;
            let f = FloatNode::from_cwbvh(&n);
            let e = n.compute_extent();
            let arrays = [
                (&n.child_min_x, n.p.x, e.x),
                (&n.child_max_x, n.p.x, e.x),
                (&n.child_min_y, n.p.y, e.y),
                (&n.child_max_y, n.p.y, e.y),
                (&n.child_min_z, n.p.z, e.z),
                (&n.child_max_z, n.p.z, e.z),
            ];
            for (a, (q, p, e)) in arrays.iter().enumerate() {
                for j in 0..8 {
                    let exact = *p as f64 + *e as f64 * q[j] as f64;
                    let plane = f.planes[a][j] as f64;
                    if a % 2 == 0 {
                        assert!(plane <= exact, "node {k}: min plane {a} of child {j} above the box");
                    } else {
                        assert!(plane >= exact, "node {k}: max plane {a} of child {j} below the box");
                    }
                }
            }
            for oct in [0u32, 0x0101_0101, 0x0606_0606, 0x0707_0707] {
                let mine = child_and_index_bits(u64::from_le_bytes(f.child_meta), oct);
                assert_eq!(mine, n.get_child_and_index_bits(oct), "node {k}, octant {oct:#x}");
            }
        }
    }

    /// Breadth-first numbering keeps the tree: each node's children stay one block in their
    /// order, every child follows its parent, and the walk from the root reaches the same
    /// leaves.
    #[test]
    fn breadth_first_keeps_the_tree() {
        let scene = crate::scene::Scene::parse(
            include_str!("../../data/scenes/torture.toml"),
            std::path::Path::new("data/scenes/torture.toml"),
        )
        .unwrap();
        let t = &scene.triangles;
        let aabbs: Vec<obvhs::aabb::Aabb> = (0..t.v0.len())
            .map(|k| obvhs::aabb::Aabb::from_points(&[t.v0[k].into(), t.v1[k].into(), t.v2[k].into()]))
            .collect();
        let mut time = std::time::Duration::default();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&aabbs, obvhs::BvhBuildParams::medium_build(), &mut time);
        let bfs = breadth_first(&bvh.nodes);
        assert_eq!(bfs.len(), bvh.nodes.len());
        assert!(bvh.nodes.len() > 9, "a tree of more than two levels");
        // the leaves' primitive ranges, in the order a depth-first walk meets them
        fn leaves(nodes: &[CwBvhNode], k: usize, out: &mut Vec<(u32, u8)>) {
            let n = &nodes[k];
            let mut child = n.child_base_idx as usize;
            for j in 0..8 {
                if n.imask & (1 << j) != 0 {
                    assert!(child > k, "child {child} of {k} comes first");
                    leaves(nodes, child, out);
                    child += 1;
                } else if n.child_meta[j] != 0 {
                    out.push((n.primitive_base_idx + (n.child_meta[j] & 0x1f) as u32, n.child_meta[j] >> 5));
                }
            }
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        leaves(&bvh.nodes, 0, &mut a);
        leaves(&bfs, 0, &mut b);
        assert_eq!(a, b);
        // breadth first: a node's depth never decreases with its index
        let mut depth = vec![0usize; bfs.len()];
        for (k, n) in bfs.iter().enumerate() {
            for c in 0..n.imask.count_ones() as usize {
                depth[n.child_base_idx as usize + c] = depth[k] + 1;
            }
        }
        assert!(depth.windows(2).all(|w| w[0] <= w[1]), "{depth:?}");
    }
}
