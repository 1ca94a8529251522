//! Samplers: a path's random numbers, by dimension. `Independent` is the hashed
//! PCG streams of [`crate::math::rng`]; `Sobol` is Owen-scrambled Sobol points
//! after Burley 2020 ("Practical Hash-based Owen Scrambling"), with the index
//! shuffled per pixel and per block of dimensions. `glsl/sampler.glsl` is the
//! same code; the dimension layout is `shared::SAMPLE_*` (docs/sampling.md).

use crate::math::rng::{pcg_hash, Rng};
use crate::shared;

/// Which sampler a render's paths draw from (`--sampler`, `shared::FLAG_SOBOL`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum SamplerKind {
    /// Independent random numbers, hashed from (seed, pixel, frame, sample); the
    /// camera's jitter stratified over the pixel.
    #[default]
    #[value(help = "independent hashed random numbers (camera samples stratified)")]
    Independent,
    /// Owen-scrambled Sobol points, decorrelated between pixels.
    #[value(help = "Owen-scrambled Sobol points, decorrelated between pixels")]
    Sobol,
}

impl SamplerKind {
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
        }
    }
}

/// Sobol dimension 1 of point `index` before bit reversal (dimension 0's is the
/// index itself, van der Corput): digit r (bit r, the most significant once
/// reversed) is the XOR of the index bits k whose binomial C(k, r) is odd, those
/// k that hold r's bits (Pascal's matrix mod 2, Joe & Kuo's d = 2).
pub fn sobol_digits_1(index: u32) -> u32 {
    let mut y = index;
    y ^= (y >> 1) & 0x5555_5555;
    y ^= (y >> 2) & 0x3333_3333;
    y ^= (y >> 4) & 0x0f0f_0f0f;
    y ^= (y >> 8) & 0x00ff_00ff;
    y ^= (y >> 16) & 0x0000_ffff;
    y
}

/// Burley's Laine-Karras style hash: a random permutation in which each bit is
/// flipped by a function of the bits below it only.
pub fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen's nested uniform scrambling in base 2 (Burley 2020): each bit flipped by
/// a hash of the more significant bits.
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// A seed for `v` of `seed`'s (one hash: the multiplier spreads small v over the word).
pub fn hash_combine(seed: u32, v: u32) -> u32 {
    pcg_hash(seed ^ v.wrapping_add(1).wrapping_mul(0x9e37_79b9))
}

/// The top 23 bits as a float in [0, 1) ([`Rng::next_f32`]'s conversion).
fn bits_to_unit(x: u32) -> f32 {
    f32::from_bits(0x3f80_0000 | (x >> 9)) - 1.0
}

/// Dimension `slot` (`shared::SAMPLE_*`) of the vertex of depth `depth`.
pub fn bounce_dim(depth: u32, slot: u32) -> u32 {
    shared::SAMPLER_BOUNCE_BASE + depth * shared::SAMPLER_BOUNCE_DIMS + slot
}

/// One path's sampler. Independent: a PCG stream, the dimension ignored (numbers
/// come in the order drawn). Sobol: the pixel's seed and the sample's index in
/// the pixel's sequence.
#[derive(Clone, Debug)]
pub struct PathSampler {
    kind: SamplerKind,
    rng: Rng,
    seed: u32,
    index: u32,
}

impl PathSampler {
    /// The sampler of sample `sample` (0..64) of `pixel` (y * width + x) in
    /// `frame`: a frame continues its pixel's Sobol sequence where the previous one stopped.
    pub fn new(kind: SamplerKind, seed: u32, pixel: u32, frame: u32, sample: u32) -> PathSampler {
        let rng = Rng::new(seed, pixel, frame, sample);
        match kind {
            SamplerKind::Independent => PathSampler { kind, rng, seed: 0, index: 0 },
            SamplerKind::Sobol => PathSampler {
                kind,
                rng,
                seed: hash_combine(pcg_hash(seed ^ 0x9e37_79b9), pixel),
                index: frame.wrapping_mul(shared::SAMPLES_PER_FRAME).wrapping_add(sample),
            },
        }
    }

