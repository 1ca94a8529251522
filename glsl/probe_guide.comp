#version 460
// Test kernel: the guided sampler of guide.glsl on a sampling row from the host.
// Input per sample: (uc, u.x, u.y); output: (direction, guided_pdf there).
#extension GL_KHR_shader_subgroup_basic : require
#include "common.glsl"
#include "guide.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 10) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 11) writeonly buffer Outputs { vec4 outputs[]; };
layout(push_constant) uniform Push { uint count; } push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    vec4 x = inputs[i];
    uint b;
    vec3 d = guided_direction(0u, x.x, x.yz, b);
    outputs[i] = vec4(d, guided_pdf(0u, d));
}
