//! Ground truth, traced: what a ray from a query point really sees, where probe A sees the
//! same point from, whether a point is inside geometry, and the reference radiance of a set
//! of queries. The evaluation's validation set and the fit's training and check sets both
//! come from here, so judging and fitting can never disagree about the truth.

use super::bvh::light_distance;
use super::{Renderer, Tracer};
use crate::sampling::{Sampler, hash_pair, uniform_sphere};
use crate::scene::Scene;
use crate::tonemap::luminance;
use crate::warp::glossy::Aim;
use glam::Vec3;
use rayon::prelude::*;

/// Distance along the unit ray (origin, dir) to the first thing it sees, sphere lights
/// included (primary rays see them); +inf when it escapes.
#[must_use]
pub fn first_visible(scene: &Scene, tracer: &Tracer, origin: Vec3, dir: Vec3) -> f32 {
    let mut t = tracer.closest_hit(origin, dir, f32::INFINITY).map_or(f32::INFINITY, |h| h.t);
    for l in &scene.lights.sphere_lights {
        t = t.min(light_distance(l, origin, dir, t));
    }
    t
}

/// The oracle: the direction from A towards the true hit of the ray (B, dir), and whether A
/// sees that point (`true` = hidden: no single fetch of A can be right). The query direction
/// itself when the ray escapes or B is A.
#[must_use]
pub fn oracle(scene: &Scene, tracer: &Tracer, a: Vec3, b: Vec3, dir: Vec3) -> (Vec3, bool) {
    if a == b {
        return (dir, false); // A's own data is exact at A
    }
    let t = first_visible(scene, tracer, b, dir);
    if !t.is_finite() {
        return (dir, false);
    }
    let p = b + dir * t;
    (crate::warp::toward(a, p, dir), !sees(scene, tracer, a, p))
}

/// Where the oracles fetch for one query: probe A towards the true hit (`a`; the query
/// direction on a miss), and, of several probes, the nearest to the query that sees the
/// true hit, towards it (`any`; probe A's fetch when none sees it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Oracle {
    pub a: Vec3,
    pub any: Aim,
}

impl Oracle {
    /// The oracles of a query with no known hit: its own direction from probe A.
    #[must_use]
    pub fn plain(dir: Vec3) -> Oracle {
        Oracle { a: dir, any: dir.into() }
    }
}

/// The oracles of query (B, dir) over the probes at `probes` (probe A first; see
/// [`Oracle`]), and whether its true hit is hidden from probe A and from every probe.
#[must_use]
pub fn oracles(scene: &Scene, tracer: &Tracer, probes: &[Vec3], b: Vec3, dir: Vec3) -> (Oracle, bool, bool) {
    let Some(&a) = probes.first() else {
        return (Oracle::plain(dir), false, false);
    };
    let (to_a, hidden_a) = oracle(scene, tracer, a, b, dir);
    let mut out = Oracle { a: to_a, any: to_a.into() };
    if !hidden_a && probes.len() == 1 {
        return (out, false, false);
    }
    let t = first_visible(scene, tracer, b, dir);
    if a == b || !t.is_finite() {
        return (out, hidden_a, hidden_a);
    }
    let p = b + dir * t;
    // the probes nearest the query first (ties in index order)
    let mut order: Vec<usize> = (0..probes.len()).collect();
    order.sort_by(|&i, &j| {
        (probes[i] - b).length_squared().total_cmp(&(probes[j] - b).length_squared()).then(i.cmp(&j))
    });
    for i in order {
        let seen = if i == 0 { !hidden_a } else { sees(scene, tracer, probes[i], p) };
        if seen {
            out.any = Aim { v: crate::warp::toward(probes[i], p, dir), k: None, probe: i as u8 };
            return (out, hidden_a, false);
        }
    }
    (out, hidden_a, true)
}

