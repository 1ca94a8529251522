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

    /// Uniform in [0, 1), in steps of 2^-23: the top 23 bits as the mantissa of a
    /// float in [1, 2), minus 1 (exact), so 1.0 is never returned. This spares
    /// the GPU an integer-to-float conversion, which runs at a fraction of the rate.
    pub fn next_f32(&mut self) -> f32 {
        f32::from_bits(0x3f80_0000 | (self.next_u32() >> 9)) - 1.0
    }

    pub fn next_2d(&mut self) -> [f32; 2] {
        let a = self.next_f32();
        [a, self.next_f32()]
    }
}

/// A number in [0, 1) hashed from a hit point `p`, the direction `wo` and a mix's
/// index `mat` (pbrt-v4's `HashFloat`): every evaluation at a vertex sees the same
/// choice of a mix's material, and no sampler dimension is taken.
/// `glsl/rng.glsl` `mix_hash` is its twin.
pub fn mix_hash(p: glam::Vec3, wo: glam::Vec3, mat: u32) -> f32 {
    let mut h = pcg_hash(mat ^ 0x2545_f491);
    for x in [p.x, p.y, p.z, wo.x, wo.y, wo.z] {
        h = pcg_hash(h ^ x.to_bits());
    }
    f32::from_bits(0x3f80_0000 | (h >> 9)) - 1.0
}

#[cfg(test)]
mod tests {
    use super::Rng;

    /// Every number is in [0, 1) and a multiple of 2^-23, the extremes map to 0
    /// and 1 - 2^-23, and a stream's mean and lowest bit are those of uniform numbers.
    #[test]
    fn floats_are_uniform_multiples_of_2_pow_minus_23_below_1() {
        let mut rng = Rng::new(1, 2, 3, 4);
        let n = 200_000;
        let (mut sum, mut odd) = (0.0f64, 0u32);
        for _ in 0..n {
            let x = rng.next_f32();
            assert!((0.0..1.0).contains(&x), "{x}");
            let k = x as f64 * (1u64 << 23) as f64;
            assert_eq!(k.fract(), 0.0, "{x} is no multiple of 2^-23");
            sum += x as f64;
            odd += k as u32 & 1;
        }
        let mean = sum / n as f64;
        // Standard deviation of the mean: sqrt(1/12 / n) = 6.5e-4; of the odd count, 224.
        assert!((mean - 0.5).abs() < 0.004, "mean {mean}");
        assert!((odd as f64 - n as f64 / 2.0).abs() < 1500.0, "{odd} odd of {n}");
        assert_eq!(f32::from_bits(0x3f80_0000 | (u32::MAX >> 9)) - 1.0, 1.0 - 2f32.powi(-23));
        assert_eq!(f32::from_bits(0x3f80_0000) - 1.0, 0.0);
    }
}
