// Intersection, offsets and light sampling: src/math/geometry.rs, same code.
#ifndef RLPT_GEOMETRY_GLSL
#define RLPT_GEOMETRY_GLSL
#include "scene.glsl"
#include "sampling.glsl"
#include "primitives.glsl"
#include "envmap.glsl"
#include "texture.glsl"
#extension GL_EXT_control_flow_attributes : require

struct Hit {
    float t;
    vec3 p;
    vec3 n;       // front-side unit normal
    vec3 ns;      // unit shading normal on the side of n (n itself but on smooth triangles)
    float eps;    // position error bound
    uint material;
    uint light;
    vec2 uv;      // texture coordinates, where SCENE_TEXTURES (texture.glsl)
};

#include "bvh.glsl"

// 1: every ray walks the BVH (params.bvh_nodes > 0; src/prepared `uses_bvh`).
layout(constant_id = SPEC_BVH) const bool SCENE_BVH = false;
// 1: some triangle has shading normals: hits interpolate them.
layout(constant_id = SPEC_SMOOTH) const bool SCENE_SMOOTH = false;
// 1: some material has a texture: hits carry their UVs (texture.glsl).
layout(constant_id = SPEC_TEXTURES) const bool SCENE_TEXTURES = false;

// src/math/geometry.rs `triangle_scale`: a triangle's largest coordinate.
float triangle_scale(Triangle t) { return max(max_abs(t.v0), max(max_abs(t.v1), max_abs(t.v2))); }

// src/math/geometry.rs `shading_normal`: the vertex normals interpolated at p,
// on the side of the geometric normal n.
vec3 shading_normal(TriangleNormals tn, Triangle t, vec3 p, vec3 n) {
    vec3 b = triangle_barycentrics(t.v0, t.v1, t.v2, p);
    vec3 ns = normalize(b.x * tn.n0.xyz + b.y * tn.n1.xyz + b.z * tn.n2.xyz);
    if (any(isnan(ns)) || any(isinf(ns))) return n;
    return dot(ns, n) < 0.0 ? -ns : ns;
}

// src/layout.rs `prim_ref`: the reference of primitive i of a kind (PRIM_*).
#define PRIM_REF(kind, i) (uint(kind) << PRIM_KIND_SHIFT | uint(i))

// src/math/geometry.rs `prim_hit`: the hit at distance t on primitive r.
Hit prim_hit(uint r, vec3 o, vec3 d, float t) {
    Hit hit;
    hit.t = t;
    hit.p = o + t * d;
    hit.uv = vec2(0.0);
    uint kind = r >> PRIM_KIND_SHIFT;
    uint i = r & PRIM_INDEX_MASK;
    if (kind == PRIM_SPHERE) {
        Sphere s = spheres[i];
        hit.n = normalize((hit.p - s.center_radius.xyz) / s.center_radius.w);
        hit.eps = hit_epsilon(hit.p, sphere_hit_scale(s));
        hit.material = s.material;
        hit.light = s.light;
        if (SCENE_TEXTURES) hit.uv = sphere_uv(i, hit.n);
    } else if (!SCENE_BVH || kind == PRIM_QUAD) {
        // Triangles come with the BVH alone: without it their code is left out.
        Quad q = quads[i];
        hit.n = q.normal.xyz;
        hit.eps = hit_epsilon(hit.p, quad_scale(q));
        hit.material = q.material;
        hit.light = q.light;
        if (SCENE_TEXTURES) hit.uv = quad_uv(q, hit.p);
    } else {
        Triangle tr = triangles[i];
        hit.n = normalize(cross(tr.v1 - tr.v0, tr.v2 - tr.v0));
        hit.eps = hit_epsilon(hit.p, triangle_scale(tr));
        hit.material = tr.material;
        hit.light = tr.light;
        if (SCENE_TEXTURES) hit.uv = triangle_uv(i, tr, hit.p);
        if (SCENE_SMOOTH && tr.normals != NO_NORMALS) {
            hit.ns = shading_normal(triangle_normals[tr.normals], tr, hit.p, hit.n);
            return hit;
        }
    }
    hit.ns = hit.n;
    return hit;
}

