// Image textures: the UVs of a hit and the bilinear lookup of a texture's
// texels; src/math/texture.rs, same functions. Repeat wrap, v up (row 0 of the
// image at v = 1), texel centres at half-integers (docs/SCENE_FORMAT.md).
// Included by geometry.glsl; a kernel reads these only where SCENE_TEXTURES.
#ifndef RLPT_TEXTURE_GLSL
#define RLPT_TEXTURE_GLSL
#include "scene.glsl"
#include "sampling.glsl"

layout(std430, set = 0, binding = BINDING_TEXTURES) readonly buffer Textures { TextureHeader textures[]; };
layout(std430, set = 0, binding = BINDING_TEXELS) readonly buffer Texels { uint texels[]; };
layout(std430, set = 0, binding = BINDING_TRIANGLE_UVS) readonly buffer TriangleUvsBuf { TriangleUvs triangle_uvs[]; };
layout(std430, set = 0, binding = BINDING_SPHERE_UVS) readonly buffer SphereUvsBuf { SphereUv sphere_uvs[]; };

// src/scene/texture.rs `srgb_to_linear`.
float srgb_to_linear(float c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }

// src/math/texture.rs `texel`: linear RGBA of texel (x, y) of t.
vec4 texel(TextureHeader t, uint x, uint y) {
    uint i = y * t.width + x;
    if (t.format == TEXEL_RGBA16F) {
        uint base = t.offset + 2u * i;
        return vec4(unpackHalf2x16(texels[base]), unpackHalf2x16(texels[base + 1u]));
    }
    uint w = texels[t.offset + i];
    vec4 c = vec4(float(w & 0xffu), float((w >> 8u) & 0xffu), float((w >> 16u) & 0xffu), float(w >> 24u)) / 255.0;
    if (t.format == TEXEL_RGBA8_SRGB) c = vec4(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z), c.w);
    return c;
}

// src/math/texture.rs `mix`, written out (as the Rust twin computes it).
vec4 lerp4(vec4 a, vec4 b, float t) { return a * (1.0 - t) + b * t; }

// src/math/texture.rs `wrap`: s in [0, 1) under repeat wrap; 0 where not finite.
float wrap(float s) {
    float f = s - floor(s);
    return f < 1.0 ? f : 0.0;
}

// src/math/texture.rs `neighbours`: the texel below x and the next, wrapped to [0, n).
uvec2 neighbours(float x, uint n, out float frac) {
    float x0 = floor(x);
    uint i0 = x0 < 0.0 ? n - 1u : min(uint(x0), n - 1u);
    frac = x - x0;
    return uvec2(i0, i0 + 1u == n ? 0u : i0 + 1u);
}

// src/math/texture.rs `texture_lookup`: texture `index`, bilinear, at uv.
vec4 texture_lookup(uint index, vec2 uv) {
    TextureHeader t = textures[index];
    float s = wrap(uv.x * t.transform.x + t.transform.z);
    float v = wrap(uv.y * t.transform.y + t.transform.w);
    float fx, fy;
    uvec2 xs = neighbours(s * float(t.width) - 0.5, t.width, fx);
    uvec2 ys = neighbours((1.0 - v) * float(t.height) - 0.5, t.height, fy);
    return lerp4(lerp4(texel(t, xs.x, ys.x), texel(t, xs.y, ys.x), fx),
                 lerp4(texel(t, xs.x, ys.y), texel(t, xs.y, ys.y), fx), fy);
}

// src/math/texture.rs `procedural_operand`: operand `which` of the procedural
// texture whose operands start at texels[at]: its constant times its image.
vec3 procedural_operand(uint at, uint which, vec2 uv) {
    uint tex = texels[at + which];
    uint c = at + 3u + 3u * which;
    vec3 value = uintBitsToFloat(uvec3(texels[c], texels[c + 1u], texels[c + 2u]));
    return tex == NO_TEXTURE ? value : value * texture_lookup(tex - 1u, uv).rgb;
}

// src/math/texture.rs `checker_odd`: whether floor(s) + floor(t) is odd
// (pbrt's 2D checkerboard, unfiltered); false where not finite.
bool checker_odd(vec2 st) {
    float f = floor(st.x) + floor(st.y);
    return f - 2.0 * floor(f * 0.5) == 1.0;
}

// src/math/texture.rs `colour_texture`: the RGB of texture `index` at uv: an
// image's bilinear lookup, or a procedural texture's (TEXTURE_CHECKER, ...;
// at most 1), whose code only kernels of scenes with one carry (SCENE_KIND_PROCEDURAL).
vec3 colour_texture(uint index, vec2 uv) {
    uint format = textures[index].format;
    if ((SCENE_KINDS & (1u << SCENE_KIND_PROCEDURAL)) == 0u || format < TEXTURE_CHECKER) return texture_lookup(index, uv).rgb;
    uint at = textures[index].offset;
    vec3 c;
    if (format == TEXTURE_CHECKER) {
        vec4 t = textures[index].transform;
        c = procedural_operand(at, checker_odd(uv * t.xy + t.zw) ? 1u : 0u, uv);
    } else {
        vec3 a = procedural_operand(at, 0u, uv), b = procedural_operand(at, 1u, uv);
        float amount = format == TEXTURE_MIX ? procedural_operand(at, 2u, uv).x : 0.0;
        c = format == TEXTURE_SCALE ? a * b : a * (1.0 - amount) + b * amount;
    }
    return min(c, vec3(1.0));
}

// src/math/texture.rs `triangle_barycentrics`: p's weights in the triangle, clamped into it.
vec3 triangle_barycentrics(vec3 v0, vec3 v1, vec3 v2, vec3 p) {
    vec3 e1 = v1 - v0, e2 = v2 - v0, ep = p - v0;
    float d00 = dot(e1, e1), d01 = dot(e1, e2), d11 = dot(e2, e2);
    float d20 = dot(ep, e1), d21 = dot(ep, e2);
    float denom = d00 * d11 - d01 * d01;
    float b1 = clamp((d11 * d20 - d01 * d21) / denom, 0.0, 1.0);
    float b2 = clamp((d00 * d21 - d01 * d20) / denom, 0.0, 1.0 - b1);
    return vec3(1.0 - b1 - b2, b1, b2);
}

// src/math/texture.rs `sphere_uv`: sphere i's UV at the outward unit normal n.
vec2 sphere_uv(uint i, vec3 n) {
    SphereUv f = sphere_uvs[i];
    vec3 o = normalize(vec3(dot(f.x.xyz, n), dot(f.y.xyz, n), dot(f.z.xyz, n)));
    float phi = atan(o.y, o.x);
    if (phi < 0.0) phi += 2.0 * PI;
    float theta = acos(clamp(o.z, -1.0, 1.0));
    return vec2(phi / f.x.w, (theta - f.y.w) / (f.z.w - f.y.w));
}

// src/math/texture.rs `quad_uv`.
vec2 quad_uv(Quad q, vec3 p) {
    vec3 rel = p - q.origin.xyz;
    return vec2(dot(rel, q.dual_u.xyz), dot(rel, q.dual_v.xyz));
}

// src/math/texture.rs `triangle_uv`.
vec2 triangle_uv(uint i, Triangle tr, vec3 p) {
    vec3 b = triangle_barycentrics(tr.v0, tr.v1, tr.v2, p);
    TriangleUvs t = triangle_uvs[i];
    return b.x * t.uv0 + b.y * t.uv1 + b.z * t.uv2;
}

#endif