/// Whether a probe at `a` sees point `p` (a surface point: the last thousandth of the way is
/// not tested, so the surface itself does not hide it); sphere lights hide what is behind
/// them. A probe at `p` sees it.
#[must_use]
pub fn sees(scene: &Scene, tracer: &Tracer, a: Vec3, p: Vec3) -> bool {
    let d = crate::warp::toward(a, p, Vec3::Z);
    let dist = (p - a).length();
    if !(dist > 0.0) {
        return true;
    }
    let reach = dist * (1.0 - 1e-3);
    let mut hidden = tracer.occluded(a, d, reach);
    for l in &scene.lights.sphere_lights {
        hidden |= light_distance(l, a, d, reach).is_finite();
    }
    !hidden
}

/// Back faces seen by the rays leaving a point: of one-sided surfaces, of any surface, and
/// how many rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Backfaces {
    pub one_sided: u32,
    pub any: u32,
    pub rays: u32,
}

impl Backfaces {
    /// Counts one ray's hit: `back` (geometric back face), `two_sided` (its material).
    pub fn add(&mut self, back: bool, two_sided: bool) {
        self.rays += 1;
        self.any += back as u32;
        self.one_sided += (back && !two_sided) as u32;
    }
}

/// Share of rays that must see back faces of any surface, two-sided ones included, for a
/// point to be inside a closed solid: two-sided materials (Blender exports `doubleSided`
/// by default) still enclose solids, but a point behind a free-standing two-sided panel
/// sees its back in at most about half of its directions.
pub const CLOSED_SOLID_FRACTION: f32 = 0.9;

/// The one inside-geometry rule: a point is inside when more than `threshold` of the rays
/// leaving it hit back faces of one-sided surfaces (the scene's
/// `grid.inside_backface_fraction`), or more than [`CLOSED_SOLID_FRACTION`] hit back faces
/// of any surface. The bake applies it to a cell's distance rays, the query sets to
/// [`INSIDE_PROBE_RAYS`] rays of their own.
#[must_use]
pub fn inside_by_backfaces(b: Backfaces, threshold: f32) -> bool {
    b.rays > 0
        && (b.one_sided as f32 / b.rays as f32 > threshold || b.any as f32 / b.rays as f32 > CLOSED_SOLID_FRACTION)
}

/// Rays a query point traces to apply the inside rule.
pub const INSIDE_PROBE_RAYS: u32 = 16;

/// The inside rule at `p`, with [`INSIDE_PROBE_RAYS`] uniform rays drawn from `sampler(k)`.
pub fn is_inside(scene: &Scene, tracer: &Tracer, p: Vec3, threshold: f32, sampler: impl Fn(u32) -> Sampler) -> bool {
    let mut b = Backfaces::default();
    for k in 0..INSIDE_PROBE_RAYS {
        let d = uniform_sphere(sampler(k).next_2d());
        match tracer.closest_hit(p, d, f32::INFINITY) {
            Some(h) => b.add(h.backface, scene.materials[h.material as usize].two_sided),
            None => b.add(false, false),
        }
    }
    inside_by_backfaces(b, threshold)
}

/// Irradiance at `p` around unit `n` from `spp` samples, and the standard error of its
/// luminance: what the light probes carry (sky, emitters, bounced light; the sun's disc is
/// not seen by rays, it reaches surfaces by next-event estimation). Each sample is
/// [`Renderer::irradiance_sample`] for a cosine-distributed direction: sphere lights and
/// emissive triangles by next-event estimation, the rest `π · L` along the direction
/// (exact for constant radiance). Unbiased like `π · mean L`, but a small bright emitter no
/// longer rules the variance (a lamp seen in a few samples of a thousand).
pub fn irradiance_reference(
    renderer: &Renderer,
    p: Vec3,
    n: Vec3,
    spp: u32,
    sampler: impl Fn(u32) -> Sampler,
    rays: &mut u64,
) -> (Vec3, f32) {
    let (mut sum, mut y1, mut y2) = (Vec3::ZERO, 0.0f64, 0.0f64);
    let spp = spp.max(1);
    for k in 0..spp {
        let mut s = sampler(k);
        let d = crate::sampling::cosine_hemisphere(s.next_2d(), n);
        let e = renderer.irradiance_sample(p, n, d, &mut s, rays);
        sum += e;
        let y = crate::tonemap::luminance(e) as f64;
        (y1, y2) = (y1 + y, y2 + y * y);
    }
    let m = spp as f64;
    let var = ((y2 - y1 * y1 / m) / (m - 1.0).max(1.0)).max(0.0);
    (sum / spp as f32, (var / m).sqrt() as f32)
}