// The first CONST_SPHERES spheres and CONST_QUADS quads, as far as the hit
// tests read them, in a uniform buffer (src/prepared/mod.rs `scene_constants`).
// Every lane of a warp reads the same primitive at once, and the kernel is
// specialized to the scene, so the loops' lengths are known when the driver
// compiles: the constant cache serves these warp-uniform reads without staging
// (docs/ARCHITECTURE.md, "Specialization").
// Primitives past the capacity are read from the storage buffers.
layout(std140, set = 0, binding = BINDING_SCENE_CONSTANTS) uniform SceneConstantsBlock {
    vec4 const_spheres[3 * CONST_SPHERES];  // center_radius, anchor_radius, axis
    vec4 const_quads[4 * CONST_QUADS];      // normal, origin, dual_u, dual_v
};

// The primitive counts as specialization constants (params.num_spheres and
// num_quads; the one includer, pathtrace.comp, is always specialized): every
// loop's trip count is known when the driver compiles.
layout(constant_id = SPEC_NUM_SPHERES) const uint SCENE_SPHERES = 0u;
layout(constant_id = SPEC_NUM_QUADS) const uint SCENE_QUADS = 0u;
// params.occluding_quads: the quads a shadow ray tests come first; the rest bound
// the scene and cannot block one (src/prepared/analysis.rs `occluding_order`).
layout(constant_id = SPEC_OCCLUDING_QUADS) const uint OCCLUDING_QUADS = 0u;
// src/layout.rs `Room`: the box whose faces are walls, and the quad that
// covers each face (NO_QUAD where it is open). Those quads are the scene's last
// ROOM_QUADS, and the closest-hit walk leaves them to room_hit.
layout(constant_id = SPEC_ROOM_QUADS) const uint ROOM_QUADS = 0u;
layout(constant_id = SPEC_ROOM_BOUNDS + 0) const float ROOM_MIN_X = 0.0;
layout(constant_id = SPEC_ROOM_BOUNDS + 1) const float ROOM_MIN_Y = 0.0;
layout(constant_id = SPEC_ROOM_BOUNDS + 2) const float ROOM_MIN_Z = 0.0;
layout(constant_id = SPEC_ROOM_BOUNDS + 3) const float ROOM_MAX_X = 0.0;
layout(constant_id = SPEC_ROOM_BOUNDS + 4) const float ROOM_MAX_Y = 0.0;
layout(constant_id = SPEC_ROOM_BOUNDS + 5) const float ROOM_MAX_Z = 0.0;
layout(constant_id = SPEC_ROOM_FACES + 0) const uint ROOM_FACE_0 = NO_QUAD;
layout(constant_id = SPEC_ROOM_FACES + 1) const uint ROOM_FACE_1 = NO_QUAD;
layout(constant_id = SPEC_ROOM_FACES + 2) const uint ROOM_FACE_2 = NO_QUAD;
layout(constant_id = SPEC_ROOM_FACES + 3) const uint ROOM_FACE_3 = NO_QUAD;
layout(constant_id = SPEC_ROOM_FACES + 4) const uint ROOM_FACE_4 = NO_QUAD;
layout(constant_id = SPEC_ROOM_FACES + 5) const uint ROOM_FACE_5 = NO_QUAD;
layout(constant_id = SPEC_ROOM_ENTERING) const bool ROOM_ENTERING = false;

// The first SPEC_SPHERES spheres and SPEC_QUADS quads as specialization
// constants, one float each (common.glsl: SPEC_QUAD_BASE, SPEC_SPHERE_BASE):
// their tests are written out once per slot below, so every operand is a number
// the driver knows, and an axis-aligned quad's test keeps only the arithmetic of
// its one axis (a wall of the seed's rooms: a multiply by the ray's reciprocal
// along that axis and two multiply-adds).
// Slots past the scene's count are left out when the kernel is specialized.
#define SPEC_QUAD_F(i, k) layout(constant_id = SPEC_QUAD_BASE + SPEC_QUAD_FLOATS * i + k) const float sq##i##_##k = 0.0;
#define SPEC_QUAD_DECL(i) \
    SPEC_QUAD_F(i, 0) SPEC_QUAD_F(i, 1) SPEC_QUAD_F(i, 2) SPEC_QUAD_F(i, 3) SPEC_QUAD_F(i, 4) \
    SPEC_QUAD_F(i, 5) SPEC_QUAD_F(i, 6) SPEC_QUAD_F(i, 7) SPEC_QUAD_F(i, 8) SPEC_QUAD_F(i, 9) \
    SPEC_QUAD_F(i, 10) SPEC_QUAD_F(i, 11) SPEC_QUAD_F(i, 12)
