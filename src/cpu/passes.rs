//! A CPU frame against a deadline (`CpuRenderer::render_frame_until`): passes of
//! one sample per pixel over the whole image, each started only where it is
//! predicted to end by the deadline, so that a frame cut short holds the same
//! number of samples in every pixel. Passes that fit twice over in the time left
//! are traced together, each pixel's in pass order, so that the threads wait for
//! each other a few times a frame rather than 64. The reasons are in docs/cli.md,
//! `--time`.

use super::{add_sums, row_groups, FrameCounters, FrameEnd, FrameSetup, PixelSums};
use crate::guide::{FrameSums, Recorder};
use crate::layout::AccumPixel;
use crate::math::rng::pcg_hash;
use crate::math::sampler::hash_combine;
use crate::shared;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// The frame's sample index (0..64) that pass `pass` traces in `pixel`: the
/// passes go through the 64 indices from one drawn per pixel and frame, so that
/// each sample of a frame cut short is, whatever its index, one of the frame's
/// own (its random numbers and, with independent samples, its sub-square of
/// the pixel) and lands anywhere in the pixel with equal chance: the first k
/// indices of every pixel would see only the top rows of its sub-squares. The
/// GLSL twin is `pass_sample` in `glsl/sampler.glsl` (a GPU frame's lanes for passes).
pub fn pass_sample(seed: u32, pixel: u32, rng_frame: u32, pass: u32) -> u32 {
    first_sample(seed, pixel, rng_frame).wrapping_add(pass) % shared::SAMPLES_PER_FRAME
}

/// [`pass_sample`]'s index of pass 0, unreduced.
fn first_sample(seed: u32, pixel: u32, rng_frame: u32) -> u32 {
    hash_combine(hash_combine(pcg_hash(seed ^ 0x85eb_ca6b), pixel), rng_frame)
}

/// Whether a pass taken to last `pass_ms` (None: unknown) that starts at `now`
/// ends by `deadline`.
pub(super) fn pass_fits(pass_ms: Option<f64>, now: Instant, deadline: Instant) -> bool {
    let pass = Duration::from_secs_f64(pass_ms.unwrap_or(0.0).max(0.0) / 1e3);
    now < deadline && now + pass <= deadline
}

/// What the passes traced: the samples per pixel, the last pass's time, what
/// was counted, and the targets recorded (None where no row recorded).
pub(super) struct Passes {
    pub samples: u32,
    pub pass_ms: Option<f64>,
    pub counters: FrameCounters,
    pub sums: Option<FrameSums>,
}

/// How many passes to trace together after `done` of `last`, at `now`: for
/// [`FrameEnd::Samples`] all of them; against a deadline, one where this frame's
/// pass time (`pass_ms`) is not measured yet, else as many as fit in half the
/// time left (at least one), so that a group that runs up to twice as slow as its
/// prediction still ends in time.
fn group(end: FrameEnd, done: u32, last: u32, pass_ms: Option<f64>, now: Instant) -> u32 {
    match (end, pass_ms) {
        (FrameEnd::Deadline(d), Some(pass)) if pass > 0.0 => {
            let left_ms = d.saturating_duration_since(now).as_secs_f64() * 1e3;
            ((left_ms / (2.0 * pass)) as u32).clamp(1, last - done)
        }
        (FrameEnd::Deadline(_), _) => 1,
        _ => last - done,
    }
}

/// Traces passes of one sample per pixel over the image whose accumulation is
/// `film` until 64 are done, or those `end` asks for, or at its deadline the next
/// is predicted, by the last pass's time, to end past it (the first always runs),
/// then adds each pixel's samples to `film` (weighed where `weigh` and the frame
/// is whole). The targets go to one set of sums per group of rows, kept over the
/// passes, as a table's sums are large.
pub(super) fn trace_passes(
    setup: &FrameSetup,
    film: &mut [AccumPixel],
    carry: &mut [[f32; 3]],
    end: FrameEnd,
    weigh: bool,
    no_sums: &(dyn Fn() -> FrameSums + Sync),
) -> Passes {
    let p = &setup.scene.params;
    let width = p.width as usize;
    // A pixel without its carry would be skipped by the zips below, not accumulated.
    assert_eq!(film.len(), carry.len(), "a film accumulated on the host keeps a carry per pixel");
    let mut pixels = vec![PixelSums::default(); film.len()];
    // The rows in fixed groups, each with its sums kept over the passes (`row_groups`).
    let mut groups: Vec<_> = row_groups(pixels.chunks_mut(width).zip(film.chunks(width)))
        .into_iter()
        .map(|rows| (rows, None::<FrameSums>))
        .collect();
    let mut counters = FrameCounters::default();
    let (mut samples, mut pass_ms) = (0, None);
    let last = match end {
        FrameEnd::Samples(k) => k,
        _ => shared::SAMPLES_PER_FRAME,
    };
    while samples < last {
        let start = Instant::now();
        if let (FrameEnd::Deadline(deadline), true) = (end, samples > 0) {
            if !pass_fits(pass_ms, start, deadline) {
                break;
            }
        }
        let passes = samples..samples + group(end, samples, last, pass_ms, start);
        let traced = groups
            .par_iter_mut()
            .map(|(rows, sums)| {
                let mut c = FrameCounters::default();
                for (y, (row, accs)) in rows.iter_mut() {
                    let (y, record) = (*y, setup.records(*y));
                    for (x, (px, acc)) in row.iter_mut().zip(accs.iter()).enumerate() {
                        let x = x as u32;
                        let (first, estimate) =
                            (first_sample(p.seed, y * p.width + x, setup.rng_frame), setup.estimate(acc));
                        for pass in passes.clone() {
                            let sample = first.wrapping_add(pass) % shared::SAMPLES_PER_FRAME;
                            let learn = record.then(|| sums.get_or_insert_with(no_sums) as &mut dyn Recorder);
                            setup.trace_sample((x, y), sample, estimate, learn, px, &mut c);
                        }
                    }
                }
                c
            })
            .reduce(FrameCounters::default, FrameCounters::plus);
        counters = counters.plus(traced);
        samples = passes.end;
        pass_ms = Some(start.elapsed().as_secs_f64() * 1e3 / passes.len() as f64);
    }
    let sums = groups.into_iter().map(|(_, sums)| sums).fold(None, add_sums);
    // Each pixel's samples into its accumulation; a frame cut short is not weighed.
    let weigh = weigh && samples == shared::SAMPLES_PER_FRAME;
    let finished = film
        .par_chunks_mut(width)
        .zip(carry.par_chunks_mut(width))
        .zip(pixels.par_chunks(width))
        .map(|((row, carries), sums)| {
            let mut c = FrameCounters::default();
            for ((acc, carry), &px) in row.iter_mut().zip(carries.iter_mut()).zip(sums) {
                setup.finish_pixel(acc, carry, px, samples, weigh, &mut c);
            }
            c
        })
        .reduce(FrameCounters::default, FrameCounters::plus);
    Passes { samples, pass_ms, counters: counters.plus(finished), sums }
}
