// The image environment light: src/math/envmap.rs, same functions and
// convention. Included by geometry.glsl and probe_env.comp.
#ifndef RLPT_ENVMAP_GLSL
#define RLPT_ENVMAP_GLSL
#include "scene.glsl"
#include "sampling.glsl"

// The map's convention:
// row v = 0 is +y, the image centre (u = 0.5) is -z, u grows towards +x, in the
// map's frame, which params.env_frame turns against the world's. Nearest texel lookup.

// src/math/envmap.rs `env_to_map` and `env_to_world`: between the world's
// directions and the map's frame (params.env_frame, the rows of the rotation).
vec3 env_to_map(vec3 d) {
    return vec3(dot(params.env_frame[0].xyz, d), dot(params.env_frame[1].xyz, d), dot(params.env_frame[2].xyz, d));
}
vec3 env_to_world(vec3 l) {
    return l.x * params.env_frame[0].xyz + l.y * params.env_frame[1].xyz + l.z * params.env_frame[2].xyz;
}

// src/math/envmap.rs `env_find`: the first i of n with u < cdf[base + i + 1], and
// u's place within that interval in t.
uint env_find(uint base, uint n, float u, out float t) {
    uint lo = 0u, hi = n - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (u < env_cdf[base + mid + 1u]) hi = mid; else lo = mid + 1u;
    }
    float a = env_cdf[base + lo], b = env_cdf[base + lo + 1u];
    t = b > a ? clamp((u - a) / (b - a), 0.0, 0.99999994) : 0.5;
    return lo;
}

// src/math/envmap.rs `env_sample`: a world direction from the map's distribution,
// its radiance and solid-angle density (without the light's choice).
bool env_sample(vec2 u, out vec3 wi, out vec3 le, out float pdf) {
    uint w = params.env_width, h = params.env_height;
    float ty, tx;
    uint y = env_find(0u, h, u.y, ty);
    uint x = env_find(h + 1u + y * (w + 1u), w, u.x, tx);
    float uu = (float(x) + tx) / float(w), vv = (float(y) + ty) / float(h);
    vec4 t = env_texels[y * w + x];
    float theta = PI * vv, phi = 2.0 * PI * (uu - 0.5);
    float s = sin(theta);
    pdf = t.w / (2.0 * PI * PI * s);
    le = t.xyz;
    wi = normalize(env_to_world(vec3(s * sin(phi), cos(theta), -s * cos(phi))));
    return pdf > 0.0 && !isinf(pdf);
}

// src/math/envmap.rs `env_lookup`: the radiance seen along d and the density of
// env_sample for d.
vec3 env_lookup(vec3 d, out float pdf) {
    uint w = params.env_width, h = params.env_height;
    vec3 l = env_to_map(d);
    float u = atan(l.x, -l.z) / (2.0 * PI) + 0.5;
    float v = acos(clamp(l.y, -1.0, 1.0)) / PI;
    uint x = min(uint(u * float(w)), w - 1u);
    uint y = min(uint(v * float(h)), h - 1u);
    vec4 t = env_texels[y * w + x];
    // sin(theta) from the direction itself: acos near the poles loses it.
    float s = length(l.xz);
    pdf = s > 0.0 ? t.w / (2.0 * PI * PI * s) : 0.0;
    return t.xyz;
}

#endif
