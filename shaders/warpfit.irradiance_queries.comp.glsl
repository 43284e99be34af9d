#version 450 core
#extension GL_ARB_compute_shader : require
#extension GL_ARB_shader_storage_buffer_object : require
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

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

layout(binding = 2) uniform sampler2D _group_0_binding_2_cs;

layout(binding = 3) uniform sampler2D _group_0_binding_3_cs;

layout(binding = 4) uniform sampler2D _group_0_binding_4_cs;

layout(binding = 5) uniform sampler2D _group_0_binding_5_cs;

layout(std140, binding = 0) uniform Params_block_0Compute { Params _group_0_binding_7_cs; };

layout(std430, binding = 0) readonly buffer type_12_block_1Compute { Cell _group_0_binding_8_cs[]; };

layout(std430, binding = 1) readonly buffer type_24_block_2Compute { vec4 _group_1_binding_0_cs[]; };

layout(std430, binding = 2) buffer type_24_block_3Compute { vec4 _group_1_binding_1_cs[]; };


uint fallback_method() {
    if (true) {
        uint _e8 = _group_0_binding_7_cs.probe_info.z;
        return _e8;
    }
    return FALLBACK;
}

uint blend_mode() {
    if (true) {
        uint _e8 = _group_0_binding_7_cs.grid_counts.w;
        return _e8;
    }
    return BLEND;
}

bool relaxation_on() {
    if (true) {
        float _e8 = _group_0_binding_7_cs.warp.x;
        return (_e8 > 0.0);
    }
    return false;
}

