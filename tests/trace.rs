//! The tracer against closed forms: a sphere seen from its centre, a box room, a furnace,
//! watertightness in a closed tessellated room, scale invariance.

mod common;
use common::*;
use glam::Vec3;
use warpfit::sampling::{Sampler, uniform_sphere};
use warpfit::scene::Scene;
use warpfit::trace::{NodeTest, Renderer, Tracer, coherent_order, trace_batch};

fn dirs(n: u32, seed: u64) -> Vec<Vec3> {
    (0..n).map(|k| uniform_sphere(Sampler::new(seed, 0, k).next_2d())).collect()
}

#[test]
fn sphere_from_centre_hits_at_radius() {
    let scene = load("sphere");
    let tracer = Tracer::new(&scene);
    let c = Vec3::new(0.0, 1.0, 0.0);
    for d in dirs(20_000, 3) {
        let h = tracer.closest_hit(c, d, f32::INFINITY).expect("closed sphere: every ray hits");
        assert!((h.t - 2.0).abs() / 2.0 < 1e-5, "t = {}", h.t);
        assert!(!h.backface, "inward sphere is seen from its front");
        assert!((h.normal + d).length() < 1e-4, "normal faces the centre");
    }
}

/// Exact distance from `p` (inside) to the walls of the box [lo, hi] along unit `d`.
fn box_exit(p: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let mut t = f32::INFINITY;
    for a in 0..3 {
        if d[a] > 0.0 {
            t = t.min((hi[a] - p[a]) / d[a]);
        } else if d[a] < 0.0 {
            t = t.min((lo[a] - p[a]) / d[a]);
        }
    }
    t
}

#[test]
fn box_room_distances_match_closed_form() {
    let scene = parse("[[geometry]]\ntype = \"room\"\nmin = [-1.0, 0.0, -2.0]\nmax = [3.0, 2.5, 1.0]\n").unwrap();
    let tracer = Tracer::new(&scene);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(3.0, 2.5, 1.0));
    for (k, d) in dirs(20_000, 5).into_iter().enumerate() {
        let f = Vec3::new((k as f32 * 0.618).fract(), (k as f32 * 0.754).fract(), (k as f32 * 0.569).fract());
        let p = lo + (hi - lo) * (0.05 + 0.9 * f);
        let h = tracer.closest_hit(p, d, f32::INFINITY).expect("closed room");
        let want = box_exit(p, d, lo, hi);
        assert!((h.t - want).abs() <= 1e-5 * want.max(1e-3) + 2e-6, "p {p} d {d}: {} vs {want}", h.t);
        assert!(!h.backface);
    }
}

#[test]
fn occlusion_agrees_with_closest_hit() {
    let scene = load("torture");
    let tracer = Tracer::new(&scene);
    let p = Vec3::new(0.35, 1.7, -2.6);
    for d in dirs(5_000, 9) {
        match tracer.closest_hit(p, d, f32::INFINITY) {
            Some(h) => {
                assert!(tracer.occluded(p, d, h.t * 1.001));
                assert!(!tracer.occluded(p, d, h.t * 0.999));
            }
            None => assert!(!tracer.occluded(p, d, f32::INFINITY)),
        }
    }
}

/// A room whose faces are tessellated into n×n quads, written as OBJ. Returns the
/// tessellation's vertices, edge midpoints and quad centres: the adversarial ray targets.
fn tessellated_room_obj(n: usize, path: &std::path::Path) -> Vec<Vec3> {
    let mut s = String::new();
    let mut targets = Vec::new();
    let mut vcount = 0;
    let (lo, hi) = (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.3, 0.7, 1.9));
    // each face: origin, u axis, v axis (u × v points into the room)
    let faces = [
        (Vec3::new(lo.x, lo.y, lo.z), Vec3::Y, Vec3::Z),
        (Vec3::new(hi.x, lo.y, lo.z), Vec3::Z, Vec3::Y),
        (Vec3::new(lo.x, lo.y, lo.z), Vec3::Z, Vec3::X),
        (Vec3::new(lo.x, hi.y, lo.z), Vec3::X, Vec3::Z),
        (Vec3::new(lo.x, lo.y, lo.z), Vec3::X, Vec3::Y),
        (Vec3::new(lo.x, lo.y, hi.z), Vec3::Y, Vec3::X),
    ];
    let size = hi - lo;
    for (o, u, v) in faces {
        let (su, sv) = (u * size.dot(u), v * size.dot(v));
        let at = |a: f32, b: f32| o + su * (a / n as f32) + sv * (b / n as f32);
        let base = vcount;
        for j in 0..=n {
            for i in 0..=n {
                let p = at(i as f32, j as f32);
                targets.extend([p, at(i as f32 + 0.5, j as f32), at(i as f32 + 0.5, j as f32 + 0.5)]);
                s += &format!("v {} {} {}\n", p.x, p.y, p.z);
                vcount += 1;
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = base + j * (n + 1) + i + 1;
                s += &format!("f {} {} {} {}\n", a, a + 1, a + n + 2, a + n + 1);
            }
        }
    }
    std::fs::write(path, s).unwrap();
    targets
}

