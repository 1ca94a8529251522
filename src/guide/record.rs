//! Recording Q-learning targets: which pixel rows record in which frame
//! ([`RecordSchedule`]), and the per-frame sums of targets ([`FrameSums`], the
//! CPU twin of `glsl/record.glsl`).

use super::*;

/// Recorded paths per table entry at which the recording stride first doubles
/// ([`RecordSchedule`]); it doubles again at twice as many, and so on.
pub const RECORD_PATHS_PER_ENTRY: f64 = 1024.0;

/// Pixel-frames ([`RecordSchedule::min_learning_period`]) a learning period spans at
/// least: below this many pixels, the table learns once in several recording
/// cycles, so that the pass, whose time does not shrink with the image, stays a
/// small share of a small image's frames (docs/guiding.md, "Small images").
pub const LEARN_PIXEL_FRAMES: u64 = 1 << 17;

/// Pixels that record in each of the first `RECORD_FIRST_FRAMES` frames at least
/// ([`RecordSchedule::first_stride`]).
pub const FIRST_RECORD_PIXELS: u64 = 1 << 16;

/// The longest learning period [`RecordSchedule::min_learning_period`] gives.
pub const MAX_LEARNING_PERIOD: u32 = 1 << 10;

/// Which pixel rows hand their paths' Q-learning targets to the table, frame by
/// frame (counted from the first frame traced): in the first
/// `RECORD_FIRST_FRAMES` frames every row, or one in [`RecordSchedule::first_stride`]
/// over large images, then every row in one frame of each cycle of a stride's
/// frames, its first ([`RecordSchedule::records_frame`]). The stride starts at `RECORD_ROW_STRIDE` and doubles, up to
/// `RECORD_MAX_STRIDE`, each time the paths recorded so far reach
/// [`RECORD_PATHS_PER_ENTRY`] per table entry, then twice that, and so on: a large
/// image over a small table gets there within a few frames, a thumbnail seldom.
/// Each stride starts at a frame that is a multiple of it, so that every row
/// records once per cycle of `stride` frames.
///
/// Q is a weighted mean of its targets ([`batch_rate`]), so recording fewer of
/// them keeps it consistent. The rows that record run a slower kernel than the
/// others (whole workgroups skip recording, since a group's pixels share a row),
/// so fewer recording rows make shorter frames (docs/guiding.md, "The recording
/// schedule"). On the GPU, `crate::render::frame_dispatches` gives the recording
/// rows to the kernel that records; the CPU renderer follows the same schedule.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordSchedule {
    /// The first frame of each doubled stride: `RECORD_ROW_STRIDE << (k + 1)` from
    /// `doublings[k]` on.
    doublings: Vec<u32>,
    /// Frames per learning pass at least, past the first `RECORD_FIRST_FRAMES`: a
    /// power of two ([`RecordSchedule::learns_after`]).
    min_period: u32,
    /// The stride of the first `RECORD_FIRST_FRAMES` frames ([`RecordSchedule::first_stride`]).
    first_stride: u32,
}

impl RecordSchedule {
    /// The schedule of a render of `pixels` pixels (`SAMPLES_PER_FRAME` paths each
    /// per frame) over a table of `entries` entries, learning once in `min_period`
    /// frames at most (a power of two; 1 learns once per recording cycle).
    pub fn new(pixels: u64, entries: u64, min_period: u32) -> RecordSchedule {
        assert!(min_period.is_power_of_two(), "learning period {min_period}: not a power of two");
        use shared::{RECORD_FIRST_FRAMES, RECORD_MAX_STRIDE, RECORD_ROW_STRIDE, SAMPLES_PER_FRAME};
        // In frames of every row: recorded so far, and needed for the next doubling.
        let per_entry = (pixels * SAMPLES_PER_FRAME as u64) as f64 / entries.max(1) as f64;
        let first_stride = RecordSchedule::first_stride(pixels);
        let mut recorded = RECORD_FIRST_FRAMES as f64 / first_stride as f64;
        let mut needed = RECORD_PATHS_PER_ENTRY / per_entry.max(1e-12);
        let (mut frame, mut stride) = (RECORD_FIRST_FRAMES as u64, RECORD_ROW_STRIDE as u64);
        let mut doublings = Vec::new();
        while stride < RECORD_MAX_STRIDE as u64 && frame < u32::MAX as u64 {
            let more = ((needed - recorded).max(0.0) * stride as f64).ceil().min(u32::MAX as f64) as u64;
            let start = (frame + more).next_multiple_of(2 * stride);
            recorded += (start - frame) as f64 / stride as f64;
            frame = start;
            doublings.push(frame.min(u32::MAX as u64) as u32);
            stride *= 2;
            needed *= 2.0;
        }
        RecordSchedule { doublings, min_period, first_stride }
    }

