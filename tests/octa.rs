//! Octahedral mapping: round trips, seam continuity, exact solid angles, mip topology; and
//! the band-2 harmonics projected from octahedral maps.

use glam::{Vec2, Vec3};
use proptest::prelude::*;
use warpfit::octa::{self, OctMap, build_mips, texel_solid_angles};

fn unit(x: f32, y: f32, z: f32) -> Option<Vec3> {
    let v = Vec3::new(x, y, z);
    (v.length() > 1e-3).then(|| v.normalize())
}

proptest! {
    #[test]
    fn round_trip(x in -1.0f32..1.0, y in -1.0f32..1.0, z in -1.0f32..1.0) {
        if let Some(v) = unit(x, y, z) {
            let back = octa::decode(octa::encode(v));
            prop_assert!((back - v).length() < 2e-6, "{v} -> {back}");
        }
    }

    #[test]
    fn uv_round_trip(u in 0.0f32..1.0, v in 0.0f32..1.0) {
        let uv = Vec2::new(u, v);
        let back = octa::encode(octa::decode(uv));
        // The outer edge folds onto itself; compare directions there instead of uv.
        let same_dir = (octa::decode(back) - octa::decode(uv)).length() < 2e-6;
        prop_assert!((back - uv).length() < 2e-6 || same_dir, "{uv} -> {back}");
    }

    /// A smooth function of direction, sampled bilinearly, stays continuous across the seams:
    /// two directions a hair apart on opposite sides of a fold give nearly the same value.
    #[test]
    fn bilinear_is_continuous_across_seams(t in -0.99f32..0.99, side in 0usize..4) {
        let f = |d: Vec3| d.x * 0.3 + d.y * 0.5 - d.z * 0.7 + 2.0;
        let map = OctMap::from_fn(64, |_, _, d| f(d));
        // points on the lower hemisphere's outer edge: u=0, u=1, v=0, v=1
        let edge = match side {
            0 => Vec2::new(0.0, t * 0.5 + 0.5),
            1 => Vec2::new(1.0, t * 0.5 + 0.5),
            2 => Vec2::new(t * 0.5 + 0.5, 0.0),
            _ => Vec2::new(t * 0.5 + 0.5, 1.0),
        };
        let d = octa::decode(edge);
        let eps = 1e-3;
        // step slightly to either side of the seam (in 3-D, normal to the fold)
        let across = Vec3::new(if side < 2 { 0.0 } else { 1.0 }, if side < 2 { 1.0 } else { 0.0 }, 0.0);
        let (a, b) = ((d + across * eps).normalize(), (d - across * eps).normalize());
        let (va, vb) = (map.bilinear(a), map.bilinear(b));
        prop_assert!((va - vb).abs() < 0.05, "seam jump {va} vs {vb} at {d}");
        prop_assert!((map.bilinear(d) - f(d)).abs() < 0.05);
    }
}

proptest! {
    /// The bilinear footprint's top-left texel is floor(uv·N − ½) and its fractions are the
    /// remainders, for every resolution in use (the floor is computed without `floorf`).
    #[test]
    fn footprint_is_the_floor(u in -0.1f32..1.1, v in -0.1f32..1.1, log_res in 1u32..13) {
        let res = 1u32 << log_res;
        let f = octa::footprint(res, Vec2::new(u, v));
        let x = u.clamp(0.0, 1.0) * res as f32 - 0.5;
        let y = v.clamp(0.0, 1.0) * res as f32 - 0.5;
        prop_assert_eq!((f.i0, f.j0), (x.floor() as i32, y.floor() as i32));
        prop_assert_eq!((f.fx, f.fy), (x - x.floor(), y - y.floor()));
    }

    /// The lane forms of encode and of the bilinear lookup return exactly the scalar values,
    /// seams and poles included.
    #[test]
    fn lanes_equal_scalar_lookups_bit_for_bit(seed in 0u32..1000) {
        let map = OctMap::from_fn(16, |i, j, d| d * (1.0 + (i * 7 + j * 3) as f32));
        let specials = [Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::ZERO, Vec3::NAN,
            Vec3::new(1.0, -1.0, 0.0), Vec3::new(-1.0, 0.0, -1e-30), Vec3::INFINITY, Vec3::new(1e-45, 0.0, -1e-45)];
        let dirs: [Vec3; octa::LANES] = std::array::from_fn(|k| {
            if k % 3 == 0 {
                specials[(seed as usize + k) % specials.len()]
            } else {
                warpfit::sampling::uniform_sphere(warpfit::sampling::Sampler::new(5, seed as u64, k as u32).next_2d())
            }
        });
        let uv = octa::encode_lanes(&dirs);
        let values = map.bilinear_uv_lanes(&uv);
        for k in 0..octa::LANES {
            let e = octa::encode(dirs[k]);
            prop_assert!(e.is_finite() && values[k].is_finite(), "{}", dirs[k]);
            prop_assert_eq!((uv.u[k].to_bits(), uv.v[k].to_bits()), (e.x.to_bits(), e.y.to_bits()));
            prop_assert_eq!(values[k].to_array().map(f32::to_bits), map.bilinear_uv(e).to_array().map(f32::to_bits));
        }
    }
}

