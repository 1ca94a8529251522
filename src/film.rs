//! The accumulated result of a render, identical for both renderers.

use crate::image::Image;
use crate::prepared::AccumPixel;
use crate::shared;

/// Per-pixel sums over all frames rendered so far.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Frames accumulated; each adds `SAMPLES_PER_FRAME` samples per pixel.
    pub frames: u32,
    pub pixels: Vec<AccumPixel>,
}

/// Adds one frame's 64-sample sum to a pixel that already holds `frames` frames
/// (Welford's update of the frame means' squared deviations); the GLSL twin is
/// `accumulate` in `glsl/pathtrace.comp`.
pub fn accumulate(acc: &mut AccumPixel, frames: u32, sum: [f32; 3]) {
    let per_frame = shared::SAMPLES_PER_FRAME as f32;
    for c in 0..3 {
        let mean_old = if frames == 0 { 0.0 } else { acc.sum[c] / (per_frame * frames as f32) };
        let m = sum[c] / per_frame;
        let delta = m - mean_old;
        let mean_new = mean_old + delta / (frames + 1) as f32;
        acc.sum[c] += sum[c];
        acc.m2_frame_mean[c] += delta * (m - mean_new);
    }
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        Film { width, height, frames: 0, pixels: vec![AccumPixel::default(); (width * height) as usize] }
    }

    pub fn samples_per_pixel(&self) -> u64 {
        self.frames as u64 * shared::SAMPLES_PER_FRAME as u64
    }

    /// The radiance estimate: mean of all samples.
    pub fn mean(&self) -> Image {
        let n = self.samples_per_pixel().max(1) as f32;
        Image {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|p| [p.sum[0] / n, p.sum[1] / n, p.sum[2] / n]).collect(),
        }
    }

    /// Estimated variance of each pixel's mean, from the spread of its per-frame
    /// 64-sample means (needs at least two frames; `None` otherwise).
    pub fn variance_of_mean(&self) -> Option<Image> {
        if self.frames < 2 {
            return None;
        }
        let f = self.frames as f64;
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
                        v[c] = (var_frame / f) as f32;
                    }
                    v
                })
                .collect(),
        })
    }
}
