//! The accumulated result of a render, identical for both renderers.

use crate::image::Image;
use crate::layout::AccumPixel;
use crate::math::mean3;
use crate::shared;
use glam::Vec3;

/// Per-pixel sums over all frames rendered so far.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Frames accumulated; each adds `SAMPLES_PER_FRAME` samples per pixel, but
    /// a last one cut short ([`Film::partial_spp`]).
    pub frames: u32,
    /// The samples per pixel of the last frame where a deadline cut it short (1
    /// to 63: a render's `--time`, `crate::cpu::CpuRenderer::render_frame_until`
    /// and `crate::render::GpuRenderer::render_round`); 0 where every frame is
    /// whole. No frame is accumulated after a partial one.
    pub partial_spp: u32,
    /// Where frames weighed other than their samples' share (a timed race's,
    /// [`FrameWeight::weight`]), their total weight in whole frames, which the
    /// image divides by; None where every frame weighs its samples' share.
    pub weight: Option<f64>,
    pub pixels: Vec<AccumPixel>,
    /// Each pixel's Kahan compensation of its sum ([`kahan_add`]), where the film
    /// accumulates on the host (the CPU renderer); a GPU keeps its own on the
    /// device, and a film read back from it leaves this empty.
    pub carry: Vec<[f32; 3]>,
}

/// The samples per pixel of `frames` frames, the last of them cut short to
/// `partial_spp` samples where that is not 0 ([`Film::partial_spp`]).
pub fn samples_in(frames: u32, partial_spp: u32) -> u64 {
    let whole = frames as u64 * shared::SAMPLES_PER_FRAME as u64;
    match partial_spp {
        0 => whole,
        k => whole - (shared::SAMPLES_PER_FRAME - k) as u64,
    }
}

/// Adds one frame's 64-sample sum to a pixel that already holds `frames` frames
/// (Welford's update of the frame means' squared deviations); the GLSL twin is
/// `accumulate` in `glsl/pathtrace.comp`. [`accumulate_samples`] with 64 samples.
///
/// The first frame of an accumulation (`frames` 0) writes over what the pixel
/// holds. Where that is the learning frames' radiance (`learned_frames` > 0,
/// `GuideConfig::learning_frames`), [`Learned::Fold`] takes their mean in as
/// the image's first frame, this one its second (docs/guiding.md, "Learning
/// frames in the image"); [`Learned::Keep`] keeps their mean3 sum in `sum[3]`,
/// the learning frames' share of learned roulette's estimate
/// (`crate::guide::roulette_estimate`), and the image is `sum[..3]` alone.
pub fn accumulate(
    acc: &mut AccumPixel,
    carry: &mut [f32; 3],
    frames: u32,
    learned_frames: u32,
    learned: Learned,
    sum: [f32; 3],
) {
    accumulate_samples(acc, carry, frames, learned_frames, learned, sum, FrameWeight::whole(frames));
}

/// What a frame weighs in the accumulation it joins ([`accumulate_samples`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameWeight {
    /// Its samples per pixel, 1 to 64: a frame of k weighs k / 64 of a whole one.
    pub samples: u32,
    /// A whole frame's weight: 1, but in a timed race, where each kind's frames
    /// weigh the inverse of their variance (`crate::guide::FrameRace::frame_weight`).
    pub weight: f32,
    /// The frames before it, their total weight in whole frames: their count
    /// where every frame weighed 1 (0 where the frame is the first).
    pub before: f32,
}

impl FrameWeight {
    /// A whole frame of weight 1 after `frames` such frames.
    pub fn whole(frames: u32) -> FrameWeight {
        FrameWeight { samples: shared::SAMPLES_PER_FRAME, weight: 1.0, before: frames as f32 }
    }

    /// Its weight in whole frames: the weight times its samples' share.
    pub fn frames(&self) -> f64 {
        self.weight as f64 * self.samples as f64 / shared::SAMPLES_PER_FRAME as f64
    }
}

/// What the image's first frame does with the learning frames the pixel holds
/// ([`accumulate`]; the kernel's `fold_learned`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Learned {
    /// Their mean becomes the image's first frame: one frame's weight, however
    /// many they were, fixed before the render, so the image stays unbiased.
    Fold,
    /// Left out of the image (a part of a split render, whose learning frames
    /// every part repeats; a render on several GPUs, each holding some of them).
    Keep,
}

