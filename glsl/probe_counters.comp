#version 460
// Test kernel: every invocation adds its value to one 64-bit counter pair through
// counters.glsl; the values sum far past 2^32, and the host checks the total.
layout(local_size_x = 256) in;
layout(std430, set = 0, binding = 0) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 1) buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { uint count; } push;

#include "counters.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < push.count) counter_add64(0u, values[i]);
}
