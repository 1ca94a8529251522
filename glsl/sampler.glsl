// Samplers: the random numbers of a path, by dimension (src/math/sampler.rs,
// same code). The includer declares `const bool SAMPLER_SOBOL` (or a macro):
// Owen-scrambled Sobol points where true, the hashed PCG streams of rng.glsl
// otherwise. docs/sampling.md describes both and the dimension layout.
#ifndef RLPT_SAMPLER_GLSL
#define RLPT_SAMPLER_GLSL
#include "rng.glsl"

// Sobol dimension 1 of point `index` before bit reversal (dimension 0's is the
// index itself, van der Corput): digit r (bit r, the most significant once
// reversed) is the XOR of the index bits k whose binomial C(k, r) is odd, those
// k that hold r's bits (Pascal's matrix mod 2, Joe & Kuo's d = 2).
uint sobol_digits_1(uint index) {
    uint y = index;
    y ^= (y >> 1u) & 0x55555555u;
    y ^= (y >> 2u) & 0x33333333u;
    y ^= (y >> 4u) & 0x0f0f0f0fu;
    y ^= (y >> 8u) & 0x00ff00ffu;
    y ^= (y >> 16u) & 0x0000ffffu;
    return y;
}

// Burley's Laine-Karras style hash: a random permutation in which each bit is
// flipped by a function of the bits below it only.
uint laine_karras_permutation(uint x, uint seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Owen's nested uniform scrambling in base 2 (Burley 2020): each bit flipped by
// a hash of the more significant bits.
uint nested_uniform_scramble(uint x, uint seed) {
    return bitfieldReverse(laine_karras_permutation(bitfieldReverse(x), seed));
}

// A seed for `v` of `seed`'s (one hash: the multiplier spreads small v over the word).
uint hash_combine(uint seed, uint v) {
    return pcg_hash(seed ^ ((v + 1u) * 0x9e3779b9u));
}

// src/cpu/passes.rs `pass_sample`: the sample index that pass (or lane) `pass`
// of a frame cut short traces in `pixel`: the passes go through the 64 indices
// from one drawn per pixel and frame, so that each lands anywhere in the pixel.
uint pass_sample(uint seed, uint pixel, uint rng_frame, uint pass) {
    uint first = hash_combine(hash_combine(pcg_hash(seed ^ 0x85ebca6bu), pixel), rng_frame);
    return (first + pass) % uint(SAMPLES_PER_FRAME);
}

// The path's sampler. Independent: `state` is the PCG stream of rng_init and the
// dimension is ignored (numbers come in the order drawn). Sobol: `state` is the
// pixel's seed and `index` the sample's place in the pixel's sequence.
struct PathSampler {
    uint state;
    uint index;
};

// The sampler of sample `sample_index` (0..SAMPLES_PER_FRAME) of `pixel` in `frame`:
// a frame continues its pixel's Sobol sequence where the previous one stopped.
PathSampler sampler_init(uint seed, uint pixel, uint frame, uint sample_index) {
    PathSampler s;
    if (SAMPLER_SOBOL) {
        s.state = hash_combine(pcg_hash(seed ^ 0x9e3779b9u), pixel);
        s.index = frame * uint(SAMPLES_PER_FRAME) + sample_index;
    } else {
        s.state = rng_init(seed, pixel, frame, sample_index);
        s.index = 0u;
    }
    return s;
}

// Dimension `slot` (SAMPLE_*) of the vertex of depth `depth`.
uint bounce_dim(uint depth, uint slot) {
    return SAMPLER_BOUNCE_BASE + depth * uint(SAMPLER_BOUNCE_DIMS) + slot;
}

// Owen-scrambled Sobol (Burley 2020), padded: each 1D or 2D sample `dim` is a
// block of its own, with a seed from the pixel's and `dim`, which shuffles the
// index (nested uniform scrambling of its reversed bits: aligned runs of 2^k
// indices map onto aligned runs, so each pixel's prefixes stay nets) and scrambles each
// dimension. Both scrambles work on the digits before the last reversal.
uint sobol_shuffled_index(PathSampler s, uint dim, out uint block_seed) {
    block_seed = hash_combine(s.state, dim);
    return nested_uniform_scramble(s.index, block_seed);
}

uint sobol_owen(uint digits, uint block_seed, uint component) {
    return bitfieldReverse(laine_karras_permutation(digits, hash_combine(block_seed, component)));
}

// The top 23 bits as a float in [0, 1) (rng_next's conversion).
float bits_to_unit(uint x) {
    return uintBitsToFloat(0x3f800000u | (x >> 9u)) - 1.0;
}

float sample_1d(inout PathSampler s, uint dim) {
    if (!SAMPLER_SOBOL) return rng_next(s.state);
    uint seed;
    uint i = sobol_shuffled_index(s, dim, seed);
    return bits_to_unit(sobol_owen(i, seed, 0u));
}

// Dimensions dim and dim + 1: one 2D sample.
vec2 sample_2d(inout PathSampler s, uint dim) {
    if (!SAMPLER_SOBOL) return rng_next_2d(s.state);
    uint seed;
    uint i = sobol_shuffled_index(s, dim, seed);
    return vec2(bits_to_unit(sobol_owen(i, seed, 0u)), bits_to_unit(sobol_owen(sobol_digits_1(i), seed, 1u)));
}

// Where in the pixel a sample looks ([0, 1)^2): an independent sample takes its
// own of the SAMPLES_X x SAMPLES_Y sub-squares, `stratum`, jittered
// (src/math/sampler.rs `pixel_jitter`); Sobol's points are stratified already.
vec2 sample_pixel(inout PathSampler s, uvec2 stratum) {
    vec2 j = sample_2d(s, SAMPLE_CAMERA);
    return SAMPLER_SOBOL ? j : (vec2(stratum) + j) / vec2(SAMPLES_X, SAMPLES_Y);
}

#endif
