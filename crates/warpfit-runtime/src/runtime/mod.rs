//! The sampler: [`FittedGrid`] loads a fitted grid folder and answers specular and
//! irradiance queries. The crate root documents what a game uses.

mod irradiance;
pub use crate::gridfile::surface::{read as load_surface_atlas, read_all as load_surface_atlases};
pub use crate::warp::surface::SurfaceAtlas;
pub use irradiance::{BlendTerms, IrradianceBlend, IrradianceSh, IrradianceView, LINK_RATIO, LINK_SEES, link_bit};

pub use crate::files::FileError as LoadError;
pub use crate::gridfile::{GridManifest, IrradianceCorrection, IrradianceGrid, Precision, read_manifest};

use crate::octa;
use crate::roughness::RoughnessCorrection;
use crate::warp::Warp;
use crate::warp::corrective::{Blend, Correctives, FaceCells};
use crate::warp::glossy::{Aim, MipRule, corrected_lanes, corrected_lanes_of, glossy_radiance};
use glam::Vec3;
use std::path::Path;

/// A loaded fitted grid: load it once per level, then ask it [`specular`](Self::specular)
/// and [`irradiance`](Self::irradiance) from any thread.
///
/// ```
/// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
/// use warpfit_runtime::{FittedGrid, glam::Vec3};
/// let grid = FittedGrid::load(dir)?; // the folder `warpfit run` wrote, e.g. "fits/mylevel"
/// let reflected = grid.specular(Vec3::new(1.0, 1.2, 0.5), Vec3::new(0.0, 0.3, -1.0), 0.25);
/// let diffuse = grid.irradiance(Vec3::new(1.0, 1.2, 0.5), Vec3::Y);
/// assert!(reflected.is_finite() && diffuse.is_finite());
/// # Ok::<(), warpfit_runtime::LoadError>(())
/// ```
///
/// Behaviour at the edges (all tested):
/// - `specular(p, dir, r)`: the direction need not be unit length; a zero or non-finite
///   direction returns black. A non-finite position is treated as the probe's own position
///   (no parallax). Roughness is perceptual (GGX α = r²), clamped to [0, 1]; NaN reads as 0.
/// - Positions outside the grid use the nearest cell's corrective (the cell lookup clamps),
///   while the warp itself still starts from the true position; the irradiance blend clamps
///   the position into the lattice of cell centres.
/// - Results are always finite and ≥ 0 (the payloads are validated on load).
/// - `FittedGrid` is `Send + Sync` and immutable; sampling never allocates.
/// - Rough lookups come in two quality tiers ([`SpecularRead`]): blended with the cells'
///   irradiance (loaded) or probe A alone (`grid.with_read(SpecularRead::ProbeOnly)`),
///   cheaper and less exact; mirror lookups are the same in both.
#[derive(Clone, Debug)]
pub struct FittedGrid {
    /// Probe A, the proxies and the warp options of the fallback method.
    warp: Warp,
    /// How a position's corrective map is found (the containing cell's).
    blend: Blend,
    /// The per-cell shift maps (sparse) and the proxy they shift, as it is in the other
    /// cells.
    correctives: Correctives,
    /// The dense grid's irradiance, distance moments and diffuse corrections.
    irradiance: IrradianceGrid,
    /// `irradiance`'s maps as harmonics, what rough lookups blend in: derived from them at
    /// load ([`IrradianceSh::project`]); project again after changing the maps.
    irradiance_sh: IrradianceSh,
    /// The GGX distance-ratio roughness correction (absent: plain roughness picks the mip).
    roughness: Option<RoughnessCorrection>,
    /// The manifest the grid was loaded from (conventions, provenance, residuals).
    manifest: GridManifest,
    /// What a rough lookup reads: [`SpecularRead::Blended`] (loaded) or the cheaper
    /// [`SpecularRead::ProbeOnly`] ([`FittedGrid::with_read`]).
    read: SpecularRead,
}

/// What a rough specular lookup reads: a quality tier chosen once per grid
/// ([`FittedGrid::with_read`]).
///
/// ```
/// use warpfit_runtime::SpecularRead;
/// let tier: SpecularRead = "probe-only".parse().unwrap();
/// assert_eq!(tier, SpecularRead::ProbeOnly);
/// assert_eq!(SpecularRead::default().name(), "blended");
/// assert_eq!(SpecularRead::ALL.len(), 2);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SpecularRead {
    /// Probe A through the fitted warp and roughness correction, blended with the
    /// irradiance harmonics of the cells around the point by the weight the fit stored for
    /// the roughness: the lowest error, what `warpfit run` evaluates as `runtime`.
    #[default]
    Blended,
    /// Probe A alone through the same warp and roughness correction, without the
    /// irradiance blend: a rough lookup costs about what a mirror one does, and loses the
    /// blend's gain (the evaluation's `runtime-probe-only` row). Mirror lookups are the
    /// same in both tiers.
    ProbeOnly,
}

