struct Params {
    float4 grid_min;
    float4 grid_max;
    uint4 grid_counts;
    float4 probe;
    uint4 probe_info;
    float4 warp;
    float4 box_centre;
    float4 box_half;
    float4 box_x;
    float4 box_y;
    float4 box_z;
    float4 kdop[18];
    uint4 kdop_open;
    float4 mip_roughness[4];
    uint4 atlas_a;
    uint4 atlas_b;
    float4 lut;
    uint4 lut_info;
    float4 blend_r[2];
    float4 blend_w[2];
    uint4 probe_maps;
    float4 probes[16];
};

struct Cell {
    int4 tiles;
    float4 offset;
    float4 sh[9];
    uint4 links;
};

struct Footprint {
    int2 corner;
    float2 f;
};

struct Lattice {
    uint3 base;
    int _pad1_0;
    float3 frac_;
    int _end_pad_0;
};

struct Basis {
    float3 t;
    int _pad1_0;
    float3 b;
    int _end_pad_0;
};

struct Aim {
    float3 v;
    float k;
    uint p;
    int _end_pad_0;
    int _end_pad_1;
    int _end_pad_2;
};

struct Near {
    Lattice l;
    uint3 home_at;
    uint links;
    uint count;
    float sum;
    int _end_pad_0;
    int _end_pad_1;
};

struct SurfaceParams {
    float4 corner;
    float4 edge_u;
    float4 edge_v;
    float4 tangent;
    float4 bitangent;
    float4 normal;
    float4 dual_u;
    float4 dual_v;
    uint4 shape;
};

struct SurfaceAxis {
    uint i0_;
    uint i1_;
    float f;
};

struct SurfaceTaps {
    uint2 lo;
    uint2 hi;
    float2 f;
};

struct CameraParams {
    row_major float4x4 view_proj;
    float4 eye;
    float4 surface_offset;
    float4 shading;
};

struct SurfaceVertex {
    float3 position : LOC0;
    float3 normal : LOC1;
    float3 albedo : LOC2;
    float flags : LOC3;
    float4 sphere : LOC4;
};

struct SurfaceVarying {
    float4 clip_ : SV_Position;
    float3 world : LOC0;
    nointerpolation float3 normal : LOC1;
    nointerpolation float3 albedo : LOC2;
    nointerpolation float flags : LOC3;
    nointerpolation float4 sphere : LOC4;
};

struct SurfaceOut {
    float4 radiance : SV_Target0;
    float4 query_point : SV_Target1;
    float depth : SV_Depth;
};

static const uint DYNAMIC = 255u;
static const float HUGE = 1e30;
static const float F32_MIN_POSITIVE = 1.1754944e-38;
static const float F32_EPSILON = 1.1920929e-7;
static const float PI = 3.1415927;
static const uint ATLAS_CORRECTIVE = 0u;
static const uint ATLAS_IRRADIANCE = 1u;
static const uint ATLAS_MOMENTS = 2u;
static const uint ATLAS_SCALE = 3u;
static const float ROUGH_MAP_FROM = 0.5;
static const float ROUGH_MAP_TO = 0.75;
static const float FACE_MARGIN = 0.125;
static const uint RELAXED = 255u;
static const uint FALLBACK = 255u;
static const uint BLEND = 255u;
static const uint RELAX = 255u;
static const uint ROUGHNESS_CORRECTION = 255u;

Texture2D<float4> probe_radiance : register(t0);
Texture2D<float4> probe_inv_distance : register(t1);
Texture2D<float4> corrective_atlas : register(t2);
Texture2D<float4> irradiance_atlas : register(t3);
Texture2D<float4> moments_atlas : register(t4);
Texture2D<float4> scale_atlas : register(t5);
Texture2D<float4> roughness_lut : register(t6);
cbuffer params : register(b7) { Params params; }
ByteAddressBuffer cells : register(t8);
Texture2DArray<float4> surface_radiance : register(t0, space2);
cbuffer surface_params : register(b1, space2) { SurfaceParams surface_params; }
Texture2D<float4> surface_inv_distance : register(t2, space2);
ByteAddressBuffer queries : register(t0, space1);
RWByteAddressBuffer results : register(u1, space1);
cbuffer camera : register(b0, space3) { CameraParams camera; }

struct VertexOutput_surface_vertex {
    float3 world : LOC0;
    nointerpolation float3 normal_1 : LOC1;
    nointerpolation float3 albedo : LOC2;
    nointerpolation float flags : LOC3;
    nointerpolation float4 sphere : LOC4;
    float4 clip_ : SV_Position;
};

struct FragmentInput_surface_fragment {
    float3 world_1 : LOC0;
    nointerpolation float3 normal_2 : LOC1;
    nointerpolation float3 albedo_1 : LOC2;
    nointerpolation float flags_1 : LOC3;
    nointerpolation float4 sphere_1 : LOC4;
    float4 clip_1 : SV_Position;
};

uint fallback_method()
{
    if (true) {
        uint _e8 = params.probe_info.z;
        return _e8;
    }
    return FALLBACK;
}

uint blend_mode()
{
    if (true) {
        uint _e8 = params.grid_counts.w;
        return _e8;
    }
    return BLEND;
}

bool relaxation_on()
{
    if (true) {
        float _e8 = params.warp.x;
        return (_e8 > 0.0);
    }
    return false;
}

bool roughness_corrected()
{
    if (true) {
        uint _e8 = params.probe_info.w;
        return (_e8 != 0u);
    }
    return false;
}

bool finite(float x)
{
    return ((asuint(x) & 2139095040u) != 2139095040u);
}

bool finite3_(float3 v_4)
{
    bool local_1 = (bool)0;
    bool local_2 = (bool)0;

    const bool _e2 = finite(v_4.x);
    if (_e2) {
        const bool _e6 = finite(v_4.y);
        local_1 = _e6;
    } else {
        local_1 = false;
    }
    bool _e8 = local_1;
    if (_e8) {
        const bool _e12 = finite(v_4.z);
        local_2 = _e12;
    } else {
        local_2 = false;
    }
    bool _e14 = local_2;
    return _e14;
}

float sign_not_zero(float x_1)
{
    return ((x_1 >= 0.0) ? 1.0 : -1.0);
}

float4 unit_direction(float3 v_5)
{
    bool local_3 = (bool)0;
    bool local_4 = (bool)0;
    bool local_5 = (bool)0;
    bool local_6 = (bool)0;

    float l2_ = dot(v_5, v_5);
    const bool _e2 = finite(l2_);
    if (_e2) {
        local_3 = (abs((l2_ - 1.0)) <= 4.7683716e-7);
    } else {
        local_3 = false;
    }
    bool _e11 = local_3;
    if (_e11) {
        return float4(v_5, 1.0);
    }
    float m_1 = max(abs(v_5.x), max(abs(v_5.y), abs(v_5.z)));
    if ((m_1 > 0.0)) {
        const bool _e26 = finite(m_1);
        local_4 = _e26;
    } else {
        local_4 = false;
    }
    bool _e28 = local_4;
    if (_e28) {
        const bool _e31 = finite3_(v_5);
        local_5 = _e31;
    } else {
        local_5 = false;
    }
    bool _e33 = local_5;
    if (!(_e33)) {
        return float4(0.0, 0.0, 1.0, 0.0);
    }
    float3 s_2 = (v_5 / (m_1).xxx);
    float l_3 = length(s_2);
    if ((l_3 > 0.0)) {
        const bool _e47 = finite(l_3);
        local_6 = _e47;
    } else {
        local_6 = false;
    }
    bool _e49 = local_6;
    if (!(_e49)) {
        return float4(0.0, 0.0, 1.0, 0.0);
    }
    return float4((s_2 / (l_3).xxx), 1.0);
}

float3 fetch_vector(float3 from, float3 to, float3 fallback)
{
    bool local_7 = (bool)0;

    float3 v_10 = (to - from);
    float l2_1 = dot(v_10, v_10);
    if ((l2_1 > 0.0)) {
        const bool _e9 = finite(l2_1);
        local_7 = _e9;
    } else {
        local_7 = false;
    }
    bool _e11 = local_7;
    if (_e11) {
        return v_10;
    }
    return fallback;
}

float2 oct_encode(float3 d)
{
    bool local_8 = (bool)0;
    float2 p_1 = (float2)0;

    float l1_ = ((abs(d.x) + abs(d.y)) + abs(d.z));
    if ((l1_ >= F32_MIN_POSITIVE)) {
        const bool _e13 = finite(l1_);
        local_8 = _e13;
    } else {
        local_8 = false;
    }
    bool _e15 = local_8;
    if (!(_e15)) {
        return float2(0.5, 0.5);
    }
    float inv_l1_ = (1.0 / l1_);
    p_1 = float2((d.x * inv_l1_), (d.y * inv_l1_));
    if ((d.z < 0.0)) {
        float _e32 = p_1.y;
        float _e37 = p_1.x;
        const float _e38 = sign_not_zero(_e37);
        float _e41 = p_1.x;
        float _e46 = p_1.y;
        const float _e47 = sign_not_zero(_e46);
        p_1 = float2(((1.0 - abs(_e32)) * _e38), ((1.0 - abs(_e41)) * _e47));
    }
    float2 _e50 = p_1;
    return clamp(((_e50 * 0.5) + (0.5).xx), (0.0).xx, (1.0).xx);
}

int naga_neg(int val) {
    return asint(-asuint(val));
}

int2 wrap_texel(int n_1, int2 t_1)
{
    int i = (int)0;
    int j = (int)0;

    i = t_1.x;
    j = t_1.y;
    int _e6 = i;
    if ((_e6 < int(0))) {
        int _e9 = i;
        i = asint(asuint(naga_neg(_e9)) - asuint(int(1)));
        int _e15 = j;
        j = asint(asuint(asint(asuint(n_1) - asuint(int(1)))) - asuint(_e15));
    } else {
        int _e17 = i;
        if ((_e17 >= n_1)) {
            int _e23 = i;
            i = asint(asuint(asint(asuint(asint(asuint(int(2)) * asuint(n_1))) - asuint(int(1)))) - asuint(_e23));
            int _e27 = j;
            j = asint(asuint(asint(asuint(n_1) - asuint(int(1)))) - asuint(_e27));
        }
    }
    int _e29 = j;
    if ((_e29 < int(0))) {
        int _e34 = i;
        i = asint(asuint(asint(asuint(n_1) - asuint(int(1)))) - asuint(_e34));
        int _e36 = j;
        j = asint(asuint(naga_neg(_e36)) - asuint(int(1)));
    } else {
        int _e40 = j;
        if ((_e40 >= n_1)) {
            int _e44 = i;
            i = asint(asuint(asint(asuint(n_1) - asuint(int(1)))) - asuint(_e44));
            int _e50 = j;
            j = asint(asuint(asint(asuint(asint(asuint(int(2)) * asuint(n_1))) - asuint(int(1)))) - asuint(_e50));
        }
    }
    int _e52 = i;
    int _e53 = j;
    return clamp(int2(_e52, _e53), (int(0)).xx, (asint(asuint(n_1) - asuint(int(1)))).xx);
}

Footprint ConstructFootprint(int2 arg0, float2 arg1) {
    Footprint ret = (Footprint)0;
    ret.corner = arg0;
    ret.f = arg1;
    return ret;
}

int2 naga_f2i32(float2 value) {
    return int2(clamp(value, -2147483600.0, 2147483500.0));
}

Footprint footprint(uint n_2, float2 uv)
{
    float2 x_5 = ((clamp(uv, (0.0).xx, (1.0).xx) * float(n_2)) - (0.5).xx);
    float2 x0_ = floor(x_5);
    const Footprint footprint_1 = ConstructFootprint(naga_f2i32(x0_), (x_5 - x0_));
    return footprint_1;
}

float4 blend4_(float4 q00_, float4 q10_, float4 q01_, float4 q11_, float2 f)
{
    return ((((q00_ * (1.0 - f.x)) + (q10_ * f.x)) * (1.0 - f.y)) + (((q01_ * (1.0 - f.x)) + (q11_ * f.x)) * f.y));
}

float4 probe_texel(uint which, int2 t_2, int level)
{
    if ((which == 0u)) {
        float4 _e6 = probe_radiance.Load(int3(t_2, level));
        return _e6;
    }
    float4 _e8 = probe_inv_distance.Load(int3(t_2, level));
    return _e8;
}

uint naga_f2u32(float value) {
    return uint(clamp(value, 0.0, 4294967000.0));
}

float4 probe_bilinear(uint which_1, float2 uv_1, uint level_1, uint p_2)
{
    float _e7 = params.warp.z;
    float _e11 = params.warp.y;
    float res0_ = ((which_1 == 0u) ? _e11 : _e7);
    uint n_11 = max((naga_f2u32(res0_) >> level_1), 1u);
    const Footprint _e19 = footprint(n_11, uv_1);
    int2 c_10 = _e19.corner;
    int l_4 = int(level_1);
    int ni = int(n_11);
    int2 at_3 = int2(asint(asuint(int(p_2)) * asuint(ni)), int(0));
    const int2 _e27 = wrap_texel(ni, c_10);
    const float4 _e29 = probe_texel(which_1, asint(asuint(at_3) + asuint(_e27)), l_4);
    const int2 _e34 = wrap_texel(ni, asint(asuint(c_10) + asuint(int2(int(1), int(0)))));
    const float4 _e36 = probe_texel(which_1, asint(asuint(at_3) + asuint(_e34)), l_4);
    const int2 _e41 = wrap_texel(ni, asint(asuint(c_10) + asuint(int2(int(0), int(1)))));
    const float4 _e43 = probe_texel(which_1, asint(asuint(at_3) + asuint(_e41)), l_4);
    const int2 _e48 = wrap_texel(ni, asint(asuint(c_10) + asuint(int2(int(1), int(1)))));
    const float4 _e50 = probe_texel(which_1, asint(asuint(at_3) + asuint(_e48)), l_4);
    const float4 _e52 = blend4_(_e29, _e36, _e43, _e50, _e19.f);
    return _e52;
}