bool roughness_corrected() {
    if (true) {
        uint _e8 = _group_0_binding_7_cs.probe_info.w;
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

vec4 atlas_texel(uint which_3, ivec2 t_3) {
    switch(which_3) {
        case 0u: {
            vec4 _e4 = texelFetch(_group_0_binding_2_cs, t_3, 0);
            return _e4;
        }
        case 1u: {
            vec4 _e7 = texelFetch(_group_0_binding_3_cs, t_3, 0);
            return _e7;
        }
        case 2u: {
            vec4 _e10 = texelFetch(_group_0_binding_4_cs, t_3, 0);
            return _e10;
        }
        default: {
            vec4 _e13 = texelFetch(_group_0_binding_5_cs, t_3, 0);
            return _e13;
        }
    }
}

vec4 atlas_bilinear(uint which_4, int tile, uint n_3, uint columns, vec2 uv_4) {
    uint s_3 = uint(tile);
    ivec2 origin = ivec2((uvec2((s_3 % columns), (s_3 / columns)) * (n_3 + 2u)));
    Footprint _e13 = footprint(n_3, uv_4);
    ivec2 c_10 = ((origin + _e13.corner) + ivec2(1, 1));
    vec4 _e20 = atlas_texel(which_4, c_10);
    vec4 _e25 = atlas_texel(which_4, (c_10 + ivec2(1, 0)));
    vec4 _e30 = atlas_texel(which_4, (c_10 + ivec2(0, 1)));
    vec4 _e35 = atlas_texel(which_4, (c_10 + ivec2(1, 1)));
    vec4 _e37 = blend4_(_e20, _e25, _e30, _e35, _e13.f);
    return _e37;
}

vec3 cell_size() {
    vec4 _e2 = _group_0_binding_7_cs.grid_max;
    vec4 _e6 = _group_0_binding_7_cs.grid_min;
    uvec4 _e11 = _group_0_binding_7_cs.grid_counts;
    return ((_e2.xyz - _e6.xyz) / vec3(_e11.xyz));
}

uint cell_index(uvec3 c_2) {
    uvec4 n_11 = _group_0_binding_7_cs.grid_counts;
    return (c_2.x + (n_11.x * (c_2.y + (n_11.y * c_2.z))));
}

uvec3 cell_of(vec3 p_5, vec3 size) {
    vec4 _e4 = _group_0_binding_7_cs.grid_min;
    vec3 f_3 = floor(((p_5 - _e4.xyz) / size));
    uvec4 _e11 = _group_0_binding_7_cs.grid_counts;
    vec3 hi = vec3((_e11.xyz - uvec3(1u)));
    bool _e17 = finite3_(f_3);
    if (!(_e17)) {
        return uvec3(0u);
    }
    return uvec3(clamp(f_3, vec3(0.0), hi));
}

vec3 cell_centre(uvec3 c_3, vec3 size_1) {
    vec4 _e4 = _group_0_binding_7_cs.grid_min;
    return (_e4.xyz + ((vec3(c_3) + vec3(0.5)) * size_1));
}

Lattice lattice(vec3 p_6, vec3 size_2) {
    vec3 f_1 = vec3(0.0);
    vec4 _e4 = _group_0_binding_7_cs.grid_min;
    f_1 = (((p_6 - _e4.xyz) / size_2) - vec3(0.5));
    uvec4 _e14 = _group_0_binding_7_cs.grid_counts;
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
    uvec4 _e17 = _group_0_binding_7_cs.grid_counts;
    return min((l_1.base + o_1), (_e17.xyz - uvec3(1u)));
}

vec2 box_exit(vec3 b_4, vec3 dir_3) {
    float t_4 = HUGE;
    int k = 0;
    vec4 _e4 = _group_0_binding_7_cs.box_x;
    vec4 _e8 = _group_0_binding_7_cs.box_y;
    vec4 _e12 = _group_0_binding_7_cs.box_z;
    mat3x3 m_2 = mat3x3(_e4.xyz, _e8.xyz, _e12.xyz);
    vec4 _e17 = _group_0_binding_7_cs.box_half;
    vec3 h = _e17.xyz;
    vec4 _e21 = _group_0_binding_7_cs.box_centre;
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
            uint _e12 = _group_0_binding_7_cs.kdop_open.x;
            uint _e14 = k_1;
            if (((_e12 & (1u << _e14)) != 0u)) {
                continue;
            }
            uint _e21 = k_1;
            vec4 _e23 = _group_0_binding_7_cs.kdop[_e21];
            vec3 n_12 = _e23.xyz;
            uint _e27 = k_1;
            float h_1 = _group_0_binding_7_cs.kdop[_e27].w;
            float nb = dot(n_12, b_5);
            if ((nb > h_1)) {
                return vec2(0.0, 0.0);
            }
            float nd = dot(n_12, dir_4);
            if ((nd > 0.0)) {
                float _e39 = t_5;
                t_5 = min(_e39, ((h_1 - nb) / nd));
            }
        }
    }
    float _e46 = t_5;
    return vec2(_e46, 1.0);
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
    vec4 _e17 = _group_0_binding_7_cs.probe;
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
    float a_1 = (-1.0 / (s_4 + n_4.z));
    float b_24 = ((n_4.x * n_4.y) * a_1);
    return Basis(vec3((1.0 + (((s_4 * n_4.x) * n_4.x) * a_1)), (s_4 * b_24), (-(s_4) * n_4.x)), vec3(b_24, (s_4 + ((n_4.y * n_4.y) * a_1)), -(n_4.y)));
}

vec3 normalize_or(vec3 v_7, vec3 fallback_1) {
    bool local_13 = false;
    float l_4 = length(v_7);
    if ((l_4 > 0.0)) {
        bool _e7 = finite(l_4);
        local_13 = _e7;
    } else {
        local_13 = false;
    }
    bool _e9 = local_13;
    if (_e9) {
        return (v_7 / vec3(l_4));
    }
    return fallback_1;
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
    vec4 _e33 = _group_0_binding_7_cs.probes[p_7];
    vec3 v_11 = ((b_10 + (dir_9 * _e27)) - _e33.xyz);
    bool _e36 = finite3_(v_11);
    if (_e36) {
        local_15 = any(notEqual(v_11, vec3(0.0)));
    } else {
        local_15 = false;
    }
    bool _e44 = local_15;
    if (_e44) {
        float _e46 = s_1;
        k_2 = (length(v_11) / _e46);
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
        return Aim(v_11, _e60, p_7);
    }
    return Aim(dir_9, 1.0, p_7);
}