impl Learned {
    /// A render's own choice: every part of a split render (`crate::parts`)
    /// traces the same learning frames, and folded into each part they would
    /// not average down; a whole render folds them.
    pub fn for_render(part: bool) -> Learned {
        if part {
            Learned::Keep
        } else {
            Learned::Fold
        }
    }
}

/// [`accumulate`] of a frame weighing `weight` after `frames` frames: West's
/// weighted Welford update, each frame's mean weighted by its share of a whole
/// frame's samples times its kind's weight, so that [`Film::variance_of_mean`]
/// stays unbiased (docs/cli.md, `--time`; docs/guiding.md, "Guided and unguided
/// frames"). The sum holds each frame's sum times its weight. With whole frames
/// of weight 1 the arithmetic is [`accumulate`]'s, bit for bit. The GLSL twin
/// is `accumulate` in `glsl/pathtrace.comp` (`push.samples`, `push.weight`,
/// `push.accum_weight`).
pub fn accumulate_samples(
    acc: &mut AccumPixel,
    carry: &mut [f32; 3],
    frames: u32,
    learned_frames: u32,
    learned: Learned,
    sum: [f32; 3],
    weight: FrameWeight,
) {
    let per_frame = shared::SAMPLES_PER_FRAME as f32;
    let mut before = weight.before;
    let weighted = sum.map(|s| s * weight.weight);
    if frames == 0 && learned_frames > 0 && learned == Learned::Fold {
        let held = Vec3::from_slice(&acc.sum[..3]) / learned_frames as f32;
        *acc = AccumPixel { sum: [held.x, held.y, held.z, 0.0], m2_frame_mean: [0.0; 4] };
        *carry = [0.0; 3];
        before = 1.0;
    } else if frames == 0 {
        let learned = if learned_frames > 0 { mean3(Vec3::from_slice(&acc.sum[..3])) } else { 0.0 };
        *acc = AccumPixel { sum: [weighted[0], weighted[1], weighted[2], learned], m2_frame_mean: [0.0; 4] };
        *carry = [0.0; 3];
        return;
    }
    let w = weight.weight * weight.samples as f32 / per_frame;
    for c in 0..3 {
        let mean_old = acc.sum[c] / (per_frame * before);
        let m = sum[c] / weight.samples as f32;
        let delta = m - mean_old;
        let mean_new = mean_old + delta * w / (before + w);
        // Compensated: after a million frames a frame's sum is a millionth of the
        // pixel's, and added plainly its low bits would be lost.
        kahan_add(&mut acc.sum[c], &mut carry[c], weighted[c]);
        acc.m2_frame_mean[c] += w * delta * (m - mean_new);
    }
}

/// Adds `x` to `sum`, carrying what the addition rounds off into the next one
/// (Kahan's compensated summation): `sum - carry` is the exact sum up to a
/// rounding, however many small terms were added. The GLSL twin is `kahan_add`
/// in `glsl/film.glsl`.
pub fn kahan_add(sum: &mut f32, carry: &mut f32, x: f32) {
    let y = x - *carry;
    let t = *sum + y;
    *carry = (t - *sum) - y;
    *sum = t;
}

/// `pathtrace.comp` `frame_variance_term`: the squared deviation of a frame's
/// mean of a pixel (mean3) from the pixel's mean before the frame, over that
/// mean's square plus relMSE's 0.01, at most `FRAME_VARIANCE_MAX`. Its
/// expectation is the frame mean's relative variance (plus the mean before's,
/// small after a few frames), whatever the frame's samples share: a pixel's 64
/// samples are stratified over its area, and their own spread overstated the
/// variance of their mean where the image varies within the pixel (docs/guiding.md,
/// "Guided and unguided frames"). Summed over the pixels, it is what a
/// [`crate::guide::FrameRace`] weighs a frame by.
pub fn frame_variance_term(frame_mean: f32, mean_before: f32) -> f32 {
    let d = frame_mean - mean_before;
    (d * d / (mean_before * mean_before + 0.01)).min(shared::FRAME_VARIANCE_MAX)
}

