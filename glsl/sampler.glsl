// Samplers: the random numbers of a path, by dimension (src/math/sampler.rs,
// same code). The includer declares `const bool SAMPLER_SOBOL` (or a macro):
// Owen-scrambled Sobol points where true, the hashed PCG streams of rng.glsl
// otherwise. docs/sampling.md describes both and the dimension layout.
#ifndef RLPT_SAMPLER_GLSL
#define RLPT_SAMPLER_GLSL
#include "rng.glsl"

// Sobol generator matrices of the first SOBOL_BLOCK_DIMS dimensions, 32 columns
// each: van der Corput, then Joe & Kuo's direction numbers (new-joe-kuo-6.21201,
// d = 2..4). src/math/sampler.rs `SOBOL_MATRICES` derives the same from (s, a, m).
const uint SOBOL_MATRICES[SOBOL_BLOCK_DIMS * 32] = uint[](
    0x80000000u, 0x40000000u, 0x20000000u, 0x10000000u, 0x08000000u, 0x04000000u, 0x02000000u, 0x01000000u, 0x00800000u, 0x00400000u, 0x00200000u, 0x00100000u, 0x00080000u, 0x00040000u, 0x00020000u, 0x00010000u, 0x00008000u, 0x00004000u, 0x00002000u, 0x00001000u, 0x00000800u, 0x00000400u, 0x00000200u, 0x00000100u, 0x00000080u, 0x00000040u, 0x00000020u, 0x00000010u, 0x00000008u, 0x00000004u, 0x00000002u, 0x00000001u,
    0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u, 0x88000000u, 0xcc000000u, 0xaa000000u, 0xff000000u, 0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u, 0x88880000u, 0xcccc0000u, 0xaaaa0000u, 0xffff0000u, 0x80008000u, 0xc000c000u, 0xa000a000u, 0xf000f000u, 0x88008800u, 0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u, 0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u, 0x88888888u, 0xccccccccu, 0xaaaaaaaau, 0xffffffffu,
    0x80000000u, 0xc0000000u, 0x60000000u, 0x90000000u, 0xe8000000u, 0x5c000000u, 0x8e000000u, 0xc5000000u, 0x68800000u, 0x9cc00000u, 0xee600000u, 0x55900000u, 0x80680000u, 0xc09c0000u, 0x60ee0000u, 0x90550000u, 0xe8808000u, 0x5cc0c000u, 0x8e606000u, 0xc5909000u, 0x6868e800u, 0x9c9c5c00u, 0xeeee8e00u, 0x5555c500u, 0x8000e880u, 0xc0005cc0u, 0x60008e60u, 0x9000c590u, 0xe8006868u, 0x5c009c9cu, 0x8e00eeeeu, 0xc5005555u,
    0x80000000u, 0xc0000000u, 0x20000000u, 0x50000000u, 0xf8000000u, 0x74000000u, 0xa2000000u, 0x93000000u, 0xd8800000u, 0x25400000u, 0x59e00000u, 0xe6d00000u, 0x78080000u, 0xb40c0000u, 0x82020000u, 0xc3050000u, 0x208f8000u, 0x51474000u, 0xfbea2000u, 0x75d93000u, 0xa0858800u, 0x914e5400u, 0xdbe79e00u, 0x25db6d00u, 0x58800080u, 0xe54000c0u, 0x79e00020u, 0xb6d00050u, 0x800800f8u, 0xc00c0074u, 0x200200a2u, 0x50050093u);

// Sobol point `index` in dimension `dim` (< SOBOL_BLOCK_DIMS), as 32 fixed-point bits.
uint sobol(uint index, uint dim) {
    uint x = 0u;
    for (uint bit = 0u; bit < 32u; bit++) {
        x ^= SOBOL_MATRICES[dim * 32u + bit] & (0u - ((index >> bit) & 1u));
    }
    return x;
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

uint hash_combine(uint seed, uint v) {
    return pcg_hash(seed ^ pcg_hash(v + 0x9e3779b9u));
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

// Owen-scrambled Sobol: dimension `dim` is component dim % SOBOL_BLOCK_DIMS of a
// Sobol point whose block (dim / SOBOL_BLOCK_DIMS) has its own seed, which
// shuffles the index (so blocks and pixels are decorrelated) and scrambles each component.
uint sobol_block_seed(PathSampler s, uint dim) {
    return hash_combine(s.state, dim / uint(SOBOL_BLOCK_DIMS));
}

uint sobol_owen(uint shuffled, uint block_seed, uint component) {
    return nested_uniform_scramble(sobol(shuffled, component), hash_combine(block_seed, component));
}

// The top 23 bits as a float in [0, 1) (rng_next's conversion).
float bits_to_unit(uint x) {
    return uintBitsToFloat(0x3f800000u | (x >> 9u)) - 1.0;
}

float sample_1d(inout PathSampler s, uint dim) {
    if (!SAMPLER_SOBOL) return rng_next(s.state);
    uint seed = sobol_block_seed(s, dim);
    uint shuffled = nested_uniform_scramble(s.index, seed);
    return bits_to_unit(sobol_owen(shuffled, seed, dim % uint(SOBOL_BLOCK_DIMS)));
}

// Dimensions dim and dim + 1, in one block (dim even).
vec2 sample_2d(inout PathSampler s, uint dim) {
    if (!SAMPLER_SOBOL) return rng_next_2d(s.state);
    uint seed = sobol_block_seed(s, dim);
    uint shuffled = nested_uniform_scramble(s.index, seed);
    uint c = dim % uint(SOBOL_BLOCK_DIMS);
    return vec2(bits_to_unit(sobol_owen(shuffled, seed, c)), bits_to_unit(sobol_owen(shuffled, seed, c + 1u)));
}

// Where in the pixel a sample looks ([0, 1)^2): an independent sample takes its
// own of the SAMPLES_X x SAMPLES_Y sub-squares, `stratum`, jittered
// (src/camera.rs `pixel_jitter`); Sobol's points are stratified already.
vec2 sample_pixel(inout PathSampler s, uvec2 stratum) {
    vec2 j = sample_2d(s, SAMPLE_CAMERA);
    return SAMPLER_SOBOL ? j : (vec2(stratum) + j) / vec2(SAMPLES_X, SAMPLES_Y);
}

#endif
