//! Deterministic low-discrepancy sampling and the warping functions that turn uniform samples
//! into directions (cosine hemisphere, cone, GGX), each with its pdf.
//!
//! Every random decision in warpfit comes from a [`Sampler`] seeded by (scene seed, stream,
//! sample index): no global state and no dependence on thread scheduling, so bakes are
//! bit-identical at any thread count. Sequences are the R-sequences of Roberts (2018,
//! "The unreasonable effectiveness of quasirandom sequences") with a hashed Cranley–Patterson
//! rotation per stream and dimension.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// SplitMix64 finaliser: a well-mixed 64-bit hash.
#[inline]
#[must_use]
pub fn hash64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Combines two values into one hash (order matters).
#[inline]
#[must_use]
pub fn hash_pair(a: u64, b: u64) -> u64 {
    hash64(a ^ hash64(b).rotate_left(17))
}

/// Uniform f64 in [0,1) from a hash.
#[inline]
fn unit_from_hash(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Plastic number: R2 generator (Roberts 2018).
const PLASTIC: f64 = 1.324_717_957_244_746;
const R2_A1: f64 = 1.0 / PLASTIC;
const R2_A2: f64 = 1.0 / (PLASTIC * PLASTIC);
const GOLDEN_FRAC: f64 = 0.618_033_988_749_894_9;

/// Generators of the dimensions after the first: the fractional parts of √p for the primes
/// p ≠ 5 (Richtmyer's sequence). With 1/φ and the plastic number's R2 pair of the first
/// dimension they are linearly independent over the rationals, so every dimension advances
/// differently and the joint sequence fills the product space (were the generators equal,
/// the draws of one sample would be shifted copies of each other: positions on a line
/// through a cell, bounce directions locked to the first direction). Dimension `d ≥ 2` uses
/// `ALPHAS[2(d−2)]` (1-D) or `ALPHAS[2(d−2)..][..2]` (2-D); beyond the table, hashed white
/// noise.
#[allow(clippy::excessive_precision, clippy::unreadable_literal)]
const ALPHAS: [f64; 48] = [
    0.41421356237309503,
    0.7320508075688773,
    0.6457513110645906,
    0.31662479035539987,
    0.6055512754639893,
    0.12310562561766054,
    0.35889894354067353,
    0.7958315233127196,
    0.385164807134504,
    0.567764362830022,
    0.08276253029821969,
    0.4031242374328487,
    0.5574385243020007,
    0.8556546004010441,
    0.2801098892805183,
    0.6811457478686082,
    0.8102496759066544,
    0.18535277187244997,
    0.4261497731763586,
    0.5440037453175312,
    0.8881944173155889,
    0.11043357914429888,
    0.4339811320566038,
    0.8488578017961047,
    0.04987562112089027,
    0.14889156509221946,
    0.34408043278860045,
    0.4403065089105502,
    0.6301458127346494,
    0.26942766958464487,
    0.44552314225959705,
    0.7046999107196251,
    0.789826122551596,
    0.20655561573370296,
    0.28820572744450756,
    0.5299640861416678,
    0.7671453348037046,
    0.9228479833200854,
    0.15294643796590543,
    0.37908816025965203,
    0.4536240470737103,
    0.8202749610852533,
    0.8924439894498045,
    0.035668847618199634,
    0.10673597966588443,
    0.5258390463339501,
    0.9331845230680786,
    0.06651917331936362,
];

/// Per-stream sampler: sample `index` of a low-discrepancy sequence, one rotation per
/// dimension. Consecutive indices of the same stream are well stratified.
#[derive(Clone, Copy, Debug)]
pub struct Sampler {
    stream: u64,
    index: u64,
    dim: u64,
}

impl Sampler {
    #[must_use]
    pub fn new(seed: u64, stream: u64, index: u32) -> Self {
        Self { stream: hash_pair(seed, stream), index: index as u64, dim: 0 }
    }

    #[inline]
    fn rotation(&mut self) -> u64 {
        self.dim += 1;
        hash_pair(self.stream, self.dim)
    }

    /// The generators of the current dimension (`None`: past the table, white noise).
    #[inline]
    fn generators(&self) -> Option<(f64, f64)> {
        match self.dim {
            1 => Some((R2_A1, R2_A2)),
            d => ALPHAS.get(2 * (d as usize - 2)..2 * (d as usize - 2) + 2).map(|a| (a[0], a[1])),
        }
    }

    /// Next 2-D sample in [0,1)².
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let h = self.rotation();
        let ox = unit_from_hash(h);
        let oy = unit_from_hash(hash64(h));
        let n = self.index as f64;
        let (x, y) = match self.generators() {
            Some((a1, a2)) => (fract(ox + n * a1), fract(oy + n * a2)),
            None => {
                let w = hash_pair(h, self.index);
                (unit_from_hash(w), unit_from_hash(hash64(w)))
            }
        };
        Vec2::new(to_unit_f32(x), to_unit_f32(y))
    }

    /// Next 1-D sample in [0,1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let h = self.rotation();
        let o = unit_from_hash(h);
        let x = match (self.dim, self.generators()) {
            (1, _) => fract(o + self.index as f64 * GOLDEN_FRAC),
            (_, Some((a, _))) => fract(o + self.index as f64 * a),
            (_, None) => unit_from_hash(hash_pair(h, self.index)),
        };
        to_unit_f32(x)
    }
}

