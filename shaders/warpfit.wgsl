// warpfit's fitted lookup as a shader: `specular(p, dir, roughness)` and `irradiance(p, n)`
// over the textures and buffers `warpfit export --format ktx2` writes. A line-by-line port
// of the CPU sampler (`warpfit::runtime::FittedGrid`), with the same defined behaviour at
// the edges: a zero or non-finite direction or normal gives black, a non-finite position
// reads as the probe's own (specular) or the grid's centre (irradiance), roughness is
// clamped to [0, 1] (NaN reads 0), positions outside the grid use the nearest cell, the sky
// (inverse distance 0) is at infinity, and every result is finite and >= 0.
//
// Bindings (group 0), all from the export folder:
//   0 probe_radiance      probe_radiance.ktx2      RGBA16F (or RGBA32F), every GGX mip
//   1 probe_inv_distance  probe_inv_distance.ktx2  R32F, every mip (1/distance, 0 = sky)
//   2 corrective_atlas    correctives.ktx2         R32F shift maps (and rough maps), guttered tiles (1x1 dummy if none)
//   3 irradiance_atlas    irradiance.ktx2          RGBA16F (or RGBA32F), guttered tiles
//   4 moments_atlas       moments.ktx2             RG32F, guttered tiles
//   5 scale_atlas         irradiance_scale.ktx2    R32F, guttered tiles (1x1 dummy if none)
//   6 roughness_lut       roughness_lookup.ktx2    R32F nodes x nodes (1x1 dummy if none)
//   7 params              warpfit_params.bin       uniform buffer (struct Params)
//   8 cells               warpfit_cells.bin        storage buffer (array<Cell>)
// Textures are read with textureLoad only (no sampler): R32F is not filterable in core
// WebGPU, and loads give the CPU's exact bilinear weights. The probe's mips are read with
// the octahedral seam wrap; the atlases' one-texel gutters make a tile's 2x2 footprint
// contiguous, so they need none (and plain hardware bilinear of a tile equals this too).
//
// Group 1 holds the query kernels' buffers (see the entry points at the end).
//
// Group 2 is one surface-probe atlas (seed 003, `surface_specular`), from the same export:
//   0 surface_radiance      surface{k}_radiance.ktx2  RGBA16F (or RGBA32F) 2-D array, layer m =
//                           every tile prefiltered for roughness m/(layers-1)
//   1 surface_params        surface{k}_params.bin     uniform buffer (struct SurfaceParams)
//   2 surface_inv_distance  surface{k}_inv_distance.ktx2  R32F, 1/distance of each mip-0
//                           texel (0 = sky; read by `surface_specular_warped` only)
// A renderer binds the atlas of the surface it shades; the grid's group 0 is not needed.
//
// Specialisation: four pipeline-overridable constants name the grid's fallback method,
// corrective blend, relaxation and roughness correction. Left at 255 (the default) the
// shader reads them from Params at run time, so one pipeline serves every grid; a renderer
// that builds a pipeline per grid sets them to export.json's `shader.constants`, and the
// compiler drops the branches that grid never takes.

struct Params {
    // the grid: min (xyz), max (xyz), cell counts (xyz) and the corrective blend (w: 0 the
    // containing cell, 1 trilinear over the eight cells around the point, 2 the containing
    // cell blended with its neighbours near its faces); grid_min.w: how
    // far the irradiance blend moves a point along its normal (the surface bias, scene units)
    grid_min: vec4<f32>,
    grid_max: vec4<f32>,
    grid_counts: vec4<u32>,
    // probe A: position (xyz) and the depth mip the warps read (w)
    probe: vec4<f32>,
    // x radiance mips, y inverse-distance mips, z the proxy the maps shift (0 the probe's
    // own depth as warp1 reads it, 1 box, 2 kdop), w 1 when the roughness correction is
    // present
    probe_info: vec4<u32>,
    // x UV relaxation in probe texels (0 = off), y and z mip-0 resolution of the radiance
    // and of the inverse-distance map
    warp: vec4<f32>,
    // the box proxy: centre, half extents, and its world-to-local rotation's columns
    box_centre: vec4<f32>,
    box_half: vec4<f32>,
    box_x: vec4<f32>,
    box_y: vec4<f32>,
    box_z: vec4<f32>,
    // the 18-DOP: normal (xyz) and offset (w) of each plane; bit k of kdop_open.x set: plane
    // k is open (the probe saw sky that way)
    kdop: array<vec4<f32>, 18>,
    kdop_open: vec4<u32>,
    // perceptual roughness of radiance mip m at mip_roughness[m / 4][m % 4]
    mip_roughness: array<vec4<f32>, 4>,
    // tile resolution N (x) and tiles per atlas row (y) of the corrective atlas and the
    // irradiance atlas (z, w)
    atlas_a: vec4<u32>,
    // the same for the moments atlas (x, y) and the irradiance scale atlas (z, w)
    atlas_b: vec4<u32>,
    // the roughness table: x0, inv_dx, k_min, k_max (see export.json's roughness_lookup)
    lut: vec4<f32>,
    // x nodes per axis of the roughness table, y nodes of the irradiance blend
    lut_info: vec4<u32>,
    // the irradiance blend of rough lookups (`RoughnessCorrection::irradiance_weight`):
    // node k's perceptual roughness at blend_r[k / 4][k % 4], its weight likewise in blend_w
    blend_r: array<vec4<f32>, 2>,
    blend_w: array<vec4<f32>, 2>,
    // several specular probes (the grid's `other_probes`): x how many (1: probe A alone), y
    // the corrective atlas tile of a stored cell's probe map is its shift map's tile + y (0:
    // no probe maps, every lookup reads probe A). The probe textures hold the probes side by
    // side: probe p's mip m starts at column p * (its width at m).
    probe_maps: vec4<u32>,
    // every probe's position (xyz), probe A first
    probes: array<vec4<f32>, 16>,
}

// One grid cell: its tiles (x shift map, y irradiance, z irradiance scale, w rough shift
// map in the corrective atlas; -1 = none), its irradiance probe's relocation offset from
// the cell centre (xyz) and its irradiance as nine spherical-harmonic coefficients (rgb;
// zero where y is -1: `IrradianceSh`), what rough lookups blend in, and (links.x) the
// neighbours a rough lookup's read blends it with: bit (ox+1) + 3(oy+1) + 9(oz+1) for
// the cell at offset o in {-1, 0, 1}^3 (`IrradianceSh::links`); links.y is the probe the cell
// reads where it stores no map (`Correctives::cell_probes`; 0 probe A).
struct Cell {
    tiles: vec4<i32>,
    offset: vec4<f32>,
    sh: array<vec4<f32>, 9>,
    links: vec4<u32>,
}

const DYNAMIC: u32 = 255u;
// the proxy: 0 warp1 (the probe's own depth), 1 box, 2 kdop
override FALLBACK: u32 = DYNAMIC;
// 0 the containing cell, 1 trilinear, 2 the containing cell blended near its faces
override BLEND: u32 = DYNAMIC;
// 0 off, 1 on
override RELAX: u32 = DYNAMIC;
// 0 absent (the plain mip of r), 1 present
override ROUGHNESS_CORRECTION: u32 = DYNAMIC;

@group(0) @binding(0) var probe_radiance: texture_2d<f32>;
@group(0) @binding(1) var probe_inv_distance: texture_2d<f32>;
@group(0) @binding(2) var corrective_atlas: texture_2d<f32>;
@group(0) @binding(3) var irradiance_atlas: texture_2d<f32>;
@group(0) @binding(4) var moments_atlas: texture_2d<f32>;
@group(0) @binding(5) var scale_atlas: texture_2d<f32>;
@group(0) @binding(6) var roughness_lut: texture_2d<f32>;
@group(0) @binding(7) var<uniform> params: Params;
@group(0) @binding(8) var<storage, read> cells: array<Cell>;

// 1e30 stands for "at B" and "beyond everything": WGSL has no infinity literal, and
// implementations may assume no infinities, so none is ever made on purpose.
const HUGE: f32 = 1e30;
const F32_MIN_POSITIVE: f32 = 1.17549435e-38;
const F32_EPSILON: f32 = 1.1920929e-7;
const PI: f32 = 3.14159265358979;

const ATLAS_CORRECTIVE: u32 = 0u;
const ATLAS_IRRADIANCE: u32 = 1u;
const ATLAS_MOMENTS: u32 = 2u;
const ATLAS_SCALE: u32 = 3u;

// ---- the grid's settings (specialised or read from Params) -----------------------------

fn fallback_method() -> u32 {
    if FALLBACK == DYNAMIC {
        return params.probe_info.z;
    }
    return FALLBACK;
}

fn blend_mode() -> u32 {
    if BLEND == DYNAMIC {
        return params.grid_counts.w;
    }
    return BLEND;
}

fn relaxation_on() -> bool {
    if RELAX == DYNAMIC {
        return params.warp.x > 0.0;
    }
    return RELAX == 1u;
}