uint probe_of(int tile_1, uint unmapped, vec2 uv_5) {
    uint best = 0u;
    uint k_3 = 1u;
    if ((tile_1 < 0)) {
        uint _e8 = _group_0_binding_7_cs.probe_maps.x;
        return min(unmapped, (max(_e8, 1u) - 1u));
    }
    uint _e17 = _group_0_binding_7_cs.probe_maps.y;
    if ((_e17 == 0u)) {
        return 0u;
    }
    uint n_13 = _group_0_binding_7_cs.atlas_a.x;
    uint columns_1 = _group_0_binding_7_cs.atlas_a.y;
    uint _e33 = _group_0_binding_7_cs.probe_maps.y;
    uint s_5 = (uint(tile_1) + _e33);
    ivec2 origin_1 = ivec2((uvec2((s_5 % columns_1), (s_5 / columns_1)) * (n_13 + 2u)));
    Footprint _e42 = footprint(n_13, uv_5);
    vec2 f_4 = _e42.f;
    vec4 w_6 = vec4(((1.0 - f_4.x) * (1.0 - f_4.y)), (f_4.x * (1.0 - f_4.y)), ((1.0 - f_4.x) * f_4.y), (f_4.x * f_4.y));
    bool loop_init_2 = true;
    while(true) {
        if (!loop_init_2) {
            uint _e79 = k_3;
            k_3 = (_e79 + 1u);
        }
        loop_init_2 = false;
        uint _e69 = k_3;
        if ((_e69 < 4u)) {
        } else {
            break;
        }
        {
            uint _e72 = k_3;
            uint _e74 = best;
            if ((w_6[_e72] > w_6[_e74])) {
                uint _e77 = k_3;
                best = _e77;
            }
        }
    }
    uint _e87 = best;
    uint _e91 = best;
    ivec2 t_10 = (((origin_1 + _e42.corner) + ivec2(1, 1)) + ivec2(int((_e87 & 1u)), int((_e91 >> 1u))));
    vec4 _e98 = atlas_texel(ATLAS_CORRECTIVE, t_10);
    uint p_11 = uint(_e98.x);
    uint _e104 = _group_0_binding_7_cs.probe_maps.x;
    return min(p_11, (max(_e104, 1u) - 1u));
}

float map_delta(int tile_2, vec2 uv_6) {
    uint _e6 = _group_0_binding_7_cs.atlas_a.x;
    uint _e10 = _group_0_binding_7_cs.atlas_a.y;
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
    float _e9 = _group_0_binding_7_cs.mip_roughness[(m / 4u)][(m % 4u)];
    return _e9;
}

