//! One render session: the frame loop every renderer shares. A [`Session`] traces
//! frames of 64 samples per pixel (in rounds of several frames where a renderer
//! drives several GPUs, `crate::render::MultiGpuRenderer`) until its [`Budget`] of frames or time is spent,
//! an interrupt is raised (Ctrl-C) or the device is lost; it shows a progress bar
//! once a render passes a second, keeps each frame's statistics, and measures
//! relMSE against a reference at the frames [`measure_at`] and [`time_mark`] name.
//! `rlpt render` runs one for the whole render; `rlpt view` one per redraw.

use crate::cpu::CpuRenderer;
use crate::film::Film;
use crate::gpu::GpuError;
use crate::guide::QTable;
use crate::metrics::Reference;
use crate::render::GpuRenderer;
pub use crate::renderer::{FrameReport, Renderer, RoundReport};
use crate::stats::FrameStats;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

impl Renderer for CpuRenderer {
    fn render_frame(&mut self) -> Result<FrameReport, GpuError> {
        CpuRenderer::render_frame(self);
        Ok(FrameReport {
            gpu_ms: None,
            learn_ms: None,
            zero_paths: Some(self.last_counters.zero_paths),
            kind: self.last_kind,
            variance: self.last_variance,
            weight: self.last_weight,
        })
    }
    /// With a time limit, the frame that would end past it is cut short at it
    /// ([`CpuRenderer::render_frame_within`]), and the round says the time is up.
    fn render_round(&mut self, max: u32, time_left_ms: Option<f64>) -> Result<RoundReport, GpuError> {
        let _ = max;
        let (samples, time_up) = match time_left_ms {
            Some(left) => {
                let (samples, up) = CpuRenderer::render_frame_within(self, left);
                (samples, Some(up))
            }
            None => {
                CpuRenderer::render_frame(self);
                (crate::shared::SAMPLES_PER_FRAME, None)
            }
        };
        Ok(RoundReport {
            frames: (samples > 0) as u32,
            gpu_ms: None,
            learn_ms: None,
            zero_paths: Some(self.last_counters.zero_paths),
            time_up,
            kind: self.last_kind,
            variance: self.last_variance,
            weight: self.last_weight,
            cut_spp: (samples < crate::shared::SAMPLES_PER_FRAME).then_some(samples),
        })
    }
    fn image_frames(&self) -> u32 {
        CpuRenderer::film(self).frames - self.learning_folded() as u32
    }
    fn image_spp(&self) -> u32 {
        let folded = self.learning_folded() as u64 * crate::shared::SAMPLES_PER_FRAME as u64;
        (CpuRenderer::film(self).samples_per_pixel() - folded) as u32
    }
    fn learn_pending(&mut self) -> Result<(), GpuError> {
        CpuRenderer::learn_pending(self);
        Ok(())
    }
    fn film(&self) -> Result<Film, GpuError> {
        Ok(CpuRenderer::film(self).clone())
    }
    fn device_name(&self) -> String {
        format!("CPU ({} threads)", rayon::current_num_threads())
    }
    fn timestamps(&self) -> bool {
        false
    }
    fn table(&self) -> Result<Option<QTable>, GpuError> {
        Ok(CpuRenderer::table(self).cloned())
    }
}

impl Renderer for GpuRenderer {
    fn render_frame(&mut self) -> Result<FrameReport, GpuError> {
        let t = self.render_frames(1)?;
        Ok(FrameReport {
            gpu_ms: self.context().info.timestamps.then_some(t.total_ms()),
            learn_ms: self.context().info.timestamps.then_some(t.learn_ms),
            zero_paths: t.zero_paths,
            kind: t.kind,
            variance: t.variance,
            weight: t.weight,
        })
    }
    fn render_round(&mut self, max: u32, time_left_ms: Option<f64>) -> Result<RoundReport, GpuError> {
        GpuRenderer::render_round(self, max, time_left_ms)
    }
    fn learn_pending(&mut self) -> Result<(), GpuError> {
        GpuRenderer::learn_pending(self)
    }
    fn image_frames(&self) -> u32 {
        self.frames() - self.learning_folded() as u32
    }
    fn image_spp(&self) -> u32 {
        crate::film::samples_in(self.image_frames(), self.partial_spp()) as u32
    }
    fn film(&self) -> Result<Film, GpuError> {
        GpuRenderer::film(self)
    }
    fn device_name(&self) -> String {
        self.context().info.name.clone()
    }
    fn timestamps(&self) -> bool {
        self.context().info.timestamps
    }
    fn table(&self) -> Result<Option<QTable>, GpuError> {
        GpuRenderer::table(self)
    }
}

