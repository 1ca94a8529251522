//! Random numbers: PCG (O'Neill 2014) streams whose seeds are hashed from
//! (user seed, pixel, frame, sample), so neighbouring pixels, samples and frames
//! are decorrelated. `glsl/rng.glsl` is the same code.

/// The PCG-RXS-M-XS 32-bit hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering").
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

/// One path's random-number stream.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u32,
}

impl Rng {
    /// The stream of sample `sample` (0..64) of `pixel` (y * width + x) in `frame`.
    pub fn new(seed: u32, pixel: u32, frame: u32, sample: u32) -> Rng {
        let h = pcg_hash(seed ^ 0x9e37_79b9);
        let h = pcg_hash(h ^ pixel);
        let h = pcg_hash(h ^ frame.wrapping_mul(0x85eb_ca6b));
        let state = pcg_hash(h ^ sample.wrapping_mul(0xc2b2_ae35));
        Rng { state }
    }

    pub fn next_u32(&mut self) -> u32 {
        self.state = self.state.wrapping_mul(747796405).wrapping_add(2891336453);
        let s = self.state;
        let word = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277803737);
        (word >> 22) ^ word
    }

    /// Uniform in [0, 1): the top 24 bits, so 1.0 is never returned.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub fn next_2d(&mut self) -> [f32; 2] {
        let a = self.next_f32();
        [a, self.next_f32()]
    }
}
