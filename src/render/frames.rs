//! A frame's work on the device: its push constants and kind, the dispatches
//! that trace it, the submission of frames with their learning passes and
//! timestamps, and what the kernel counted (`GpuRenderer::render_frames`,
//! `render_frame_profiled`).

use super::*;
use crate::film::FrameWeight;
use crate::math::sampler::rng_frame;
use crate::renderer::RoundReport;

/// GPU time a round of short frames fills ([`GpuRenderer::render_round`]): each
/// submission waits for the host, and frames of a fraction of a millisecond one
/// to a submission leave the GPU idle most of the time, and slower.
pub const ROUND_MS: f64 = 2.0;
/// A frame cut short to k samples per pixel is taken to cost this share of a
/// whole frame plus k/64 of it: its idle subgroups still take their workgroups'
/// places, so half the samples take about 0.7 of the time or more (docs/cli.md,
/// `--time`); the surplus keeps a cut frame from ending past the time limit.
pub const CUT_FRAME_FIXED: f64 = 0.4;

/// Frames in one round at most.
pub const ROUND_MAX_FRAMES: u32 = 64;

impl GpuRenderer {
    /// The kernel's push constants for the next frame (`rows` left 0, `cmd_trace`
    /// sets it per dispatch), counting the frame as traced and accumulated. The
    /// frame after the learning frames starts the image: the accumulation's
    /// frames become the learned frames, and the kernel takes their mean in as
    /// the image's first frame or writes over them (`accumulate`,
    /// `crate::film::accumulate`).
    ///
    /// The frame has `samples` samples per pixel, and in a timed race its kind's
    /// weight (`FrameRace::frame_weight`); the learning frames weigh 1.
    pub(super) fn next_frame(&mut self, kind: FrameKind, samples: u32) -> PathPush {
        let learning_frames = self.learning_frames();
        // The first image frame (frames traced in order, or handed out by
        // `MultiGpuRenderer`, which may skip frames) moves the learning frames out.
        let mut folds = false;
        if self.counts.accum_holds_learning && self.counts.frames_traced >= learning_frames {
            self.counts.learned_frames = self.counts.accum_frames;
            self.counts.accum_frames = 0;
            self.counts.accum_weight = 0.0;
            self.counts.accum_holds_learning = false;
            folds = self.learned == crate::film::Learned::Fold;
        } else if self.counts.frames_traced < learning_frames {
            self.counts.accum_holds_learning = true;
        }
        let push = PathPush {
            frame: if self.learning.is_some() { self.counts.guided_traced } else { self.counts.frames_traced },
            rng_frame: rng_frame(self.counts.frames_traced, learning_frames, self.frame_offset),
            accum_frames: self.counts.accum_frames,
            ablate: self.ablate,
            rows: 0,
            learned_frames: self.counts.learned_frames,
            table_frames: self.table_frames,
            fold_learned: folds as u32,
            samples,
            weight: 1.0,
            accum_weight: self.counts.accum_weight as f32,
        };
        let image = self.counts.frames_traced >= learning_frames;
        let weight = FrameWeight {
            samples,
            weight: self.race.as_ref().filter(|_| image).map_or(1.0, |r| r.frame_weight(kind)),
            before: push.accum_weight,
        };
        let push = PathPush { weight: weight.weight, ..push };
        self.counts.weighted |= weight.weight != 1.0;
        self.counts.frames_traced += 1;
        self.counts.accum_frames += 1;
        self.counts.accum_weight += weight.frames();
        if folds {
            // The learning frames' mean is now the image's first frame.
            self.counts.accum_frames += 1;
            self.counts.accum_weight += 1.0;
            self.counts.learned_frames = 0;
            self.counts.learning_folded = true;
        }
        if kind == FrameKind::Guided {
            self.counts.guided_traced += 1;
        }
        push
    }

    /// The kind of the next frame: guided with guiding (the race's choice past
    /// the learning frames, where there is a race), else unguided.
    pub(super) fn next_kind(&self) -> FrameKind {
        let Some(l) = &self.learning else { return FrameKind::Unguided };
        crate::guide::frame_kind(
            self.race.as_ref(),
            self.counts.frames_traced,
            self.counts.guided_traced,
            l.cfg.learning_frames,
        )
    }

