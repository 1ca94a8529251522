#version 460
// Test kernel: bvh_closest and bvh_occluded (bvh.glsl) on a batch of rays, so
// tests/bvh_gpu.rs can compare them with their twins in src/math/bvh.rs.
#include "bvh.glsl"

layout(local_size_x = 64) in;
// The occlusion test asks about the segment (0, t_max), leaving out skip.
struct ProbeRay {
    vec3 o;
    float t_max;
    vec3 d;
    uint skip;
};
layout(std430, set = 0, binding = 20) readonly buffer Rays { ProbeRay rays[]; };
// Per ray: the closest hit's t (bits) and prim ref, and whether the segment is occluded.
layout(std430, set = 0, binding = 21) writeonly buffer Results { uvec4 results[]; };
layout(push_constant) uniform Push { uint count; } push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    ProbeRay r = rays[i];
    float t;
    uint prim;
    bool hit = bvh_closest(r.o, r.d, 1.0 / 0.0, t, prim);
    bool blocked = bvh_occluded(r.o, r.d, r.t_max, r.skip);
    results[i] = uvec4(hit ? floatBitsToUint(t) : 0u, hit ? prim : NO_PRIM, blocked ? 1u : 0u, 0u);
}
