#version 450 core
#extension GL_ARB_shader_storage_buffer_object : require
struct Params {
    vec4 grid_min;
    vec4 grid_max;
    uvec4 grid_counts;
    vec4 probe;
    uvec4 probe_info;
    vec4 warp;
    vec4 box_centre;
    vec4 box_half;
    vec4 box_x;
    vec4 box_y;
    vec4 box_z;
    vec4 kdop[18];
    uvec4 kdop_open;
    vec4 mip_roughness[4];
    uvec4 atlas_a;
    uvec4 atlas_b;
    vec4 lut;
    uvec4 lut_info;
    vec4 blend_r[2];
    vec4 blend_w[2];
    uvec4 probe_maps;
    vec4 probes[16];
};
struct Cell {
    ivec4 tiles;
    vec4 offset;
    vec4 sh[9];
    uvec4 links;
};
struct Footprint {
    ivec2 corner;
    vec2 f;
};
struct Lattice {
    uvec3 base;
    vec3 frac;
};
struct Basis {
    vec3 t;
    vec3 b;
};
struct Aim {
    vec3 v;
    float k;
    uint p;
};
struct Near {
    Lattice l;
    uvec3 home_at;
    uint links;
    uint count;
    float sum;
};
struct SurfaceParams {
    vec4 corner;
    vec4 edge_u;
    vec4 edge_v;
    vec4 tangent;
    vec4 bitangent;
    vec4 normal;
    vec4 dual_u;
    vec4 dual_v;
    uvec4 shape;
};
struct SurfaceAxis {
    uint i0_;
    uint i1_;
    float f;
};
struct SurfaceTaps {
    uvec2 lo;
    uvec2 hi;
    vec2 f;
};
struct CameraParams {
    mat4x4 view_proj;
    vec4 eye;
    vec4 surface_offset;
    vec4 shading;
};
struct SurfaceVertex {
    vec3 position;
    vec3 normal;
    vec3 albedo;
    float flags;
    vec4 sphere;
};
struct SurfaceVarying {
    vec4 clip;
    vec3 world;
    vec3 normal;
    vec3 albedo;
    float flags;
    vec4 sphere;
};
struct SurfaceOut {
    vec4 radiance;
    vec4 query_point;
    float depth;
};
const uint DYNAMIC = 255u;
const float HUGE = 1e30;
const float F32_MIN_POSITIVE = 1.1754944e-38;
const float F32_EPSILON = 1.1920929e-7;
const float PI = 3.1415927;
const uint ATLAS_CORRECTIVE = 0u;
const uint ATLAS_IRRADIANCE = 1u;
const uint ATLAS_MOMENTS = 2u;
const uint ATLAS_SCALE = 3u;
const float ROUGH_MAP_FROM = 0.5;
const float ROUGH_MAP_TO = 0.75;
const float FACE_MARGIN = 0.125;
const uint RELAXED = 255u;
const uint FALLBACK = 255u;
const uint BLEND = 255u;
const uint RELAX = 255u;
const uint ROUGHNESS_CORRECTION = 255u;

layout(binding = 0) uniform sampler2D _group_0_binding_0_fs;

layout(binding = 1) uniform sampler2D _group_0_binding_1_fs;

layout(binding = 2) uniform sampler2D _group_0_binding_2_fs;

layout(binding = 3) uniform sampler2D _group_0_binding_3_fs;

layout(binding = 4) uniform sampler2D _group_0_binding_4_fs;

layout(binding = 5) uniform sampler2D _group_0_binding_5_fs;

layout(binding = 6) uniform sampler2D _group_0_binding_6_fs;

layout(std140, binding = 0) uniform Params_block_0Fragment { Params _group_0_binding_7_fs; };

layout(std430, binding = 0) readonly buffer type_12_block_1Fragment { Cell _group_0_binding_8_fs[]; };

layout(std140, binding = 2) uniform CameraParams_block_2Fragment { CameraParams _group_3_binding_0_fs; };

layout(location = 0) smooth in vec3 _vs2fs_location0;
layout(location = 1) flat in vec3 _vs2fs_location1;
layout(location = 2) flat in vec3 _vs2fs_location2;
layout(location = 3) flat in float _vs2fs_location3;
layout(location = 4) flat in vec4 _vs2fs_location4;
layout(location = 0) out vec4 _fs2p_location0;
layout(location = 1) out vec4 _fs2p_location1;

uint fallback_method() {
    if (true) {
        uint _e8 = _group_0_binding_7_fs.probe_info.z;
        return _e8;
    }
    return FALLBACK;
}

uint blend_mode() {
    if (true) {
        uint _e8 = _group_0_binding_7_fs.grid_counts.w;
        return _e8;
    }
    return BLEND;
}

bool relaxation_on() {
    if (true) {
        float _e8 = _group_0_binding_7_fs.warp.x;
        return (_e8 > 0.0);
    }
    return false;
}

bool roughness_corrected() {
    if (true) {
        uint _e8 = _group_0_binding_7_fs.probe_info.w;
        return (_e8 != 0u);
    }
    return false;
}

bool finite(float x) {
    return ((floatBitsToUint(x) & 2139095040u) != 2139095040u);
}

bool finite3_(vec3 v_4) {
    bool local_1 = false;
    bool local_2 = false;
    bool _e2 = finite(v_4.x);
    if (_e2) {
        bool _e6 = finite(v_4.y);
        local_1 = _e6;
    } else {
        local_1 = false;
    }
    bool _e8 = local_1;
    if (_e8) {
        bool _e12 = finite(v_4.z);
        local_2 = _e12;
    } else {
        local_2 = false;
    }
    bool _e14 = local_2;
    return _e14;
}

float sign_not_zero(float x_1) {
    return ((x_1 >= 0.0) ? 1.0 : -1.0);
}

vec4 unit_direction(vec3 v_5) {
    bool local_3 = false;
    bool local_4 = false;
    bool local_5 = false;
    bool local_6 = false;
    float l2_ = dot(v_5, v_5);
    bool _e2 = finite(l2_);
    if (_e2) {
        local_3 = (abs((l2_ - 1.0)) <= 4.7683716e-7);
    } else {
        local_3 = false;
    }
    bool _e11 = local_3;
    if (_e11) {
        return vec4(v_5, 1.0);
    }
    float m_1 = max(abs(v_5.x), max(abs(v_5.y), abs(v_5.z)));
    if ((m_1 > 0.0)) {
        bool _e26 = finite(m_1);
        local_4 = _e26;
    } else {
        local_4 = false;
    }
    bool _e28 = local_4;
    if (_e28) {
        bool _e31 = finite3_(v_5);
        local_5 = _e31;
    } else {
        local_5 = false;
    }
    bool _e33 = local_5;
    if (!(_e33)) {
        return vec4(0.0, 0.0, 1.0, 0.0);
    }
    vec3 s_2 = (v_5 / vec3(m_1));
    float l_3 = length(s_2);
    if ((l_3 > 0.0)) {
        bool _e47 = finite(l_3);
        local_6 = _e47;
    } else {
        local_6 = false;
    }
    bool _e49 = local_6;
    if (!(_e49)) {
        return vec4(0.0, 0.0, 1.0, 0.0);
    }
    return vec4((s_2 / vec3(l_3)), 1.0);
}