/// How much a session may render: at most `frames` frames (the learning frames
/// counted), and where `time_ms` is set, no frame that would end past it, each
/// taken to last as long as the frame before (the first frame always runs; a
/// frame slower than the one before ends past the limit by the difference). The
/// frame that would end past it is traced cut short: on the CPU up to the limit
/// ([`CpuRenderer::render_frame_within`]), on one GPU to the samples that fit
/// (`GpuRenderer::render_round`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    pub frames: u32,
    pub time_ms: Option<f64>,
}

/// Why a session stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Stop {
    /// Every frame of the budget, or its time ran out.
    Finished,
    /// The interrupt was raised before the last frame.
    Interrupted,
    /// The GPU was lost (`VK_ERROR_DEVICE_LOST`); what it said of the call.
    DeviceLost(String),
}

/// A session's failure other than a lost device, which is a [`Stop`].
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// relMSE could not be measured against the reference: what the comparison said.
    #[error("{0}")]
    Measure(String),
}

/// A render in progress: its renderer, the reference it is measured against, and
/// what its frames so far did.
pub struct Session<'a> {
    pub renderer: Box<dyn Renderer + 'a>,
    reference: Option<&'a Reference>,
    /// Paths a frame traces (pixels times 64), for the zero-radiance fraction.
    paths_per_frame: f64,
    /// Each frame traced, the learning frames included; with several GPUs, each
    /// round of frames (its last frame's number, the round's time).
    pub frames: Vec<FrameStats>,
    /// Render time so far: GPU time where the renderer has timestamps, else wall clock.
    pub elapsed_ms: f64,
    /// The learning passes' share of `elapsed_ms`, where the renderer times them.
    pub learn_ms: f64,
}

impl<'a> Session<'a> {
    pub fn new(renderer: Box<dyn Renderer + 'a>, reference: Option<&'a Reference>, paths_per_frame: f64) -> Self {
        Session { renderer, reference, paths_per_frame, frames: Vec::new(), elapsed_ms: 0.0, learn_ms: 0.0 }
    }

    /// Frames traced so far, the learning frames included.
    pub fn traced(&self) -> u32 {
        self.frames.last().map_or(0, |f| f.frame)
    }