impl SpecularRead {
    /// Both tiers, the default first.
    pub const ALL: [SpecularRead; 2] = [SpecularRead::Blended, SpecularRead::ProbeOnly];

    /// The name the command line and the evaluation use.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            SpecularRead::Blended => "blended",
            SpecularRead::ProbeOnly => "probe-only",
        }
    }
}

impl std::str::FromStr for SpecularRead {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        SpecularRead::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| format!("unknown specular read {s:?} (blended, probe-only)"))
    }
}

/// A valid specular query: position (finite), unit direction, roughness in [0, 1].
#[derive(Clone, Copy, Debug)]
struct SpecularQuery {
    b: Vec3,
    dir: Vec3,
    r: f32,
}

impl FittedGrid {
    /// Loads a fitted grid folder (`manifest.json` + EXR payloads), verifying versions,
    /// checksums, sizes and values. Any problem is a [`LoadError`] naming the file and the
    /// field; nothing half-loaded is ever returned.
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// let grid = warpfit_runtime::FittedGrid::load(dir)?;
    /// assert!(warpfit_runtime::FittedGrid::load("no/such/folder").is_err());
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    pub fn load(dir: impl AsRef<Path>) -> Result<FittedGrid, LoadError> {
        let d = crate::gridfile::read(dir.as_ref())?;
        Ok(FittedGrid {
            irradiance_sh: IrradianceSh::project(&d.irradiance.view()),
            warp: d.warp,
            blend: d.manifest.warp.blend,
            correctives: d.correctives,
            irradiance: d.irradiance,
            roughness: d.roughness,
            manifest: d.manifest,
            read: SpecularRead::Blended,
        })
    }

    /// The grid reading rough lookups as `read` says (see [`SpecularRead`]).
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// use warpfit_runtime::{FittedGrid, SpecularRead, glam::Vec3};
    /// let cheap = FittedGrid::load(dir)?.with_read(SpecularRead::ProbeOnly);
    /// let c = cheap.specular(Vec3::new(0.2, 1.0, 0.1), Vec3::X, 0.6);
    /// assert!(c.is_finite());
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    #[must_use]
    pub fn with_read(self, read: SpecularRead) -> FittedGrid {
        FittedGrid { read, ..self }
    }

    /// The irradiance blend's weight at perceptual roughness `r`: the stored one, 0 without
    /// a roughness correction or when this grid reads probe A alone.
    #[inline]
    fn irradiance_weight(&self, read: SpecularRead, r: f32) -> f32 {
        match (&self.roughness, read) {
            (Some(c), SpecularRead::Blended) => c.irradiance_weight(r),
            _ => 0.0,
        }
    }

