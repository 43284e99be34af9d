//! Fit-side helpers of the corrective model: the maps a cell's fit starts from. The model
//! itself (`Correctives`, `Blend`) and its runtime evaluation live in `warp::corrective`,
//! which the runtime sampler shares.

use crate::octa::OctMap;
pub use crate::warp::corrective::box_map;

/// Initial warp map of a cell from the grid's distance moments: inverse of the mean hit
/// distance per texel (misses removed from the mean), 0 where most rays missed; reduced to
/// `map_res` by averaging inverse distance.
pub fn initial_map(depth_res: u32, mean: &[f32], hit: &[f32], far: f32, map_res: u32) -> Vec<f32> {
    let inv: Vec<f32> = mean
        .iter()
        .zip(hit)
        .map(|(&m, &h)| {
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
    map.texels
}