float4 probe_sample_lod(uint which_2, float2 uv_2, float lod_in, uint levels, uint p_3)
{
    float lod = 0.0;
    bool local_9 = (bool)0;

    float top = float((max(levels, 1u) - 1u));
    const bool _e12 = finite(lod_in);
    if (_e12) {
        lod = min(max(lod_in, 0.0), top);
    }
    float _e16 = lod;
    uint l0_ = naga_f2u32(_e16);
    float _e18 = lod;
    float f_3 = (_e18 - float(l0_));
    const float4 _e21 = probe_bilinear(which_2, uv_2, l0_, p_3);
    if (!((f_3 == 0.0))) {
        local_9 = ((l0_ + 1u) >= levels);
    } else {
        local_9 = true;
    }
    bool _e31 = local_9;
    if (_e31) {
        return _e21;
    }
    const float4 _e34 = probe_bilinear(which_2, uv_2, (l0_ + 1u), p_3);
    return ((_e21 * (1.0 - f_3)) + (_e34 * f_3));
}

float3 radiance_lod(float2 uv_3, float lod_1, uint p_4)
{
    uint _e7 = params.probe_info.x;
    const float4 _e8 = probe_sample_lod(0u, uv_3, lod_1, _e7, p_4);
    return _e8.xyz;
}

float inv_dist(float3 v_6)
{
    bool local_10 = (bool)0;

    const float2 _e2 = oct_encode(v_6);
    float _e6 = params.probe.w;
    uint _e10 = params.probe_info.y;
    const float4 _e12 = probe_sample_lod(1u, _e2, _e6, _e10, 0u);
    float w_6 = _e12.x;
    if ((w_6 > 0.0)) {
        const bool _e18 = finite(w_6);
        local_10 = _e18;
    } else {
        local_10 = false;
    }
    bool _e20 = local_10;
    if (_e20) {
        return w_6;
    }
    return 0.0;
}

float4 atlas_texel(uint which_3, int2 t_3)
{
    switch(which_3) {
        case 0u: {
            float4 _e4 = corrective_atlas.Load(int3(t_3, int(0)));
            return _e4;
        }
        case 1u: {
            float4 _e7 = irradiance_atlas.Load(int3(t_3, int(0)));
            return _e7;
        }
        case 2u: {
            float4 _e10 = moments_atlas.Load(int3(t_3, int(0)));
            return _e10;
        }
        default: {
            float4 _e13 = scale_atlas.Load(int3(t_3, int(0)));
            return _e13;
        }
    }
}

uint naga_mod(uint lhs, uint rhs) {
    return lhs % (rhs == 0u ? 1u : rhs);
}

uint naga_div(uint lhs, uint rhs) {
    return lhs / (rhs == 0u ? 1u : rhs);
}

float4 atlas_bilinear(uint which_4, int tile, uint n_3, uint columns, float2 uv_4)
{
    uint s_3 = uint(tile);
    int2 origin = int2((uint2(naga_mod(s_3, columns), naga_div(s_3, columns)) * (n_3 + 2u)));
    const Footprint _e13 = footprint(n_3, uv_4);
    int2 c_11 = asint(asuint(asint(asuint(origin) + asuint(_e13.corner))) + asuint(int2(int(1), int(1))));
    const float4 _e20 = atlas_texel(which_4, c_11);
    const float4 _e25 = atlas_texel(which_4, asint(asuint(c_11) + asuint(int2(int(1), int(0)))));
    const float4 _e30 = atlas_texel(which_4, asint(asuint(c_11) + asuint(int2(int(0), int(1)))));
    const float4 _e35 = atlas_texel(which_4, asint(asuint(c_11) + asuint(int2(int(1), int(1)))));
    const float4 _e37 = blend4_(_e20, _e25, _e30, _e35, _e13.f);
    return _e37;
}

float3 cell_size()
{
    float4 _e2 = params.grid_max;
    float4 _e6 = params.grid_min;
    uint4 _e11 = params.grid_counts;
    return ((_e2.xyz - _e6.xyz) / float3(_e11.xyz));
}

uint cell_index(uint3 c_2)
{
    uint4 n_12 = params.grid_counts;
    return (c_2.x + (n_12.x * (c_2.y + (n_12.y * c_2.z))));
}

uint3 naga_f2u32(float3 value) {
    return uint3(clamp(value, 0.0, 4294967000.0));
}

uint3 cell_of(float3 p_5, float3 size)
{
    float4 _e4 = params.grid_min;
    float3 f_4 = floor(((p_5 - _e4.xyz) / size));
    uint4 _e11 = params.grid_counts;
    float3 hi = float3((_e11.xyz - (1u).xxx));
    const bool _e17 = finite3_(f_4);
    if (!(_e17)) {
        return (0u).xxx;
    }
    return naga_f2u32(clamp(f_4, (0.0).xxx, hi));
}

float3 cell_centre(uint3 c_3, float3 size_1)
{
    float4 _e4 = params.grid_min;
    return (_e4.xyz + ((float3(c_3) + (0.5).xxx) * size_1));
}

Lattice ConstructLattice(uint3 arg0, float3 arg1) {
    Lattice ret = (Lattice)0;
    ret.base = arg0;
    ret.frac_ = arg1;
    return ret;
}

Lattice lattice(float3 p_6, float3 size_2)
{
    float3 f_1 = (float3)0;

    float4 _e4 = params.grid_min;
    f_1 = (((p_6 - _e4.xyz) / size_2) - (0.5).xxx);
    uint4 _e14 = params.grid_counts;
    float3 hi_1 = float3((_e14.xyz - (1u).xxx));
    float3 _e20 = f_1;
    const bool _e21 = finite3_(_e20);
    if (_e21) {
        float3 _e22 = f_1;
        f_1 = clamp(_e22, (0.0).xxx, hi_1);
    } else {
        f_1 = (0.0).xxx;
    }
    float3 _e28 = f_1;
    float3 base_1 = floor(_e28);
    float3 _e31 = f_1;
    const Lattice lattice_1 = ConstructLattice(naga_f2u32(base_1), (_e31 - base_1));
    return lattice_1;
}

float corner_weight(Lattice l, uint corner)
{
    uint3 o = uint3((corner & 1u), ((corner >> 1u) & 1u), ((corner >> 2u) & 1u));
    float wx = ((o.x == 1u) ? l.frac_.x : (1.0 - l.frac_.x));
    float wy = ((o.y == 1u) ? l.frac_.y : (1.0 - l.frac_.y));
    float wz = ((o.z == 1u) ? l.frac_.z : (1.0 - l.frac_.z));
    return ((wx * wy) * wz);
}

uint3 corner_cell(Lattice l_1, uint corner_1)
{
    uint3 o_1 = uint3((corner_1 & 1u), ((corner_1 >> 1u) & 1u), ((corner_1 >> 2u) & 1u));
    uint4 _e17 = params.grid_counts;
    return min((l_1.base + o_1), (_e17.xyz - (1u).xxx));
}

float2 warp1_exit(float3 b_2, float3 dir_1)
{
    bool local_11 = (bool)0;

    float4 _e4 = params.probe;
    float3 a_1 = _e4.xyz;
    const float _e6 = inv_dist(dir_1);
    if ((_e6 == 0.0)) {
        return float2(1e30, 1.0);
    }
    float3 ab = (a_1 - b_2);
    float dir_ab = dot(dir_1, ab);
    float3 v_11 = ((dir_1 * max(((dir_ab * _e6) + 1.0), 0.0)) - (ab * _e6));
    const float _e23 = inv_dist(v_11);
    float lambda = (length(v_11) * _e23);
    if (!((lambda > 0.0))) {
        return float2(1e30, 1.0);
    }
    float t_10 = (max(((dir_ab * lambda) + dot(dir_1, v_11)), 0.0) / lambda);
    const bool _e37 = finite(t_10);
    if (_e37) {
        local_11 = (t_10 < HUGE);
    } else {
        local_11 = false;
    }
    bool _e43 = local_11;
    if (!(_e43)) {
        return float2(1e30, 1.0);
    }
    return float2(t_10, 1.0);
}

float3 warp1_(float3 b_3, float3 dir_2)
{
    float4 _e4 = params.probe;
    float3 a_2 = _e4.xyz;
    const float _e6 = inv_dist(dir_2);
    if ((_e6 == 0.0)) {
        return dir_2;
    }
    float3 ab_1 = (a_2 - b_3);
    float dir_ab_1 = dot(dir_2, ab_1);
    float3 v_12 = ((dir_2 * max(((dir_ab_1 * _e6) + 1.0), 0.0)) - (ab_1 * _e6));
    const float _e20 = inv_dist(v_12);
    float lambda_1 = (length(v_12) * _e20);
    float t_11 = max(((dir_ab_1 * lambda_1) + dot(dir_2, v_12)), 0.0);
    float3 f_5 = ((dir_2 * t_11) - (ab_1 * lambda_1));
    if ((lambda_1 > 0.0)) {
        const float3 _e34 = fetch_vector((0.0).xxx, f_5, dir_2);
        return _e34;
    }
    return dir_2;
}

float2 box_exit(float3 b_4, float3 dir_3)
{
    float t_4 = HUGE;
    int k = int(0);

    float4 _e4 = params.box_x;
    float4 _e8 = params.box_y;
    float4 _e12 = params.box_z;
    float3x3 m_2 = float3x3(_e4.xyz, _e8.xyz, _e12.xyz);
    float4 _e17 = params.box_half;
    float3 h = _e17.xyz;
    float4 _e21 = params.box_centre;
    float3 o_2 = mul((b_4 - _e21.xyz), m_2);
    if (any((abs(o_2) > h))) {
        return float2(0.0, 0.0);
    }
    float3 d_2 = mul(dir_3, m_2);
    uint2 loop_bound = uint2(4294967295u, 4294967295u);
    bool loop_init = true;
    while(true) {
        if (all(loop_bound == uint2(0u, 0u))) { break; }
        loop_bound -= uint2(loop_bound.y == 0u, 1u);
        if (!loop_init) {
            int _e62 = k;
            k = asint(asuint(_e62) + asuint(int(1)));
        }
        loop_init = false;
        int _e36 = k;
        if ((_e36 < int(3))) {
        } else {
            break;
        }
        {
            int _e39 = k;
            if ((d_2[min(uint(_e39), 2u)] != 0.0)) {
                int _e43 = k;
                int _e46 = k;
                int _e48 = k;
                float face = ((d_2[min(uint(_e48), 2u)] > 0.0) ? h[min(uint(_e46), 2u)] : -(h[min(uint(_e43), 2u)]));
                float _e53 = t_4;
                int _e54 = k;
                int _e57 = k;
                t_4 = min(_e53, ((face - o_2[min(uint(_e54), 2u)]) / d_2[min(uint(_e57), 2u)]));
            }
        }
    }
    float _e64 = t_4;
    if (!((_e64 < HUGE))) {
        return float2(0.0, 0.0);
    }
    float _e71 = t_4;
    return float2(max(_e71, 0.0), 1.0);
}

float2 kdop_exit(float3 b_5, float3 dir_4)
{
    float t_5 = HUGE;
    uint k_1 = 0u;

    uint2 loop_bound_1 = uint2(4294967295u, 4294967295u);
    bool loop_init_1 = true;
    while(true) {
        if (all(loop_bound_1 == uint2(0u, 0u))) { break; }
        loop_bound_1 -= uint2(loop_bound_1.y == 0u, 1u);
        if (!loop_init_1) {
            uint _e44 = k_1;
            k_1 = (_e44 + 1u);
        }
        loop_init_1 = false;
        uint _e6 = k_1;
        if ((_e6 < 18u)) {
        } else {
            break;
        }
        {
            uint _e12 = params.kdop_open.x;
            uint _e14 = k_1;
            if (((_e12 & (1u << _e14)) != 0u)) {
                continue;
            }
            uint _e21 = k_1;
            float4 _e23 = params.kdop[_e21];
            float3 n_13 = _e23.xyz;
            uint _e27 = k_1;
            float h_1 = params.kdop[_e27].w;
            float nb = dot(n_13, b_5);
            if ((nb > h_1)) {
                return float2(0.0, 0.0);
            }
            float nd = dot(n_13, dir_4);
            if ((nd > 0.0)) {
                float _e39 = t_5;
                t_5 = min(_e39, ((h_1 - nb) / nd));
            }
        }
    }
    float _e46 = t_5;
    return float2(_e46, 1.0);
}

float2 proxy_exit(float3 b_6, float3 dir_5)
{
    const uint _e2 = fallback_method();
    switch(_e2) {
        case 0u: {
            const float2 _e3 = warp1_exit(b_6, dir_5);
            return _e3;
        }
        case 2u: {
            const float2 _e4 = kdop_exit(b_6, dir_5);
            return _e4;
        }
        default: {
            const float2 _e5 = box_exit(b_6, dir_5);
            return _e5;
        }
    }
}

