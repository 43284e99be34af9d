//! Sparse bricks: how many cells a volume needs when its cells are fine only where the level
//! needs them, as Unity's Adaptive Probe Volumes store them. A brick holds
//! [`BRICK_CELLS`]³ cells; a brick at level `k` has cells of `finest · 3^k` and splits into
//! 3 × 3 × 3 bricks of level `k − 1`. The volume is tiled by bricks of the top level; a brick
//! splits while its rule says its cells are too coarse, and is dropped when it lies wholly
//! inside geometry (every sample point inside by the back-face rule).
//!
//! Two rules, both measured (docs/volumes.md):
//! - [`Rule::NearGeometry`], the APV rule: split wherever a surface lies within one of the
//!   brick's cells of it. Every brick on a level's ground splits to the finest size.
//! - [`Rule::SeenDistance`]: split while the brick's cell is larger than half the distance
//!   its air sample points see in half of their directions (by default the nearest point's) (the median hit distance, the
//!   sky counting as infinite) — the rule `warpfit check` gives for a whole grid's cell size,
//!   applied brick by brick. A room's brick splits; open ground under the sky and a single
//!   wall do not.
//!
//! Pure geometry and fixed ray sets: the plan is the same at any thread count.

use crate::sampling::{Sampler, uniform_sphere};
use crate::scene::Scene;
use crate::trace::{Tracer, truth};
use glam::Vec3;
use rayon::prelude::*;

/// Cells along a brick's side.
pub const BRICK_CELLS: u32 = 4;
/// Bricks along a brick's side at the next finer level.
pub const SPLIT: u32 = 3;
/// Directions each sample point traces for [`Rule::SeenDistance`].
const SEEN_RAYS: u32 = 64;
/// Sample points along a brick's side (their centres of a 3 × 3 × 3 split).
const SAMPLES: u32 = 3;

/// When a brick splits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rule {
    /// Wherever a surface lies within one of the brick's cells of it.
    NearGeometry,
    /// While `factor ×` the brick's cell exceeds the distance its air sample points see:
    /// each point's median hit distance, the `quantile` of those over the points (0: the
    /// nearest, 0.5: the median point).
    SeenDistance { quantile: f32, factor: f32 },
}

impl Rule {
    /// The rule `warpfit check` reports: split while a cell is over half the distance any
    /// of the brick's air points sees, as check's advice for a whole grid's cell.
    pub const CHECK: Rule = Rule::SeenDistance { quantile: 0.0, factor: 2.0 };
}

/// The bricks a volume keeps at each level (finest first) and the cells they hold.
#[derive(Clone, Debug, PartialEq)]
pub struct BrickPlan {
    /// The finest cell size (scene units).
    pub finest: f32,
    /// Bricks kept per level, finest first.
    pub kept: Vec<u64>,
    /// Bricks dropped as inside geometry, per level.
    pub solid: Vec<u64>,
    /// Cells of a uniform grid of the finest cells over the same box.
    pub uniform_cells: u64,
}

impl BrickPlan {
    /// Cells the kept bricks hold.
    #[must_use]
    pub fn cells(&self) -> u64 {
        self.kept.iter().sum::<u64>() * u64::from(BRICK_CELLS.pow(3))
    }

    /// [`BrickPlan::cells`] over the uniform grid's.
    #[must_use]
    pub fn share(&self) -> f64 {
        self.cells() as f64 / self.uniform_cells.max(1) as f64
    }
}

