#version 460
// Test kernel: the image environment's GLSL sampler and lookup (envmap.glsl) on
// inputs from the host. Per input (u.x, u.y, dx, dy; dz in the second vec4's x):
// env_sample(u) -> (wi, ok), (le, pdf); env_lookup(d) -> (le, pdf).
#include "common.glsl"
#include "envmap.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 30) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 31) writeonly buffer Outputs { vec4 outputs[]; };
layout(push_constant) uniform Push { uint count; } push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    vec4 a = inputs[2u * i];
    vec4 b = inputs[2u * i + 1u];
    vec3 wi, le;
    float pdf;
    bool ok = env_sample(a.xy, wi, le, pdf);
    outputs[3u * i] = vec4(wi, ok ? 1.0 : 0.0);
    outputs[3u * i + 1u] = vec4(le, pdf);
    float pdf_l;
    vec3 le_l = env_lookup(vec3(a.zw, b.x), pdf_l);
    outputs[3u * i + 2u] = vec4(le_l, pdf_l);
}
