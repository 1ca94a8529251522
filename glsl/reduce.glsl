// Sum of a value over the 64 invocations (the samples) of each pixel of the
// workgroup, for any subgroup size. Subgroup shuffles do the work inside a
// subgroup; where the subgroup is smaller than 64, its partial sums meet in
// shared memory. Assumes subgroups are runs of consecutive
// gl_LocalInvocationIndex (what every Vulkan driver does for compute; the
// probe kernel probe_reduce.comp checks it on the device at hand).
// Every invocation of the workgroup must call it (it contains a barrier).
#ifndef RLPT_REDUCE_GLSL
#define RLPT_REDUCE_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle : require
#include "common.glsl"

// Sized for the largest group (PIXELS_PER_GROUP pixels; the unguided kernel's
// groups are smaller and use the front of it).
shared vec4 reduce_partial[PIXELS_PER_GROUP * SAMPLES_PER_FRAME];

// Returns the pixel's sum in the invocation whose sample index is 0; other
// invocations get a partial sum.
vec4 reduce_pixel_sum4(vec4 v) {
    uint lanes = min(gl_SubgroupSize, uint(SAMPLES_PER_FRAME));
    for (uint offset = 1u; offset < lanes; offset <<= 1u) {
        v += subgroupShuffleXor(v, offset);
    }
    if (gl_SubgroupSize >= uint(SAMPLES_PER_FRAME)) {
        return v;
    }
    if (gl_SubgroupInvocationID == 0u) {
        reduce_partial[gl_LocalInvocationIndex / lanes] = v;
    }
    barrier();
    vec4 total = vec4(0.0);
    uint blocks = uint(SAMPLES_PER_FRAME) / lanes;
    uint first = gl_LocalInvocationID.z * blocks;
    if (gl_LocalInvocationIndex % uint(SAMPLES_PER_FRAME) == 0u) {
        for (uint k = 0u; k < blocks; ++k) total += reduce_partial[first + k];
    }
    return total;
}

// The same for three components.
vec3 reduce_pixel_sum(vec3 v) {
    return reduce_pixel_sum4(vec4(v, 0.0)).xyz;
}

#endif
