#version 450 core
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

layout(std140, binding = 2) uniform CameraParams_block_0Vertex { CameraParams _group_3_binding_0_vs; };

layout(location = 0) in vec3 _p2vs_location0;
layout(location = 1) in vec3 _p2vs_location1;
layout(location = 2) in vec3 _p2vs_location2;
layout(location = 3) in float _p2vs_location3;
layout(location = 4) in vec4 _p2vs_location4;
layout(location = 0) smooth out vec3 _vs2fs_location0;
layout(location = 1) flat out vec3 _vs2fs_location1;
layout(location = 2) flat out vec3 _vs2fs_location2;
layout(location = 3) flat out float _vs2fs_location3;
layout(location = 4) flat out vec4 _vs2fs_location4;

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

float corner_weight(Lattice l, uint corner) {
    uvec3 o = uvec3((corner & 1u), ((corner >> 1u) & 1u), ((corner >> 2u) & 1u));
    float wx = ((o.x == 1u) ? l.frac.x : (1.0 - l.frac.x));
    float wy = ((o.y == 1u) ? l.frac.y : (1.0 - l.frac.y));
    float wz = ((o.z == 1u) ? l.frac.z : (1.0 - l.frac.z));
    return ((wx * wy) * wz);
}

Basis orthonormal_basis(vec3 n_4) {
    float s_3 = ((n_4.z >= 0.0) ? 1.0 : -1.0);
    float a_1 = (-1.0 / (s_3 + n_4.z));
    float b_24 = ((n_4.x * n_4.y) * a_1);
    return Basis(vec3((1.0 + (((s_3 * n_4.x) * n_4.x) * a_1)), (s_3 * b_24), (-(s_3) * n_4.x)), vec3(b_24, (s_3 + ((n_4.y * n_4.y) * a_1)), -(n_4.y)));
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

float face_ramp(float x_2) {
    return clamp(((x_2 - 0.375) / 0.25), 0.0, 1.0);
}

float pseudo_log2_(float k_4) {
    uint bits_1 = floatBitsToUint(k_4);
    int e_2 = (int(((bits_1 >> 23u) & 255u)) - 127);
    float m_2 = uintBitsToFloat(((bits_1 & 8388607u) | 1065353216u));
    return (float(e_2) + (m_2 - 1.0));
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

vec3 clean(vec3 c_8) {
    bool _e1 = finite3_(c_8);
    if (_e1) {
        return max(c_8, vec3(0.0));
    }
    return vec3(0.0);
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
    float c_10 = clamp(((_e5 * float(n_10)) - 0.5), 0.0, float((n_10 - 1u)));
    uint i0_ = uint(floor(c_10));
    return SurfaceAxis(i0_, min((i0_ + 1u), (n_10 - 1u)), (c_10 - float(i0_)));
}

float offset_off_surface(vec3 p_10) {
    vec4 _e3 = _group_3_binding_0_vs.surface_offset;
    float _e9 = _group_3_binding_0_vs.surface_offset.w;
    vec3 pn = abs(((p_10 - _e3.xyz) * _e9));
    float _e24 = _group_3_binding_0_vs.surface_offset.w;
    return (((max(pn.x, max(pn.y, pn.z)) + 1.0) * 2e-5) / _e24);
}

void main() {
    SurfaceVertex v_2 = SurfaceVertex(_p2vs_location0, _p2vs_location1, _p2vs_location2, _p2vs_location3, _p2vs_location4);
    SurfaceVarying out_ = SurfaceVarying(vec4(0.0), vec3(0.0), vec3(0.0), vec3(0.0), 0.0, vec4(0.0));
    mat4x4 _e5 = _group_3_binding_0_vs.view_proj;
    out_.clip = (_e5 * vec4(v_2.position, 1.0));
    out_.world = v_2.position;
    out_.normal = v_2.normal;
    out_.albedo = v_2.albedo;
    out_.flags = v_2.flags;
    out_.sphere = v_2.sphere;
    SurfaceVarying _e20 = out_;
    gl_Position = _e20.clip;
    _vs2fs_location0 = _e20.world;
    _vs2fs_location1 = _e20.normal;
    _vs2fs_location2 = _e20.albedo;
    _vs2fs_location3 = _e20.flags;
    _vs2fs_location4 = _e20.sphere;
    gl_Position.yz = vec2(-gl_Position.y, gl_Position.z * 2.0 - gl_Position.w);
    return;
}

