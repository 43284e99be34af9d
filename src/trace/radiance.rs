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

use super::bvh::{Tracer, intersect_sphere};
use crate::sampling::{Sampler, cosine_hemisphere, uniform_cone};
use crate::scene::Scene;
use glam::{Vec3, Vec3A};
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

    /// Next-event estimate from the emissive triangles (picked by area, uniform point on the
    /// picked triangle): radiance-weighted cosine term, divided by π by the caller's albedo/π.
    fn emitter_irradiance(&self, origin: Vec3, n: Vec3, sampler: &mut Sampler, rays: &mut u64) -> Vec3 {
        let Some(&total) = self.emitter_cdf.last() else {
            return Vec3::ZERO;
        };
        let u = sampler.next_2d();
        let pick = sampler.next_1d() * total;
        let slot = self.emitter_cdf.partition_point(|&c| c <= pick).min(self.emitters.len() - 1);
        let k = self.emitters[slot] as usize;
        let tris = &self.scene.triangles;
        let (v0, v1, v2) = (tris.v0[k], tris.v1[k], tris.v2[k]);
        let su = u.x.sqrt();
        let (b0, b1) = (1.0 - su, u.y * su);
        let p = v0 * b0 + v1 * b1 + v2 * (1.0 - b0 - b1);
        let to_l = p - origin;
        let d2 = to_l.length_squared();
        if !(d2 > 0.0) {
            return Vec3::ZERO;
        }
        let d = d2.sqrt();
        let l = to_l / d;
        let cos_s = n.dot(l);
        let mat = self.scene.materials[tris.material[k] as usize];
        let nl = (v1 - v0).cross(v2 - v0).normalize_or_zero();
        let cos_l = if mat.two_sided { nl.dot(l).abs() } else { -nl.dot(l) };
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

    /// Radiance and distance along one ray (unit `dir`). `sampler` drives light and bounce
    /// sampling; `rays` counts every ray traced (primary, shadow and bounce).
    pub fn sample(&self, origin: Vec3, dir: Vec3, sampler: &mut Sampler, rays: &mut u64) -> RaySample {
        if !origin.is_finite() || !dir.is_finite() || dir.length_squared() == 0.0 {
            return RaySample { radiance: Vec3::ZERO, distance: f32::INFINITY, ..Default::default() };
        }
        let dir = dir.normalize();
        *rays += 1;
        let hit = self.tracer.closest_hit(origin, dir, f32::INFINITY);
        let t_geom = hit.map_or(f32::INFINITY, |h| h.t);
        // Sphere lights are seen by primary rays when in front of the geometry.
        let mut t_light = t_geom;
        let mut light_radiance = None;
        for l in &self.scene.lights.sphere_lights {
            let t = intersect_sphere(
                Vec3A::from(origin),
                Vec3A::from(dir),
                Vec3A::from(l.position),
                l.radius,
                0.0,
                t_light,
            );
            if t < t_light {
                t_light = t;
                light_radiance = Some(l.radiance * l.falloff(-dir));
            }
        }
        if let Some(radiance) = light_radiance {
            return RaySample { radiance, distance: t_light, ..Default::default() };
        }
        let Some(hit) = hit else {
            return RaySample { radiance: self.scene.sky.radiance(dir), distance: f32::INFINITY, ..Default::default() };
        };
        let mat = self.scene.materials[hit.material as usize];
        if hit.backface && !mat.two_sided {
            return RaySample { radiance: Vec3::ZERO, distance: hit.t, backface: true, backface_two_sided: false };
        }
        let n = if hit.backface { -hit.normal } else { hit.normal };
        let radiance = mat.emission + self.shade(hit.position, n, self.albedo(&hit), self.bounces, sampler, rays);
        RaySample { radiance: sanitize(radiance), distance: hit.t, backface: false, backface_two_sided: hit.backface }
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
        let mut irradiance_over_pi = Vec3::ZERO;
        if let Some(sun) = self.scene.lights.sun {
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
            let to_c = light.position - origin;
            let d2 = to_c.length_squared();
            let r2 = light.radius * light.radius;
            if d2 <= r2 {
                continue; // shading point inside the light
            }
            let dist = d2.sqrt();
            let axis = to_c / dist;
            let cos_max = (1.0 - r2 / d2).max(0.0).sqrt();
            let u = sampler.next_2d();
            let l = uniform_cone(u, axis, cos_max);
            let cos = n.dot(l);
            if cos <= 0.0 {
                continue;
            }
            let t_s = intersect_sphere(
                Vec3A::from(origin),
                Vec3A::from(l),
                Vec3A::from(light.position),
                light.radius,
                0.0,
                f32::INFINITY,
            );
            if !t_s.is_finite() {
                continue;
            }
            let falloff = light.falloff(-l);
            if falloff <= 0.0 {
                continue;
            }
            *rays += 1;
            if !self.tracer.occluded(origin, l, t_s * (1.0 - 1e-4)) {
                let solid_angle = TAU * (1.0 - cos_max);
                irradiance_over_pi += light.radiance * (cos * solid_angle * FRAC_1_PI * falloff);
            }
        }
        irradiance_over_pi += self.emitter_irradiance(origin, n, sampler, rays) * FRAC_1_PI;
        let mut out = albedo * irradiance_over_pi;
        if bounces_left > 0 {
            let d = cosine_hemisphere(sampler.next_2d(), n);
            *rays += 1;
            // Cosine-weighted sampling: the estimator of ∫ albedo/π L cos dω is albedo · L.
            let incoming = match self.tracer.closest_hit(origin, d, f32::INFINITY) {
                None => self.scene.sky.radiance(d),
                Some(h) => {
                    let m = self.scene.materials[h.material as usize];
                    if h.backface && !m.two_sided {
                        Vec3::ZERO
                    } else {
                        let hn = if h.backface { -h.normal } else { h.normal };
                        // Emissive triangles already arrived by next-event estimation.
                        let emission = if h.sphere { m.emission } else { Vec3::ZERO };
                        emission + self.shade(h.position, hn, self.albedo(&h), bounces_left - 1, sampler, rays)
                    }
                }
            };
            out += albedo * incoming;
        }
        out
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
