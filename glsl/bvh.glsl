// The BVH walk and the watertight triangle test: src/math/bvh.rs and
// src/math/triangle.rs, the same algorithm, child order and tests.
#ifndef RLPT_BVH_GLSL
#define RLPT_BVH_GLSL
#include "scene.glsl"
#include "primitives.glsl"
#extension GL_EXT_control_flow_attributes : require

// src/math/bvh.rs `EXIT_SCALE` (a box's exit distance, scaled so that rounding,
// the reciprocal's 2.5 ulp included, never culls a box the ray meets; Ize 2013)
// and `MIN_DIR` (direction components below it are taken as it before 1 / d).
const float BVH_EXIT_SCALE = 1.0 + 1.0 / 524288.0;
const float BVH_MIN_DIR = 1e-30;

// src/math/triangle.rs `TriangleRay`: the ray of the watertight test (Woop,
// Benthin, Wald 2013), its axes permuted so that d's largest component is z
// (kz; kx, ky follow cyclically) and its shear. Two-sided, so the paper's swap
// of kx and ky where d[kz] < 0 is left out.
struct TriangleRay {
    uint kz;
    vec3 o;      // the origin, permuted
    vec3 s;      // d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]
};

vec3 wt_permute(vec3 v, uint kz) { return kz == 0u ? v.yzx : (kz == 1u ? v.zxy : v); }

TriangleRay triangle_ray(vec3 o, vec3 d) {
    vec3 a = abs(d);
    uint kz = (a.x >= a.y && a.x >= a.z) ? 0u : (a.y >= a.z ? 1u : 2u);
    vec3 dp = wt_permute(d, kz);
    TriangleRay r;
    r.kz = kz;
    r.o = wt_permute(o, kz);
    r.s = vec3(dp.x / dp.z, dp.y / dp.z, 1.0 / dp.z);
    return r;
}

// a * b - round(a * b), exactly: Dekker's product with Veltkamp's split, which
// needs only correctly rounded * and - (Vulkan lets fma() round twice).
float product_error(float a, float b) {
    precise float p = a * b;
    precise float ca = 4097.0 * a;
    precise float cb = 4097.0 * b;
    precise float ah = ca - (ca - a);
    precise float bh = cb - (cb - b);
    precise float al = a - ah;
    precise float bl = b - bh;
    precise float e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    return e;
}

// src/math/triangle.rs `edge_function`: a.x b.y - a.y b.x, recomputed where it
// rounds to 0. The two products then round to the same float, so the exact
// value is the difference of their rounding errors: rounded once, it is the
// f64 result the Rust rounds to f32. precise: no fusing, so the function of an
// edge is exactly the negation of its neighbour's (watertightness).
float edge_function(vec2 a, vec2 b) {
    precise float e = a.x * b.y - a.y * b.x;
    if (e != 0.0) return e;
    precise float x = product_error(a.x, b.y) - product_error(a.y, b.x);
    return x;
}

// src/math/triangle.rs `TriangleRay::intersect`: t in (0, t_max) of a hit from
// either side, or -1.
float triangle_hit(TriangleRay r, vec3 v0, vec3 v1, vec3 v2, float t_max) {
    vec3 a = wt_permute(v0, r.kz) - r.o;
    vec3 b = wt_permute(v1, r.kz) - r.o;
    vec3 c = wt_permute(v2, r.kz) - r.o;
    // The sheared vertices: the same bits for a vertex in every triangle.
    precise vec2 sa = vec2(a.x - r.s.x * a.z, a.y - r.s.y * a.z);
    precise vec2 sb = vec2(b.x - r.s.x * b.z, b.y - r.s.y * b.z);
    precise vec2 sc = vec2(c.x - r.s.x * c.z, c.y - r.s.y * c.z);
    float u = edge_function(sc, sb);
    float v = edge_function(sa, sc);
    float w = edge_function(sb, sa);
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return -1.0;
    float det = u + v + w;
    if (det == 0.0) return -1.0;
    float t = (u * (r.s.z * a.z) + v * (r.s.z * b.z) + w * (r.s.z * c.z)) / det;
    return (t > 0.0 && t < t_max) ? t : -1.0;
}

