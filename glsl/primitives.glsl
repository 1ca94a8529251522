// The plain primitive tests and offsets, with no specialization constants and
// no uniform block, so that probe kernels and bvh.glsl can include them:
// src/math/geometry.rs, same code. geometry.glsl includes this file.
#ifndef RLPT_PRIMITIVES_GLSL
#define RLPT_PRIMITIVES_GLSL
#include "common.glsl"

float max_abs(vec3 v) { vec3 a = abs(v); return max(a.x, max(a.y, a.z)); }

float hit_epsilon(vec3 p, float scale) { return 1e-5 * (1.0 + max_abs(p)) + 2.5e-7 * scale; }

float sphere_scale(vec4 cr) { return max_abs(cr.xyz) + cr.w; }  // sampled light points
float sphere_hit_scale(Sphere s) { return max_abs(s.anchor_radius.xyz); }  // intersect_sphere's hits
float quad_scale(Quad q) { return q.edge_u.w; }  // src/math/geometry.rs `quad_points_scale`, from the host

// src/math/geometry.rs `approach`: f = o - C, b = -(f.d) (the nearest approach
// to the centre along the line) and l2 = |f + b d|^2; false where the line
// misses the sphere (l2 > r^2). Every sphere test starts here, and most stop.
bool sphere_approach(vec3 center, float r, vec3 o, vec3 d, out vec3 f, out float b, out float l2) {
    f = o - center;
    b = -dot(f, d);
    vec3 h = f + b * d;
    l2 = dot(h, h);
    return l2 <= r * r;
}

// Ray Tracing Gems ch. 7, with the origin's power c taken from the sphere's
// anchor so that nothing of the size of the radius is subtracted; misses are
// rejected first, from the centre alone and without a square root
// (src/math/geometry.rs `intersect_sphere` explains). Returns the nearest root
// in (0, t_max) or -1.
float intersect_sphere_anchored(vec3 center, vec4 anchor_radius, vec3 axis, vec3 o, vec3 d, float t_max) {
    float r = anchor_radius.w;
    vec3 f;
    float b, l2;
    if (!sphere_approach(center, r, o, d, f, b, l2)) return -1.0;
    float l = sqrt(l2);
    float disc = max((r - l) * (r + l), 0.0);
    vec3 g = o - anchor_radius.xyz;
    float c = dot(g, g) + 2.0 * r * dot(g, axis);
    if (c < 0.0) disc = b * b - c;
    float q = b + (b >= 0.0 ? sqrt(disc) : -sqrt(disc));
    if (q == 0.0) return -1.0;
    float a = c / q;
    float t0 = min(a, q);
    float t1 = max(a, q);
    if (t0 > 0.0 && t0 < t_max) return t0;
    if (t1 > 0.0 && t1 < t_max) return t1;
    return -1.0;
}

// src/math/geometry.rs `sphere_blocks`: whether the segment from o to o + t_max d
// (d unit) meets the sphere; a shadow ray's test, without the roots. The ends'
// sides come from the powers of the ends, taken from the centre on a compact
// sphere (sphere_blocks_compact) and from the anchor on others
// (sphere_blocks_anchored); the verdict from them and the line's nearest
// approach b to the centre, where the line passes inside:
bool segment_crosses(bool in_o, bool in_e, float b, float t_max) {
    if (in_o != in_e) return true;
    return !in_o && b > 0.0 && b < t_max;
}

bool sphere_blocks_compact(vec3 center, float r, vec3 o, vec3 d, float t_max) {
    vec3 f;
    float b, l2;
    if (!sphere_approach(center, r, o, d, f, b, l2)) return false;
    vec3 e = f + t_max * d;
    return segment_crosses(dot(f, f) < r * r, dot(e, e) < r * r, b, t_max);
}

bool sphere_blocks_anchored(vec3 center, vec4 anchor_radius, vec3 axis, vec3 o, vec3 d, float t_max) {
    float r = anchor_radius.w;
    vec3 f;
    float b, l2;
    if (!sphere_approach(center, r, o, d, f, b, l2)) return false;
    vec3 g = o - anchor_radius.xyz;
    vec3 ge = g + t_max * d;
    return segment_crosses(dot(g, g) + 2.0 * r * dot(g, axis) < 0.0, dot(ge, ge) + 2.0 * r * dot(ge, axis) < 0.0, b, t_max);
}

