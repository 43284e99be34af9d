//! Warp methods: exact where they must be (query at the probe, sky, a sphere seen from its
//! centre, a box room for the box proxy) and finite everywhere (property tests).

mod common;
use common::*;
use glam::{Vec2, Vec3};
use proptest::prelude::*;
use warpfit::bake::SpecularProbe;
use warpfit::octa::{self, OctMap, OctMips, build_distance_mips};
use warpfit::progress::Progress;
use warpfit::trace::Tracer;
use warpfit::trace::truth;
use warpfit::warp::{self, Method, Proxies, Warp, WarpOptions, proxy, reproject::reproject};

const PER_LOOKUP: [Method; 8] = Method::PER_LOOKUP;

/// A probe at `a` whose distance is given per direction, with radiance = direction colour.
fn synthetic_probe(a: Vec3, res: u32, dist: impl Fn(Vec3) -> f32) -> SpecularProbe {
    let rad = OctMap::from_fn(res, |_, _, d| d * 0.5 + Vec3::splat(0.5));
    let depth = OctMap::from_fn(res, |_, _, d| dist(d));
    SpecularProbe {
        position: a,
        radiance: OctMips { levels: vec![rad] },
        roughness: vec![0.0],
        depth: build_distance_mips(depth, 8),
    }
}

/// The warp context of probe `p` with a box proxy [lo, hi] and `options`.
fn context(p: &SpecularProbe, lo: Vec3, hi: Vec3, options: WarpOptions) -> Warp {
    let proxies = Proxies { aabb: proxy::BoxProxy::aabb(lo, hi), kdop: proxy::Kdop::fit(p.position, p.distance()) };
    Warp { probe: p.warp_probe(), others: Default::default(), proxies, options }
}

/// `warp` with other options.
fn with(warp: &Warp, options: WarpOptions) -> Warp {
    Warp { options, ..warp.clone() }
}

fn dirs(n: u32) -> Vec<Vec3> {
    (0..n).map(|k| warpfit::sampling::uniform_sphere(warpfit::sampling::Sampler::new(3, 1, k).next_2d())).collect()
}

/// The default scene with a 64² probe: scene, tracer, probe and warp context.
fn torture_at_test_resolution() -> (warpfit::scene::Scene, Tracer, SpecularProbe, Warp) {
    let mut s = load("torture");
    s.config.probe.resolution = 64;
    s.config.probe.samples_per_texel = 1;
    s.config.grid.counts = [2, 2, 2];
    let tracer = Tracer::new(&s);
    let baked = warpfit::bake::bake(&s, &tracer, &Progress::quiet());
    let ctx = warpfit::bake::warp(&s, &baked.probe, WarpOptions::standard());
    (s, tracer, baked.probe, ctx)
}

#[test]
fn query_at_the_probe_returns_the_query_direction_exactly() {
    let (s, tracer, probe, ctx) = torture_at_test_resolution();
    let a = probe.position;
    for opts in [WarpOptions::default(), WarpOptions { relax_texels: 2.0, depth_lod: 0.0, ..WarpOptions::default() }] {
        let w = with(&ctx, opts);
        for d in dirs(2000) {
            for m in PER_LOOKUP {
                let f = w.fetch_dir(m, a, d);
                assert_eq!(f, d, "{} at the probe", m.name());
            }
            let (o, hidden) = truth::oracle(&s, &tracer, a, a, d);
            assert_eq!(o, d);
            assert!(!hidden);
        }
    }
    // reprojection to A itself reproduces A's map exactly
    let map = reproject(&ctx.probe, a, ctx.probe.radiance.levels[0].res);
    assert_eq!(map.texels, ctx.probe.radiance.levels[0].texels);
}