/// Host memory a render of `pixels` pixels holds at its peak, about: the film, the
/// image made from it and the file's encoding, and on the GPU the readback
/// buffer too. The bytes per pixel are measured maxima of resident memory, the
/// GPU's taken from a CPU driver, whose device memory is host memory too, so
/// that the warning comes early rather than late (docs/ARCHITECTURE.md, "Host memory").
pub fn host_bytes_estimate(pixels: u64, gpu: bool) -> u64 {
    pixels * if gpu { 170 } else { 104 }
}

/// A warning where a render of `pixels` pixels would hold more host memory
/// ([`host_bytes_estimate`]) than `available` bytes, the memory the system
/// reports available: it would swap, or be killed part way.
pub fn memory_warning(pixels: u64, gpu: bool, available: u64) -> Option<String> {
    let need = host_bytes_estimate(pixels, gpu);
    let gb = |b: u64| b as f64 / 1e9;
    (need > available).then(|| {
        format!(
            "the render holds about {:.1} GB of host memory at its peak, and {:.1} GB is available: \
             it may swap or be killed; render a smaller image",
            gb(need),
            gb(available)
        )
    })
}

/// The memory the system reports available (`MemAvailable` of `/proc/meminfo`),
/// in bytes; `None` where there is no such file.
pub fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            frames: 0,
            partial_spp: 0,
            weight: None,
            pixels: vec![AccumPixel::default(); (width * height) as usize],
            carry: vec![[0.0; 3]; (width * height) as usize],
        }
    }

    pub fn samples_per_pixel(&self) -> u64 {
        samples_in(self.frames, self.partial_spp)
    }

    /// The frames' total weight in whole frames: [`Film::weight`], or where
    /// every frame weighed its samples' share, the samples per pixel over 64.
    pub fn weight_frames(&self) -> f64 {
        self.weight.unwrap_or(self.samples_per_pixel() as f64 / shared::SAMPLES_PER_FRAME as f64)
    }

    /// The radiance estimate: the samples' mean, each frame's weighted by its
    /// [`FrameWeight`].
    pub fn mean(&self) -> Image {
        let w = self.weight_frames();
        let n = if w > 0.0 { (w * shared::SAMPLES_PER_FRAME as f64) as f32 } else { 1.0 };
        Image {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|p| [p.sum[0] / n, p.sum[1] / n, p.sum[2] / n]).collect(),
        }
    }

    /// Estimated variance of each pixel's mean, from the spread of its per-frame
    /// means (needs at least two frames; `None` otherwise): the weighted squared
    /// deviations over (frames - 1) and the frames' total weight
    /// ([`accumulate_samples`]), which with whole frames of weight 1 is their
    /// count. Where the weights are the inverse of the frames' variances, as a
    /// race's are, this is the weighted mean's variance too.
    pub fn variance_of_mean(&self) -> Option<Image> {
        if self.frames < 2 {
            return None;
        }
        let f = self.frames as f64;
        let weight = self.weight_frames();
        Some(Image {
            width: self.width,
            height: self.height,
            pixels: self
                .pixels
                .iter()
                .map(|p| {
                    let mut v = [0.0f32; 3];
                    for c in 0..3 {
                        let var_frame = (p.m2_frame_mean[c] as f64 / (f - 1.0)).max(0.0);
                        v[c] = (var_frame / weight) as f32;
                    }
                    v
                })
                .collect(),
        })
    }
}

#[cfg(test)]
mod memory_tests {
    use super::*;

    #[test]
    fn a_render_larger_than_memory_is_named() {
        let pixels = 16384u64 * 16384;
        let w = memory_warning(pixels, false, 8_000_000_000).expect("27.9 GB against 8");
        assert!(w.contains("about 27.9 GB") && w.contains("8.0 GB is available"), "{w}");
        assert!(memory_warning(pixels, true, 8_000_000_000).unwrap().contains("about 45.6 GB"));
        assert_eq!(memory_warning(640 * 480, true, 8_000_000_000), None);
        if std::path::Path::new("/proc/meminfo").exists() {
            assert!(available_memory().is_some_and(|b| b > 0));
        }
    }
}

#[cfg(test)]
mod accumulation_tests {
    use super::*;

