//! Fit-side helpers of the corrective model: the distances a cell's map starts from. The
//! model itself (`Correctives`, `Blend`) and its runtime evaluation live in
//! `warp::corrective`, which the runtime sampler shares.

use crate::octa::OctMap;

/// Per texel of a `map_res`² map, the distance a cell's probe saw, from the grid's distance
/// moments: the mean hit distance (misses removed from the mean), reduced to `map_res` by
/// averaging inverse distance, or, for a map finer than the moments, each map texel taking
/// the moment texel that holds it; +inf where most rays missed (sky). `hits` counts each
/// texel's rays that hit, of `samples`. Both resolutions are powers of two.
#[must_use]
pub fn celldepth_distances(
    depth_res: u32,
    mean: &[f32],
    hits: &[u8],
    samples: u32,
    far: f32,
    map_res: u32,
) -> Vec<f32> {
    let inv: Vec<f32> = mean
        .iter()
        .zip(hits)
        .map(|(&m, &n)| {
            let h = crate::bake::grid::hit_fraction(n, samples);
            if h < 0.5 {
                return 0.0;
            }
            let hits_mean = (m - (1.0 - h) * far) / h;
            if hits_mean > 0.0 && hits_mean.is_finite() { 1.0 / hits_mean } else { 0.0 }
        })
        .collect();
    let mut map = OctMap::new(depth_res, inv);
    while map.res > map_res && map.res.is_multiple_of(2) {
        map = map.downsample();
    }
    if map.res < map_res && map_res.is_multiple_of(map.res) {
        let f = map_res / map.res;
        let texels = (0..map_res * map_res)
            .map(|k| map.texels[((k / map_res / f) * map.res + (k % map_res) / f) as usize])
            .collect();
        map = OctMap::new(map_res, texels);
    }
    map.texels.iter().map(|&w| crate::octa::distance_from_inverse(w)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_map_finer_than_the_moments_takes_the_texel_that_holds_each_of_its_texels() {
        // 2×2 moments, every ray a hit, distances 1, 2, 3, 4 (far: 100, one sample)
        let (mean, hits) = (vec![1.0, 2.0, 3.0, 4.0], vec![1u8; 4]);
        let same = celldepth_distances(2, &mean, &hits, 1, 100.0, 2);
        assert_eq!(same, vec![1.0, 2.0, 3.0, 4.0]);
        let fine = celldepth_distances(2, &mean, &hits, 1, 100.0, 4);
        assert_eq!(fine.len(), 16);
        #[rustfmt::skip]
        let want = [1.0, 1.0, 2.0, 2.0,
                    1.0, 1.0, 2.0, 2.0,
                    3.0, 3.0, 4.0, 4.0,
                    3.0, 3.0, 4.0, 4.0];
        for (k, (d, w)) in fine.iter().zip(want).enumerate() {
            assert!((d - w).abs() <= 1e-6 * w, "texel {k}: {d} against {w}");
        }
        // coarser: one texel, the mean of the inverse distances
        let coarse = celldepth_distances(2, &mean, &hits, 1, 100.0, 1);
        let inv = (1.0 + 0.5 + 1.0 / 3.0 + 0.25) / 4.0;
        assert!((coarse[0] - 1.0 / inv).abs() < 1e-5, "{coarse:?}");
    }
}