vec3 fetch_vector(vec3 from, vec3 to, vec3 fallback) {
    bool local_7 = false;
    vec3 v_10 = (to - from);
    float l2_1 = dot(v_10, v_10);
    if ((l2_1 > 0.0)) {
        bool _e9 = finite(l2_1);
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

vec2 oct_encode(vec3 d) {
    bool local_8 = false;
    vec2 p_1 = vec2(0.0);
    float l1_ = ((abs(d.x) + abs(d.y)) + abs(d.z));
    if ((l1_ >= F32_MIN_POSITIVE)) {
        bool _e13 = finite(l1_);
        local_8 = _e13;
    } else {
        local_8 = false;
    }
    bool _e15 = local_8;
    if (!(_e15)) {
        return vec2(0.5, 0.5);
    }
    float inv_l1_ = (1.0 / l1_);
    p_1 = vec2((d.x * inv_l1_), (d.y * inv_l1_));
    if ((d.z < 0.0)) {
        float _e32 = p_1.y;
        float _e37 = p_1.x;
        float _e38 = sign_not_zero(_e37);
        float _e41 = p_1.x;
        float _e46 = p_1.y;
        float _e47 = sign_not_zero(_e46);
        p_1 = vec2(((1.0 - abs(_e32)) * _e38), ((1.0 - abs(_e41)) * _e47));
    }
    vec2 _e50 = p_1;
    return clamp(((_e50 * 0.5) + vec2(0.5)), vec2(0.0), vec2(1.0));
}

ivec2 wrap_texel(int n_1, ivec2 t_1) {
    int i = 0;
    int j = 0;
    i = t_1.x;
    j = t_1.y;
    int _e6 = i;
    if ((_e6 < 0)) {
        int _e9 = i;
        i = (-(_e9) - 1);
        int _e15 = j;
        j = ((n_1 - 1) - _e15);
    } else {
        int _e17 = i;
        if ((_e17 >= n_1)) {
            int _e23 = i;
            i = (((2 * n_1) - 1) - _e23);
            int _e27 = j;
            j = ((n_1 - 1) - _e27);
        }
    }
    int _e29 = j;
    if ((_e29 < 0)) {
        int _e34 = i;
        i = ((n_1 - 1) - _e34);
        int _e36 = j;
        j = (-(_e36) - 1);
    } else {
        int _e40 = j;
        if ((_e40 >= n_1)) {
            int _e44 = i;
            i = ((n_1 - 1) - _e44);
            int _e50 = j;
            j = (((2 * n_1) - 1) - _e50);
        }
    }
    int _e52 = i;
    int _e53 = j;
    return min(max(ivec2(_e52, _e53), ivec2(0)), ivec2((n_1 - 1)));
}

Footprint footprint(uint n_2, vec2 uv) {
    vec2 x_5 = ((clamp(uv, vec2(0.0), vec2(1.0)) * float(n_2)) - vec2(0.5));
    vec2 x0_ = floor(x_5);
    return Footprint(ivec2(x0_), (x_5 - x0_));
}

vec4 blend4_(vec4 q00_, vec4 q10_, vec4 q01_, vec4 q11_, vec2 f) {
    return ((((q00_ * (1.0 - f.x)) + (q10_ * f.x)) * (1.0 - f.y)) + (((q01_ * (1.0 - f.x)) + (q11_ * f.x)) * f.y));
}

vec4 probe_texel(uint which, ivec2 t_2, int level) {
    if ((which == 0u)) {
        vec4 _e6 = texelFetch(_group_0_binding_0_fs, t_2, level);
        return _e6;
    }
    vec4 _e8 = texelFetch(_group_0_binding_1_fs, t_2, level);
    return _e8;
}

vec4 probe_bilinear(uint which_1, vec2 uv_1, uint level_1, uint p_2) {
    float _e7 = _group_0_binding_7_fs.warp.z;
    float _e11 = _group_0_binding_7_fs.warp.y;
    float res0_ = ((which_1 == 0u) ? _e11 : _e7);
    uint n_11 = max((uint(res0_) >> level_1), 1u);
    Footprint _e19 = footprint(n_11, uv_1);
    ivec2 c_10 = _e19.corner;
    int l_4 = int(level_1);
    int ni = int(n_11);
    ivec2 at_3 = ivec2((int(p_2) * ni), 0);
    ivec2 _e27 = wrap_texel(ni, c_10);
    vec4 _e29 = probe_texel(which_1, (at_3 + _e27), l_4);
    ivec2 _e34 = wrap_texel(ni, (c_10 + ivec2(1, 0)));
    vec4 _e36 = probe_texel(which_1, (at_3 + _e34), l_4);
    ivec2 _e41 = wrap_texel(ni, (c_10 + ivec2(0, 1)));
    vec4 _e43 = probe_texel(which_1, (at_3 + _e41), l_4);
    ivec2 _e48 = wrap_texel(ni, (c_10 + ivec2(1, 1)));
    vec4 _e50 = probe_texel(which_1, (at_3 + _e48), l_4);
    vec4 _e52 = blend4_(_e29, _e36, _e43, _e50, _e19.f);
    return _e52;
}

vec4 probe_sample_lod(uint which_2, vec2 uv_2, float lod_in, uint levels, uint p_3) {
    float lod = 0.0;
    bool local_9 = false;
    float top = float((max(levels, 1u) - 1u));
    bool _e12 = finite(lod_in);
    if (_e12) {
        lod = min(max(lod_in, 0.0), top);
    }
    float _e16 = lod;
    uint l0_ = uint(_e16);
    float _e18 = lod;
    float f_3 = (_e18 - float(l0_));
    vec4 _e21 = probe_bilinear(which_2, uv_2, l0_, p_3);
    if (!((f_3 == 0.0))) {
        local_9 = ((l0_ + 1u) >= levels);
    } else {
        local_9 = true;
    }
    bool _e31 = local_9;
    if (_e31) {
        return _e21;
    }
    vec4 _e34 = probe_bilinear(which_2, uv_2, (l0_ + 1u), p_3);
    return ((_e21 * (1.0 - f_3)) + (_e34 * f_3));
}

vec3 radiance_lod(vec2 uv_3, float lod_1, uint p_4) {
    uint _e7 = _group_0_binding_7_fs.probe_info.x;
    vec4 _e8 = probe_sample_lod(0u, uv_3, lod_1, _e7, p_4);
    return _e8.xyz;
}

float inv_dist(vec3 v_6) {
    bool local_10 = false;
    vec2 _e2 = oct_encode(v_6);
    float _e6 = _group_0_binding_7_fs.probe.w;
    uint _e10 = _group_0_binding_7_fs.probe_info.y;
    vec4 _e12 = probe_sample_lod(1u, _e2, _e6, _e10, 0u);
    float w_6 = _e12.x;
    if ((w_6 > 0.0)) {
        bool _e18 = finite(w_6);
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

vec4 atlas_texel(uint which_3, ivec2 t_3) {
    switch(which_3) {
        case 0u: {
            vec4 _e4 = texelFetch(_group_0_binding_2_fs, t_3, 0);
            return _e4;
        }
        case 1u: {
            vec4 _e7 = texelFetch(_group_0_binding_3_fs, t_3, 0);
            return _e7;
        }
        case 2u: {
            vec4 _e10 = texelFetch(_group_0_binding_4_fs, t_3, 0);
            return _e10;
        }
        default: {
            vec4 _e13 = texelFetch(_group_0_binding_5_fs, t_3, 0);
            return _e13;
        }
    }
}

vec4 atlas_bilinear(uint which_4, int tile, uint n_3, uint columns, vec2 uv_4) {
    uint s_3 = uint(tile);
    ivec2 origin = ivec2((uvec2((s_3 % columns), (s_3 / columns)) * (n_3 + 2u)));
    Footprint _e13 = footprint(n_3, uv_4);
    ivec2 c_11 = ((origin + _e13.corner) + ivec2(1, 1));
    vec4 _e20 = atlas_texel(which_4, c_11);
    vec4 _e25 = atlas_texel(which_4, (c_11 + ivec2(1, 0)));
    vec4 _e30 = atlas_texel(which_4, (c_11 + ivec2(0, 1)));
    vec4 _e35 = atlas_texel(which_4, (c_11 + ivec2(1, 1)));
    vec4 _e37 = blend4_(_e20, _e25, _e30, _e35, _e13.f);
    return _e37;
}

vec3 cell_size() {
    vec4 _e2 = _group_0_binding_7_fs.grid_max;
    vec4 _e6 = _group_0_binding_7_fs.grid_min;
    uvec4 _e11 = _group_0_binding_7_fs.grid_counts;
    return ((_e2.xyz - _e6.xyz) / vec3(_e11.xyz));
}

uint cell_index(uvec3 c_2) {
    uvec4 n_12 = _group_0_binding_7_fs.grid_counts;
    return (c_2.x + (n_12.x * (c_2.y + (n_12.y * c_2.z))));
}

uvec3 cell_of(vec3 p_5, vec3 size) {
    vec4 _e4 = _group_0_binding_7_fs.grid_min;
    vec3 f_4 = floor(((p_5 - _e4.xyz) / size));
    uvec4 _e11 = _group_0_binding_7_fs.grid_counts;
    vec3 hi = vec3((_e11.xyz - uvec3(1u)));
    bool _e17 = finite3_(f_4);
    if (!(_e17)) {
        return uvec3(0u);
    }
    return uvec3(clamp(f_4, vec3(0.0), hi));
}

vec3 cell_centre(uvec3 c_3, vec3 size_1) {
    vec4 _e4 = _group_0_binding_7_fs.grid_min;
    return (_e4.xyz + ((vec3(c_3) + vec3(0.5)) * size_1));
}

Lattice lattice(vec3 p_6, vec3 size_2) {
    vec3 f_1 = vec3(0.0);
    vec4 _e4 = _group_0_binding_7_fs.grid_min;
    f_1 = (((p_6 - _e4.xyz) / size_2) - vec3(0.5));
    uvec4 _e14 = _group_0_binding_7_fs.grid_counts;
    vec3 hi_1 = vec3((_e14.xyz - uvec3(1u)));
    vec3 _e20 = f_1;
    bool _e21 = finite3_(_e20);
    if (_e21) {
        vec3 _e22 = f_1;
        f_1 = clamp(_e22, vec3(0.0), hi_1);
    } else {
        f_1 = vec3(0.0);
    }
    vec3 _e28 = f_1;
    vec3 base_1 = floor(_e28);
    vec3 _e31 = f_1;
    return Lattice(uvec3(base_1), (_e31 - base_1));
}

float corner_weight(Lattice l, uint corner) {
    uvec3 o = uvec3((corner & 1u), ((corner >> 1u) & 1u), ((corner >> 2u) & 1u));
    float wx = ((o.x == 1u) ? l.frac.x : (1.0 - l.frac.x));
    float wy = ((o.y == 1u) ? l.frac.y : (1.0 - l.frac.y));
    float wz = ((o.z == 1u) ? l.frac.z : (1.0 - l.frac.z));
    return ((wx * wy) * wz);
}

uvec3 corner_cell(Lattice l_1, uint corner_1) {
    uvec3 o_1 = uvec3((corner_1 & 1u), ((corner_1 >> 1u) & 1u), ((corner_1 >> 2u) & 1u));
    uvec4 _e17 = _group_0_binding_7_fs.grid_counts;
    return min((l_1.base + o_1), (_e17.xyz - uvec3(1u)));
}

vec2 warp1_exit(vec3 b_2, vec3 dir_1) {
    bool local_11 = false;
    vec4 _e4 = _group_0_binding_7_fs.probe;
    vec3 a_1 = _e4.xyz;
    float _e6 = inv_dist(dir_1);
    if ((_e6 == 0.0)) {
        return vec2(1e30, 1.0);
    }
    vec3 ab = (a_1 - b_2);
    float dir_ab = dot(dir_1, ab);
    vec3 v_11 = ((dir_1 * max(((dir_ab * _e6) + 1.0), 0.0)) - (ab * _e6));
    float _e23 = inv_dist(v_11);
    float lambda = (length(v_11) * _e23);
    if (!((lambda > 0.0))) {
        return vec2(1e30, 1.0);
    }
    float t_10 = (max(((dir_ab * lambda) + dot(dir_1, v_11)), 0.0) / lambda);
    bool _e37 = finite(t_10);
    if (_e37) {
        local_11 = (t_10 < HUGE);
    } else {
        local_11 = false;
    }
    bool _e43 = local_11;
    if (!(_e43)) {
        return vec2(1e30, 1.0);
    }
    return vec2(t_10, 1.0);
}

vec3 warp1_(vec3 b_3, vec3 dir_2) {
    vec4 _e4 = _group_0_binding_7_fs.probe;
    vec3 a_2 = _e4.xyz;
    float _e6 = inv_dist(dir_2);
    if ((_e6 == 0.0)) {
        return dir_2;
    }
    vec3 ab_1 = (a_2 - b_3);
    float dir_ab_1 = dot(dir_2, ab_1);
    vec3 v_12 = ((dir_2 * max(((dir_ab_1 * _e6) + 1.0), 0.0)) - (ab_1 * _e6));
    float _e20 = inv_dist(v_12);
    float lambda_1 = (length(v_12) * _e20);
    float t_11 = max(((dir_ab_1 * lambda_1) + dot(dir_2, v_12)), 0.0);
    vec3 f_5 = ((dir_2 * t_11) - (ab_1 * lambda_1));
    if ((lambda_1 > 0.0)) {
        vec3 _e34 = fetch_vector(vec3(0.0), f_5, dir_2);
        return _e34;
    }
    return dir_2;
}

vec2 box_exit(vec3 b_4, vec3 dir_3) {
    float t_4 = HUGE;
    int k = 0;
    vec4 _e4 = _group_0_binding_7_fs.box_x;
    vec4 _e8 = _group_0_binding_7_fs.box_y;
    vec4 _e12 = _group_0_binding_7_fs.box_z;
    mat3x3 m_2 = mat3x3(_e4.xyz, _e8.xyz, _e12.xyz);
    vec4 _e17 = _group_0_binding_7_fs.box_half;
    vec3 h = _e17.xyz;
    vec4 _e21 = _group_0_binding_7_fs.box_centre;
    vec3 o_2 = (m_2 * (b_4 - _e21.xyz));
    if (any(greaterThan(abs(o_2), h))) {
        return vec2(0.0, 0.0);
    }
    vec3 d_2 = (m_2 * dir_3);
    bool loop_init = true;
    while(true) {
        if (!loop_init) {
            int _e62 = k;
            k = (_e62 + 1);
        }
        loop_init = false;
        int _e36 = k;
        if ((_e36 < 3)) {
        } else {
            break;
        }
        {
            int _e39 = k;
            if ((d_2[_e39] != 0.0)) {
                int _e43 = k;
                int _e46 = k;
                int _e48 = k;
                float face = ((d_2[_e48] > 0.0) ? h[_e46] : -(h[_e43]));
                float _e53 = t_4;
                int _e54 = k;
                int _e57 = k;
                t_4 = min(_e53, ((face - o_2[_e54]) / d_2[_e57]));
            }
        }
    }
    float _e64 = t_4;
    if (!((_e64 < HUGE))) {
        return vec2(0.0, 0.0);
    }
    float _e71 = t_4;
    return vec2(max(_e71, 0.0), 1.0);
}

vec2 kdop_exit(vec3 b_5, vec3 dir_4) {
    float t_5 = HUGE;
    uint k_1 = 0u;
    bool loop_init_1 = true;
    while(true) {
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
            uint _e12 = _group_0_binding_7_fs.kdop_open.x;
            uint _e14 = k_1;
            if (((_e12 & (1u << _e14)) != 0u)) {
                continue;
            }
            uint _e21 = k_1;
            vec4 _e23 = _group_0_binding_7_fs.kdop[_e21];
            vec3 n_13 = _e23.xyz;
            uint _e27 = k_1;
            float h_1 = _group_0_binding_7_fs.kdop[_e27].w;
            float nb = dot(n_13, b_5);
            if ((nb > h_1)) {
                return vec2(0.0, 0.0);
            }
            float nd = dot(n_13, dir_4);
            if ((nd > 0.0)) {
                float _e39 = t_5;
                t_5 = min(_e39, ((h_1 - nb) / nd));
            }
        }
    }
    float _e46 = t_5;
    return vec2(_e46, 1.0);
}

vec2 proxy_exit(vec3 b_6, vec3 dir_5) {
    uint _e2 = fallback_method();
    switch(_e2) {
        case 0u: {
            vec2 _e3 = warp1_exit(b_6, dir_5);
            return _e3;
        }
        case 2u: {
            vec2 _e4 = kdop_exit(b_6, dir_5);
            return _e4;
        }
        default: {
            vec2 _e5 = box_exit(b_6, dir_5);
            return _e5;
        }
    }
}

vec3 proxy_fetch(vec2 exit, vec3 b_7, vec3 dir_6) {
    bool local_12 = false;
    if (!((exit.y == 0.0))) {
        local_12 = !((exit.x < HUGE));
    } else {
        local_12 = true;
    }
    bool _e14 = local_12;
    if (_e14) {
        return dir_6;
    }
    vec4 _e17 = _group_0_binding_7_fs.probe;
    vec3 _e22 = fetch_vector(_e17.xyz, (b_7 + (dir_6 * exit.x)), dir_6);
    return _e22;
}

vec3 box_fetch(vec3 b_8, vec3 dir_7) {
    vec2 _e2 = box_exit(b_8, dir_7);
    vec3 _e3 = proxy_fetch(_e2, b_8, dir_7);
    return _e3;
}

Basis orthonormal_basis(vec3 n_4) {
    float s_4 = ((n_4.z >= 0.0) ? 1.0 : -1.0);
    float a_3 = (-1.0 / (s_4 + n_4.z));
    float b_24 = ((n_4.x * n_4.y) * a_3);
    return Basis(vec3((1.0 + (((s_4 * n_4.x) * n_4.x) * a_3)), (s_4 * b_24), (-(s_4) * n_4.x)), vec3(b_24, (s_4 + ((n_4.y * n_4.y) * a_3)), -(n_4.y)));
}

vec3 normalize_or(vec3 v_7, vec3 fallback_1) {
    bool local_13 = false;
    float l_5 = length(v_7);
    if ((l_5 > 0.0)) {
        bool _e7 = finite(l_5);
        local_13 = _e7;
    } else {
        local_13 = false;
    }
    bool _e9 = local_13;
    if (_e9) {
        return (v_7 / vec3(l_5));
    }
    return fallback_1;
}

vec3 fallback_fetch(vec3 b_9, vec3 dir_8) {
    vec3 plain = vec3(0.0);
    vec3 sum = vec3(0.0);
    uint s = 0u;
    vec3 d_1 = vec3(0.0);
    vec4 _e4 = _group_0_binding_7_fs.probe;
    if (all(equal(b_9, _e4.xyz))) {
        return dir_8;
    }
    float relax = _group_0_binding_7_fs.warp.x;
    bool _e12 = relaxation_on();
    float _e18 = _group_0_binding_7_fs.warp.y;
    float angle = ((relax * 3.5449078) / _e18);
    Basis _e20 = orthonormal_basis(dir_8);
    vec3 t_12 = (_e20.t * angle);
    vec3 bt = (_e20.b * angle);
    plain = dir_8;
    bool loop_init_2 = true;
    while(true) {
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
            vec3 _e46 = d_1;
            vec2 _e47 = proxy_exit(b_9, _e46);
            vec3 _e48 = d_1;
            vec3 _e49 = proxy_fetch(_e47, b_9, _e48);
            uint _e50 = s;
            if ((_e50 == 0u)) {
                plain = _e49;
            }
            vec3 _e53 = sum;
            vec3 _e54 = normalize_or(_e49, dir_8);
            sum = (_e53 + _e54);
        }
    }
    if (!(_e12)) {
        vec3 _e60 = plain;
        return _e60;
    }
    vec3 _e61 = sum;
    vec3 _e62 = normalize_or(_e61, dir_8);
    return _e62;
}

Aim shifted_aim(vec2 exit_1, float delta, vec3 b_10, vec3 dir_9, uint p_7) {
    bool local_14 = false;
    float s_1 = 0.0;
    bool local_15 = false;
    float k_2 = 0.0;
    bool local_16 = false;
    if (!((exit_1.y == 0.0))) {
        local_14 = !((exit_1.x < HUGE));
    } else {
        local_14 = true;
    }
    bool _e16 = local_14;
    if (_e16) {
        return Aim(dir_9, 1.0, p_7);
    }
    s_1 = (exit_1.x + delta);
    float _e22 = s_1;
    if (!((_e22 > 1e-30))) {
        s_1 = 1e-30;
    }
    float _e27 = s_1;
    vec4 _e33 = _group_0_binding_7_fs.probes[p_7];
    vec3 v_13 = ((b_10 + (dir_9 * _e27)) - _e33.xyz);
    bool _e36 = finite3_(v_13);
    if (_e36) {
        local_15 = any(notEqual(v_13, vec3(0.0)));
    } else {
        local_15 = false;
    }
    bool _e44 = local_15;
    if (_e44) {
        float _e46 = s_1;
        k_2 = (length(v_13) / _e46);
        float _e49 = k_2;
        bool _e50 = finite(_e49);
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
        return Aim(v_13, _e60, p_7);
    }
    return Aim(dir_9, 1.0, p_7);
}

uint probe_of(int tile_1, uint unmapped, vec2 uv_5) {
    uint best = 0u;
    uint k_3 = 1u;
    if ((tile_1 < 0)) {
        uint _e8 = _group_0_binding_7_fs.probe_maps.x;
        return min(unmapped, (max(_e8, 1u) - 1u));
    }
    uint _e17 = _group_0_binding_7_fs.probe_maps.y;
    if ((_e17 == 0u)) {
        return 0u;
    }
    uint n_14 = _group_0_binding_7_fs.atlas_a.x;
    uint columns_1 = _group_0_binding_7_fs.atlas_a.y;
    uint _e33 = _group_0_binding_7_fs.probe_maps.y;
    uint s_5 = (uint(tile_1) + _e33);
    ivec2 origin_1 = ivec2((uvec2((s_5 % columns_1), (s_5 / columns_1)) * (n_14 + 2u)));
    Footprint _e42 = footprint(n_14, uv_5);
    vec2 f_6 = _e42.f;
    vec4 w_7 = vec4(((1.0 - f_6.x) * (1.0 - f_6.y)), (f_6.x * (1.0 - f_6.y)), ((1.0 - f_6.x) * f_6.y), (f_6.x * f_6.y));
    bool loop_init_3 = true;
    while(true) {
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
            if ((w_7[_e72] > w_7[_e74])) {
                uint _e77 = k_3;
                best = _e77;
            }
        }
    }
    uint _e87 = best;
    uint _e91 = best;
    ivec2 t_13 = (((origin_1 + _e42.corner) + ivec2(1, 1)) + ivec2(int((_e87 & 1u)), int((_e91 >> 1u))));
    vec4 _e98 = atlas_texel(ATLAS_CORRECTIVE, t_13);
    uint p_11 = uint(_e98.x);
    uint _e104 = _group_0_binding_7_fs.probe_maps.x;
    return min(p_11, (max(_e104, 1u) - 1u));
}

float map_delta(int tile_2, vec2 uv_6) {
    uint _e6 = _group_0_binding_7_fs.atlas_a.x;
    uint _e10 = _group_0_binding_7_fs.atlas_a.y;
    vec4 _e11 = atlas_bilinear(ATLAS_CORRECTIVE, tile_2, _e6, _e10, uv_6);
    return _e11.x;
}

float cell_delta(ivec4 tiles, vec2 uv_7, float r_1) {
    float w = 0.0;
    if ((tiles.w < 0)) {
        float _e7 = map_delta(tiles.x, uv_7);
        return _e7;
    }
    w = ((r_1 - ROUGH_MAP_FROM) / 0.25);
    float _e13 = w;
    if (!((_e13 > 0.0))) {
        float _e18 = map_delta(tiles.x, uv_7);
        return _e18;
    }
    float _e19 = w;
    if ((_e19 >= 1.0)) {
        float _e23 = map_delta(tiles.w, uv_7);
        return _e23;
    }
    float _e25 = map_delta(tiles.x, uv_7);
    float _e27 = map_delta(tiles.w, uv_7);
    float _e29 = w;
    return (_e25 + ((_e27 - _e25) * _e29));
}

Aim fetch(vec3 b_11, vec3 dir_10, float r_2) {
    float delta_1 = 0.0;
    bool mapped = false;
    uint corner_2 = 0u;
    bool local_17 = false;
    bool local_18 = false;
    vec2 _e3 = oct_encode(dir_10);
    vec3 _e4 = cell_size();
    uvec3 _e6 = cell_of(b_11, _e4);
    uint _e7 = cell_index(_e6);
    Cell home_cell = _group_0_binding_8_fs[_e7];
    ivec4 tiles_1 = home_cell.tiles;
    uint _e14 = probe_of(tiles_1.x, home_cell.links.y, _e3);
    vec4 _e18 = _group_0_binding_7_fs.probes[_e14];
    if (all(equal(b_11, _e18.xyz))) {
        return Aim(dir_10, 1.0, _e14);
    }
    uint _e28 = blend_mode();
    if ((_e28 != 1u)) {
        if ((tiles_1.x >= 0)) {
            float _e34 = cell_delta(tiles_1, _e3, r_2);
            delta_1 = _e34;
            mapped = true;
        }
    } else {
        Lattice _e36 = lattice(b_11, _e4);
        bool loop_init_4 = true;
        while(true) {
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
                uvec3 _e44 = corner_cell(_e36, _e43);
                uint _e45 = cell_index(_e44);
                ivec4 tiles_2 = _group_0_binding_8_fs[_e45].tiles;
                if ((tiles_2.x >= 0)) {
                    float _e52 = delta_1;
                    uint _e53 = corner_2;
                    float _e54 = corner_weight(_e36, _e53);
                    float _e55 = cell_delta(tiles_2, _e3, r_2);
                    delta_1 = (_e52 + (_e54 * _e55));
                    mapped = true;
                }
            }
        }
    }
    bool _e62 = mapped;
    if (!(_e62)) {
        bool _e66 = relaxation_on();
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
        vec3 _e75 = fallback_fetch(b_11, dir_10);
        return Aim(_e75, -1.0, 0u);
    }
    vec2 _e79 = proxy_exit(b_11, dir_10);
    float _e80 = delta_1;
    Aim _e81 = shifted_aim(_e79, _e80, b_11, dir_10, _e14);
    return _e81;
}