/// `x.fract()` for the sequences' non-negative sums (`x − trunc(x)`, the same value): the
/// truncation as a conversion, not a call (x86-64's baseline has no rounding instruction,
/// and `trunc` is a library call on every sample).
#[inline(always)]
fn fract(x: f64) -> f64 {
    if x > 0.0 && x < 4.0e18 { x - (x as i64) as f64 } else { x.fract() }
}

/// f64 in [0,1) to f32 in [0,1) (rounding could otherwise produce 1.0).
#[inline]
fn to_unit_f32(x: f64) -> f32 {
    (x as f32).min(1.0 - f32::EPSILON / 2.0)
}

pub use crate::octa::orthonormal_basis;

/// Local (x, y, z) with z along `n` to world.
#[inline]
#[must_use]
pub fn to_world(local: Vec3, n: Vec3) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    t * local.x + b * local.y + n * local.z
}

/// Cosine-weighted hemisphere direction around `n` (Malley's method); pdf = cosθ/π.
#[inline]
#[must_use]
pub fn cosine_hemisphere(u: Vec2, n: Vec3) -> Vec3 {
    let r = u.x.sqrt();
    let (sin_phi, cos_phi) = libm::sincosf(2.0 * PI * u.y);
    let local = Vec3::new(r * cos_phi, r * sin_phi, (1.0 - u.x).max(0.0).sqrt());
    to_world(local, n)
}

/// Uniform direction in the cone of half-angle acos(`cos_max`) around `axis`;
/// pdf = 1 / (2π (1 − cos_max)).
#[inline]
#[must_use]
pub fn uniform_cone(u: Vec2, axis: Vec3, cos_max: f32) -> Vec3 {
    let cos_t = 1.0 - u.x * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (sin_phi, cos_phi) = libm::sincosf(2.0 * PI * u.y);
    to_world(Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t), axis)
}