/// The plan of the box `[min, max]` at finest cell size `finest` with `levels` levels
/// (1–4), by `rule`; `inside_threshold` is the back-face share of the inside rule.
///
/// # Panics
/// Never: a non-finite or empty box, a cell size that is not positive and finite, or a level
/// count outside 1–4 give an empty plan.
#[must_use]
pub fn plan(
    scene: &Scene,
    tracer: &Tracer,
    (min, max): (Vec3, Vec3),
    finest: f32,
    levels: u32,
    rule: Rule,
    inside_threshold: f32,
) -> BrickPlan {
    let mut p = BrickPlan { finest, kept: vec![0; levels as usize], solid: vec![0; levels as usize], uniform_cells: 0 };
    let size = max - min;
    let valid =
        min.is_finite() && max.is_finite() && size.cmpgt(Vec3::ZERO).all() && finest.is_finite() && finest > 0.0;
    if !valid || !(1..=4).contains(&levels) {
        return p;
    }
    let cells = (size / finest).ceil();
    if cells.max_element() > 1e6 {
        return p;
    }
    p.uniform_cells = cells.x as u64 * cells.y as u64 * cells.z as u64;
    let top = levels - 1;
    let top_side = finest * (BRICK_CELLS * SPLIT.pow(top)) as f32;
    let n = (size / top_side).ceil().as_uvec3();
    let ctx = Ctx { scene, tracer, min, max, rule, threshold: inside_threshold };
    let all: Vec<u32> = (0..scene.triangles.len() as u32).collect();
    let spheres: Vec<u32> = (0..scene.spheres.len() as u32).collect();
    let bricks: Vec<(u32, u32, u32)> =
        (0..n.z).flat_map(|z| (0..n.y).flat_map(move |y| (0..n.x).map(move |x| (x, y, z)))).collect();
    let counts: Vec<Counts> = bricks
        .par_iter()
        .map(|&(x, y, z)| {
            let lo = min + Vec3::new(x as f32, y as f32, z as f32) * top_side;
            let mut c = Counts::new(levels);
            ctx.visit(top, lo, top_side, &all, &spheres, &mut c);
            c
        })
        .collect();
    for c in counts {
        for k in 0..levels as usize {
            p.kept[k] += c.kept[k];
            p.solid[k] += c.solid[k];
        }
    }
    p
}

struct Counts {
    kept: Vec<u64>,
    solid: Vec<u64>,
}

impl Counts {
    fn new(levels: u32) -> Counts {
        Counts { kept: vec![0; levels as usize], solid: vec![0; levels as usize] }
    }
}

struct Ctx<'a> {
    scene: &'a Scene,
    tracer: &'a Tracer,
    min: Vec3,
    max: Vec3,
    rule: Rule,
    threshold: f32,
}