float face_ramp(float x_2) {
    return clamp(((x_2 - 0.375) / 0.25), 0.0, 1.0);
}

Lattice face_lattice(vec3 b_12) {
    vec3 _e1 = cell_size();
    Lattice _e2 = lattice(b_12, _e1);
    float _e6 = face_ramp(_e2.frac.x);
    float _e9 = face_ramp(_e2.frac.y);
    float _e12 = face_ramp(_e2.frac.z);
    return Lattice(_e2.base, vec3(_e6, _e9, _e12));
}

float linked_weight(Lattice l_2, uint corner_3, uvec3 home_at, uint links) {
    float _e4 = corner_weight(l_2, corner_3);
    if (!((_e4 > 0.0))) {
        return 0.0;
    }
    uvec3 _e9 = corner_cell(l_2, corner_3);
    if (all(equal(_e9, home_at))) {
        return _e4;
    }
    ivec3 o_3 = (ivec3(_e9) - ivec3(home_at));
    if (any(greaterThan(abs(o_3), ivec3(1)))) {
        return 0.0;
    }
    uint bit = uint((((o_3.x + 1) + (3 * (o_3.y + 1))) + (9 * (o_3.z + 1))));
    return ((((links >> bit) & 1u) != 0u) ? _e4 : 0.0);
}

