//! Fit-side helpers of the corrective model: the distances a cell's map starts from. The
//! model itself (`Correctives`, `Blend`) and its runtime evaluation live in
//! `warp::corrective`, which the runtime sampler shares.

use crate::octa::OctMap;

/// Per texel of a `map_res`² map, the distance a cell's probe saw, from the grid's distance
/// moments: the mean hit distance (misses removed from the mean), reduced to `map_res` by
/// averaging inverse distance; +inf where most rays missed (sky). `hits` counts each
/// texel's rays that hit, of `samples`.
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
    map.texels.iter().map(|&w| crate::octa::distance_from_inverse(w)).collect()
}