#[test]
fn sky_returns_the_query_direction() {
    // Probe sees sky above the horizontal plane (y > 0), a floor 1 below it elsewhere.
    let a = Vec3::new(0.0, 1.0, 0.0);
    let p = synthetic_probe(a, 64, |d| if d.y > -0.05 { f32::INFINITY } else { 1.0 / -d.y });
    let w =
        context(&p, Vec3::splat(-10.0), Vec3::splat(10.0), WarpOptions { depth_lod: 0.0, ..WarpOptions::default() });
    let b = Vec3::new(0.4, 1.3, -0.2);
    for d in dirs(3000).into_iter().filter(|d| d.y > 0.3) {
        // Proxies (box, k-DOP) close the scene by construction and are not expected to.
        for m in [Method::None, Method::Warp1, Method::Warp2Fixed, Method::Warp2New, Method::Secant, Method::Raymarch] {
            let f = w.fetch_dir(m, b, d);
            assert!((f - d).length() < 1e-6, "{}: {f} vs {d}", m.name());
        }
    }
}

#[test]
fn sphere_centre_probe_secant_and_two_steps_converge() {
    // A at the centre of a sphere of radius R: the true hit from B along d is closed-form.
    let a = Vec3::new(0.0, 1.0, 0.0);
    let r = 2.0f32;
    let p = synthetic_probe(a, 128, |_| r);
    let opts = WarpOptions { depth_lod: 0.0, secant_steps: 8, ..WarpOptions::default() };
    let w = context(&p, Vec3::splat(-3.0), Vec3::splat(3.0), opts);
    let mut err = [0.0f64; 4];
    let ds = dirs(2000);
    for (k, d) in ds.iter().enumerate() {
        let b = a + Vec3::new(0.9 * ((k % 7) as f32 / 6.0 - 0.5), 0.6 * ((k % 5) as f32 / 4.0 - 0.5), 0.5);
        // closed-form hit: |b + t d − a| = r
        let o = b - a;
        let t = -o.dot(*d) + (o.dot(*d).powi(2) - o.length_squared() + r * r).sqrt();
        let truth = (b + *d * t - a).normalize();
        for (slot, m) in [Method::Warp1, Method::Warp2Fixed, Method::Warp2New, Method::Secant].iter().enumerate() {
            let f = w.fetch_dir(*m, b, *d);
            err[slot] += libm::acosf(f.dot(truth).clamp(-1.0, 1.0)) as f64;
        }
    }
    let mean: Vec<f64> = err.iter().map(|e| e.to_degrees() / ds.len() as f64).collect();
    assert!(mean[3] < 0.01, "secant must converge to the exact hit: {:?}", mean);
    assert!(mean[1] < mean[0] && mean[2] < mean[0], "two steps must beat one on a sphere: {:?}", mean);
    assert!(mean[0] < 5.0, "one step must be close on a sphere: {:?}", mean);
}

#[test]
fn box_proxy_is_exact_in_a_box_room() {
    let scene = parse("[[geometry]]\ntype = \"room\"\nmin = [-2.0, 0.0, -3.0]\nmax = [3.0, 2.5, 1.0]\n").unwrap();
    let tracer = Tracer::new(&scene);
    let a = Vec3::new(0.2, 1.1, -0.7);
    let p = synthetic_probe(a, 32, |_| 1.0);
    let w = context(&p, Vec3::new(-2.0, 0.0, -3.0), Vec3::new(3.0, 2.5, 1.0), WarpOptions::default());
    for (k, d) in dirs(3000).into_iter().enumerate() {
        let b = Vec3::new(-1.5 + (k % 9) as f32 * 0.5, 0.2 + (k % 4) as f32 * 0.6, -2.5 + (k % 7) as f32 * 0.5);
        let f = w.fetch_dir(Method::Box, b, d);
        let (o, _) = truth::oracle(&scene, &tracer, a, b, d);
        assert!((f - o).length() < 2e-6, "box fetch {f} vs oracle {o} from {b} along {d}");
    }
}