float near_weight(Near near, uint corner_4) {
    float _e5 = linked_weight(near.l, corner_4, near.home_at, near.links);
    return (_e5 / near.sum);
}

float mip_roughness(uint m) {
    float _e9 = _group_0_binding_7_fs.mip_roughness[(m / 4u)][(m % 4u)];
    return _e9;
}

float lod_of_roughness(float r_3) {
    bool local_19 = false;
    uint below = 0u;
    uint t_6 = 0u;
    float f_2 = 0.0;
    uint n_15 = _group_0_binding_7_fs.probe_info.x;
    if (!((n_15 < 2u))) {
        float _e11 = mip_roughness(0u);
        local_19 = !((r_3 > _e11));
    } else {
        local_19 = true;
    }
    bool _e15 = local_19;
    if (_e15) {
        return 0.0;
    }
    uint last = (n_15 - 1u);
    float _e19 = mip_roughness(last);
    if ((r_3 >= _e19)) {
        return float(last);
    }
    bool loop_init_5 = true;
    while(true) {
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
            float _e32 = mip_roughness(_e31);
            below = (_e28 + ((_e32 <= r_3) ? 1u : 0u));
        }
    }
    uint _e39 = below;
    uint i_6 = (min(max(_e39, 1u), last) - 1u);
    float _e46 = mip_roughness((i_6 + 1u));
    float _e47 = mip_roughness(i_6);
    float span = (_e46 - _e47);
    if ((span > 0.0)) {
        float _e53 = mip_roughness(i_6);
        f_2 = ((r_3 - _e53) / span);
    }
    float _e57 = f_2;
    return (float(i_6) + clamp(_e57, 0.0, 1.0));
}