/// Rays aimed exactly at shared vertices and edges (including the room's creases) from
/// many interior points: none may escape. The bare obvhs path escapes on these very rays,
/// so this test catches a regression to it.
#[test]
fn closed_tessellated_room_is_watertight() {
    let dir = tmp_dir("watertight");
    let obj = dir.join("room.obj");
    let targets = tessellated_room_obj(48, &obj);
    let text = format!("{HEADER}\n[[geometry]]\ntype = \"obj\"\npath = \"room.obj\"\n");
    let scene = Scene::parse(&text, &dir.join("room.toml")).unwrap();
    assert_eq!(scene.triangles.len(), 6 * 48 * 48 * 2);
    let tracer = Tracer::new(&scene);
    let tris = tracer.normalised_triangles();
    let (mut escaped, mut bare_escaped, mut total) = (0, 0, 0);
    for (k, target) in targets.iter().enumerate() {
        for q in 0..4 {
            let p = Vec3::new(
                ((k * 3 + q) % 7) as f32 * 0.173 - 0.5,
                ((k + q) % 5) as f32 * 0.11 - 0.3,
                ((k + 2 * q) % 11) as f32 * 0.09 - 0.4,
            );
            let d = (*target - p).normalize();
            total += 1;
            escaped += tracer.closest_hit(p, d, f32::INFINITY).is_none() as u32;
            bare_escaped += !tracer.bare_closest_t(&tris, tracer.to_normalised(p), d.into()).is_finite() as u32;
        }
    }
    assert_eq!(escaped, 0, "{escaped} of {total} rays escaped a closed room");
    assert!(bare_escaped > 0, "the adversarial rays no longer stress the intersection test");
}

#[test]
fn furnace_sphere_radiance_is_closed_form() {
    // Inward emissive sphere, albedo a, emission E, no lights: L = E (1 + a + … + a^bounces).
    for bounces in [0u32, 1, 2] {
        let scene = Scene::parse(&format!(
            "bounces = {bounces}\n{HEADER}\n[[geometry]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 3.0\ninward = true\nmaterial = {{ albedo = [0.5, 0.5, 0.5], emission = [2.0, 1.0, 0.5] }}\n"
        ), &fixture("furnace.toml"))
        .unwrap();
        let tracer = Tracer::new(&scene);
        let r = Renderer::new(&scene, &tracer);
        let d = dirs(512, 1);
        let o = vec![Vec3::new(0.3, 1.2, -0.4); d.len()];
        let (samples, _) = trace_batch(&r, &o, &d, 1, 0, 2);
        let gain: f32 = (0..=bounces).map(|k| 0.5f32.powi(k as i32)).sum();
        for s in samples {
            let want = Vec3::new(2.0, 1.0, 0.5) * gain;
            assert!((s.radiance - want).length() < 1e-5 * want.length(), "bounces {bounces}: {} vs {want}", s.radiance);
        }
    }
}

#[test]
fn scaled_scenes_give_scaled_distances() {
    let base = load("torture");
    let p = Vec3::from_array(base.config.probe.position);
    let t0 = Tracer::new(&base);
    let ref_t: Vec<Option<f32>> =
        dirs(4_000, 13).iter().map(|&d| t0.closest_hit(p, d, f32::INFINITY).map(|h| h.t)).collect();
    for factor in [1e-4f32, 1e4] {
        let s = base.scaled(factor);
        let t = Tracer::new(&s);
        let mut mismatched = 0;
        for (d, want) in dirs(4_000, 13).iter().zip(&ref_t) {
            let got = t.closest_hit(p * factor, *d, f32::INFINITY).map(|h| h.t / factor);
            match (got, want) {
                (Some(g), Some(w)) => {
                    if (g - w).abs() > 1e-4 * w {
                        mismatched += 1;
                    }
                }
                (None, None) => {}
                _ => mismatched += 1,
            }
        }
        // Rays grazing an edge may legitimately flip; nothing else may change.
        assert!(mismatched <= 4, "scale {factor}: {mismatched} of 4000 rays differ");
    }
}

