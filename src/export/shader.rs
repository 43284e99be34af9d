//! The reference shader's buffers: `warpfit_params.bin` (the uniform `Params` of
//! `shaders/warpfit.wgsl`) and `warpfit_cells.bin` (its `array<Cell>`), little-endian bytes
//! an engine uploads as they are. The WGSL, and its HLSL and GLSL translations (naga), ship
//! in the export folder beside them.

use crate::runtime::FittedGrid;
use crate::warp::Method;
use crate::warp::corrective::{Blend, NO_MAP};
use glam::Vec3;

/// `shaders/warpfit.wgsl`, and naga's translations of it (regenerated and compared by
/// `tests/shader.rs`): (file name, text).
pub const SHADER_FILES: [(&str, &str); 11] = [
    ("warpfit.wgsl", include_str!("../../shaders/warpfit.wgsl")),
    ("warpfit.hlsl", include_str!("../../shaders/warpfit.hlsl")),
    ("warpfit.specular_queries.comp.glsl", include_str!("../../shaders/warpfit.specular_queries.comp.glsl")),
    ("warpfit.irradiance_queries.comp.glsl", include_str!("../../shaders/warpfit.irradiance_queries.comp.glsl")),
    ("warpfit.warp1_queries.comp.glsl", include_str!("../../shaders/warpfit.warp1_queries.comp.glsl")),
    ("warpfit.box_queries.comp.glsl", include_str!("../../shaders/warpfit.box_queries.comp.glsl")),
    ("warpfit.surface_queries.comp.glsl", include_str!("../../shaders/warpfit.surface_queries.comp.glsl")),
    (
        "warpfit.surface_warped_queries.comp.glsl",
        include_str!("../../shaders/warpfit.surface_warped_queries.comp.glsl"),
    ),
    ("warpfit.surface_vertex.vert.glsl", include_str!("../../shaders/warpfit.surface_vertex.vert.glsl")),
    ("warpfit.surface_fragment.frag.glsl", include_str!("../../shaders/warpfit.surface_fragment.frag.glsl")),
    ("warpfit.include.glsl", include_str!("../../shaders/warpfit.include.glsl")),
];

/// Bytes of the WGSL `Params` struct: 59 vec4s.
pub const PARAMS_BYTES: usize = 59 * 16;
/// Probes `Params::probes` holds (the grid format's most).
pub const MAX_PROBES: usize = 16;
/// Bytes of one WGSL `Cell`: tiles (`vec4<i32>`), offset (`vec4<f32>`), nine harmonic
/// coefficients (`array<vec4<f32>, 9>`, rgb), its links (`vec4<u32>`, x) and the probe it
/// reads without a map (y).
pub const CELL_BYTES: usize = 32 + 9 * 16 + 16;
/// Bytes of the WGSL `SurfaceParams` struct (one surface-probe atlas): 9 vec4s.
pub const SURFACE_PARAMS_BYTES: usize = 9 * 16;
/// Radiance mips `Params::mip_roughness` holds.
pub const MAX_MIPS: usize = 16;
/// Nodes of the irradiance blend `Params::blend_r`/`blend_w` hold.
pub const MAX_BLEND_NODES: usize = 8;

/// Tiles per atlas row and tile resolution of the four atlases (0 when an atlas is absent).
#[derive(Clone, Copy, Debug, Default)]
pub struct AtlasShape {
    pub tile_resolution: u32,
    pub columns: u32,
}

/// The atlases' shapes, as the export wrote them.
#[derive(Clone, Copy, Debug, Default)]
pub struct Atlases {
    pub corrective: AtlasShape,
    pub irradiance: AtlasShape,
    pub moments: AtlasShape,
    pub scale: AtlasShape,
}

/// Why a grid cannot be expressed in the shader's buffers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unsupported(pub String);

/// Appends vec4s of little-endian words.
struct Words(Vec<u8>);

impl Words {
    fn put(&mut self, words: [[u8; 4]; 4]) -> &mut Self {
        self.0.extend(words.into_iter().flatten());
        self
    }
    fn f(&mut self, v: [f32; 4]) -> &mut Self {
        self.put(v.map(f32::to_le_bytes))
    }
    fn u(&mut self, v: [u32; 4]) -> &mut Self {
        self.put(v.map(u32::to_le_bytes))
    }
    fn i(&mut self, v: [i32; 4]) -> &mut Self {
        self.put(v.map(i32::to_le_bytes))
    }
}

