//! What a reflection sees from an open validation position, as octahedral maps: the
//! raytraced reference, then probe A warped by several methods and the fitted grid. The
//! report draws them (`eval_views.png`).

use super::methods::{CorrectiveRow, CorrectiveVariant};
use super::validation::ValidationSet;
use crate::octa::{self, OctMap};
use crate::sampling::{Sampler, uniform_sphere};
use crate::scene::Scene;
use crate::trace::{Renderer, Tracer, trace_batch, truth};
use crate::warp::{Method, Warp};
use glam::Vec3;

/// Tiles of the view figure and its title.
pub struct Views {
    pub title: String,
    pub tiles: Vec<(String, OctMap<Vec3>)>,
}

/// Resolution of each view tile.
const VIEW_RES: u32 = 128;

/// The views from the most open of the first 32 validation positions (largest nearest-hit
/// distance over 64 directions: a view hugging a column shows mostly that column).
pub fn views(
    scene: &Scene,
    tracer: &Tracer,
    warp: &Warp,
    set: &ValidationSet,
    reference_spp: u32,
    seed: u64,
    corrective_rows: &[CorrectiveRow],
) -> Option<Views> {
    let openness = |b: Vec3| {
        (0..64u32)
            .map(|k| uniform_sphere(Sampler::new(5, 0, k).next_2d()))
            .map(|d| tracer.closest_hit(b, d, f32::INFINITY).map_or(f32::INFINITY, |h| h.t))
            .fold(f32::INFINITY, f32::min)
    };
    let &b = set.positions.iter().take(32).max_by(|p, q| openness(**p).total_cmp(&openness(**q)))?;
    let res = VIEW_RES;
    let dirs: Vec<Vec3> = (0..res * res).map(|t| octa::texel_dir(res, t % res, t / res)).collect();
    let renderer = Renderer::new(scene, tracer);
    let origins = vec![b; dirs.len()];
    let (reference, _) = trace_batch(&renderer, &origins, &dirs, seed, 0x7E5, reference_spp);
    let mut tiles = vec![("reference".to_string(), OctMap::new(res, reference.iter().map(|r| r.radiance).collect()))];
    for m in [Method::None, Method::Box, Method::Warp1, Method::Raymarch] {
        tiles.push((m.name().to_string(), OctMap::new(res, dirs.iter().map(|&d| warp.lookup(m, b, d)).collect())));
    }
    for r in corrective_rows.iter().filter(|r| r.variant == CorrectiveVariant::Fitted) {
        let blend = r.variant.blend();
        let read = |d: Vec3| {
            let aim = r.correctives.fetch(blend, warp, b, d, 0.0);
            warp.probe_at(aim.probe.into()).radiance(aim.v)
        };
        let map = dirs.iter().map(|&d| read(d)).collect();
        tiles.push((r.variant.name().to_string(), OctMap::new(res, map)));
    }
    let a = warp.probe.position;
    let oracle = dirs.iter().map(|&d| warp.probe.radiance(truth::oracle(scene, tracer, a, b, d).0)).collect();
    tiles.push(("oracle".to_string(), OctMap::new(res, oracle)));
    let title = format!(
        "{}: seen from validation position ({:.2}, {:.2}, {:.2}); octahedral maps, +Z at the centre",
        scene.name, b.x, b.y, b.z
    );
    Some(Views { title, tiles })
}
