//! The GPU renderer of `--gpu` or `--gpus`, built one way for `rlpt render`,
//! `rlpt bench` and `rlpt view`: a [`GpuRenderer`] on one context, a
//! [`MultiGpuRenderer`] on several. It is a `renderer::Renderer`, and gives the
//! viewer what it changes between frames (camera, NEE, restarts) on every device.

use super::*;
use crate::renderer::{forward_renderer_queries, FrameReport, Renderer, RoundReport};

/// A renderer on one GPU or on several; see the module's description.
pub enum GpuSet {
    /// Boxed: a `GpuRenderer` is large beside a `MultiGpuRenderer`, which holds its devices on the heap.
    One(Box<GpuRenderer>),
    Several(MultiGpuRenderer),
}

/// Why a [`GpuSet`] could not be built.
#[derive(Debug, thiserror::Error)]
pub enum GpuSetError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The settings ask what several GPUs cannot do: the sentence says what.
    #[error("{0}")]
    Settings(String),
}

/// Why `scene`'s settings cannot render on several GPUs, or None: the race of
/// `--unguided-frames auto` chooses each frame's kernel on one GPU, and several
/// trace every frame guided.
pub fn several_gpus_refusal(scene: &PreparedScene) -> Option<String> {
    scene.guide.is_some_and(|g| g.unguided_frames).then(|| {
        "--unguided-frames auto chooses each frame's kernel on one GPU; with several (--gpus) every frame is \
         guided: leave --unguided-frames out, or render on one GPU"
            .to_string()
    })
}

impl GpuSet {
    /// The renderer of `scene` on `contexts` (at least one); the image's frames
    /// draw the random numbers from frame `frame_offset` on (a part of a split
    /// render), and on one GPU take the learning frames in as `learned` says
    /// (several leave them out).
    pub fn new(
        contexts: &[Arc<Context>],
        scene: &PreparedScene,
        frame_offset: u32,
        learned: crate::film::Learned,
    ) -> Result<GpuSet, GpuSetError> {
        Ok(match contexts {
            [] => panic!("a render needs at least one GPU"),
            [ctx] => {
                let mut r = GpuRenderer::new(ctx, scene)?;
                r.set_frame_offset(frame_offset);
                r.set_learned(learned);
                GpuSet::One(Box::new(r))
            }
            _ => {
                if let Some(why) = several_gpus_refusal(scene) {
                    return Err(GpuSetError::Settings(why));
                }
                let mut r = MultiGpuRenderer::new(contexts, scene)?;
                r.set_frame_offset(frame_offset);
                GpuSet::Several(r)
            }
        })
    }

    /// The renderer as a session's (`session::Session` takes it boxed).
    fn renderer(&self) -> &dyn Renderer {
        match self {
            GpuSet::One(r) => &**r,
            GpuSet::Several(r) => r,
        }
    }

    fn renderer_mut(&mut self) -> &mut dyn Renderer {
        match self {
            GpuSet::One(r) => &mut **r,
            GpuSet::Several(r) => r,
        }
    }

    /// The frames a round traces at most: one on one GPU, a round of
    /// [`ROUND_FRAMES_PER_DEVICE`] per device on several.
    pub fn round_frames(&self) -> u32 {
        match self {
            GpuSet::One(_) => 1,
            GpuSet::Several(r) => ROUND_FRAMES_PER_DEVICE * r.device_count() as u32,
        }
    }

    /// GPUs still rendering.
    pub fn device_count(&self) -> usize {
        match self {
            GpuSet::One(_) => 1,
            GpuSet::Several(r) => r.device_count(),
        }
    }

    /// The renderer whose parameters and table stand for all: the only one, or
    /// the first device still rendering (the devices share the table after each
    /// learning pass). None where every device was lost.
    pub fn first(&self) -> Option<&GpuRenderer> {
        match self {
            GpuSet::One(r) => Some(&**r),
            GpuSet::Several(r) => r.first(),
        }
    }

    /// Replaces the render parameters (camera, NEE...) on every device.
    pub fn set_params(&mut self, params: &crate::layout::RenderParams) -> Result<(), GpuError> {
        match self {
            GpuSet::One(r) => r.set_params(params),
            GpuSet::Several(r) => r.set_params(params),
        }
    }

    /// Starts a new accumulation on every device; what guiding learned is kept.
    pub fn reset_accumulation(&mut self) -> Result<(), GpuError> {
        match self {
            GpuSet::One(r) => r.reset_accumulation(),
            GpuSet::Several(r) => r.reset_accumulation(),
        }
    }
}

impl Renderer for GpuSet {
    fn render_frame(&mut self) -> Result<FrameReport, GpuError> {
        self.renderer_mut().render_frame()
    }
    fn render_round(&mut self, max: u32, time_left_ms: Option<f64>) -> Result<RoundReport, GpuError> {
        self.renderer_mut().render_round(max, time_left_ms)
    }
    fn learn_pending(&mut self) -> Result<(), GpuError> {
        self.renderer_mut().learn_pending()
    }
    forward_renderer_queries!(self => self.renderer());
}
