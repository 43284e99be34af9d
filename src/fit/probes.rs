//! Which probe each texel of a cell's map reads, where a scene has several.
//!
//! A texel's candidates are the probes that see the points its lookups hit: the true hits
//! of the cell's training queries whose direction is nearest that texel (as the runtime
//! picks a lookup's texel, `corrective::nearest_tap`), and the point the cell's own probe
//! sees along the texel's direction. A probe sees a point when its distance map, at the
//! texel nearest the point's direction, reaches at least that far (within
//! [`SEES_TOLERANCE`]); it sees a miss to the sky when it sees sky that way. The texel reads
//! the probe that sees most of its points, the nearest to the cell's probe of equals (less
//! parallax for the shift to correct), probe A the first of equally near ones. With one
//! probe every texel reads probe A and nothing is stored.

use crate::octa;
use crate::warp::corrective::nearest_tap;
use crate::warp::{Warp, WarpProbe};
use glam::Vec3;

/// A probe sees a point when it lies no farther than this factor of the probe's distance
/// towards it (a distance map holds the texel centre's distance; surfaces at an angle to it
/// differ within the texel).
pub const SEES_TOLERANCE: f32 = 1.05;

/// A point a cell's lookup hits: the query's origin, direction and the distance along it
/// (+inf: sky).
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub b: Vec3,
    pub dir: Vec3,
    pub t: f32,
}

/// Whether `probe` sees the point `hit` hits.
#[must_use]
pub fn sees(probe: &WarpProbe, hit: &Hit) -> bool {
    let level = &probe.inv_depth.levels[0];
    if !hit.t.is_finite() {
        return level.nearest(hit.dir) == 0.0;
    }
    let v = (hit.b + hit.dir * hit.t) - probe.position;
    let dist = v.length();
    if !(dist > 0.0 && dist.is_finite()) {
        return true;
    }
    let w = level.nearest(v);
    // w = 0: the probe saw nothing that way, so nothing stands in front of the point
    !(w > 0.0) || dist * w <= SEES_TOLERANCE
}

/// The probe map of a cell (`res`² texels, see the module docs): `hits` are its training
/// queries' true hits, `distance` the cell probe's distances per texel (from `origin`).
/// Empty when the warp has one probe.
#[must_use]
pub fn choose(warp: &Warp, origin: Vec3, res: u32, distance: &[f32], hits: &[Hit]) -> Vec<u8> {
    let k = warp.probe_count();
    if k <= 1 {
        return Vec::new();
    }
    let n2 = (res * res) as usize;
    let mut seen = vec![0u32; n2 * k];
    let mut tally = |texel: usize, hit: &Hit| {
        for p in 0..k {
            seen[texel * k + p] += u32::from(sees(warp.probe_at(p), hit));
        }
    };
    for (texel, &d) in distance.iter().enumerate().take(n2) {
        let dir = octa::texel_dir(res, texel as u32 % res, texel as u32 / res);
        tally(texel, &Hit { b: origin, dir, t: if d.is_finite() && d > 0.0 { d } else { f32::INFINITY } });
    }
    for h in hits {
        let texel = nearest_tap(&octa::bilinear_taps(res, octa::encode(h.dir))) as usize;
        tally(texel, h);
    }
    let near: Vec<f32> = (0..k).map(|p| (warp.probe_at(p).position - origin).length_squared()).collect();
    (0..n2)
        .map(|texel| {
            let counts = &seen[texel * k..(texel + 1) * k];
            let mut best = 0;
            for p in 1..k {
                if counts[p] > counts[best] || (counts[p] == counts[best] && near[p] < near[best]) {
                    best = p;
                }
            }
            best as u8
        })
        .collect()
}

/// The probe a cell reads when it reads one: the one most of its map's texels chose
/// (`map`, as [`choose`] gives it), the lowest index of equals.
#[must_use]
pub fn per_cell(map: &[u8]) -> u8 {
    let mut count = [0u32; 256];
    for &p in map {
        count[p as usize] += 1;
    }
    (0..=255u8).max_by(|&a, &b| count[a as usize].cmp(&count[b as usize]).then(b.cmp(&a))).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::octa::{OctMap, OctMips};
    use crate::warp::{Proxies, WarpOptions, proxy};

    /// A probe at `position` that sees a sphere of radius `d` around itself everywhere.
    fn probe(position: Vec3, d: f32) -> WarpProbe {
        let distance = OctMips { levels: vec![OctMap::new(8, vec![d; 64])] };
        let radiance = OctMips { levels: vec![OctMap::new(8, vec![Vec3::ONE; 64])] };
        WarpProbe::from_distance_mips(position, &distance, radiance, vec![0.0])
    }

    fn warp(probes: Vec<WarpProbe>) -> Warp {
        let mut probes = probes.into_iter();
        let first = probes.next().unwrap();
        let aabb = proxy::BoxProxy::aabb(Vec3::splat(-100.0), Vec3::splat(100.0));
        let kdop = proxy::Kdop::fit(first.position, &OctMap::new(8, vec![1.0f32; 64]));
        Warp {
            probe: first,
            others: probes.collect::<Vec<_>>().into(),
            proxies: Proxies { aabb, kdop },
            options: WarpOptions::standard(),
        }
    }

    #[test]
    fn a_texel_reads_the_probe_that_sees_its_hits_and_the_nearest_of_equals() {
        // probe A sees only 1 unit around it, probe 1 (10 away) sees everything
        let w = warp(vec![probe(Vec3::ZERO, 1.0), probe(Vec3::new(10.0, 0.0, 0.0), f32::INFINITY)]);
        let res = 4;
        let dir = Vec3::new(0.3, 0.4, 0.866).normalize();
        let texel = nearest_tap(&octa::bilinear_taps(res, octa::encode(dir))) as usize;
        // hits 5 units out: hidden from A, seen by probe 1
        let far = vec![Hit { b: Vec3::ZERO, dir, t: 5.0 }; 3];
        // the cell's own distances: 0.5 everywhere (both probes see them)
        let near = vec![0.5f32; (res * res) as usize];
        let map = choose(&w, Vec3::ZERO, res, &near, &far);
        assert_eq!(map[texel], 1, "the far hits are seen by probe 1 alone");
        // every other texel: both see the cell's own point; probe A is nearer the origin
        assert!(map.iter().enumerate().all(|(k, &p)| k == texel || p == 0), "{map:?}");
        // from an origin next to probe 1, the equals go to probe 1
        let map = choose(&w, Vec3::new(9.0, 0.0, 0.0), res, &[f32::INFINITY; 16], &[]);
        assert!(map.iter().all(|&p| p == 1), "{map:?}");
        // one probe: nothing stored
        assert!(choose(&warp(vec![probe(Vec3::ZERO, 1.0)]), Vec3::ZERO, res, &near, &far).is_empty());
    }

    #[test]
    fn sky_is_seen_by_a_probe_that_sees_sky_that_way() {
        let (closed, open) = (probe(Vec3::ZERO, 2.0), probe(Vec3::ZERO, f32::INFINITY));
        let sky = Hit { b: Vec3::ZERO, dir: Vec3::Y, t: f32::INFINITY };
        assert!(!sees(&closed, &sky) && sees(&open, &sky));
        // a point exactly at the probe is seen; a NaN distance never panics
        assert!(sees(&closed, &Hit { b: Vec3::ZERO, dir: Vec3::Y, t: 0.0 }));
        let _ = sees(&closed, &Hit { b: Vec3::ZERO, dir: Vec3::Y, t: f32::NAN });
    }
}
