// The frame counters' 64-bit sums: the includer declares `counters[]` (uint).
#ifndef RLPT_COUNTERS_GLSL
#define RLPT_COUNTERS_GLSL

// Adds v to the 64-bit counter whose low word is counters[lo] and high word
// counters[lo + 1]. The add that wraps the low word past 2^32 - 1 carries one
// into the high word, so the pair sums exactly in any order: a frame of a 4K
// image traces more rays than a 32-bit counter holds (src/render/mod.rs reads
// the pairs).
void counter_add64(uint lo, uint v) {
    uint old = atomicAdd(counters[lo], v);
    if (old + v < old) atomicAdd(counters[lo + 1u], 1u);
}

#endif