#[test]
fn methods_on_the_default_scene_are_finite_and_unit() {
    let (_, _, probe, ctx) = torture_at_test_resolution();
    let a = probe.position;
    let special: Vec<Vec3> = [
        Vec3::X,
        -Vec3::X,
        Vec3::Y,
        -Vec3::Y,
        Vec3::Z,
        -Vec3::Z, // poles
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
        Vec3::new(1.0, 0.0, -1.0), // seams
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(-1.0, -1.0, -1.0), // diagonals
        Vec3::new(1.0, 1e-7, 0.0),   // grazing the floor plane from a point on it
    ]
    .iter()
    .map(|v| v.normalize())
    .collect();
    let positions = [
        a,
        Vec3::new(0.0, 1e-6, 0.0),        // on the floor
        Vec3::new(-6.0 + 1e-6, 2.0, 1.0), // on a wall
        Vec3::new(0.0, 0.0, -0.1),        // inside the thin wall
        Vec3::new(50.0, 30.0, -40.0),     // outside the scene
        Vec3::new(1e20, -1e20, 1e20),
    ];
    for b in positions {
        for d in special.iter().chain(dirs(500).iter()) {
            for m in PER_LOOKUP {
                let f = ctx.fetch_dir(m, b, *d);
                assert!(f.is_finite() && (f.length() - 1.0).abs() < 1e-4, "{} from {b} along {d}: {f}", m.name());
                let l = ctx.lookup(m, b, *d);
                assert!(l.is_finite(), "{} radiance", m.name());
            }
        }
        let map = reproject(&ctx.probe, b, 32);
        assert!(map.texels.iter().all(|t| t.is_finite()));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]
    /// Arbitrary probes (finite, zero and infinite depths) and queries never produce NaN/Inf.
    #[test]
    fn never_nan(seed in 0u64..1000, bx in -100.0f32..100.0, by in -100.0f32..100.0, bz in -100.0f32..100.0,
                 u in 0.0f32..1.0, v in 0.0f32..1.0, lod in 0.0f32..3.0, relax in 0.0f32..3.0) {
        let a = Vec3::new(0.5, 1.0, -0.5);
        let p = synthetic_probe(a, 16, |d| {
            let h = (libm::sinf(d.x * 12.9898 + d.y * 78.233 + d.z * 37.719 + seed as f32) * 43758.547).fract().abs();
            if h < 0.2 { f32::INFINITY } else if h < 0.25 { 0.0 } else { h * 5.0 }
        });
        let opts = WarpOptions { depth_lod: lod, relax_texels: relax, ..WarpOptions::default() };
        let w = context(&p, Vec3::splat(-4.0), Vec3::splat(4.0), opts);
        let b = Vec3::new(bx, by, bz);
        let d = octa::decode(Vec2::new(u, v));
        for m in PER_LOOKUP {
            let f = w.fetch_dir(m, b, d);
            prop_assert!(f.is_finite() && (f.length() - 1.0).abs() < 1e-3, "{} {f}", m.name());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]
    /// The distance the grid's maps shift from, with `warp1` as the proxy, is where seed
    /// 000's one-step warp aims: the point it gives, seen from the probe, is `warp1`'s fetch
    /// direction; where `warp1` reads sky it is infinite; it is never NaN.
    #[test]
    fn warp1_distance_is_where_warp1_aims(seed in 0u64..1000, bx in -3.0f32..3.0, by in -3.0f32..3.0,
                                          bz in -3.0f32..3.0, u in 0.0f32..1.0, v in 0.0f32..1.0) {
        let a = Vec3::new(0.5, 1.0, -0.5);
        let p = synthetic_probe(a, 16, |d| {
            let h = (libm::sinf(d.x * 12.9898 + d.y * 78.233 + d.z * 37.719 + seed as f32) * 43758.547).fract().abs();
            if h < 0.2 { f32::INFINITY } else { 2.0 + h * 5.0 }
        });
        let w = context(&p, Vec3::splat(-8.0), Vec3::splat(8.0), WarpOptions::default());
        let (b, d) = (Vec3::new(bx, by, bz), octa::decode(Vec2::new(u, v)));
        let t = w.base_distance(Method::Warp1, b, d).unwrap();
        prop_assert!(!t.is_nan() && t >= 0.0, "{t}");
        let f = w.fetch_dir(Method::Warp1, b, d);
        if t.is_finite() {
            let aimed = (b + d * t - a).normalize();
            prop_assert!((aimed - f).length() < 1e-4, "{aimed} vs {f}");
        } else {
            prop_assert_eq!(f, d);
        }
    }
}

/// Bit patterns of a vector: batched and per-lookup results must agree bit for bit.
fn bits(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

#[test]
fn batched_warp1_equals_the_per_lookup_warp1() {
    let (_, _, probe, ctx) = torture_at_test_resolution();
    let opts = ctx.options;
    let mut queries: Vec<(Vec3, Vec3)> = dirs(1000)
        .into_iter()
        .enumerate()
        .map(|(k, d)| (Vec3::new(-4.0 + (k % 9) as f32, 0.5 + (k % 4) as f32, -4.0 + (k % 7) as f32), d))
        .collect();
    queries.push((probe.position, Vec3::X)); // query at the probe
    queries.push((Vec3::new(1.5, 3.0, 1.5), Vec3::Y)); // towards the skylight
    queries.push((Vec3::new(40.0, -30.0, 5.0), Vec3::X)); // B far outside the scene
    for d in [Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::Y, Vec3::new(1.0, -1.0, 0.0).normalize()] {
        queries.push((Vec3::new(0.3, 1.0, 0.2), d)); // poles and seams of the octahedral map
    }
    queries.push((Vec3::new(0.3, 0.0, 0.2), Vec3::new(1.0, 1e-7, 0.0).normalize())); // grazing along the floor
    assert!(!queries.len().is_multiple_of(octa::LANES), "the remainder path must be exercised too");
    let mut vectors = vec![Vec3::ZERO; queries.len()];
    warp::depth::warp1_batch(&ctx.probe, &queries, opts.depth_lod, &mut vectors);
    let mut radiance = vec![Vec3::ZERO; queries.len()];
    ctx.probe.radiance_batch(&vectors, &mut radiance);
    for ((q, v), r) in queries.iter().zip(&vectors).zip(&radiance) {
        let single = ctx.fetch_vector(Method::Warp1, q.0, q.1);
        assert_eq!(bits(*v), bits(single), "query {q:?}: {v} vs {single}");
        assert_eq!(bits(*r), bits(ctx.probe.radiance(single)), "query {q:?}");
    }
}

#[test]
fn batches_of_unequal_length_answer_the_common_prefix() {
    let (_, _, _, ctx) = torture_at_test_resolution();
    let lod = WarpOptions::default().depth_lod;
    let queries: Vec<(Vec3, Vec3)> = dirs(45).into_iter().map(|d| (Vec3::new(0.3, 1.0, 0.2), d)).collect();
    let vectors: Vec<Vec3> =
        queries.iter().map(|q| warp::depth::plane_warp(&ctx.probe, q.0, q.1, lod, 1, false)).collect();
    for (nq, no) in [(45, 20), (20, 45), (33, 33)] {
        let mut out = vec![Vec3::NAN; no];
        warp::depth::warp1_batch(&ctx.probe, &queries[..nq], lod, &mut out);
        let mut rad = vec![Vec3::NAN; no];
        ctx.probe.radiance_batch(&vectors[..nq], &mut rad);
        for k in 0..no {
            if k < nq.min(no) {
                assert_eq!(bits(out[k]), bits(vectors[k]), "{nq} queries, {no} outputs, output {k}");
                assert_eq!(bits(rad[k]), bits(ctx.probe.radiance(vectors[k])), "{nq}/{no}: {k}");
            } else {
                assert!(out[k].is_nan() && rad[k].is_nan(), "output {k} beyond the queries is left alone");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]
    /// Batched warp1 equals per-lookup warp1 bit for bit on arbitrary probes (finite, zero
    /// and infinite depths), depth mips and queries, including every degenerate early exit.
    #[test]
    fn batched_warp1_is_bitwise_the_per_lookup_warp1(seed in 0u64..1000, lod in 0.0f32..3.0,
        queries in proptest::collection::vec((-20.0f32..20.0, -20.0f32..20.0, -20.0f32..20.0, 0.0f32..1.0, 0.0f32..1.0), 1..40)) {
        let a = Vec3::new(0.5, 1.0, -0.5);
        let p = synthetic_probe(a, 16, |d| {
            let h = (libm::sinf(d.x * 12.9898 + d.y * 78.233 + d.z * 37.719 + seed as f32) * 43758.547).fract().abs();
            if h < 0.2 { f32::INFINITY } else if h < 0.25 { 0.0 } else { h * 5.0 }
        });
        let w = context(&p, Vec3::splat(-4.0), Vec3::splat(4.0), WarpOptions { depth_lod: lod, ..WarpOptions::default() });
        let mut q: Vec<(Vec3, Vec3)> =
            queries.iter().map(|&(x, y, z, u, v)| (Vec3::new(x, y, z), octa::decode(Vec2::new(u, v)))).collect();
        q.push((a, q[0].1)); // at the probe: the query direction itself, not a rescaled copy
        let mut out = vec![Vec3::ZERO; q.len()];
        warp::depth::warp1_batch(&w.probe, &q, lod, &mut out);
        for (q, v) in q.iter().zip(&out) {
            let single = w.fetch_vector(Method::Warp1, q.0, q.1);
            prop_assert_eq!(bits(*v), bits(single), "query {:?}", q);
            prop_assert!(v.is_finite() && *v != Vec3::ZERO);
        }
    }
}

proptest! {
    /// The box proxy's lane form returns the per-lookup exit bit for bit: queries inside
    /// and outside the box, axis-parallel directions, zero components, B at the probe.
    #[test]
    fn box_lanes_are_bitwise_the_per_lookup_box(
        seed in 0u64..10_000,
        rot in -1.0f32..1.0,
        special in 0usize..4,
    ) {
        let bx = proxy::BoxProxy::oriented(
            Vec3::new(0.3, 1.1, -0.2),
            glam::Quat::from_rotation_y(rot),
            Vec3::new(2.0, 1.5, 3.0),
        );
        let a = Vec3::new(0.1, 1.0, 0.4);
        let mut b = [Vec3::ZERO; octa::LANES];
        let mut d = [Vec3::ZERO; octa::LANES];
        for k in 0..octa::LANES {
            let mut s = warpfit::sampling::Sampler::new(seed, 3, k as u32);
            b[k] = Vec3::new(s.next_1d() * 8.0 - 4.0, s.next_1d() * 5.0 - 1.5, s.next_1d() * 8.0 - 4.0);
            d[k] = warpfit::sampling::uniform_sphere(s.next_2d());
        }
        match special {
            1 => { d[0] = Vec3::X; d[1] = -Vec3::Y; d[2] = Vec3::new(0.0, 0.6, 0.8); }
            2 => { b[0] = a; b[5] = a; }
            3 => { d[3] = Vec3::ZERO; b[4] = Vec3::splat(f32::NAN); }
            _ => {}
        }
        let (t, has) = bx.exit_distance_soa(&octa::soa(&b), &octa::soa(&d));
        for k in 0..octa::LANES {
            let one = bx.exit_distance(b[k], d[k]);
            let lane = has[k].then_some(t[k]);
            prop_assert_eq!(lane.map(f32::to_bits), one.map(f32::to_bits), "lane {}: {:?} vs {:?}", k, lane, one);
        }
    }
}

#[test]
fn the_per_lookup_methods_are_every_method_but_reprojection_and_the_oracle() {
    let rest: Vec<Method> = Method::ALL.into_iter().filter(|m| !PER_LOOKUP.contains(m)).collect();
    assert_eq!(rest, [Method::Reproject, Method::Oracle]);
    let options = warpfit::warp::WarpOptions::standard();
    assert!(PER_LOOKUP.iter().all(|m| m.probe_reads(&options).is_some()), "each answers a lookup by reads of A");
}