#[test]
fn degenerate_queries_never_produce_nan() {
    let scene = load("torture");
    let tracer = Tracer::new(&scene);
    let r = Renderer::new(&scene, &tracer);
    let mut rays = 0;
    for (o, d) in [
        (Vec3::NAN, Vec3::X),
        (Vec3::ZERO, Vec3::ZERO),
        (Vec3::ZERO, Vec3::INFINITY),
        (Vec3::splat(1e30), Vec3::X),
        (Vec3::new(0.0, 1e-7, 0.0), Vec3::new(1.0, -1e-9, 0.0).normalize()), // grazing the floor
    ] {
        let s = r.sample(o, d, &mut Sampler::new(1, 0, 0), &mut rays);
        assert!(s.radiance.is_finite(), "{o} {d}");
        assert!(!s.distance.is_nan(), "{o} {d}");
    }
}

/// Closest hit of the ray over every triangle and sphere of the scene, one by one, in f64
/// (Möller–Trumbore; the sphere's nearer positive root). Also the second-nearest hit, so
/// rays that graze an edge or pass between two nearly equal hits can be told apart.
fn brute_force(scene: &Scene, o: Vec3, d: Vec3) -> (f64, f64) {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let mut best = [f64::INFINITY; 2];
    let mut push = |t: f64| {
        if t < best[0] {
            best = [t, best[0]];
        } else if t < best[1] {
            best[1] = t;
        }
    };
    let tris = &scene.triangles;
    for k in 0..tris.len() {
        let (v0, v1, v2) = (tris.v0[k].as_dvec3(), tris.v1[k].as_dvec3(), tris.v2[k].as_dvec3());
        let (e1, e2) = (v1 - v0, v2 - v0);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-300 {
            continue;
        }
        let s = o - v0;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            push(t);
        }
    }
    for (c, r) in scene.spheres.center.iter().zip(&scene.spheres.radius) {
        let f = o - c.as_dvec3();
        let b = f.dot(d);
        let disc = b * b - (f.length_squared() - (*r as f64).powi(2));
        if disc >= 0.0 {
            for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
                if t > 0.0 {
                    push(t);
                }
            }
        }
    }
    (best[0], best[1])
}

#[test]
fn the_bvh_finds_what_a_scan_of_every_primitive_finds() {
    // Random rays from inside the torture hall and from outside it, against a linear scan of
    // every triangle and sphere. Rays whose two nearest hits lie within 1e-4 of each other
    // (an edge shared by two triangles, a corner) are only checked for the distance.
    let scene = load("torture");
    let tracer = Tracer::new(&scene);
    let (lo, hi) = scene.bounds();
    let mut checked = 0;
    for k in 0..3000u32 {
        let mut s = Sampler::new(41, 7, k);
        let u = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        let o = if k % 4 == 0 { lo - (hi - lo) * 0.5 + (hi - lo) * 2.0 * u } else { lo + (hi - lo) * u };
        let d = uniform_sphere(s.next_2d());
        let (t, second) = brute_force(&scene, o, d);
        let got = tracer.closest_hit(o, d, f32::INFINITY).map_or(f64::INFINITY, |h| h.t as f64);
        if t.is_infinite() {
            assert!(got.is_infinite(), "ray {k} from {o} along {d}: the scan finds nothing, the BVH {got}");
            continue;
        }
        let tol = 1e-4 * t.max(1.0);
        if second - t < tol {
            assert!((got - t).abs() < tol, "ray {k}: BVH {got}, scan {t}");
            continue;
        }
        assert!((got - t).abs() < tol, "ray {k} from {o} along {d}: BVH {got}, scan {t} (next {second})");
        checked += 1;
    }
    assert!(checked > 2000, "only {checked} unambiguous rays");
}

