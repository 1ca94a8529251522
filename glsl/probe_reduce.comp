#version 460
// Test kernel: the 64-sample reduction of pathtrace.comp (four components) on known inputs, and
// a check that subgroups are runs of consecutive invocation indices.
#extension GL_KHR_shader_subgroup_basic : require
#include "common.glsl"
#include "reduce.glsl"

layout(local_size_x = SAMPLES_X, local_size_y = SAMPLES_Y, local_size_z = PIXELS_PER_GROUP) in;

layout(std430, set = 0, binding = 0) readonly buffer Inputs { vec4 values[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Sums { vec4 sums[]; };
// info[0]: subgroup size seen by the kernel; info[1]: invocations whose subgroup
// position disagrees with gl_LocalInvocationIndex.
layout(std430, set = 0, binding = 2) buffer Info { uint info[]; };

void main() {
    uint group_size = uint(SAMPLES_PER_FRAME * PIXELS_PER_GROUP);
    uint invocation = gl_WorkGroupID.x * group_size + gl_LocalInvocationIndex;
    vec4 sum = reduce_pixel_sum4(values[invocation]);
    uint pixel = gl_WorkGroupID.x * uint(PIXELS_PER_GROUP) + gl_LocalInvocationID.z;
    if (gl_LocalInvocationIndex % uint(SAMPLES_PER_FRAME) == 0u) sums[pixel] = sum;
    if (gl_SubgroupID * gl_SubgroupSize + gl_SubgroupInvocationID != gl_LocalInvocationIndex) atomicAdd(info[1], 1u);
    if (invocation == 0u) info[0] = gl_SubgroupSize;
}