float distance_ratio(vec3 b_13, vec3 v_8, vec2 uv_8, uint p_8) {
    bool local_20 = false;
    bool local_21 = false;
    bool local_22 = false;
    bool local_23 = false;
    float l_6 = length(v_8);
    float _e9 = _group_0_binding_7_fs.probe.w;
    uint _e13 = _group_0_binding_7_fs.probe_info.y;
    vec4 _e14 = probe_sample_lod(1u, uv_8, _e9, _e13, p_8);
    float w_8 = _e14.x;
    if ((l_6 > 0.0)) {
        bool _e20 = finite(l_6);
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
        bool _e31 = finite(w_8);
        local_22 = _e31;
    } else {
        local_22 = false;
    }
    bool _e33 = local_22;
    if (!(_e33)) {
        return 1.0;
    }
    float d_probe = (1.0 / w_8);
    vec4 _e41 = _group_0_binding_7_fs.probes[p_8];
    float d_surface = length(((_e41.xyz + (v_8 * (d_probe / l_6))) - b_13));
    float k_13 = (d_probe / d_surface);
    bool _e49 = finite(k_13);
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

float pseudo_log2_(float k_4) {
    uint bits_1 = floatBitsToUint(k_4);
    int e_2 = (int(((bits_1 >> 23u) & 255u)) - 127);
    float m_3 = uintBitsToFloat(((bits_1 & 8388607u) | 1065353216u));
    return (float(e_2) + (m_3 - 1.0));
}

float corrected_roughness(float r_4, float k_in) {
    float fr = 0.0;
    float k_5 = 1.0;
    bool local_24 = false;
    uint n_16 = _group_0_binding_7_fs.lut_info.x;
    float last_1 = float((n_16 - 1u));
    bool _e11 = finite(r_4);
    if (_e11) {
        fr = clamp((r_4 * last_1), 0.0, last_1);
    }
    bool _e17 = finite(k_in);
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
    float _e28 = _group_0_binding_7_fs.lut.z;
    float _e32 = _group_0_binding_7_fs.lut.w;
    k_5 = clamp(_e24, _e28, _e32);
    float _e34 = k_5;
    float _e35 = pseudo_log2_(_e34);
    float _e39 = _group_0_binding_7_fs.lut.x;
    float _e44 = _group_0_binding_7_fs.lut.y;
    float fx = clamp(((_e35 - _e39) * _e44), 0.0, last_1);
    float _e48 = fr;
    uint i_7 = min(uint(_e48), (n_16 - 2u));
    uint j_5 = min(uint(fx), (n_16 - 2u));
    float _e57 = fr;
    float a_4 = (_e57 - float(i_7));
    float b_25 = (fx - float(j_5));
    vec4 _e67 = texelFetch(_group_0_binding_6_fs, ivec2(int(j_5), int(i_7)), 0);
    float v00_ = _e67.x;
    vec4 _e76 = texelFetch(_group_0_binding_6_fs, ivec2(int((j_5 + 1u)), int(i_7)), 0);
    float v01_ = _e76.x;
    vec4 _e85 = texelFetch(_group_0_binding_6_fs, ivec2(int(j_5), int((i_7 + 1u))), 0);
    float v10_ = _e85.x;
    vec4 _e96 = texelFetch(_group_0_binding_6_fs, ivec2(int((j_5 + 1u)), int((i_7 + 1u))), 0);
    float v11_ = _e96.x;
    return ((((v00_ * (1.0 - b_25)) + (v01_ * b_25)) * (1.0 - a_4)) + (((v10_ * (1.0 - b_25)) + (v11_ * b_25)) * a_4));
}

vec3 shade(vec3 b_14, Aim aim, float r_5) {
    float k_6 = 0.0;
    vec2 _e4 = oct_encode(aim.v);
    if ((r_5 == 0.0)) {
        vec3 _e9 = radiance_lod(_e4, 0.0, aim.p);
        return _e9;
    }
    bool _e10 = roughness_corrected();
    if (!(_e10)) {
        float _e12 = lod_of_roughness(r_5);
        vec3 _e14 = radiance_lod(_e4, _e12, aim.p);
        return _e14;
    }
    k_6 = aim.k;
    float _e17 = k_6;
    if ((_e17 < 0.0)) {
        float _e22 = distance_ratio(b_14, aim.v, _e4, aim.p);
        k_6 = _e22;
    }
    float _e23 = k_6;
    float _e24 = corrected_roughness(r_5, _e23);
    float _e25 = lod_of_roughness(_e24);
    vec3 _e27 = radiance_lod(_e4, _e25, aim.p);
    return _e27;
}

vec3 faces_radiance(Near near_1, vec3 b_15, vec3 dir_11, float r_6) {
    uint keys[8] = uint[8](0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
    float ws[8] = float[8](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    float ds[8] = float[8](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    uint n_5 = 0u;
    uint corner_5 = 0u;
    uint key = 0u;
    float delta_2 = 0.0;
    bool local_25 = false;
    uint at = 0u;
    uint g = 0u;
    bool local_26 = false;
    vec3 c_4 = vec3(0.0);
    uint g_1 = 0u;
    Aim aim_1 = Aim(vec3(0.0), 0.0, 0u);
    vec2 _e4 = oct_encode(dir_11);
    bool _e5 = relaxation_on();
    bool loop_init_6 = true;
    while(true) {
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
            float _e44 = near_weight(near_1, _e43);
            if (!((_e44 > 0.0))) {
                continue;
            }
            uint _e50 = corner_5;
            uvec3 _e51 = corner_cell(near_1.l, _e50);
            uint _e52 = cell_index(_e51);
            Cell cell_1 = _group_0_binding_8_fs[_e52];
            ivec4 tiles_3 = cell_1.tiles;
            uint _e59 = probe_of(tiles_3.x, cell_1.links.y, _e4);
            key = _e59;
            delta_2 = 0.0;
            if ((tiles_3.x >= 0)) {
                float _e66 = cell_delta(tiles_3, _e4, r_6);
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
            bool loop_init_7 = true;
            while(true) {
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
                    uint _e84 = keys[_e82];
                    uint _e85 = key;
                    if ((_e84 == _e85)) {
                        uint _e89 = g;
                        float _e91 = ds[_e89];
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
                keys[_e103] = _e105;
                uint _e106 = n_5;
                ws[_e106] = 0.0;
                uint _e109 = n_5;
                float _e111 = delta_2;
                ds[_e109] = _e111;
                uint _e113 = n_5;
                n_5 = (_e113 + 1u);
            }
            uint _e115 = at;
            float _e117 = ws[_e115];
            ws[_e115] = (_e117 + _e44);
        }
    }
    vec2 _e122 = proxy_exit(b_15, dir_11);
    bool loop_init_8 = true;
    while(true) {
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
            uint _e133 = keys[_e131];
            aim_1 = Aim(dir_11, 1.0, _e133);
            uint _e137 = g_1;
            uint _e139 = keys[_e137];
            if ((_e139 == RELAXED)) {
                vec3 _e142 = fallback_fetch(b_15, dir_11);
                aim_1 = Aim(_e142, -1.0, 0u);
            } else {
                uint _e148 = g_1;
                uint _e150 = keys[_e148];
                vec4 _e152 = _group_0_binding_7_fs.probes[_e150];
                if (any(notEqual(b_15, _e152.xyz))) {
                    uint _e156 = g_1;
                    float _e158 = ds[_e156];
                    uint _e159 = g_1;
                    uint _e161 = keys[_e159];
                    Aim _e162 = shifted_aim(_e122, _e158, b_15, dir_11, _e161);
                    aim_1 = _e162;
                }
            }
            vec3 _e163 = c_4;
            uint _e164 = g_1;
            float _e166 = ws[_e164];
            Aim _e167 = aim_1;
            vec3 _e168 = shade(b_15, _e167, r_6);
            c_4 = (_e163 + (_e166 * _e168));
        }
    }
    vec3 _e174 = c_4;
    return _e174;
}

Near near_cells(vec3 b_16) {
    uint count = 0u;
    float sum_1 = 0.0;
    uint corner_6 = 0u;
    Lattice _e1 = face_lattice(b_16);
    vec3 _e2 = cell_size();
    uvec3 _e3 = cell_of(b_16, _e2);
    uint _e5 = cell_index(_e3);
    uint links_1 = _group_0_binding_8_fs[_e5].links.x;
    bool loop_init_9 = true;
    while(true) {
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
            float _e20 = linked_weight(_e1, _e19, _e3, links_1);
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
    return Near(_e1, _e3, links_1, _e31, _e32);
}

vec3 sh_eval(vec3 c_5[9], vec3 n_6) {
    float x_6 = n_6.x;
    float y = n_6.y;
    float z = n_6.z;
    vec3 t0_ = (c_5[0] * 0.2820948);
    vec3 t1_ = (c_5[1] * (0.4886025 * y));
    vec3 t2_ = (c_5[2] * (0.4886025 * z));
    vec3 t3_ = (c_5[3] * (0.4886025 * x_6));
    vec3 t4_ = (c_5[4] * (1.0925484 * (x_6 * y)));
    vec3 t5_ = (c_5[5] * (1.0925484 * (y * z)));
    vec3 t6_ = (c_5[6] * (0.31539157 * ((3.0 * (z * z)) - 1.0)));
    vec3 t7_ = (c_5[7] * (1.0925484 * (x_6 * z)));
    vec3 t8_ = (c_5[8] * (0.5462742 * ((x_6 * x_6) - (y * y))));
    vec3 e_3 = ((((t0_ + t1_) + (t2_ + t3_)) + ((t4_ + t5_) + (t6_ + t7_))) + t8_);
    return max(e_3, vec3(0.0));
}

vec3 cell_sh_irradiance(uint cell, vec3 n_7) {
    vec4 _e6 = _group_0_binding_8_fs[cell].sh[0];
    vec4 _e12 = _group_0_binding_8_fs[cell].sh[1];
    vec4 _e18 = _group_0_binding_8_fs[cell].sh[2];
    vec4 _e24 = _group_0_binding_8_fs[cell].sh[3];
    vec4 _e30 = _group_0_binding_8_fs[cell].sh[4];
    vec4 _e36 = _group_0_binding_8_fs[cell].sh[5];
    vec4 _e42 = _group_0_binding_8_fs[cell].sh[6];
    vec4 _e48 = _group_0_binding_8_fs[cell].sh[7];
    vec4 _e54 = _group_0_binding_8_fs[cell].sh[8];
    vec3 c_12[9] = vec3[9](_e6.xyz, _e12.xyz, _e18.xyz, _e24.xyz, _e30.xyz, _e36.xyz, _e42.xyz, _e48.xyz, _e54.xyz);
    vec3 _e57 = sh_eval(c_12, n_7);
    return _e57;
}

vec3 sh_blend4_(uvec4 at_1, vec4 w_1, uint i_1) {
    vec4 _e8 = _group_0_binding_8_fs[at_1.x].sh[i_1];
    vec4 _e17 = _group_0_binding_8_fs[at_1.y].sh[i_1];
    vec4 _e27 = _group_0_binding_8_fs[at_1.z].sh[i_1];
    vec4 _e36 = _group_0_binding_8_fs[at_1.w].sh[i_1];
    return (((_e8.xyz * w_1.x) + (_e17.xyz * w_1.y)) + ((_e27.xyz * w_1.z) + (_e36.xyz * w_1.w)));
}

vec3 sh_read(uvec3 home_at_1, vec3 b_17, vec3 n_8) {
    uvec3 base = uvec3(0u);
    vec3 frac = vec3(0.0);
    uint a = 0u;
    uint bx = 1u;
    uint c_6 = 2u;
    uvec3 top_v = uvec3(0u);
    uvec3 home_v = uvec3(0u);
    uint bit0_ = 0u;
    uint x_3 = 0u;
    uint rel = 0u;
    uvec4 corner_cell_1 = uvec4(0u);
    uvec4 bits = uvec4(0u);
    uint k_7 = 1u;
    uint cs = 0u;
    uint bs = 0u;
    vec4 w_2 = vec4(0.0);
    uvec4 at_2 = uvec4(0u);
    uint k_8 = 0u;
    bool kept = false;
    bool local_27 = false;
    bool local_28 = false;
    vec3 _e3 = cell_size();
    uvec4 _e6 = _group_0_binding_7_fs.grid_counts;
    uvec3 counts = _e6.xyz;
    uvec3 top_1 = (counts - uvec3(1u));
    vec4 _e13 = _group_0_binding_7_fs.grid_min;
    vec3 units = ((b_17 - _e13.xyz) / _e3);
    uint _e17 = cell_index(home_at_1);
    vec3 f0_ = (units - vec3(0.5));
    bool _e21 = finite3_(f0_);
    if (!(_e21)) {
        vec3 _e23 = cell_sh_irradiance(_e17, n_8);
        return _e23;
    }
    vec3 f_7 = clamp(f0_, vec3(0.0), vec3(top_1));
    vec3 fl = floor(f_7);
    base = uvec3(fl);
    frac = (f_7 - fl);
    uint _e39 = bx;
    float _e41 = frac[_e39];
    uint _e42 = a;
    float _e44 = frac[_e42];
    if ((_e41 > _e44)) {
        uint t_14 = a;
        uint _e47 = bx;
        a = _e47;
        bx = t_14;
    }
    uint _e48 = c_6;
    float _e50 = frac[_e48];
    uint _e51 = bx;
    float _e53 = frac[_e51];
    if ((_e50 > _e53)) {
        uint t_15 = bx;
        uint _e56 = c_6;
        bx = _e56;
        c_6 = t_15;
        uint _e57 = bx;
        float _e59 = frac[_e57];
        uint _e60 = a;
        float _e62 = frac[_e60];
        if ((_e59 > _e62)) {
            uint u = a;
            uint _e65 = bx;
            a = _e65;
            bx = u;
        }
    }
    uint _e66 = a;
    float _e68 = frac[_e66];
    uint _e71 = a;
    float _e73 = frac[_e71];
    uint _e74 = bx;
    float _e76 = frac[_e74];
    uint _e78 = bx;
    float _e80 = frac[_e78];
    uint _e81 = c_6;
    float _e83 = frac[_e81];
    uint _e85 = c_6;
    float _e87 = frac[_e85];
    vec4 weights = vec4((1.0 - _e68), (_e73 - _e76), (_e80 - _e83), _e87);
    top_v = top_1;
    home_v = home_at_1;
    uvec3 cell_stride = uvec3(1u, counts.x, (counts.x * counts.y));
    uvec3 bit_stride = uvec3(1u, 3u, 9u);
    uint _e102 = base.x;
    uint _e105 = base.y;
    uint _e108 = base.z;
    uint cell0_ = (_e102 + (counts.x * (_e105 + (counts.y * _e108))));
    bool loop_init_10 = true;
    while(true) {
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
            uint _e122 = base[_e120];
            uint up = (_e122 + 1u);
            rel = 0u;
            uint _e127 = x_3;
            uint _e129 = home_v[_e127];
            if ((up > _e129)) {
                uint _e131 = x_3;
                uint _e133 = home_v[_e131];
                rel = min((up - _e133), 2u);
            }
            uint _e137 = bit0_;
            uint _e138 = rel;
            uint _e139 = x_3;
            bit0_ = (_e137 + (_e138 * bit_stride[_e139]));
        }
    }
    corner_cell_1 = uvec4(cell0_);
    uint _e148 = bit0_;
    bits = uvec4(_e148);
    uint _e151 = a;
    uint _e152 = bx;
    uint _e153 = c_6;
    uvec3 axes = uvec3(_e151, _e152, _e153);
    bool loop_init_11 = true;
    while(true) {
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
            uint x_7 = axes[(_e160 - 1u)];
            cs = 0u;
            bs = 0u;
            uint _e169 = base[x_7];
            uint _e171 = top_v[x_7];
            if ((_e169 < _e171)) {
                cs = cell_stride[x_7];
                bs = bit_stride[x_7];
            }
            uint _e175 = k_7;
            uint _e177 = k_7;
            uint _e181 = corner_cell_1[(_e177 - 1u)];
            uint _e182 = cs;
            corner_cell_1[_e175] = (_e181 + _e182);
            uint _e184 = k_7;
            uint _e186 = k_7;
            uint _e190 = bits[(_e186 - 1u)];
            uint _e191 = bs;
            bits[_e184] = (_e190 + _e191);
        }
    }
    uint links_2 = _group_0_binding_8_fs[_e17].links.x;
    w_2 = weights;
    at_2 = uvec4(_e17);
    uint count_1 = uint(_group_0_binding_8_fs.length());
    bool loop_init_12 = true;
    while(true) {
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
            uint ck = corner_cell_1[_e211];
            kept = false;
            uint _e216 = k_8;
            uint _e218 = bits[_e216];
            if ((_e218 < 27u)) {
                uint _e223 = k_8;
                uint _e225 = bits[_e223];
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
                int _e242 = _group_0_binding_8_fs[ck].tiles.y;
                kept = (_e242 >= 0);
            }
            bool _e245 = kept;
            if (_e245) {
                uint _e246 = k_8;
                at_2[_e246] = ck;
            } else {
                uint _e248 = k_8;
                w_2[_e248] = 0.0;
            }
        }
    }
    float _e255 = w_2.x;
    float _e257 = w_2.y;
    float _e260 = w_2.z;
    float _e262 = w_2.w;
    float wsum_1 = ((_e255 + _e257) + (_e260 + _e262));
    if (!((wsum_1 > 0.0))) {
        vec3 _e268 = cell_sh_irradiance(_e17, n_8);
        return _e268;
    }
    uvec4 _e269 = at_2;
    vec4 _e270 = w_2;
    vec3 _e272 = sh_blend4_(_e269, _e270, 0u);
    uvec4 _e273 = at_2;
    vec4 _e274 = w_2;
    vec3 _e276 = sh_blend4_(_e273, _e274, 1u);
    uvec4 _e277 = at_2;
    vec4 _e278 = w_2;
    vec3 _e280 = sh_blend4_(_e277, _e278, 2u);
    uvec4 _e281 = at_2;
    vec4 _e282 = w_2;
    vec3 _e284 = sh_blend4_(_e281, _e282, 3u);
    uvec4 _e285 = at_2;
    vec4 _e286 = w_2;
    vec3 _e288 = sh_blend4_(_e285, _e286, 4u);
    uvec4 _e289 = at_2;
    vec4 _e290 = w_2;
    vec3 _e292 = sh_blend4_(_e289, _e290, 5u);
    uvec4 _e293 = at_2;
    vec4 _e294 = w_2;
    vec3 _e296 = sh_blend4_(_e293, _e294, 6u);
    uvec4 _e297 = at_2;
    vec4 _e298 = w_2;
    vec3 _e300 = sh_blend4_(_e297, _e298, 7u);
    uvec4 _e301 = at_2;
    vec4 _e302 = w_2;
    vec3 _e304 = sh_blend4_(_e301, _e302, 8u);
    vec3 acc[9] = vec3[9](_e272, _e276, _e280, _e284, _e288, _e292, _e296, _e300, _e304);
    vec3 _e306 = sh_eval(acc, n_8);
    return (_e306 / vec3(wsum_1));
}

vec3 faces_specular(Near near_2, vec3 b_18, vec3 dir_12, float r_7, float w_3) {
    vec3 c_7 = vec3(0.0);
    vec3 e = vec3(0.0);
    float share = 0.0;
    uint corner_7 = 0u;
    bool local_29 = false;
    vec3 _e5 = faces_radiance(near_2, b_18, dir_12, r_7);
    c_7 = _e5;
    if ((w_3 > 0.0)) {
        bool loop_init_13 = true;
        while(true) {
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
                float _e20 = near_weight(near_2, _e19);
                uint _e22 = corner_7;
                uvec3 _e23 = corner_cell(near_2.l, _e22);
                if ((_e20 > 0.0)) {
                    uint _e29 = cell_index(_e23);
                    int _e33 = _group_0_binding_8_fs[_e29].tiles.y;
                    local_29 = (_e33 >= 0);
                } else {
                    local_29 = false;
                }
                bool _e37 = local_29;
                if (_e37) {
                    vec3 _e38 = e;
                    vec3 _e39 = sh_read(_e23, b_18, dir_12);
                    e = (_e38 + (_e20 * _e39));
                    float _e42 = share;
                    share = (_e42 + _e20);
                }
            }
        }
        float _e47 = share;
        if ((_e47 > 0.0)) {
            vec3 _e50 = c_7;
            float _e51 = share;
            vec3 _e56 = e;
            float _e57 = share;
            float _e60 = share;
            c_7 = ((_e50 * (1.0 - (w_3 * _e51))) + ((_e56 / vec3(_e57)) * ((w_3 * _e60) * 0.31830987)));
        }
    }
    vec3 _e66 = c_7;
    return _e66;
}

float blend_node_r(uint k_9) {
    float _e9 = _group_0_binding_7_fs.blend_r[(k_9 / 4u)][(k_9 % 4u)];
    return _e9;
}

float blend_node_w(uint k_10) {
    float _e9 = _group_0_binding_7_fs.blend_w[(k_10 / 4u)][(k_10 % 4u)];
    return _e9;
}

float irradiance_weight(float r_8) {
    bool local_30 = false;
    float w_4 = 0.0;
    uint k_11 = 1u;
    uint n_17 = _group_0_binding_7_fs.lut_info.y;
    if (!((n_17 == 0u))) {
        local_30 = !((r_8 > 0.0));
    } else {
        local_30 = true;
    }
    bool _e14 = local_30;
    if (_e14) {
        return 0.0;
    }
    float _e17 = blend_node_w(0u);
    w_4 = _e17;
    bool loop_init_14 = true;
    while(true) {
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
            float _e26 = blend_node_r((_e23 - 1u));
            if ((r_8 > _e26)) {
                uint _e29 = k_11;
                float _e30 = blend_node_r(_e29);
                float t_16 = min(max(((r_8 - _e26) / (_e30 - _e26)), 0.0), 1.0);
                uint _e37 = k_11;
                float _e40 = blend_node_w((_e37 - 1u));
                uint _e44 = k_11;
                float _e45 = blend_node_w(_e44);
                w_4 = ((_e40 * (1.0 - t_16)) + (_e45 * t_16));
            }
        }
    }
    float _e51 = w_4;
    return min(max(_e51, 0.0), 1.0);
}