#define SPEC_SPHERE_F(i, k) layout(constant_id = SPEC_SPHERE_BASE + SPEC_SPHERE_FLOATS * i + k) const float ss##i##_##k = 0.0;
#define SPEC_SPHERE_DECL(i) \
    SPEC_SPHERE_F(i, 0) SPEC_SPHERE_F(i, 1) SPEC_SPHERE_F(i, 2) SPEC_SPHERE_F(i, 3) SPEC_SPHERE_F(i, 4) \
    SPEC_SPHERE_F(i, 5) SPEC_SPHERE_F(i, 6) SPEC_SPHERE_F(i, 7) SPEC_SPHERE_F(i, 8) SPEC_SPHERE_F(i, 9)
SPEC_QUAD_DECL(0) SPEC_QUAD_DECL(1) SPEC_QUAD_DECL(2) SPEC_QUAD_DECL(3)
SPEC_QUAD_DECL(4) SPEC_QUAD_DECL(5) SPEC_QUAD_DECL(6) SPEC_QUAD_DECL(7)
SPEC_QUAD_DECL(8) SPEC_QUAD_DECL(9) SPEC_QUAD_DECL(10) SPEC_QUAD_DECL(11)
SPEC_QUAD_DECL(12) SPEC_QUAD_DECL(13) SPEC_QUAD_DECL(14) SPEC_QUAD_DECL(15)
SPEC_SPHERE_DECL(0) SPEC_SPHERE_DECL(1) SPEC_SPHERE_DECL(2) SPEC_SPHERE_DECL(3)
SPEC_SPHERE_DECL(4) SPEC_SPHERE_DECL(5) SPEC_SPHERE_DECL(6) SPEC_SPHERE_DECL(7)
SPEC_SPHERE_DECL(8) SPEC_SPHERE_DECL(9) SPEC_SPHERE_DECL(10) SPEC_SPHERE_DECL(11)
SPEC_SPHERE_DECL(12) SPEC_SPHERE_DECL(13) SPEC_SPHERE_DECL(14) SPEC_SPHERE_DECL(15)
// Bit i: the sphere in slot i is compact (src/layout.rs `GpuSphere::compact`),
// an integer the host works out, which the driver folds (common.glsl).
layout(constant_id = SPEC_COMPACT_SPHERES) const uint COMPACT_SPHERES = 0u;

