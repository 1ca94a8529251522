#version 460
// Test kernel: the guided sampler of guide.glsl on a sampling row from the host.
// Input per sample: (uc, u.x, u.y); output: (direction, pdf of the bin drawn);
// the second output: guided_pdf evaluated at that direction.
#extension GL_KHR_shader_subgroup_basic : require
#include "common.glsl"
#include "guide.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 10) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 11) writeonly buffer Outputs { vec4 outputs[]; };
layout(std430, set = 0, binding = 12) writeonly buffer Pdfs { float pdfs[]; };
layout(push_constant) uniform Push { uint count; } push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    vec4 x = inputs[i];
    float pdf;
    vec3 d = guided_sample(0u, x.x, x.yz, pdf);
    outputs[i] = vec4(d, pdf);
    pdfs[i] = guided_pdf(0u, d);
}