/// `count` points area-uniform on the scene's triangles inside `bounds`, each offset off the
/// surface along the side it is seen from (one-sided: the front; two-sided: either, at
/// random), with that normal; points inside geometry are skipped. Drawn from
/// `Sampler::new(seed, stream, attempt)`: each user (validation, training, check) its own
/// stream.
pub fn surface_points(
    scene: &Scene,
    tracer: &Tracer,
    bounds: (Vec3, Vec3),
    count: u32,
    streams: (u64, u64),
) -> Vec<(Vec3, Vec3)> {
    let sampler = SurfaceSampler::new(scene, tracer, bounds, streams);
    sampler.successes(count).into_iter().filter_map(|a| sampler.candidate(a)).collect()
}

/// The draw of [`surface_points`], attempt by attempt: attempt `a`'s candidate (a point and
/// its normal) is a pure function of `a`, so a set of points can be kept as the attempts that
/// succeeded (4 bytes a point instead of 24) and each point computed again where it is used.
pub struct SurfaceSampler<'a> {
    scene: &'a Scene,
    tracer: &'a Tracer,
    bounds: (Vec3, Vec3),
    /// Cumulative triangle areas, and their total (0: nothing to draw on).
    cdf: Vec<f64>,
    total: f64,
    streams: (u64, u64),
}

impl<'a> SurfaceSampler<'a> {
    /// The draw on `scene`'s triangles inside `bounds`, on the streams `(seed, stream)`.
    #[must_use]
    pub fn new(scene: &'a Scene, tracer: &'a Tracer, bounds: (Vec3, Vec3), streams: (u64, u64)) -> Self {
        let tris = &scene.triangles;
        let mut cdf = Vec::with_capacity(tris.len());
        let mut total = 0.0f64;
        for k in 0..tris.len() {
            total += 0.5 * (tris.v1[k] - tris.v0[k]).cross(tris.v2[k] - tris.v0[k]).length() as f64;
            cdf.push(total);
        }
        let total = if total > 0.0 { total } else { 0.0 };
        SurfaceSampler { scene, tracer, bounds, cdf, total, streams }
    }

    /// Attempt `a`'s candidate before the inside test: a point area-uniform on the triangles,
    /// off the surface along the side it is seen from, with that normal; `None` outside the
    /// bounds or on a degenerate triangle.
    #[must_use]
    pub fn candidate(&self, a: u32) -> Option<(Vec3, Vec3)> {
        let (tris, (seed, stream)) = (&self.scene.triangles, self.streams);
        if tris.is_empty() || !(self.total > 0.0) {
            return None;
        }
        let mut s = Sampler::new(seed, stream, a);
        let pick = s.next_1d() as f64 * self.total;
        let k = self.cdf.partition_point(|&c| c <= pick).min(tris.len() - 1);
        let (u, v) = (s.next_1d(), s.next_1d());
        let su = u.sqrt();
        let (b0, b1) = (1.0 - su, v * su);
        let p = tris.v0[k] * b0 + tris.v1[k] * b1 + tris.v2[k] * (1.0 - b0 - b1);
        if !(p.cmpge(self.bounds.0).all() && p.cmple(self.bounds.1).all()) {
            return None;
        }
        let front = (tris.v1[k] - tris.v0[k]).cross(tris.v2[k] - tris.v0[k]).normalize_or_zero();
        let two_sided = self.scene.materials[tris.material[k] as usize].two_sided;
        let n = if two_sided && s.next_1d() < 0.5 { -front } else { front };
        (n != Vec3::ZERO).then(|| (p + n * self.tracer.surface_offset(p), n))
    }

    /// Whether attempt `a` gives a point: a candidate the inside rule does not reject.
    #[must_use]
    pub fn succeeds(&self, a: u32) -> bool {
        let threshold = self.scene.config.grid.inside_backface_fraction;
        let (seed, stream) = self.streams;
        let inside_stream = hash_pair(stream, 0x1D ^ (a as u64 + 1));
        self.candidate(a).is_some_and(|(b, _)| {
            !is_inside(self.scene, self.tracer, b, threshold, |j| Sampler::new(seed, inside_stream, j))
        })
    }