    /// Records the dispatches of one frame (`frame_dispatches`) by the kernel of its
    /// kind. A `learning` frame's rows that record no targets take the unguided
    /// kernel (`learning_rows_unguided`, as `crate::cpu` `FrameSetup::trace_sample`).
    pub(super) fn cmd_trace(
        &self,
        cmd: crate::gpu::vk::CommandBuffer,
        push: PathPush,
        kind: FrameKind,
        learning: bool,
    ) {
        if let (Some(u), FrameKind::Unguided) = (&self.unguided, kind) {
            let wide = self.width.div_ceil(pixels_per_group(false, self.params.scene_kinds));
            let push = PathPush { rows: shared::ROWS_ALL, ..push };
            u.cmd_dispatch(cmd, [wide, self.height, 1], bytemuck::bytes_of(&push));
            return;
        }
        for d in frame_dispatches(self.learning.as_ref().map(|l| &l.schedule), push.frame, self.height) {
            let (pipeline, recording) = match (&self.recording, d.recording, &self.unguided) {
                (Some(r), true, _) => (r, true),
                (_, false, Some(u)) if learning => (u, false),
                _ => (&self.pipeline, false),
            };
            let wide = self.width.div_ceil(pixels_per_group(recording, self.params.scene_kinds));
            let push = PathPush { rows: d.rows, ..push };
            pipeline.cmd_dispatch(cmd, [wide, d.groups_y, 1], bytemuck::bytes_of(&push));
        }
    }

    /// [`DEVICE_LOST_HOOK`]: the device lost where tracing `count` more frames
    /// would pass the frames it names.
    pub(super) fn check_device_lost_hook(&self, count: u32) -> Result<(), GpuError> {
        match self.lose_device_after {
            Some(n) if self.counts.frames_traced.saturating_add(count) > n => {
                Err(self.ctx.lose_device("vkQueueSubmit"))
            }
            _ => Ok(()),
        }
    }

    /// Renders a round of frames in one submission: as many as fill [`ROUND_MS`]
    /// at the last submission's time per frame, up to [`ROUND_MAX_FRAMES`] and
    /// `max`, and where `time_left_ms` is set, no more than fit it (each taken to
    /// last as long, the first as long as the last round's first frame where that
    /// was longer: [`lone_frame_ms`](Self::lone_frame_ms)). Where not one whole frame fits, a last frame cut short to
    /// the samples that do ([`samples_that_fit`](Self::samples_that_fit); none
    /// where none fit), which ends the film. Where a race chooses the image
    /// frames' kernel, no more than a timed render's unguided opening left
    /// (`FrameRace::opens_unguided`), its run of one kind or the guided head
    /// start's frames left (`FrameRace::round_left`), and one frame until the
    /// image starts. One frame where there are no timestamps (the session judges
    /// the time by the wall clock) and before the first submission.
    pub fn render_round(&mut self, max: u32, time_left_ms: Option<f64>) -> Result<RoundReport, GpuError> {
        if let (Some(race), Some(left)) = (self.race.as_mut(), time_left_ms) {
            race.set_time_left(left);
        }
        let per_frame = self.next_frame_ms();
        let mut count = per_frame.map_or(1, |ms| ((ROUND_MS / ms) as u32).clamp(1, ROUND_MAX_FRAMES)).min(max.max(1));
        if let (Some(race), Some(l)) = (&self.race, &self.learning) {
            let image = self.counts.frames_traced >= l.cfg.learning_frames;
            let (traced, guided) = (self.counts.frames_traced, self.counts.guided_traced);
            // The opening's frames are a round of their own: the race's frames after
            // it measure against a mean of several.
            let left = match race.opens_unguided(traced, guided, l.cfg.learning_frames) {
                true => l.cfg.learning_frames + crate::guide::RACE_OPENING - traced,
                false => race.round_left(guided),
            };
            count = count.min(if image { left } else { 1 });
        }
        let mut samples = shared::SAMPLES_PER_FRAME;
        if let (Some(ms), Some(first), Some(left)) = (per_frame, self.lone_frame_ms(), time_left_ms) {
            let fit = if left >= first { 1.0 + (left - first) / ms } else { 0.0 };
            count = count.min(fit as u32);
            if count == 0 {
                samples = self.samples_that_fit(first, left);
                if samples == 0 {
                    return Ok(RoundReport { frames: 0, time_up: Some(true), ..Default::default() });
                }
                count = 1;
            }
        }
        let t = self.submit_frames_of(count, true, samples)?;
        let timestamps = self.ctx.info.timestamps;
        let ms = t.total_ms();
        let cut = samples < shared::SAMPLES_PER_FRAME;
        // As the session judges one frame: the next is taken to last as long as
        // these did, and a frame cut short to the samples that fit.
        let time_up = match (self.lone_frame_ms(), time_left_ms) {
            _ if cut => Some(true),
            (Some(next), Some(left)) if timestamps => Some(self.samples_that_fit(next, left - ms) == 0),
            (_, None) if timestamps => Some(false),
            _ => None,
        };
        Ok(RoundReport {
            frames: count,
            gpu_ms: timestamps.then_some(ms),
            learn_ms: timestamps.then_some(t.learn_ms),
            zero_paths: t.zero_paths,
            time_up,
            kind: t.kind,
            variance: t.variance.filter(|_| !cut),
            weight: t.weight,
            cut_spp: cut.then_some(samples),
        })
    }