    /// The (perceptual roughness, weight) nodes of the irradiance blend this grid's rough
    /// lookups apply (`RoughnessCorrection::irradiance_nodes`): none when it reads probe A
    /// alone. What an export hands the shader (the tool's; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn irradiance_blend_nodes(&self) -> &[(f32, f32)] {
        match (&self.roughness, self.read) {
            (Some(c), SpecularRead::Blended) => c.irradiance_nodes(),
            _ => &[],
        }
    }

    /// Fetch vector of probe A for the query (unit `dir`): exactly what the fit evaluated;
    /// with the faces blend, that of the near cell with the greatest share (the tool's; not
    /// a supported API).
    #[doc(hidden)]
    #[inline]
    #[must_use]
    pub fn fetch_vector(&self, position: Vec3, dir: Vec3) -> Vec3 {
        let b = if position.is_finite() { position } else { self.warp.probe.position };
        if self.blend == Blend::Faces {
            // the cells the lookup reads (`near_cells`), not every near cell
            return self.correctives.face_aims_in(self.near_cells(b), &self.warp, b, dir, 0.0).main().v;
        }
        self.correctives.fetch_vector(self.blend, &self.warp, b, dir)
    }

    /// Radiance reflected towards `dir` from `position` for perceptual roughness `roughness`:
    /// the fitted warp picks where to read probe A, the roughness correction picks the mip,
    /// and a rough lookup blends in the irradiance around the point unless the grid reads
    /// probe A alone ([`FittedGrid::read`]).
    ///
    /// `direction` points away from the shaded point (the view vector reflected about the
    /// normal) and need not be unit length; `roughness` is perceptual, in [0, 1].
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// use warpfit_runtime::{FittedGrid, glam::Vec3};
    /// let grid = FittedGrid::load(dir)?;
    /// let (normal, to_eye) = (Vec3::Y, Vec3::new(0.6, 0.8, 0.0));
    /// let reflected = 2.0 * normal.dot(to_eye) * normal - to_eye;
    /// let mirror = grid.specular(Vec3::new(0.2, 0.5, 0.1), reflected, 0.0);
    /// assert!(mirror.is_finite() && mirror.min_element() >= 0.0);
    /// assert_eq!(grid.specular(Vec3::ZERO, Vec3::ZERO, 0.5), Vec3::ZERO); // no direction: black
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn specular(&self, position: Vec3, direction: Vec3, roughness: f32) -> Vec3 {
        self.specular_as(self.read, position, direction, roughness)
    }

    /// [`FittedGrid::specular`] in read tier `read`, whatever the grid's own (the
    /// evaluation rates both tiers of one loaded grid; not a supported API).
    #[doc(hidden)]
    #[inline]
    pub fn specular_as(&self, read: SpecularRead, position: Vec3, direction: Vec3, roughness: f32) -> Vec3 {
        let Some(q) = self.specular_query(position, direction, roughness) else {
            return Vec3::ZERO;
        };
        if self.blend == Blend::Faces {
            let cells = self.near_cells(q.b);
            let aims = self.correctives.face_aims_in(cells, &self.warp, q.b, q.dir, q.r);
            if cells.n > 1 {
                let spec = self.probe_radiance(q, &aims.aims[..aims.n], &aims.weights[..aims.n]);
                return self.mix_near(q, &cells, spec, read);
            }
            return self.shade(q, aims.aims[0], read);
        }
        let aim = self.correctives.fetch(self.blend, &self.warp, q.b, q.dir, q.r);
        self.shade(q, aim, read)
    }

    /// A specular query made safe (see the module conventions); `None` means black.
    #[inline]
    fn specular_query(&self, position: Vec3, direction: Vec3, roughness: f32) -> Option<SpecularQuery> {
        // unit to rounding: used as is (as the fit used it); otherwise normalised
        let dir = octa::unit_direction(direction)?;
        let b = if position.is_finite() { position } else { self.warp.probe.position };
        let r = if roughness.is_finite() { roughness.clamp(0.0, 1.0) } else { 0.0 };
        Some(SpecularQuery { b, dir, r })
    }

    /// Radiance of probe A along `aim` for the query's roughness: the mip from the stored
    /// roughness correction (`warp::glossy`, shared with the fit and eval).
    #[inline]
    fn shade(&self, q: SpecularQuery, aim: Aim, read: SpecularRead) -> Vec3 {
        // the irradiance first: its loads are independent of probe A's and overlap them
        let blend = self.irradiance_blend(q, read);
        if let Some((e, w)) = blend.filter(|&(_, w)| w >= 1.0) {
            // probe A's part has weight 0: `mix_irradiance(spec, e, 1)` for any finite spec
            return mix_irradiance(Vec3::ZERO, e, w);
        }
        let spec = self.probe_radiance(q, &[aim], &[1.0]);
        match blend {
            Some((e, w)) => mix_irradiance(spec, e, w),
            None => spec,
        }
    }

    /// The probes' radiance along `aims` for the query's roughness, blended by `weights`
    /// (summing to 1; one aim is read as it is): the mip from the stored roughness
    /// correction (`warp::glossy`, shared with the fit and eval).
    #[inline]
    fn probe_radiance(&self, q: SpecularQuery, aims: &[Aim], weights: &[f32]) -> Vec3 {
        let radiance =
            |aim| glossy_radiance(&self.warp, self.roughness.as_ref(), MipRule::Corrected, q.b, q.dir, aim, q.r);
        match aims {
            [aim] => radiance(*aim),
            _ => aims.iter().zip(weights).fold(Vec3::ZERO, |sum, (&aim, &w)| sum + w * radiance(aim)),
        }
    }

    /// The cells a faces-blend lookup at `b` (finite) reads: `Correctives::face_cells`, kept
    /// where the containing cell links to them (`IrradianceSh::links`: stored, the two probes
    /// see each other, their irradiance alike), so no blend reaches through a wall; the kept
    /// weights renormalised. A containing cell without links reads itself alone.
    #[inline]
    fn near_cells(&self, b: Vec3) -> FaceCells {
        let mut cells = self.correctives.face_cells(b);
        if cells.n == 1 {
            return cells;
        }
        let geo = &self.correctives.geometry;
        let home = self.correctives.cell_at(b);
        let links = self.irradiance_sh.links.get(home).copied().unwrap_or(0);
        let home_at = geo.cell_coords(home).as_ivec3();
        let mut kept = 0;
        let mut sum = 0.0f32;
        for k in 0..cells.n {
            let o = geo.cell_coords(cells.cells[k]).as_ivec3() - home_at;
            let linked = cells.cells[k] == home || (o.abs().max_element() <= 1 && links & link_bit(o) != 0);
            if linked {
                (cells.cells[kept], cells.weights[kept]) = (cells.cells[k], cells.weights[k]);
                sum += cells.weights[k];
                kept += 1;
            }
        }
        if kept <= 1 || !(sum > 0.0) {
            return FaceCells { cells: [home; 8], weights: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], n: 1 };
        }
        for w in &mut cells.weights[..kept] {
            *w /= sum;
        }
        cells.n = kept;
        cells
    }

    /// A faces-blend lookup's probe radiance `spec` near a cell face (near cells `cells`)
    /// with its irradiance blend: the near cells' irradiance reads, each as if the point lay
    /// in it, averaged over those that hold irradiance, blended by the stored weight times
    /// their share of the near cells' weight (`IrradianceSh::read_near`), so the blend too
    /// is continuous across faces.
    #[inline]
    fn mix_near(&self, q: SpecularQuery, cells: &FaceCells, spec: Vec3, read: SpecularRead) -> Vec3 {
        let w = self.irradiance_weight(read, q.r);
        if !(w > 0.0) {
            return spec;
        }
        match self.irradiance_sh.read_near(cells, q.b, q.dir) {
            Some((e, share)) => mix_irradiance(spec, e, w * share),
            None => spec,
        }
    }

    /// What a rough lookup blends into its probe-A radiance: the containing cell's
    /// irradiance for the query direction and the stored weight of its roughness
    /// (`RoughnessCorrection::irradiance_weight`); `None` without a weight, for a mirror
    /// query and in a cell without irradiance.
    #[inline]
    fn irradiance_blend(&self, q: SpecularQuery, read: SpecularRead) -> Option<(Vec3, f32)> {
        let w = self.irradiance_weight(read, q.r);
        if !(w > 0.0) {
            return None;
        }
        self.irradiance_sh.read(q.b, q.dir).map(|e| (e, w))
    }

    /// `specular` for [`octa::LANES`] queries at once, bit for bit the same values: the
    /// lanes' fetch vectors are found in lockstep and, when every lane is a mirror query,
    /// the probe is read with the lane sampler.
    #[inline]
    fn specular_lanes(
        &self,
        positions: &[Vec3; octa::LANES],
        directions: &[Vec3; octa::LANES],
        roughness: &[f32; octa::LANES],
    ) -> [Vec3; octa::LANES] {
        // the lanes made safe as `specular_query` makes them; the usual case (finite
        // positions, unit directions) is checked for all lanes at once and used as it is
        let mut usual = true;
        for k in 0..octa::LANES {
            usual &= positions[k].is_finite() & octa::is_unit(directions[k]);
        }
        let safe;
        let (b, dir, valid) = if usual {
            (positions, directions, None)
        } else {
            safe = self.safe_lanes(positions, directions);
            (&safe.0, &safe.1, Some(safe.2))
        };
        // `specular_query`'s roughness, lane by lane
        let mut r = [0.0f32; octa::LANES];
        for k in 0..octa::LANES {
            r[k] = if roughness[k].is_finite() { roughness[k].clamp(0.0, 1.0) } else { 0.0 };
        }
        // the faces blend: every lane as `Blend::Cell` (what a lane inside its cell reads),
        // then the lanes near a face again with their near cells
        let blend = if self.blend == Blend::Faces { Blend::Cell } else { self.blend };
        let mut out = if r.iter().all(|&r| r == 0.0) {
            // mirror lanes: the fetch vectors alone
            let (v, probe) = self.correctives.fetch_vector_lanes(blend, &self.warp, b, dir);
            self.mirror_lanes(&probe, &v)
        } else {
            // probe A's part, then the irradiance blend lane by lane (`irradiance_blend`)
            let (v, ratio, probe) = self.correctives.fetch_lanes(blend, &self.warp, b, dir, &r);
            let c = self.roughness.as_ref();
            let mut out = self.warp.by_probe(
                &probe,
                |p| corrected_lanes(p, c, &r, &v, &ratio),
                |ps| corrected_lanes_of(ps, c, &r, &v, &ratio),
            );
            let w: [f32; octa::LANES] = std::array::from_fn(|k| self.irradiance_weight(self.read, r[k]));
            if w.iter().any(|&w| w > 0.0) {
                self.irradiance_sh.mix_lanes(b, dir, &w, &mut out);
            }
            out
        };
        if self.blend == Blend::Faces {
            let cells = b.map(|b| self.near_cells(b));
            if cells.iter().any(|c| c.n > 1) {
                let faces = self.specular_faces_lanes(positions, directions, roughness, &cells);
                for k in 0..octa::LANES {
                    if cells[k].n > 1 {
                        out[k] = faces[k];
                    }
                }
            }
        }
        if let Some(valid) = valid {
            for k in 0..octa::LANES {
                if !valid[k] {
                    out[k] = Vec3::ZERO;
                }
            }
        }
        out
    }

    /// `specular` for the lanes near a face of [`octa::LANES`] queries of a grid read with
    /// `Blend::Faces` (`cells`, each lane's `Correctives::face_cells` at its position made
    /// safe; the other lanes are left black), bit for bit the same values: each query's
    /// distinct lookups (`Correctives::face_groups`: up to eight near cells), the proxy's
    /// exit for all lanes at once, then the aims and the probe reads side by side,
    /// [`octa::LANES`] at a time, each query summing its aims' radiances in order, then
    /// blending its irradiance (`mix_near`). With UV relaxation the aims are found one by
    /// one (`Correctives::face_aims_in`), since cells without a map read the relaxed proxy.
    #[inline]
    fn specular_faces_lanes(
        &self,
        positions: &[Vec3; octa::LANES],
        directions: &[Vec3; octa::LANES],
        roughness: &[f32; octa::LANES],
        cells: &[FaceCells; octa::LANES],
    ) -> [Vec3; octa::LANES] {
        use crate::warp::corrective::{AimLanes, FaceAims};
        const L: usize = octa::LANES;
        let placeholder = SpecularQuery { b: self.warp.probe.position, dir: Vec3::Z, r: 0.0 };
        let mut q = [placeholder; L];
        let mut valid = [false; L];
        for k in (0..L).filter(|&k| cells[k].n > 1) {
            if let Some(query) = self.specular_query(positions[k], directions[k], roughness[k]) {
                (q[k], valid[k]) = (query, true);
            }
        }
        let relaxed = self.warp.options.relax_texels > 0.0;
        // per query its lookups: (probe, weight, shift) and how many; aims one by one when
        // relaxed
        let mut groups = [([(0u8, 0.0f32, 0.0f32); 8], 0usize); L];
        let mut aims = [FaceAims::one(Aim::from(Vec3::Z)); L];
        // every lookup of every valid query, as (query, lookup) in query order
        let mut entries = [(0u8, 0u8); 8 * L];
        let mut count = 0;
        for k in (0..L).filter(|&k| valid[k]) {
            let n = if relaxed {
                aims[k] = self.correctives.face_aims_in(cells[k], &self.warp, q[k].b, q[k].dir, q[k].r);
                aims[k].n
            } else {
                groups[k] = self.correctives.face_groups(&cells[k], &self.warp, q[k].dir, q[k].r);
                groups[k].1
            };
            for a in 0..n {
                entries[count] = (k as u8, a as u8);
                count += 1;
            }
        }
        // the proxy's exit of every query, as `face_aims_in` finds it once per query
        let (t, has_t) = if relaxed {
            ([0.0f32; L], [false; L])
        } else {
            self.correctives.proxy_exit_lanes(&self.warp, &q.map(|q| q.b), &q.map(|q| q.dir))
        };
        let weight = |k: usize, a: usize| if relaxed { aims[k].weights[a] } else { groups[k].0[a].1 };
        let lookups = |k: usize| if relaxed { aims[k].n } else { groups[k].1 };
        let mut spec = [Vec3::ZERO; L];
        let c = self.roughness.as_ref();
        for start in (0..count).step_by(L) {
            let m = (count - start).min(L);
            // the group's lookups, the last one repeated to fill the lanes
            let pick: [(usize, usize); L] = std::array::from_fn(|l| {
                let (k, a) = entries[start + l.min(m - 1)];
                (k as usize, a as usize)
            });
            let r: [f32; L] = std::array::from_fn(|l| q[pick[l].0].r);
            let (v, ratio, probe) = if relaxed {
                let (mut v, mut ratio, mut probe) = ([Vec3::Z; L], [1.0f32; L], [0u8; L]);
                for l in 0..L {
                    let (k, a) = pick[l];
                    let aim = aims[k].aims[a];
                    (v[l], probe[l]) = (aim.v, aim.probe);
                    if q[k].r != 0.0 {
                        ratio[l] = aim.ratio(&self.warp, q[k].b, octa::encode(aim.v));
                    }
                }
                (octa::soa(&v), ratio, probe)
            } else {
                let probe: [u8; L] = std::array::from_fn(|l| groups[pick[l].0].0[pick[l].1].0);
                let delta: [f32; L] = std::array::from_fn(|l| groups[pick[l].0].0[pick[l].1].2);
                let mut a = [[0.0f32; L]; 3];
                for l in 0..L {
                    [a[0][l], a[1][l], a[2][l]] = self.warp.probe_at(probe[l].into()).position.to_array();
                }
                let bb = octa::soa(&pick.map(|(k, _)| q[k].b));
                let d = octa::soa(&pick.map(|(k, _)| q[k].dir));
                let (tl, hl) = (pick.map(|(k, _)| t[k]), pick.map(|(k, _)| has_t[k]));
                let aimed = AimLanes::shifted_from(&a, &tl, &hl, &delta, &bb, d).with_probes(probe);
                let (v, ratio) = aimed.vectors_and_ratios();
                (v, ratio, probe)
            };
            let radiance = if r.iter().all(|&r| r == 0.0) {
                self.mirror_lanes(&probe, &v)
            } else {
                self.warp.by_probe(
                    &probe,
                    |p| corrected_lanes(p, c, &r, &v, &ratio),
                    |ps| corrected_lanes_of(ps, c, &r, &v, &ratio),
                )
            };
            // each query's sum in its lookups' order, as `shade` forms it
            for l in 0..m {
                let (k, a) = pick[l];
                spec[k] = if lookups(k) == 1 { radiance[l] } else { spec[k] + weight(k, a) * radiance[l] };
            }
        }
        for k in 0..L {
            spec[k] = if valid[k] { self.mix_near(q[k], &cells[k], spec[k], self.read) } else { Vec3::ZERO };
        }
        spec
    }

    /// Mirror radiance of [`octa::LANES`] fetch vectors `v` (as components), lane k read from
    /// probe `probe[k]`'s mip 0.
    #[inline(always)]
    fn mirror_lanes(&self, probe: &[u8; octa::LANES], v: &octa::Soa3) -> [Vec3; octa::LANES] {
        let uv = octa::encode_soa(v);
        self.warp.by_probe(
            probe,
            |p| p.radiance.levels[0].bilinear_uv_lanes(&uv),
            |ps| octa::OctMap::bilinear_uv_lanes_of(&std::array::from_fn(|k| &ps[k].radiance.levels[0]), &uv),
        )
    }

    /// The positions and directions of [`octa::LANES`] queries made safe lane by lane
    /// (`specular_query`); a lane with no direction (black) reads a placeholder and is
    /// `false` in the mask.
    #[cold]
    #[allow(clippy::type_complexity)]
    fn safe_lanes(
        &self,
        positions: &[Vec3; octa::LANES],
        directions: &[Vec3; octa::LANES],
    ) -> ([Vec3; octa::LANES], [Vec3; octa::LANES], [bool; octa::LANES]) {
        let (mut b, mut dir, mut valid) = (*positions, *directions, [true; octa::LANES]);
        for k in 0..octa::LANES {
            match self.specular_query(positions[k], directions[k], 0.0) {
                Some(q) => (b[k], dir[k]) = (q.b, q.dir),
                None => (b[k], dir[k], valid[k]) = (self.warp.probe.position, Vec3::Z, false),
            }
        }
        (b, dir, valid)
    }

    /// Irradiance at `position` around the unit surface normal `normal` (linear, the
    /// scene's units; multiply by albedo / π for diffuse radiance): the dense grid's probes
    /// blended with visibility weights, with the fitted diffuse corrections.
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// use warpfit_runtime::{FittedGrid, glam::Vec3};
    /// let grid = FittedGrid::load(dir)?;
    /// let e = grid.irradiance(Vec3::new(0.2, 0.0, 0.1), Vec3::Y);
    /// assert!(e.is_finite() && e.min_element() >= 0.0);
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn irradiance(&self, position: Vec3, normal: Vec3) -> Vec3 {
        self.irradiance.irradiance(position, normal)
    }

    /// [`specular`](Self::specular) over slices, bit for bit the single calls, faster (the
    /// lookups advance in lockstep); every slice must have `out.len()` elements, else a
    /// [`BatchError`] and `out` untouched.
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// use warpfit_runtime::{FittedGrid, glam::Vec3};
    /// let grid = FittedGrid::load(dir)?;
    /// let p = [Vec3::new(0.2, 0.5, 0.1); 3];
    /// let d = [Vec3::X, Vec3::Y, Vec3::NEG_Z];
    /// let mut out = [Vec3::ZERO; 3];
    /// grid.specular_batch(&p, &d, &[0.0, 0.3, 1.0], &mut out).unwrap();
    /// assert_eq!(out[1], grid.specular(p[1], d[1], 0.3));
    /// assert!(grid.specular_batch(&p, &d, &[0.0], &mut out).is_err());
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    pub fn specular_batch(
        &self,
        positions: &[Vec3],
        directions: &[Vec3],
        roughness: &[f32],
        out: &mut [Vec3],
    ) -> Result<(), BatchError> {
        let n = out.len();
        if positions.len() != n || directions.len() != n || roughness.len() != n {
            return Err(BatchError { expected: n, found: [positions.len(), directions.len(), roughness.len()] });
        }
        use octa::group_at;
        octa::fill_in_lanes(
            out,
            |k| self.specular_lanes(group_at(positions, k), group_at(directions, k), group_at(roughness, k)),
            |k| self.specular(positions[k], directions[k], roughness[k]),
        );
        Ok(())
    }

    /// [`irradiance`](Self::irradiance) over slices, equal to the single calls; every slice
    /// must have `out.len()` elements, else a [`BatchError`].
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// use warpfit_runtime::{FittedGrid, glam::Vec3};
    /// let grid = FittedGrid::load(dir)?;
    /// let (p, n) = ([Vec3::new(0.2, 0.0, 0.1); 2], [Vec3::Y, Vec3::X]);
    /// let mut out = [Vec3::ZERO; 2];
    /// grid.irradiance_batch(&p, &n, &mut out).unwrap();
    /// assert_eq!(out[0], grid.irradiance(p[0], n[0]));
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    pub fn irradiance_batch(&self, positions: &[Vec3], normals: &[Vec3], out: &mut [Vec3]) -> Result<(), BatchError> {
        let n = out.len();
        if positions.len() != n || normals.len() != n {
            return Err(BatchError { expected: n, found: [positions.len(), normals.len(), n] });
        }
        for k in 0..n {
            out[k] = self.irradiance(positions[k], normals[k]);
        }
        Ok(())
    }

    /// Probe A, the proxies and the warp options of the fallback method (the `warpfit`
    /// tool's view of the data; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn warp(&self) -> &Warp {
        &self.warp
    }

    /// How a position's corrective map is found (the tool's view; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn blend(&self) -> Blend {
        self.blend
    }

    /// The per-cell shift maps (the tool's view; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn correctives(&self) -> &Correctives {
        &self.correctives
    }

    /// The dense grid's irradiance, distance moments and diffuse corrections (the tool's
    /// view; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn irradiance_grid(&self) -> &IrradianceGrid {
        &self.irradiance
    }

    /// The irradiance maps as harmonics, what rough lookups blend in (the tool's view; not a
    /// supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn irradiance_sh(&self) -> &IrradianceSh {
        &self.irradiance_sh
    }

    /// The GGX distance-ratio roughness correction, if the grid stores one (the tool's
    /// view; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn roughness(&self) -> Option<&RoughnessCorrection> {
        self.roughness.as_ref()
    }

    /// The manifest the grid was loaded from (the tool's view; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn manifest(&self) -> &GridManifest {
        &self.manifest
    }

    /// The quality tier rough lookups read ([`FittedGrid::with_read`]).
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// use warpfit_runtime::{FittedGrid, SpecularRead};
    /// let grid = FittedGrid::load(dir)?;
    /// assert_eq!(grid.read(), SpecularRead::Blended);
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    #[must_use]
    pub fn read(&self) -> SpecularRead {
        self.read
    }

    /// The same grid with probe A's radiance replaced by `radiance` (same mip sizes): the
    /// evaluation's emitted-light twin (the tool's; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn with_radiance(mut self, radiance: crate::octa::OctMips<Vec3>) -> FittedGrid {
        self.warp.probe.radiance = radiance;
        self
    }

    /// The same grid with its irradiance edited by `edit`, the harmonics derived again when
    /// `edit` says it changed the maps (the tool's evaluation and tests; not a supported
    /// API).
    #[doc(hidden)]
    #[must_use]
    pub fn with_irradiance(mut self, edit: impl FnOnce(&mut IrradianceGrid) -> bool) -> FittedGrid {
        if edit(&mut self.irradiance) {
            self.irradiance_sh = self.irradiance_sh.reproject(&self.irradiance.view());
        }
        self
    }

    /// The same grid with another roughness correction (the tool's tests; not a supported
    /// API).
    #[doc(hidden)]
    #[must_use]
    pub fn with_roughness(mut self, roughness: Option<RoughnessCorrection>) -> FittedGrid {
        self.roughness = roughness;
        self
    }

    /// The same grid with its lookup's parts edited by `edit` (the fallback proxy, the
    /// blend, the warp options): the tool's tests of exported variants; not a supported API.
    #[doc(hidden)]
    #[must_use]
    pub fn with_lookup(mut self, edit: impl FnOnce(&mut Warp, &mut Blend, &mut Correctives)) -> FittedGrid {
        edit(&mut self.warp, &mut self.blend, &mut self.correctives);
        self
    }

    /// The grid's volume as (min corner, max corner), in scene units. Lookups outside it
    /// still answer (the nearest cell's data, see the type's conventions).
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// let grid = warpfit_runtime::FittedGrid::load(dir)?;
    /// let (lo, hi) = grid.bounds();
    /// assert!(lo.cmplt(hi).all());
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    #[must_use]
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.correctives.geometry.min, self.correctives.geometry.max)
    }

    /// Bytes of the loaded data (probe, correctives, irradiance), for a level's memory
    /// budget.
    ///
    /// ```
    /// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
    /// let grid = warpfit_runtime::FittedGrid::load(dir)?;
    /// assert!(grid.memory_bytes() > 0);
    /// # Ok::<(), warpfit_runtime::LoadError>(())
    /// ```
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        let p = &self.warp.probe;
        let probe: usize = p.radiance.levels.iter().map(|l| l.texels.len() * 12).sum::<usize>()
            + p.inv_depth.levels.iter().map(|l| l.texels.len() * 4).sum::<usize>();
        let c = &self.correctives;
        let g = &self.irradiance;
        probe
            + (c.maps.len() + c.rough_maps.len()) * 4
            + c.slot.len() * 4
            + c.probe_maps.len()
            + c.cell_probes.len()
            + g.irradiance.len() * 12
            + (g.depth_mean.len() + g.depth_mean_sq.len()) * 4
            + g.slot.len() * 4
            + self.irradiance_sh.coeffs.len() * std::mem::size_of::<[glam::Vec3A; crate::sh::COEFFS]>()
            + (self.irradiance_sh.slot.len() + self.irradiance_sh.links.len()) * 4
    }
}