// src/math/triangle.rs `intersect_triangle`: -1 on a miss, as the sphere and quad tests.
float intersect_triangle(vec3 v0, vec3 v1, vec3 v2, vec3 o, vec3 d, float t_max) {
    return triangle_hit(triangle_ray(o, d), v0, v1, v2, t_max);
}

// src/math/bvh.rs `WalkRay`.
struct WalkRay {
    vec3 o;
    vec3 d;
    vec3 inv_d;
    TriangleRay tri;
};

WalkRay walk_ray(vec3 o, vec3 d) {
    WalkRay r;
    r.o = o;
    r.d = d;
    vec3 safe = mix(d, mix(vec3(BVH_MIN_DIR), vec3(-BVH_MIN_DIR), lessThan(d, vec3(0.0))),
                    lessThan(abs(d), vec3(BVH_MIN_DIR)));
    r.inv_d = 1.0 / safe;
    r.tri = triangle_ray(o, d);
    return r;
}

// src/math/bvh.rs `WalkRay::children`: the slab test of node n's four boxes
// against (0, t_max), the exits scaled by BVH_EXIT_SCALE so that rounding never
// culls a box the ray meets; the children entered, nearest first where sorted (a
// sorting network) else in slot order, with their entry distances; a slot not
// entered is (+inf, BVH_EMPTY).
// The near plane is the low one where the direction is positive: an inverted
// (empty) box is entered at +inf, left at -inf; on a box, the min and the max.
void bvh_children(WalkRay r, BvhNode n, float t_max, const bool sorted, out vec4 enter, out uvec4 child,
                  out uvec4 count) {
    bvec3 neg = lessThan(r.inv_d, vec3(0.0));
    vec4 nx = ((neg.x ? n.hi_x : n.lo_x) - r.o.x) * r.inv_d.x;
    vec4 fx = ((neg.x ? n.lo_x : n.hi_x) - r.o.x) * r.inv_d.x;
    vec4 ny = ((neg.y ? n.hi_y : n.lo_y) - r.o.y) * r.inv_d.y;
    vec4 fy = ((neg.y ? n.lo_y : n.hi_y) - r.o.y) * r.inv_d.y;
    vec4 nz = ((neg.z ? n.hi_z : n.lo_z) - r.o.z) * r.inv_d.z;
    vec4 fz = ((neg.z ? n.lo_z : n.hi_z) - r.o.z) * r.inv_d.z;
    vec4 e = max(max(nx, ny), max(nz, vec4(0.0)));
    vec4 x = min(min(fx, fy), min(fz, vec4(t_max))) * BVH_EXIT_SCALE;
    bvec4 in_box = lessThanEqual(e, x);
    enter = mix(vec4(uintBitsToFloat(0x7f800000u)), e, in_box);
    child = mix(uvec4(BVH_EMPTY), n.child, in_box);
    count = n.count;
#define BVH_ORDER(i, j) if (enter[j] < enter[i]) { \
        float te = enter[i]; enter[i] = enter[j]; enter[j] = te; \
        uint tc = child[i]; child[i] = child[j]; child[j] = tc; \
        tc = count[i]; count[i] = count[j]; count[j] = tc; }
    // One child or none entered: nothing to order.
    if (sorted && bitCount(uint(in_box.x) | uint(in_box.y) << 1 | uint(in_box.z) << 2 | uint(in_box.w) << 3) > 1) {
        BVH_ORDER(0, 1) BVH_ORDER(2, 3) BVH_ORDER(0, 2) BVH_ORDER(1, 3) BVH_ORDER(1, 2)
    }
#undef BVH_ORDER
}

// src/math/bvh.rs `WalkRay::prim_t`: the distance to primitive ref in (0, t_max), or -1.
float bvh_prim_t(WalkRay r, uint ref, float t_max) {
    uint kind = ref >> PRIM_KIND_SHIFT;
    uint i = ref & PRIM_INDEX_MASK;
    if (kind == PRIM_TRIANGLE) {
        Triangle tr = triangles[i];
        return triangle_hit(r.tri, tr.v0, tr.v1, tr.v2, t_max);
    }
    if (kind == PRIM_SPHERE) return intersect_sphere(spheres[i], r.o, r.d, t_max);
    return intersect_quad(quads[i], r.o, r.d, t_max);
}

