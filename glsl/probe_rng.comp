#version 460
// Test kernel: the random-number streams of rng.glsl. Invocation i takes the
// stream of (push.seed, pixel i, push.frame, sample i % 64) and writes, as bits,
// rng_next_u32 and then seven rng_next floats (src/math/rng.rs must match).
#include "common.glsl"
#include "rng.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) writeonly buffer Outputs { uvec4 outputs[]; };
layout(push_constant) uniform Push { uint count; uint seed; uint frame; } push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    uint state = rng_init(push.seed, i, push.frame, i % 64u);
    uint u = rng_next_u32(state);
    uvec4 a = uvec4(u, floatBitsToUint(rng_next(state)), floatBitsToUint(rng_next(state)), floatBitsToUint(rng_next(state)));
    vec2 p = rng_next_2d(state);
    uvec4 b = uvec4(floatBitsToUint(p.x), floatBitsToUint(p.y), floatBitsToUint(rng_next(state)), floatBitsToUint(rng_next(state)));
    outputs[2u * i] = a;
    outputs[2u * i + 1u] = b;
}