    /// The first `count` attempts that succeed (at most `256 × count` attempts), in order.
    #[must_use]
    pub fn successes(&self, count: u32) -> Vec<u32> {
        if !(self.total > 0.0) {
            return Vec::new();
        }
        first_successes(count, count.saturating_mul(256), |a| self.succeeds(a).then_some(a))
    }
}

/// Up to `count` points on the surfaces seen from inside the box `from` (rays from random
/// points in it in uniform directions), each where the ray's first hit lies inside the box
/// `accept` on a side that can be seen (a front face, or either side of a two-sided
/// material): off the surface by a small offset, with the seen side's normal. Points the
/// inside rule rejects (inside a closed two-sided solid) are skipped. At most `16 × count`
/// rays; fewer points where little surface is near (none in open air). Seeded by
/// `(seed, stream)` alone.
pub fn cell_surface_points(
    scene: &Scene,
    tracer: &Tracer,
    from: (Vec3, Vec3),
    accept: (Vec3, Vec3),
    count: u32,
    (seed, stream): (u64, u64),
) -> Vec<(Vec3, Vec3)> {
    let threshold = scene.config.grid.inside_backface_fraction;
    let mut out = Vec::new();
    for a in 0..count.saturating_mul(16) {
        if out.len() >= count as usize {
            break;
        }
        let mut s = Sampler::new(seed, stream, a);
        let o = from.0 + (from.1 - from.0) * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        let d = uniform_sphere(s.next_2d());
        let Some(h) = tracer.closest_hit(o, d, f32::INFINITY) else { continue };
        let two_sided = scene.materials[h.material as usize].two_sided;
        if !(h.position.cmpge(accept.0).all() && h.position.cmple(accept.1).all()) || (h.backface && !two_sided) {
            continue;
        }
        let n = if h.backface { -h.normal } else { h.normal };
        let b = h.position + n * tracer.surface_offset(h.position);
        let inside_stream = hash_pair(stream, 0x5F ^ (a as u64 + 1));
        if is_inside(scene, tracer, b, threshold, |j| Sampler::new(seed, inside_stream, j)) {
            continue;
        }
        out.push((b, n));
    }
    out
}

/// The first `count` successes of `attempt(0)`, `attempt(1)`, … (at most `limit` attempts),
/// in attempt order. Each attempt must depend on its index alone: blocks of them run in
/// parallel and give the same answer as one attempt after another.
pub fn first_successes<T: Send>(count: u32, limit: u32, attempt: impl Fn(u32) -> Option<T> + Sync) -> Vec<T> {
    // exactly `count` slots: a growing vector would hold up to twice that (a fit draws 24
    // surface points per active cell)
    let mut out = Vec::with_capacity(count as usize);
    let mut next = 0u32;
    while out.len() < count as usize && next < limit {
        let block = ((count as usize - out.len()) * 5 / 4).clamp(256, 1 << 16) as u32;
        let end = next.saturating_add(block).min(limit);
        let found: Vec<Option<T>> = (next..end).into_par_iter().map(&attempt).collect();
        next = end;
        out.extend(found.into_iter().flatten().take(count as usize - out.len()));
    }
    out.shrink_to_fit();
    out
}

/// Queries (B, dir, roughness) with traced references: `positions.len() × dirs_per_position`
/// of them, position-major.
#[derive(Clone, Debug, Default)]
pub struct TracedQueries {
    pub positions: Vec<Vec3>,
    pub dirs: Vec<Vec3>,
    pub dirs_per_position: usize,
    /// Perceptual roughness of each query (0 = mirror).
    pub roughness: Vec<f32>,
    /// Each query's reference: the GGX lobe of its roughness around its direction (a mirror
    /// ray at roughness 0), estimated from `spp` traced samples.
    pub reference: Vec<Vec3>,
    /// Standard error of each reference's luminance (the estimator's own noise).
    pub reference_se: Vec<f32>,
    /// The part of each reference seen straight from an emitter ([`Reference::emitted`]):
    /// what the evaluation takes out of reference and lookup alike to measure the light
    /// apart from the emitters.
    pub emitted: Vec<Vec3>,
    /// Rays traced for the references (primary, shadow and bounce).
    pub rays: u64,
}