float3 proxy_fetch(float2 exit, float3 b_7, float3 dir_6)
{
    bool local_12 = (bool)0;

    if (!((exit.y == 0.0))) {
        local_12 = !((exit.x < HUGE));
    } else {
        local_12 = true;
    }
    bool _e14 = local_12;
    if (_e14) {
        return dir_6;
    }
    float4 _e17 = params.probe;
    const float3 _e22 = fetch_vector(_e17.xyz, (b_7 + (dir_6 * exit.x)), dir_6);
    return _e22;
}

float3 box_fetch(float3 b_8, float3 dir_7)
{
    const float2 _e2 = box_exit(b_8, dir_7);
    const float3 _e3 = proxy_fetch(_e2, b_8, dir_7);
    return _e3;
}

Basis ConstructBasis(float3 arg0, float3 arg1) {
    Basis ret = (Basis)0;
    ret.t = arg0;
    ret.b = arg1;
    return ret;
}

Basis orthonormal_basis(float3 n_4)
{
    float s_4 = ((n_4.z >= 0.0) ? 1.0 : -1.0);
    float a_3 = (-1.0 / (s_4 + n_4.z));
    float b_24 = ((n_4.x * n_4.y) * a_3);
    const Basis basis = ConstructBasis(float3((1.0 + (((s_4 * n_4.x) * n_4.x) * a_3)), (s_4 * b_24), (-(s_4) * n_4.x)), float3(b_24, (s_4 + ((n_4.y * n_4.y) * a_3)), -(n_4.y)));
    return basis;
}

float3 normalize_or(float3 v_7, float3 fallback_1)
{
    bool local_13 = (bool)0;

    float l_5 = length(v_7);
    if ((l_5 > 0.0)) {
        const bool _e7 = finite(l_5);
        local_13 = _e7;
    } else {
        local_13 = false;
    }
    bool _e9 = local_13;
    if (_e9) {
        return (v_7 / (l_5).xxx);
    }
    return fallback_1;
}

float3 fallback_fetch(float3 b_9, float3 dir_8)
{
    float3 plain = (float3)0;
    float3 sum = (0.0).xxx;
    uint s = 0u;
    float3 d_1 = (float3)0;

    float4 _e4 = params.probe;
    if (all((b_9 == _e4.xyz))) {
        return dir_8;
    }
    float relax = params.warp.x;
    const bool _e12 = relaxation_on();
    float _e18 = params.warp.y;
    float angle = ((relax * 3.5449078) / _e18);
    const Basis _e20 = orthonormal_basis(dir_8);
    float3 t_12 = (_e20.t * angle);
    float3 bt = (_e20.b * angle);
    plain = dir_8;
    uint2 loop_bound_2 = uint2(4294967295u, 4294967295u);
    bool loop_init_2 = true;
    while(true) {
        if (all(loop_bound_2 == uint2(0u, 0u))) { break; }
        loop_bound_2 -= uint2(loop_bound_2.y == 0u, 1u);
        if (!loop_init_2) {
            uint _e57 = s;
            s = (_e57 + 1u);
        }
        loop_init_2 = false;
        uint _e31 = s;
        if ((_e31 < (_e12 ? 5u : 1u))) {
        } else {
            break;
        }
        {
            d_1 = dir_8;
            uint _e37 = s;
            bool should_continue = false;
            switch(_e37) {
                case 1u: {
                    d_1 = normalize((dir_8 + t_12));
                    break;
                }
                case 2u: {
                    d_1 = normalize((dir_8 - t_12));
                    break;
                }
                case 3u: {
                    d_1 = normalize((dir_8 + bt));
                    break;
                }
                case 4u: {
                    d_1 = normalize((dir_8 - bt));
                    break;
                }
                default: {
                    break;
                }
            }
            float3 _e46 = d_1;
            const float2 _e47 = proxy_exit(b_9, _e46);
            float3 _e48 = d_1;
            const float3 _e49 = proxy_fetch(_e47, b_9, _e48);
            uint _e50 = s;
            if ((_e50 == 0u)) {
                plain = _e49;
            }
            float3 _e53 = sum;
            const float3 _e54 = normalize_or(_e49, dir_8);
            sum = (_e53 + _e54);
        }
    }
    if (!(_e12)) {
        float3 _e60 = plain;
        return _e60;
    }
    float3 _e61 = sum;
    const float3 _e62 = normalize_or(_e61, dir_8);
    return _e62;
}

Aim ConstructAim(float3 arg0, float arg1, uint arg2) {
    Aim ret = (Aim)0;
    ret.v = arg0;
    ret.k = arg1;
    ret.p = arg2;
    return ret;
}

Aim shifted_aim(float2 exit_1, float delta, float3 b_10, float3 dir_9, uint p_7)
{
    bool local_14 = (bool)0;
    float s_1 = (float)0;
    bool local_15 = (bool)0;
    float k_2 = (float)0;
    bool local_16 = (bool)0;

    if (!((exit_1.y == 0.0))) {
        local_14 = !((exit_1.x < HUGE));
    } else {
        local_14 = true;
    }
    bool _e16 = local_14;
    if (_e16) {
        const Aim aim_2 = ConstructAim(dir_9, 1.0, p_7);
        return aim_2;
    }
    s_1 = (exit_1.x + delta);
    float _e22 = s_1;
    if (!((_e22 > 1e-30))) {
        s_1 = 1e-30;
    }
    float _e27 = s_1;
    float4 _e33 = params.probes[p_7];
    float3 v_13 = ((b_10 + (dir_9 * _e27)) - _e33.xyz);
    const bool _e36 = finite3_(v_13);
    if (_e36) {
        local_15 = any((v_13 != (0.0).xxx));
    } else {
        local_15 = false;
    }
    bool _e44 = local_15;
    if (_e44) {
        float _e46 = s_1;
        k_2 = (length(v_13) / _e46);
        float _e49 = k_2;
        const bool _e50 = finite(_e49);
        if (_e50) {
            float _e53 = k_2;
            local_16 = (_e53 > 0.0);
        } else {
            local_16 = false;
        }
        bool _e57 = local_16;
        if (!(_e57)) {
            k_2 = 1.0;
        }
        float _e60 = k_2;
        const Aim aim_3 = ConstructAim(v_13, _e60, p_7);
        return aim_3;
    }
    const Aim aim_4 = ConstructAim(dir_9, 1.0, p_7);
    return aim_4;
}

uint probe_of(int tile_1, uint unmapped, float2 uv_5)
{
    uint best = 0u;
    uint k_3 = 1u;

    if ((tile_1 < int(0))) {
        uint _e8 = params.probe_maps.x;
        return min(unmapped, (max(_e8, 1u) - 1u));
    }
    uint _e17 = params.probe_maps.y;
    if ((_e17 == 0u)) {
        return 0u;
    }
    uint n_14 = params.atlas_a.x;
    uint columns_1 = params.atlas_a.y;
    uint _e33 = params.probe_maps.y;
    uint s_5 = (uint(tile_1) + _e33);
    int2 origin_1 = int2((uint2(naga_mod(s_5, columns_1), naga_div(s_5, columns_1)) * (n_14 + 2u)));
    const Footprint _e42 = footprint(n_14, uv_5);
    float2 f_6 = _e42.f;
    float4 w_7 = float4(((1.0 - f_6.x) * (1.0 - f_6.y)), (f_6.x * (1.0 - f_6.y)), ((1.0 - f_6.x) * f_6.y), (f_6.x * f_6.y));
    uint2 loop_bound_3 = uint2(4294967295u, 4294967295u);
    bool loop_init_3 = true;
    while(true) {
        if (all(loop_bound_3 == uint2(0u, 0u))) { break; }
        loop_bound_3 -= uint2(loop_bound_3.y == 0u, 1u);
        if (!loop_init_3) {
            uint _e79 = k_3;
            k_3 = (_e79 + 1u);
        }
        loop_init_3 = false;
        uint _e69 = k_3;
        if ((_e69 < 4u)) {
        } else {
            break;
        }
        {
            uint _e72 = k_3;
            uint _e74 = best;
            if ((w_7[min(uint(_e72), 3u)] > w_7[min(uint(_e74), 3u)])) {
                uint _e77 = k_3;
                best = _e77;
            }
        }
    }
    uint _e87 = best;
    uint _e91 = best;
    int2 t_13 = asint(asuint(asint(asuint(asint(asuint(origin_1) + asuint(_e42.corner))) + asuint(int2(int(1), int(1))))) + asuint(int2(int((_e87 & 1u)), int((_e91 >> 1u)))));
    const float4 _e98 = atlas_texel(ATLAS_CORRECTIVE, t_13);
    uint p_11 = naga_f2u32(_e98.x);
    uint _e104 = params.probe_maps.x;
    return min(p_11, (max(_e104, 1u) - 1u));
}

float map_delta(int tile_2, float2 uv_6)
{
    uint _e6 = params.atlas_a.x;
    uint _e10 = params.atlas_a.y;
    const float4 _e11 = atlas_bilinear(ATLAS_CORRECTIVE, tile_2, _e6, _e10, uv_6);
    return _e11.x;
}

float cell_delta(int4 tiles, float2 uv_7, float r_1)
{
    float w = (float)0;

    if ((tiles.w < int(0))) {
        const float _e7 = map_delta(tiles.x, uv_7);
        return _e7;
    }
    w = ((r_1 - ROUGH_MAP_FROM) / 0.25);
    float _e13 = w;
    if (!((_e13 > 0.0))) {
        const float _e18 = map_delta(tiles.x, uv_7);
        return _e18;
    }
    float _e19 = w;
    if ((_e19 >= 1.0)) {
        const float _e23 = map_delta(tiles.w, uv_7);
        return _e23;
    }
    const float _e25 = map_delta(tiles.x, uv_7);
    const float _e27 = map_delta(tiles.w, uv_7);
    float _e29 = w;
    return (_e25 + ((_e27 - _e25) * _e29));
}

typedef float4 ret_Constructarray9_float4_[9];
ret_Constructarray9_float4_ Constructarray9_float4_(float4 arg0, float4 arg1, float4 arg2, float4 arg3, float4 arg4, float4 arg5, float4 arg6, float4 arg7, float4 arg8) {
    float4 ret[9] = { arg0, arg1, arg2, arg3, arg4, arg5, arg6, arg7, arg8 };
    return ret;
}

Cell ConstructCell(int4 arg0, float4 arg1, float4 arg2[9], uint4 arg3) {
    Cell ret = (Cell)0;
    ret.tiles = arg0;
    ret.offset = arg1;
    ret.sh = arg2;
    ret.links = arg3;
    return ret;
}

Aim fetch(float3 b_11, float3 dir_10, float r_2)
{
    float delta_1 = 0.0;
    bool mapped = false;
    uint corner_2 = 0u;
    bool local_17 = (bool)0;
    bool local_18 = (bool)0;

    const float2 _e3 = oct_encode(dir_10);
    const float3 _e4 = cell_size();
    const uint3 _e6 = cell_of(b_11, _e4);
    const uint _e7 = cell_index(_e6);
    Cell home_cell = ConstructCell(asint(cells.Load4(_e7*192+0)), asfloat(cells.Load4(_e7*192+16)), Constructarray9_float4_(asfloat(cells.Load4(_e7*192+32+0)), asfloat(cells.Load4(_e7*192+32+16)), asfloat(cells.Load4(_e7*192+32+32)), asfloat(cells.Load4(_e7*192+32+48)), asfloat(cells.Load4(_e7*192+32+64)), asfloat(cells.Load4(_e7*192+32+80)), asfloat(cells.Load4(_e7*192+32+96)), asfloat(cells.Load4(_e7*192+32+112)), asfloat(cells.Load4(_e7*192+32+128))), asuint(cells.Load4(_e7*192+176)));
    int4 tiles_1 = home_cell.tiles;
    const uint _e14 = probe_of(tiles_1.x, home_cell.links.y, _e3);
    float4 _e18 = params.probes[_e14];
    if (all((b_11 == _e18.xyz))) {
        const Aim aim_5 = ConstructAim(dir_10, 1.0, _e14);
        return aim_5;
    }
    const uint _e28 = blend_mode();
    if ((_e28 != 1u)) {
        if ((tiles_1.x >= int(0))) {
            const float _e34 = cell_delta(tiles_1, _e3, r_2);
            delta_1 = _e34;
            mapped = true;
        }
    } else {
        const Lattice _e36 = lattice(b_11, _e4);
        uint2 loop_bound_4 = uint2(4294967295u, 4294967295u);
        bool loop_init_4 = true;
        while(true) {
            if (all(loop_bound_4 == uint2(0u, 0u))) { break; }
            loop_bound_4 -= uint2(loop_bound_4.y == 0u, 1u);
            if (!loop_init_4) {
                uint _e60 = corner_2;
                corner_2 = (_e60 + 1u);
            }
            loop_init_4 = false;
            uint _e39 = corner_2;
            if ((_e39 < 8u)) {
            } else {
                break;
            }
            {
                uint _e43 = corner_2;
                const uint3 _e44 = corner_cell(_e36, _e43);
                const uint _e45 = cell_index(_e44);
                int4 tiles_2 = asint(cells.Load4(0+_e45*192));
                if ((tiles_2.x >= int(0))) {
                    float _e52 = delta_1;
                    uint _e53 = corner_2;
                    const float _e54 = corner_weight(_e36, _e53);
                    const float _e55 = cell_delta(tiles_2, _e3, r_2);
                    delta_1 = (_e52 + (_e54 * _e55));
                    mapped = true;
                }
            }
        }
    }
    bool _e62 = mapped;
    if (!(_e62)) {
        const bool _e66 = relaxation_on();
        local_17 = _e66;
    } else {
        local_17 = false;
    }
    bool _e68 = local_17;
    if (_e68) {
        local_18 = (_e14 == 0u);
    } else {
        local_18 = false;
    }
    bool _e74 = local_18;
    if (_e74) {
        const float3 _e75 = fallback_fetch(b_11, dir_10);
        const Aim aim_6 = ConstructAim(_e75, -1.0, 0u);
        return aim_6;
    }
    const float2 _e79 = proxy_exit(b_11, dir_10);
    float _e80 = delta_1;
    const Aim _e81 = shifted_aim(_e79, _e80, b_11, dir_10, _e14);
    const Aim aim_7 = _e81;
    return aim_7;
}