    /// What a round's first frame is taken to last (ms): the last submission's
    /// time per frame, or its first frame's (timed apart) where that was longer.
    /// The first of a submission runs from cold caches, and a frame alone in its
    /// submission (a timed render's last, whole or cut short) takes about as
    /// long, at small sizes much longer than a warm one. None before the first
    /// submission or without timestamps.
    pub fn lone_frame_ms(&self) -> Option<f64> {
        let ms = self.next_frame_ms()?;
        Some(self.round_first_ms.map_or(ms, |first| first.max(ms)))
    }

    /// What a frame of the next round is taken to last (ms): the last
    /// submission's time per frame, or where a race chooses the kernel, its
    /// mean for the next frame's kind where that is longer (a round of guided
    /// frames after unguided ones takes longer). None before the first
    /// submission or without timestamps.
    fn next_frame_ms(&self) -> Option<f64> {
        let ms = self.round_frame_ms.filter(|_| self.ctx.info.timestamps)?;
        let kind_ms = self.race.as_ref().and_then(|r| r.frame_ms(self.next_kind()));
        Some(kind_ms.map_or(ms, |k| k.max(ms)))
    }

    /// The samples per pixel of a frame that fit `left_ms` where a whole one
    /// takes `frame_ms`: 64 where it fits whole; in the image (a learning
    /// frame is whole or none), else a multiple of the subgroup size (a frame
    /// cut short traces its samples in the first lanes of each pixel, and whole
    /// subgroups idle), a frame of k samples taken to cost [`CUT_FRAME_FIXED`]
    /// of a whole one plus k / 64 of it.
    pub fn samples_that_fit(&self, frame_ms: f64, left_ms: f64) -> u32 {
        let whole = shared::SAMPLES_PER_FRAME;
        if left_ms >= frame_ms {
            return whole;
        }
        if self.counts.frames_traced < self.learning_frames() || frame_ms <= 0.0 || left_ms <= 0.0 {
            return 0;
        }
        let lanes = self.ctx.info.subgroup_size.clamp(1, whole);
        let share = (left_ms / frame_ms - CUT_FRAME_FIXED).max(0.0);
        let groups = (share * (whole / lanes) as f64) as u32;
        (groups * lanes).min(whole - lanes)
    }