// compact: src/layout.rs `GpuSphere::compact`, the sphere's axis.w != 0 or a
// specialized slot's bit of COMPACT_SPHERES.
bool sphere_blocks_at(vec3 center, vec4 anchor_radius, vec3 axis, bool compact, vec3 o, vec3 d, float t_max) {
    if (compact) return sphere_blocks_compact(center, anchor_radius.w, o, d, t_max);
    return sphere_blocks_anchored(center, anchor_radius, axis, o, d, t_max);
}

bool sphere_blocks(Sphere s, vec3 o, vec3 d, float t_max) {
    return sphere_blocks_at(s.center_radius.xyz, s.anchor_radius, s.axis.xyz, s.axis.w != 0.0, o, d, t_max);
}

// src/math/geometry.rs `intersect_sphere_compact`: the roots b -+ sqrt(r^2 - l^2)
// of a compact sphere, from the centre.
float intersect_sphere_compact(vec3 center, float r, vec3 o, vec3 d, float t_max) {
    vec3 f;
    float b, l2;
    if (!sphere_approach(center, r, o, d, f, b, l2)) return -1.0;
    float s = sqrt(r * r - l2);
    if (b - s > 0.0 && b - s < t_max) return b - s;
    if (b + s > 0.0 && b + s < t_max) return b + s;
    return -1.0;
}

// compact: as for sphere_blocks_at.
float intersect_sphere_at(vec3 center, vec4 anchor_radius, vec3 axis, bool compact, vec3 o, vec3 d, float t_max) {
    if (compact) return intersect_sphere_compact(center, anchor_radius.w, o, d, t_max);
    return intersect_sphere_anchored(center, anchor_radius, axis, o, d, t_max);
}

float intersect_sphere(Sphere s, vec3 o, vec3 d, float t_max) {
    return intersect_sphere_at(s.center_radius.xyz, s.anchor_radius, s.axis.xyz, s.axis.w != 0.0, o, d, t_max);
}

// The quad's plane (normal, offset in w), origin and dual edges; denom is
// dot(normal, d) and inv its reciprocal.
float quad_hit(vec4 normal, vec3 origin, vec3 dual_u, vec3 dual_v, vec3 o, vec3 d, float denom, float inv, float t_max) {
    if (abs(denom) < 1e-12) return -1.0;
    float t = (normal.w - dot(normal.xyz, o)) * inv;
    if (!(t > 0.0 && t < t_max)) return -1.0;
    vec3 rel = o + t * d - origin;
    float s = dot(rel, dual_u);
    float tt = dot(rel, dual_v);
    if (s >= 0.0 && s <= 1.0 && tt >= 0.0 && tt <= 1.0) return t;
    return -1.0;
}

float intersect_quad_at(vec4 normal, vec3 origin, vec3 dual_u, vec3 dual_v, vec3 o, vec3 d, float t_max) {
    float denom = dot(normal.xyz, d);
    return quad_hit(normal, origin, dual_u, dual_v, o, d, denom, 1.0 / denom, t_max);
}

// The same for a quad whose normal the driver knows (a specialized slot): where
// it lies along an axis (every wall of the seed's rooms and of door), 1 / denom
// is the ray's reciprocal along that axis, computed once per ray (inv_d) for all
// such quads. src/math/geometry.rs divides; the two agree to rounding.
float intersect_quad_inv(vec4 normal, vec3 origin, vec3 dual_u, vec3 dual_v, vec3 o, vec3 d, vec3 inv_d, float t_max) {
    float denom = dot(normal.xyz, d);
    float inv;
    if (normal.y == 0.0 && normal.z == 0.0) inv = normal.x * inv_d.x;
    else if (normal.x == 0.0 && normal.z == 0.0) inv = normal.y * inv_d.y;
    else if (normal.x == 0.0 && normal.y == 0.0) inv = normal.z * inv_d.z;
    else inv = 1.0 / denom;
    return quad_hit(normal, origin, dual_u, dual_v, o, d, denom, inv, t_max);
}

float intersect_quad(Quad q, vec3 o, vec3 d, float t_max) {
    return intersect_quad_at(q.normal, q.origin.xyz, q.dual_u.xyz, q.dual_v.xyz, o, d, t_max);
}

#endif