/// Uniform direction on the sphere; pdf = 1/(4π).
#[inline]
#[must_use]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = libm::sincosf(2.0 * PI * u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// GGX (Trowbridge–Reitz) normal distribution D(h) for `cos_h` = n·h and roughness `alpha`
/// (Walter et al. 2007).
#[inline]
#[must_use]
pub fn ggx_d(cos_h: f32, alpha: f32) -> f32 {
    let a2 = (alpha * alpha).max(1e-12);
    let c2 = cos_h * cos_h;
    let d = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Importance-samples a GGX half vector around `n`; pdf(h) = D(h) · (n·h).
#[inline]
#[must_use]
pub fn ggx_half_vector(u: Vec2, n: Vec3, alpha: f32) -> Vec3 {
    let a2 = alpha * alpha;
    let cos_t = ((1.0 - u.x) / (1.0 + (a2 - 1.0) * u.x)).max(0.0).sqrt();
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (sin_phi, cos_phi) = libm::sincosf(2.0 * PI * u.y);
    to_world(Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t), n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_in_unit_square_and_deterministic() {
        for i in 0..1000 {
            let mut a = Sampler::new(7, 3, i);
            let mut b = Sampler::new(7, 3, i);
            let (x, y) = (a.next_2d(), b.next_2d());
            assert_eq!(x, y);
            assert!(x.x >= 0.0 && x.x < 1.0 && x.y >= 0.0 && x.y < 1.0);
        }
    }

    /// Draws of one sample fill the product space: a product of indicators over two
    /// dimensions averages to the product of their means, for every pair of the first 30
    /// dimensions, 1-D and 2-D alike, past the generator table too.
    #[test]
    fn dimensions_are_independent() {
        let n = 4096;
        for (kind_a, kind_b) in [(1, 1), (2, 2), (1, 2), (2, 1)] {
            for (da, db) in (1..30).flat_map(|a| (a + 1..31).map(move |b| (a, b))) {
                let mut quad = [0u32; 16];
                for i in 0..n {
                    let mut s = Sampler::new(3, 11, i);
                    let (mut x, mut y) = (0.0, 0.0);
                    for d in 1..=db {
                        let v = if (d == da && kind_a == 1) || (d == db && kind_b == 1) {
                            Vec2::splat(s.next_1d())
                        } else {
                            s.next_2d()
                        };
                        if d == da {
                            x = v.x;
                        }
                        if d == db {
                            y = v.y;
                        }
                    }
                    quad[(x * 4.0) as usize * 4 + (y * 4.0) as usize] += 1;
                }
                // each of the 16 cells of [0,1)² holds n/16 = 256 draws; a line through the
                // square (the failure) leaves most near empty; white noise past the table spreads ±6σ
                let (lo, hi) = (quad.iter().min().unwrap(), quad.iter().max().unwrap());
                assert!(*lo > 160 && *hi < 352, "dims {da} ({kind_a}-D) and {db} ({kind_b}-D): {quad:?}");
            }
        }
    }

    #[test]
    fn basis_is_orthonormal() {
        for k in 0..500 {
            let n = uniform_sphere(Sampler::new(1, 0, k).next_2d());
            let (t, b) = orthonormal_basis(n);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!(t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5 && t.dot(b).abs() < 1e-5);
        }
    }

    #[test]
    fn ggx_d_integrates_projected_to_one() {
        // ∫ D(h) (n·h) dω = 1 for any alpha.
        for alpha in [0.1f32, 0.3, 0.7, 1.0] {
            let steps = 20000;
            let mut sum = 0.0f64;
            for k in 0..steps {
                let t = (k as f64 + 0.5) / steps as f64 * std::f64::consts::FRAC_PI_2;
                let d = ggx_d(libm::cos(t) as f32, alpha) as f64;
                sum += d
                    * libm::cos(t)
                    * libm::sin(t)
                    * 2.0
                    * std::f64::consts::PI
                    * (std::f64::consts::FRAC_PI_2 / steps as f64);
            }
            assert!((sum - 1.0).abs() < 2e-3, "alpha {alpha}: {sum}");
        }
    }

    /// The samplers' angle φ = 2π·u, u in [0, 1), gives the same sine and cosine from one
    /// `sincosf` as from `sinf` and `cosf` apart, for every f32 in [0, 2π] (about 1.1e9
    /// values, a few seconds on two threads), and the sequences' `fract` is `f64::fract`
    /// bit for bit.
    #[test]
    fn the_fast_paths_give_the_same_bits() {
        use rayon::prelude::*;
        let end = (2.0 * PI).to_bits();
        let differ = (0..=end / 4096)
            .into_par_iter()
            .map(|block| {
                (block * 4096..=(block * 4096 + 4095).min(end))
                    .filter(|&bits| {
                        let phi = f32::from_bits(bits);
                        let (s, c) = libm::sincosf(phi);
                        (s.to_bits(), c.to_bits()) != (libm::sinf(phi).to_bits(), libm::cosf(phi).to_bits())
                    })
                    .count()
            })
            .sum::<usize>();
        assert_eq!(differ, 0, "angles where sincosf differs from sinf/cosf");
        let mut xs = vec![0.0, -0.0, 1e-300, 0.5, 1.0, 2.5, 1e15 + 0.25, 2f64.powi(53), 3.9e18, 4.0e18, 1e300, -2.5];
        xs.extend((0..100_000u32).map(|k| unit_from_hash(hash64(k as u64)) + k as f64 * R2_A1));
        for x in xs {
            assert_eq!(fract(x).to_bits(), x.fract().to_bits(), "x {x}");
        }
    }
}