/// Slices of a batch call with different lengths.
///
/// ```
/// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
/// use warpfit_runtime::{FittedGrid, glam::Vec3};
/// let grid = FittedGrid::load(dir)?;
/// let mut out = [Vec3::ZERO; 2];
/// let err = grid.irradiance_batch(&[Vec3::ZERO], &[Vec3::Y, Vec3::X], &mut out).unwrap_err();
/// assert_eq!((err.expected, err.found[0]), (2, 1));
/// # Ok::<(), warpfit_runtime::LoadError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BatchError {
    /// Length of the output slice.
    pub expected: usize,
    /// Lengths of the positions, directions and roughness (or normals) slices.
    pub found: [usize; 3],
}

impl std::fmt::Display for BatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "batch slices must all hold {} elements, found {:?}", self.expected, self.found)
    }
}

impl std::error::Error for BatchError {}

/// `spec` and the irradiance `e` (for the lookup's direction) blended by weight `w`:
/// `spec·(1 − w) + (e/π)·w`. The one formula the runtime, the fit and the shader use.
#[inline]
#[must_use]
pub fn mix_irradiance(spec: Vec3, e: Vec3, w: f32) -> Vec3 {
    spec * (1.0 - w) + e * (w * std::f32::consts::FRAC_1_PI)
}
