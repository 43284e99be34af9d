//! The radiance model: view-independent (Lambertian) outgoing radiance seen along a ray, and
//! the distance to what the ray saw. This is what probes store and what references compare
//! against, so there is exactly one implementation.
//!
//! Model: Lambert surfaces with emission; direct light from sphere lights and the sun by
//! next-event estimation with shadow rays (one sample of each light and of the emissive triangles per shading point, soft
//! shadows come from the per-sample light positions); the sky is seen on rays that miss and
//! lights surfaces through diffuse bounce rays (cosine-sampled, `bounces` of them). Back
//! faces of one-sided surfaces are black. Sphere lights are visible to primary rays only
//! (bounce rays skip them: their energy already arrives by next-event estimation).

use super::bvh::{Tracer, light_distance};
use crate::sampling::{Sampler, cosine_hemisphere, uniform_cone};
use crate::scene::Scene;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, TAU};

/// One primary ray's answer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RaySample {
    /// Linear RGB radiance arriving at the origin along −dir.
    pub radiance: Vec3,
    /// Distance to the first thing seen (+inf on miss).
    pub distance: f32,
    /// The ray hit the back of a one-sided surface (black).
    pub backface: bool,
    /// The ray hit the back of a two-sided surface (shaded as its front).
    pub backface_two_sided: bool,
}

/// What a first ray sees, before any shading ([`Renderer::seen`]).
#[derive(Clone, Copy, Debug)]
enum Seen {
    /// A sphere light, at this distance.
    Light(f32),
    Sky,
    /// The back of a one-sided surface, at this distance.
    BackFace(f32),
    Surface(super::bvh::Hit),
}

/// What a ray meets first, before any sampling ([`Renderer::first_hit`]).
#[derive(Clone, Copy, Debug)]
pub struct FirstHit {
    origin: Vec3,
    /// The ray's unit direction.
    dir: Vec3,
    hit: Option<super::bvh::Hit>,
}

/// Radiance a ray received straight from a light next-event estimation samples, and the
/// solid-angle pdf with which [`Renderer::light_samples`] picks that direction (0: none).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Emitted {
    pub radiance: Vec3,
    pub pdf: f32,
}

/// The cone a sphere light fills seen from `origin`: its axis and the cosine of its half
/// angle (`None` inside the light).
#[inline]
fn sphere_cone(light: &crate::scene::SphereLight, origin: Vec3) -> Option<(Vec3, f32)> {
    let to_c = light.position - origin;
    let d2 = to_c.length_squared();
    let r2 = light.radius * light.radius;
    if d2 <= r2 {
        return None;
    }
    let dist = d2.sqrt();
    Some((to_c / dist, (1.0 - r2 / d2).max(0.0).sqrt()))
}

/// Scene + tracer: everything needed to answer radiance queries.
pub struct Renderer<'a> {
    pub scene: &'a Scene,
    pub tracer: &'a Tracer,
    pub bounces: u32,
    /// Emissive triangles sampled by next-event estimation, with their cumulative areas.
    emitters: Vec<u32>,
    emitter_cdf: Vec<f32>,
}

impl<'a> Renderer<'a> {
    pub fn new(scene: &'a Scene, tracer: &'a Tracer) -> Self {
        let tris = &scene.triangles;
        let mut emitters = Vec::new();
        let mut emitter_cdf = Vec::new();
        let mut total = 0.0f32;
        for k in 0..tris.len() {
            if scene.materials[tris.material[k] as usize].emission.max_element() > 0.0 {
                total += 0.5 * (tris.v1[k] - tris.v0[k]).cross(tris.v2[k] - tris.v0[k]).length();
                emitters.push(k as u32);
                emitter_cdf.push(total);
            }
        }
        Renderer { scene, tracer, bounces: scene.config.bounces, emitters, emitter_cdf }
    }

    /// A point on the emissive triangles, picked by area (uniform on the picked triangle):
    /// the triangle, the point and the emitters' total area (the area pdf is 1 / total).
    fn emitter_point(&self, sampler: &mut Sampler) -> Option<(usize, Vec3, f32)> {
        let &total = self.emitter_cdf.last()?;
        let u = sampler.next_2d();
        let pick = sampler.next_1d() * total;
        let slot = self.emitter_cdf.partition_point(|&c| c <= pick).min(self.emitters.len() - 1);
        let k = self.emitters[slot] as usize;
        let tris = &self.scene.triangles;
        let (v0, v1, v2) = (tris.v0[k], tris.v1[k], tris.v2[k]);
        let su = u.x.sqrt();
        let (b0, b1) = (1.0 - su, u.y * su);
        Some((k, v0 * b0 + v1 * b1 + v2 * (1.0 - b0 - b1), total))
    }