/// The tracer walks obvhs's CWBVH itself (nearest child first), with a node test chosen for
/// the CPU at run time. Whichever test runs, it must find what obvhs's own traversal finds,
/// bit for bit: the same distance, and the same leaf slot (so the same primitive, normal
/// and material) unless primitives tie at that distance (coplanar faces, a shared edge):
/// then obvhs's pick depends on its visiting order and the tracer's is the one facing the
/// ray, then the lowest slot, whatever the order. For closest hit and occlusion, on rays from inside and
/// outside, axis rays and rays that end early.
#[test]
fn every_node_test_finds_what_obvhs_finds_bit_for_bit() {
    for name in ["torture", "cornell"] {
        let scene = load(name);
        let wide = Tracer::new(&scene).with_node_test(NodeTest::Wide);
        let portable = Tracer::new(&scene).with_node_test(NodeTest::Portable);
        assert_eq!(portable.node_test(), NodeTest::Portable);
        let (lo, hi) = scene.bounds();
        let (mut hits, mut ties) = (0, 0);
        for k in 0..20_000u32 {
            let mut s = Sampler::new(43, 9, k);
            let u = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
            let o = if k % 5 == 0 { lo - (hi - lo) * 0.5 + (hi - lo) * 2.0 * u } else { lo + (hi - lo) * u };
            let d = if k % 7 == 0 {
                [Vec3::X, -Vec3::Y, Vec3::Z, -Vec3::X][(k / 7 % 4) as usize]
            } else {
                uniform_sphere(s.next_2d())
            };
            let reference = wide.closest_slot_obvhs(o, d).map(|(t, slot)| (t.to_bits(), slot));
            for t in [&wide, &portable] {
                let got = t.closest_slot(o, d).map(|(t, slot)| (t.to_bits(), slot));
                let same = match (got, reference) {
                    (Some((a, s)), Some((b, r))) if a == b && s != r => {
                        // a tie: both hit at exactly that distance, ours facing the ray if
                        // obvhs's does, and the lower slot if they face alike
                        ties += 1;
                        let ((ts, back_s), (tr, back_r)) = (t.slot_distance(o, d, s), t.slot_distance(o, d, r));
                        ts.to_bits() == a && tr.to_bits() == a && (back_s, s) < (back_r, r)
                    }
                    _ => got == reference,
                };
                assert!(same, "{name}, ray {k} from {o} along {d}, {:?}: {got:?} against {reference:?}", t.node_test());
                let a = t.closest_hit(o, d, f32::INFINITY);
                let b = wide.closest_hit(o, d, f32::INFINITY);
                assert_eq!(format!("{a:?}"), format!("{b:?}"), "{name}, ray {k}");
                let tmax = [0.5f32, 2.0, f32::INFINITY][(k % 3) as usize];
                assert_eq!(t.occluded(o, d, tmax), wide.occluded(o, d, tmax), "{name}, ray {k}, tmax {tmax}");
                assert_eq!(
                    t.occluded(o, d, tmax),
                    t.closest_hit(o, d, tmax).is_some(),
                    "{name}, ray {k}, tmax {tmax}: occlusion disagrees with closest hit"
                );
            }
            hits += reference.is_some() as u32;
        }
        assert!(hits > 10_000, "{name}: only {hits} hits");
        eprintln!("{name}: {hits} hits, {ties} ties between primitives at one distance");
    }
}

/// The GGX lobe reference (`trace::truth::lobe_reference`) against closed forms.
mod lobe_reference {
    use super::*;
    use warpfit::trace::truth::lobe_reference;

    /// Constant radiance all around: every lobe sample sees L, so the reference is exactly L
    /// at every roughness, with zero standard error.
    #[test]
    fn constant_radiance_gives_exactly_l() {
        let scene = Scene::parse(
            &format!("bounces = 0\n{HEADER}\n[[geometry]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 3.0\ninward = true\nmaterial = {{ albedo = [0.0, 0.0, 0.0], emission = [2.0, 1.0, 0.5] }}\n"),
            &fixture("constant.toml"),
        )
        .unwrap();
        let tracer = Tracer::new(&scene);
        let renderer = Renderer::new(&scene, &tracer);
        let want = Vec3::new(2.0, 1.0, 0.5);
        for (k, dir) in dirs(32, 9).into_iter().enumerate() {
            for r in [0.0f32, 0.125, 0.25, 0.5, 0.75, 1.0] {
                let mut rays = 0;
                let b = Vec3::new(0.4, 1.3, -0.2);
                let got = lobe_reference(&renderer, b, dir, r, 64, |s| Sampler::new(3, k as u64, s), &mut rays);
                assert!((got.radiance - want).abs().max_element() < 1e-5, "r {r}: {} vs {want}", got.radiance);
                assert!(got.se < 1e-5, "r {r}: se {}", got.se);
                assert!(rays > 0);
            }
        }
    }

    /// A mirror reference traces its one ray once and continues each sample from the hit
    /// (`Renderer::first_hit`, `sample_after`): the same sum, bit for bit, as tracing every
    /// sample whole, with one closest-hit ray instead of `spp`.
    #[test]
    fn a_mirror_reference_is_the_mean_of_whole_samples_bit_for_bit() {
        let scene = load("torture");
        let tracer = Tracer::new(&scene);
        let renderer = Renderer::new(&scene, &tracer);
        for (k, dir) in dirs(64, 4).into_iter().enumerate() {
            let b = Vec3::new(-2.0 + 0.06 * k as f32, 1.1, 0.7 - 0.03 * k as f32);
            let sampler = |s: u32| Sampler::new(11, k as u64, s);
            let (mut rays, mut whole_rays) = (0u64, 0u64);
            let got = lobe_reference(&renderer, b, dir, 0.0, 8, sampler, &mut rays);
            let mut sum = Vec3::ZERO;
            for s in 0..8 {
                sum += renderer.sample(b, dir, &mut sampler(s), &mut whole_rays).radiance;
            }
            let want = sum / 8.0;
            assert_eq!(got.radiance.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "query {k}");
            assert_eq!(rays + 7, whole_rays, "query {k}: the first ray is traced once");
        }
    }