    /// Renders one frame of `samples` (1 to 64) samples per pixel, as the last
    /// frame of a render cut short at a time limit does: the same samples as
    /// `crate::cpu::CpuRenderer::render_frame_samples`. A frame of fewer than 64
    /// ends the film: no frame follows it until the accumulation is reset.
    pub fn render_frame_samples(&mut self, samples: u32) -> Result<FrameTimings, GpuError> {
        assert!((1..=shared::SAMPLES_PER_FRAME).contains(&samples), "a frame holds 1 to 64 samples per pixel");
        self.submit_frames_of(1, true, samples)
    }

    /// Renders `count` frames in one submission (each followed by learning when
    /// guiding is on: the fold and the rows' rebuild as `RecordSchedule::learns_after`
    /// says) and returns what they measured. Times come from timestamp
    /// queries (zero where the queue has none).
    pub fn render_frames(&mut self, count: u32) -> Result<FrameTimings, GpuError> {
        self.submit_frames(count, true)
    }

    /// [`render_frames`](Self::render_frames), learning after the frames that
    /// `RecordSchedule::learns_after` names only where `learn` (else the targets
    /// wait in the frame sums: `MultiGpuRenderer` learns from every device's at once).
    pub(super) fn submit_frames(&mut self, count: u32, learn: bool) -> Result<FrameTimings, GpuError> {
        self.submit_frames_of(count, learn, shared::SAMPLES_PER_FRAME)
    }

