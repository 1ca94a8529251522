#version 460
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_EXT_shader_atomic_float : require
#ifdef RLPT_PARTITIONED
#extension GL_NV_shader_subgroup_partitioned : require
#endif
// Test kernel: many lanes record targets for few keys through the subgroup-
// aggregated atomics of guide.glsl; the host checks the sums and counts exactly.
#include "common.glsl"
#include "rng.glsl"

layout(local_size_x = 256) in;
layout(std430, set = 0, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) readonly buffer Targets { float targets[]; };
layout(std430, set = 0, binding = 2) buffer FrameSums { float frame_sums[]; };
layout(std430, set = 0, binding = 3) buffer FrameCounts { uint frame_counts[]; };
layout(push_constant) uniform Push { uint count; } push;

#include "record.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    // Lanes leave early in an irregular pattern, as paths end at different depths.
    if (i >= push.count || (pcg_hash(i) & 7u) == 0u) return;
    record_target(keys[i], targets[i]);
}