fn roughness_corrected() -> bool {
    if ROUGHNESS_CORRECTION == DYNAMIC {
        return params.probe_info.w != 0u;
    }
    return ROUGHNESS_CORRECTION == 1u;
}

// ---- numbers ---------------------------------------------------------------------------

// Finite (not NaN or infinite), by the bits: comparisons may be optimised on the
// assumption that no NaN exists.
fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn finite3(v: vec3<f32>) -> bool {
    return finite(v.x) && finite(v.y) && finite(v.z);
}

fn sign_not_zero(x: f32) -> f32 {
    return select(-1.0, 1.0, x >= 0.0);
}

// `v` made unit length (w = 1), or w = 0 for a zero or non-finite vector. Scaled by its
// largest component first, so huge and tiny vectors work; a unit vector is kept as is.
fn unit_direction(v: vec3<f32>) -> vec4<f32> {
    let l2 = dot(v, v);
    if finite(l2) && abs(l2 - 1.0) <= 4.0 * F32_EPSILON {
        return vec4<f32>(v, 1.0);
    }
    let m = max(abs(v.x), max(abs(v.y), abs(v.z)));
    if !(m > 0.0 && finite(m) && finite3(v)) {
        return vec4<f32>(0.0, 0.0, 1.0, 0.0);
    }
    let s = v / m;
    let l = length(s);
    if !(l > 0.0 && finite(l)) {
        return vec4<f32>(0.0, 0.0, 1.0, 0.0);
    }
    return vec4<f32>(s / l, 1.0);
}

// `to - from` when usable as a fetch vector, else `fallback`.
fn fetch_vector(from_: vec3<f32>, to: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let v = to - from_;
    let l2 = dot(v, v);
    if l2 > 0.0 && finite(l2) {
        return v;
    }
    return fallback;
}

// ---- octahedral maps -------------------------------------------------------------------

// Direction -> uv in [0,1]^2 (the manifest's `octahedral` convention); a zero, subnormal or
// non-finite vector maps to the centre (+Z).
fn oct_encode(d: vec3<f32>) -> vec2<f32> {
    let l1 = abs(d.x) + abs(d.y) + abs(d.z);
    if !(l1 >= F32_MIN_POSITIVE && finite(l1)) {
        return vec2<f32>(0.5, 0.5);
    }
    let inv_l1 = 1.0 / l1;
    var p = vec2<f32>(d.x * inv_l1, d.y * inv_l1);
    if d.z < 0.0 {
        p = vec2<f32>((1.0 - abs(p.y)) * sign_not_zero(p.x), (1.0 - abs(p.x)) * sign_not_zero(p.y));
    }
    return clamp(p * 0.5 + 0.5, vec2<f32>(0.0), vec2<f32>(1.0));
}

// Integer texel coordinates up to one texel outside an N x N map, folded back inside by the
// octahedral seam rule (an edge's outside neighbour is the mirrored texel of the same edge).
fn wrap_texel(n: i32, t: vec2<i32>) -> vec2<i32> {
    var i = t.x;
    var j = t.y;
    if i < 0 {
        i = -i - 1;
        j = n - 1 - j;
    } else if i >= n {
        i = 2 * n - 1 - i;
        j = n - 1 - j;
    }
    if j < 0 {
        i = n - 1 - i;
        j = -j - 1;
    } else if j >= n {
        i = n - 1 - i;
        j = 2 * n - 1 - j;
    }
    return clamp(vec2<i32>(i, j), vec2<i32>(0), vec2<i32>(n - 1));
}

// The bilinear footprint of uv on an N x N map: its top-left texel (-1 .. N-1) and the
// blend fractions.
struct Footprint {
    corner: vec2<i32>,
    f: vec2<f32>,
}

fn footprint(n: u32, uv: vec2<f32>) -> Footprint {
    let x = clamp(uv, vec2<f32>(0.0), vec2<f32>(1.0)) * f32(n) - 0.5;
    let x0 = floor(x);
    return Footprint(vec2<i32>(x0), x - x0);
}

fn blend4(q00: vec4<f32>, q10: vec4<f32>, q01: vec4<f32>, q11: vec4<f32>, f: vec2<f32>) -> vec4<f32> {
    return (q00 * (1.0 - f.x) + q10 * f.x) * (1.0 - f.y) + (q01 * (1.0 - f.x) + q11 * f.x) * f.y;
}

// Seam-aware bilinear of mip `level` of probe `p` in probe texture `which` (0 radiance, 1
// inverse distance): the probes sit side by side, probe p's texels from column p * n.
fn probe_texel(which: u32, t: vec2<i32>, level: i32) -> vec4<f32> {
    if which == 0u {
        return textureLoad(probe_radiance, t, level);
    }
    return textureLoad(probe_inv_distance, t, level);
}

fn probe_bilinear(which: u32, uv: vec2<f32>, level: u32, p: u32) -> vec4<f32> {
    // mip sizes from the parameters, not textureDimensions: some drivers (llvmpipe 22) answer
    // textureDimensions for one invocation's level when invocations read different mips
    let res0 = select(params.warp.z, params.warp.y, which == 0u);
    let n = max(u32(res0) >> level, 1u);
    let fp = footprint(n, uv);
    let c = fp.corner;
    let l = i32(level);
    let ni = i32(n);
    let at = vec2<i32>(i32(p) * ni, 0);
    let q00 = probe_texel(which, at + wrap_texel(ni, c), l);
    let q10 = probe_texel(which, at + wrap_texel(ni, c + vec2<i32>(1, 0)), l);
    let q01 = probe_texel(which, at + wrap_texel(ni, c + vec2<i32>(0, 1)), l);
    let q11 = probe_texel(which, at + wrap_texel(ni, c + vec2<i32>(1, 1)), l);
    return blend4(q00, q10, q01, q11, fp.f);
}

// Trilinear lookup at fractional `lod` of probe `p`'s mip chain of `levels` levels.
fn probe_sample_lod(which: u32, uv: vec2<f32>, lod_in: f32, levels: u32, p: u32) -> vec4<f32> {
    let top = f32(max(levels, 1u) - 1u);
    var lod = 0.0;
    if finite(lod_in) {
        lod = min(max(lod_in, 0.0), top);
    }
    let l0 = u32(lod);
    let f = lod - f32(l0);
    let a = probe_bilinear(which, uv, l0, p);
    if f == 0.0 || l0 + 1u >= levels {
        return a;
    }
    let b = probe_bilinear(which, uv, l0 + 1u, p);
    return a * (1.0 - f) + b * f;
}

// Radiance of probe `p` at uv and fractional mip `lod`.
fn radiance_lod(uv: vec2<f32>, lod: f32, p: u32) -> vec3<f32> {
    return probe_sample_lod(0u, uv, lod, params.probe_info.x, p).xyz;
}

// Inverse distance probe A sees along `v` at the warps' depth mip: finite and > 0, else 0
// (sky).
fn inv_dist(v: vec3<f32>) -> f32 {
    let w = probe_sample_lod(1u, oct_encode(v), params.probe.w, params.probe_info.y, 0u).x;
    if w > 0.0 && finite(w) {
        return w;
    }
    return 0.0;
}

// Texel `t` of atlas `which`.
fn atlas_texel(which: u32, t: vec2<i32>) -> vec4<f32> {
    switch which {
        case 0u: {
            return textureLoad(corrective_atlas, t, 0);
        }
        case 1u: {
            return textureLoad(irradiance_atlas, t, 0);
        }
        case 2u: {
            return textureLoad(moments_atlas, t, 0);
        }
        default: {
            return textureLoad(scale_atlas, t, 0);
        }
    }
}

// Bilinear of tile `tile` (N x N, `columns` tiles per row, one-texel gutter) of atlas
// `which` at octahedral uv: the gutter holds the seam neighbours, so the footprint is four
// plain loads.
fn atlas_bilinear(which: u32, tile: i32, n: u32, columns: u32, uv: vec2<f32>) -> vec4<f32> {
    let s = u32(tile);
    let origin = vec2<i32>(vec2<u32>(s % columns, s / columns) * (n + 2u));
    let fp = footprint(n, uv);
    let c = origin + fp.corner + vec2<i32>(1, 1);
    let q00 = atlas_texel(which, c);
    let q10 = atlas_texel(which, c + vec2<i32>(1, 0));
    let q01 = atlas_texel(which, c + vec2<i32>(0, 1));
    let q11 = atlas_texel(which, c + vec2<i32>(1, 1));
    return blend4(q00, q10, q01, q11, fp.f);
}

// ---- the grid --------------------------------------------------------------------------

fn cell_size() -> vec3<f32> {
    return (params.grid_max.xyz - params.grid_min.xyz) / vec3<f32>(params.grid_counts.xyz);
}

fn cell_index(c: vec3<u32>) -> u32 {
    let n = params.grid_counts;
    return c.x + n.x * (c.y + n.y * c.z);
}