vec3 clean(vec3 c_8) {
    bool _e1 = finite3_(c_8);
    if (_e1) {
        return max(c_8, vec3(0.0));
    }
    return vec3(0.0);
}

vec3 specular(vec3 position, vec3 direction, float roughness) {
    vec3 b_19 = vec3(0.0);
    float r_9 = 0.0;
    uvec3 home_at_2 = uvec3(0u);
    bool stored = false;
    bool local_31 = false;
    vec3 c_9 = vec3(0.0);
    vec4 _e3 = unit_direction(direction);
    if ((_e3.w == 0.0)) {
        return vec3(0.0);
    }
    vec4 _e11 = _group_0_binding_7_fs.probe;
    b_19 = _e11.xyz;
    bool _e14 = finite3_(position);
    if (_e14) {
        b_19 = position;
    }
    bool _e17 = finite(roughness);
    if (_e17) {
        r_9 = clamp(roughness, 0.0, 1.0);
    }
    float _e21 = r_9;
    float _e22 = irradiance_weight(_e21);
    uint _e23 = blend_mode();
    if ((_e23 == 2u)) {
        vec3 _e26 = b_19;
        Near _e27 = near_cells(_e26);
        if ((_e27.count > 1u)) {
            vec3 _e31 = b_19;
            float _e33 = r_9;
            vec3 _e34 = faces_specular(_e27, _e31, _e3.xyz, _e33, _e22);
            vec3 _e35 = clean(_e34);
            return _e35;
        }
    }
    if ((_e22 > 0.0)) {
        vec3 _e43 = b_19;
        vec3 _e44 = cell_size();
        uvec3 _e45 = cell_of(_e43, _e44);
        home_at_2 = _e45;
        uvec3 _e47 = home_at_2;
        uint _e48 = cell_index(_e47);
        int _e52 = _group_0_binding_8_fs[_e48].tiles.y;
        stored = (_e52 >= 0);
    }
    bool _e55 = stored;
    if (_e55) {
        local_31 = (_e22 >= 1.0);
    } else {
        local_31 = false;
    }
    bool _e61 = local_31;
    if (_e61) {
        uvec3 _e62 = home_at_2;
        vec3 _e63 = b_19;
        vec3 _e65 = sh_read(_e62, _e63, _e3.xyz);
        vec3 _e69 = clean((_e65 * (_e22 * 0.31830987)));
        return _e69;
    }
    vec3 _e70 = b_19;
    vec3 _e71 = b_19;
    float _e73 = r_9;
    Aim _e74 = fetch(_e71, _e3.xyz, _e73);
    float _e75 = r_9;
    vec3 _e76 = shade(_e70, _e74, _e75);
    c_9 = _e76;
    bool _e78 = stored;
    if (_e78) {
        vec3 _e79 = c_9;
        uvec3 _e83 = home_at_2;
        vec3 _e84 = b_19;
        vec3 _e86 = sh_read(_e83, _e84, _e3.xyz);
        c_9 = ((_e79 * (1.0 - _e22)) + (_e86 * (_e22 * 0.31830987)));
    }
    vec3 _e91 = c_9;
    vec3 _e92 = clean(_e91);
    return _e92;
}