// The hit test of specialized quad or sphere slot i (a literal).
#define SPEC_QUAD_HIT(i, o, d, t_max) \
    intersect_quad_inv(vec4(sq##i##_0, sq##i##_1, sq##i##_2, sq##i##_3), vec3(sq##i##_4, sq##i##_5, sq##i##_6), \
                      vec3(sq##i##_7, sq##i##_8, sq##i##_9), vec3(sq##i##_10, sq##i##_11, sq##i##_12), o, d, inv_d, t_max)
#define SPEC_SPHERE_COMPACT(i) (((COMPACT_SPHERES >> i) & 1u) != 0u)
// Slot i's sphere as the arguments of intersect_sphere_at and sphere_blocks_at.
#define SPEC_SPHERE_ARGS(i) \
    vec3(ss##i##_0, ss##i##_1, ss##i##_2), vec4(ss##i##_3, ss##i##_4, ss##i##_5, ss##i##_6), \
        vec3(ss##i##_7, ss##i##_8, ss##i##_9), SPEC_SPHERE_COMPACT(i)
#define SPEC_SPHERE_HIT(i, o, d, t_max) intersect_sphere_at(SPEC_SPHERE_ARGS(i), o, d, t_max)
#define SPEC_SPHERE_BLOCKS(i, o, d, t_max) sphere_blocks_at(SPEC_SPHERE_ARGS(i), o, d, t_max)
// A statement per slot, for the slots 0 to 15 (SPEC_QUADS, SPEC_SPHERES).
#define FOR_SPEC_SLOTS(S) \
    S(0) S(1) S(2) S(3) S(4) S(5) S(6) S(7) S(8) S(9) S(10) S(11) S(12) S(13) S(14) S(15)

// How many spheres and quads are specialization constants, and how many more the
// uniform buffer holds: the first ones, up to the capacities.
uint spec_sphere_count() { return min(SCENE_SPHERES, uint(SPEC_SPHERES)); }
// The quads' counts are those of the closest-hit walk: the room's quads, the
// last, are left to room_hit (shadow rays test the first OCCLUDING_QUADS alone).
uint walked_quads() { return SCENE_QUADS - ROOM_QUADS; }
uint spec_quad_count() { return min(walked_quads(), uint(SPEC_QUADS)); }
uint const_sphere_count() { return min(SCENE_SPHERES, uint(CONST_SPHERES)); }
uint const_quad_count() { return min(walked_quads(), uint(CONST_QUADS)); }

// The hit tests of primitive i of the uniform buffer.
float const_sphere(uint i, vec3 o, vec3 d, float t_max) {
    uint k = 3u * i;
    return intersect_sphere_at(const_spheres[k].xyz, const_spheres[k + 1u], const_spheres[k + 2u].xyz,
                               const_spheres[k + 2u].w != 0.0, o, d, t_max);
}
bool const_sphere_blocks(uint i, vec3 o, vec3 d, float t_max) {
    uint k = 3u * i;
    return sphere_blocks_at(const_spheres[k].xyz, const_spheres[k + 1u], const_spheres[k + 2u].xyz,
                            const_spheres[k + 2u].w != 0.0, o, d, t_max);
}
float const_quad(uint i, vec3 o, vec3 d, float t_max) {
    uint k = 4u * i;
    return intersect_quad_at(const_quads[k], const_quads[k + 1u].xyz, const_quads[k + 2u].xyz,
                             const_quads[k + 3u].xyz, o, d, t_max);
}

// The quad of the room's face on `axis`, at its max side or its min.
uint room_face(uint axis, bool at_max) {
    if (axis == 0u) return at_max ? ROOM_FACE_1 : ROOM_FACE_0;
    if (axis == 1u) return at_max ? ROOM_FACE_3 : ROOM_FACE_2;
    return at_max ? ROOM_FACE_5 : ROOM_FACE_4;
}

// src/math/geometry.rs `Room::hit`: the first of the room's quads the ray meets
// in (0, best), by one slab test (the distances by the ray's reciprocal, as the
// specialized quads' own tests take them); its index in `q`. The face a ray
// enters by only where ROOM_ENTERING says a ray may come from outside.
bool room_hit(vec3 o, vec3 d, vec3 inv_d, float best, out float t, out uint q) {
    vec3 t_lo = (vec3(ROOM_MIN_X, ROOM_MIN_Y, ROOM_MIN_Z) - o) * inv_d;
    vec3 t_hi = (vec3(ROOM_MAX_X, ROOM_MAX_Y, ROOM_MAX_Z) - o) * inv_d;
    vec3 near = min(t_lo, t_hi);
    vec3 far = max(t_lo, t_hi);
    float t_enter = max(near.x, max(near.y, near.z));
    float t_exit = min(far.x, min(far.y, far.z));
    if (!(t_enter <= t_exit)) return false;
    // The axes whose planes give t_enter and t_exit (selects, not d[axis]: see normal_class).
    uint ax = far.x == t_exit ? 0u : (far.y == t_exit ? 1u : 2u);
    float dx = ax == 0u ? d.x : (ax == 1u ? d.y : d.z);
    t = t_exit;
    q = room_face(ax, dx > 0.0);
    if (ROOM_ENTERING) {
        uint ae = near.x == t_enter ? 0u : (near.y == t_enter ? 1u : 2u);
        float de = ae == 0u ? d.x : (ae == 1u ? d.y : d.z);
        uint qe = room_face(ae, de < 0.0);
        if (t_enter > 0.0 && qe != NO_QUAD) {
            t = t_enter;
            q = qe;
        }
    }
    return q != NO_QUAD && t > 0.0 && t < best;
}

// Each kind of primitive is walked in three runs: the specialized slots, the
// uniform buffer, then the rest from the storage buffers: one loop that chose the
// source per primitive was slower. The loops over the uniform buffer stay
// loops: unrolled (the driver's choice once their length is known) they made
// frames slower.
bool intersect_scene(vec3 o, vec3 d, float t_max, out Hit hit) {
    if (SCENE_BVH) {
        float t;
        uint r;
        if (!bvh_closest(o, d, t_max, t, r)) return false;
        hit = prim_hit(r, o, d, t);
        return true;
    }
    vec3 inv_d = 1.0 / d;
    float best = t_max;
    int found = -1;
    bool is_sphere = false;
#define NEAREST_SPEC_SPHERE(i) \
    if (i < spec_sphere_count()) { \
        float t = SPEC_SPHERE_HIT(i, o, d, best); \
        if (t > 0.0) { best = t; found = i; is_sphere = true; } \
    }
    FOR_SPEC_SLOTS(NEAREST_SPEC_SPHERE)
    uint ns = const_sphere_count();
    [[dont_unroll]] for (uint i = spec_sphere_count(); i < ns; ++i) {
        float t = const_sphere(i, o, d, best);
        if (t > 0.0) { best = t; found = int(i); is_sphere = true; }
    }
    for (uint i = ns; i < SCENE_SPHERES; ++i) {
        float t = intersect_sphere(spheres[i], o, d, best);
        if (t > 0.0) { best = t; found = int(i); is_sphere = true; }
    }
    if (ROOM_QUADS > 0u) {
        float t;
        uint q;
        if (room_hit(o, d, inv_d, best, t, q)) { best = t; found = int(q); is_sphere = false; }
    }
#define NEAREST_SPEC_QUAD(i) \
    if (i < spec_quad_count()) { \
        float t = SPEC_QUAD_HIT(i, o, d, best); \
        if (t > 0.0) { best = t; found = i; is_sphere = false; } \
    }
    FOR_SPEC_SLOTS(NEAREST_SPEC_QUAD)
    uint nq = const_quad_count();
    [[dont_unroll]] for (uint i = spec_quad_count(); i < nq; ++i) {
        float t = const_quad(i, o, d, best);
        if (t > 0.0) { best = t; found = int(i); is_sphere = false; }
    }
    for (uint i = nq; i < walked_quads(); ++i) {
        float t = intersect_quad(quads[i], o, d, best);
        if (t > 0.0) { best = t; found = int(i); is_sphere = false; }
    }
    if (found < 0) return false;
    hit = prim_hit(PRIM_REF(is_sphere ? PRIM_SPHERE : PRIM_QUAD, found), o, d, best);
    return true;
}

// Bit i: the quad (sphere) in slot i is a light (src/prepared/mod.rs
// `geometry_specialization`).
layout(constant_id = SPEC_LIGHT_QUADS) const uint LIGHT_QUAD_SLOTS = 0u;
layout(constant_id = SPEC_LIGHT_SPHERES) const uint LIGHT_SPHERE_SLOTS = 0u;

// src/math/geometry.rs `meets_light`: whether the line of the ray from o along d
// meets a light at t > 0, whatever lies in front of it. For scenes whose every
// light is in a specialized slot (FLAG_LAST_RAY_TO_LIGHTS): the tests of those
// slots alone, written out with their numbers, a few instructions per light.
bool meets_light(vec3 o, vec3 d) {
    vec3 inv_d = 1.0 / d;
    float far = 1.0 / 0.0;
#define MEETS_SPEC_QUAD(i) \
    if (((LIGHT_QUAD_SLOTS >> i) & 1u) != 0u && SPEC_QUAD_HIT(i, o, d, far) > 0.0) return true;
    FOR_SPEC_SLOTS(MEETS_SPEC_QUAD)
#define MEETS_SPEC_SPHERE(i) \
    if (((LIGHT_SPHERE_SLOTS >> i) & 1u) != 0u && SPEC_SPHERE_HIT(i, o, d, far) > 0.0) return true;
    FOR_SPEC_SLOTS(MEETS_SPEC_SPHERE)
    return false;
}

// src/math/geometry.rs `occluded`: whether anything but the primitive skip (the
// light a shadow ray ends on; NO_PRIM for none) blocks the segment; without a
// BVH the quads that bound the scene are not tested.
// `skip` is compared whole with each primitive's reference (PRIM_REF), a
// constant in the specialized slots: no decoding of it into an index per kind.
bool occluded(vec3 o, vec3 d, float t_max, uint skip) {
    if (SCENE_BVH) return bvh_occluded(o, d, t_max, skip);
    vec3 inv_d = 1.0 / d;
#define BLOCKS_SPEC_SPHERE(i) \
    if (i < spec_sphere_count() && skip != PRIM_REF(PRIM_SPHERE, i) && SPEC_SPHERE_BLOCKS(i, o, d, t_max)) return true;
    FOR_SPEC_SLOTS(BLOCKS_SPEC_SPHERE)
    uint ns = const_sphere_count();
    [[dont_unroll]] for (uint i = spec_sphere_count(); i < ns; ++i) {
        if (skip != PRIM_REF(PRIM_SPHERE, i) && const_sphere_blocks(i, o, d, t_max)) return true;
    }
    for (uint i = ns; i < SCENE_SPHERES; ++i) {
        if (skip != PRIM_REF(PRIM_SPHERE, i) && sphere_blocks(spheres[i], o, d, t_max)) return true;
    }
    uint nqs = min(OCCLUDING_QUADS, uint(SPEC_QUADS));
#define BLOCKS_SPEC_QUAD(i) \
    if (i < nqs && skip != PRIM_REF(PRIM_QUAD, i) && SPEC_QUAD_HIT(i, o, d, t_max) > 0.0) return true;
    FOR_SPEC_SLOTS(BLOCKS_SPEC_QUAD)
    uint nq = min(OCCLUDING_QUADS, uint(CONST_QUADS));
    [[dont_unroll]] for (uint i = nqs; i < nq; ++i) {
        if (skip != PRIM_REF(PRIM_QUAD, i) && const_quad(i, o, d, t_max) > 0.0) return true;
    }
    for (uint i = nq; i < OCCLUDING_QUADS; ++i) {
        if (skip != PRIM_REF(PRIM_QUAD, i) && intersect_quad(quads[i], o, d, t_max) > 0.0) return true;
    }
    return false;
}

vec3 offset_origin(vec3 p, vec3 n, float eps, vec3 w) {
    return dot(n, w) >= 0.0 ? p + eps * n : p - eps * n;
}

vec3 emitted(uint mat, vec3 n, vec3 w) {
    Material m = materials[mat];
    return (m.two_sided != 0u || dot(n, w) > 0.0) ? m.emission_ior.xyz : vec3(0.0);
}

float one_minus_cos_max(float sin2_max) {
    return sin2_max < 0.00068523 ? 0.5 * sin2_max : 1.0 - sqrt(max(0.0, 1.0 - sin2_max));
}

// src/math/geometry.rs `LightSample`: `end` is where the shadow ray ends, the
// light point itself with the light's own primitive skipped, except for a
// sphere sampled by area (which may hide its far side), see the Rust doc.
struct LightSample {
    vec3 wi;
    float dist;
    vec3 end;
    uint skip;    // the primitive the shadow ray leaves out (NO_PRIM: none)
    vec3 le;
    float pdf;
    bool delta;   // a delta light's: no MIS against BSDF sampling (SCENE_DELTA)
};

#include "delta.glsl"

// src/math/geometry.rs `shadow_ray`: the segment from the shading point (moved
// off its surface) to the light sample's end, as origin, unit direction, length.
void shadow_ray(vec3 p, vec3 n, float eps, LightSample ls, out vec3 origin, out vec3 dir, out float len) {
    origin = offset_origin(p, n, eps, ls.wi);
    // The image environment's and a distant light's samples lie at infinity (dist), along wi.
    if ((scene_has_light(LIGHT_ENV) || scene_has_light(LIGHT_DISTANT)) && isinf(ls.dist)) {
        dir = ls.wi;
        len = ls.dist;
        return;
    }
    vec3 seg = ls.end - origin;
    len = length(seg);
    dir = seg / len;
}

// A light's kind (LIGHT_*); known where the kernel is specialized to a scene
// with lights of one kind, so the others' code goes.
uint light_kind(Light l) {
    if (!scene_has_light(LIGHT_QUAD) && !scene_has_light(LIGHT_TRIANGLE)) return LIGHT_SPHERE;
    if (!scene_has_light(LIGHT_SPHERE) && !scene_has_light(LIGHT_TRIANGLE)) return LIGHT_QUAD;
    if (!scene_has_light(LIGHT_SPHERE) && !scene_has_light(LIGHT_QUAD)) return LIGHT_TRIANGLE;
    // Spheres and quads without triangles: the triangle's code goes too.
    if (!scene_has_light(LIGHT_TRIANGLE)) return l.kind == LIGHT_SPHERE ? LIGHT_SPHERE : LIGHT_QUAD;
    return l.kind;
}

// params.num_lights. A scene with one light has no choice to make and the kernel
// leaves the choosing out; with more the count is read at run time, as a loop
// of known length unrolled made two-light scenes' frames slower.
layout(constant_id = SPEC_NUM_LIGHTS) const uint SCENE_LIGHTS = 0u;

// src/math/geometry.rs `choose_light`: the first light whose cdf exceeds u_sel
// (the last where none does); a walk where there are few, else bisection. The
// choice is the specialization constant's, so each kernel carries one of them.
uint choose_light(uint n_lights, float u_sel) {
    if (SCENE_LIGHTS <= 8u) {
        for (uint i = 0u; i < n_lights; ++i) {
            if (u_sel < lights[i].cdf) return i;
        }
        return n_lights - 1u;
    }
    uint lo = 0u, hi = n_lights - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (u_sel < lights[mid].cdf) hi = mid; else lo = mid + 1u;
    }
    return lo;
}

// src/math/triangle.rs `sample_triangle`: a point uniform by area, the unit
// geometric normal and the area.
void sample_triangle(Triangle t, vec2 u, out vec3 p, out vec3 n, out float area) {
    float su = sqrt(u.x);
    float b0 = 1.0 - su, b1 = u.y * su;
    p = b0 * t.v0 + b1 * t.v1 + (1.0 - b0 - b1) * t.v2;
    vec3 c = cross(t.v1 - t.v0, t.v2 - t.v0);
    float len = length(c);
    n = c / len;
    area = 0.5 * len;
}


bool sample_light(vec3 p, float u_sel, vec2 u, out LightSample ls) {
    uint n_lights = SCENE_LIGHTS == 1u ? 1u : params.num_lights;
    if (n_lights == 0u) return false;
    Light light = lights[choose_light(n_lights, u_sel)];
    ls.delta = false;
    if (SCENE_DELTA && light.kind >= LIGHT_DISTANT) return sample_delta_light(light, p, ls);
    // The image environment: a direction to infinity, nothing skipped.
    if (scene_has_light(LIGHT_ENV) && light.kind == LIGHT_ENV) {
        float pdf_env;
        if (!env_sample(u, ls.wi, ls.le, pdf_env)) return false;
        ls.dist = 1.0 / 0.0;
        ls.end = ls.wi;
        ls.skip = NO_PRIM;
        ls.pdf = pdf_env * light.pmf;
        return ls.pdf > 0.0 && !isinf(ls.pdf);
    }
    vec3 lp, ln;
    float pdf_solid;
    uint mat;
    // The shadow ray's end and what it skips: the point itself and the light's
    // primitive, unless a sphere is sampled by area (area_eps > 0).
    ls.skip = NO_PRIM;
    float area_eps = 0.0;
    uint kind = light_kind(light);
    if (kind == LIGHT_SPHERE) {
        Sphere s = spheres[light.index];
        vec3 c = s.center_radius.xyz;
        float r = s.center_radius.w;
        vec3 to_c = c - p;
        float dc2 = dot(to_c, to_c);
        if (dc2 > r * r * 1.0001) {
            float dc = sqrt(dc2);
            float sin_max = r / dc;
            float sin2_max = sin_max * sin_max;
            float cos_max = sqrt(max(0.0, 1.0 - sin2_max));
            float omc = one_minus_cos_max(sin2_max);
            float sin2_t, cos_t;
            if (sin2_max < 0.00068523) {
                sin2_t = sin2_max * u.x;
                cos_t = sqrt(1.0 - sin2_t);
            } else {
                cos_t = (cos_max - 1.0) * u.x + 1.0;
                sin2_t = 1.0 - cos_t * cos_t;
            }
            float cos_alpha = sin2_t / sin_max + cos_t * sqrt(max(0.0, 1.0 - sin2_t / sin2_max));
            float sin_alpha = sqrt(max(0.0, 1.0 - cos_alpha * cos_alpha));
            float phi = 2.0 * PI * u.y;
            mat3 frame = make_frame(to_c / dc);
            ln = -to_world(frame, vec3(sin_alpha * cos(phi), sin_alpha * sin(phi), cos_alpha));
            lp = c + r * ln;
            pdf_solid = 1.0 / (2.0 * PI * omc);
            ls.skip = PRIM_REF(PRIM_SPHERE, light.index);
        } else {
            ln = uniform_sphere(u);
            lp = c + r * ln;
            vec3 d = lp - p;
            float d2 = dot(d, d);
            float cos_l = abs(dot(ln, d)) / sqrt(d2);
            if (cos_l <= 0.0) return false;
            pdf_solid = d2 / (4.0 * PI * r * r * cos_l);
            area_eps = hit_epsilon(lp, sphere_scale(s.center_radius));
        }
        mat = s.material;
    } else if (kind == LIGHT_QUAD) {
        Quad q = quads[light.index];
        lp = q.origin.xyz + u.x * q.edge_u.xyz + u.y * q.edge_v.xyz;
        ln = q.normal.xyz;
        vec3 d = lp - p;
        float d2 = dot(d, d);
        float cos_l = abs(dot(ln, d)) / sqrt(d2);
        if (cos_l <= 0.0) return false;
        pdf_solid = d2 / (q.origin.w * cos_l);
        ls.skip = PRIM_REF(PRIM_QUAD, light.index);
        mat = q.material;
    } else {
        Triangle t = triangles[light.index];
        float area;
        sample_triangle(t, u, lp, ln, area);
        vec3 d = lp - p;
        float d2 = dot(d, d);
        float cos_l = abs(dot(ln, d)) / sqrt(d2);
        if (!(cos_l > 0.0 && area > 0.0)) return false;
        pdf_solid = d2 / (area * cos_l);
        ls.skip = PRIM_REF(PRIM_TRIANGLE, light.index);
        mat = t.material;
    }
    vec3 d = lp - p;
    float dist = length(d);
    if (!(dist > 0.0)) return false;
    ls.wi = d / dist;
    ls.dist = dist;
    ls.end = area_eps > 0.0 ? offset_origin(lp, ln, area_eps, -ls.wi) : lp;
    ls.le = emitted(mat, ln, -ls.wi);
    ls.pdf = pdf_solid * light.pmf;
    return ls.pdf > 0.0 && !isinf(ls.pdf);
}

// src/math/geometry.rs `light_pdf`: a function of (p, w) alone.
float light_pdf(uint light_index, vec3 p, vec3 w) {
    Light l = lights[light_index];
    float pdf_solid;
    uint kind = light_kind(l);
    if (kind == LIGHT_SPHERE) {
        vec4 cr = spheres[l.index].center_radius;
        float r = cr.w;
        vec3 f = p - cr.xyz;
        float dc2 = dot(f, f);
        if (dc2 > r * r * 1.0001) {
            pdf_solid = 1.0 / (2.0 * PI * one_minus_cos_max(r * r / dc2));
        } else {
            // Sampled by area: the point w reaches first (src/math/geometry.rs).
            float b = -dot(f, w);
            float l2 = length(f + b * w);
            float root = sqrt(max(0.0, (r - l2) * (r + l2)));
            bool outside = sqrt(dc2) - r > hit_epsilon(p, sphere_scale(cr));
            float t = outside ? b - root : b + root;
            if (!(t > 0.0)) return 0.0;
            vec3 n = (p + t * w - cr.xyz) / r;
            pdf_solid = t * t / (4.0 * PI * r * r * abs(dot(n, w)));
        }
    } else if (kind == LIGHT_QUAD) {
        Quad q = quads[l.index];
        float cos_l = dot(q.normal.xyz, w);
        float t = (q.normal.w - dot(q.normal.xyz, p)) / cos_l;
        if (!(t > 0.0)) return 0.0;
        pdf_solid = t * t / (q.origin.w * abs(cos_l));
    } else {
        Triangle tr = triangles[l.index];
        vec3 c = cross(tr.v1 - tr.v0, tr.v2 - tr.v0);
        float len = length(c);
        vec3 n = c / len;
        float cos_l = dot(n, w);
        float t = dot(n, tr.v0 - p) / cos_l;
        if (!(t > 0.0)) return 0.0;
        pdf_solid = t * t / (0.5 * len * abs(cos_l));
    }
    return pdf_solid * l.pmf;
}

#endif