// The cell containing p, clamped to the grid.
fn cell_of(p: vec3<f32>, size: vec3<f32>) -> vec3<u32> {
    let f = floor((p - params.grid_min.xyz) / size);
    let hi = vec3<f32>(params.grid_counts.xyz - vec3<u32>(1u));
    if !finite3(f) {
        return vec3<u32>(0u);
    }
    return vec3<u32>(clamp(f, vec3<f32>(0.0), hi));
}

fn cell_centre(c: vec3<u32>, size: vec3<f32>) -> vec3<f32> {
    return params.grid_min.xyz + (vec3<f32>(c) + 0.5) * size;
}

// Position in the lattice of cell centres, clamped to it (trilinear blends).
struct Lattice {
    base: vec3<u32>,
    frac: vec3<f32>,
}

fn lattice(p: vec3<f32>, size: vec3<f32>) -> Lattice {
    var f = (p - params.grid_min.xyz) / size - 0.5;
    let hi = vec3<f32>(params.grid_counts.xyz - vec3<u32>(1u));
    if finite3(f) {
        f = clamp(f, vec3<f32>(0.0), hi);
    } else {
        f = vec3<f32>(0.0);
    }
    let base = floor(f);
    return Lattice(vec3<u32>(base), f - base);
}

// Corner `corner` (bits x, y, z) of a lattice cube: its cell and trilinear weight.
fn corner_weight(l: Lattice, corner: u32) -> f32 {
    let o = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
    let wx = select(1.0 - l.frac.x, l.frac.x, o.x == 1u);
    let wy = select(1.0 - l.frac.y, l.frac.y, o.y == 1u);
    let wz = select(1.0 - l.frac.z, l.frac.z, o.z == 1u);
    return wx * wy * wz;
}

fn corner_cell(l: Lattice, corner: u32) -> vec3<u32> {
    let o = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
    return min(l.base + o, params.grid_counts.xyz - vec3<u32>(1u));
}

// ---- the unfitted warps (the fallback of cells without a map) --------------------------

// Where seed 000's one-step warp aims along the ray from B (the probe's second hit
// projected on it), as `box_exit`: x the distance (HUGE where the warp reads sky), y 1.
fn warp1_exit(b: vec3<f32>, dir: vec3<f32>) -> vec2<f32> {
    let a = params.probe.xyz;
    let w1 = inv_dist(dir);
    if w1 == 0.0 {
        return vec2<f32>(HUGE, 1.0);
    }
    let ab = a - b;
    let dir_ab = dot(dir, ab);
    let v = dir * max(dir_ab * w1 + 1.0, 0.0) - ab * w1;
    let lambda = length(v) * inv_dist(v);
    if !(lambda > 0.0) {
        return vec2<f32>(HUGE, 1.0);
    }
    let t = max(dir_ab * lambda + dot(dir, v), 0.0) / lambda;
    if !(finite(t) && t < HUGE) {
        return vec2<f32>(HUGE, 1.0);
    }
    return vec2<f32>(t, 1.0);
}

// Seed 000's plane warp, one step, in the homogeneous form the CPU uses.
fn warp1(b: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let a = params.probe.xyz;
    let w1 = inv_dist(dir);
    if w1 == 0.0 {
        return dir;
    }
    let ab = a - b;
    let dir_ab = dot(dir, ab);
    let v = dir * max(dir_ab * w1 + 1.0, 0.0) - ab * w1;
    let lambda = length(v) * inv_dist(v);
    let t = max(dir_ab * lambda + dot(dir, v), 0.0);
    let f = dir * t - ab * lambda;
    if lambda > 0.0 {
        return fetch_vector(vec3<f32>(0.0), f, dir);
    }
    return dir;
}

// Where the ray from B leaves the oriented box proxy (seed 001): x the distance, y 1 when
// there is one (0: B outside the box, or no exit).
fn box_exit(b: vec3<f32>, dir: vec3<f32>) -> vec2<f32> {
    let m = mat3x3<f32>(params.box_x.xyz, params.box_y.xyz, params.box_z.xyz);
    let h = params.box_half.xyz;
    let o = m * (b - params.box_centre.xyz);
    if any(abs(o) > h) {
        return vec2<f32>(0.0, 0.0);
    }
    let d = m * dir;
    var t = HUGE;
    for (var k = 0; k < 3; k++) {
        if d[k] != 0.0 {
            let face = select(-h[k], h[k], d[k] > 0.0);
            t = min(t, (face - o[k]) / d[k]);
        }
    }
    if !(t < HUGE) {
        return vec2<f32>(0.0, 0.0);
    }
    return vec2<f32>(max(t, 0.0), 1.0);
}

// Where the ray from B leaves the 18-DOP through its nearest closed plane: as `box_exit`,
// with x = HUGE through an open side.
fn kdop_exit(b: vec3<f32>, dir: vec3<f32>) -> vec2<f32> {
    var t = HUGE;
    for (var k = 0u; k < 18u; k++) {
        if (params.kdop_open.x & (1u << k)) != 0u {
            continue;
        }
        let n = params.kdop[k].xyz;
        let h = params.kdop[k].w;
        let nb = dot(n, b);
        if nb > h {
            return vec2<f32>(0.0, 0.0); // B outside the proxy
        }
        let nd = dot(n, dir);
        if nd > 0.0 {
            t = min(t, (h - nb) / nd);
        }
    }
    return vec2<f32>(t, 1.0);
}

// The grid's proxy's exit (see `box_exit`).
fn proxy_exit(b: vec3<f32>, dir: vec3<f32>) -> vec2<f32> {
    switch fallback_method() {
        case 0u: {
            return warp1_exit(b, dir);
        }
        case 2u: {
            return kdop_exit(b, dir);
        }
        default: {
            return box_exit(b, dir);
        }
    }
}

// A proxy's fetch vector: towards where the ray from B leaves it; the query direction when
// B is outside it or the ray leaves through an open side.
fn proxy_fetch(exit: vec2<f32>, b: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    if exit.y == 0.0 || !(exit.x < HUGE) {
        return dir;
    }
    return fetch_vector(params.probe.xyz, b + dir * exit.x, dir);
}

// The box proxy's fetch (the `box_queries` kernel's baseline).
fn box_fetch(b: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    return proxy_fetch(box_exit(b, dir), b, dir);
}

// Frisvad's orthonormal basis around unit n (Duff et al. 2017), as the CPU builds it: the
// two tangents.
struct Basis {
    t: vec3<f32>,
    b: vec3<f32>,
}

fn orthonormal_basis(n: vec3<f32>) -> Basis {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return Basis(vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x), vec3<f32>(b, s + n.y * n.y * a, -n.y));
}

fn normalize_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    if l > 0.0 && finite(l) {
        return v / l;
    }
    return fallback;
}

// The proxy's fetch vector with UV relaxation (seed 000: the fetch direction averaged over
// a 4-tap stencil of query directions), for cells without a map when the grid relaxes. One
// loop: a processor that runs every branch under a mask (llvmpipe) pays for the stencil
// only when relaxation is on.
fn fallback_fetch(b: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    if all(b == params.probe.xyz) {
        return dir;
    }
    let relax = params.warp.x;
    let relaxed = relaxation_on();
    let angle = relax * sqrt(4.0 * PI) / params.warp.y;
    let basis = orthonormal_basis(dir);
    let t = basis.t * angle;
    let bt = basis.b * angle;
    var plain = dir;
    var sum = vec3<f32>(0.0);
    for (var s = 0u; s < select(1u, 5u, relaxed); s++) {
        var d = dir;
        switch s {
            case 1u: {
                d = normalize(dir + t);
            }
            case 2u: {
                d = normalize(dir - t);
            }
            case 3u: {
                d = normalize(dir + bt);
            }
            case 4u: {
                d = normalize(dir - bt);
            }
            default: {}
        }
        let v = proxy_fetch(proxy_exit(b, d), b, d);
        if s == 0u {
            plain = v;
        }
        sum += normalize_or(v, dir);
    }
    if !relaxed {
        return plain;
    }
    return normalize_or(sum, dir);
}

// ---- the fitted correctives ------------------------------------------------------------

// Where a lookup reads: fetch vector v of probe p (0: probe A) and, when it aimed at a
// known point, that point's distance ratio k = d_probe / d_surface (k < 0: unknown, read
// the probe's depth).
struct Aim {
    v: vec3<f32>,
    k: f32,
    p: u32,
}

// The corrective lookup: the ray from B leaves the proxy at `exit` (see `box_exit`); its
// surface shifted by `delta` along dir is where probe A is fetched towards, with that
// point's distance ratio. B outside the proxy, or an open side: the query direction; a
// surface at or behind B: B itself.
fn shifted_aim(exit: vec2<f32>, delta: f32, b: vec3<f32>, dir: vec3<f32>, p: u32) -> Aim {
    if exit.y == 0.0 || !(exit.x < HUGE) {
        return Aim(dir, 1.0, p);
    }
    // at or behind B: aim at B (the CPU's NEAREST)
    var s = exit.x + delta;
    if !(s > 1e-30) {
        s = 1e-30;
    }
    let v = b + dir * s - params.probes[p].xyz;
    if finite3(v) && any(v != vec3<f32>(0.0)) {
        var k = length(v) / s;
        if !(finite(k) && k > 0.0) {
            k = 1.0;
        }
        return Aim(v, k, p);
    }
    return Aim(dir, 1.0, p);
}