/// The shader's number for a grid's proxy (`Params::probe_info.z`, `FALLBACK`).
fn fallback_code(m: Method) -> Result<u32, Unsupported> {
    match m {
        Method::Warp1 => Ok(0),
        Method::Box => Ok(1),
        Method::Kdop => Ok(2),
        m => Err(Unsupported(format!("`{}` is not a proxy the shader's maps shift (box, kdop, warp1)", m.name()))),
    }
}

/// The shader's number for a corrective blend (`Params::grid_counts.w`, `BLEND`).
fn blend_code(b: Blend) -> u32 {
    match b {
        Blend::Cell => 0,
        Blend::Trilinear => 1,
        Blend::Faces => 2,
    }
}

fn tile(slot: Option<&u32>) -> i32 {
    match slot {
        Some(&s) if s != NO_MAP => s as i32,
        _ => -1,
    }
}

/// The shader's specialisation constants for `grid` (WGSL `override`s; see
/// `shaders/warpfit.wgsl`): the values `params` writes for the fallback method, corrective
/// blend, relaxation and roughness correction.
pub fn constants(grid: &FittedGrid) -> Result<Vec<(&'static str, u32)>, Unsupported> {
    Ok(vec![
        ("FALLBACK", fallback_code(grid.correctives().fallback)?),
        ("BLEND", blend_code(grid.blend())),
        ("RELAX", (grid.warp().options.relax_texels > 0.0) as u32),
        ("ROUGHNESS_CORRECTION", grid.roughness().is_some() as u32),
    ])
}

/// `Params` for `grid` with atlases shaped `atlases` (see `shaders/warpfit.wgsl` for each
/// field's meaning).
/// `probe_tile_offset`: where the corrective atlas's probe maps start after a cell's shift
/// map tile (0: none).
pub fn params(grid: &FittedGrid, atlases: &Atlases, probe_tile_offset: u32) -> Result<Vec<u8>, Unsupported> {
    let w = &grid.warp();
    let p = &w.probe;
    let c = &grid.correctives();
    let geo = &c.geometry;
    if geo != &grid.irradiance_grid().geometry {
        return Err(Unsupported("the correctives and the irradiance use different grids".into()));
    }
    let fallback = fallback_code(c.fallback)?;
    if p.mip_roughness().len() > MAX_MIPS || p.radiance.levels.len() > MAX_MIPS {
        return Err(Unsupported(format!(
            "{} radiance mips; the shader holds up to {MAX_MIPS}",
            p.radiance.levels.len()
        )));
    }
    let kdop = &w.proxies.kdop;
    if kdop.normals.len() != 18 || kdop.offsets.len() != 18 {
        return Err(Unsupported(format!("a {}-DOP; the shader reads an 18-DOP", kdop.normals.len())));
    }
    let blend = blend_code(grid.blend());
    let bx = &w.proxies.aabb;
    let m = bx.world_to_local();
    let mut out = Words(Vec::with_capacity(PARAMS_BYTES));
    out.f(geo.min.extend(grid.irradiance_grid().surface_shift()).to_array())
        .f(geo.max.extend(0.0).to_array())
        .u([geo.counts.x, geo.counts.y, geo.counts.z, blend])
        .f(p.position.extend(w.options.depth_lod).to_array())
        .u([
            p.radiance.levels.len() as u32,
            p.inv_depth.levels.len() as u32,
            fallback,
            grid.roughness().is_some() as u32,
        ])
        .f([w.options.relax_texels, p.radiance.levels[0].res as f32, p.inv_depth.levels[0].res as f32, 0.0])
        .f(bx.centre.extend(0.0).to_array())
        .f(bx.half_extents.extend(0.0).to_array())
        .f(m.x_axis.extend(0.0).to_array())
        .f(m.y_axis.extend(0.0).to_array())
        .f(m.z_axis.extend(0.0).to_array());
    let mut open = 0u32;
    for (k, (n, &h)) in kdop.normals.iter().zip(&kdop.offsets).enumerate() {
        let finite = h.is_finite();
        open |= (!finite as u32) << k;
        out.f([n.x, n.y, n.z, if finite { h } else { 0.0 }]);
    }
    out.u([open, 0, 0, 0]);
    let mut mips = [0.0f32; MAX_MIPS];
    mips[..p.mip_roughness().len()].copy_from_slice(p.mip_roughness());
    for q in mips.chunks_exact(4) {
        out.f([q[0], q[1], q[2], q[3]]);
    }
    let a = atlases;
    out.u([a.corrective.tile_resolution, a.corrective.columns, a.irradiance.tile_resolution, a.irradiance.columns]);
    out.u([a.moments.tile_resolution, a.moments.columns, a.scale.tile_resolution, a.scale.columns]);
    // none for a grid read as probe A alone: the shader's weight is 0 without nodes
    let nodes = grid.irradiance_blend_nodes();
    if nodes.len() > MAX_BLEND_NODES {
        return Err(Unsupported(format!(
            "{} irradiance blend nodes; the shader holds up to {MAX_BLEND_NODES}",
            nodes.len()
        )));
    }
    match grid.roughness().map(|r| r.lookup_table()) {
        Some(t) => out.f([t.x0, t.inv_dx, t.k_min, t.k_max]).u([t.nodes, nodes.len() as u32, 0, 0]),
        None => out.f([0.0, 0.0, 1.0, 1.0]).u([2, 0, 0, 0]),
    };
    let (mut rs, mut ws) = ([0.0f32; MAX_BLEND_NODES], [0.0f32; MAX_BLEND_NODES]);
    for (k, &(r, w)) in nodes.iter().enumerate() {
        (rs[k], ws[k]) = (r, w);
    }
    for q in rs.chunks_exact(4).chain(ws.chunks_exact(4)) {
        out.f([q[0], q[1], q[2], q[3]]);
    }
    let count = w.probe_count();
    if count > MAX_PROBES {
        return Err(Unsupported(format!("{count} probes; the shader holds up to {MAX_PROBES}")));
    }
    out.u([count as u32, probe_tile_offset, 0, 0]);
    for k in 0..MAX_PROBES {
        let at = if k < count { w.probe_at(k).position } else { Vec3::ZERO };
        out.f(at.extend(0.0).to_array());
    }
    debug_assert_eq!(out.0.len(), PARAMS_BYTES);
    Ok(out.0)
}