float lod_of_roughness(float r_3) {
    bool local_19 = false;
    uint below = 0u;
    uint t_6 = 0u;
    float f_2 = 0.0;
    uint n_14 = _group_0_binding_7_cs.probe_info.x;
    if (!((n_14 < 2u))) {
        float _e11 = mip_roughness(0u);
        local_19 = !((r_3 > _e11));
    } else {
        local_19 = true;
    }
    bool _e15 = local_19;
    if (_e15) {
        return 0.0;
    }
    uint last = (n_14 - 1u);
    float _e19 = mip_roughness(last);
    if ((r_3 >= _e19)) {
        return float(last);
    }
    bool loop_init_3 = true;
    while(true) {
        if (!loop_init_3) {
            uint _e37 = t_6;
            t_6 = (_e37 + 1u);
        }
        loop_init_3 = false;
        uint _e26 = t_6;
        if ((_e26 < n_14)) {
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

float pseudo_log2_(float k_4) {
    uint bits_1 = floatBitsToUint(k_4);
    int e_2 = (int(((bits_1 >> 23u) & 255u)) - 127);
    float m_3 = uintBitsToFloat(((bits_1 & 8388607u) | 1065353216u));
    return (float(e_2) + (m_3 - 1.0));
}

Near near_cells(vec3 b_16) {
    uint count = 0u;
    float sum_1 = 0.0;
    uint corner_6 = 0u;
    Lattice _e1 = face_lattice(b_16);
    vec3 _e2 = cell_size();
    uvec3 _e3 = cell_of(b_16, _e2);
    uint _e5 = cell_index(_e3);
    uint links_1 = _group_0_binding_8_cs[_e5].links.x;
    bool loop_init_4 = true;
    while(true) {
        if (!loop_init_4) {
            uint _e29 = corner_6;
            corner_6 = (_e29 + 1u);
        }
        loop_init_4 = false;
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
    vec4 _e6 = _group_0_binding_8_cs[cell].sh[0];
    vec4 _e12 = _group_0_binding_8_cs[cell].sh[1];
    vec4 _e18 = _group_0_binding_8_cs[cell].sh[2];
    vec4 _e24 = _group_0_binding_8_cs[cell].sh[3];
    vec4 _e30 = _group_0_binding_8_cs[cell].sh[4];
    vec4 _e36 = _group_0_binding_8_cs[cell].sh[5];
    vec4 _e42 = _group_0_binding_8_cs[cell].sh[6];
    vec4 _e48 = _group_0_binding_8_cs[cell].sh[7];
    vec4 _e54 = _group_0_binding_8_cs[cell].sh[8];
    vec3 c_11[9] = vec3[9](_e6.xyz, _e12.xyz, _e18.xyz, _e24.xyz, _e30.xyz, _e36.xyz, _e42.xyz, _e48.xyz, _e54.xyz);
    vec3 _e57 = sh_eval(c_11, n_7);
    return _e57;
}

vec3 sh_blend4_(uvec4 at_1, vec4 w_1, uint i_1) {
    vec4 _e8 = _group_0_binding_8_cs[at_1.x].sh[i_1];
    vec4 _e17 = _group_0_binding_8_cs[at_1.y].sh[i_1];
    vec4 _e27 = _group_0_binding_8_cs[at_1.z].sh[i_1];
    vec4 _e36 = _group_0_binding_8_cs[at_1.w].sh[i_1];
    return (((_e8.xyz * w_1.x) + (_e17.xyz * w_1.y)) + ((_e27.xyz * w_1.z) + (_e36.xyz * w_1.w)));
}

float blend_node_r(uint k_9) {
    float _e9 = _group_0_binding_7_cs.blend_r[(k_9 / 4u)][(k_9 % 4u)];
    return _e9;
}

float blend_node_w(uint k_10) {
    float _e9 = _group_0_binding_7_cs.blend_w[(k_10 / 4u)][(k_10 % 4u)];
    return _e9;
}

float irradiance_weight(float r_8) {
    bool local_30 = false;
    float w_4 = 0.0;
    uint k_11 = 1u;
    uint n_15 = _group_0_binding_7_cs.lut_info.y;
    if (!((n_15 == 0u))) {
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
    bool loop_init_5 = true;
    while(true) {
        if (!loop_init_5) {
            uint _e49 = k_11;
            k_11 = (_e49 + 1u);
        }
        loop_init_5 = false;
        uint _e21 = k_11;
        if ((_e21 < n_15)) {
        } else {
            break;
        }
        {
            uint _e23 = k_11;
            float _e26 = blend_node_r((_e23 - 1u));
            if ((r_8 > _e26)) {
                uint _e29 = k_11;
                float _e30 = blend_node_r(_e29);
                float t_11 = min(max(((r_8 - _e26) / (_e30 - _e26)), 0.0), 1.0);
                uint _e37 = k_11;
                float _e40 = blend_node_w((_e37 - 1u));
                uint _e44 = k_11;
                float _e45 = blend_node_w(_e44);
                w_4 = ((_e40 * (1.0 - t_11)) + (_e45 * t_11));
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

vec3 cell_irradiance(int tile_3, vec3 n_9) {
    uint _e6 = _group_0_binding_7_cs.atlas_a.z;
    uint _e10 = _group_0_binding_7_cs.atlas_a.w;
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
    vec3 n_16 = _e2.xyz;
    vec3 _e9 = cell_size();
    vec4 _e12 = _group_0_binding_7_cs.grid_min;
    vec4 _e16 = _group_0_binding_7_cs.grid_max;
    vec4 _e20 = _group_0_binding_7_cs.grid_min;
    p_9 = (_e12.xyz + ((_e16.xyz - _e20.xyz) * 0.5));
    float _e30 = _group_0_binding_7_cs.grid_min.w;
    vec3 biased = (position_1 + (n_16 * _e30));
    bool _e33 = finite3_(biased);
    if (_e33) {
        p_9 = biased;
    }
    vec3 _e34 = p_9;
    Lattice _e35 = lattice(_e34, _e9);
    vec2 _e36 = oct_encode(n_16);
    bool loop_init_6 = true;
    while(true) {
        if (!loop_init_6) {
            uint _e157 = corner_8;
            corner_8 = (_e157 + 1u);
        }
        loop_init_6 = false;
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
            ivec4 tiles_1 = _group_0_binding_8_cs[_e53].tiles;
            if ((tiles_1.y < 0)) {
                continue;
            }
            vec3 _e61 = p_9;
            vec3 _e62 = cell_centre(_e52, _e9);
            vec4 _e66 = _group_0_binding_8_cs[_e53].offset;
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
                vec3 u = (to_point / vec3(dist));
                float facing = ((dot(n_16, -(u)) + 1.0) * 0.5);
                float _e87 = w_5;
                w_5 = (_e87 * ((facing * facing) + 0.2));
                uint _e97 = _group_0_binding_7_cs.atlas_b.x;
                uint _e101 = _group_0_binding_7_cs.atlas_b.y;
                vec2 _e102 = oct_encode(u);
                vec4 _e103 = atlas_bilinear(ATLAS_MOMENTS, tiles_1.y, _e97, _e101, _e102);
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
            if ((tiles_1.z >= 0)) {
                uint _e138 = _group_0_binding_7_cs.atlas_b.z;
                uint _e142 = _group_0_binding_7_cs.atlas_b.w;
                vec4 _e143 = atlas_bilinear(ATLAS_SCALE, tiles_1.z, _e138, _e142, _e36);
                k_12 = _e143.x;
            }
            vec3 _e145 = e_1;
            vec3 _e147 = cell_irradiance(tiles_1.y, n_16);
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
    float c_12 = clamp(((_e5 * float(n_10)) - 0.5), 0.0, float((n_10 - 1u)));
    uint i0_ = uint(floor(c_12));
    return SurfaceAxis(i0_, min((i0_ + 1u), (n_10 - 1u)), (c_12 - float(i0_)));
}

uint query_count() {
    return uint(_group_1_binding_1_cs.length());
}

void main() {
    uvec3 id_1 = gl_GlobalInvocationID;
    uint k_13 = id_1.x;
    uint _e2 = query_count();
    if ((k_13 >= _e2)) {
        return;
    }
    vec4 p_12 = _group_1_binding_0_cs[(2u * k_13)];
    vec4 n_17 = _group_1_binding_0_cs[((2u * k_13) + 1u)];
    vec3 _e20 = irradiance(p_12.xyz, n_17.xyz);
    _group_1_binding_1_cs[k_13] = vec4(_e20, 1.0);
    return;
}