    /// GGX D (α), as the probe's prefilter uses it.
    fn ggx_d(alpha: f64, cos_h: f64) -> f64 {
        let a2 = alpha * alpha;
        let t = cos_h * cos_h * (a2 - 1.0) + 1.0;
        a2 / (std::f64::consts::PI * t * t)
    }

    /// ∫ over directions l within `theta_max` of the lobe axis of (n·l)·D(h)/4 dl, for N = V:
    /// the half vector is at half the angle of l. Simpson's rule in θ.
    fn lobe_mass(alpha: f64, theta_max: f64) -> f64 {
        let n = 20_000;
        let h = theta_max / n as f64;
        let f = |t: f64| libm::cos(t) * ggx_d(alpha, libm::cos(t * 0.5)) / 4.0 * std::f64::consts::TAU * libm::sin(t);
        let mut s = f(0.0) + f(theta_max);
        for i in 1..n {
            s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    /// A small sphere light of radiance Le straight along the lobe's axis, in a black world:
    /// the reference is Le times the lobe's normalised mass over the light's cap, within the
    /// estimator's own standard error, which is small (the light is sampled directly).
    #[test]
    fn a_small_emitter_matches_the_analytic_lobe_mass() {
        let le = 50.0f32;
        let scene = Scene::parse(
            &format!(
                "bounces = 0\n{HEADER}\n[sky]\nzenith = [0.0, 0.0, 0.0]\nhorizon = [0.0, 0.0, 0.0]\nground = [0.0, 0.0, 0.0]\n\
                 [[sphere_lights]]\nposition = [0.0, 1.0, 2.0]\nradius = 0.3\nradiance = [{le}, {le}, {le}]\n\
                 [[geometry]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 8.0\ninward = true\nmaterial = {{ albedo = [0.0, 0.0, 0.0] }}\n"
            ),
            &fixture("emitter.toml"),
        )
        .unwrap();
        let tracer = Tracer::new(&scene);
        let renderer = Renderer::new(&scene, &tracer);
        let b = Vec3::new(0.0, 1.0, 0.0);
        let cap = libm::asin(0.3f64 / 2.0);
        for (k, r) in [0.25f32, 0.5, 0.75, 1.0].into_iter().enumerate() {
            let alpha = f64::from(r * r);
            let want = f64::from(le) * lobe_mass(alpha, cap) / lobe_mass(alpha, std::f64::consts::FRAC_PI_2);
            let mut rays = 0;
            // the estimator divides the lights' share by the lobe's mass in closed form
            let closed = warpfit::trace::truth::lobe_mass(r * r);
            let numeric = lobe_mass(alpha, std::f64::consts::FRAC_PI_2);
            assert!((closed - numeric).abs() < 1e-6 * numeric, "r {r}: lobe mass {closed} vs {numeric}");
            let got = lobe_reference(&renderer, b, Vec3::Z, r, 1024, |s| Sampler::new(11, k as u64, s), &mut rays);
            let y = f64::from(got.radiance.x);
            let se = f64::from(got.se);
            // 1,024 samples: the lamp sampled directly (cosine-weighted lobe samples alone needed
            // 65,536 for 6%): 2%
            assert!(se > 0.0 && se < 0.02 * want, "r {r}: se {se} for {want}");
            assert!((y - want).abs() < 4.0 * se, "r {r}: {y} vs analytic {want} (se {se})");
            // all of it is the lamp seen straight from B, by lobe samples and light samples alike
            assert!(got.emitter_share() > 0.999, "r {r}: emitter share {}", got.emitter_share());
        }
        let mut rays = 0;
        // mirror: exactly Le on the axis, all of it the lamp's; beside the lamp, black: no share
        let mirror = lobe_reference(&renderer, b, Vec3::Z, 0.0, 4, |s| Sampler::new(11, 9, s), &mut rays);
        assert_eq!(mirror.radiance, Vec3::splat(le));
        assert_eq!(mirror.emitter_share(), 1.0);
        let beside = lobe_reference(&renderer, b, Vec3::X, 0.0, 4, |s| Sampler::new(11, 9, s), &mut rays);
        assert_eq!((beside.radiance, beside.emitter_share()), (Vec3::ZERO, 0.0));
    }

    /// A mirror ray that meets a lit, non-emissive wall sees no emitter, and one that meets
    /// an emissive triangle sees the emission's share of what it returns.
    #[test]
    fn the_emitter_share_of_a_wall_is_zero_and_of_a_lamp_its_emission() {
        let scene = load("cornell");
        let tracer = Tracer::new(&scene);
        let renderer = Renderer::new(&scene, &tracer);
        let (mut walls, mut lamps) = (0, 0);
        let b = Vec3::new(0.278, 0.274, 0.28);
        // random directions, and 16 aimed into the ceiling lamp (0.213–0.343 × 0.227–0.332)
        let mut all = dirs(256, 5);
        all.extend((0..16).map(|t| {
            let target = Vec3::new(0.23 + 0.03 * (t % 4) as f32, 0.5478, 0.24 + 0.025 * (t / 4) as f32);
            (target - b).normalize()
        }));
        for (k, dir) in all.into_iter().enumerate() {
            let mut rays = 0;
            let got = lobe_reference(&renderer, b, dir, 0.0, 4, |s| Sampler::new(5, k as u64, s), &mut rays);
            let share = got.emitter_share();
            assert!((0.0..=1.0).contains(&share));
            let hit = tracer.closest_hit(b, dir, f32::INFINITY).expect("a closed box");
            let emission = scene.materials[hit.material as usize].emission;
            if emission.max_element() > 0.0 {
                lamps += 1;
                let want = warpfit::tonemap::luminance(emission) / warpfit::tonemap::luminance(got.radiance);
                assert!((share - want.min(1.0)).abs() < 1e-4, "query {k}: {share} vs {want}");
            } else {
                walls += 1;
                assert_eq!(share, 0.0, "query {k}");
            }
        }
        assert!(walls > 100 && lamps >= 16, "walls {walls}, lamps {lamps}");
    }
}

#[test]
fn axis_rays_with_negative_zero_components_hit_like_positive_zero() {
    // obvhs reads a ray's octant from `d < 0.0` and its inverse from the sign bit: with a
    // −0.0 component the two disagree; the tracer must hide that (`-Vec3::Y` is (−0, −1, −0))
    let scene = load("torture");
    let tracer = Tracer::new(&scene);
    let p = Vec3::new(-3.0, 1.0, -3.0); // under the roof, below the window's sill
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut base = [0.0f32; 3];
            base[axis] = sign;
            let want = tracer.closest_hit(p, Vec3::from_array(base), f32::INFINITY).map(|h| h.t);
            assert!(want.is_some(), "the closed hall stops axis {axis} sign {sign}");
            for zeros in 0..4u32 {
                let mut d = base;
                let others = [(axis + 1) % 3, (axis + 2) % 3];
                for (bit, &c) in others.iter().enumerate() {
                    if zeros & (1 << bit) != 0 {
                        d[c] = -0.0;
                    }
                }
                let d = Vec3::from_array(d);
                assert_eq!(tracer.closest_hit(p, d, f32::INFINITY).map(|h| h.t), want, "{d:?}");
                assert!(tracer.occluded(p, d, f32::INFINITY), "{d:?}");
            }
        }
    }
}