#[test]
fn bilinear_reproduces_smooth_function() {
    let f = |d: Vec3| 1.0 + d.x * 0.5 + d.y * d.y - d.z * 0.25;
    let map = OctMap::from_fn(128, |_, _, d| f(d));
    let mut worst = 0.0f32;
    for k in 0..2000 {
        let u = Vec2::new((k as f32 * 0.618_034).fract(), (k as f32 * 0.754_878).fract());
        let d = octa::decode(u);
        worst = worst.max((map.bilinear(d) - f(d)).abs());
    }
    assert!(worst < 0.02, "worst bilinear error {worst}");
}

#[test]
fn solid_angles_sum_to_4pi_and_are_positive() {
    for res in [8u32, 16, 32, 128] {
        let w = texel_solid_angles(res);
        assert!(w.iter().all(|&x| x > 0.0));
        let sum: f64 = w.iter().map(|&x| x as f64).sum();
        assert!((sum - 4.0 * std::f64::consts::PI).abs() < 1e-4, "{res}: {sum}");
    }
}

#[test]
fn solid_angles_match_numerical_integration() {
    // Compare against a dense Monte-Carlo-free count: uniform sphere points binned per texel.
    let res = 8u32;
    let w = texel_solid_angles(res);
    let n = 400_000u32;
    let mut counts = vec![0u32; (res * res) as usize];
    for k in 0..n {
        // Fibonacci sphere
        let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = k as f64 * 2.399_963_229_728_653;
        let d = Vec3::new((r * libm::cos(phi)) as f32, (r * libm::sin(phi)) as f32, z as f32);
        let (i, j) = octa::texel_of_uv(res, octa::encode(d));
        counts[(j * res + i) as usize] += 1;
    }
    for (t, &c) in counts.iter().enumerate() {
        let est = c as f64 / n as f64 * 4.0 * std::f64::consts::PI;
        assert!((est - w[t] as f64).abs() / (w[t] as f64) < 0.01, "texel {t}: {est} vs {}", w[t]);
    }
}

#[test]
fn mips_preserve_the_solid_angle_weighted_mean() {
    let map = OctMap::from_fn(64, |_, _, d| 1.0 + d.x + 2.0 * d.z * d.z);
    let mips = build_mips(map, 4);
    assert_eq!(mips.levels.iter().map(|l| l.res).collect::<Vec<_>>(), vec![64, 32, 16, 8, 4]);
    let mean = |m: &OctMap<f32>| {
        let w = texel_solid_angles(m.res);
        m.texels.iter().zip(&w).map(|(v, w)| (*v * *w) as f64).sum::<f64>() / (4.0 * std::f64::consts::PI)
    };
    let m0 = mean(&mips.levels[0]);
    for l in &mips.levels {
        assert!((mean(l) - m0).abs() < 1e-4, "res {}: {} vs {m0}", l.res, mean(l));
    }
}

#[test]
fn seam_convention_pinned() {
    // The spec in the manifest: texel (i, j) centre at ((i+.5)/N, (j+.5)/N), row 0 first.
    let d = octa::texel_dir(4, 0, 0);
    assert!(d.z < 0.0 && d.x < 0.0 && d.y < 0.0, "{d}");
    let d = octa::texel_dir(4, 1, 1);
    assert!(d.z > 0.0 && d.x < 0.0 && d.y < 0.0, "{d}");
}

// The band-2 harmonics a rough lookup blends in (`warpfit::sh`), projected from maps on
// this octahedral layout.
proptest! {
    #[test]
    fn harmonics_are_linear_in_the_map_and_finite_and_non_negative_everywhere(
        a in proptest::collection::vec(0.0f32..100.0, 64),
        b in proptest::collection::vec(0.0f32..100.0, 64),
        k in 0.001f32..1000.0,
        x in -1.0f32..1.0, y in -1.0f32..1.0, z in -1.0f32..1.0,
    ) {
        use warpfit::sh;
        let w = sh::projection_weights(8);
        let map = |v: &[f32]| v.iter().map(|&e| Vec3::new(e, 0.5 * e, 0.25 * e)).collect::<Vec<_>>();
        let (ma, mb) = (map(&a), map(&b));
        let sum: Vec<Vec3> = ma.iter().zip(&mb).map(|(p, q)| *p + *q).collect();
        let scaled: Vec<Vec3> = ma.iter().map(|p| *p * k).collect();
        let (ca, cb, cs, ck) = (sh::project(&ma, &w), sh::project(&mb, &w), sh::project(&sum, &w), sh::project(&scaled, &w));
        // linear to rounding: what keeps the evaluation's emitted/rest split of the blend
        // exact wherever the clamp at 0 does not act
        let scale = ca.iter().chain(&cb).map(|c| c.abs().max_element()).fold(1e-6f32, f32::max);
        for i in 0..sh::COEFFS {
            prop_assert!((cs[i] - (ca[i] + cb[i])).abs().max_element() <= 1e-5 * scale, "coefficient {i}");
            prop_assert!((ck[i] - ca[i] * k).abs().max_element() <= 1e-5 * scale * k, "coefficient {i} scaled");
        }
        if let Some(d) = unit(x, y, z) {
            for c in [&ca, &cb, &cs, &ck] {
                let e = sh::eval(c, d);
                prop_assert!(e.is_finite() && e.min_element() >= 0.0, "{d}: {e}");
            }
        }
    }
}