/// Where a query set draws its random numbers, and each query's roughness: the direction
/// of query (position p, d) and sample k of its reference. Each set (validation, a cell's
/// training or check set, a roughness bucket) has its own streams, so the sets are
/// independent.
pub trait QueryStreams {
    fn direction(&self, p: usize, d: usize) -> Sampler;
    fn reference(&self, p: usize, d: usize, k: u32) -> Sampler;
    /// Perceptual roughness of query (p, d); mirror unless a set says otherwise.
    fn roughness(&self, _p: usize, _d: usize) -> f32 {
        0.0
    }
    /// The normal of the surface position p lies on: its directions are reflections off
    /// that surface, uniform over its hemisphere; `None`: uniform over the sphere.
    fn hemisphere(&self, _p: usize) -> Option<Vec3> {
        None
    }
}

/// A reference and its standard error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reference {
    pub radiance: Vec3,
    /// Standard error of the luminance of `radiance`.
    pub se: f32,
    /// The part of `radiance` that is light seen straight from B: lamps, emissive surfaces
    /// and, through next-event estimation, the sun (what a lookup can only get right by
    /// landing on the emitter's few texels).
    pub emitted: Vec3,
}

/// The reference of query (B, unit `dir`, perceptual roughness `r`): radiance arriving at B
/// through the GGX lobe the probe's mips are prefiltered with (N = V = dir, α = r²; Karis
/// 2013), `∫ L(l) D(h)(n·l) dl / ∫ D(h)(n·l) dl`. Each sample draws a half vector from
/// D(h)(n·h) and reflects it (pdf D/4 over l, weight n·l), and one sample of each light
/// next-event estimation samples. What those lights send straight at B is shared between
/// the two techniques by the balance heuristic (Veach 1997): the lobe's share and all other
/// light form the weighted mean of the lobe samples (exact for constant radiance), the
/// lights' share is divided by the lobe's exact mass ([`lobe_mass`]). A small bright lamp
/// in the lobe no longer rules the variance. At r = 0 the lobe is the mirror ray, and the
/// mean of `spp` samples along it. `sampler(k)` drives sample k (lobe direction, the
/// renderer's shading, then the light samples). The standard error adds the two parts'
/// variances (their covariance is left out).
pub fn lobe_reference(
    renderer: &Renderer,
    b: Vec3,
    dir: Vec3,
    r: f32,
    spp: u32,
    sampler: impl Fn(u32) -> Sampler,
    rays: &mut u64,
) -> Reference {
    let alpha = r * r;
    // the lobe's pdf over l at N = V = dir (0 below its horizon)
    let lobe_pdf = |l: Vec3| {
        let h = (dir + l).normalize_or_zero();
        let p = crate::sampling::ggx_d(dir.dot(h).max(0.0), alpha) * 0.25;
        if p.is_finite() { p } else { 0.0 }
    };
    // balance-heuristic weight of the technique with pdf `own` against the other's `other`
    let share = |own: f32, other: f32| if own + other > 0.0 { own / (own + other) } else { 0.0 };
    let (mut sum, mut w_sum, mut lights) = (Vec3::ZERO, 0.0f64, Vec3::ZERO);
    // the weighted lobe samples' part that came straight from an emitter
    let mut direct = Vec3::ZERO;
    // moments for the ratio estimator's variance (a = luminance of a lobe sample's weighted
    // radiance, w its weight): Σw², Σaw, Σa²; and of the light samples' luminance: Σc, Σc²
    let (mut w2, mut aw, mut a2, mut c1, mut c2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let spp = spp.max(1);
    // a mirror reference's samples all start with the ray (b, dir): traced once
    let mirror = if r > 0.0 { None } else { renderer.first_hit(b, dir, rays) };
    for k in 0..spp {
        let mut s = sampler(k);
        let (weighted, w, light, seen) = if r > 0.0 {
            let h = crate::sampling::ggx_half_vector(s.next_2d(), dir, alpha);
            let nh = dir.dot(h).max(0.0);
            let l = 2.0 * nh * h - dir;
            let nl = dir.dot(l);
            let (mut weighted, mut w, mut seen) = (Vec3::ZERO, 0.0, Vec3::ZERO);
            if nl > 0.0 {
                let (sample, emitted) = renderer.sample_parts(b, l, &mut s, rays);
                let rest = (sample.radiance - emitted.radiance).max(Vec3::ZERO);
                let lobe_share = emitted.radiance * share(lobe_pdf(l), emitted.pdf);
                weighted = (rest + lobe_share) * nl;
                seen = lobe_share * nl;
                w = nl;
            }
            // (n·l)·(D/4)·L / pdf_light, weighted pdf_light / (pdf_lobe + pdf_light)
            let mut light = Vec3::ZERO;
            renderer.light_samples(b, dir, &mut s, rays, |l, radiance, pdf| {
                let p = lobe_pdf(l);
                light += radiance * (dir.dot(l) * p / (p + pdf));
            });
            (weighted, w, crate::trace::radiance::sanitize(light), seen)
        } else {
            let (sample, emitted) = match mirror.as_ref() {
                Some(f) => renderer.sample_after(f, &mut s, rays),
                None => Default::default(),
            };
            (sample.radiance, 1.0, Vec3::ZERO, emitted.radiance.min(sample.radiance))
        };
        let (w, a, c) = (w as f64, luminance(weighted) as f64, luminance(light) as f64);
        sum += weighted;
        direct += seen;
        lights += light;
        w_sum += w;
        (w2, aw, a2, c1, c2) = (w2 + w * w, aw + a * w, a2 + a * a, c1 + c, c2 + c * c);
    }
    let n = spp as f64;
    let mass = if r > 0.0 { lobe_mass(alpha) } else { 1.0 };
    let from_lights = lights / (n * mass) as f32;
    let direct_from_lobe = if w_sum > 0.0 { direct / w_sum as f32 } else { Vec3::ZERO };
    let (from_lobe, var_lobe) = if w_sum > 0.0 {
        let mean = sum / w_sum as f32;
        let m = luminance(mean) as f64;
        // delta-method variance of Σa / Σw
        (mean, (a2 - 2.0 * m * aw + m * m * w2).max(0.0) / (w_sum * w_sum))
    } else {
        (Vec3::ZERO, 0.0)
    };
    let var_lights = (c2 - c1 * c1 / n).max(0.0) / (n * n) / (mass * mass);
    // the n/(n−1) small-sample correction
    let se = if n > 1.0 { ((var_lobe + var_lights) * n / (n - 1.0)).sqrt() } else { 0.0 };
    let radiance = crate::trace::radiance::sanitize(from_lobe + from_lights);
    let emitted = crate::trace::radiance::sanitize(direct_from_lobe + from_lights).min(radiance);
    Reference { radiance, se: se as f32, emitted }
}

impl Reference {
    /// Share of the reference's luminance seen straight from an emitter, in [0, 1] (0 for a
    /// black reference).
    #[must_use]
    pub fn emitter_share(&self) -> f32 {
        emitter_share(self.radiance, self.emitted)
    }
}

/// Share of `radiance`'s luminance that `emitted`, its part seen straight from an emitter,
/// makes up, in [0, 1] (0 for black).
#[must_use]
pub fn emitter_share(radiance: Vec3, emitted: Vec3) -> f32 {
    let share = luminance(emitted) / luminance(radiance);
    if share.is_finite() { share.clamp(0.0, 1.0) } else { 0.0 }
}

/// The mass `∫ D(h)(n·l)/4 dl` of the GGX lobe at N = V (the expected n·l of a reflected
/// half vector drawn from D(h)(n·h)), in closed form: with u uniform, n·h² =
/// (1 − u)/(1 + (α² − 1)u), and n·l = 2 n·h² − 1 is positive for u < 1/(1 + α²).
#[must_use]
pub fn lobe_mass(alpha: f32) -> f64 {
    let a2 = (alpha as f64 * alpha as f64).clamp(1e-12, 1.0);
    let b = a2 - 1.0; // in (−1, 0]
    let u = 1.0 / (1.0 + a2);
    // ∫₀ᵘ (1 − t)/(1 + b t) dt: −u/b + (1 + 1/b)·ln(1 + b u)/b, and near b = 0 (where
    // that cancels) its expansion u − u²/2 + b(u³/3 − u²/2) + O(b²)
    let integral = if b.abs() < 1e-4 {
        u - u * u / 2.0 + b * (u * u * u / 3.0 - u * u / 2.0)
    } else {
        -u / b + (1.0 + 1.0 / b) * libm::log1p(b * u) / b
    };
    (2.0 * integral - u).max(0.0)
}

/// Traces the references of `dirs_per_position` uniform directions at each position (over
/// the hemisphere of `streams.hemisphere` where it names one), sequentially: callers
/// parallelise over positions or cells.
pub fn trace_queries(
    renderer: &Renderer,
    positions: &[Vec3],
    dirs_per_position: usize,
    spp: u32,
    streams: &impl QueryStreams,
) -> TracedQueries {
    let n = positions.len() * dirs_per_position;
    let mut q = TracedQueries {
        positions: positions.to_vec(),
        dirs: Vec::with_capacity(n),
        dirs_per_position,
        roughness: Vec::with_capacity(n),
        reference: Vec::with_capacity(n),
        reference_se: Vec::with_capacity(n),
        emitted: Vec::with_capacity(n),
        rays: 0,
    };
    for (p, &b) in positions.iter().enumerate() {
        for d in 0..dirs_per_position {
            let mut dir = uniform_sphere(streams.direction(p, d).next_2d());
            if let Some(n) = streams.hemisphere(p)
                && dir.dot(n) < 0.0
            {
                dir = -dir; // the sphere folded onto the hemisphere: uniform over it
            }
            let r = streams.roughness(p, d);
            let reference = lobe_reference(renderer, b, dir, r, spp, |k| streams.reference(p, d, k), &mut q.rays);
            q.dirs.push(dir);
            q.roughness.push(r);
            q.reference.push(reference.radiance);
            q.reference_se.push(reference.se);
            q.emitted.push(reference.emitted);
        }
    }
    q
}

impl TracedQueries {
    /// Position of query `k`.
    #[inline]
    #[must_use]
    pub fn position_of(&self, k: usize) -> Vec3 {
        self.positions[k / self.dirs_per_position.max(1)]
    }

    /// Share of query `k`'s reference seen straight from an emitter ([`emitter_share`]).
    #[inline]
    #[must_use]
    pub fn emitter_share(&self, k: usize) -> f32 {
        emitter_share(self.reference[k], self.emitted[k])
    }

    /// Concatenates sets traced in parts (e.g. per position, in parallel), in order.
    #[must_use]
    pub fn concat(parts: Vec<TracedQueries>) -> TracedQueries {
        let dirs_per_position = parts.first().map_or(0, |p| p.dirs_per_position);
        let mut out = TracedQueries { dirs_per_position, ..TracedQueries::default() };
        for p in parts {
            assert_eq!(p.dirs_per_position, dirs_per_position, "parts of one set share its directions per position");
            out.positions.extend(p.positions);
            out.dirs.extend(p.dirs);
            out.roughness.extend(p.roughness);
            out.reference.extend(p.reference);
            out.reference_se.extend(p.reference_se);
            out.emitted.extend(p.emitted);
            out.rays += p.rays;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_inside_rule_is_a_strict_fraction() {
        let b = |one_sided, any, rays| Backfaces { one_sided, any, rays };
        assert!(!inside_by_backfaces(b(4, 4, 16), 0.25));
        assert!(inside_by_backfaces(b(5, 5, 16), 0.25));
        assert!(!inside_by_backfaces(b(0, 0, 0), 0.0), "no rays: not inside");
        assert!(inside_by_backfaces(b(1, 1, 1), 0.999));
        // two-sided back faces: only a closed solid's share counts
        assert!(!inside_by_backfaces(b(0, 8, 16), 0.25), "behind a two-sided panel");
        assert!(inside_by_backfaces(b(0, 15, 16), 0.25), "inside a two-sided solid");
    }
}