impl Ctx<'_> {
    /// Counts the brick of level `level` at `lo` (side `side`), with the triangles and
    /// spheres that may lie near it.
    fn visit(&self, level: u32, lo: Vec3, side: f32, tris: &[u32], spheres: &[u32], c: &mut Counts) {
        let cell = side / BRICK_CELLS as f32;
        let (glo, ghi) = (lo - Vec3::splat(cell), lo + Vec3::splat(side + cell));
        let t = &self.scene.triangles;
        let near: Vec<u32> = tris
            .iter()
            .copied()
            .filter(|&i| {
                let i = i as usize;
                triangle_overlaps_box([t.v0[i], t.v1[i], t.v2[i]], glo, ghi)
            })
            .collect();
        let s = &self.scene.spheres;
        let near_spheres: Vec<u32> = spheres
            .iter()
            .copied()
            .filter(|&i| {
                let (centre, r) = (s.center[i as usize], s.radius[i as usize]);
                centre.clamp(glo, ghi).distance_squared(centre) <= r * r
            })
            .collect();
        let surfaces = !(near.is_empty() && near_spheres.is_empty());
        let split = match self.rule {
            // the rule needs no distances: a brick by a surface splits without tracing
            Rule::NearGeometry if surfaces && level > 0 => true,
            rule => {
                // (a finest brick cannot split: its points need only the inside test)
                let traced = if level == 0 { Rule::NearGeometry } else { rule };
                let mut seen = self.sample_points(lo, side, traced);
                if seen.is_empty() {
                    c.solid[level as usize] += 1;
                    return;
                }
                seen.sort_by(f32::total_cmp);
                match rule {
                    Rule::SeenDistance { quantile, factor } if level > 0 => {
                        let k = (quantile.clamp(0.0, 1.0) * (seen.len() - 1) as f32) as usize;
                        seen[k.min(seen.len() - 1)] < factor * cell
                    }
                    _ => false,
                }
            }
        };
        if !split {
            c.kept[level as usize] += 1;
            return;
        }
        let child = side / SPLIT as f32;
        for z in 0..SPLIT {
            for y in 0..SPLIT {
                for x in 0..SPLIT {
                    let clo = lo + Vec3::new(x as f32, y as f32, z as f32) * child;
                    if clo.cmplt(self.max).all() {
                        self.visit(level - 1, clo, child, &near, &near_spheres, c);
                    }
                }
            }
        }
    }

    /// The median hit distance (the sky infinite) of each of the brick's sample points in
    /// air, inside the volume; empty when every one is inside geometry. For
    /// [`Rule::NearGeometry`] the distances are not traced (infinite).
    fn sample_points(&self, lo: Vec3, side: f32, rule: Rule) -> Vec<f32> {
        // over the part of the brick inside the volume
        let step = ((lo + Vec3::splat(side)).min(self.max) - lo) / SAMPLES as f32;
        let mut out = Vec::new();
        let key = lo.to_array().map(f32::to_bits);
        let stream = u64::from(key[0]) ^ (u64::from(key[1]) << 21) ^ (u64::from(key[2]) << 42);
        for k in 0..SAMPLES.pow(3) {
            let (x, y, z) = (k % SAMPLES, (k / SAMPLES) % SAMPLES, k / (SAMPLES * SAMPLES));
            let p = lo + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * step;
            if !p.cmplt(self.max).all() || !p.cmpgt(self.min).all() {
                continue;
            }
            if truth::is_inside(self.scene, self.tracer, p, self.threshold, |j| Sampler::new(u64::from(k), stream, j)) {
                continue;
            }
            out.push(match rule {
                Rule::NearGeometry => f32::INFINITY,
                Rule::SeenDistance { .. } => self.median_distance(p, stream, k),
            });
        }
        out
    }

    /// The median distance `p` sees over [`SEEN_RAYS`] uniform directions, the sky infinite.
    fn median_distance(&self, p: Vec3, stream: u64, k: u32) -> f32 {
        let mut d: Vec<f32> = (0..SEEN_RAYS)
            .map(|j| {
                let dir = uniform_sphere(Sampler::new(u64::from(k) + 1000, stream, j).next_2d());
                self.tracer.closest_hit(p, dir, f32::INFINITY).map_or(f32::INFINITY, |h| h.t)
            })
            .collect();
        d.sort_by(f32::total_cmp);
        d[d.len() / 2]
    }
}

/// Whether the triangle `v` overlaps the box `[lo, hi]`: the separating-axis test of
/// Akenine-Möller (2001), the box's three axes, the triangle's normal and the nine edge
/// cross products.
#[must_use]
pub fn triangle_overlaps_box(v: [Vec3; 3], lo: Vec3, hi: Vec3) -> bool {
    let c = (lo + hi) * 0.5;
    let h = (hi - lo) * 0.5;
    let v = v.map(|p| p - c);
    // the box's axes
    let (tmin, tmax) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
    if tmin.cmpgt(h).any() || tmax.cmplt(-h).any() {
        return false;
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let separated = |axis: Vec3| {
        if axis.length_squared() <= f32::MIN_POSITIVE {
            return false;
        }
        let p = v.map(|q| q.dot(axis));
        let r = h.dot(axis.abs());
        p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r
    };
    if separated(e[0].cross(e[1])) {
        return false;
    }
    for edge in e {
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            if separated(axis.cross(edge)) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_overlaps_the_boxes_it_crosses_and_no_other() {
        let t = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
        assert!(triangle_overlaps_box(t, Vec3::splat(-0.5), Vec3::splat(0.5)));
        // beyond the hypotenuse: inside the triangle's bounding box, not the triangle
        assert!(!triangle_overlaps_box(t, Vec3::new(1.6, 1.6, -0.1), Vec3::new(2.0, 2.0, 0.1)));
        // off its plane
        assert!(!triangle_overlaps_box(t, Vec3::new(0.1, 0.1, 0.2), Vec3::new(0.5, 0.5, 0.6)));
        // a box the triangle passes through without a vertex in it
        assert!(triangle_overlaps_box(t, Vec3::new(0.8, 0.8, -0.1), Vec3::new(1.2, 1.2, 0.1)));
    }
}
