// Random numbers: src/math/rng.rs, same code.
#ifndef RLPT_RNG_GLSL
#define RLPT_RNG_GLSL

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

uint rng_init(uint seed, uint pixel, uint frame, uint sample_index) {
    uint h = pcg_hash(seed ^ 0x9e3779b9u);
    h = pcg_hash(h ^ pixel);
    h = pcg_hash(h ^ (frame * 0x85ebca6bu));
    return pcg_hash(h ^ (sample_index * 0xc2b2ae35u));
}

uint rng_next_u32(inout uint state) {
    state = state * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1): 23 random bits as the mantissa of a float in [1, 2), minus 1
// (no integer-to-float conversion, which GPUs run at a fraction of the rate).
float rng_next(inout uint state) {
    return uintBitsToFloat(0x3f800000u | (rng_next_u32(state) >> 9u)) - 1.0;
}

vec2 rng_next_2d(inout uint state) {
    float a = rng_next(state);
    return vec2(a, rng_next(state));
}

// src/math/rng.rs `mix_hash`: a number in [0, 1) hashed from a hit point, the
// direction wo and a mix's index (pbrt-v4's HashFloat), so that every evaluation
// at a vertex sees the same choice, and no sampler dimension is taken.
float mix_hash(vec3 p, vec3 wo, uint mat) {
    uvec3 a = floatBitsToUint(p), b = floatBitsToUint(wo);
    uint h = pcg_hash(mat ^ 0x2545f491u);
    h = pcg_hash(h ^ a.x);
    h = pcg_hash(h ^ a.y);
    h = pcg_hash(h ^ a.z);
    h = pcg_hash(h ^ b.x);
    h = pcg_hash(h ^ b.y);
    h = pcg_hash(h ^ b.z);
    return uintBitsToFloat(0x3f800000u | (h >> 9u)) - 1.0;
}

#endif