    /// [`submit_frames`](Self::submit_frames) of `samples` samples per pixel
    /// each: fewer than 64 only in one frame, the film's last.
    fn submit_frames_of(&mut self, count: u32, learn: bool, samples: u32) -> Result<FrameTimings, GpuError> {
        assert_eq!(self.counts.partial_spp, 0, "a frame cut short ends the film: reset the accumulation first");
        let cut = samples < shared::SAMPLES_PER_FRAME;
        assert!(!cut || count == 1, "only one frame is cut short");
        self.check_device_lost_hook(count)?;
        let timestamps = self.ctx.info.timestamps;
        let wall = std::time::Instant::now();
        let before = self.counts;
        // The image's frames of one submission are of one kind.
        let image_kind = self.next_kind();
        let learning_frames = self.learning_frames();
        let pushes: Vec<(PathPush, FrameKind, bool)> = (0..count)
            .map(|_| {
                let learning = self.counts.frames_traced < learning_frames;
                let kind = if learning { self.next_kind() } else { image_kind };
                (PathPush { ablate: 0, ..self.next_frame(kind, samples) }, kind, learning)
            })
            .collect();
        if cut {
            self.counts.partial_spp = samples;
        }
        // Stamps: 0 before the first frame, 1 after its path tracing (the first
        // frame of a kernel after the other's runs from cold caches: the race
        // times it apart), a pair around each learning pass (up to the timer's
        // room; passes past it count as path tracing), the last after everything.
        let passes = std::cell::Cell::new(0u32);
        let pass_pairs = (self.timer.capacity() - 3) / 2;
        let submitted = self.ctx.run_commands("pathtrace frames", |cmd| {
            self.counters.cmd_clear(cmd);
            self.ctx.barrier(cmd);
            if timestamps {
                self.timer.cmd_reset(cmd);
            }
            for (f, &(push, kind, learning)) in (0..count).zip(&pushes) {
                if f > 0 {
                    self.ctx.barrier(cmd);
                }
                if timestamps && f == 0 {
                    self.timer.cmd_stamp(cmd, 0);
                }
                self.cmd_trace(cmd, push, kind, learning);
                if timestamps && f == 0 {
                    self.timer.cmd_stamp(cmd, 1);
                }
                if let Some(l) = &self.learning {
                    if learn && kind == FrameKind::Guided && l.schedule.learns_after(push.frame) {
                        let k = passes.get();
                        let stamped = timestamps && k < pass_pairs;
                        if stamped {
                            self.timer.cmd_stamp(cmd, 2 + 2 * k);
                        }
                        l.cmd_learn(&self.ctx, cmd, |_| {});
                        if stamped {
                            self.timer.cmd_stamp(cmd, 3 + 2 * k);
                            passes.set(k + 1);
                        }
                    }
                }
            }
            if timestamps {
                self.timer.cmd_stamp(cmd, 2 + 2 * passes.get());
            }
            self.ctx.barrier(cmd);
            self.counters.cmd_copy_to(cmd, &self.counters_readback);
        });
        if let Err(e) = submitted {
            // The frames did not finish: the counts stay those of the accumulation.
            self.counts = before;
            return Err(e);
        }
        let (zero_paths, segments, subgroup_segments) = self.read_counters();
        let kind = pushes.last().map(|&(_, k, _)| k).filter(|_| self.learning.is_some());
        let variance = self.read_frame_variance(count);
        let weight = match (&self.race, pushes.last()) {
            (Some(race), Some(&(push, _, learning))) if race.timed() && !learning => Some(push.weight),
            _ => None,
        };
        let mut t =
            FrameTimings { zero_paths, segments, subgroup_segments, kind, variance, weight, ..Default::default() };
        if timestamps {
            let passes = passes.get();
            let s = self.timer.read(3 + 2 * passes)?;
            t.learn_ms = (0..passes as usize).map(|k| self.timer.ticks_to_ms(s[2 + 2 * k], s[3 + 2 * k])).sum();
            t.pathtrace_ms = self.timer.ticks_to_ms(s[0], s[2 + 2 * passes as usize]) - t.learn_ms;
            t.first_trace_ms = self.timer.ticks_to_ms(s[0], s[1]);
            if !cut {
                self.round_frame_ms = Some(t.total_ms() / count as f64);
                self.round_first_ms = Some(t.first_trace_ms);
            }
        }
        // A frame cut short ends the render; the kernel sums no variance for it.
        if let (Some(race), Some(v), Some(l), false) = (self.race.as_mut(), variance, &self.learning, cut) {
            let n = count as f64;
            // The first frame's path tracing as timed, the others' their mean;
            // each learning pass of the submission taken to last their mean.
            let (trace_ms, learn_ms) = if timestamps {
                let first = t.first_trace_ms;
                let rest = if count > 1 { (t.pathtrace_ms - first).max(0.0) / (n - 1.0) } else { first };
                ((first, rest), t.learn_ms / passes.get().max(1) as f64)
            } else {
                let ms = wall.elapsed().as_secs_f64() * 1e3 / n;
                ((ms, ms), 0.0)
            };
            let first = self.counts.frames_traced - count;
            for (i, &(push, kind, _)) in pushes.iter().enumerate() {
                // A guided frame's push.frame counts the guided frames before it.
                let guided_before = if kind == FrameKind::Guided { push.frame } else { self.counts.guided_traced };
                let learned = l.schedule.learns_after(push.frame).then_some(learn_ms);
                let at = (kind, first + i as u32, guided_before, learning_frames);
                let ms = if i == 0 { trace_ms.0 } else { trace_ms.1 };
                race.report_traced(at, v, ms, learned, l.schedule.learning_period(push.frame));
            }
        }
        Ok(t)
    }

    /// The race of the image's frames' kernels, where there is one.
    pub fn race(&self) -> Option<&FrameRace> {
        self.race.as_ref()
    }

    /// The mean relative variance of the last submission's `frames` frames, from
    /// the kernel's `add_frame_variance` slots (each a float word,
    /// `FRAME_VARIANCE_STRIDE` words apart, the last within `NUM_COUNTERS`); None
    /// where it keeps none.
    pub(super) fn read_frame_variance(&self, frames: u32) -> Option<f64> {
        if self.params.flags & shared::FLAG_FRAME_VARIANCE == 0 {
            return None;
        }
        const _: () = assert!(
            shared::COUNTER_FRAME_VARIANCE + shared::FRAME_VARIANCE_STRIDE * (shared::FRAME_VARIANCE_SLOTS - 1)
                < shared::NUM_COUNTERS
        );
        let c: Vec<f32> = bytemuck::pod_collect_to_vec(self.counters_readback.read());
        let sum = (0..shared::FRAME_VARIANCE_SLOTS)
            .map(|i| c[(shared::COUNTER_FRAME_VARIANCE + shared::FRAME_VARIANCE_STRIDE * i) as usize] as f64)
            .sum::<f64>();
        let pixels = (self.width * self.height) as f64;
        Some(sum / pixels / frames as f64)
    }