vec3 cell_irradiance(int tile_3, vec3 n_9) {
    uint _e6 = _group_0_binding_7_fs.atlas_a.z;
    uint _e10 = _group_0_binding_7_fs.atlas_a.w;
    vec2 _e11 = oct_encode(n_9);
    vec4 _e12 = atlas_bilinear(ATLAS_IRRADIANCE, tile_3, _e6, _e10, _e11);
    return _e12.xyz;
}

vec3 irradiance(vec3 position_1, vec3 normal) {
    vec3 p_9 = vec3(0.0);
    vec3 e_1 = vec3(0.0);
    float wsum = 0.0;
    uint corner_8 = 0u;
    float w_5 = 0.0;
    bool local_32 = false;
    float k_12 = 0.0;
    vec4 _e2 = unit_direction(normal);
    if ((_e2.w == 0.0)) {
        return vec3(0.0);
    }
    vec3 n_18 = _e2.xyz;
    vec3 _e9 = cell_size();
    vec4 _e12 = _group_0_binding_7_fs.grid_min;
    vec4 _e16 = _group_0_binding_7_fs.grid_max;
    vec4 _e20 = _group_0_binding_7_fs.grid_min;
    p_9 = (_e12.xyz + ((_e16.xyz - _e20.xyz) * 0.5));
    float _e30 = _group_0_binding_7_fs.grid_min.w;
    vec3 biased = (position_1 + (n_18 * _e30));
    bool _e33 = finite3_(biased);
    if (_e33) {
        p_9 = biased;
    }
    vec3 _e34 = p_9;
    Lattice _e35 = lattice(_e34, _e9);
    vec2 _e36 = oct_encode(n_18);
    bool loop_init_15 = true;
    while(true) {
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
            float _e48 = corner_weight(_e35, _e47);
            if ((_e48 <= 0.0)) {
                continue;
            }
            uint _e51 = corner_8;
            uvec3 _e52 = corner_cell(_e35, _e51);
            uint _e53 = cell_index(_e52);
            ivec4 tiles_4 = _group_0_binding_8_fs[_e53].tiles;
            if ((tiles_4.y < 0)) {
                continue;
            }
            vec3 _e61 = p_9;
            vec3 _e62 = cell_centre(_e52, _e9);
            vec4 _e66 = _group_0_binding_8_fs[_e53].offset;
            vec3 to_point = (_e61 - (_e62 + _e66.xyz));
            float dist = length(to_point);
            w_5 = _e48;
            if ((dist > 0.0)) {
                bool _e76 = finite(dist);
                local_32 = _e76;
            } else {
                local_32 = false;
            }
            bool _e78 = local_32;
            if (_e78) {
                vec3 u_1 = (to_point / vec3(dist));
                float facing = ((dot(n_18, -(u_1)) + 1.0) * 0.5);
                float _e87 = w_5;
                w_5 = (_e87 * ((facing * facing) + 0.2));
                uint _e97 = _group_0_binding_7_fs.atlas_b.x;
                uint _e101 = _group_0_binding_7_fs.atlas_b.y;
                vec2 _e102 = oct_encode(u_1);
                vec4 _e103 = atlas_bilinear(ATLAS_MOMENTS, tiles_4.y, _e97, _e101, _e102);
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
            if ((tiles_4.z >= 0)) {
                uint _e138 = _group_0_binding_7_fs.atlas_b.z;
                uint _e142 = _group_0_binding_7_fs.atlas_b.w;
                vec4 _e143 = atlas_bilinear(ATLAS_SCALE, tiles_4.z, _e138, _e142, _e36);
                k_12 = _e143.x;
            }
            vec3 _e145 = e_1;
            vec3 _e147 = cell_irradiance(tiles_4.y, n_18);
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
        return vec3(0.0);
    }
    vec3 _e165 = e_1;
    float _e166 = wsum;
    vec3 _e169 = clean((_e165 / vec3(_e166)));
    return _e169;
}

vec2 hemi_encode(vec3 v_9) {
    bool local_33 = false;
    float z_1 = max(v_9.z, 0.0);
    float l1_1 = ((abs(v_9.x) + abs(v_9.y)) + z_1);
    if ((l1_1 >= F32_MIN_POSITIVE)) {
        bool _e14 = finite(l1_1);
        local_33 = _e14;
    } else {
        local_33 = false;
    }
    bool _e16 = local_33;
    if (!(_e16)) {
        return vec2(0.5, 0.5);
    }
    float px = (v_9.x / l1_1);
    float py = (v_9.y / l1_1);
    return clamp(vec2((((px + py) * 0.5) + 0.5), (((px - py) * 0.5) + 0.5)), vec2(0.0), vec2(1.0));
}

SurfaceAxis surface_axis(float x_in, uint n_10) {
    float x_4 = 0.5;
    bool _e4 = finite(x_in);
    if (_e4) {
        x_4 = x_in;
    }
    float _e5 = x_4;
    float c_13 = clamp(((_e5 * float(n_10)) - 0.5), 0.0, float((n_10 - 1u)));
    uint i0_ = uint(floor(c_13));
    return SurfaceAxis(i0_, min((i0_ + 1u), (n_10 - 1u)), (c_13 - float(i0_)));
}

float offset_off_surface(vec3 p_10) {
    vec4 _e3 = _group_3_binding_0_fs.surface_offset;
    float _e9 = _group_3_binding_0_fs.surface_offset.w;
    vec3 pn = abs(((p_10 - _e3.xyz) * _e9));
    float _e24 = _group_3_binding_0_fs.surface_offset.w;
    return (((max(pn.x, max(pn.y, pn.z)) + 1.0) * 2e-5) / _e24);
}

void main() {
    SurfaceVarying v_3 = SurfaceVarying(gl_FragCoord, _vs2fs_location0, _vs2fs_location1, _vs2fs_location2, _vs2fs_location3, _vs2fs_location4);
    SurfaceOut out_1 = SurfaceOut(vec4(0.0), vec4(0.0), 0.0);
    vec3 p = vec3(0.0);
    vec3 n = vec3(0.0);
    float t = 0.0;
    bool local = false;
    vec3 dir = vec3(0.0);
    float r = 0.0;
    out_1.depth = v_3.clip.z;
    vec4 _e7 = _group_3_binding_0_fs.eye;
    vec3 eye = _e7.xyz;
    vec3 ray = normalize((v_3.world - eye));
    p = v_3.world;
    n = v_3.normal;
    if ((v_3.sphere.w != 0.0)) {
        vec3 oc = (eye - v_3.sphere.xyz);
        float half_b = dot(oc, ray);
        float c_14 = (dot(oc, oc) - (v_3.sphere.w * v_3.sphere.w));
        float disc = ((half_b * half_b) - c_14);
        if ((disc < 0.0)) {
            discard;
        }
        float s_6 = sqrt(disc);
        t = (-(half_b) - s_6);
        float _e39 = t;
        if ((_e39 <= 0.0)) {
            t = (-(half_b) + s_6);
        }
        float _e44 = t;
        if ((_e44 <= 0.0)) {
            discard;
        }
        float _e47 = t;
        p = (eye + (ray * _e47));
        vec3 _e50 = p;
        n = normalize((_e50 - v_3.sphere.xyz));
        if ((v_3.sphere.w < 0.0)) {
            vec3 _e59 = n;
            n = -(_e59);
        }
        mat4x4 _e63 = _group_3_binding_0_fs.view_proj;
        vec3 _e64 = p;
        vec4 clip = (_e63 * vec4(_e64, 1.0));
        out_1.depth = clamp((clip.z / clip.w), 0.0, 1.0);
    }
    vec3 _e75 = n;
    bool back = (dot(_e75, ray) > 0.0);
    if (back) {
        local = ((uint(v_3.flags) & 1u) == 0u);
    } else {
        local = false;
    }
    bool _e88 = local;
    if (_e88) {
        out_1.radiance = vec4(0.0, 0.0, 0.0, 1.0);
        vec3 _e96 = p;
        out_1.query_point = vec4(_e96, 0.0);
        SurfaceOut _e99 = out_1;
        _fs2p_location0 = _e99.radiance;
        _fs2p_location1 = _e99.query_point;
        gl_FragDepth = _e99.depth;
        return;
    }
    if (back) {
        vec3 _e100 = n;
        n = -(_e100);
    }
    vec3 _e102 = p;
    vec3 _e103 = n;
    vec3 _e104 = p;
    float _e105 = offset_off_surface(_e104);
    vec3 b_26 = (_e102 + (_e103 * _e105));
    out_1.query_point = vec4(b_26, 1.0);
    vec3 _e111 = n;
    dir = _e111;
    float _e118 = _group_3_binding_0_fs.shading.y;
    if ((_e118 == 1.0)) {
        vec3 _e122 = n;
        vec3 _e123 = irradiance(b_26, _e122);
        out_1.radiance = vec4(((_e123 * v_3.albedo) * 0.31830987), 1.0);
    } else {
        vec3 _e130 = n;
        vec3 _e134 = n;
        dir = normalize((ray - ((2.0 * dot(ray, _e130)) * _e134)));
        float _e141 = _group_3_binding_0_fs.shading.x;
        r = _e141;
        vec3 _e143 = dir;
        float _e144 = r;
        vec3 _e145 = specular(b_26, _e143, _e144);
        out_1.radiance = vec4(_e145, 1.0);
    }
    float _e151 = _group_3_binding_0_fs.shading.z;
    if ((_e151 == 1.0)) {
        vec3 _e155 = dir;
        float _e156 = r;
        out_1.radiance = vec4(_e155, _e156);
    }
    SurfaceOut _e158 = out_1;
    _fs2p_location0 = _e158.radiance;
    _fs2p_location1 = _e158.query_point;
    gl_FragDepth = _e158.depth;
    return;
}

