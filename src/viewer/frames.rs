//! Each redraw's frames, traced by a `session::Session` as `rlpt render` traces
//! its own, and, with several GPUs, when their film is merged onto the
//! presenting GPU ([`MergeClock`]; docs/cli.md, "rlpt view").

use super::timings::FrameTime;
use super::Viewer;
use crate::gpu::{Buffer, GpuError};
use crate::session::{Budget, Renderer, Session, Stop};
use crate::shared;
use anyhow::{anyhow, Result};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// With several GPUs, their film is merged onto the presenting GPU once they
/// have rendered this many times as long as the last merge took: they wait
/// while it runs, so they idle at most about 1 / (1 + `MERGE_RATIO`) of the time.
pub(super) const MERGE_RATIO: f64 = 10.0;

/// When the film of several GPUs was last merged for display.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct MergeClock {
    /// Wall time of the last merge, ms.
    merge_ms: f64,
    /// Wall time of the rounds traced since, ms.
    rendered_ms: f64,
    /// Whether what is shown is older than the film (frames traced, or a restart).
    stale: bool,
    /// Whether the next merge is due whatever the clock says: after a restart,
    /// the new view shows after its first round.
    now: bool,
}

impl MergeClock {
    pub(super) fn restarted(&mut self) {
        self.stale = true;
        self.now = true;
    }

    pub(super) fn traced(&mut self, ms: f64) {
        self.rendered_ms += ms;
        self.stale = true;
    }

    /// Whether to merge now. `force`: whatever is stale is to be shown now (no
    /// frame is traced this redraw, or the scripted frames are done).
    pub(super) fn due(&self, force: bool) -> bool {
        self.stale && (force || self.now || self.rendered_ms >= MERGE_RATIO * self.merge_ms)
    }

    pub(super) fn merged(&mut self, ms: f64) {
        *self = MergeClock { merge_ms: ms, ..MergeClock::default() };
    }
}

/// No interrupt: the window's close ends the viewer between redraws.
static NEVER: AtomicBool = AtomicBool::new(false);

impl Viewer {
    /// Traces at most `max` frames (at least 1), a round of the renderer's
    /// (`GpuSet::round_frames`), by a session; returns how many it traced.
    pub(super) fn trace(&mut self, max: u32) -> Result<u32> {
        let (w, h) = self.display.size();
        let paths = w as f64 * h as f64 * shared::SAMPLES_PER_FRAME as f64;
        let renderer = &mut self.renderers[self.current].renderer;
        let budget = Budget { frames: max.min(renderer.round_frames()), time_ms: None };
        let gpu = renderer.timestamps();
        let start = Instant::now();
        let mut session = Session::new(Box::new(renderer), None, paths);
        let (stop, _) = session.run(budget, &NEVER)?;
        if let Stop::DeviceLost(detail) = stop {
            return Err(GpuError::DeviceLost(detail).into());
        }
        let n = session.traced();
        let (ms, learn_ms) = (session.elapsed_ms, session.learn_ms);
        drop(session);
        self.merge.traced(start.elapsed().as_secs_f64() * 1e3);
        if n > 0 {
            let per_frame = FrameTime { pathtrace_ms: (ms - learn_ms) / n as f64, learn_ms: learn_ms / n as f64, gpu };
            for _ in 0..n.min(super::timings::RECENT_FRAMES as u32) {
                self.recent.push(per_frame);
            }
        }
        self.rendered += n;
        Ok(n)
    }

    /// With several GPUs, merges their films onto the presenting GPU where due
    /// ([`MergeClock::due`]). Returns whether the window is to be drawn: always
    /// on one GPU (its accumulation is what the display pass reads), else after a
    /// merge or where `force`d.
    pub(super) fn merge_if_due(&mut self, force: bool) -> Result<bool> {
        let Some(shared) = self.shared.as_mut() else { return Ok(true) };
        if !self.merge.due(force) {
            return Ok(force);
        }
        let start = Instant::now();
        let film = self.renderers[self.current].renderer.film()?;
        shared.upload(&film);
        self.merge.merged(start.elapsed().as_secs_f64() * 1e3);
        Ok(true)
    }

    /// The accumulation the display pass reads: the merged one with several
    /// GPUs, else the renderer's own.
    pub(super) fn shown_accumulation(&self) -> Result<&Buffer> {
        match &self.shared {
            Some(s) => Ok(s.buffer()),
            None => Ok(self.renderers[self.current].renderer.first().ok_or_else(lost)?.accumulation()),
        }
    }

    /// Frames in the image shown.
    pub(super) fn shown_frames(&self) -> u32 {
        match &self.shared {
            Some(s) => s.frames(),
            None => self.renderers[self.current].renderer.image_frames(),
        }
    }
}

/// The error where no GPU is left to render.
pub(super) fn lost() -> anyhow::Error {
    anyhow!(GpuError::DeviceLost("every GPU of the view was lost".into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rounds of `round_ms` and merges of `merge_ms`: the devices wait for the
    /// merges at most about 1 / (1 + MERGE_RATIO) of the time, and a restart
    /// shows after its first round.
    #[test]
    fn merges_leave_the_devices_busy() {
        for (round_ms, merge_ms) in [(3.0, 5.0), (40.0, 5.0), (1.0, 30.0)] {
            let mut clock = MergeClock::default();
            clock.merged(merge_ms);
            let (mut busy, mut idle) = (0.0, 0.0);
            for _ in 0..10_000 {
                clock.traced(round_ms);
                busy += round_ms;
                if clock.due(false) {
                    clock.merged(merge_ms);
                    idle += merge_ms;
                }
            }
            let share = idle / (busy + idle);
            assert!(share <= 1.0 / (1.0 + MERGE_RATIO), "rounds {round_ms} ms, merges {merge_ms} ms: idle {share}");
            assert!(idle > 0.0, "the view was merged");
            clock.restarted();
            assert!(clock.due(false), "a restart shows at once");
            clock.merged(merge_ms);
            assert!(!clock.due(true), "nothing new: nothing to merge");
        }
    }
}