    /// The sampler that `flags` (`shared::FLAG_SOBOL`) name.
    pub fn for_flags(flags: u32, seed: u32, pixel: u32, frame: u32, sample: u32) -> PathSampler {
        let kind = if flags & shared::FLAG_SOBOL != 0 { SamplerKind::Sobol } else { SamplerKind::Independent };
        PathSampler::new(kind, seed, pixel, frame, sample)
    }

    /// Owen-scrambled Sobol (Burley 2020), padded: each 1D or 2D sample `dim`
    /// is a block of its own, with a seed from the pixel's and `dim`, which
    /// shuffles the index (nested uniform scrambling of its reversed bits: aligned
    /// runs of 2^k indices map onto aligned runs, so each pixel's prefixes stay
    /// nets) and scrambles each dimension. Returns (shuffled index, block seed).
    fn shuffled_index(&self, dim: u32) -> (u32, u32) {
        let seed = hash_combine(self.seed, dim);
        (nested_uniform_scramble(self.index, seed), seed)
    }

    pub fn sample_1d(&mut self, dim: u32) -> f32 {
        match self.kind {
            SamplerKind::Independent => self.rng.next_f32(),
            SamplerKind::Sobol => {
                let (i, seed) = self.shuffled_index(dim);
                bits_to_unit(sobol_owen(i, seed, 0))
            }
        }
    }

    /// Dimensions `dim` and `dim + 1`: one 2D sample.
    pub fn sample_2d(&mut self, dim: u32) -> [f32; 2] {
        match self.kind {
            SamplerKind::Independent => self.rng.next_2d(),
            SamplerKind::Sobol => {
                let (i, seed) = self.shuffled_index(dim);
                [bits_to_unit(sobol_owen(i, seed, 0)), bits_to_unit(sobol_owen(sobol_digits_1(i), seed, 1))]
            }
        }
    }

    /// Where in pixel sample `sample` of a frame looks ([0, 1)^2): independent
    /// samples take their own of the 8 x 8 sub-squares, jittered
    /// ([`pixel_jitter`]); Sobol's points are stratified already.
    /// `glsl/sampler.glsl` `sample_pixel`.
    pub fn sample_pixel(&mut self, sample: u32) -> [f32; 2] {
        let j = self.sample_2d(shared::SAMPLE_CAMERA);
        match self.kind {
            SamplerKind::Independent => pixel_jitter(sample, j),
            SamplerKind::Sobol => j,
        }
    }
}

/// Where in its pixel sample `sample` (0..64) of a frame looks: the pixel is cut
/// into the 8 x 8 grid of the workgroup's samples, and each sample is jittered by
/// `j` inside its own sub-square (stratified sampling: edges converge much faster
/// than with 64 independent positions). `glsl/sampler.glsl` `sample_pixel`.
pub fn pixel_jitter(sample: u32, j: [f32; 2]) -> [f32; 2] {
    let (sx, sy) = (shared::SAMPLES_X, shared::SAMPLES_Y);
    [((sample % sx) as f32 + j[0]) / sx as f32, ((sample / sx) as f32 + j[1]) / sy as f32]
}

/// The frame index of the random numbers of the frame traced after `traced`
/// frames: the learning frames keep theirs, so that every part of a split render
/// learns the table an unsplit render would; the image's frames add `offset`, the
/// part's first frame (`crate::parts::Part::frames`), so that parts draw disjoint
/// samples. Recording and learned roulette go by `traced` alone.
pub fn rng_frame(traced: u32, learning_frames: u32, offset: u32) -> u32 {
    if traced < learning_frames {
        traced
    } else {
        traced + offset
    }
}