/// Two boxes touching at x = 1: their faces there coincide, one facing each way. A ray
/// crossing that plane meets both at one distance; it must see the face turned towards it
/// (front side, the far box's material), from either side and with either box listed first
/// (the walk's order, and obvhs's, would otherwise decide).
#[test]
fn coinciding_faces_show_the_one_facing_the_ray() {
    let red = "{ albedo = [0.9, 0.1, 0.1] }";
    let green = "{ albedo = [0.1, 0.9, 0.1] }";
    let a = format!("[[geometry]]\ntype = \"box\"\nmin = [0.0, 0.0, 0.0]\nmax = [1.0, 1.0, 1.0]\nmaterial = {red}\n");
    let b = format!("[[geometry]]\ntype = \"box\"\nmin = [1.0, 0.0, 0.0]\nmax = [2.0, 1.0, 1.0]\nmaterial = {green}\n");
    for body in [format!("{a}{b}"), format!("{b}{a}")] {
        let scene = parse(&body).unwrap();
        let albedo = |m: u32| scene.materials[m as usize].albedo;
        for test in [NodeTest::Wide, NodeTest::Portable] {
            let tracer = Tracer::new(&scene).with_node_test(test);
            let mut checked = 0;
            for k in 0..64u32 {
                let mut s = Sampler::new(5, 17, k);
                let (y, z) = (0.1 + 0.8 * s.next_1d(), 0.1 + 0.8 * s.next_1d());
                let d = Vec3::new(1.0, 0.4 * s.next_1d() - 0.2, 0.4 * s.next_1d() - 0.2).normalize();
                // from inside the red box towards +x, and from inside the green one back
                for (o, dir, want, normal) in [
                    (Vec3::new(0.5, y, z), d, Vec3::new(0.1, 0.9, 0.1), -Vec3::X),
                    (Vec3::new(1.5, y, z), -d, Vec3::new(0.9, 0.1, 0.1), Vec3::X),
                ] {
                    let hit = tracer.closest_hit(o, dir, f32::INFINITY).expect("the shared face is hit");
                    if (hit.position.x - 1.0).abs() > 1e-5 {
                        continue; // left through another face first
                    }
                    assert!(!hit.backface, "{test:?}, ray {k} from {o}: the back face was reported");
                    assert_eq!(hit.normal, normal, "{test:?}, ray {k} from {o}");
                    assert_eq!(albedo(hit.material), want, "{test:?}, ray {k} from {o}");
                    checked += 1;
                }
            }
            assert!(checked > 64, "only {checked} rays reached the shared face");
        }
    }
}

