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
            oct_inv4: (if neg[0] { 0 } else { 0x0404_0404 })
                | (if neg[1] { 0 } else { 0x0202_0202 })
                | (if neg[2] { 0 } else { 0x0101_0101 }),
            tmax,
        }
    }

    /// Far-plane array offset of `axis`.
    #[inline(always)]
    fn far(&self, axis: usize) -> usize {
        // min and max arrays of one axis are adjacent 8-byte blocks
        self.near[axis] ^ 8
    }
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
fn hit_mask(node: &CwBvhNode, oct_inv4: u32, mut entered: u32) -> u32 {
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
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
        let tmax = min(min(t1x, min(t1y, t1z)), ray.tmax);
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
            let hi = _mm_set1_ps(ray.tmax);
            let mut test = |nx, ny, nz, fx, fy, fz, half: usize| {
                let tmin = _mm_max_ps(_mm_max_ps(nx, _mm_max_ps(ny, nz)), lo);
                let tmax = _mm_min_ps(_mm_min_ps(fx, _mm_min_ps(fy, fz)), hi);
                _mm_storeu_ps(entry[4 * half..].as_mut_ptr(), tmin);
                _mm_movemask_ps(_mm_cmple_ps(tmin, tmax)) as u32
            };
            test(nx0, ny0, nz0, fx0, fy0, fz0, 0) | (test(nx1, ny1, nz1, fx1, fy1, fz1, 1) << 4)
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
            let tmax = _mm256_min_ps(_mm256_min_ps(fx, _mm256_min_ps(fy, fz)), _mm256_set1_ps(ray.tmax));
            _mm256_storeu_ps(entry.as_mut_ptr(), tmin);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32
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

/// Walks the tree for `ray` with the node test `entered` (which also writes each child's
/// entry distance). Closest hit (`ANY` false): the slot of the nearest hit, with `ray.tmax`
/// its distance ([`walk_nearest`]). `ANY`: the first slot hit, in obvhs's order
/// ([`walk_any`]).
#[inline(always)]
fn walk<const ANY: bool>(
    nodes: &[CwBvhNode],
    ray: &mut NodeRay,
    entered: impl Fn(&CwBvhNode, &NodeRay, &mut [f32; 8]) -> u32,
    leaves: &impl Leaves,
) -> Option<u32> {
    if ANY { walk_any(nodes, ray, entered, leaves) } else { walk_nearest(nodes, ray, entered, leaves) }
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
    nodes: &[CwBvhNode],
    ray: &mut NodeRay,
    entered: impl Fn(&CwBvhNode, &NodeRay, &mut [f32; 8]) -> u32,
    leaves: &impl Leaves,
) -> Option<u32> {
    let mut best: Option<u32> = None;
    // inner children to visit, as `nearest_key`s
    let mut stack = Stack::<u64>::new();
    let mut entry = [0.0f32; 8];
    let mut current = 0u32;
    // (a malformed tree, or none, ends the walk rather than panic)
    while let Some(node) = nodes.get(current as usize) {
        let hit = entered(node, ray, &mut entry);
        let imask = node.imask as u32;
        // leaf children first, so their hits shorten the ray before the inner children
        // are ordered
        let mut leaf = hit & !imask;
        while leaf != 0 {
            let j = (leaf.trailing_zeros() & 7) as usize;
            leaf &= leaf - 1;
            if entry[j] > ray.tmax {
                continue; // a leaf of this node already hit nearer than this box
            }
            // the high 3 bits of the child's meta count its primitives (unary), the low 5
            // their offset from the node's first
            let meta = node.child_meta[j] as u32;
            let first = node.primitive_base_idx.wrapping_add(meta & 0x1f);
            for slot in first..first.saturating_add((meta >> 5).count_ones()) {
                // with a hit found, a primitive at exactly its distance is a tie to break
                let limit = if best.is_some() { ray.tmax.next_up() } else { ray.tmax };
                let t = leaves.intersect(slot, limit);
                if t < ray.tmax || (t == ray.tmax && best.is_some_and(|b| wins_tie(leaves, slot, b))) {
                    best = Some(slot);
                    ray.tmax = t;
                }
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
            let index = node.child_base_idx.wrapping_add((imask & ((1u32 << j) - 1)).count_ones());
            keys[n & 7] = nearest_key(t, index);
            n += (t <= ray.tmax) as usize;
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
                    Some(k) if key_distance(k) <= ray.tmax => break k as u32,
                    Some(_) => {}
                    None => return best,
                }
            },
        };
    }
    best
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

/// obvhs's `traverse!` loop with the node test `entered`: the first slot hit. About 40% of
/// its time waits on node and triangle loads; prefetching the hit children and leaf
/// triangles as soon as a node is tested did not pay (measured on the atrium).
#[inline(always)]
fn walk_any(
    nodes: &[CwBvhNode],
    ray: &mut NodeRay,
    entered: impl Fn(&CwBvhNode, &NodeRay, &mut [f32; 8]) -> u32,
    leaves: &impl Leaves,
) -> Option<u32> {
    if nodes.is_empty() {
        return None;
    }
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
            let Some(node) = nodes.get((base + relative) as usize) else {
                break; // malformed tree: stop rather than panic
            };
            let mask = hit_mask(node, ray.oct_inv4, entered(node, ray, &mut entry));
            current = UVec2::new(node.child_base_idx, (mask & 0xff00_0000) | node.imask as u32);
            prims = UVec2::new(node.primitive_base_idx, mask & 0x00ff_ffff);
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

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn walk_avx2<const ANY: bool>(nodes: &[CwBvhNode], ray: &mut NodeRay, leaves: &impl Leaves) -> Option<u32> {
    // Runs only after `wide_available()` said the CPU has AVX2, POPCNT and BMI1 (see
    // `traverse`).
    walk::<ANY>(nodes, ray, |n, r, e| x86::entered_avx2(n, r, e), leaves)
}

/// Walks `nodes` for `ray` with the node test `test` (resolved to what the CPU has).
/// Closest hit unless `ANY`; see `walk`.
#[inline(always)]
pub fn traverse<const ANY: bool>(
    nodes: &[CwBvhNode],
    ray: &mut NodeRay,
    test: NodeTest,
    leaves: &impl Leaves,
) -> Option<u32> {
    #[cfg(target_arch = "x86_64")]
    {
        if test == NodeTest::Wide && wide_available() {
            // SAFETY: the CPU has AVX2, POPCNT and BMI1 (checked just above; the check is a
            // cached load).
            return unsafe { walk_avx2::<ANY>(nodes, ray, leaves) };
        }
        walk::<ANY>(nodes, ray, x86::entered_sse2, leaves)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = test;
        walk::<ANY>(nodes, ray, entered_scalar, leaves)
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
            #[cfg(target_arch = "x86_64")]
            {
                let bits = |e: [f32; 8]| e.map(f32::to_bits);
                let mut e = [0.0f32; 8];
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
}