/// Sobol digits (before bit reversal) of dimension `component` Owen-scrambled by
/// a seed of the block's, as 32 fixed-point bits: the scramble works on the digits
/// as they come, and the reversal puts the first digit on top.
pub fn sobol_owen(digits: u32, block_seed: u32, component: u32) -> u32 {
    laine_karras_permutation(digits, hash_combine(block_seed, component)).reverse_bits()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shared::{
        SAMPLE_CAMERA, SAMPLE_DIRECTION, SAMPLE_LIGHT, SAMPLE_LIGHT_SELECT, SAMPLE_LOBE, SAMPLE_MIX, SAMPLE_ROULETTE,
    };

    /// Whether `points` (2^k of them) fall one in each elementary interval of
    /// 2^k cells, of every shape 2^a x 2^(k-a): a (0, k, 2)-net.
    fn is_net(points: &[[f32; 2]]) -> bool {
        let k = points.len().trailing_zeros();
        assert_eq!(points.len(), 1 << k);
        (0..=k).all(|a| {
            let mut seen = vec![false; points.len()];
            points.iter().all(|p| {
                let (x, y) = ((p[0] * (1 << a) as f32) as usize, (p[1] * (1 << (k - a)) as f32) as usize);
                !std::mem::replace(&mut seen[x << (k - a) | y], true)
            })
        })
    }

    /// Whether `values` (2^k of them) fall one in each interval of length 2^-k.
    fn is_stratified(values: &[f32]) -> bool {
        let mut seen = vec![false; values.len()];
        values.iter().all(|&v| !std::mem::replace(&mut seen[(v * values.len() as f32) as usize], true))
    }

    /// The samples `first..first + n` of `pixel`, drawn by `draw`.
    fn sequence<T>(kind: SamplerKind, pixel: u32, first: u32, n: u32, draw: impl Fn(&mut PathSampler) -> T) -> Vec<T> {
        let per_frame = shared::SAMPLES_PER_FRAME;
        (first..first + n).map(|i| draw(&mut PathSampler::new(kind, 3, pixel, i / per_frame, i % per_frame))).collect()
    }

    /// Dimension 1's digits are those of the generator matrix that Joe & Kuo's
    /// direction numbers for d = 2 (s = 1, a = 0, m = 1) give, v_k = v_(k-1) ^
    /// (v_(k-1) >> 1); with dimension 0 the points are a (0, 2)-sequence: every
    /// aligned run of 2^k points is a (0, k, 2)-net.
    #[test]
    fn sobol_dimensions_0_and_1_are_a_0_2_sequence() {
        let mut v = 1u32 << 31;
        for k in 0..32 {
            assert_eq!(sobol_digits_1(1 << k).reverse_bits(), v, "column {k}");
            v ^= v >> 1;
        }
        let unit = |x: u32| x.reverse_bits() as f32 / 2f32.powi(32);
        for k in 0..=12 {
            for run in [0u32, 1, 5] {
                let n = 1u32 << k;
                let points: Vec<_> = (run * n..(run + 1) * n).map(|i| [unit(i), unit(sobol_digits_1(i))]).collect();
                assert!(is_net(&points), "2^{k} points from {}", run * n);
            }
        }
    }

    /// Owen-scrambled and shuffled per pixel, the 2D samples of every pixel keep
    /// the net property in their first 2^k samples and in each frame's 64; every
    /// 1D sample is stratified. Independent samples are not.
    #[test]
    fn sobol_samples_are_stratified_in_every_pixel() {
        let two_d = [
            SAMPLE_CAMERA,
            bounce_dim(0, SAMPLE_LIGHT),
            bounce_dim(0, SAMPLE_DIRECTION),
            bounce_dim(5, SAMPLE_DIRECTION),
        ];
        let one_d = [SAMPLE_LIGHT_SELECT, SAMPLE_ROULETTE, SAMPLE_LOBE, SAMPLE_MIX].map(|s| bounce_dim(2, s));
        for pixel in [0u32, 1, 77, 12345] {
            for (first, n) in [(0u32, 1024u32), (0, 256), (0, 8), (64, 64), (192, 64), (512, 512)] {
                for dim in two_d {
                    let points = sequence(SamplerKind::Sobol, pixel, first, n, |s| s.sample_2d(dim));
                    assert!(is_net(&points), "pixel {pixel}, dimension {dim}, {n} samples from {first}");
                }
                for dim in one_d {
                    let v = sequence(SamplerKind::Sobol, pixel, first, n, |s| s.sample_1d(dim));
                    assert!(is_stratified(&v), "pixel {pixel}, dimension {dim}, {n} samples from {first}");
                }
            }
            let points =
                sequence(SamplerKind::Independent, pixel, 0, 256, |s| s.sample_2d(bounce_dim(0, SAMPLE_LIGHT)));
            assert!(!is_net(&points), "independent samples are no net");
        }
    }

    /// Pearson's correlation of two equally long sequences.
    fn correlation(a: &[f32], b: &[f32]) -> f64 {
        let n = a.len() as f64;
        let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / n;
        let (ma, mb) = (mean(a), mean(b));
        let cov: f64 = a.iter().zip(b).map(|(&x, &y)| (x as f64 - ma) * (y as f64 - mb)).sum();
        let var = |v: &[f32], m: f64| v.iter().map(|&x| (x as f64 - m).powi(2)).sum::<f64>();
        cov / (var(a, ma) * var(b, mb)).sqrt()
    }

    /// Pixels are decorrelated: neighbouring pixels' sequences differ, and over
    /// many pixels a dimension's values at one index are uncorrelated between
    /// neighbours and between two blocks of one pixel; their mean is 1/2.
    #[test]
    fn sobol_pixels_and_blocks_are_decorrelated() {
        let dim = bounce_dim(1, SAMPLE_DIRECTION);
        let a = sequence(SamplerKind::Sobol, 10, 0, 64, |s| s.sample_2d(dim));
        let b = sequence(SamplerKind::Sobol, 11, 0, 64, |s| s.sample_2d(dim));
        assert!(a.iter().zip(&b).all(|(p, q)| p != q), "pixels 10 and 11 share samples");
        // 4096 pairs: the correlation's standard deviation is 1/64.
        for index in [0u32, 1, 63, 64, 1000] {
            let at = |pixel: u32, dim: u32| {
                let f = index / shared::SAMPLES_PER_FRAME;
                PathSampler::new(SamplerKind::Sobol, 3, pixel, f, index % shared::SAMPLES_PER_FRAME).sample_1d(dim)
            };
            let here: Vec<f32> = (0..4096).map(|p| at(p, dim)).collect();
            let right: Vec<f32> = (0..4096).map(|p| at(p + 1, dim)).collect();
            let below: Vec<f32> = (0..4096).map(|p| at(p + 96, dim)).collect();
            let other_block: Vec<f32> = (0..4096).map(|p| at(p, bounce_dim(1, SAMPLE_LIGHT))).collect();
            for (what, other) in [("right", &right), ("below", &below), ("other block", &other_block)] {
                let r = correlation(&here, other);
                assert!(r.abs() < 0.07, "index {index}, {what}: correlation {r}");
            }
            let mean = here.iter().map(|&x| x as f64).sum::<f64>() / here.len() as f64;
            // Standard deviation of the mean: sqrt(1/12 / 4096) = 0.0045.
            assert!((mean - 0.5).abs() < 0.02, "index {index}: mean {mean}");
        }
        // Within one pixel, two blocks' sequences are uncorrelated too (shuffled apart).
        let x = sequence(SamplerKind::Sobol, 5, 0, 4096, |s| s.sample_1d(bounce_dim(0, SAMPLE_LIGHT)));
        let y = sequence(SamplerKind::Sobol, 5, 0, 4096, |s| s.sample_1d(bounce_dim(0, SAMPLE_DIRECTION)));
        let r = correlation(&x, &y);
        assert!(r.abs() < 0.07, "blocks of one pixel: correlation {r}");
    }

    /// Owen scrambling flips each bit by the bits above it alone: values that
    /// share their top k bits still share them scrambled (an aligned interval maps
    /// onto one), so nets stay nets; and the top bits themselves are permuted.
    #[test]
    fn nested_uniform_scramble_keeps_aligned_intervals() {
        for seed in [0u32, 1, 0xdead_beef] {
            for k in [1u32, 4, 9] {
                let tops: std::collections::HashSet<u32> = (0..1u32 << k)
                    .map(|t| {
                        let low_bits = 32 - k;
                        let scrambled: std::collections::HashSet<u32> = (0..256u32)
                            .map(|i| {
                                nested_uniform_scramble(t << low_bits | i.wrapping_mul(0x9e37_79b9) >> k, seed)
                                    >> low_bits
                            })
                            .collect();
                        assert_eq!(scrambled.len(), 1, "seed {seed}, k {k}, top bits {t}");
                        *scrambled.iter().next().unwrap()
                    })
                    .collect();
                assert_eq!(tops.len(), 1 << k, "seed {seed}, k {k}: not a permutation");
            }
        }
    }
}
