//! Learned Russian roulette: the survival probability from the learned radiance
//! and the pixel's estimate; `glsl/pathtrace.comp` is the GPU twin.

use super::*;

/// Russian roulette with guiding: the probability that a path goes on, from its
/// expected contribution (throughput times the radiance the table has learned for
/// the ray it is about to trace) relative to the pixel's estimate so far. Paths
/// that can still matter to the pixel survive; a path whose every continuation is
/// dim is cut early (after Vorba & Křivánek, "Adjoint-Driven Russian Roulette and
/// Splitting in Light Transport Simulation", 2016, without the splitting). Plain
/// throughput-based roulette gives up exactly where guiding pays, in dim regions
/// lit through long paths. At least `RR_MIN_PERCENT` %, so that a dark estimate
/// in a bin not yet learned costs little variance; any probability above zero
/// keeps the estimate unbiased. `glsl/pathtrace.comp` is the same.
pub fn survival_probability(expected: f32, pixel_estimate: f32) -> f32 {
    (shared::RR_WINDOW as f32 * expected / pixel_estimate).clamp(shared::RR_MIN_PERCENT as f32 / 100.0, 1.0)
}

/// The pixel estimate learned Russian roulette compares with (the mean3 of the
/// pixel's mean radiance so far), or 0, meaning plain throughput roulette, where
/// the pixel has no frames yet or the table has learned from fewer than
/// `LEARNED_RR_FRAMES` frames (`frames_traced`, which a restart of the
/// accumulation keeps): a roulette driven by the first frames' table puts, through
/// its 1/q weights, fireflies into the image that the average keeps for a long
/// time. The frames so far are the accumulation's `accum_frames` and the
/// `learned_frames` left out of the image before it (`GuideConfig::learning_frames`),
/// whose mean3 sum the pixel keeps in `sum[3]` once the image has a frame
/// (`crate::film::accumulate`, `Learned::Keep`); before that (`accum_frames` 0)
/// the pixel still holds them as its sum. Folded into the image
/// (`Learned::Fold`), they are one of its frames and `learned_frames` is 0.
/// The accumulation's frames count by their total weight, `accum_weight`
/// (`crate::film::FrameWeight`: `accum_frames` where each weighed 1).
/// `glsl/pathtrace.comp` is the same.
pub fn roulette_estimate(
    acc: &AccumPixel,
    (accum_frames, accum_weight): (u32, f32),
    learned_frames: u32,
    frames_traced: u32,
) -> f32 {
    if accum_frames + learned_frames == 0 || frames_traced < shared::LEARNED_RR_FRAMES {
        return 0.0;
    }
    let learned = if accum_frames > 0 { acc.sum[3] } else { 0.0 };
    let frames = if accum_frames > 0 { accum_weight } else { 0.0 } + learned_frames as f32;
    (mean3(Vec3::from_slice(&acc.sum[..3])) + learned) / (shared::SAMPLES_PER_FRAME as f32 * frames)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Learned;

    /// [`roulette_estimate`] of an accumulation whose frames each weighed 1.
    fn estimate(acc: &AccumPixel, accum_frames: u32, learned_frames: u32, frames_traced: u32) -> f32 {
        roulette_estimate(acc, (accum_frames, accum_frames as f32), learned_frames, frames_traced)
    }

    /// Frames of other weights (a timed race's): the estimate is their weighted mean.
    #[test]
    fn learned_roulette_reads_the_weighted_mean() {
        let per_frame = shared::SAMPLES_PER_FRAME as f32;
        let (mut acc, mut carry) = (AccumPixel::default(), [0.0f32; 3]);
        let frames = [(2.0f32, 1.0f32), (8.0, 0.25), (2.0, 1.0)];
        let mut before = 0.0;
        for (i, &(radiance, weight)) in frames.iter().enumerate() {
            let w = crate::film::FrameWeight { samples: shared::SAMPLES_PER_FRAME, weight, before };
            crate::film::accumulate_samples(
                &mut acc,
                &mut carry,
                i as u32,
                0,
                Learned::Fold,
                [radiance * per_frame; 3],
                w,
            );
            before += w.frames() as f32;
        }
        // (2 + 0.25 * 8 + 2) / 2.25, not the plain mean 4.
        let e = roulette_estimate(&acc, (3, before), 0, shared::LEARNED_RR_FRAMES);
        assert!((e - 6.0 / 2.25).abs() < 1e-6, "{e}");
    }

    #[test]
    fn learned_roulette_waits_for_a_table_of_several_frames() {
        let n = shared::LEARNED_RR_FRAMES;
        let pixel = |sum: Vec3, w: f32| AccumPixel { sum: [sum.x, sum.y, sum.z, w], m2_frame_mean: [0.0; 4] };
        let sum = Vec3::new(3.0, 6.0, 9.0) * (shared::SAMPLES_PER_FRAME * n) as f32;
        for traced in 0..n {
            assert_eq!(estimate(&pixel(sum, 0.0), traced, 0, traced), 0.0, "{traced} frames");
        }
        assert_eq!(estimate(&pixel(sum, 0.0), n, 0, n), 6.0);
        assert_eq!(estimate(&pixel(sum, 0.0), 2 * n, 0, 2 * n), 3.0);
        // After a restart of the accumulation the table is still learned.
        assert_eq!(estimate(&pixel(sum / n as f32, 0.0), 1, 0, 3 * n), 6.0);
        assert_eq!(estimate(&pixel(Vec3::ZERO, 0.0), 0, 0, 3 * n), 0.0);
    }

    /// After the learning frames the estimate counts them: first as the sum the
    /// pixel still holds, then as its `sum[3]` beside the image's frames.
    #[test]
    fn learned_roulette_counts_the_learning_frames() {
        let n = shared::LEARNED_RR_FRAMES;
        let per_frame = shared::SAMPLES_PER_FRAME as f32;
        // n learning frames of mean3 6, held as the sum before the image's first frame.
        let mut acc = AccumPixel {
            sum: [3.0 * per_frame * n as f32, 6.0 * per_frame * n as f32, 9.0 * per_frame * n as f32, 0.0],
            m2_frame_mean: [5.0; 4],
        };
        assert_eq!(estimate(&acc, 0, n, n), 6.0);
        let held = acc;
        // Left out of the image (Keep), the image's first frame, of mean3 2 (and 1,
        // 2, 3 per channel), replaces them and keeps their share.
        let frame = [per_frame, 2.0 * per_frame, 3.0 * per_frame];
        crate::film::accumulate(&mut acc, &mut [0.0; 3], 0, n, Learned::Keep, frame);
        assert_eq!(acc.sum, [per_frame, 2.0 * per_frame, 3.0 * per_frame, 6.0 * per_frame * n as f32]);
        assert_eq!(acc.m2_frame_mean, [0.0; 4]);
        assert_eq!(estimate(&acc, 1, n, n + 1), (2.0 + 6.0 * n as f32) / (n + 1) as f32);
        // Folded (Fold), their mean (3, 6, 9 per sample) is the image's
        // first frame and this one its second; their spread is not the image's.
        let mut folded = held;
        crate::film::accumulate(&mut folded, &mut [0.0; 3], 0, n, Learned::Fold, frame);
        assert_eq!(folded.sum, [4.0 * per_frame, 8.0 * per_frame, 12.0 * per_frame, 0.0]);
        // Welford over the two frame means (3, 6, 9) and (1, 2, 3): half their squared difference.
        assert_eq!(folded.m2_frame_mean, [2.0, 8.0, 18.0, 0.0]);
        assert_eq!(estimate(&folded, 2, 0, n + 1), 4.0);
        // Without learning frames the first frame keeps nothing of what the pixel held.
        crate::film::accumulate(&mut acc, &mut [0.0; 3], 0, 0, Learned::Fold, [per_frame; 3]);
        assert_eq!(acc.sum, [per_frame, per_frame, per_frame, 0.0]);
    }
}