// src/math/bvh.rs `WalkRay::prim_blocks`: spheres by sphere_blocks.
bool bvh_prim_blocks(WalkRay r, uint ref, float t_max) {
    uint kind = ref >> PRIM_KIND_SHIFT;
    if (kind == PRIM_SPHERE) return sphere_blocks(spheres[ref & PRIM_INDEX_MASK], r.o, r.d, t_max);
    return bvh_prim_t(r, ref, t_max) > 0.0;
}

// src/math/bvh.rs `WalkRay::leaf`: the leaf of count references from first in
// prim_refs. any_hit: whether one but skip blocks (0, best); else best and prim
// brought to its nearest hit nearer than best, and false.
bool bvh_leaf(WalkRay r, uint first, uint count, uint skip, const bool any_hit, inout float best, inout uint prim) {
    for (uint j = first; j < first + count; ++j) {
        uint ref = prim_refs[j];
        if (any_hit) {
            if (ref != skip && bvh_prim_blocks(r, ref, best)) return true;
        } else {
            float h = bvh_prim_t(r, ref, best);
            if (h > 0.0) { best = h; prim = ref; }
        }
    }
    return false;
}

// src/math/bvh.rs `walk`: with any_hit false, the nearest primitive in
// (0, t_max), its distance t and reference prim; with any_hit true, whether
// anything but the primitive skip blocks (0, t_max) (the first blocker ends the
// walk). Callers pass any_hit as a constant: the inlined walk keeps only its own
// tests. Each node is read once; the leaves the ray enters are tested there, the
// nearer first; of the interior children it enters, the walk goes on with the
// nearest and pushes the others, farthest first. The BVH has a node at least
// (callers walk it where params.bvh_nodes > 0).
bool bvh_walk(vec3 o, vec3 d, float t_max, uint skip, const bool any_hit, out float t, out uint prim) {
    WalkRay r = walk_ray(o, d);
    float best = t_max;
    prim = NO_PRIM;
    uint stack[BVH_STACK];
    uint sp = 0u;
    uint node = 0u;
    while (true) {
        vec4 enter;
        uvec4 child, count;
        // Shadow rays take the children in slot order (src/math/bvh.rs `walk`).
        bvh_children(r, bvh_nodes[node], best, !any_hit, enter, child, count);
        // The leaves entered, nearer first, by a mask of their slots: the leaf
        // test is inlined once. A leaf before may bring best nearer than the
        // children after it (not with any_hit, whose best stays t_max, which the
        // slab test bounds).
        uint leaves = 0u;
        for (uint k = 0u; k < 4u; ++k) {
            if (child[k] != BVH_EMPTY && (child[k] & BVH_LEAF) != 0u) leaves |= 1u << k;
        }
        [[dont_unroll]] while (leaves != 0u) {
            uint k = uint(findLSB(leaves));
            leaves &= leaves - 1u;
            if (!any_hit && enter[k] > best * BVH_EXIT_SCALE) continue;
            if (bvh_leaf(r, child[k] & ~BVH_LEAF, count[k], skip, any_hit, best, prim)) {
                t = best;
                return true;
            }
        }
        // The interior children, farthest first: all but the nearest pushed
        // (BVH_EMPTY has the leaf bit).
        uint next = BVH_EMPTY;
        for (int k = 3; k >= 0; --k) {
            if ((child[k] & BVH_LEAF) != 0u) continue;
            if (!any_hit && enter[k] > best * BVH_EXIT_SCALE) continue;
            if (next != BVH_EMPTY) stack[sp++] = next;
            next = child[k];
        }
        if (next != BVH_EMPTY) {
            node = next;
        } else if (sp == 0u) {
            break;
        } else {
            node = stack[--sp];
        }
    }
    t = best;
    return prim != NO_PRIM;
}

// src/math/bvh.rs `closest_hit`: the nearest primitive in (0, t_max), its
// distance t and reference prim.
bool bvh_closest(vec3 o, vec3 d, float t_max, out float t, out uint prim) {
    return bvh_walk(o, d, t_max, NO_PRIM, false, t, prim);
}

// src/math/bvh.rs `occluded`: whether anything but the primitive skip (a
// reference, or NO_PRIM) blocks the segment (0, t_max).
bool bvh_occluded(vec3 o, vec3 d, float t_max, uint skip) {
    float t;
    uint prim;
    return bvh_walk(o, d, t_max, skip, true, t, prim);
}

#endif
