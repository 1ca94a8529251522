// PLACEHOLDER (replaced by the bvh branch): every primitive of the one leaf.
#ifndef RLPT_BVH_GLSL
#define RLPT_BVH_GLSL
float intersect_triangle(vec3 v0, vec3 v1, vec3 v2, vec3 o, vec3 d, float t_max) {
    vec3 e1 = v1 - v0, e2 = v2 - v0;
    vec3 p = cross(d, e2);
    float det = dot(e1, p);
    if (det == 0.0) return -1.0;
    float inv = 1.0 / det;
    vec3 s = o - v0;
    float u = dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) return -1.0;
    vec3 q = cross(s, e1);
    float v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    float t = dot(e2, q) * inv;
    return (t > 0.0 && t < t_max) ? t : -1.0;
}
float leaf_prim_t(uint r, vec3 o, vec3 d, float t_max) {
    uint k = r >> PRIM_KIND_SHIFT, i = r & PRIM_INDEX_MASK;
    if (k == PRIM_TRIANGLE) { Triangle tr = triangles[i]; return intersect_triangle(tr.v0, tr.v1, tr.v2, o, d, t_max); }
    if (k == PRIM_SPHERE) return intersect_sphere(spheres[i], o, d, t_max);
    return intersect_quad(quads[i], o, d, t_max);
}
bool bvh_closest(vec3 o, vec3 d, float t_max, out float t, out uint prim) {
    float best = t_max; prim = NO_PRIM;
    uint n = bvh_nodes[0].a_count;
    for (uint j = 0u; j < n; ++j) {
        uint r = prim_refs[j];
        float h = leaf_prim_t(r, o, d, best);
        if (h > 0.0) { best = h; prim = r; }
    }
    t = best;
    return prim != NO_PRIM;
}
bool bvh_occluded(vec3 o, vec3 d, float t_max, uint skip) {
    uint n = bvh_nodes[0].a_count;
    for (uint j = 0u; j < n; ++j) {
        uint r = prim_refs[j];
        if (r == skip) continue;
        uint k = r >> PRIM_KIND_SHIFT, i = r & PRIM_INDEX_MASK;
        if (k == PRIM_SPHERE) { if (sphere_blocks(spheres[i], o, d, t_max)) return true; }
        else if (leaf_prim_t(r, o, d, t_max) > 0.0) return true;
    }
    return false;
}
#endif