// The probe a lookup along the direction of uv reads in a cell whose shift map is tile
// `tile` (< 0: none): the probe map's texel with the greatest bilinear weight (the first
// of equals, in the order of `blend4`'s corners), as `corrective::nearest_tap` picks it;
// without a map the cell's own probe `unmapped` (`Correctives::cell_probe`), without probe
// maps probe A.
fn probe_of(tile: i32, unmapped: u32, uv: vec2<f32>) -> u32 {
    if tile < 0 {
        return min(unmapped, max(params.probe_maps.x, 1u) - 1u);
    }
    if params.probe_maps.y == 0u {
        return 0u;
    }
    let n = params.atlas_a.x;
    let columns = params.atlas_a.y;
    let s = u32(tile) + params.probe_maps.y;
    let origin = vec2<i32>(vec2<u32>(s % columns, s / columns) * (n + 2u));
    let fp = footprint(n, uv);
    let f = fp.f;
    let w = vec4<f32>((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
    var best = 0u;
    for (var k = 1u; k < 4u; k++) {
        if w[k] > w[best] {
            best = k;
        }
    }
    let t = origin + fp.corner + vec2<i32>(1, 1) + vec2<i32>(i32(best & 1u), i32(best >> 1u));
    let p = u32(atlas_texel(ATLAS_CORRECTIVE, t).x);
    return min(p, max(params.probe_maps.x, 1u) - 1u);
}

// The shift of cell tile `tile`'s map along the direction of uv.
fn map_delta(tile: i32, uv: vec2<f32>) -> f32 {
    return atlas_bilinear(ATLAS_CORRECTIVE, tile, params.atlas_a.x, params.atlas_a.y, uv).x;
}

// With a rough map, the roughness up to which a lookup reads the cell's map alone, and
// from which it reads the rough map alone (`warp::corrective::ROUGH_MAP_FROM`, `_TO`).
const ROUGH_MAP_FROM: f32 = 0.5;
const ROUGH_MAP_TO: f32 = 0.75;

// The shift of `cell` (which stores a map) along the direction of uv for a lookup of
// roughness r: its map's, or with a rough map the two blended by r
// (`warp::corrective::sample_maps`).
fn cell_delta(tiles: vec4<i32>, uv: vec2<f32>, r: f32) -> f32 {
    if tiles.w < 0 {
        return map_delta(tiles.x, uv);
    }
    var w = (r - ROUGH_MAP_FROM) / (ROUGH_MAP_TO - ROUGH_MAP_FROM);
    if !(w > 0.0) {
        return map_delta(tiles.x, uv);
    }
    if w >= 1.0 {
        return map_delta(tiles.w, uv);
    }
    let m = map_delta(tiles.x, uv);
    return m + (map_delta(tiles.w, uv) - m) * w;
}

// Where query (B, unit dir) of roughness r reads probe A: the proxy's surface shifted by the
// containing cell's maps (or the trilinear blend of the eight cells' shifts around B, cells
// without a map counting 0); the proxy as it is where no map applies (relaxed when the grid
// relaxes).
fn fetch(b: vec3<f32>, dir: vec3<f32>, r: f32) -> Aim {
    let uv = oct_encode(dir);
    let size = cell_size();
    // the containing cell's probe map says which probe (its own probe without one)
    let home_cell = cells[cell_index(cell_of(b, size))];
    let home = home_cell.tiles;
    let p = probe_of(home.x, home_cell.links.y, uv);
    if all(b == params.probes[p].xyz) {
        return Aim(dir, 1.0, p);
    }
    var delta = 0.0;
    var mapped = false;
    if blend_mode() != 1u {
        let tiles = home;
        if tiles.x >= 0 {
            delta = cell_delta(tiles, uv, r);
            mapped = true;
        }
    } else {
        let l = lattice(b, size);
        for (var corner = 0u; corner < 8u; corner++) {
            let tiles = cells[cell_index(corner_cell(l, corner))].tiles;
            if tiles.x >= 0 {
                delta += corner_weight(l, corner) * cell_delta(tiles, uv, r);
                mapped = true;
            }
        }
    }
    // (the relaxed proxy is probe A's: a cell reading another probe reads it unrelaxed)
    if !mapped && relaxation_on() && p == 0u {
        return Aim(fallback_fetch(b, dir), -1.0, 0u);
    }
    return shifted_aim(proxy_exit(b, dir), delta, b, dir, p);
}

// How far from a cell face (in cells, either side) the faces blend reaches
// (`warp::corrective::FACE_MARGIN`).
const FACE_MARGIN: f32 = 0.125;
// The group of cells without a map when the grid relaxes them (they read the relaxed proxy).
const RELAXED: u32 = 255u;

// A cell-beyond-the-face weight along one axis: 0 up to FACE_MARGIN before the face, 1/2 at
// it (the lattice fraction 1/2), 1 as far beyond it.
fn face_ramp(x: f32) -> f32 {
    return clamp((x - (0.5 - FACE_MARGIN)) / (2.0 * FACE_MARGIN), 0.0, 1.0);
}

// The faces blend's weights at B: the lattice cube around B with each axis's fraction
// ramped (`Correctives::face_cells`); corner_weight of it is a near cell's weight.
fn face_lattice(b: vec3<f32>) -> Lattice {
    let l = lattice(b, cell_size());
    return Lattice(l.base, vec3<f32>(face_ramp(l.frac.x), face_ramp(l.frac.y), face_ramp(l.frac.z)));
}

// Probe radiance of a faces-blend lookup of (B, unit dir, roughness r) near cell faces
// (`Correctives::face_aims`, then `FittedGrid::shade`): each near cell's own lookup (its
// probe and shift; cells without a map read their own probe with no shift, or, reading
// probe A, the relaxed proxy when the grid relaxes), cells with the same probe and shift merged, the radiances
// blended by the cells' weights.
fn faces_radiance(near: Near, b: vec3<f32>, dir: vec3<f32>, r: f32) -> vec3<f32> {
    let uv = oct_encode(dir);
    let relax = relaxation_on();
    // (initialised in full: HLSL's zero cast of an array is not portable)
    var keys = array<u32, 8>(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
    var ws = array<f32, 8>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    var ds = array<f32, 8>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    var n = 0u;
    for (var corner = 0u; corner < 8u; corner++) {
        let w = near_weight(near, corner);
        if !(w > 0.0) {
            continue;
        }
        let cell = cells[cell_index(corner_cell(near.l, corner))];
        let tiles = cell.tiles;
        var key = probe_of(tiles.x, cell.links.y, uv);
        var delta = 0.0;
        if tiles.x >= 0 {
            delta = cell_delta(tiles, uv, r);
        } else if relax && key == 0u {
            key = RELAXED;
        }
        var at = n;
        for (var g = 0u; g < n; g++) {
            if keys[g] == key && ds[g] == delta {
                at = g;
                break;
            }
        }
        if at == n {
            keys[n] = key;
            ws[n] = 0.0;
            ds[n] = delta;
            n++;
        }
        ws[at] += w;
    }
    let exit = proxy_exit(b, dir);
    var c = vec3<f32>(0.0);
    for (var g = 0u; g < n; g++) {
        var aim = Aim(dir, 1.0, keys[g]);
        if keys[g] == RELAXED {
            aim = Aim(fallback_fetch(b, dir), -1.0, 0u);
        } else if any(b != params.probes[keys[g]].xyz) {
            aim = shifted_aim(exit, ds[g], b, dir, keys[g]);
        }
        c += ws[g] * shade(b, aim, r);
    }
    return c;
}

// The cells the faces blend reads at B (`FittedGrid::near_cells`): the corners of
// `face_lattice` l with a weight, kept where the containing cell (at home_at, its link bits
// `links`) links to them; `sum` the kept weights, which renormalise them.
struct Near {
    l: Lattice,
    home_at: vec3<u32>,
    links: u32,
    count: u32,
    sum: f32,
}

// Corner `corner`'s weight in the faces blend before renormalising: its ramped corner
// weight where it is the containing cell or linked to it, else 0.
fn linked_weight(l: Lattice, corner: u32, home_at: vec3<u32>, links: u32) -> f32 {
    let w = corner_weight(l, corner);
    if !(w > 0.0) {
        return 0.0;
    }
    let at = corner_cell(l, corner);
    if all(at == home_at) {
        return w;
    }
    let o = vec3<i32>(at) - vec3<i32>(home_at);
    if any(abs(o) > vec3<i32>(1)) {
        return 0.0;
    }
    let bit = u32((o.x + 1) + 3 * (o.y + 1) + 9 * (o.z + 1));
    return select(0.0, w, ((links >> bit) & 1u) != 0u);
}

fn near_cells(b: vec3<f32>) -> Near {
    let l = face_lattice(b);
    let home_at = cell_of(b, cell_size());
    let links = cells[cell_index(home_at)].links.x;
    var count = 0u;
    var sum = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let w = linked_weight(l, corner, home_at, links);
        if w > 0.0 {
            count++;
            sum += w;
        }
    }
    return Near(l, home_at, links, count, sum);
}

// Near cell `corner`'s share of a faces-blend lookup (0 where it is not read).
fn near_weight(near: Near, corner: u32) -> f32 {
    return linked_weight(near.l, corner, near.home_at, near.links) / near.sum;
}

// A faces-blend lookup near a cell face with its irradiance blend of weight w
// (`FittedGrid::mix_near`): the near cells' irradiance reads, each as if B lay in it,
// averaged over those that hold irradiance, blended by w times their share of the weight.
fn faces_specular(near: Near, b: vec3<f32>, dir: vec3<f32>, r: f32, w: f32) -> vec3<f32> {
    var c = faces_radiance(near, b, dir, r);
    if w > 0.0 {
        var e = vec3<f32>(0.0);
        var share = 0.0;
        for (var corner = 0u; corner < 8u; corner++) {
            let cw = near_weight(near, corner);
            let at = corner_cell(near.l, corner);
            if cw > 0.0 && cells[cell_index(at)].tiles.y >= 0 {
                e += cw * sh_read(at, b, dir);
                share += cw;
            }
        }
        if share > 0.0 {
            c = c * (1.0 - w * share) + (e / share) * (w * share * 0.31830987);
        }
    }
    return c;
}

// ---- rough lookups ---------------------------------------------------------------------

fn mip_roughness(m: u32) -> f32 {
    return params.mip_roughness[m / 4u][m % 4u];
}

// Fractional radiance mip of perceptual roughness r (linear between the mips' roughness).
fn lod_of_roughness(r: f32) -> f32 {
    let n = params.probe_info.x;
    if n < 2u || !(r > mip_roughness(0u)) {
        return 0.0;
    }
    let last = n - 1u;
    if r >= mip_roughness(last) {
        return f32(last);
    }
    var below = 0u;
    for (var t = 0u; t < n; t++) {
        below += select(0u, 1u, mip_roughness(t) <= r);
    }
    let i = clamp(below, 1u, last) - 1u;
    let span = mip_roughness(i + 1u) - mip_roughness(i);
    var f = 0.0;
    if span > 0.0 {
        f = (r - mip_roughness(i)) / span;
    }
    return f32(i) + clamp(f, 0.0, 1.0);
}

// Distance ratio k = d_probe / d_surface of the point probe p sees along v from B.
fn distance_ratio(b: vec3<f32>, v: vec3<f32>, uv: vec2<f32>, p: u32) -> f32 {
    let l = length(v);
    let w = probe_sample_lod(1u, uv, params.probe.w, params.probe_info.y, p).x;
    if !(l > 0.0 && finite(l) && w > 0.0 && finite(w)) {
        return 1.0;
    }
    let d_probe = 1.0 / w;
    let d_surface = length(params.probes[p].xyz + v * (d_probe / l) - b);
    let k = d_probe / d_surface;
    if finite(k) && k > 0.0 {
        return k;
    }
    return 1.0;
}

// Exponent plus mantissa fraction of positive normal k: monotone, exact at powers of two.
fn pseudo_log2(k: f32) -> f32 {
    let bits = bitcast<u32>(k);
    let e = i32((bits >> 23u) & 0xffu) - 127;
    let m = bitcast<f32>((bits & 0x007fffffu) | 0x3f800000u);
    return f32(e) + (m - 1.0);
}

// Perceptual roughness of the mip a lookup of roughness r at distance ratio k reads: the
// fitted correction's table, bilinear (export.json's roughness_lookup.rule).
fn corrected_roughness(r: f32, k_in: f32) -> f32 {
    let n = params.lut_info.x;
    let last = f32(n - 1u);
    var fr = 0.0;
    if finite(r) {
        fr = clamp(r * last, 0.0, last);
    }
    var k = 1.0;
    if finite(k_in) && k_in > 0.0 {
        k = k_in;
    }
    k = clamp(k, params.lut.z, params.lut.w);
    let fx = clamp((pseudo_log2(k) - params.lut.x) * params.lut.y, 0.0, last);
    let i = min(u32(fr), n - 2u);
    let j = min(u32(fx), n - 2u);
    let a = fr - f32(i);
    let b = fx - f32(j);
    let v00 = textureLoad(roughness_lut, vec2<i32>(i32(j), i32(i)), 0).x;
    let v01 = textureLoad(roughness_lut, vec2<i32>(i32(j + 1u), i32(i)), 0).x;
    let v10 = textureLoad(roughness_lut, vec2<i32>(i32(j), i32(i + 1u)), 0).x;
    let v11 = textureLoad(roughness_lut, vec2<i32>(i32(j + 1u), i32(i + 1u)), 0).x;
    return (v00 * (1.0 - b) + v01 * b) * (1.0 - a) + (v10 * (1.0 - b) + v11 * b) * a;
}

// Radiance of the aim's probe for query (B, unit dir, roughness r) along `aim`, the mip
// from the roughness correction (the plain mip of r without one).
fn shade(b: vec3<f32>, aim: Aim, r: f32) -> vec3<f32> {
    let uv = oct_encode(aim.v);
    if r == 0.0 {
        return radiance_lod(uv, 0.0, aim.p);
    }
    if !roughness_corrected() {
        return radiance_lod(uv, lod_of_roughness(r), aim.p);
    }
    var k = aim.k;
    if k < 0.0 {
        k = distance_ratio(b, aim.v, uv, aim.p);
    }
    return radiance_lod(uv, lod_of_roughness(corrected_roughness(r, k)), aim.p);
}

fn blend_node_r(k: u32) -> f32 {
    return params.blend_r[k / 4u][k % 4u];
}

fn blend_node_w(k: u32) -> f32 {
    return params.blend_w[k / 4u][k % 4u];
}

// Share of a lookup of perceptual roughness r taken from the containing cell's irradiance:
// `RoughnessCorrection::irradiance_weight` (linear in r between the nodes: on the last
// segment starting below r, wa (1 - t) + wb t).
fn irradiance_weight(r: f32) -> f32 {
    let n = params.lut_info.y;
    if n == 0u || !(r > 0.0) {
        return 0.0;
    }
    var w = blend_node_w(0u);
    for (var k = 1u; k < n; k++) {
        let ra = blend_node_r(k - 1u);
        if r > ra {
            let t = min(max((r - ra) / (blend_node_r(k) - ra), 0.0), 1.0);
            w = blend_node_w(k - 1u) * (1.0 - t) + blend_node_w(k) * t;
        }
    }
    return min(max(w, 0.0), 1.0);
}

// ---- the two lookups -------------------------------------------------------------------

fn clean(c: vec3<f32>) -> vec3<f32> {
    if finite3(c) {
        return max(c, vec3<f32>(0.0));
    }
    return vec3<f32>(0.0);
}

// Radiance reflected towards `direction` from `position` for perceptual roughness
// `roughness`: `FittedGrid::specular`.
fn specular(position: vec3<f32>, direction: vec3<f32>, roughness: f32) -> vec3<f32> {
    let d = unit_direction(direction);
    if d.w == 0.0 {
        return vec3<f32>(0.0);
    }
    var b = params.probe.xyz;
    if finite3(position) {
        b = position;
    }
    var r = 0.0;
    if finite(roughness) {
        r = clamp(roughness, 0.0, 1.0);
    }
    // rough lookups: blended with the containing cell's irradiance over π; at weight 1
    // probe A is not read
    let w = irradiance_weight(r);
    if blend_mode() == 2u {
        let near = near_cells(b);
        if near.count > 1u {
            return clean(faces_specular(near, b, d.xyz, r, w));
        }
    }
    var home_at = vec3<u32>(0u);
    var stored = false;
    if w > 0.0 {
        home_at = cell_of(b, cell_size());
        stored = cells[cell_index(home_at)].tiles.y >= 0;
    }
    if stored && w >= 1.0 {
        return clean(sh_read(home_at, b, d.xyz) * (w * 0.31830987));
    }
    var c = shade(b, fetch(b, d.xyz, r), r);
    if stored {
        c = c * (1.0 - w) + sh_read(home_at, b, d.xyz) * (w * 0.31830987);
    }
    return clean(c);
}

// Irradiance of stored cell tile `tile` for unit normal n (bilinear in its map).
fn cell_irradiance(tile: i32, n: vec3<f32>) -> vec3<f32> {
    return atlas_bilinear(ATLAS_IRRADIANCE, tile, params.atlas_a.z, params.atlas_a.w, oct_encode(n)).xyz;
}

// The function with harmonic coefficients c at unit direction n: `sh::eval`, the nine
// real harmonics of bands 0-2 weighted by the coefficients, summed as the same tree,
// clamped at 0.
fn sh_eval(c: array<vec3<f32>, 9>, n: vec3<f32>) -> vec3<f32> {
    let x = n.x;
    let y = n.y;
    let z = n.z;
    let t0 = c[0] * 0.2820948;
    let t1 = c[1] * (0.4886025 * y);
    let t2 = c[2] * (0.4886025 * z);
    let t3 = c[3] * (0.4886025 * x);
    let t4 = c[4] * (1.0925484 * (x * y));
    let t5 = c[5] * (1.0925484 * (y * z));
    let t6 = c[6] * (0.31539157 * (3.0 * (z * z) - 1.0));
    let t7 = c[7] * (1.0925484 * (x * z));
    let t8 = c[8] * (0.5462742 * (x * x - y * y));
    let e = ((t0 + t1) + (t2 + t3)) + ((t4 + t5) + (t6 + t7)) + t8;
    return max(e, vec3<f32>(0.0));
}

// Irradiance of cell `cell` for unit direction n from its own harmonics.
fn cell_sh_irradiance(cell: u32, n: vec3<f32>) -> vec3<f32> {
    let c = array<vec3<f32>, 9>(
        cells[cell].sh[0].xyz, cells[cell].sh[1].xyz, cells[cell].sh[2].xyz,
        cells[cell].sh[3].xyz, cells[cell].sh[4].xyz, cells[cell].sh[5].xyz,
        cells[cell].sh[6].xyz, cells[cell].sh[7].xyz, cells[cell].sh[8].xyz,
    );
    return sh_eval(c, n);
}

// Coefficient i of four cells' harmonics weighted by w, summed as `IrradianceSh::read`
// sums them.
fn sh_blend4(at: vec4<u32>, w: vec4<f32>, i: u32) -> vec3<f32> {
    return (cells[at[0]].sh[i].xyz * w[0] + cells[at[1]].sh[i].xyz * w[1])
        + (cells[at[2]].sh[i].xyz * w[2] + cells[at[3]].sh[i].xyz * w[3]);
}

// Irradiance at b (finite) for unit direction n, smooth across cells, `home_at` the stored
// cell that contains b (or, for the faces blend, a near cell read as if b lay in it):
// `IrradianceSh::read_in`. The four cells of the tetrahedron of the cell-centre lattice
// that holds b (Kuhn's split of the lattice cube, corners in the order of b's fractions),
// those `home` does not link to weighing 0, the weights renormalised; the coefficients
// summed, then read once.
fn sh_read(home_at: vec3<u32>, b: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let size = cell_size();
    let counts = params.grid_counts.xyz;
    let top = counts - vec3<u32>(1u);
    let units = (b - params.grid_min.xyz) / size;
    let home = cell_index(home_at);
    let f0 = units - 0.5;
    if !finite3(f0) {
        return cell_sh_irradiance(home, n);
    }
    let f = clamp(f0, vec3<f32>(0.0), vec3<f32>(top));
    let fl = floor(f);
    var base = vec3<u32>(fl);
    var frac = f - fl;
    // the axes by decreasing fraction (ties in axis order)
    var a = 0u;
    var bx = 1u;
    var c = 2u;
    if frac[bx] > frac[a] {
        let t = a;
        a = bx;
        bx = t;
    }
    if frac[c] > frac[bx] {
        let t = bx;
        bx = c;
        c = t;
        if frac[bx] > frac[a] {
            let u = a;
            a = bx;
            bx = u;
        }
    }
    let weights = vec4<f32>(1.0 - frac[a], frac[a] - frac[bx], frac[bx] - frac[c], frac[c]);
    // each corner's index and its bit in the links, stepped along with it
    var top_v = top;
    var home_v = home_at;
    let cell_stride = vec3<u32>(1u, counts.x, counts.x * counts.y);
    let bit_stride = vec3<u32>(1u, 3u, 9u);
    let cell0 = base.x + counts.x * (base.y + counts.y * base.z);
    var bit0 = 0u;
    for (var x = 0u; x < 3u; x++) {
        let up = base[x] + 1u;
        var rel = 0u;
        if up > home_v[x] {
            rel = min(up - home_v[x], 2u);
        }
        bit0 = bit0 + rel * bit_stride[x];
    }
    // (vectors, not arrays: a local array's HLSL form is one glslang refuses)
    var corner_cell = vec4<u32>(cell0);
    var bits = vec4<u32>(bit0);
    let axes = vec3<u32>(a, bx, c);
    for (var k = 1u; k < 4u; k++) {
        let x = axes[k - 1u];
        var cs = 0u;
        var bs = 0u;
        if base[x] < top_v[x] {
            cs = cell_stride[x];
            bs = bit_stride[x];
        }
        corner_cell[k] = corner_cell[k - 1u] + cs;
        bits[k] = bits[k - 1u] + bs;
    }
    let links = cells[home].links.x;
    var w = weights;
    var at = vec4<u32>(home);
    let count = arrayLength(&cells);
    for (var k = 0u; k < 4u; k++) {
        let ck = corner_cell[k];
        var kept = false;
        if bits[k] < 27u && ((links >> bits[k]) & 1u) != 0u && ck < count {
            kept = cells[ck].tiles.y >= 0;
        }
        if kept {
            at[k] = ck;
        } else {
            w[k] = 0.0;
        }
    }
    let wsum = (w[0] + w[1]) + (w[2] + w[3]);
    if !(wsum > 0.0) {
        return cell_sh_irradiance(home, n);
    }
    let acc = array<vec3<f32>, 9>(
        sh_blend4(at, w, 0u), sh_blend4(at, w, 1u), sh_blend4(at, w, 2u),
        sh_blend4(at, w, 3u), sh_blend4(at, w, 4u), sh_blend4(at, w, 5u),
        sh_blend4(at, w, 6u), sh_blend4(at, w, 7u), sh_blend4(at, w, 8u),
    );
    return sh_eval(acc, n) / wsum;
}

// Irradiance at `position` for surface normal `normal`: `FittedGrid::irradiance`. The
// eight cells around the point moved along the normal by the surface bias, weighted
// trilinearly, by a smooth back-face term and by Chebyshev visibility from the distance
// moments (DDGI), each cell's answer scaled by its fitted correction.
fn irradiance(position: vec3<f32>, normal: vec3<f32>) -> vec3<f32> {
    let nd = unit_direction(normal);
    if nd.w == 0.0 {
        return vec3<f32>(0.0);
    }
    let n = nd.xyz;
    let size = cell_size();
    var p = params.grid_min.xyz + (params.grid_max.xyz - params.grid_min.xyz) * 0.5;
    let biased = position + n * params.grid_min.w;
    if finite3(biased) {
        p = biased;
    }
    let l = lattice(p, size);
    let uv_n = oct_encode(n);
    var e = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let tri = corner_weight(l, corner);
        if tri <= 0.0 {
            continue;
        }
        let c = corner_cell(l, corner);
        let index = cell_index(c);
        let tiles = cells[index].tiles;
        if tiles.y < 0 {
            continue;
        }
        let to_point = p - (cell_centre(c, size) + cells[index].offset.xyz);
        let dist = length(to_point);
        var w = tri;
        if dist > 0.0 && finite(dist) {
            let u = to_point / dist;
            let facing = (dot(n, -u) + 1.0) * 0.5;
            w *= facing * facing + 0.2;
            let m = atlas_bilinear(ATLAS_MOMENTS, tiles.y, params.atlas_b.x, params.atlas_b.y, oct_encode(u));
            let mean = m.x;
            let mean_sq = m.y;
            if dist > mean {
                let variance = max(abs(mean_sq - mean * mean), 1e-12 * mean * mean);
                let dd = dist - mean;
                let cheb = variance / (variance + dd * dd);
                w *= max(cheb * cheb * cheb, 0.0);
            }
        }
        w = max(w, 1e-6 * tri);
        var k = 1.0;
        if tiles.z >= 0 {
            k = atlas_bilinear(ATLAS_SCALE, tiles.z, params.atlas_b.z, params.atlas_b.w, uv_n).x;
        }
        e += cell_irradiance(tiles.y, n) * w * k;
        wsum += w;
    }
    if !(wsum > 0.0) {
        return vec3<f32>(0.0);
    }
    return clean(e / wsum);
}

// ---- query kernels ---------------------------------------------------------------------
// Batches of lookups, one invocation each: what the tests compare with the CPU sampler and
// the GPU bench times. `queries` holds two vec4 per query; `results` one vec4 (xyz).

// ---------------------------------------------------------------------------------------
// Surface probes (seed 003): a port of `warpfit::warp::surface::SurfaceAtlas::radiance`.

// One atlas: its patch `corner + s*edge_u + t*edge_v`, the tangent frame the tiles are
// stored in, the dual basis giving (s, t), and its shape.
struct SurfaceParams {
    corner: vec4<f32>,     // xyz; w: the probes' height above the surface
    edge_u: vec4<f32>,     // xyz: the patch's first edge (probes along it: shape.x)
    edge_v: vec4<f32>,     // xyz: its second edge (probes along it: shape.y)
    tangent: vec4<f32>,    // xyz (unit edge_u)
    bitangent: vec4<f32>,  // xyz (normal x tangent)
    normal: vec4<f32>,     // xyz (unit edge_u x edge_v)
    dual_u: vec4<f32>,     // s = dot(dual_u, p - corner)
    dual_v: vec4<f32>,     // t = dot(dual_v, p - corner)
    shape: vec4<u32>,      // probes along edge_u, along edge_v, tile resolution N, layers
}

@group(2) @binding(0) var surface_radiance: texture_2d_array<f32>;
@group(2) @binding(1) var<uniform> surface_params: SurfaceParams;
@group(2) @binding(2) var surface_inv_distance: texture_2d<f32>;

// Tangent-space direction -> hemi-octahedral uv in [0,1]^2 (`octa::hemi::encode`).
fn hemi_encode(v: vec3<f32>) -> vec2<f32> {
    let z = max(v.z, 0.0);
    let l1 = abs(v.x) + abs(v.y) + z;
    if !(l1 >= F32_MIN_POSITIVE && finite(l1)) {
        return vec2<f32>(0.5, 0.5);
    }
    let px = v.x / l1;
    let py = v.y / l1;
    return clamp(vec2<f32>((px + py) * 0.5 + 0.5, (px - py) * 0.5 + 0.5), vec2<f32>(0.0), vec2<f32>(1.0));
}

// Where a point falls between probes along one edge: nearest lower probe, the next one
// (clamped), and the blend fraction; `x` is the surface coordinate (NaN reads 0.5).
struct SurfaceAxis {
    i0: u32,
    i1: u32,
    f: f32,
}

fn surface_axis(x_in: f32, n: u32) -> SurfaceAxis {
    var x = 0.5;
    if finite(x_in) {
        x = x_in;
    }
    let c = clamp(x * f32(n) - 0.5, 0.0, f32(n - 1u));
    let i0 = u32(floor(c));
    return SurfaceAxis(i0, min(i0 + 1u, n - 1u), c - f32(i0));
}

// Where a bilinear lookup at `uv` reads a tile (`octa::hemi::taps`): the lower and upper
// texel of each axis inside the tile (clamped to its edge) and the blend fractions. The
// same for every tile, so one lookup finds them once.
struct SurfaceTaps {
    lo: vec2<u32>,
    hi: vec2<u32>,
    f: vec2<f32>,
}

fn surface_taps(uv: vec2<f32>) -> SurfaceTaps {
    let n = surface_params.shape.z;
    let nf = f32(n);
    let x = clamp(uv.x * nf - 0.5, 0.0, nf - 1.0);
    let y = clamp(uv.y * nf - 0.5, 0.0, nf - 1.0);
    let x0 = floor(x);
    let y0 = floor(y);
    let lo = vec2<u32>(u32(x0), u32(y0));
    return SurfaceTaps(lo, min(lo + 1u, vec2<u32>(n - 1u)), vec2<f32>(x - x0, y - y0));
}

// Bilinear read of probe (i, j)'s tile in layer `layer` at taps `t`.
fn surface_tile(i: u32, j: u32, layer: u32, t: SurfaceTaps) -> vec3<f32> {
    let o = vec2<u32>(i, j) * surface_params.shape.z;
    let l = i32(layer);
    let q00 = textureLoad(surface_radiance, vec2<i32>(o + t.lo), l, 0);
    let q10 = textureLoad(surface_radiance, vec2<i32>(o + vec2<u32>(t.hi.x, t.lo.y)), l, 0);
    let q01 = textureLoad(surface_radiance, vec2<i32>(o + vec2<u32>(t.lo.x, t.hi.y)), l, 0);
    let q11 = textureLoad(surface_radiance, vec2<i32>(o + t.hi), l, 0);
    return blend4(q00, q10, q01, q11, t.f).xyz;
}

// Bilinear 1/distance of probe (i, j)'s tile at taps `t`.
fn surface_tile_inv_distance(i: u32, j: u32, t: SurfaceTaps) -> f32 {
    let o = vec2<u32>(i, j) * surface_params.shape.z;
    let q00 = textureLoad(surface_inv_distance, vec2<i32>(o + t.lo), 0);
    let q10 = textureLoad(surface_inv_distance, vec2<i32>(o + vec2<u32>(t.hi.x, t.lo.y)), 0);
    let q01 = textureLoad(surface_inv_distance, vec2<i32>(o + vec2<u32>(t.lo.x, t.hi.y)), 0);
    let q11 = textureLoad(surface_inv_distance, vec2<i32>(o + t.hi), 0);
    return blend4(q00, q10, q01, q11, t.f).x;
}

// Where probe (i, j) reads for a lookup from `b` along tangent-space `local` (`shared`:
// where every probe reads unwarped): seed 000's plane warp from that probe, as
// `SurfaceAtlas::radiance_warped` does. w1 is the probe's 1/distance along the direction;
// the plane perpendicular to it at that hit is crossed by the ray from B, and the probe
// reads towards the crossing. Sky (w1 = 0) or an unusable vector: the shared taps.
fn surface_warped_taps(i: u32, j: u32, b: vec3<f32>, local: vec3<f32>, shared_taps: SurfaceTaps) -> SurfaceTaps {
    let sp = surface_params;
    let s = (f32(i) + 0.5) / f32(sp.shape.x);
    let t = (f32(j) + 0.5) / f32(sp.shape.y);
    let probe = sp.corner.xyz + sp.edge_u.xyz * s + sp.edge_v.xyz * t + sp.normal.xyz * sp.corner.w;
    let d = probe - b;
    let ab = vec3<f32>(dot(d, sp.tangent.xyz), dot(d, sp.bitangent.xyz), dot(d, sp.normal.xyz));
    let w1 = surface_tile_inv_distance(i, j, shared_taps);
    let v = local * max(dot(local, ab) * w1 + 1.0, 0.0) - ab * w1;
    if w1 > 0.0 && finite3(v) && dot(v, v) > 0.0 {
        return surface_taps(hemi_encode(v));
    }
    return shared_taps;
}

// Probe (i, j)'s radiance at taps `t`, linear in roughness between layers m0 and m1.
fn surface_probe(i: u32, j: u32, t: SurfaceTaps, m0: u32, m1: u32, fm: f32) -> vec3<f32> {
    let a = surface_tile(i, j, m0, t);
    if fm > 0.0 {
        return mix(a, surface_tile(i, j, m1, t), fm);
    }
    return a;
}

// Radiance arriving at `b` (a point on or just off the atlas's surface) from direction
// `dir` at perceptual roughness `roughness`: the four nearest probes blended bilinearly by
// the point's (s, t), each read bilinearly in its tile; with `warped`, each probe first
// warped by its own depth (`surface_warped_taps`). Black for a zero or non-finite
// direction; a non-finite position reads the patch's corner; a point off the patch reads
// its nearest probes; roughness is clamped to [0, 1] (NaN reads 0).
fn surface_lookup(b_in: vec3<f32>, dir_in: vec3<f32>, roughness: f32, warped: bool) -> vec3<f32> {
    let u = unit_direction(dir_in);
    if u.w == 0.0 {
        return vec3<f32>(0.0);
    }
    let sp = surface_params;
    var b = sp.corner.xyz;
    if finite3(b_in) {
        b = b_in;
    }
    let d = b - sp.corner.xyz;
    let ax = surface_axis(dot(sp.dual_u.xyz, d), sp.shape.x);
    let ay = surface_axis(dot(sp.dual_v.xyz, d), sp.shape.y);
    let last = sp.shape.w - 1u;
    var lod = 0.0;
    if finite(roughness) {
        lod = clamp(roughness, 0.0, 1.0) * f32(last);
    }
    let m0 = u32(floor(lod));
    let m1 = min(m0 + 1u, last);
    let fm = lod - f32(m0);
    let dir = u.xyz;
    let local = vec3<f32>(dot(dir, sp.tangent.xyz), dot(dir, sp.bitangent.xyz), dot(dir, sp.normal.xyz));
    let shared_taps = surface_taps(hemi_encode(local));
    var t00 = shared_taps;
    var t10 = shared_taps;
    var t01 = shared_taps;
    var t11 = shared_taps;
    if warped {
        t00 = surface_warped_taps(ax.i0, ay.i0, b, local, shared_taps);
        t10 = surface_warped_taps(ax.i1, ay.i0, b, local, shared_taps);
        t01 = surface_warped_taps(ax.i0, ay.i1, b, local, shared_taps);
        t11 = surface_warped_taps(ax.i1, ay.i1, b, local, shared_taps);
    }
    let top = mix(surface_probe(ax.i0, ay.i0, t00, m0, m1, fm), surface_probe(ax.i1, ay.i0, t10, m0, m1, fm), ax.f);
    let bottom = mix(surface_probe(ax.i0, ay.i1, t01, m0, m1, fm), surface_probe(ax.i1, ay.i1, t11, m0, m1, fm), ax.f);
    let l = mix(top, bottom, ay.f);
    if finite3(l) {
        return max(l, vec3<f32>(0.0));
    }
    return vec3<f32>(0.0);
}

// Seed 003's lookup (`SurfaceAtlas::radiance`).
fn surface_specular(b: vec3<f32>, dir: vec3<f32>, roughness: f32) -> vec3<f32> {
    return surface_lookup(b, dir, roughness, false);
}

// The same, each probe warped by its own depth first (`SurfaceAtlas::radiance_warped`).
fn surface_specular_warped(b: vec3<f32>, dir: vec3<f32>, roughness: f32) -> vec3<f32> {
    return surface_lookup(b, dir, roughness, true);
}

@group(1) @binding(0) var<storage, read> queries: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read_write> results: array<vec4<f32>>;

fn query_count() -> u32 {
    return arrayLength(&results);
}

// query k: (position xyz, roughness), (direction xyz, -)
@compute @workgroup_size(64)
fn specular_queries(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= query_count() {
        return;
    }
    let p = queries[2u * k];
    let d = queries[2u * k + 1u];
    results[k] = vec4<f32>(specular(p.xyz, d.xyz, p.w), 1.0);
}

// query k: (position xyz, -), (normal xyz, -)
@compute @workgroup_size(64)
fn irradiance_queries(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= query_count() {
        return;
    }
    let p = queries[2u * k];
    let n = queries[2u * k + 1u];
    results[k] = vec4<f32>(irradiance(p.xyz, n.xyz), 1.0);
}

// Baselines in the same style, for the cost comparison: a mirror lookup through seed 000's
// one-step warp alone, and through the box proxy alone (queries as `specular_queries`).
@compute @workgroup_size(64)
fn warp1_queries(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= query_count() {
        return;
    }
    var b = params.probe.xyz;
    if finite3(queries[2u * k].xyz) {
        b = queries[2u * k].xyz;
    }
    let d = unit_direction(queries[2u * k + 1u].xyz);
    var c = vec3<f32>(0.0);
    if d.w != 0.0 {
        var v = d.xyz;
        if any(b != params.probe.xyz) {
            v = warp1(b, d.xyz);
        }
        c = clean(radiance_lod(oct_encode(v), 0.0, 0u));
    }
    results[k] = vec4<f32>(c, 1.0);
}

@compute @workgroup_size(64)
fn box_queries(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= query_count() {
        return;
    }
    var b = params.probe.xyz;
    if finite3(queries[2u * k].xyz) {
        b = queries[2u * k].xyz;
    }
    let d = unit_direction(queries[2u * k + 1u].xyz);
    var c = vec3<f32>(0.0);
    if d.w != 0.0 {
        var v = d.xyz;
        if any(b != params.probe.xyz) {
            v = box_fetch(b, d.xyz);
        }
        c = clean(radiance_lod(oct_encode(v), 0.0, 0u));
    }
    results[k] = vec4<f32>(c, 1.0);
}

// query k: (position xyz, roughness), (direction xyz, -); reads group 2's atlas
@compute @workgroup_size(64)
fn surface_queries(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= query_count() {
        return;
    }
    let p = queries[2u * k];
    let d = queries[2u * k + 1u];
    results[k] = vec4<f32>(surface_specular(p.xyz, d.xyz, p.w), 1.0);
}

// query k: (position xyz, roughness), (direction xyz, -); reads group 2's atlas
@compute @workgroup_size(64)
fn surface_warped_queries(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= query_count() {
        return;
    }
    let p = queries[2u * k];
    let d = queries[2u * k + 1u];
    results[k] = vec4<f32>(surface_specular_warped(p.xyz, d.xyz, p.w), 1.0);
}

// ---- drawing a level: a vertex and a pixel shader ---------------------------------------
//
// An engine's own pixel shader calls `specular` and `irradiance` as these two entry points
// do; they are what `warpfit render` rasterises a level with. Every visible surface is
// shaded as a glossy reflector of roughness `camera.shading.x` (the view ray reflected
// about the normal, read by `specular`) or, with `camera.shading.y` = 1, as a diffuse one
// (`irradiance` × albedo / π). Back faces of one-sided materials are drawn black, as the
// CPU-drawn views draw them; the sky is not drawn (alpha 0 where no surface is).
//
// Group 3:
//   0 camera  uniform buffer (struct CameraParams)
// Vertex buffer 0, per vertex (14 f32): position (xyz), the triangle's geometric normal
// (xyz, the side its corners wind counter-clockwise around), albedo (rgb), flags (bit 0:
// the material is two-sided), sphere (centre xyz, radius; radius 0: a triangle, negative:
// a sphere lit from inside). A sphere is drawn as the 36 corners of a box around it and
// intersected exactly in each pixel.

struct CameraParams {
    // world to clip space (depth 1 at the near plane, 0 at infinity: reverse Z)
    view_proj: mat4x4<f32>,
    // the camera's position (xyz)
    eye: vec4<f32>,
    // how far a shaded point moves off its surface, as the tracer moves ray origins:
    // (max |(p - xyz) · w| + 1) · 2e-5 / w
    surface_offset: vec4<f32>,
    // x perceptual roughness, y 0 specular / 1 diffuse, z what location 0 holds (0 the
    // radiance, 1 the query's direction)
    shading: vec4<f32>,
}

@group(3) @binding(0) var<uniform> camera: CameraParams;

struct SurfaceVertex {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    @location(3) flags: f32,
    @location(4) sphere: vec4<f32>,
}

struct SurfaceVarying {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) normal: vec3<f32>,
    @location(2) @interpolate(flat) albedo: vec3<f32>,
    @location(3) @interpolate(flat) flags: f32,
    @location(4) @interpolate(flat) sphere: vec4<f32>,
}