/// The `array<Cell>`: per grid cell (`x + nx·(y + ny·z)`) its shift-map, irradiance and
/// irradiance-scale tiles (−1: none), its irradiance probe's offset from the cell centre,
/// its irradiance harmonics (`FittedGrid::irradiance_sh`; zero where none is stored),
/// their links and the probe the cell reads where it stores no map.
#[must_use]
pub fn cells(grid: &FittedGrid) -> Vec<u8> {
    let c = &grid.correctives();
    let ir = &grid.irradiance_grid();
    let n = c.geometry.cell_count();
    // a cell's rough map follows the maps in the corrective atlas (`export`)
    let stored = (c.maps.len() / ((c.map_res * c.map_res) as usize).max(1)) as i32;
    let rough = |map: i32| if c.has_rough_maps() && map >= 0 { map + stored } else { -1 };
    let mut out = Words(Vec::with_capacity(n * CELL_BYTES));
    for cell in 0..n {
        let offset = ir.probe_offset.get(cell).copied().unwrap_or_default();
        let map = tile(c.slot.get(cell));
        out.i([map, tile(ir.slot.get(cell)), tile(ir.correction.slot.get(cell)), rough(map)])
            .f(offset.extend(0.0).to_array());
        let sh = grid.irradiance_sh().slot.get(cell).and_then(|&s| grid.irradiance_sh().coeffs.get(s as usize));
        for k in 0..crate::sh::COEFFS {
            out.f(sh.map_or([0.0; 4], |c| c[k].extend(0.0).to_array()));
        }
        out.u([grid.irradiance_sh().links.get(cell).copied().unwrap_or(0), c.cell_probe(cell).into(), 0, 0]);
    }
    out.0
}

/// `SurfaceParams` for a surface-probe atlas (`surface{k}_params.bin`, group 2 of
/// `shaders/warpfit.wgsl`): the patch's corner, probe height and edges, its tangent frame,
/// the dual basis of its edges and its shape, exactly the values `SurfaceAtlas::radiance`
/// and `radiance_warped` use.
#[must_use]
pub fn surface_params(atlas: &crate::warp::surface::SurfaceAtlas) -> Vec<u8> {
    let (p, f) = (&atlas.patch, atlas.frame());
    let mut out = Words(Vec::with_capacity(SURFACE_PARAMS_BYTES));
    out.f(p.corner.extend(p.offset).to_array())
        .f(p.edge_u.extend(0.0).to_array())
        .f(p.edge_v.extend(0.0).to_array())
        .f(f.tangent.extend(0.0).to_array())
        .f(f.bitangent.extend(0.0).to_array())
        .f(f.normal.extend(0.0).to_array())
        .f(f.dual_u.extend(0.0).to_array())
        .f(f.dual_v.extend(0.0).to_array())
        .u([p.counts[0], p.counts[1], p.resolution, atlas.radiance.len() as u32]);
    debug_assert_eq!(out.0.len(), SURFACE_PARAMS_BYTES);
    out.0
}
