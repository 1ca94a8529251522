// The accumulation's arithmetic shared by the kernels: src/film.rs, same functions.
#ifndef RLPT_FILM_GLSL
#define RLPT_FILM_GLSL

// src/film.rs `kahan_add`: adds x to sum, carrying what the addition rounds off
// into the next one (Kahan); sum - carry is the exact sum up to a rounding,
// however many small terms were added. `precise` keeps the compiler from
// folding (t - sum) - y to zero or fusing it.
void kahan_add(inout vec3 sum, inout vec3 carry, vec3 x) {
    precise vec3 y = x - carry;
    precise vec3 t = sum + y;
    precise vec3 c = (t - sum) - y;
    carry = c;
    sum = t;
}

#endif
