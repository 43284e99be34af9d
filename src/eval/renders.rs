//! The evaluation's rendered views for ꟻLIP (`crate::perceptual`): each row renders the
//! same pixels through its own lookup, against references traced from the evaluation's own
//! streams.

use super::methods::Row;
use super::validation::DOMAIN_EVAL;
use crate::perceptual;
pub use crate::perceptual::{RenderSettings, View, ViewReference, flip_map, views};
use crate::sampling::hash_pair;
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::warp::glossy::Glossy;
use glam::Vec3;

/// [`perceptual::reference`] of `view` at roughness `r` from the evaluation's stream `tag`
/// (per view and bucket).
pub fn reference(
    (scene, tracer, store): (&Scene, &Tracer, Option<&crate::trace::store::ReferenceStore>),
    view: &View,
    r: f32,
    spp: u32,
    (seed, tag, exposure): (u64, u64, f32),
) -> ViewReference {
    use crate::trace::store;
    let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0x7E57), tag);
    let trace = || perceptual::reference_halves(scene, tracer, view, r, spp, (seed, stream));
    let halves = match store {
        Some(store) => {
            let (b, d) = view.queries();
            let key = store.key("view").vec3s(&b).vec3s(&d).words([
                u64::from(r.to_bits()),
                u64::from(spp),
                seed,
                stream,
                u64::from(view.width),
                u64::from(view.height),
            ]);
            let len = view.len();
            store.cached(
                "view",
                key,
                (|h: &Vec<_>| store::pairs_to_words(h), |w: &[u32]| store::pairs_from_words(w, len)),
                trace,
            )
        }
        None => trace(),
    };
    perceptual::reference_from_halves(view, r, spp, halves, exposure)
}

/// What `row` renders for a view at the reference's roughness.
pub fn render(row: &Row, shading: Glossy, v: &ViewReference) -> Vec<Vec3> {
    perceptual::render(v, |b, dir, oracle| row.estimate(shading, b, dir, oracle, v.roughness))
}

/// Mean ꟻLIP of `row` over the views, weighted by their pixel counts.
pub fn mean_flip(row: &Row, shading: Glossy, views: &[ViewReference], exposure: f32) -> f64 {
    perceptual::mean_flip(views, exposure, |r, b, dir, oracle| row.estimate(shading, b, dir, oracle, r))
}

/// `row` rendered into every view once and measured (`perceptual::judge_views`): each
/// view's mean ꟻLIP and tiles, and its seams over `pairs`.
pub fn judge(
    row: &Row,
    shading: Glossy,
    views: &[ViewReference],
    pairs: &[perceptual::SeamPairs],
    exposure: f32,
) -> perceptual::Judged {
    perceptual::judge_views(views, exposure, pairs, |r, b, dir, oracle| row.estimate(shading, b, dir, oracle, r))
}

/// The [`perceptual::SeamPairs`] of every view over the cells of `geometry`.
pub fn seam_pairs(views: &[perceptual::View], geometry: &crate::grid::GridGeometry) -> Vec<perceptual::SeamPairs> {
    let size = geometry.cell_size();
    let step = 0.25 * size.min_element();
    views
        .iter()
        .map(|v| perceptual::seam_pairs(v, |b| geometry.cell_index(geometry.cell_of_sized(b, size)) as u32, step))
        .collect()
}