    /// Cosine at emissive triangle `k` towards unit `l` (from the shading point to the
    /// emitter) on its emitting side: ≤ 0 where it emits nothing that way.
    fn emitter_cos(&self, k: usize, l: Vec3) -> f32 {
        let tris = &self.scene.triangles;
        let (v0, v1, v2) = (tris.v0[k], tris.v1[k], tris.v2[k]);
        let nl = (v1 - v0).cross(v2 - v0).normalize_or_zero();
        if self.scene.materials[tris.material[k] as usize].two_sided { nl.dot(l).abs() } else { -nl.dot(l) }
    }

    /// Next-event estimate from the emissive triangles (picked by area, uniform point on the
    /// picked triangle): radiance-weighted cosine term, divided by π by the caller's albedo/π.
    fn emitter_irradiance(&self, origin: Vec3, n: Vec3, sampler: &mut Sampler, rays: &mut u64) -> Vec3 {
        let Some((k, p, total)) = self.emitter_point(sampler) else {
            return Vec3::ZERO;
        };
        let to_l = p - origin;
        let d2 = to_l.length_squared();
        if !(d2 > 0.0) {
            return Vec3::ZERO;
        }
        let d = d2.sqrt();
        let l = to_l / d;
        let cos_s = n.dot(l);
        let mat = self.scene.materials[self.scene.triangles.material[k] as usize];
        let cos_l = self.emitter_cos(k, l);
        if cos_s <= 0.0 || cos_l <= 0.0 {
            return Vec3::ZERO;
        }
        *rays += 1;
        if self.tracer.occluded(origin, l, d * (1.0 - 1e-4)) {
            return Vec3::ZERO;
        }
        // Area sampling: pdf_ω = d² / (cos_l · A_total).
        mat.emission * (cos_s * cos_l * total / d2)
    }

    /// One sample of each light next-event estimation samples (each sphere light, then the
    /// emissive triangles), seen from `origin`: `visit(l, radiance, pdf)` for each that
    /// reaches it unoccluded with `facing · l > 0`, with the solid-angle pdf of its
    /// technique. What multiple importance sampling pairs with a lobe's own samples.
    pub fn light_samples(
        &self,
        origin: Vec3,
        facing: Vec3,
        sampler: &mut Sampler,
        rays: &mut u64,
        mut visit: impl FnMut(Vec3, Vec3, f32),
    ) {
        for light in &self.scene.lights.sphere_lights {
            if let Some((l, falloff, solid_angle)) = self.sphere_light_sample(light, origin, facing, sampler, rays) {
                visit(l, light.radiance * falloff, 1.0 / solid_angle);
            }
        }
        let Some((k, p, total)) = self.emitter_point(sampler) else { return };
        let to_l = p - origin;
        let d2 = to_l.length_squared();
        if !(d2 > 0.0) {
            return;
        }
        let d = d2.sqrt();
        let l = to_l / d;
        let cos_l = self.emitter_cos(k, l);
        if facing.dot(l) <= 0.0 || cos_l <= 0.0 {
            return;
        }
        *rays += 1;
        if !self.tracer.occluded(origin, l, d * (1.0 - 1e-4)) {
            let mat = self.scene.materials[self.scene.triangles.material[k] as usize];
            visit(l, mat.emission, d2 / (cos_l * total));
        }
    }

    /// Radiance and distance along one ray (unit `dir`). `sampler` drives light and bounce
    /// sampling; `rays` counts every ray traced (primary, shadow and bounce).
    pub fn sample(&self, origin: Vec3, dir: Vec3, sampler: &mut Sampler, rays: &mut u64) -> RaySample {
        self.sample_parts(origin, dir, sampler, rays).0
    }