// What a pixel shows (location 0: radiance, alpha 1 wherever a surface is drawn; with
// `camera.shading.z` = 1 instead the query's direction: the reflected view ray or, diffuse,
// the normal, w the roughness) and where it asked (location 1: the shaded point, w 1 where
// shaded, 0 on a back face drawn black). Two RGBA32F targets fit WebGPU's 32 bytes per
// sample.
struct SurfaceOut {
    @location(0) radiance: vec4<f32>,
    @location(1) query_point: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@vertex
fn surface_vertex(v: SurfaceVertex) -> SurfaceVarying {
    var out: SurfaceVarying;
    out.clip = camera.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.albedo = v.albedo;
    out.flags = v.flags;
    out.sphere = v.sphere;
    return out;
}

fn offset_off_surface(p: vec3<f32>) -> f32 {
    let pn = abs((p - camera.surface_offset.xyz) * camera.surface_offset.w);
    return (max(pn.x, max(pn.y, pn.z)) + 1.0) * 2e-5 / camera.surface_offset.w;
}

@fragment
fn surface_fragment(v: SurfaceVarying) -> SurfaceOut {
    var out: SurfaceOut;
    out.depth = v.clip.z;
    let eye = camera.eye.xyz;
    let ray = normalize(v.world - eye);
    var p = v.world;
    var n = v.normal;
    if v.sphere.w != 0.0 {
        // the nearest intersection in front of the eye with the exact sphere
        let oc = eye - v.sphere.xyz;
        let half_b = dot(oc, ray);
        let c = dot(oc, oc) - v.sphere.w * v.sphere.w;
        let disc = half_b * half_b - c;
        if disc < 0.0 {
            discard;
        }
        let s = sqrt(disc);
        var t = -half_b - s;
        if t <= 0.0 {
            t = -half_b + s;
        }
        if t <= 0.0 {
            discard;
        }
        p = eye + ray * t;
        n = normalize(p - v.sphere.xyz);
        if v.sphere.w < 0.0 {
            n = -n;
        }
        let clip = camera.view_proj * vec4<f32>(p, 1.0);
        out.depth = clamp(clip.z / clip.w, 0.0, 1.0);
    }
    let back = dot(n, ray) > 0.0;
    if back && (u32(v.flags) & 1u) == 0u {
        out.radiance = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        out.query_point = vec4<f32>(p, 0.0);
        return out;
    }
    if back {
        n = -n;
    }
    let b = p + n * offset_off_surface(p);
    out.query_point = vec4<f32>(b, 1.0);
    var dir = n;
    var r = 0.0;
    if camera.shading.y == 1.0 {
        out.radiance = vec4<f32>(irradiance(b, n) * v.albedo * 0.31830987, 1.0);
    } else {
        dir = normalize(ray - 2.0 * dot(ray, n) * n);
        r = camera.shading.x;
        out.radiance = vec4<f32>(specular(b, dir, r), 1.0);
    }
    if camera.shading.z == 1.0 {
        out.radiance = vec4<f32>(dir, r);
    }
    return out;
}