float face_ramp(float x_2)
{
    return clamp(((x_2 - 0.375) / 0.25), 0.0, 1.0);
}

Lattice face_lattice(float3 b_12)
{
    const float3 _e1 = cell_size();
    const Lattice _e2 = lattice(b_12, _e1);
    const float _e6 = face_ramp(_e2.frac_.x);
    const float _e9 = face_ramp(_e2.frac_.y);
    const float _e12 = face_ramp(_e2.frac_.z);
    const Lattice lattice_2 = ConstructLattice(_e2.base, float3(_e6, _e9, _e12));
    return lattice_2;
}

int3 naga_abs(int3 val) {
    return val >= 0 ? val : asint(-asuint(val));
}

float linked_weight(Lattice l_2, uint corner_3, uint3 home_at, uint links)
{
    const float _e4 = corner_weight(l_2, corner_3);
    if (!((_e4 > 0.0))) {
        return 0.0;
    }
    const uint3 _e9 = corner_cell(l_2, corner_3);
    if (all((_e9 == home_at))) {
        return _e4;
    }
    int3 o_3 = asint(asuint(int3(_e9)) - asuint(int3(home_at)));
    if (any((naga_abs(o_3) > (int(1)).xxx))) {
        return 0.0;
    }
    uint bit = uint(asint(asuint(asint(asuint(asint(asuint(o_3.x) + asuint(int(1)))) + asuint(asint(asuint(int(3)) * asuint(asint(asuint(o_3.y) + asuint(int(1)))))))) + asuint(asint(asuint(int(9)) * asuint(asint(asuint(o_3.z) + asuint(int(1))))))));
    return ((((links >> bit) & 1u) != 0u) ? _e4 : 0.0);
}

float near_weight(Near near, uint corner_4)
{
    const float _e5 = linked_weight(near.l, corner_4, near.home_at, near.links);
    return (_e5 / near.sum);
}

float mip_roughness(uint m)
{
    float _e9 = params.mip_roughness[naga_div(m, 4u)][naga_mod(m, 4u)];
    return _e9;
}

float lod_of_roughness(float r_3)
{
    bool local_19 = (bool)0;
    uint below = 0u;
    uint t_6 = 0u;
    float f_2 = 0.0;

    uint n_15 = params.probe_info.x;
    if (!((n_15 < 2u))) {
        const float _e11 = mip_roughness(0u);
        local_19 = !((r_3 > _e11));
    } else {
        local_19 = true;
    }
    bool _e15 = local_19;
    if (_e15) {
        return 0.0;
    }
    uint last = (n_15 - 1u);
    const float _e19 = mip_roughness(last);
    if ((r_3 >= _e19)) {
        return float(last);
    }
    uint2 loop_bound_5 = uint2(4294967295u, 4294967295u);
    bool loop_init_5 = true;
    while(true) {
        if (all(loop_bound_5 == uint2(0u, 0u))) { break; }
        loop_bound_5 -= uint2(loop_bound_5.y == 0u, 1u);
        if (!loop_init_5) {
            uint _e37 = t_6;
            t_6 = (_e37 + 1u);
        }
        loop_init_5 = false;
        uint _e26 = t_6;
        if ((_e26 < n_15)) {
        } else {
            break;
        }
        {
            uint _e28 = below;
            uint _e31 = t_6;
            const float _e32 = mip_roughness(_e31);
            below = (_e28 + ((_e32 <= r_3) ? 1u : 0u));
        }
    }
    uint _e39 = below;
    uint i_6 = (clamp(_e39, 1u, last) - 1u);
    const float _e46 = mip_roughness((i_6 + 1u));
    const float _e47 = mip_roughness(i_6);
    float span = (_e46 - _e47);
    if ((span > 0.0)) {
        const float _e53 = mip_roughness(i_6);
        f_2 = ((r_3 - _e53) / span);
    }
    float _e57 = f_2;
    return (float(i_6) + clamp(_e57, 0.0, 1.0));
}

float distance_ratio(float3 b_13, float3 v_8, float2 uv_8, uint p_8)
{
    bool local_20 = (bool)0;
    bool local_21 = (bool)0;
    bool local_22 = (bool)0;
    bool local_23 = (bool)0;

    float l_6 = length(v_8);
    float _e9 = params.probe.w;
    uint _e13 = params.probe_info.y;
    const float4 _e14 = probe_sample_lod(1u, uv_8, _e9, _e13, p_8);
    float w_8 = _e14.x;
    if ((l_6 > 0.0)) {
        const bool _e20 = finite(l_6);
        local_20 = _e20;
    } else {
        local_20 = false;
    }
    bool _e22 = local_20;
    if (_e22) {
        local_21 = (w_8 > 0.0);
    } else {
        local_21 = false;
    }
    bool _e28 = local_21;
    if (_e28) {
        const bool _e31 = finite(w_8);
        local_22 = _e31;
    } else {
        local_22 = false;
    }
    bool _e33 = local_22;
    if (!(_e33)) {
        return 1.0;
    }
    float d_probe = (1.0 / w_8);
    float4 _e41 = params.probes[p_8];
    float d_surface = length(((_e41.xyz + (v_8 * (d_probe / l_6))) - b_13));
    float k_13 = (d_probe / d_surface);
    const bool _e49 = finite(k_13);
    if (_e49) {
        local_23 = (k_13 > 0.0);
    } else {
        local_23 = false;
    }
    bool _e55 = local_23;
    if (_e55) {
        return k_13;
    }
    return 1.0;
}

float pseudo_log2_(float k_4)
{
    uint bits_1 = asuint(k_4);
    int e_2 = asint(asuint(int(((bits_1 >> 23u) & 255u))) - asuint(int(127)));
    float m_3 = asfloat(((bits_1 & 8388607u) | 1065353216u));
    return (float(e_2) + (m_3 - 1.0));
}

float corrected_roughness(float r_4, float k_in)
{
    float fr = 0.0;
    float k_5 = 1.0;
    bool local_24 = (bool)0;

    uint n_16 = params.lut_info.x;
    float last_1 = float((n_16 - 1u));
    const bool _e11 = finite(r_4);
    if (_e11) {
        fr = clamp((r_4 * last_1), 0.0, last_1);
    }
    const bool _e17 = finite(k_in);
    if (_e17) {
        local_24 = (k_in > 0.0);
    } else {
        local_24 = false;
    }
    bool _e23 = local_24;
    if (_e23) {
        k_5 = k_in;
    }
    float _e24 = k_5;
    float _e28 = params.lut.z;
    float _e32 = params.lut.w;
    k_5 = clamp(_e24, _e28, _e32);
    float _e34 = k_5;
    const float _e35 = pseudo_log2_(_e34);
    float _e39 = params.lut.x;
    float _e44 = params.lut.y;
    float fx = clamp(((_e35 - _e39) * _e44), 0.0, last_1);
    float _e48 = fr;
    uint i_7 = min(naga_f2u32(_e48), (n_16 - 2u));
    uint j_5 = min(naga_f2u32(fx), (n_16 - 2u));
    float _e57 = fr;
    float a_4 = (_e57 - float(i_7));
    float b_25 = (fx - float(j_5));
    float4 _e67 = roughness_lut.Load(int3(int2(int(j_5), int(i_7)), int(0)));
    float v00_ = _e67.x;
    float4 _e76 = roughness_lut.Load(int3(int2(int((j_5 + 1u)), int(i_7)), int(0)));
    float v01_ = _e76.x;
    float4 _e85 = roughness_lut.Load(int3(int2(int(j_5), int((i_7 + 1u))), int(0)));
    float v10_ = _e85.x;
    float4 _e96 = roughness_lut.Load(int3(int2(int((j_5 + 1u)), int((i_7 + 1u))), int(0)));
    float v11_ = _e96.x;
    return ((((v00_ * (1.0 - b_25)) + (v01_ * b_25)) * (1.0 - a_4)) + (((v10_ * (1.0 - b_25)) + (v11_ * b_25)) * a_4));
}

float3 shade(float3 b_14, Aim aim, float r_5)
{
    float k_6 = (float)0;

    const float2 _e4 = oct_encode(aim.v);
    if ((r_5 == 0.0)) {
        const float3 _e9 = radiance_lod(_e4, 0.0, aim.p);
        return _e9;
    }
    const bool _e10 = roughness_corrected();
    if (!(_e10)) {
        const float _e12 = lod_of_roughness(r_5);
        const float3 _e14 = radiance_lod(_e4, _e12, aim.p);
        return _e14;
    }
    k_6 = aim.k;
    float _e17 = k_6;
    if ((_e17 < 0.0)) {
        const float _e22 = distance_ratio(b_14, aim.v, _e4, aim.p);
        k_6 = _e22;
    }
    float _e23 = k_6;
    const float _e24 = corrected_roughness(r_5, _e23);
    const float _e25 = lod_of_roughness(_e24);
    const float3 _e27 = radiance_lod(_e4, _e25, aim.p);
    return _e27;
}

typedef uint ret_Constructarray8_uint_[8];
ret_Constructarray8_uint_ Constructarray8_uint_(uint arg0, uint arg1, uint arg2, uint arg3, uint arg4, uint arg5, uint arg6, uint arg7) {
    uint ret[8] = { arg0, arg1, arg2, arg3, arg4, arg5, arg6, arg7 };
    return ret;
}

typedef float ret_Constructarray8_float_[8];
ret_Constructarray8_float_ Constructarray8_float_(float arg0, float arg1, float arg2, float arg3, float arg4, float arg5, float arg6, float arg7) {
    float ret[8] = { arg0, arg1, arg2, arg3, arg4, arg5, arg6, arg7 };
    return ret;
}

