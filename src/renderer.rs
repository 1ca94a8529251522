//! What the frame loop needs of a renderer (`Renderer`) and what a frame or a
//! round of frames reports; below `cpu` and `render`, which implement it, and
//! `session`, which drives it (and re-exports it).

use crate::film::Film;
use crate::gpu::GpuError;
use crate::guide::QTable;

/// What one frame reports to the session.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameReport {
    /// GPU time of the frame, from timestamps; None where there are none (the CPU).
    pub gpu_ms: Option<f64>,
    /// The learning pass's share of `gpu_ms`, where it is timed.
    pub learn_ms: Option<f64>,
    /// Paths that carried zero radiance, where the renderer counts them.
    pub zero_paths: Option<u64>,
    /// The kernel that traced the frame, with guiding (`guide::FrameRace`).
    pub kind: Option<crate::guide::FrameKind>,
    /// The frame's mean relative variance, where the renderer weighs it.
    pub variance: Option<f64>,
    /// What the frame weighs in the image (`crate::film::FrameWeight`), where a
    /// timed race weighs frames by their kind; None where every frame weighs 1.
    pub weight: Option<f32>,
}

/// What one round of frames reports to the session ([`Renderer::render_round`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoundReport {
    /// New frames the round traced (at least one unless `time_up`).
    pub frames: u32,
    /// Time of the round, from timestamps: with several devices, as long as the
    /// busiest device took (they run in parallel); None where there are none.
    pub gpu_ms: Option<f64>,
    /// The learning passes' share of `gpu_ms`, where they are timed.
    pub learn_ms: Option<f64>,
    /// Paths that carried zero radiance, where the renderer counts them.
    pub zero_paths: Option<u64>,
    /// Where the renderer keeps the time budget itself: whether no further frame
    /// fits the time left. None where the session judges it (one frame a round).
    pub time_up: Option<bool>,
    /// The kernel of a one-frame round, with guiding (`guide::FrameRace`).
    pub kind: Option<crate::guide::FrameKind>,
    /// The one frame's mean relative variance, where the renderer weighs it.
    pub variance: Option<f64>,
    /// What each of the round's image frames weighs, where a timed race weighs
    /// frames by their kind ([`FrameReport::weight`]).
    pub weight: Option<f32>,
    /// The samples per pixel of a last frame cut short at the time limit (the
    /// CPU's, or one GPU's), None where every frame was whole.
    pub cut_spp: Option<u32>,
}

/// What the frame loop needs of a renderer: `crate::render::GpuRenderer`,
/// `crate::cpu::CpuRenderer` (their impls in `crate::session`),
/// `crate::render::MultiGpuRenderer` and `crate::render::GpuSet`.
pub trait Renderer {
    /// Traces one frame: a learning frame, or one of the image.
    fn render_frame(&mut self) -> Result<FrameReport, GpuError>;
    /// Traces a round of at most `max` frames (`max` at least 1), where
    /// `time_left_ms` is set none that its renderer judges would end past it.
    /// One frame, the time judged by the session, unless a renderer does more
    /// (the CPU's and one GPU's last frame is cut short to the time left).
    fn render_round(&mut self, max: u32, time_left_ms: Option<f64>) -> Result<RoundReport, GpuError> {
        let _ = (max, time_left_ms);
        let r = self.render_frame()?;
        Ok(RoundReport {
            frames: 1,
            gpu_ms: r.gpu_ms,
            learn_ms: r.learn_ms,
            zero_paths: r.zero_paths,
            time_up: None,
            kind: r.kind,
            variance: r.variance,
            weight: r.weight,
            cut_spp: None,
        })
    }
    /// The image's own frames: the learning frames not counted once it starts,
    /// though their mean may be one of the film's frames (`crate::film::Learned`).
    fn image_frames(&self) -> u32;
    /// Samples per pixel of the image: its frames' 64 each, less what a last
    /// frame cut short lacks ([`Film::partial_spp`]).
    fn image_spp(&self) -> u32 {
        self.image_frames() * crate::shared::SAMPLES_PER_FRAME
    }
    /// The image so far.
    fn film(&self) -> Result<Film, GpuError>;
    /// The device, in words: a GPU's name, or the CPU and its threads.
    fn device_name(&self) -> String;
    /// Whether frames report GPU time; the session times wall clock where not.
    fn timestamps(&self) -> bool;
    /// The learned table, None without guiding.
    fn table(&self) -> Result<Option<QTable>, GpuError>;
    /// Folds the targets recorded since the table last learned into it and
    /// rebuilds its rows, so that a table saved after the render holds every
    /// frame's targets (the schedule learns only after some frames). Nothing
    /// without guiding.
    fn learn_pending(&mut self) -> Result<(), GpuError> {
        Ok(())
    }
}

/// In an `impl Renderer` of a renderer that wraps another, `$inner` (an
/// expression of `$self`): the methods that ask about the image, the device and
/// the table, answered by the wrapped renderer.
macro_rules! forward_renderer_queries {
    ($self:ident => $inner:expr) => {
        fn image_frames(&$self) -> u32 {
            $inner.image_frames()
        }
        fn image_spp(&$self) -> u32 {
            $inner.image_spp()
        }
        fn film(&$self) -> Result<$crate::film::Film, $crate::gpu::GpuError> {
            $inner.film()
        }
        fn device_name(&$self) -> String {
            $inner.device_name()
        }
        fn timestamps(&$self) -> bool {
            $inner.timestamps()
        }
        fn table(&$self) -> Result<Option<$crate::guide::QTable>, $crate::gpu::GpuError> {
            $inner.table()
        }
    };
}
pub(crate) use forward_renderer_queries;

/// A borrowed renderer renders as its owner: the owner keeps it for what the
/// session does not ask (a `crate::render::MultiGpuRenderer`'s device stats).
impl<R: Renderer + ?Sized> Renderer for &mut R {
    fn render_frame(&mut self) -> Result<FrameReport, GpuError> {
        (**self).render_frame()
    }
    fn render_round(&mut self, max: u32, time_left_ms: Option<f64>) -> Result<RoundReport, GpuError> {
        (**self).render_round(max, time_left_ms)
    }
    fn learn_pending(&mut self) -> Result<(), GpuError> {
        (**self).learn_pending()
    }
    forward_renderer_queries!(self => (**self));
}