    /// Frames of two kinds, the second 16 times as noisy and weighing 1/16
    /// (a timed race's [`FrameWeight`]s), over many pixels of uniform samples:
    /// the image's mean is unbiased, [`Film::variance_of_mean`] is the weighted
    /// mean's variance (sigma^2 / W) within 5 standard errors, and that is a
    /// quarter of what weighing every frame alike would leave.
    #[test]
    fn frames_weighed_by_their_inverse_variance_stay_unbiased() {
        use crate::math::rng::Rng;
        let trials = 20_000u32;
        let noisy = [false, true, true, false, true, false, true, true];
        let per_frame = shared::SAMPLES_PER_FRAME;
        let sigma2 = 1.0 / 12.0 / per_frame as f64;
        let w_total: f64 = noisy.iter().map(|&n| if n { 1.0 / 16.0 } else { 1.0 }).sum();
        let truth = sigma2 / w_total;
        let (mut means, mut means_sq, mut variances, mut variances_sq) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for t in 0..trials {
            let mut rng = Rng::new(7, t, 0, 0);
            let (mut acc, mut carry, mut before) = (AccumPixel::default(), [0.0f32; 3], 0.0f32);
            for (f, &n) in noisy.iter().enumerate() {
                // Uniform samples about 0.5, four times as wide (16 times the variance) where noisy.
                let scale = if n { 4.0 } else { 1.0 };
                let s: f32 = (0..per_frame).map(|_| 0.5 + scale * (rng.next_f32() - 0.5)).sum();
                let weight = FrameWeight { samples: per_frame, weight: if n { 1.0 / 16.0 } else { 1.0 }, before };
                accumulate_samples(&mut acc, &mut carry, f as u32, 0, Learned::Fold, [s; 3], weight);
                before += weight.frames() as f32;
            }
            let film = Film {
                width: 1,
                height: 1,
                frames: noisy.len() as u32,
                partial_spp: 0,
                weight: Some(before as f64),
                pixels: vec![acc],
                carry: vec![carry],
            };
            let m = film.mean().pixels[0][0] as f64;
            means += m;
            means_sq += m * m;
            let v = film.variance_of_mean().expect("8 frames").pixels[0][0] as f64;
            variances += v;
            variances_sq += v * v;
        }
        let n = trials as f64;
        let mean = means / n;
        let spread = means_sq / n - mean * mean;
        assert!((mean - 0.5).abs() < 5.0 * (spread / n).sqrt(), "mean {mean}");
        // The spread of the weighted mean over the trials, and its estimate, against sigma^2 / W.
        assert!((spread / truth - 1.0).abs() < 5.0 * (2.0 / n).sqrt(), "spread {spread:e} against {truth:e}");
        let estimate = variances / n;
        let se = ((variances_sq / n - estimate * estimate) / n).sqrt();
        assert!(
            (estimate - truth).abs() < 5.0 * se,
            "estimated {estimate:e} against {truth:e} (standard error {se:e})"
        );
        let alike = sigma2 * noisy.iter().map(|&n| if n { 16.0 } else { 1.0 }).sum::<f64>() / 64.0;
        assert!(truth < 0.25 * alike, "weighted {truth:e}, alike {alike:e}");
    }

    /// A million frames of one pixel, each summing nearly the same radiance (a
    /// furnace): its sum is the exact sum to float precision. Added plainly in
    /// f32, the sum lost about 1e-3 of itself by then.
    #[test]
    fn a_million_frames_sum_to_float_precision() {
        let frames = 1u32 << 20;
        let (mut acc, mut carry) = (AccumPixel::default(), [0.0f32; 3]);
        let mut exact = [0.0f64; 3];
        let mut plain = [0.0f32; 3];
        for f in 0..frames {
            // 64 samples of about 0.37, the channels apart, varying by 1e-3.
            let wobble = 1.0 + 1e-3 * ((f % 7) as f32 - 3.0) / 3.0;
            let sum = [23.68 * wobble, 11.1 * wobble, 40.3 * wobble];
            accumulate(&mut acc, &mut carry, f, 0, Learned::Fold, sum);
            for c in 0..3 {
                exact[c] += sum[c] as f64;
                plain[c] += sum[c];
            }
        }
        for c in 0..3 {
            let err = (acc.sum[c] as f64 - exact[c]).abs() / exact[c];
            assert!(err < 1e-7, "channel {c}: relative error {err:e}");
            let err_plain = (plain[c] as f64 - exact[c]).abs() / exact[c];
            assert!(err_plain > 1e-4, "channel {c}: a plain f32 sum lost only {err_plain:e}: the test proves nothing");
        }
    }
}