    /// One row in this many records in the first `RECORD_FIRST_FRAMES` frames:
    /// the largest power of two that leaves [`FIRST_RECORD_PIXELS`] pixels
    /// recording per frame, up to `RECORD_ROW_STRIDE` (1, every row, below twice
    /// as many pixels). Recording is most of those frames' extra cost, and a
    /// large image's rows record more targets than a table that starts needs
    /// (docs/guiding.md, "The recording schedule").
    pub fn first_stride(pixels: u64) -> u32 {
        let s = (pixels / FIRST_RECORD_PIXELS).max(1);
        (1u64 << s.ilog2()).min(shared::RECORD_ROW_STRIDE as u64) as u32
    }

    /// The schedule of a guided render of `width` x `height` pixels: its learning
    /// period `cfg.learning_period`, else [`min_learning_period`](Self::min_learning_period).
    pub fn for_render(cfg: &GuideConfig, width: u32, height: u32) -> RecordSchedule {
        let pixels = width as u64 * height as u64;
        let period = cfg.learning_period.unwrap_or_else(|| RecordSchedule::min_learning_period(pixels));
        RecordSchedule::new(pixels, cfg.entries() as u64, period)
    }

    /// The default learning period of an image of `pixels` pixels: the fewest
    /// frames, a power of two, that trace [`LEARN_PIXEL_FRAMES`] pixel-frames (1 for
    /// images of that many pixels or more), at most [`MAX_LEARNING_PERIOD`].
    pub fn min_learning_period(pixels: u64) -> u32 {
        let frames = LEARN_PIXEL_FRAMES.div_ceil(pixels.max(1)).next_power_of_two();
        frames.min(MAX_LEARNING_PERIOD as u64) as u32
    }

    /// One pixel row in this many records in frame `frame`: the first stride in
    /// the first `RECORD_FIRST_FRAMES` frames, then `RECORD_ROW_STRIDE` up to `RECORD_MAX_STRIDE`.
    pub fn stride(&self, frame: u32) -> u32 {
        if frame < shared::RECORD_FIRST_FRAMES {
            return self.first_stride;
        }
        shared::RECORD_ROW_STRIDE << self.doublings.iter().filter(|&&d| frame >= d).count()
    }

    /// Whether the paths of pixel row `y` record their targets in frame `frame`:
    /// in the first `RECORD_FIRST_FRAMES` frames, which learn after each, one row
    /// in the first stride, a different one each frame; then every row in the first
    /// frame of each cycle ([`records_frame`](Self::records_frame)).
    pub fn records(&self, frame: u32, y: u32) -> bool {
        match self.records_frame(frame) {
            Some(all) => all,
            None => (y + frame).is_multiple_of(self.stride(frame)),
        }
    }

    /// Whether every row of frame `frame` records (Some(true)) or none does
    /// (Some(false)); None in the first `RECORD_FIRST_FRAMES` frames, whose rows
    /// take turns. Past them the table learns only at the end of a cycle
    /// ([`learns_after`](Self::learns_after)), so a cycle whose first frame
    /// records every row hands it the same targets as one whose frames each
    /// record a row in `stride`, and each frame is one dispatch of one kernel
    /// (docs/guiding.md, "The recording schedule"). The first, so that a render
    /// stopped within a cycle has its targets to fold (`learn_pending`).
    pub fn records_frame(&self, frame: u32) -> Option<bool> {
        if frame < shared::RECORD_FIRST_FRAMES {
            return None;
        }
        let stride = self.stride(frame);
        Some(frame.is_multiple_of(stride))
    }

    /// Whether the table learns after frame `frame`: the targets recorded since
    /// it last learned are folded into Q, and the sampling rows rebuilt from it
    /// ([`QTable::learn`]). After each of the first `RECORD_FIRST_FRAMES` frames,
    /// while the table changes fast, then after the last frame of each cycle of
    /// the recording rows, one frame in `stride`, when every row has recorded once.
    /// Small images learn once in several cycles, the schedule's `min_period`
    /// frames. In between, the targets are summed per entry, and paths read a table and
    /// sample rows a few frames old; the densities they evaluate are those of the
    /// same rows, so the estimate stays unbiased, and Q takes the same targets,
    /// folded later. The rebuild is a sequential loop per row, and learning
    /// once per cycle spares most frames its pass. Rows go staler as the stride
    /// grows, but only once the table has seen many targets per entry and changes
    /// little from frame to frame; that is why the stride follows the table's
    /// fill, not the frame count (docs/guiding.md, "The recording schedule").
    pub fn learns_after(&self, frame: u32) -> bool {
        let period = if frame < shared::RECORD_FIRST_FRAMES { 1 } else { self.learning_period(frame) };
        frame % period == period - 1
    }

    /// Frames per learning pass once the first `RECORD_FIRST_FRAMES` are past, at
    /// frame `frame`: its stride, or the schedule's `min_period` where that is
    /// longer. The share of a pass each guided frame costs in the long run
    /// ([`FrameRace::report_guided`]).
    pub fn learning_period(&self, frame: u32) -> u32 {
        self.stride(frame.max(shared::RECORD_FIRST_FRAMES)).max(self.min_period)
    }
}