    /// [`Renderer::sample`], and the part of its radiance emitted by what the ray hit first
    /// when that is a light next-event estimation samples (a sphere light, an emissive
    /// triangle), with the solid-angle pdf [`Renderer::light_samples`] draws it with.
    pub fn sample_parts(&self, origin: Vec3, dir: Vec3, sampler: &mut Sampler, rays: &mut u64) -> (RaySample, Emitted) {
        match self.first_hit(origin, dir, rays) {
            Some(first) => self.sample_after(&first, sampler, rays),
            None => {
                (RaySample { radiance: Vec3::ZERO, distance: f32::INFINITY, ..Default::default() }, Emitted::default())
            }
        }
    }

    /// The first part of [`Renderer::sample_parts`], which draws nothing from a sampler:
    /// what the ray from `origin` along `dir` meets first (`None`: no ray, a non-finite
    /// origin or direction). Samples that start with the same ray (a mirror reference's)
    /// trace it once and continue each with [`Renderer::sample_after`]: the same values as
    /// tracing it for each.
    pub fn first_hit(&self, origin: Vec3, dir: Vec3, rays: &mut u64) -> Option<FirstHit> {
        if !origin.is_finite() || !dir.is_finite() || dir.length_squared() == 0.0 {
            return None;
        }
        let dir = dir.normalize();
        *rays += 1;
        Some(FirstHit { origin, dir, hit: self.tracer.closest_hit(origin, dir, f32::INFINITY) })
    }

    /// [`Renderer::sample_parts`] from its first hit on: the light or sky the ray sees, or
    /// the shading of the surface it hit (drawing from `sampler`).
    pub fn sample_after(&self, first: &FirstHit, sampler: &mut Sampler, rays: &mut u64) -> (RaySample, Emitted) {
        let none = Emitted::default();
        let (seen, emitted) = self.seen(first);
        let hit = match seen {
            Seen::Light(t) => {
                let sample = RaySample { radiance: emitted.radiance, distance: t, ..Default::default() };
                return (sample, emitted);
            }
            Seen::Sky => {
                let radiance = self.scene.sky.radiance(first.dir);
                return (RaySample { radiance, distance: f32::INFINITY, ..Default::default() }, none);
            }
            Seen::BackFace(t) => {
                let sample = RaySample { radiance: Vec3::ZERO, distance: t, backface: true, backface_two_sided: false };
                return (sample, none);
            }
            Seen::Surface(hit) => hit,
        };
        let mat = self.scene.materials[hit.material as usize];
        let n = if hit.backface { -hit.normal } else { hit.normal };
        let radiance = mat.emission + self.shade(hit.position, n, self.albedo(&hit), self.bounces, sampler, rays);
        let sample = RaySample {
            radiance: sanitize(radiance),
            distance: hit.t,
            backface: false,
            backface_two_sided: hit.backface,
        };
        (sample, emitted)
    }

    /// What the first ray sees before any shading, and the radiance it receives straight
    /// from a light next-event estimation samples (with that light technique's pdf):
    /// sphere lights in front of the geometry (primary rays see them), the sky, a one-sided
    /// surface's back (black), or a surface, whose emission counts when it is an emissive
    /// triangle.
    fn seen(&self, first: &FirstHit) -> (Seen, Emitted) {
        let FirstHit { origin, dir, hit } = *first;
        let mut t_light = hit.map_or(f32::INFINITY, |h| h.t);
        let mut light_seen = None;
        for l in &self.scene.lights.sphere_lights {
            let t = light_distance(l, origin, dir, t_light);
            if t < t_light {
                t_light = t;
                light_seen = Some(l);
            }
        }
        if let Some(l) = light_seen {
            let radiance = l.radiance * l.falloff(-dir);
            let pdf = sphere_cone(l, origin).map_or(0.0, |(_, cos_max)| 1.0 / (TAU * (1.0 - cos_max)));
            return (Seen::Light(t_light), Emitted { radiance, pdf });
        }
        let Some(hit) = hit else {
            return (Seen::Sky, Emitted::default());
        };
        let mat = self.scene.materials[hit.material as usize];
        if hit.backface && !mat.two_sided {
            return (Seen::BackFace(hit.t), Emitted::default());
        }
        let emitted = if !hit.sphere && mat.emission.max_element() > 0.0 && !self.emitters.is_empty() {
            let cos_l = self.emitter_cos(hit.prim as usize, dir);
            let total = self.emitter_cdf[self.emitter_cdf.len() - 1];
            let pdf = if cos_l > 0.0 { hit.t * hit.t / (cos_l * total) } else { 0.0 };
            Emitted { radiance: mat.emission, pdf: if pdf.is_finite() { pdf } else { 0.0 } }
        } else {
            Emitted::default()
        };
        (Seen::Surface(hit), emitted)
    }

