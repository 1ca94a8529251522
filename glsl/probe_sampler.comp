#version 460
// Test kernel: the samplers of sampler.glsl. Invocation i takes the sampler of
// (push.seed, pixel i, push.frame, sample i % 64), Sobol where push.sobol is 1,
// and writes, as bits, its pixel sample and dimensions of vertices 0, 3 and 7
// (src/math/sampler.rs must match).
#include "common.glsl"
layout(push_constant) uniform Push { uint count; uint seed; uint frame; uint sobol; } push;
#define SAMPLER_SOBOL (push.sobol != 0u)
#include "sampler.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) writeonly buffer Outputs { uvec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    uint sample_index = i % 64u;
    PathSampler s = sampler_init(push.seed, i, push.frame, sample_index);
    vec2 pix = sample_pixel(s, uvec2(sample_index % uint(SAMPLES_X), sample_index / uint(SAMPLES_X)));
    float sel = sample_1d(s, bounce_dim(0u, SAMPLE_LIGHT_SELECT));
    vec2 light = sample_2d(s, bounce_dim(0u, SAMPLE_LIGHT));
    float rr = sample_1d(s, bounce_dim(3u, SAMPLE_ROULETTE));
    vec2 dir = sample_2d(s, bounce_dim(7u, SAMPLE_DIRECTION));
    outputs[2u * i] = floatBitsToUint(vec4(pix, sel, light.x));
    outputs[2u * i + 1u] = floatBitsToUint(vec4(light.y, rr, dir));
}