/// What a path that records hands over: Q-learning targets, and where each
/// cell learns its guided fraction, the gradient samples of its fraction.
pub trait Recorder {
    /// The target of the ray that left through table entry `key`.
    fn target(&mut self, key: u32, target: f32);
    /// A sample of the gradient of the KL divergence with respect to the logit
    /// of `cell`'s fraction ([`FractionState`]).
    fn fraction_gradient(&mut self, cell: u32, gradient: f32);
    /// Sampling row `row` (its index, `cell * NORMAL_CLASSES + class`) was read by
    /// a guided vertex ([`QTable::rows_read`]).
    fn row_read(&mut self, row: usize);
}

/// Targets summed per entry, and fraction gradients per cell: a frame's, or
/// those of the frames since the table last learned.
#[derive(Clone, Debug)]
pub struct FrameSums {
    pub sums: Vec<f32>,
    pub counts: Vec<u32>,
    pub gradients: Vec<f32>,
    pub gradient_counts: Vec<u32>,
    /// Sampling rows read by guided vertices ([`QTable::rows_read`]).
    pub rows_read: Vec<bool>,
}

impl Recorder for FrameSums {
    fn target(&mut self, key: u32, target: f32) {
        self.sums[key as usize] += target;
        self.counts[key as usize] += 1;
    }
    fn fraction_gradient(&mut self, cell: u32, gradient: f32) {
        self.gradients[cell as usize] += gradient;
        self.gradient_counts[cell as usize] += 1;
    }
    fn row_read(&mut self, row: usize) {
        self.rows_read[row] = true;
    }
}

impl FrameSums {
    /// Empty sums for `entries` table entries over `cells` cells.
    pub fn new(entries: usize, cells: usize) -> FrameSums {
        FrameSums {
            sums: vec![0.0; entries],
            counts: vec![0; entries],
            gradients: vec![0.0; cells],
            gradient_counts: vec![0; cells],
            rows_read: vec![false; cells * NORMAL_CLASSES as usize],
        }
    }
    /// Empty sums for a table of `cfg`'s shape.
    pub fn for_config(cfg: &GuideConfig) -> FrameSums {
        FrameSums::new(cfg.entries(), cfg.cells() as usize)
    }
    /// Adds `other`'s sums and counts to these.
    pub fn add_all(&mut self, other: &FrameSums) {
        fn add<T: Copy + std::ops::AddAssign>(a: &mut [T], b: &[T]) {
            for (a, &b) in a.iter_mut().zip(b) {
                *a += b;
            }
        }
        add(&mut self.sums, &other.sums);
        add(&mut self.counts, &other.counts);
        add(&mut self.gradients, &other.gradients);
        add(&mut self.gradient_counts, &other.gradient_counts);
        for (a, &b) in self.rows_read.iter_mut().zip(&other.rows_read) {
            *a |= b;
        }
    }
    pub fn merge(mut self, other: FrameSums) -> FrameSums {
        self.add_all(&other);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first frames record every row below twice `FIRST_RECORD_PIXELS`
    /// pixels, and over larger images one row in the largest power of two that
    /// leaves that many recording, up to `RECORD_ROW_STRIDE`.
    #[test]
    fn large_images_record_fewer_rows_in_the_first_frames() {
        let first = RecordSchedule::first_stride;
        let n = FIRST_RECORD_PIXELS;
        assert_eq!((first(0), first(64 * 40), first(2 * n - 1), first(2 * n), first(4 * n - 1)), (1, 1, 1, 2, 2));
        assert_eq!((first(480 * 320), first(640 * 480), first(960 * 640), first(1920 * 1080)), (2, 4, 8, 8));
        assert_eq!(shared::RECORD_ROW_STRIDE, 8);
        let s = RecordSchedule::new(640 * 480, 1 << 20, 1);
        for f in 0..shared::RECORD_FIRST_FRAMES {
            assert_eq!(s.stride(f), 4);
            assert!(s.learns_after(f), "frame {f}: the first frames learn after each");
            assert_eq!((0..4).filter(|&y| s.records(f, y)).count(), 1, "frame {f}: one row in 4 records");
        }
        assert_eq!(s.stride(shared::RECORD_FIRST_FRAMES), shared::RECORD_ROW_STRIDE);
    }

    /// Past the first frames, every row records in the first frame of each cycle
    /// and no row in its other frames, and the table learns at the cycle's end.
    #[test]
    fn past_the_first_frames_the_cycles_first_frame_records_every_row() {
        for (pixels, period) in [(64 * 40, 64), (640 * 480, 1), (1600 * 1000, 1)] {
            let s = RecordSchedule::new(pixels, 1 << 16, period);
            for f in 0..shared::RECORD_FIRST_FRAMES {
                assert_eq!(s.records_frame(f), None, "{pixels} px, frame {f}");
            }
            for f in shared::RECORD_FIRST_FRAMES..2000 {
                let stride = s.stride(f);
                let first = f % stride == 0;
                assert_eq!(s.records_frame(f), Some(first), "{pixels} px, frame {f}");
                assert!((0..3 * stride).all(|y| s.records(f, y) == first), "{pixels} px, frame {f}");
                let p = period.max(stride);
                assert_eq!(s.learns_after(f), f % p == p - 1, "{pixels} px, frame {f}");
            }
        }
    }
}
