//! The small numeric helpers at the edges of f32: 0, −0, subnormals, ±∞, NaN and f32::MAX.
//! Each helper has a table of inputs and what it must return; none may return NaN or ±∞
//! where it promises a finite value.

use glam::{Vec2, Vec3};
use warpfit::grid::GridGeometry;
use warpfit::octa::{self, distance_from_inverse, inverse_distance};
use warpfit::trace::radiance::sanitize;
use warpfit::warp::corrective::shifted_aim;
use warpfit::warp::{depth, toward};

const SUB: f32 = 1e-40; // subnormal
const EDGES: [f32; 9] = [0.0, -0.0, SUB, -SUB, f32::MAX, -f32::MAX, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];

/// Compares bit patterns, so −0 and NaN are checked exactly.
fn check(name: &str, got: f32, want: f32) {
    let same = got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan());
    assert!(same, "{name}: got {got:e}, want {want:e}");
}

#[test]
fn inverse_distance_at_the_edges() {
    for (d, want) in [
        (0.0, f32::MAX),
        (-0.0, f32::MAX),
        (-1.0, f32::MAX),
        (SUB, f32::MAX), // 1/subnormal overflows: clamped
        (f32::MAX, 1.0 / f32::MAX),
        (f32::INFINITY, 0.0),
        (f32::NEG_INFINITY, 0.0),
        (f32::NAN, 0.0),
        (2.0, 0.5),
    ] {
        check(&format!("inverse_distance({d:e})"), inverse_distance(d), want);
    }
    for (w, want) in [
        (0.0, f32::INFINITY),
        (-0.0, f32::INFINITY),
        (-3.0, f32::INFINITY),
        (f32::NAN, f32::INFINITY),
        (f32::INFINITY, 0.0),
        (0.5, 2.0),
    ] {
        check(&format!("distance_from_inverse({w:e})"), distance_from_inverse(w), want);
    }
    // the way there and back keeps sky as sky and ordinary distances exact
    for d in [f32::INFINITY, 1.0, 4.0, 1e-3, 1e6] {
        check(&format!("round trip {d:e}"), distance_from_inverse(inverse_distance(d)), d);
    }
}

#[test]
fn encode_never_leaves_the_map() {
    for x in EDGES {
        for y in EDGES {
            for z in EDGES {
                let uv = octa::encode(Vec3::new(x, y, z));
                assert!(uv.is_finite() && uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all(), "{x} {y} {z}: {uv}");
            }
        }
    }
    // degenerate vectors go to the map centre (+Z)
    for v in [Vec3::ZERO, Vec3::splat(SUB), Vec3::NAN, Vec3::INFINITY, Vec3::new(f32::MAX, f32::MAX, 0.0)] {
        let uv = octa::encode(v);
        assert!(uv == Vec2::splat(0.5) || v.x == f32::MAX, "{v}: {uv}");
    }
    // decode clamps any uv and returns a unit vector
    for u in EDGES {
        let d = octa::decode(Vec2::new(u, 0.25));
        assert!(d.is_finite() && (d.length() - 1.0).abs() < 1e-5 || u.is_nan(), "decode({u}): {d}");
    }
}

#[test]
fn toward_falls_back_where_it_cannot_point() {
    let fb = Vec3::Y;
    for (to, want) in [
        (Vec3::ZERO, fb),
        (Vec3::splat(SUB), fb), // squared length underflows to 0
        (Vec3::INFINITY, fb),
        (Vec3::NAN, fb),
        (Vec3::new(f32::MAX, 0.0, 0.0), fb), // squared length overflows
        (Vec3::new(3.0, 0.0, 4.0), Vec3::new(0.6, 0.0, 0.8)),
    ] {
        assert_eq!(toward(Vec3::ZERO, to, fb), want, "toward {to}");
        assert_eq!(depth::fetch_vector(Vec3::ZERO, to, fb) == fb, want == fb, "fetch_vector {to}");
    }
}