    /// Whether anything in the scene emits light that rays can see straight: a sphere
    /// light or an emissive triangle (what [`Renderer::emitted_along`] reports).
    #[must_use]
    pub fn has_emitters(&self) -> bool {
        !self.scene.lights.sphere_lights.is_empty() || !self.emitters.is_empty()
    }

    /// The radiance a ray receives straight from an emitter next-event estimation samples
    /// (a sphere light, an emissive triangle): the `Emitted` part of
    /// [`Renderer::sample_after`], with no shading and nothing drawn from a sampler.
    #[must_use]
    pub fn emitted_along(&self, first: &FirstHit) -> Vec3 {
        self.seen(first).1.radiance
    }

    /// Albedo at a hit: the material's, times its base-colour texture at the hit's texture
    /// coordinates (interpolated barycentrically) when it has one.
    #[inline]
    fn albedo(&self, hit: &super::bvh::Hit) -> Vec3 {
        let mat = &self.scene.materials[hit.material as usize];
        let (Some(t), false) = (mat.texture, hit.sphere) else { return mat.albedo };
        let (Some(tex), Some(uv)) =
            (self.scene.textures.get(t as usize), self.scene.triangles.uv.get(hit.prim as usize))
        else {
            return mat.albedo;
        };
        let tris = &self.scene.triangles;
        let k = hit.prim as usize;
        let (a, b, c) = (tris.v0[k], tris.v1[k], tris.v2[k]);
        let n = (b - a).cross(c - a);
        let n2 = n.length_squared();
        if !(n2 > 0.0 && n2.is_finite()) {
            return mat.albedo;
        }
        let p = hit.position;
        let wb = (p - a).cross(c - a).dot(n) / n2;
        let wc = (b - a).cross(p - a).dot(n) / n2;
        let at = uv[0] * (1.0 - wb - wc) + uv[1] * wb + uv[2] * wc;
        (mat.albedo * tex.sample(at)).clamp(Vec3::ZERO, Vec3::ONE)
    }

    /// Outgoing Lambertian radiance (without emission) at `p` with front normal `n`.
    fn shade(&self, p: Vec3, n: Vec3, albedo: Vec3, bounces_left: u32, sampler: &mut Sampler, rays: &mut u64) -> Vec3 {
        let origin = p + n * self.tracer.surface_offset(p);
        let irradiance_over_pi = self.direct_over_pi(origin, n, true, sampler, rays);
        let mut out = albedo * irradiance_over_pi;
        if bounces_left > 0 {
            let d = cosine_hemisphere(sampler.next_2d(), n);
            *rays += 1;
            // Cosine-weighted sampling: the estimator of ∫ albedo/π L cos dω is albedo · L.
            let hit = self.tracer.closest_hit_as(super::streams::Kind::Bounce, origin, d, f32::INFINITY);
            out += albedo * self.bounce_radiance(hit, d, bounces_left - 1, sampler, rays);
        }
        out
    }

    /// Direct irradiance over π at `origin` around front normal `n` by next-event estimation,
    /// one sample of each light: the sun (when `sun`), each sphere light, the emissive
    /// triangles.
    fn direct_over_pi(&self, origin: Vec3, n: Vec3, sun: bool, sampler: &mut Sampler, rays: &mut u64) -> Vec3 {
        let mut irradiance_over_pi = Vec3::ZERO;
        if let (Some(sun), true) = (self.scene.lights.sun, sun) {
            let l = uniform_cone(sampler.next_2d(), sun.direction, sun.cos_angular_radius);
            let cos = n.dot(l);
            if cos > 0.0 {
                *rays += 1;
                if !self.tracer.occluded(origin, l, f32::INFINITY) {
                    // Uniform cone sampling of a disc of radiance E/Ω: estimator E·cos.
                    irradiance_over_pi += sun.irradiance * cos * FRAC_1_PI;
                }
            }
        }
        for light in &self.scene.lights.sphere_lights {
            if let Some((l, falloff, solid_angle)) = self.sphere_light_sample(light, origin, n, sampler, rays) {
                irradiance_over_pi += light.radiance * (n.dot(l) * solid_angle * FRAC_1_PI * falloff);
            }
        }
        irradiance_over_pi + self.emitter_irradiance(origin, n, sampler, rays) * FRAC_1_PI
    }