float3 faces_radiance(Near near_1, float3 b_15, float3 dir_11, float r_6)
{
    uint keys[8] = Constructarray8_uint_(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
    float ws[8] = Constructarray8_float_(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    float ds[8] = Constructarray8_float_(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    uint n_5 = 0u;
    uint corner_5 = 0u;
    uint key = (uint)0;
    float delta_2 = (float)0;
    bool local_25 = (bool)0;
    uint at = (uint)0;
    uint g = (uint)0;
    bool local_26 = (bool)0;
    float3 c_4 = (0.0).xxx;
    uint g_1 = 0u;
    Aim aim_1 = (Aim)0;

    const float2 _e4 = oct_encode(dir_11);
    const bool _e5 = relaxation_on();
    uint2 loop_bound_6 = uint2(4294967295u, 4294967295u);
    bool loop_init_6 = true;
    while(true) {
        if (all(loop_bound_6 == uint2(0u, 0u))) { break; }
        loop_bound_6 -= uint2(loop_bound_6.y == 0u, 1u);
        if (!loop_init_6) {
            uint _e120 = corner_5;
            corner_5 = (_e120 + 1u);
        }
        loop_init_6 = false;
        uint _e40 = corner_5;
        if ((_e40 < 8u)) {
        } else {
            break;
        }
        {
            uint _e43 = corner_5;
            const float _e44 = near_weight(near_1, _e43);
            if (!((_e44 > 0.0))) {
                continue;
            }
            uint _e50 = corner_5;
            const uint3 _e51 = corner_cell(near_1.l, _e50);
            const uint _e52 = cell_index(_e51);
            Cell cell_1 = ConstructCell(asint(cells.Load4(_e52*192+0)), asfloat(cells.Load4(_e52*192+16)), Constructarray9_float4_(asfloat(cells.Load4(_e52*192+32+0)), asfloat(cells.Load4(_e52*192+32+16)), asfloat(cells.Load4(_e52*192+32+32)), asfloat(cells.Load4(_e52*192+32+48)), asfloat(cells.Load4(_e52*192+32+64)), asfloat(cells.Load4(_e52*192+32+80)), asfloat(cells.Load4(_e52*192+32+96)), asfloat(cells.Load4(_e52*192+32+112)), asfloat(cells.Load4(_e52*192+32+128))), asuint(cells.Load4(_e52*192+176)));
            int4 tiles_3 = cell_1.tiles;
            const uint _e59 = probe_of(tiles_3.x, cell_1.links.y, _e4);
            key = _e59;
            delta_2 = 0.0;
            if ((tiles_3.x >= int(0))) {
                const float _e66 = cell_delta(tiles_3, _e4, r_6);
                delta_2 = _e66;
            } else {
                if (_e5) {
                    uint _e69 = key;
                    local_25 = (_e69 == 0u);
                } else {
                    local_25 = false;
                }
                bool _e73 = local_25;
                if (_e73) {
                    key = RELAXED;
                }
            }
            uint _e75 = n_5;
            at = _e75;
            g = 0u;
            uint2 loop_bound_7 = uint2(4294967295u, 4294967295u);
            bool loop_init_7 = true;
            while(true) {
                if (all(loop_bound_7 == uint2(0u, 0u))) { break; }
                loop_bound_7 -= uint2(loop_bound_7.y == 0u, 1u);
                if (!loop_init_7) {
                    uint _e98 = g;
                    g = (_e98 + 1u);
                }
                loop_init_7 = false;
                uint _e79 = g;
                uint _e80 = n_5;
                if ((_e79 < _e80)) {
                } else {
                    break;
                }
                {
                    uint _e82 = g;
                    uint _e84 = keys[min(uint(_e82), 7u)];
                    uint _e85 = key;
                    if ((_e84 == _e85)) {
                        uint _e89 = g;
                        float _e91 = ds[min(uint(_e89), 7u)];
                        float _e92 = delta_2;
                        local_26 = (_e91 == _e92);
                    } else {
                        local_26 = false;
                    }
                    bool _e95 = local_26;
                    if (_e95) {
                        uint _e96 = g;
                        at = _e96;
                        break;
                    }
                }
            }
            uint _e100 = at;
            uint _e101 = n_5;
            if ((_e100 == _e101)) {
                uint _e103 = n_5;
                uint _e105 = key;
                keys[min(uint(_e103), 7u)] = _e105;
                uint _e106 = n_5;
                ws[min(uint(_e106), 7u)] = 0.0;
                uint _e109 = n_5;
                float _e111 = delta_2;
                ds[min(uint(_e109), 7u)] = _e111;
                uint _e113 = n_5;
                n_5 = (_e113 + 1u);
            }
            uint _e115 = at;
            float _e117 = ws[min(uint(_e115), 7u)];
            ws[min(uint(_e115), 7u)] = (_e117 + _e44);
        }
    }
    const float2 _e122 = proxy_exit(b_15, dir_11);
    uint2 loop_bound_8 = uint2(4294967295u, 4294967295u);
    bool loop_init_8 = true;
    while(true) {
        if (all(loop_bound_8 == uint2(0u, 0u))) { break; }
        loop_bound_8 -= uint2(loop_bound_8.y == 0u, 1u);
        if (!loop_init_8) {
            uint _e172 = g_1;
            g_1 = (_e172 + 1u);
        }
        loop_init_8 = false;
        uint _e128 = g_1;
        uint _e129 = n_5;
        if ((_e128 < _e129)) {
        } else {
            break;
        }
        {
            uint _e131 = g_1;
            uint _e133 = keys[min(uint(_e131), 7u)];
            aim_1 = ConstructAim(dir_11, 1.0, _e133);
            uint _e137 = g_1;
            uint _e139 = keys[min(uint(_e137), 7u)];
            if ((_e139 == RELAXED)) {
                const float3 _e142 = fallback_fetch(b_15, dir_11);
                aim_1 = ConstructAim(_e142, -1.0, 0u);
            } else {
                uint _e148 = g_1;
                uint _e150 = keys[min(uint(_e148), 7u)];
                float4 _e152 = params.probes[_e150];
                if (any((b_15 != _e152.xyz))) {
                    uint _e156 = g_1;
                    float _e158 = ds[min(uint(_e156), 7u)];
                    uint _e159 = g_1;
                    uint _e161 = keys[min(uint(_e159), 7u)];
                    const Aim _e162 = shifted_aim(_e122, _e158, b_15, dir_11, _e161);
                    aim_1 = _e162;
                }
            }
            float3 _e163 = c_4;
            uint _e164 = g_1;
            float _e166 = ws[min(uint(_e164), 7u)];
            Aim _e167 = aim_1;
            const float3 _e168 = shade(b_15, _e167, r_6);
            c_4 = (_e163 + (_e166 * _e168));
        }
    }
    float3 _e174 = c_4;
    return _e174;
}

Near ConstructNear(Lattice arg0, uint3 arg1, uint arg2, uint arg3, float arg4) {
    Near ret = (Near)0;
    ret.l = arg0;
    ret.home_at = arg1;
    ret.links = arg2;
    ret.count = arg3;
    ret.sum = arg4;
    return ret;
}

Near near_cells(float3 b_16)
{
    uint count = 0u;
    float sum_1 = 0.0;
    uint corner_6 = 0u;

    const Lattice _e1 = face_lattice(b_16);
    const float3 _e2 = cell_size();
    const uint3 _e3 = cell_of(b_16, _e2);
    const uint _e5 = cell_index(_e3);
    uint links_1 = asuint(cells.Load(0+176+_e5*192));
    uint2 loop_bound_9 = uint2(4294967295u, 4294967295u);
    bool loop_init_9 = true;
    while(true) {
        if (all(loop_bound_9 == uint2(0u, 0u))) { break; }
        loop_bound_9 -= uint2(loop_bound_9.y == 0u, 1u);
        if (!loop_init_9) {
            uint _e29 = corner_6;
            corner_6 = (_e29 + 1u);
        }
        loop_init_9 = false;
        uint _e16 = corner_6;
        if ((_e16 < 8u)) {
        } else {
            break;
        }
        {
            uint _e19 = corner_6;
            const float _e20 = linked_weight(_e1, _e19, _e3, links_1);
            if ((_e20 > 0.0)) {
                uint _e24 = count;
                count = (_e24 + 1u);
                float _e26 = sum_1;
                sum_1 = (_e26 + _e20);
            }
        }
    }
    uint _e31 = count;
    float _e32 = sum_1;
    const Near near_3 = ConstructNear(_e1, _e3, links_1, _e31, _e32);
    return near_3;
}

float3 sh_eval(float3 c_5[9], float3 n_6)
{
    float x_6 = n_6.x;
    float y = n_6.y;
    float z = n_6.z;
    float3 t0_ = (c_5[0] * 0.2820948);
    float3 t1_ = (c_5[1] * (0.4886025 * y));
    float3 t2_ = (c_5[2] * (0.4886025 * z));
    float3 t3_ = (c_5[3] * (0.4886025 * x_6));
    float3 t4_ = (c_5[4] * (1.0925484 * (x_6 * y)));
    float3 t5_ = (c_5[5] * (1.0925484 * (y * z)));
    float3 t6_ = (c_5[6] * (0.31539157 * ((3.0 * (z * z)) - 1.0)));
    float3 t7_ = (c_5[7] * (1.0925484 * (x_6 * z)));
    float3 t8_ = (c_5[8] * (0.5462742 * ((x_6 * x_6) - (y * y))));
    float3 e_3 = ((((t0_ + t1_) + (t2_ + t3_)) + ((t4_ + t5_) + (t6_ + t7_))) + t8_);
    return max(e_3, (0.0).xxx);
}

typedef float3 ret_Constructarray9_float3_[9];
ret_Constructarray9_float3_ Constructarray9_float3_(float3 arg0, float3 arg1, float3 arg2, float3 arg3, float3 arg4, float3 arg5, float3 arg6, float3 arg7, float3 arg8) {
    float3 ret[9] = { arg0, arg1, arg2, arg3, arg4, arg5, arg6, arg7, arg8 };
    return ret;
}

float3 cell_sh_irradiance(uint cell, float3 n_7)
{
    float4 _e6 = asfloat(cells.Load4(0+32+cell*192));
    float4 _e12 = asfloat(cells.Load4(16+32+cell*192));
    float4 _e18 = asfloat(cells.Load4(32+32+cell*192));
    float4 _e24 = asfloat(cells.Load4(48+32+cell*192));
    float4 _e30 = asfloat(cells.Load4(64+32+cell*192));
    float4 _e36 = asfloat(cells.Load4(80+32+cell*192));
    float4 _e42 = asfloat(cells.Load4(96+32+cell*192));
    float4 _e48 = asfloat(cells.Load4(112+32+cell*192));
    float4 _e54 = asfloat(cells.Load4(128+32+cell*192));
    float3 c_12[9] = Constructarray9_float3_(_e6.xyz, _e12.xyz, _e18.xyz, _e24.xyz, _e30.xyz, _e36.xyz, _e42.xyz, _e48.xyz, _e54.xyz);
    const float3 _e57 = sh_eval(c_12, n_7);
    return _e57;
}

float3 sh_blend4_(uint4 at_1, float4 w_1, uint i_1)
{
    float4 _e8 = asfloat(cells.Load4(i_1*16+32+at_1.x*192));
    float4 _e17 = asfloat(cells.Load4(i_1*16+32+at_1.y*192));
    float4 _e27 = asfloat(cells.Load4(i_1*16+32+at_1.z*192));
    float4 _e36 = asfloat(cells.Load4(i_1*16+32+at_1.w*192));
    return (((_e8.xyz * w_1.x) + (_e17.xyz * w_1.y)) + ((_e27.xyz * w_1.z) + (_e36.xyz * w_1.w)));
}

uint NagaBufferLength(ByteAddressBuffer buffer)
{
    uint ret;
    buffer.GetDimensions(ret);
    return ret;
}

float3 sh_read(uint3 home_at_1, float3 b_17, float3 n_8)
{
    uint3 base = (uint3)0;
    float3 frac_ = (float3)0;
    uint a = 0u;
    uint bx = 1u;
    uint c_6 = 2u;
    uint3 top_v = (uint3)0;
    uint3 home_v = (uint3)0;
    uint bit0_ = 0u;
    uint x_3 = 0u;
    uint rel = (uint)0;
    uint4 corner_cell_1 = (uint4)0;
    uint4 bits = (uint4)0;
    uint k_7 = 1u;
    uint cs = (uint)0;
    uint bs = (uint)0;
    float4 w_2 = (float4)0;
    uint4 at_2 = (uint4)0;
    uint k_8 = 0u;
    bool kept = (bool)0;
    bool local_27 = (bool)0;
    bool local_28 = (bool)0;

    const float3 _e3 = cell_size();
    uint4 _e6 = params.grid_counts;
    uint3 counts = _e6.xyz;
    uint3 top_1 = (counts - (1u).xxx);
    float4 _e13 = params.grid_min;
    float3 units = ((b_17 - _e13.xyz) / _e3);
    const uint _e17 = cell_index(home_at_1);
    float3 f0_ = (units - (0.5).xxx);
    const bool _e21 = finite3_(f0_);
    if (!(_e21)) {
        const float3 _e23 = cell_sh_irradiance(_e17, n_8);
        return _e23;
    }
    float3 f_7 = clamp(f0_, (0.0).xxx, float3(top_1));
    float3 fl = floor(f_7);
    base = naga_f2u32(fl);
    frac_ = (f_7 - fl);
    uint _e39 = bx;
    float _e41 = frac_[min(uint(_e39), 2u)];
    uint _e42 = a;
    float _e44 = frac_[min(uint(_e42), 2u)];
    if ((_e41 > _e44)) {
        uint t_14 = a;
        uint _e47 = bx;
        a = _e47;
        bx = t_14;
    }
    uint _e48 = c_6;
    float _e50 = frac_[min(uint(_e48), 2u)];
    uint _e51 = bx;
    float _e53 = frac_[min(uint(_e51), 2u)];
    if ((_e50 > _e53)) {
        uint t_15 = bx;
        uint _e56 = c_6;
        bx = _e56;
        c_6 = t_15;
        uint _e57 = bx;
        float _e59 = frac_[min(uint(_e57), 2u)];
        uint _e60 = a;
        float _e62 = frac_[min(uint(_e60), 2u)];
        if ((_e59 > _e62)) {
            uint u = a;
            uint _e65 = bx;
            a = _e65;
            bx = u;
        }
    }
    uint _e66 = a;
    float _e68 = frac_[min(uint(_e66), 2u)];
    uint _e71 = a;
    float _e73 = frac_[min(uint(_e71), 2u)];
    uint _e74 = bx;
    float _e76 = frac_[min(uint(_e74), 2u)];
    uint _e78 = bx;
    float _e80 = frac_[min(uint(_e78), 2u)];
    uint _e81 = c_6;
    float _e83 = frac_[min(uint(_e81), 2u)];
    uint _e85 = c_6;
    float _e87 = frac_[min(uint(_e85), 2u)];
    float4 weights = float4((1.0 - _e68), (_e73 - _e76), (_e80 - _e83), _e87);
    top_v = top_1;
    home_v = home_at_1;
    uint3 cell_stride = uint3(1u, counts.x, (counts.x * counts.y));
    uint3 bit_stride = uint3(1u, 3u, 9u);
    uint _e102 = base.x;
    uint _e105 = base.y;
    uint _e108 = base.z;
    uint cell0_ = (_e102 + (counts.x * (_e105 + (counts.y * _e108))));
    uint2 loop_bound_10 = uint2(4294967295u, 4294967295u);
    bool loop_init_10 = true;
    while(true) {
        if (all(loop_bound_10 == uint2(0u, 0u))) { break; }
        loop_bound_10 -= uint2(loop_bound_10.y == 0u, 1u);
        if (!loop_init_10) {
            uint _e144 = x_3;
            x_3 = (_e144 + 1u);
        }
        loop_init_10 = false;
        uint _e117 = x_3;
        if ((_e117 < 3u)) {
        } else {
            break;
        }
        {
            uint _e120 = x_3;
            uint _e122 = base[min(uint(_e120), 2u)];
            uint up = (_e122 + 1u);
            rel = 0u;
            uint _e127 = x_3;
            uint _e129 = home_v[min(uint(_e127), 2u)];
            if ((up > _e129)) {
                uint _e131 = x_3;
                uint _e133 = home_v[min(uint(_e131), 2u)];
                rel = min((up - _e133), 2u);
            }
            uint _e137 = bit0_;
            uint _e138 = rel;
            uint _e139 = x_3;
            bit0_ = (_e137 + (_e138 * bit_stride[min(uint(_e139), 2u)]));
        }
    }
    corner_cell_1 = (cell0_).xxxx;
    uint _e148 = bit0_;
    bits = (_e148).xxxx;
    uint _e151 = a;
    uint _e152 = bx;
    uint _e153 = c_6;
    uint3 axes = uint3(_e151, _e152, _e153);
    uint2 loop_bound_11 = uint2(4294967295u, 4294967295u);
    bool loop_init_11 = true;
    while(true) {
        if (all(loop_bound_11 == uint2(0u, 0u))) { break; }
        loop_bound_11 -= uint2(loop_bound_11.y == 0u, 1u);
        if (!loop_init_11) {
            uint _e194 = k_7;
            k_7 = (_e194 + 1u);
        }
        loop_init_11 = false;
        uint _e157 = k_7;
        if ((_e157 < 4u)) {
        } else {
            break;
        }
        {
            uint _e160 = k_7;
            uint x_7 = axes[min(uint((_e160 - 1u)), 2u)];
            cs = 0u;
            bs = 0u;
            uint _e169 = base[min(uint(x_7), 2u)];
            uint _e171 = top_v[min(uint(x_7), 2u)];
            if ((_e169 < _e171)) {
                cs = cell_stride[min(uint(x_7), 2u)];
                bs = bit_stride[min(uint(x_7), 2u)];
            }
            uint _e175 = k_7;
            uint _e177 = k_7;
            uint _e181 = corner_cell_1[min(uint((_e177 - 1u)), 3u)];
            uint _e182 = cs;
            corner_cell_1[min(uint(_e175), 3u)] = (_e181 + _e182);
            uint _e184 = k_7;
            uint _e186 = k_7;
            uint _e190 = bits[min(uint((_e186 - 1u)), 3u)];
            uint _e191 = bs;
            bits[min(uint(_e184), 3u)] = (_e190 + _e191);
        }
    }
    uint links_2 = asuint(cells.Load(0+176+_e17*192));
    w_2 = weights;
    at_2 = (_e17).xxxx;
    uint count_1 = ((NagaBufferLength(cells) - 0) / 192);
    uint2 loop_bound_12 = uint2(4294967295u, 4294967295u);
    bool loop_init_12 = true;
    while(true) {
        if (all(loop_bound_12 == uint2(0u, 0u))) { break; }
        loop_bound_12 -= uint2(loop_bound_12.y == 0u, 1u);
        if (!loop_init_12) {
            uint _e252 = k_8;
            k_8 = (_e252 + 1u);
        }
        loop_init_12 = false;
        uint _e208 = k_8;
        if ((_e208 < 4u)) {
        } else {
            break;
        }
        {
            uint _e211 = k_8;
            uint ck = corner_cell_1[min(uint(_e211), 3u)];
            kept = false;
            uint _e216 = k_8;
            uint _e218 = bits[min(uint(_e216), 3u)];
            if ((_e218 < 27u)) {
                uint _e223 = k_8;
                uint _e225 = bits[min(uint(_e223), 3u)];
                local_27 = (((links_2 >> _e225) & 1u) != 0u);
            } else {
                local_27 = false;
            }
            bool _e232 = local_27;
            if (_e232) {
                local_28 = (ck < count_1);
            } else {
                local_28 = false;
            }
            bool _e237 = local_28;
            if (_e237) {
                int _e242 = asint(cells.Load(4+0+ck*192));
                kept = (_e242 >= int(0));
            }
            bool _e245 = kept;
            if (_e245) {
                uint _e246 = k_8;
                at_2[min(uint(_e246), 3u)] = ck;
            } else {
                uint _e248 = k_8;
                w_2[min(uint(_e248), 3u)] = 0.0;
            }
        }
    }
    float _e255 = w_2.x;
    float _e257 = w_2.y;
    float _e260 = w_2.z;
    float _e262 = w_2.w;
    float wsum_1 = ((_e255 + _e257) + (_e260 + _e262));
    if (!((wsum_1 > 0.0))) {
        const float3 _e268 = cell_sh_irradiance(_e17, n_8);
        return _e268;
    }
    uint4 _e269 = at_2;
    float4 _e270 = w_2;
    const float3 _e272 = sh_blend4_(_e269, _e270, 0u);
    uint4 _e273 = at_2;
    float4 _e274 = w_2;
    const float3 _e276 = sh_blend4_(_e273, _e274, 1u);
    uint4 _e277 = at_2;
    float4 _e278 = w_2;
    const float3 _e280 = sh_blend4_(_e277, _e278, 2u);
    uint4 _e281 = at_2;
    float4 _e282 = w_2;
    const float3 _e284 = sh_blend4_(_e281, _e282, 3u);
    uint4 _e285 = at_2;
    float4 _e286 = w_2;
    const float3 _e288 = sh_blend4_(_e285, _e286, 4u);
    uint4 _e289 = at_2;
    float4 _e290 = w_2;
    const float3 _e292 = sh_blend4_(_e289, _e290, 5u);
    uint4 _e293 = at_2;
    float4 _e294 = w_2;
    const float3 _e296 = sh_blend4_(_e293, _e294, 6u);
    uint4 _e297 = at_2;
    float4 _e298 = w_2;
    const float3 _e300 = sh_blend4_(_e297, _e298, 7u);
    uint4 _e301 = at_2;
    float4 _e302 = w_2;
    const float3 _e304 = sh_blend4_(_e301, _e302, 8u);
    float3 acc[9] = Constructarray9_float3_(_e272, _e276, _e280, _e284, _e288, _e292, _e296, _e300, _e304);
    const float3 _e306 = sh_eval(acc, n_8);
    return (_e306 / (wsum_1).xxx);
}

float3 faces_specular(Near near_2, float3 b_18, float3 dir_12, float r_7, float w_3)
{
    float3 c_7 = (float3)0;
    float3 e = (0.0).xxx;
    float share = 0.0;
    uint corner_7 = 0u;
    bool local_29 = (bool)0;

    const float3 _e5 = faces_radiance(near_2, b_18, dir_12, r_7);
    c_7 = _e5;
    if ((w_3 > 0.0)) {
        uint2 loop_bound_13 = uint2(4294967295u, 4294967295u);
        bool loop_init_13 = true;
        while(true) {
            if (all(loop_bound_13 == uint2(0u, 0u))) { break; }
            loop_bound_13 -= uint2(loop_bound_13.y == 0u, 1u);
            if (!loop_init_13) {
                uint _e45 = corner_7;
                corner_7 = (_e45 + 1u);
            }
            loop_init_13 = false;
            uint _e16 = corner_7;
            if ((_e16 < 8u)) {
            } else {
                break;
            }
            {
                uint _e19 = corner_7;
                const float _e20 = near_weight(near_2, _e19);
                uint _e22 = corner_7;
                const uint3 _e23 = corner_cell(near_2.l, _e22);
                if ((_e20 > 0.0)) {
                    const uint _e29 = cell_index(_e23);
                    int _e33 = asint(cells.Load(4+0+_e29*192));
                    local_29 = (_e33 >= int(0));
                } else {
                    local_29 = false;
                }
                bool _e37 = local_29;
                if (_e37) {
                    float3 _e38 = e;
                    const float3 _e39 = sh_read(_e23, b_18, dir_12);
                    e = (_e38 + (_e20 * _e39));
                    float _e42 = share;
                    share = (_e42 + _e20);
                }
            }
        }
        float _e47 = share;
        if ((_e47 > 0.0)) {
            float3 _e50 = c_7;
            float _e51 = share;
            float3 _e56 = e;
            float _e57 = share;
            float _e60 = share;
            c_7 = ((_e50 * (1.0 - (w_3 * _e51))) + ((_e56 / (_e57).xxx) * ((w_3 * _e60) * 0.31830987)));
        }
    }
    float3 _e66 = c_7;
    return _e66;
}

float blend_node_r(uint k_9)
{
    float _e9 = params.blend_r[naga_div(k_9, 4u)][naga_mod(k_9, 4u)];
    return _e9;
}

float blend_node_w(uint k_10)
{
    float _e9 = params.blend_w[naga_div(k_10, 4u)][naga_mod(k_10, 4u)];
    return _e9;
}

float irradiance_weight(float r_8)
{
    bool local_30 = (bool)0;
    float w_4 = (float)0;
    uint k_11 = 1u;

    uint n_17 = params.lut_info.y;
    if (!((n_17 == 0u))) {
        local_30 = !((r_8 > 0.0));
    } else {
        local_30 = true;
    }
    bool _e14 = local_30;
    if (_e14) {
        return 0.0;
    }
    const float _e17 = blend_node_w(0u);
    w_4 = _e17;
    uint2 loop_bound_14 = uint2(4294967295u, 4294967295u);
    bool loop_init_14 = true;
    while(true) {
        if (all(loop_bound_14 == uint2(0u, 0u))) { break; }
        loop_bound_14 -= uint2(loop_bound_14.y == 0u, 1u);
        if (!loop_init_14) {
            uint _e49 = k_11;
            k_11 = (_e49 + 1u);
        }
        loop_init_14 = false;
        uint _e21 = k_11;
        if ((_e21 < n_17)) {
        } else {
            break;
        }
        {
            uint _e23 = k_11;
            const float _e26 = blend_node_r((_e23 - 1u));
            if ((r_8 > _e26)) {
                uint _e29 = k_11;
                const float _e30 = blend_node_r(_e29);
                float t_16 = min(max(((r_8 - _e26) / (_e30 - _e26)), 0.0), 1.0);
                uint _e37 = k_11;
                const float _e40 = blend_node_w((_e37 - 1u));
                uint _e44 = k_11;
                const float _e45 = blend_node_w(_e44);
                w_4 = ((_e40 * (1.0 - t_16)) + (_e45 * t_16));
            }
        }
    }
    float _e51 = w_4;
    return min(max(_e51, 0.0), 1.0);
}

float3 clean(float3 c_8)
{
    const bool _e1 = finite3_(c_8);
    if (_e1) {
        return max(c_8, (0.0).xxx);
    }
    return (0.0).xxx;
}

float3 specular(float3 position, float3 direction, float roughness)
{
    float3 b_19 = (float3)0;
    float r_9 = 0.0;
    uint3 home_at_2 = (0u).xxx;
    bool stored = false;
    bool local_31 = (bool)0;
    float3 c_9 = (float3)0;

    const float4 _e3 = unit_direction(direction);
    if ((_e3.w == 0.0)) {
        return (0.0).xxx;
    }
    float4 _e11 = params.probe;
    b_19 = _e11.xyz;
    const bool _e14 = finite3_(position);
    if (_e14) {
        b_19 = position;
    }
    const bool _e17 = finite(roughness);
    if (_e17) {
        r_9 = clamp(roughness, 0.0, 1.0);
    }
    float _e21 = r_9;
    const float _e22 = irradiance_weight(_e21);
    const uint _e23 = blend_mode();
    if ((_e23 == 2u)) {
        float3 _e26 = b_19;
        const Near _e27 = near_cells(_e26);
        if ((_e27.count > 1u)) {
            float3 _e31 = b_19;
            float _e33 = r_9;
            const float3 _e34 = faces_specular(_e27, _e31, _e3.xyz, _e33, _e22);
            const float3 _e35 = clean(_e34);
            return _e35;
        }
    }
    if ((_e22 > 0.0)) {
        float3 _e43 = b_19;
        const float3 _e44 = cell_size();
        const uint3 _e45 = cell_of(_e43, _e44);
        home_at_2 = _e45;
        uint3 _e47 = home_at_2;
        const uint _e48 = cell_index(_e47);
        int _e52 = asint(cells.Load(4+0+_e48*192));
        stored = (_e52 >= int(0));
    }
    bool _e55 = stored;
    if (_e55) {
        local_31 = (_e22 >= 1.0);
    } else {
        local_31 = false;
    }
    bool _e61 = local_31;
    if (_e61) {
        uint3 _e62 = home_at_2;
        float3 _e63 = b_19;
        const float3 _e65 = sh_read(_e62, _e63, _e3.xyz);
        const float3 _e69 = clean((_e65 * (_e22 * 0.31830987)));
        return _e69;
    }
    float3 _e70 = b_19;
    float3 _e71 = b_19;
    float _e73 = r_9;
    const Aim _e74 = fetch(_e71, _e3.xyz, _e73);
    float _e75 = r_9;
    const float3 _e76 = shade(_e70, _e74, _e75);
    c_9 = _e76;
    bool _e78 = stored;
    if (_e78) {
        float3 _e79 = c_9;
        uint3 _e83 = home_at_2;
        float3 _e84 = b_19;
        const float3 _e86 = sh_read(_e83, _e84, _e3.xyz);
        c_9 = ((_e79 * (1.0 - _e22)) + (_e86 * (_e22 * 0.31830987)));
    }
    float3 _e91 = c_9;
    const float3 _e92 = clean(_e91);
    return _e92;
}

float3 cell_irradiance(int tile_3, float3 n_9)
{
    uint _e6 = params.atlas_a.z;
    uint _e10 = params.atlas_a.w;
    const float2 _e11 = oct_encode(n_9);
    const float4 _e12 = atlas_bilinear(ATLAS_IRRADIANCE, tile_3, _e6, _e10, _e11);
    return _e12.xyz;
}

float3 irradiance(float3 position_1, float3 normal)
{
    float3 p_9 = (float3)0;
    float3 e_1 = (0.0).xxx;
    float wsum = 0.0;
    uint corner_8 = 0u;
    float w_5 = (float)0;
    bool local_32 = (bool)0;
    float k_12 = (float)0;

    const float4 _e2 = unit_direction(normal);
    if ((_e2.w == 0.0)) {
        return (0.0).xxx;
    }
    float3 n_18 = _e2.xyz;
    const float3 _e9 = cell_size();
    float4 _e12 = params.grid_min;
    float4 _e16 = params.grid_max;
    float4 _e20 = params.grid_min;
    p_9 = (_e12.xyz + ((_e16.xyz - _e20.xyz) * 0.5));
    float _e30 = params.grid_min.w;
    float3 biased = (position_1 + (n_18 * _e30));
    const bool _e33 = finite3_(biased);
    if (_e33) {
        p_9 = biased;
    }
    float3 _e34 = p_9;
    const Lattice _e35 = lattice(_e34, _e9);
    const float2 _e36 = oct_encode(n_18);
    uint2 loop_bound_15 = uint2(4294967295u, 4294967295u);
    bool loop_init_15 = true;
    while(true) {
        if (all(loop_bound_15 == uint2(0u, 0u))) { break; }
        loop_bound_15 -= uint2(loop_bound_15.y == 0u, 1u);
        if (!loop_init_15) {
            uint _e157 = corner_8;
            corner_8 = (_e157 + 1u);
        }
        loop_init_15 = false;
        uint _e44 = corner_8;
        if ((_e44 < 8u)) {
        } else {
            break;
        }
        {
            uint _e47 = corner_8;
            const float _e48 = corner_weight(_e35, _e47);
            if ((_e48 <= 0.0)) {
                continue;
            }
            uint _e51 = corner_8;
            const uint3 _e52 = corner_cell(_e35, _e51);
            const uint _e53 = cell_index(_e52);
            int4 tiles_4 = asint(cells.Load4(0+_e53*192));
            if ((tiles_4.y < int(0))) {
                continue;
            }
            float3 _e61 = p_9;
            const float3 _e62 = cell_centre(_e52, _e9);
            float4 _e66 = asfloat(cells.Load4(16+_e53*192));
            float3 to_point = (_e61 - (_e62 + _e66.xyz));
            float dist = length(to_point);
            w_5 = _e48;
            if ((dist > 0.0)) {
                const bool _e76 = finite(dist);
                local_32 = _e76;
            } else {
                local_32 = false;
            }
            bool _e78 = local_32;
            if (_e78) {
                float3 u_1 = (to_point / (dist).xxx);
                float facing = ((dot(n_18, -(u_1)) + 1.0) * 0.5);
                float _e87 = w_5;
                w_5 = (_e87 * ((facing * facing) + 0.2));
                uint _e97 = params.atlas_b.x;
                uint _e101 = params.atlas_b.y;
                const float2 _e102 = oct_encode(u_1);
                const float4 _e103 = atlas_bilinear(ATLAS_MOMENTS, tiles_4.y, _e97, _e101, _e102);
                float mean = _e103.x;
                float mean_sq = _e103.y;
                if ((dist > mean)) {
                    float variance = max(abs((mean_sq - (mean * mean))), ((1e-12 * mean) * mean));
                    float dd = (dist - mean);
                    float cheb = (variance / (variance + (dd * dd)));
                    float _e118 = w_5;
                    w_5 = (_e118 * max(((cheb * cheb) * cheb), 0.0));
                }
            }
            float _e124 = w_5;
            w_5 = max(_e124, (1e-6 * _e48));
            k_12 = 1.0;
            if ((tiles_4.z >= int(0))) {
                uint _e138 = params.atlas_b.z;
                uint _e142 = params.atlas_b.w;
                const float4 _e143 = atlas_bilinear(ATLAS_SCALE, tiles_4.z, _e138, _e142, _e36);
                k_12 = _e143.x;
            }
            float3 _e145 = e_1;
            const float3 _e147 = cell_irradiance(tiles_4.y, n_18);
            float _e148 = w_5;
            float _e150 = k_12;
            e_1 = (_e145 + ((_e147 * _e148) * _e150));
            float _e153 = wsum;
            float _e154 = w_5;
            wsum = (_e153 + _e154);
        }
    }
    float _e159 = wsum;
    if (!((_e159 > 0.0))) {
        return (0.0).xxx;
    }
    float3 _e165 = e_1;
    float _e166 = wsum;
    const float3 _e169 = clean((_e165 / (_e166).xxx));
    return _e169;
}

float2 hemi_encode(float3 v_9)
{
    bool local_33 = (bool)0;

    float z_1 = max(v_9.z, 0.0);
    float l1_1 = ((abs(v_9.x) + abs(v_9.y)) + z_1);
    if ((l1_1 >= F32_MIN_POSITIVE)) {
        const bool _e14 = finite(l1_1);
        local_33 = _e14;
    } else {
        local_33 = false;
    }
    bool _e16 = local_33;
    if (!(_e16)) {
        return float2(0.5, 0.5);
    }
    float px = (v_9.x / l1_1);
    float py = (v_9.y / l1_1);
    return clamp(float2((((px + py) * 0.5) + 0.5), (((px - py) * 0.5) + 0.5)), (0.0).xx, (1.0).xx);
}

SurfaceAxis ConstructSurfaceAxis(uint arg0, uint arg1, float arg2) {
    SurfaceAxis ret = (SurfaceAxis)0;
    ret.i0_ = arg0;
    ret.i1_ = arg1;
    ret.f = arg2;
    return ret;
}

SurfaceAxis surface_axis(float x_in, uint n_10)
{
    float x_4 = 0.5;

    const bool _e4 = finite(x_in);
    if (_e4) {
        x_4 = x_in;
    }
    float _e5 = x_4;
    float c_13 = clamp(((_e5 * float(n_10)) - 0.5), 0.0, float((n_10 - 1u)));
    uint i0_ = naga_f2u32(floor(c_13));
    const SurfaceAxis surfaceaxis = ConstructSurfaceAxis(i0_, min((i0_ + 1u), (n_10 - 1u)), (c_13 - float(i0_)));
    return surfaceaxis;
}

SurfaceTaps ConstructSurfaceTaps(uint2 arg0, uint2 arg1, float2 arg2) {
    SurfaceTaps ret = (SurfaceTaps)0;
    ret.lo = arg0;
    ret.hi = arg1;
    ret.f = arg2;
    return ret;
}

SurfaceTaps surface_taps(float2 uv_9)
{
    uint n_19 = surface_params.shape.z;
    float nf = float(n_19);
    float x_8 = clamp(((uv_9.x * nf) - 0.5), 0.0, (nf - 1.0));
    float y_1 = clamp(((uv_9.y * nf) - 0.5), 0.0, (nf - 1.0));
    float x0_1 = floor(x_8);
    float y0_ = floor(y_1);
    uint2 lo = uint2(naga_f2u32(x0_1), naga_f2u32(y0_));
    const SurfaceTaps surfacetaps = ConstructSurfaceTaps(lo, min((lo + (1u).xx), ((n_19 - 1u)).xx), float2((x_8 - x0_1), (y_1 - y0_)));
    return surfacetaps;
}

float3 surface_tile(uint i_2, uint j_1, uint layer, SurfaceTaps t_7)
{
    uint _e8 = surface_params.shape.z;
    uint2 o_4 = (uint2(i_2, j_1) * _e8);
    int l_7 = int(layer);
    float4 q00_1 = surface_radiance.Load(int4(int2((o_4 + t_7.lo)), l_7, int(0)));
    float4 q10_1 = surface_radiance.Load(int4(int2((o_4 + uint2(t_7.hi.x, t_7.lo.y))), l_7, int(0)));
    float4 q01_1 = surface_radiance.Load(int4(int2((o_4 + uint2(t_7.lo.x, t_7.hi.y))), l_7, int(0)));
    float4 q11_1 = surface_radiance.Load(int4(int2((o_4 + t_7.hi)), l_7, int(0)));
    const float4 _e44 = blend4_(q00_1, q10_1, q01_1, q11_1, t_7.f);
    return _e44.xyz;
}

float surface_tile_inv_distance(uint i_3, uint j_2, SurfaceTaps t_8)
{
    uint _e7 = surface_params.shape.z;
    uint2 o_5 = (uint2(i_3, j_2) * _e7);
    float4 q00_2 = surface_inv_distance.Load(int3(int2((o_5 + t_8.lo)), int(0)));
    float4 q10_2 = surface_inv_distance.Load(int3(int2((o_5 + uint2(t_8.hi.x, t_8.lo.y))), int(0)));
    float4 q01_2 = surface_inv_distance.Load(int3(int2((o_5 + uint2(t_8.lo.x, t_8.hi.y))), int(0)));
    float4 q11_2 = surface_inv_distance.Load(int3(int2((o_5 + t_8.hi)), int(0)));
    const float4 _e42 = blend4_(q00_2, q10_2, q01_2, q11_2, t_8.f);
    return _e42.x;
}

SurfaceTaps surface_warped_taps(uint i_4, uint j_3, float3 b_20, float3 local_34, SurfaceTaps shared_taps)
{
    bool local_35 = (bool)0;
    bool local_36 = (bool)0;

    SurfaceParams sp = surface_params;
    float s_6 = ((float(i_4) + 0.5) / float(sp.shape.x));
    float t_17 = ((float(j_3) + 0.5) / float(sp.shape.y));
    float3 probe = (((sp.corner.xyz + (sp.edge_u.xyz * s_6)) + (sp.edge_v.xyz * t_17)) + (sp.normal.xyz * sp.corner.w));
    float3 d_3 = (probe - b_20);
    float3 ab_2 = float3(dot(d_3, sp.tangent.xyz), dot(d_3, sp.bitangent.xyz), dot(d_3, sp.normal.xyz));
    const float _e48 = surface_tile_inv_distance(i_4, j_3, shared_taps);
    float3 v_14 = ((local_34 * max(((dot(local_34, ab_2) * _e48) + 1.0), 0.0)) - (ab_2 * _e48));
    if ((_e48 > 0.0)) {
        const bool _e62 = finite3_(v_14);
        local_35 = _e62;
    } else {
        local_35 = false;
    }
    bool _e64 = local_35;
    if (_e64) {
        local_36 = (dot(v_14, v_14) > 0.0);
    } else {
        local_36 = false;
    }
    bool _e71 = local_36;
    if (_e71) {
        const float2 _e72 = hemi_encode(v_14);
        const SurfaceTaps _e73 = surface_taps(_e72);
        const SurfaceTaps surfacetaps_1 = _e73;
        return surfacetaps_1;
    }
    const SurfaceTaps surfacetaps_2 = shared_taps;
    return surfacetaps_2;
}

float3 surface_probe(uint i_5, uint j_4, SurfaceTaps t_9, uint m0_, uint m1_, float fm)
{
    const float3 _e6 = surface_tile(i_5, j_4, m0_, t_9);
    if ((fm > 0.0)) {
        const float3 _e9 = surface_tile(i_5, j_4, m1_, t_9);
        return lerp(_e6, _e9, fm);
    }
    return _e6;
}

float3 surface_lookup(float3 b_in, float3 dir_in, float roughness_1, bool warped)
{
    float3 b_21 = (float3)0;
    float lod_2 = 0.0;
    SurfaceTaps t00_ = (SurfaceTaps)0;
    SurfaceTaps t10_ = (SurfaceTaps)0;
    SurfaceTaps t01_ = (SurfaceTaps)0;
    SurfaceTaps t11_ = (SurfaceTaps)0;

    const float4 _e4 = unit_direction(dir_in);
    if ((_e4.w == 0.0)) {
        return (0.0).xxx;
    }
    SurfaceParams sp_1 = surface_params;
    b_21 = sp_1.corner.xyz;
    const bool _e15 = finite3_(b_in);
    if (_e15) {
        b_21 = b_in;
    }
    float3 _e16 = b_21;
    float3 d_4 = (_e16 - sp_1.corner.xyz);
    const SurfaceAxis _e25 = surface_axis(dot(sp_1.dual_u.xyz, d_4), sp_1.shape.x);
    const SurfaceAxis _e31 = surface_axis(dot(sp_1.dual_v.xyz, d_4), sp_1.shape.y);
    uint last_2 = (sp_1.shape.w - 1u);
    const bool _e38 = finite(roughness_1);
    if (_e38) {
        lod_2 = (clamp(roughness_1, 0.0, 1.0) * float(last_2));
    }
    float _e44 = lod_2;
    uint m0_1 = naga_f2u32(floor(_e44));
    uint m1_1 = min((m0_1 + 1u), last_2);
    float _e50 = lod_2;
    float fm_1 = (_e50 - float(m0_1));
    float3 dir_15 = _e4.xyz;
    float3 local_37 = float3(dot(dir_15, sp_1.tangent.xyz), dot(dir_15, sp_1.bitangent.xyz), dot(dir_15, sp_1.normal.xyz));
    const float2 _e64 = hemi_encode(local_37);
    const SurfaceTaps _e65 = surface_taps(_e64);
    t00_ = _e65;
    t10_ = _e65;
    t01_ = _e65;
    t11_ = _e65;
    if (warped) {
        float3 _e72 = b_21;
        const SurfaceTaps _e73 = surface_warped_taps(_e25.i0_, _e31.i0_, _e72, local_37, _e65);
        t00_ = _e73;
        float3 _e76 = b_21;
        const SurfaceTaps _e77 = surface_warped_taps(_e25.i1_, _e31.i0_, _e76, local_37, _e65);
        t10_ = _e77;
        float3 _e80 = b_21;
        const SurfaceTaps _e81 = surface_warped_taps(_e25.i0_, _e31.i1_, _e80, local_37, _e65);
        t01_ = _e81;
        float3 _e84 = b_21;
        const SurfaceTaps _e85 = surface_warped_taps(_e25.i1_, _e31.i1_, _e84, local_37, _e65);
        t11_ = _e85;
    }
    SurfaceTaps _e88 = t00_;
    const float3 _e89 = surface_probe(_e25.i0_, _e31.i0_, _e88, m0_1, m1_1, fm_1);
    SurfaceTaps _e92 = t10_;
    const float3 _e93 = surface_probe(_e25.i1_, _e31.i0_, _e92, m0_1, m1_1, fm_1);
    float3 top_2 = lerp(_e89, _e93, _e25.f);
    SurfaceTaps _e98 = t01_;
    const float3 _e99 = surface_probe(_e25.i0_, _e31.i1_, _e98, m0_1, m1_1, fm_1);
    SurfaceTaps _e102 = t11_;
    const float3 _e103 = surface_probe(_e25.i1_, _e31.i1_, _e102, m0_1, m1_1, fm_1);
    float3 bottom = lerp(_e99, _e103, _e25.f);
    float3 l_8 = lerp(top_2, bottom, _e31.f);
    const bool _e108 = finite3_(l_8);
    if (_e108) {
        return max(l_8, (0.0).xxx);
    }
    return (0.0).xxx;
}

float3 surface_specular(float3 b_22, float3 dir_13, float roughness_2)
{
    const float3 _e4 = surface_lookup(b_22, dir_13, roughness_2, false);
    return _e4;
}

float3 surface_specular_warped(float3 b_23, float3 dir_14, float roughness_3)
{
    const float3 _e4 = surface_lookup(b_23, dir_14, roughness_3, true);
    return _e4;
}

uint NagaBufferLengthRW(RWByteAddressBuffer buffer)
{
    uint ret;
    buffer.GetDimensions(ret);
    return ret;
}

uint query_count()
{
    return ((NagaBufferLengthRW(results) - 0) / 16);
}

float offset_off_surface(float3 p_10)
{
    float4 _e3 = camera.surface_offset;
    float _e9 = camera.surface_offset.w;
    float3 pn = abs(((p_10 - _e3.xyz) * _e9));
    float _e24 = camera.surface_offset.w;
    return (((max(pn.x, max(pn.y, pn.z)) + 1.0) * 2e-5) / _e24);
}

[numthreads(64, 1, 1)]
void specular_queries(uint3 id : SV_DispatchThreadID)
{
    uint k_14 = id.x;
    const uint _e2 = query_count();
    if ((k_14 >= _e2)) {
        return;
    }
    float4 p_12 = asfloat(queries.Load4((2u * k_14)*16));
    float4 d_5 = asfloat(queries.Load4(((2u * k_14) + 1u)*16));
    const float3 _e21 = specular(p_12.xyz, d_5.xyz, p_12.w);
    results.Store4(k_14*16, asuint(float4(_e21, 1.0)));
    return;
}

[numthreads(64, 1, 1)]
void irradiance_queries(uint3 id_1 : SV_DispatchThreadID)
{
    uint k_15 = id_1.x;
    const uint _e2 = query_count();
    if ((k_15 >= _e2)) {
        return;
    }
    float4 p_13 = asfloat(queries.Load4((2u * k_15)*16));
    float4 n_20 = asfloat(queries.Load4(((2u * k_15) + 1u)*16));
    const float3 _e20 = irradiance(p_13.xyz, n_20.xyz);
    results.Store4(k_15*16, asuint(float4(_e20, 1.0)));
    return;
}

[numthreads(64, 1, 1)]
void warp1_queries(uint3 id_2 : SV_DispatchThreadID)
{
    float3 b = (float3)0;
    float3 c = (0.0).xxx;
    float3 v = (float3)0;

    uint k_16 = id_2.x;
    const uint _e2 = query_count();
    if ((k_16 >= _e2)) {
        return;
    }
    float4 _e6 = params.probe;
    b = _e6.xyz;
    float4 _e13 = asfloat(queries.Load4((2u * k_16)*16));
    const bool _e15 = finite3_(_e13.xyz);
    if (_e15) {
        float4 _e20 = asfloat(queries.Load4((2u * k_16)*16));
        b = _e20.xyz;
    }
    float4 _e28 = asfloat(queries.Load4(((2u * k_16) + 1u)*16));
    const float4 _e30 = unit_direction(_e28.xyz);
    if ((_e30.w != 0.0)) {
        v = _e30.xyz;
        float3 _e39 = b;
        float4 _e42 = params.probe;
        if (any((_e39 != _e42.xyz))) {
            float3 _e46 = b;
            const float3 _e48 = warp1_(_e46, _e30.xyz);
            v = _e48;
        }
        float3 _e49 = v;
        const float2 _e50 = oct_encode(_e49);
        const float3 _e53 = radiance_lod(_e50, 0.0, 0u);
        const float3 _e54 = clean(_e53);
        c = _e54;
    }
    float3 _e57 = c;
    results.Store4(k_16*16, asuint(float4(_e57, 1.0)));
    return;
}

[numthreads(64, 1, 1)]
void box_queries(uint3 id_3 : SV_DispatchThreadID)
{
    float3 b_1 = (float3)0;
    float3 c_1 = (0.0).xxx;
    float3 v_1 = (float3)0;

    uint k_17 = id_3.x;
    const uint _e2 = query_count();
    if ((k_17 >= _e2)) {
        return;
    }
    float4 _e6 = params.probe;
    b_1 = _e6.xyz;
    float4 _e13 = asfloat(queries.Load4((2u * k_17)*16));
    const bool _e15 = finite3_(_e13.xyz);
    if (_e15) {
        float4 _e20 = asfloat(queries.Load4((2u * k_17)*16));
        b_1 = _e20.xyz;
    }
    float4 _e28 = asfloat(queries.Load4(((2u * k_17) + 1u)*16));
    const float4 _e30 = unit_direction(_e28.xyz);
    if ((_e30.w != 0.0)) {
        v_1 = _e30.xyz;
        float3 _e39 = b_1;
        float4 _e42 = params.probe;
        if (any((_e39 != _e42.xyz))) {
            float3 _e46 = b_1;
            const float3 _e48 = box_fetch(_e46, _e30.xyz);
            v_1 = _e48;
        }
        float3 _e49 = v_1;
        const float2 _e50 = oct_encode(_e49);
        const float3 _e53 = radiance_lod(_e50, 0.0, 0u);
        const float3 _e54 = clean(_e53);
        c_1 = _e54;
    }
    float3 _e57 = c_1;
    results.Store4(k_17*16, asuint(float4(_e57, 1.0)));
    return;
}

[numthreads(64, 1, 1)]
void surface_queries(uint3 id_4 : SV_DispatchThreadID)
{
    uint k_18 = id_4.x;
    const uint _e2 = query_count();
    if ((k_18 >= _e2)) {
        return;
    }
    float4 p_14 = asfloat(queries.Load4((2u * k_18)*16));
    float4 d_6 = asfloat(queries.Load4(((2u * k_18) + 1u)*16));
    const float3 _e21 = surface_specular(p_14.xyz, d_6.xyz, p_14.w);
    results.Store4(k_18*16, asuint(float4(_e21, 1.0)));
    return;
}

[numthreads(64, 1, 1)]
void surface_warped_queries(uint3 id_5 : SV_DispatchThreadID)
{
    uint k_19 = id_5.x;
    const uint _e2 = query_count();
    if ((k_19 >= _e2)) {
        return;
    }
    float4 p_15 = asfloat(queries.Load4((2u * k_19)*16));
    float4 d_7 = asfloat(queries.Load4(((2u * k_19) + 1u)*16));
    const float3 _e21 = surface_specular_warped(p_15.xyz, d_7.xyz, p_15.w);
    results.Store4(k_19*16, asuint(float4(_e21, 1.0)));
    return;
}

VertexOutput_surface_vertex surface_vertex(SurfaceVertex v_2)
{
    SurfaceVarying out_ = (SurfaceVarying)0;

    float4x4 _e5 = camera.view_proj;
    out_.clip_ = mul(float4(v_2.position, 1.0), _e5);
    out_.world = v_2.position;
    out_.normal = v_2.normal;
    out_.albedo = v_2.albedo;
    out_.flags = v_2.flags;
    out_.sphere = v_2.sphere;
    SurfaceVarying _e20 = out_;
    const SurfaceVarying surfacevarying = _e20;
    const VertexOutput_surface_vertex surfacevarying_1 = { surfacevarying.world, surfacevarying.normal, surfacevarying.albedo, surfacevarying.flags, surfacevarying.sphere, surfacevarying.clip_ };
    return surfacevarying_1;
}

SurfaceOut surface_fragment(FragmentInput_surface_fragment fragmentinput_surface_fragment)
{
    SurfaceVarying v_3 = { fragmentinput_surface_fragment.clip_1, fragmentinput_surface_fragment.world_1, fragmentinput_surface_fragment.normal_2, fragmentinput_surface_fragment.albedo_1, fragmentinput_surface_fragment.flags_1, fragmentinput_surface_fragment.sphere_1 };
    SurfaceOut out_1 = (SurfaceOut)0;
    float3 p = (float3)0;
    float3 n = (float3)0;
    float t = (float)0;
    bool local = (bool)0;
    float3 dir = (float3)0;
    float r = 0.0;

    out_1.depth = v_3.clip_.z;
    float4 _e7 = camera.eye;
    float3 eye = _e7.xyz;
    float3 ray = normalize((v_3.world - eye));
    p = v_3.world;
    n = v_3.normal;
    if ((v_3.sphere.w != 0.0)) {
        float3 oc = (eye - v_3.sphere.xyz);
        float half_b = dot(oc, ray);
        float c_14 = (dot(oc, oc) - (v_3.sphere.w * v_3.sphere.w));
        float disc = ((half_b * half_b) - c_14);
        if ((disc < 0.0)) {
            discard;
        }
        float s_7 = sqrt(disc);
        t = (-(half_b) - s_7);
        float _e39 = t;
        if ((_e39 <= 0.0)) {
            t = (-(half_b) + s_7);
        }
        float _e44 = t;
        if ((_e44 <= 0.0)) {
            discard;
        }
        float _e47 = t;
        p = (eye + (ray * _e47));
        float3 _e50 = p;
        n = normalize((_e50 - v_3.sphere.xyz));
        if ((v_3.sphere.w < 0.0)) {
            float3 _e59 = n;
            n = -(_e59);
        }
        float4x4 _e63 = camera.view_proj;
        float3 _e64 = p;
        float4 clip_2 = mul(float4(_e64, 1.0), _e63);
        out_1.depth = clamp((clip_2.z / clip_2.w), 0.0, 1.0);
    }
    float3 _e75 = n;
    bool back = (dot(_e75, ray) > 0.0);
    if (back) {
        local = ((naga_f2u32(v_3.flags) & 1u) == 0u);
    } else {
        local = false;
    }
    bool _e88 = local;
    if (_e88) {
        out_1.radiance = float4(0.0, 0.0, 0.0, 1.0);
        float3 _e96 = p;
        out_1.query_point = float4(_e96, 0.0);
        SurfaceOut _e99 = out_1;
        const SurfaceOut surfaceout = _e99;
        return surfaceout;
    }
    if (back) {
        float3 _e100 = n;
        n = -(_e100);
    }
    float3 _e102 = p;
    float3 _e103 = n;
    float3 _e104 = p;
    const float _e105 = offset_off_surface(_e104);
    float3 b_26 = (_e102 + (_e103 * _e105));
    out_1.query_point = float4(b_26, 1.0);
    float3 _e111 = n;
    dir = _e111;
    float _e118 = camera.shading.y;
    if ((_e118 == 1.0)) {
        float3 _e122 = n;
        const float3 _e123 = irradiance(b_26, _e122);
        out_1.radiance = float4(((_e123 * v_3.albedo) * 0.31830987), 1.0);
    } else {
        float3 _e130 = n;
        float3 _e134 = n;
        dir = normalize((ray - ((2.0 * dot(ray, _e130)) * _e134)));
        float _e141 = camera.shading.x;
        r = _e141;
        float3 _e143 = dir;
        float _e144 = r;
        const float3 _e145 = specular(b_26, _e143, _e144);
        out_1.radiance = float4(_e145, 1.0);
    }
    float _e151 = camera.shading.z;
    if ((_e151 == 1.0)) {
        float3 _e155 = dir;
        float _e156 = r;
        out_1.radiance = float4(_e155, _e156);
    }
    SurfaceOut _e158 = out_1;
    const SurfaceOut surfaceout_1 = _e158;
    return surfaceout_1;
}