    /// Renders one frame in its own submission with a timestamp after each pass:
    /// what `rlpt bench` measures. Needs timestamp queries on the compute queue.
    pub fn render_frame_profiled(&mut self) -> Result<PassTimes, GpuError> {
        if !self.ctx.info.timestamps {
            return Err(GpuError::Unsupported {
                index: self.ctx.info.index,
                name: self.ctx.info.name.clone(),
                missing: "timestamp queries on the compute queue, which GPU timing needs".into(),
            });
        }
        self.check_device_lost_hook(1)?;
        // Profiling measures the kernels as they are: every frame guided with guiding.
        let kind = if self.learning.is_some() { FrameKind::Guided } else { FrameKind::Unguided };
        let learns = self.learning.as_ref().is_some_and(|l| l.schedule.learns_after(self.counts.guided_traced));
        let learning = self.counts.frames_traced < self.learning_frames();
        let push = self.next_frame(kind, shared::SAMPLES_PER_FRAME);
        self.ctx.run_commands("profiled frame", |cmd| {
            self.counters.cmd_clear(cmd);
            self.timer.cmd_reset(cmd);
            self.ctx.barrier(cmd);
            self.timer.cmd_stamp(cmd, 0);
            self.cmd_trace(cmd, push, kind, learning);
            self.timer.cmd_stamp(cmd, 1);
            // Learning's passes, and their stamps, after the frames it follows alone.
            if let Some(l) = self.learning.as_ref().filter(|_| learns) {
                l.cmd_learn(&self.ctx, cmd, |phase| self.timer.cmd_stamp(cmd, 2 + phase));
            }
            self.ctx.barrier(cmd);
            self.counters.cmd_copy_to(cmd, &self.counters_readback);
        })?;
        let (zero_paths, segments, subgroup_segments) = self.read_counters();
        let s = self.timer.read(if learns { 4 } else { 2 })?;
        let ms = |a: u64, b: u64| self.timer.ticks_to_ms(a, b);
        let mut t = PassTimes {
            start_ms: s[0] as f64 * self.ctx.info.timestamp_period_ns as f64 * 1e-6,
            pathtrace_ms: ms(s[0], s[1]),
            zero_paths,
            segments,
            subgroup_segments,
            ..Default::default()
        };
        if learns {
            t.learn_fold_ms = ms(s[1], s[2]);
            t.learn_rows_ms = ms(s[2], s[3]);
        }
        Ok(t)
    }

    /// The frame counters copied back by the last submission: (paths that carried
    /// nothing, rays traced, the subgroups' rays as `FrameTimings::subgroup_segments`
    /// has them), None where the kernel keeps none (`FLAG_COUNTERS`,
    /// `FLAG_COUNT_RAYS`).
    pub(super) fn read_counters(&self) -> (Option<u64>, Option<u64>, Option<u64>) {
        let flags = self.params.flags;
        if flags & shared::FLAG_COUNTERS == 0 {
            return (None, None, None);
        }
        let c: Vec<u32> = bytemuck::pod_collect_to_vec(self.counters_readback.read());
        let zero = Some(c[shared::COUNTER_ZERO_PATHS as usize] as u64);
        if flags & shared::FLAG_COUNT_RAYS == 0 {
            return (zero, None, None);
        }
        // The kernel adds the longest path's rays once per subgroup's worth of
        // lanes that trace paths, min(subgroup size, 64) lanes (pathtrace.comp).
        let lanes = self.ctx.info.subgroup_size.min(shared::SAMPLES_PER_FRAME) as u64;
        // 64-bit pairs, low word first (glsl/counters.glsl).
        let pair = |i: u32| c[i as usize] as u64 | (c[i as usize + 1] as u64) << 32;
        (zero, Some(pair(shared::COUNTER_SEGMENTS)), Some(pair(shared::COUNTER_SUBGROUP_SEGMENTS) * lanes))
    }
}