    /// One direction sampled uniformly in the cone `light` fills seen from `origin` (no
    /// sample from inside the light), kept when `facing · l > 0`, the light emits that way and
    /// the shadow ray reaches it: the direction, the light's falloff along it and the cone's
    /// solid angle (1 / the technique's pdf).
    fn sphere_light_sample(
        &self,
        light: &crate::scene::SphereLight,
        origin: Vec3,
        facing: Vec3,
        sampler: &mut Sampler,
        rays: &mut u64,
    ) -> Option<(Vec3, f32, f32)> {
        let (axis, cos_max) = sphere_cone(light, origin)?;
        let l = uniform_cone(sampler.next_2d(), axis, cos_max);
        if facing.dot(l) <= 0.0 {
            return None;
        }
        let t_s = light_distance(light, origin, l, f32::INFINITY);
        let falloff = light.falloff(-l);
        if !t_s.is_finite() || falloff <= 0.0 {
            return None;
        }
        *rays += 1;
        (!self.tracer.occluded(origin, l, t_s * (1.0 - 1e-4))).then_some((l, falloff, TAU * (1.0 - cos_max)))
    }

    /// Radiance a bounce ray along `d` brings back from `hit` (`bounces` more after it):
    /// the sky on a miss, black from the back of a one-sided surface, otherwise the hit's
    /// shading plus the emission of emissive spheres (emissive triangles and sphere lights
    /// arrive by next-event estimation instead).
    fn bounce_radiance(
        &self,
        hit: Option<super::bvh::Hit>,
        d: Vec3,
        bounces: u32,
        sampler: &mut Sampler,
        rays: &mut u64,
    ) -> Vec3 {
        match hit {
            None => self.scene.sky.radiance(d),
            Some(h) => {
                let m = self.scene.materials[h.material as usize];
                if h.backface && !m.two_sided {
                    Vec3::ZERO
                } else {
                    let hn = if h.backface { -h.normal } else { h.normal };
                    let emission = if h.sphere { m.emission } else { Vec3::ZERO };
                    emission + self.shade(h.position, hn, self.albedo(&h), bounces, sampler, rays)
                }
            }
        }
    }

    /// One sample of the irradiance at `p` around unit normal `n` as the light probes carry
    /// it (sky, emitters, bounced light; not the sun's disc, which rays never see), for the
    /// cosine-distributed direction `d`: the sphere lights and emissive triangles by
    /// next-event estimation, everything else by the ray along `d` (π · its radiance; a
    /// sphere light in its way blocks it, as it blocks a primary ray). Its mean over
    /// cosine-distributed `d` is `E = ∫ L cos dω` of what primary rays see, with far less
    /// variance than π · L alone where a small bright emitter is in view.
    pub fn irradiance_sample(&self, p: Vec3, n: Vec3, d: Vec3, sampler: &mut Sampler, rays: &mut u64) -> Vec3 {
        if !(p.is_finite() && n.is_finite() && d.is_finite()) {
            return Vec3::ZERO;
        }
        let direct = self.direct_over_pi(p, n, false, sampler, rays) * std::f32::consts::PI;
        *rays += 1;
        let hit = self.tracer.closest_hit(p, d, f32::INFINITY);
        let t_geom = hit.map_or(f32::INFINITY, |h| h.t);
        let blocked = self.scene.lights.sphere_lights.iter().any(|l| light_distance(l, p, d, t_geom) < t_geom);
        let indirect = if blocked { Vec3::ZERO } else { self.bounce_radiance(hit, d, self.bounces, sampler, rays) };
        sanitize(direct + indirect * std::f32::consts::PI)
    }
}

/// Replaces NaN/Inf components by 0 (radiance is never allowed to carry them out).
#[inline]
pub fn sanitize(v: Vec3) -> Vec3 {
    Vec3::new(finite_or_zero(v.x), finite_or_zero(v.y), finite_or_zero(v.z))
}

#[inline]
fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() { x } else { 0.0 }
}