    /// Renders within `budget`, checking `interrupt` between frames. Returns why it
    /// stopped and, where relMSE was measured at the last frame, the film read for
    /// it (so that it is not read back twice).
    pub fn run(&mut self, budget: Budget, interrupt: &AtomicBool) -> Result<(Stop, Option<Film>), SessionError> {
        let bar = ProgressBar::with_draw_target(Some(budget.frames as u64), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} frames ({eta} left)")
                .expect("valid template")
                .progress_chars("=> "),
        );
        let start = Instant::now();
        let mut shown = false;
        let mut film = None;
        let mut stop = Stop::Finished;
        let mut f = self.traced();
        while f < budget.frames {
            let frame_start = Instant::now();
            let time_left = budget.time_ms.map(|limit| limit - self.elapsed_ms);
            let report = match self.renderer.render_round(budget.frames - f, time_left) {
                Ok(r) => r,
                Err(GpuError::DeviceLost(detail)) => {
                    stop = Stop::DeviceLost(detail);
                    break;
                }
                Err(e) => return Err(e.into()),
            };
            let n = report.frames;
            if n == 0 {
                // Nothing fitted the time left (a renderer that keeps the budget itself).
                break;
            }
            // The round's frames' paths; a frame cut short traced its share of a whole frame's.
            let paths = self.paths_per_frame
                * report.cut_spp.map_or(n as f64, |k| k as f64 / crate::shared::SAMPLES_PER_FRAME as f64);
            let frame_ms = report.gpu_ms.unwrap_or_else(|| frame_start.elapsed().as_secs_f64() * 1e3);
            let mark = time_mark(self.elapsed_ms, self.elapsed_ms + frame_ms);
            self.elapsed_ms += frame_ms;
            self.learn_ms += report.learn_ms.unwrap_or(0.0);
            // The next frame is taken to last as long as this one: the session
            // stops where it would end past the limit, so that --time T ends by T.
            // A renderer of rounds judges its devices' next frames itself.
            let out_of_time = report
                .time_up
                .unwrap_or_else(|| budget.time_ms.is_some_and(|limit| self.elapsed_ms + frame_ms > limit));
            let interrupted = interrupt.load(Ordering::SeqCst) && f + n < budget.frames;
            let last = f + n == budget.frames || out_of_time || interrupted;
            let errors = match self.reference {
                Some(r) if last || mark || (f + 1..=f + n).any(measure_at) => {
                    let current = self.renderer.film()?;
                    let e = r.compare(&current.mean()).map_err(SessionError::Measure)?;
                    if last {
                        film = Some(current);
                    }
                    Some(e)
                }
                _ => None,
            };
            self.frames.push(FrameStats {
                frame: f + n,
                spp: self.renderer.image_spp(),
                gpu_ms: report.gpu_ms,
                elapsed_ms: self.elapsed_ms,
                rel_mse: errors.map(|e| e.rel_mse),
                rel_mse_debiased: errors.and_then(|e| e.rel_mse_debiased),
                zero_fraction: report.zero_paths.map(|z| z as f64 / paths),
                unguided: report.kind == Some(crate::guide::FrameKind::Unguided),
                frame_variance: report.variance,
                weight: report.weight.map(f64::from),
            });
            if !shown && start.elapsed() > Duration::from_secs(1) {
                bar.set_draw_target(ProgressDrawTarget::stderr());
                shown = true;
            }
            f += n;
            bar.set_position(f as u64);
            if interrupted {
                stop = Stop::Interrupted;
                break;
            }
            if out_of_time {
                break;
            }
        }
        bar.finish_and_clear();
        Ok((stop, film))
    }
}

/// Frames at which relMSE is measured against the reference: about 24 per decade
/// (each readback and comparison costs host time, not GPU time), the last, and
/// the first frame at or past each power of ten of elapsed time ([`time_mark`]).
pub fn measure_at(frame: u32) -> bool {
    let f = frame as f64;
    frame <= 8 || (f.log10() * 24.0).floor() != ((f - 1.0).log10() * 24.0).floor()
}

/// Whether a frame that took the elapsed time from `before_ms` to `after_ms` is
/// the first at or past a power of ten of milliseconds from 100 ms on (0.1 s,
/// 1 s, 10 s...): relMSE is measured there, so that runs whose frames take
/// different times are compared at equal time to within one frame, not at
/// whichever of their geometric frames falls nearest.
pub fn time_mark(before_ms: f64, after_ms: f64) -> bool {
    let mut mark = 100.0;
    while mark <= before_ms {
        mark *= 10.0;
    }
    after_ms >= mark
}

#[cfg(test)]
mod tests {
    use super::*;

    /// relMSE is measured at the first frame at or past 0.1 s, 1 s, 10 s... of
    /// elapsed time, once each, whatever the frames' length.
    #[test]
    fn time_marks_fall_on_the_first_frame_past_each_power_of_ten() {
        for dt in [0.37, 1.0, 7.3, 99.0] {
            let (mut t, mut marks) = (0.0f64, Vec::new());
            while t < 20000.0 {
                if time_mark(t, t + dt) {
                    marks.push((t, t + dt));
                }
                t += dt;
            }
            assert_eq!(marks.len(), 3, "frames of {dt} ms: {marks:?}");
            for ((before, after), mark) in marks.into_iter().zip([100.0, 1000.0, 10000.0]) {
                assert!(before < mark && after >= mark, "frames of {dt} ms: {before}..{after} for {mark}");
            }
        }
        assert!(time_mark(50.0, 5000.0), "a frame past two marks");
        assert!(!time_mark(100.0, 999.0) && time_mark(999.0, 1000.0));
    }
}