#[test]
fn the_corrective_step_is_finite_for_any_shift_and_proxy_distance() {
    let (b, dir, a) = (Vec3::new(1.2, 0.1, 0.0), Vec3::Z, Vec3::new(-1.0, 0.0, 0.5));
    for t in EDGES.into_iter().map(Some).chain([None]) {
        for delta in EDGES {
            let aim = shifted_aim(a, t, delta, b, dir);
            assert!(aim.v.is_finite() && aim.v != Vec3::ZERO, "t = {t:?}, shift {delta:e}: {:?}", aim.v);
            assert!(aim.k.is_some_and(|k| k.is_finite() && k > 0.0), "t = {t:?}, shift {delta:e}: {:?}", aim.k);
        }
    }
    // B outside the proxy, or a ray through an open side: the query direction itself
    for t in [None, Some(f32::INFINITY), Some(f32::NAN)] {
        assert_eq!(shifted_aim(a, t, 0.5, b, dir).v, dir, "t = {t:?}");
    }
    // a surface shifted to or behind B: the aim is B itself
    let at_b = shifted_aim(a, Some(2.0), -5.0, b, dir).v;
    assert!((at_b - (b - a)).length() < 1e-6, "{at_b}");
    // B at the probe: the query direction
    assert_eq!(shifted_aim(a, Some(2.0), 0.5, a, dir).v, dir);
}

#[test]
fn sanitize_zeroes_what_is_not_finite() {
    for x in EDGES {
        let s = sanitize(Vec3::new(x, 1.0, x));
        let want = if x.is_finite() { x } else { 0.0 };
        check(&format!("sanitize({x:e})"), s.x, want);
        assert_eq!(s.y, 1.0);
    }
}

#[test]
fn cell_lookups_clamp_every_position_into_the_grid() {
    let g = GridGeometry { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), counts: glam::UVec3::new(4, 2, 3) };
    for x in EDGES {
        let c = g.cell_of(Vec3::new(x, 0.3, -x));
        assert!(c.cmplt(g.counts).all(), "cell_of({x:e}) = {c}");
    }
    assert_eq!(g.cell_of(Vec3::splat(-1.0)), glam::UVec3::ZERO);
    assert_eq!(g.cell_of(Vec3::splat(1.0)), g.counts - glam::UVec3::ONE);
}

#[test]
fn the_lanes_find_the_cells_the_single_lookup_finds() {
    use warpfit::octa::{LANES, soa};
    // a small grid, and one with an axis past 2²² cells, where the float → integer step is
    // no longer exact and must still stay inside the grid
    let grids = [
        GridGeometry { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), counts: glam::UVec3::new(4, 2, 3) },
        GridGeometry { min: Vec3::ZERO, max: Vec3::new(1.0, 1.0, 16.0), counts: glam::UVec3::new(1, 1, 1 << 23) },
    ];
    for g in grids {
        let size = g.cell_size();
        let mut points: Vec<Vec3> = Vec::new();
        for x in EDGES.into_iter().chain([0.5, 0.999_999_9, 1.0, 8.000_001, 15.999_999, 16.0]) {
            points.push(Vec3::new(x, 0.3, -x));
            points.push(Vec3::new(0.25, -x, x));
            points.push(Vec3::splat(x));
        }
        for chunk in points.chunks(LANES) {
            let mut lanes = [Vec3::ZERO; LANES];
            lanes[..chunk.len()].copy_from_slice(chunk);
            let cells = g.cell_index_soa(&soa(&lanes), size);
            for (k, p) in lanes.iter().enumerate() {
                let c = g.cell_of_sized(*p, size);
                assert!(c.cmplt(g.counts).all(), "{p}: {c}");
                assert_eq!(cells[k], g.cell_index(c), "{p}");
            }
        }
    }
}

#[test]
fn the_roughness_lookup_stays_in_range() {
    let lut = warpfit::roughness::fit_correction();
    for a in EDGES.into_iter().chain([0.3, 1.0, 2.0]) {
        for k in EDGES.into_iter().chain([0.5, 1.0, 8.0]) {
            let ap = lut.corrected_alpha(a, k);
            assert!(ap.is_finite() && (1e-3..=1.0).contains(&ap), "α {a:e} k {k:e}: {ap}");
        }
    }
    // no correction at k = 1 (within the table's accuracy)
    assert!((lut.corrected_alpha(0.25, 1.0) - 0.25).abs() < 0.02);
}
