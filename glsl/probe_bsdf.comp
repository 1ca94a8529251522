#version 460
// Test kernel: runs the GLSL BSDF on inputs from the host. Mode 0 samples
// (input: uc, u.x, u.y), mode 1 evaluates f and pdf (input: wi). Two vec4
// results per input: sample -> (wi, ok), (weight, pdf); eval -> (f, pdf), 0.
// k.w is a coated material's base_alpha.
#include "common.glsl"
#include "bsdf.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Outputs { vec4 outputs[]; };
layout(push_constant) uniform Push {
    vec4 albedo;
    vec4 wo;
    vec4 eta;
    vec4 k;
    uint kind;
    uint mode;
    float alpha;
    float ior;
    uint count;
} push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    Bsdf b;
    b.kind = push.kind;
    b.albedo = push.albedo.xyz;
    b.alpha = push.alpha;
    b.ior = push.ior;
    b.eta = push.eta.xyz;
    b.k = push.k.xyz;
    b.base_alpha = push.k.w;
    vec4 x = inputs[i];
    if (push.mode == 0u) {
        BsdfSample s = bsdf_sample(b, push.wo.xyz, x.x, x.yz);
        outputs[2u * i] = vec4(s.wi, s.ok ? 1.0 : 0.0);
        outputs[2u * i + 1u] = vec4(s.weight, s.pdf);
    } else {
        outputs[2u * i] = vec4(bsdf_eval(b, push.wo.xyz, x.xyz), bsdf_pdf(b, push.wo.xyz, x.xyz));
        outputs[2u * i + 1u] = vec4(0.0);
    }
}