/// The batch walk (`Tracer::closest_hits`, packets of rays walked together) finds for every
/// ray exactly what `closest_hit` finds for it alone, with either node test: rays from
/// one point in coherent order (a probe's), in random order, from scattered points, with
/// a finite `tmax`, partial packets, rays with no direction or a non-finite origin, and
/// the grid's probe rays from cell centres (some on a surface).
#[test]
fn packets_of_rays_find_what_single_rays_find() {
    for name in ["torture", "cornell", "sphere"] {
        let scene = load(name);
        let (lo, hi) = scene.bounds();
        for test in [NodeTest::Wide, NodeTest::Portable] {
            let tracer = Tracer::new(&scene).with_node_test(test);
            let centre = Vec3::from_array(scene.config.probe.position);
            let mut cases: Vec<(String, Vec<Vec3>, Vec<Vec3>, f32)> = Vec::new();
            let random = dirs(5_003, 17);
            let order = coherent_order(&random.iter().map(|&d| (centre, d)).collect::<Vec<_>>());
            let sorted: Vec<Vec3> = order.iter().map(|&i| random[i as usize]).collect();
            cases.push(("one point, coherent".into(), vec![centre; sorted.len()], sorted, f32::INFINITY));
            cases.push(("one point, random".into(), vec![centre; random.len()], random.clone(), f32::INFINITY));
            let scattered: Vec<Vec3> = (0..random.len() as u32)
                .map(|k| {
                    let mut s = Sampler::new(5, 1, k);
                    lo + (hi - lo) * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d())
                })
                .collect();
            cases.push(("scattered points".into(), scattered.clone(), random.clone(), f32::INFINITY));
            cases.push(("scattered points, tmax 0.7".into(), scattered, random.clone(), 0.7));
            let mut odd = random[..37].to_vec();
            odd[3] = Vec3::ZERO;
            odd[20] = Vec3::NAN;
            let mut odd_origins = vec![centre; odd.len()];
            odd_origins[9] = Vec3::INFINITY;
            cases.push(("degenerate rays".into(), odd_origins, odd, f32::INFINITY));
            // each grid cell's probe rays from its centre, some of which lie on surfaces:
            // a hit closer than the node test's entry clamp must not depend on the order
            let gc = &scene.config.grid;
            let (gmin, gmax) = (Vec3::from_array(gc.min), Vec3::from_array(gc.max));
            let counts = glam::UVec3::from_array(gc.counts);
            let (mut cell_origins, mut cell_dirs) = (Vec::new(), Vec::new());
            for z in 0..counts.z {
                for y in 0..counts.y {
                    for x in 0..counts.x {
                        let centre =
                            gmin + (gmax - gmin) * (glam::UVec3::new(x, y, z).as_vec3() + 0.5) / counts.as_vec3();
                        for t in 0..256u32 {
                            let uv = glam::Vec2::new(((t % 16) as f32 + 0.3) / 16.0, ((t / 16) as f32 + 0.6) / 16.0);
                            cell_origins.push(centre);
                            cell_dirs.push(warpfit::octa::decode(uv));
                        }
                    }
                }
            }
            cases.push(("cell centres".into(), cell_origins, cell_dirs, f32::INFINITY));
            for (what, origins, ds, tmax) in &cases {
                let rays: Vec<(Vec3, Vec3)> = origins.iter().copied().zip(ds.iter().copied()).collect();
                let out = tracer.closest_hits(&rays, *tmax);
                assert_eq!(out.len(), rays.len());
                for k in 0..ds.len() {
                    let single = tracer.closest_hit(origins[k], ds[k], *tmax);
                    assert_eq!(
                        format!("{:?}", out[k]),
                        format!("{single:?}"),
                        "{name}, {test:?}, {what}: ray {k} from {} along {}",
                        origins[k],
                        ds[k]
                    );
                }
            }
        }
    }
}

