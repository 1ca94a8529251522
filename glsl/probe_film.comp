#version 460
// Test kernel: film.glsl's compensated sum. Invocation i adds terms push.first to
// push.first + push.count - 1, a base of its own wobbling by a thousandth, to the
// sum and carry it holds, by kahan_add (src/film.rs `kahan_add` must match).
// Dispatched again and again for many terms: lavapipe ends a shader's loop after
// 65535 iterations.
#include "common.glsl"
#include "film.glsl"

layout(local_size_x = 8) in;
layout(std430, set = 0, binding = 0) buffer State { vec4 state[]; };
layout(push_constant) uniform Push { uint first; uint count; uint invocations; } push;

// The k-th term of invocation i (tests/gpu_probes.rs computes the same): exact
// in f32, so that both devices add the same terms whatever they fuse.
vec3 probe_term(uint i, uint k) {
    float wobble = 1.0 + (float(k % 7u) - 3.0) / 4096.0;
    return vec3(23.6875, 11.125, 40.3125) * (float(i + 1u) * wobble);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.invocations) return;
    vec3 sum = state[2u * i].xyz;
    vec3 carry = state[2u * i + 1u].xyz;
    for (uint k = push.first; k < push.first + push.count; ++k) kahan_add(sum, carry, probe_term(i, k));
    state[2u * i] = vec4(sum, 0.0);
    state[2u * i + 1u] = vec4(carry, 0.0);
}
