//! The frame timings the window's title shows: a mean over the recent frames.

/// Timings of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct FrameTime {
    pub(super) pathtrace_ms: f64,
    pub(super) learn_ms: f64,
    /// From timestamps; false: wall clock.
    pub(super) gpu: bool,
}

/// How many frames the title's timings average: two cycles of guiding's learning
/// at its longest, which runs after one guided frame in a stride of up to
/// `RECORD_MAX_STRIDE` and makes that frame longer (`RecordSchedule::learns_after`),
/// so that the readout holds still.
pub(super) const RECENT_FRAMES: usize = 2 * crate::shared::RECORD_MAX_STRIDE as usize;

/// The timings of the last `RECENT_FRAMES` frames since the accumulation restarted.
#[derive(Default)]
pub(super) struct RecentFrames(std::collections::VecDeque<FrameTime>);

impl RecentFrames {
    pub(super) fn push(&mut self, t: FrameTime) {
        if self.0.len() == RECENT_FRAMES {
            self.0.pop_front();
        }
        self.0.push_back(t);
    }

    pub(super) fn clear(&mut self) {
        self.0.clear();
    }

    /// The mean of the frames held (zero where there are none); `gpu` as the newest says.
    pub(super) fn mean(&self) -> FrameTime {
        let n = self.0.len().max(1) as f64;
        FrameTime {
            pathtrace_ms: self.0.iter().map(|t| t.pathtrace_ms).sum::<f64>() / n,
            learn_ms: self.0.iter().map(|t| t.learn_ms).sum::<f64>() / n,
            gpu: self.0.back().is_some_and(|t| t.gpu),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(pathtrace_ms: f64, learn_ms: f64) -> FrameTime {
        FrameTime { pathtrace_ms, learn_ms, gpu: true }
    }

    /// The title's timings: a mean over the last RECENT_FRAMES frames, which holds
    /// still while one frame in 32 learns.
    #[test]
    fn title_timings_average_the_recent_frames() {
        let mut r = RecentFrames::default();
        assert_eq!(r.mean(), FrameTime::default());
        r.push(frame(2.0, 0.5));
        assert_eq!(r.mean(), frame(2.0, 0.5));
        // Frames as guided rendering makes them after its first ones: the rows'
        // rebuild (0.4 in this test) after one frame in the largest stride.
        let stride = crate::shared::RECORD_MAX_STRIDE as usize;
        let mut means = Vec::new();
        for i in 0..5 * RECENT_FRAMES {
            r.push(frame(1.0, if i % stride == stride - 1 { 0.4 } else { 0.0 }));
            means.push(r.mean());
        }
        // Once the window holds only such frames, every frame shows the same figure.
        for m in &means[RECENT_FRAMES..] {
            assert_eq!(m.pathtrace_ms, 1.0);
            assert!((m.learn_ms - 0.4 / stride as f64).abs() < 1e-12, "{m:?}");
        }
        r.clear();
        assert_eq!(r.mean(), FrameTime::default());
        r.push(FrameTime { gpu: false, ..frame(3.0, 0.0) });
        assert!(!r.mean().gpu);
    }
}