/// The distance to what a ray sees first (`truth::first_visible`, what the probe bake
/// stores per texel without shading the ray) along a direction normalised as a sample
/// normalises it is the distance that sample reports: rays from the probe and from
/// scattered points (some inside solids, seeing back faces), in scenes with and without
/// sphere lights.
#[test]
fn the_first_visible_distance_is_the_whole_samples() {
    use warpfit::trace::truth::first_visible;
    for name in ["torture", "cornell", "sphere", "hall"] {
        let scene = load(name);
        let tracer = Tracer::new(&scene);
        let renderer = Renderer::new(&scene, &tracer);
        let centre = Vec3::from_array(scene.config.probe.position);
        let (lo, hi) = scene.bounds();
        let mut rays: Vec<(Vec3, Vec3)> = dirs(1_000, 31).into_iter().map(|d| (centre, d)).collect();
        for (k, d) in dirs(1_000, 37).into_iter().enumerate() {
            let mut s = Sampler::new(7, 2, k as u32);
            rays.push((lo + (hi - lo) * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()), d * 3.0));
        }
        let mut finite = 0;
        for (k, &(o, d)) in rays.iter().enumerate() {
            let whole = renderer.sample(o, d, &mut Sampler::new(1, 2, k as u32), &mut 0).distance;
            let got = first_visible(&scene, &tracer, o, d.normalize());
            assert_eq!(got.to_bits(), whole.to_bits(), "{name}: ray {k} from {o} along {d}");
            finite += usize::from(got.is_finite());
        }
        assert!(finite > 1_000, "{name}: only {finite} of {} rays see something", rays.len());
    }
}

/// `coherent_order` is a permutation of the rays, the same for the same input, and puts
/// neighbours in neighbouring directions.
#[test]
fn coherent_order_is_a_permutation_of_neighbouring_directions() {
    let random = dirs(10_000, 23);
    let rays: Vec<(Vec3, Vec3)> = random.iter().map(|&d| (Vec3::ZERO, d)).collect();
    let order = coherent_order(&rays);
    assert_eq!(order, coherent_order(&rays));
    let mut seen = order.clone();
    seen.sort_unstable();
    assert!(seen.iter().enumerate().all(|(k, &i)| i == k as u32), "not a permutation");
    let mean_step = |v: &mut dyn Iterator<Item = Vec3>| {
        let v: Vec<Vec3> = v.collect();
        v.windows(2).map(|w| w[0].angle_between(w[1])).sum::<f32>() / (v.len() - 1) as f32
    };
    let (given, sorted) =
        (mean_step(&mut random.iter().copied()), mean_step(&mut order.iter().map(|&i| random[i as usize])));
    assert!(sorted < given / 10.0, "mean angle between neighbours {sorted} against {given} unsorted");
}

/// `WARPFIT_DUMP_STREAMS=DIR` keeps the rays a command traces per stage and kind, in the
/// layout `examples/ray_rate.rs` and the Embree scripts read: the scene's triangles, each
/// stream's rays (origin, unit direction) and their reach.
#[test]
fn the_ray_streams_a_bake_traces_are_dumped_per_stage_and_kind() {
    let dir = common::tmp_dir("streams");
    let out = common::tmp_dir("streams-bake");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_warpfit"))
        .args(["--quiet", "--threads", "1", "bake", "--scene", "data/scenes/tiny.toml", "--out"])
        .arg(&*out)
        .env("WARPFIT_DUMP_STREAMS", &*dir)
        .current_dir(common::repo())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let list = std::fs::read_to_string(dir.join("streams.txt")).unwrap();
    let streams: Vec<(&str, usize)> =
        list.lines().map(|l| l.split_once(' ').map(|(a, b)| (a, b.parse().unwrap())).unwrap()).collect();
    for want in ["probe_bake_primary", "probe_bake_shadow", "grid_bake_primary", "grid_bake_bounce"] {
        assert!(streams.iter().any(|(n, k)| *n == want && *k > 0), "{want} in {list}");
    }
    let floats = |p: std::path::PathBuf| -> Vec<f32> {
        std::fs::read(&p).unwrap().chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
    };
    let scene = common::load("tiny");
    assert_eq!(floats(dir.join("scene.tris.f32")).len(), 9 * scene.triangles.len());
    for (name, n) in streams {
        let rays = floats(dir.join(format!("{name}.rays.f32")));
        let tmax = floats(dir.join(format!("{name}.tmax.f32")));
        assert_eq!((rays.len(), tmax.len()), (6 * n, n), "{name}");
        assert!(dir.join(format!("{name}.tris.f32")).is_file());
        for r in rays.chunks_exact(6) {
            let d = Vec3::new(r[3], r[4], r[5]);
            assert!((d.length() - 1.0).abs() < 1e-3, "{name}: direction {d}");
        }
        assert!(tmax.iter().all(|t| *t > 0.0 && !t.is_nan()), "{name}");
    }
    // the probe's first rays all start at probe A, one per texel sample, in texel order
    let first = floats(dir.join("probe_bake_primary.rays.f32"));
    let a = Vec3::from_array(scene.config.probe.position);
    assert!(first.chunks_exact(6).take(100).all(|r| Vec3::new(r[0], r[1], r[2]) == a));
}
