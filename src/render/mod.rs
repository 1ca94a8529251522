//! The GPU renderer: uploads a [`PreparedScene`], runs `pathtrace.comp` once
//! per frame (64 samples per pixel) and, with guiding, `learn.comp` after it;
//! reads the accumulation, the counters and the learned table back.

use crate::film::Film;
use crate::gpu::{shader, Binding, Buffer, BufferUsage, Context, GpuError, Pipeline, PipelineStatistic, Timer};
use crate::guide::{AliasBin, FrameKind, FrameRace, GuideConfig, QTable, RecordSchedule};
use crate::layout::AccumPixel;
use crate::prepared::PreparedScene;
use crate::shared;
use std::sync::Arc;

mod dispatch;
pub mod display;
mod frames;
pub use frames::{CUT_FRAME_FIXED, ROUND_MAX_FRAMES, ROUND_MS};
mod learning;
mod memory;
mod multi;
mod pipelines;
pub mod raycast;
mod set;
mod sync;

pub use dispatch::*;
use learning::*;
pub use memory::scene_geometry_bytes;
use memory::*;
pub use multi::*;
use pipelines::*;
pub use set::*;

/// What one submission of frames measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameTimings {
    /// GPU time of path tracing, from timestamps (ms).
    pub pathtrace_ms: f64,
    /// Of it, the first frame's (ms): a round's first frame of a kernel after
    /// the other's runs from cold caches, and the race times it apart.
    pub first_trace_ms: f64,
    /// GPU time of the learning pass (ms; 0 without guiding).
    pub learn_ms: f64,
    /// Paths that carried zero radiance; None where the kernel keeps no counters
    /// (`RenderOptions::counters`).
    pub zero_paths: Option<u64>,
    /// Rays traced: camera, bounce and shadow rays; None where the kernel counts
    /// no rays (`Counters::All` counts them).
    pub segments: Option<u64>,
    /// The rays the subgroups would have traced had every lane's path been as long
    /// as the longest of its subgroup, which the subgroup runs the loop for: over
    /// it, `segments` is the share of lanes busy (the lane utilization); None likewise.
    pub subgroup_segments: Option<u64>,
    /// The kernel that traced the frames (None without guiding).
    pub kind: Option<FrameKind>,
    /// The frames' mean relative variance, where the kernel sums it
    /// (`FLAG_FRAME_VARIANCE`: `crate::film::frame_variance_term` summed over the
    /// pixels, over the pixels and frames).
    pub variance: Option<f64>,
    /// What each image frame of the submission weighs, where a timed race
    /// weighs frames by their kind (`FrameRace::frame_weight`); None where every
    /// frame weighs 1.
    pub weight: Option<f32>,
}

impl FrameTimings {
    pub fn total_ms(&self) -> f64 {
        self.pathtrace_ms + self.learn_ms
    }
}

/// GPU time of each pass of one frame (`GpuRenderer::render_frame_profiled`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassTimes {
    /// When the frame began, in ms on the device's timestamp clock (for traces).
    pub start_ms: f64,
    /// Path tracing (`pathtrace.comp`), ms.
    pub pathtrace_ms: f64,
    /// Folding the Q-learning targets recorded since the table last learned into it
    /// (`learn.comp` phase 0; after the frames `RecordSchedule::learns_after` names, else 0), ms.
    pub learn_fold_ms: f64,
    /// Rebuilding the sampling rows, alias tables (`learn.comp` phase 1; as the fold), ms.
    pub learn_rows_ms: f64,
    /// Paths that carried zero radiance; None where the kernel keeps no counters
    /// (`RenderOptions::counters`).
    pub zero_paths: Option<u64>,
    /// Rays traced: camera, bounce and shadow rays; None where the kernel counts
    /// no rays (`Counters::All` counts them).
    pub segments: Option<u64>,
    /// The rays the subgroups would have traced had every lane's path been as long
    /// as the longest of its subgroup, which the subgroup runs the loop for: over
    /// it, `segments` is the share of lanes busy (the lane utilization); None likewise.
    pub subgroup_segments: Option<u64>,
}

/// Test hook, for tests only: `RLPT_TEST_DEVICE_LOST_AFTER=N` makes a
/// [`GpuRenderer`] lose its device when a submission would trace frame N + 1 (N
/// frames traced, learning frames counted): the submission fails as one that
/// returned `VK_ERROR_DEVICE_LOST` does, and every later one with it
/// (`Context::lose_device`), so the film cannot be read back. No test can lose a
/// device for real.
pub const DEVICE_LOST_HOOK: &str = "RLPT_TEST_DEVICE_LOST_AFTER";

pub struct GpuRenderer {
    ctx: Arc<Context>,
    /// The path-tracing kernel's name (`pathtrace`, `pathtrace_guided`...).
    kernel: &'static str,
    /// The path-tracing pipeline; with guiding, the one that records no targets.
    pipeline: Pipeline,
    /// With guiding, the path-tracing pipeline that records targets.
    recording: Option<Pipeline>,
    /// With guiding, the unguided kernel: for the frames a [`FrameRace`] names, and
    /// for the learning frames' rows that record no targets ([`learning_rows_unguided`]).
    unguided: Option<Pipeline>,
    /// The choice of kernel of the image's frames, where it may choose.
    race: Option<FrameRace>,
    /// The frames traced and accumulated, which a failed submission restores.
    counts: FrameCounts,
    learning: Option<Learning>,
    /// Params (uniform, rewritten by `set_params`), materials, spheres, quads and
    /// lights, in the order of the pipeline's first bindings.
    scene_buffers: Vec<Buffer>,
    /// Triangles, their normals, the BVH's nodes and refs (device-local), in binding order.
    geometry_buffers: Vec<Buffer>,
    /// The first primitives as the hit tests read them (uniform).
    scene_constants: Buffer,
    /// The scene's hit-test data as specialization constants (`PreparedScene::geometry_specialization`).
    geometry: Vec<u32>,
    /// The scene's room, whose `entering` follows the camera (`set_params`).
    room: crate::layout::Room,
    accum: Buffer,
    /// The accumulation's Kahan compensation, a vec4 per pixel, read by the kernel alone.
    accum_carry: Buffer,
    readback: Buffer,
    counters: Buffer,
    counters_readback: Buffer,
    timer: Timer,
    width: u32,
    height: u32,
    params: crate::layout::RenderParams,
    /// Added to the random numbers' frame index on the image's frames (`rng_frame`).
    frame_offset: u32,
    /// What the image's first frame does with the learning frames
    /// (`crate::film::Learned`; the kernel's `fold_learned`).
    learned: crate::film::Learned,
    /// Frames the table learned from before this render: learned roulette need
    /// not wait for a loaded field to learn (`GuideField::table_frames`).
    table_frames: u32,
    /// `ABLATE_*` bits for `render_frame_profiled`: parts of guiding left out
    /// (profiling only: the image is then not what rlpt renders).
    pub ablate: u32,
    /// [`DEVICE_LOST_HOOK`]'s frame count (tests only).
    lose_device_after: Option<u32>,
    /// GPU time per frame of the last submission, its learning passes included
    /// (timestamps): how many frames the next round takes ([`ROUND_MS`]).
    round_frame_ms: Option<f64>,
    /// Its first frame's path tracing (ms), timed apart (`GpuRenderer::lone_frame_ms`).
    round_first_ms: Option<f64>,
}

/// A GPU renderer's count of the frames it traced and accumulated: one value, so
/// that a submission that fails restores them together (`submit_frames`).
#[derive(Clone, Copy, Debug, Default)]
struct FrameCounts {
    /// Frames traced so far (decorrelates random numbers; not reset with the accumulation).
    frames_traced: u32,
    /// Guided frames traced, the learning frames included: the recording
    /// schedule's and learned roulette's frame count (`PathPush::frame`).
    guided_traced: u32,
    /// Frames in the accumulation buffer.
    accum_frames: u32,
    /// Whether the accumulation's frames are learning frames, which the first
    /// image frame moves to `learned_frames` (`next_frame`).
    accum_holds_learning: bool,
    /// The learning frames left out of the image once it starts (0 until then,
    /// after `reset_accumulation`, and where the image folded them in): learned
    /// roulette's estimate still counts them (the kernel's `learned_frames`).
    learned_frames: u32,
    /// Whether the accumulation's first frame is the learning frames' mean.
    learning_folded: bool,
    /// The samples per pixel of a last frame cut short at a time limit, 0 where
    /// every frame is whole (`crate::film::Film::partial_spp`).
    partial_spp: u32,
    /// The accumulation's frames' total weight in whole frames
    /// (`crate::film::FrameWeight`; the learning frames' mean folded in counts 1).
    accum_weight: f64,
    /// Whether any frame weighed other than its samples' share (a timed race's).
    weighted: bool,
}

/// pathtrace.comp's push constants (`Push`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PathPush {
    /// Frames traced before this one (the recording schedule, learned roulette).
    frame: u32,
    /// Frames in the accumulation before this one.
    accum_frames: u32,
    /// `ABLATE_*` bits (profiling only).
    ablate: u32,
    /// The pixel rows a dispatch traces (`RowDispatch::rows`).
    rows: u32,
    /// The learning frames left out of the image (`FrameCounts::learned_frames`), or
    /// where this frame folds them in, their count.
    learned_frames: u32,
    /// Frames the table learned from before this render (`GuideField::table_frames`).
    table_frames: u32,
    /// The random numbers' frame index (`rng_frame`).
    rng_frame: u32,
    /// 1 where this frame folds the learning frames into the image (`crate::film::Learned::Fold`).
    fold_learned: u32,
    /// The frame's samples per pixel: 64, fewer in a last frame cut short at a
    /// time limit (`GpuRenderer::render_round`).
    samples: u32,
    /// A whole frame's weight (`crate::film::FrameWeight::weight`): 1 but in a timed race.
    weight: f32,
    /// The accumulation's frames' total weight before this one (`FrameCounts::accum_weight`).
    accum_weight: f32,
}

fn bytes<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

/// The bindings of the meshes and the BVH, in the order of [`geometry_buffers`].
const GEOMETRY_BINDINGS: [u32; 11] = [
    shared::BINDING_TRIANGLES,
    shared::BINDING_TRIANGLE_NORMALS,
    shared::BINDING_BVH_NODES,
    shared::BINDING_PRIM_REFS,
    shared::BINDING_ENV_TEXELS,
    shared::BINDING_ENV_CDF,
    shared::BINDING_TEXTURES,
    shared::BINDING_TEXELS,
    shared::BINDING_TRIANGLE_UVS,
    shared::BINDING_SPHERE_UVS,
    shared::BINDING_DELTA_LIGHTS,
];

/// The meshes and the BVH on the device (the path tracer's and `raycast`'s):
/// device-local, as they are large and read at every ray.
fn geometry_buffers(ctx: &Arc<Context>, scene: &crate::layout::SceneArrays) -> Result<Vec<Buffer>, GpuError> {
    Ok(vec![
        Buffer::device_with_data(ctx, "triangles", bytes(&scene.triangles))?,
        Buffer::device_with_data(ctx, "triangle normals", bytes(&scene.triangle_normals))?,
        Buffer::device_with_data(ctx, "BVH nodes", bytes(&scene.bvh_nodes))?,
        Buffer::device_with_data(ctx, "primitive refs", bytes(&scene.prim_refs))?,
        Buffer::device_with_data(ctx, "environment texels", bytes(&scene.env_texels))?,
        Buffer::device_with_data(ctx, "environment cdfs", bytes(&scene.env_cdf))?,
        Buffer::device_with_data(ctx, "texture headers", bytes(&scene.textures))?,
        Buffer::device_with_data(ctx, "texels", bytes(&scene.texels))?,
        Buffer::device_with_data(ctx, "triangle UVs", bytes(&scene.triangle_uvs))?,
        Buffer::device_with_data(ctx, "sphere UVs", bytes(&scene.sphere_uvs))?,
        Buffer::device_with_data(ctx, "delta lights", bytes(&scene.delta_lights))?,
    ])
}

impl GpuRenderer {
    pub fn new(ctx: &Arc<Context>, scene: &PreparedScene) -> Result<GpuRenderer, GpuError> {
        let p = &scene.params;
        let guided = scene.guide.is_some();
        if guided && !ctx.info.float_atomic_add {
            return Err(GpuError::Unsupported {
                index: ctx.info.index,
                name: ctx.info.name.clone(),
                missing:
                    "float atomic add on storage buffers (VK_EXT_shader_atomic_float), which learned guiding needs; \
                          render with --guiding off or --device cpu"
                        .into(),
            });
        }
        let kernel = match (guided, ctx.info.subgroup_partitioned) {
            (false, _) => "pathtrace",
            (true, false) => "pathtrace_guided",
            (true, true) => "pathtrace_guided_partitioned",
        };
        // A table no one buffer can hold is refused as such, before the memory it would take.
        if let Some(cfg) = &scene.guide {
            sampling_rows_fit(ctx, cfg)?;
        }
        fits_device_memory(ctx, scene)?;
        for (what, size) in [
            ("the triangles", std::mem::size_of_val(scene.triangles.as_slice())),
            ("the BVH's nodes", std::mem::size_of_val(scene.bvh_nodes.as_slice())),
        ] {
            fits_one_buffer(ctx, what, size as u64, "split the scene's meshes or render on the CPU (--device cpu)")?;
        }
        fits_one_buffer(
            ctx,
            "the textures' texels",
            std::mem::size_of_val(scene.texels.as_slice()) as u64,
            "use smaller texture images, or render on the CPU (--device cpu)",
        )?;
        let geometry = scene.geometry_specialization();
        let (pipeline, recording) = path_pipelines(ctx, kernel, guided, p, &geometry)?;
        let racing = scene.guide.is_some_and(|g| g.unguided_frames);
        let unguided = match racing || learning_rows_unguided(scene) {
            true => Some(unguided_twin(ctx, p, &geometry)?),
            false => None,
        };
        let mut scene_buffers = vec![
            Buffer::with_data(ctx, "render params", bytemuck::bytes_of(p), true)?,
            Buffer::with_data(ctx, "materials", bytes(&scene.materials), false)?,
            Buffer::with_data(ctx, "spheres", bytes(&scene.spheres), false)?,
            Buffer::with_data(ctx, "quads", bytes(&scene.quads), false)?,
            Buffer::with_data(ctx, "lights", bytes(&scene.lights), false)?,
        ];
        let geometry_buffers = geometry_buffers(ctx, scene)?;
        let scene_constants = Buffer::with_data(ctx, "scene constants", bytes(&scene.scene_constants()), true)?;
        let accum_size = (p.width as u64) * (p.height as u64) * std::mem::size_of::<AccumPixel>() as u64;
        fits_one_buffer(ctx, "the accumulation buffer", accum_size, "render a smaller image")?;
        let accum = Buffer::new(ctx, "accumulation", accum_size, BufferUsage::Storage)?;
        let readback = Buffer::new(ctx, "accumulation readback", accum_size, BufferUsage::Readback)?;
        let carry_size = (p.width as u64) * (p.height as u64) * ACCUM_CARRY_BYTES;
        let accum_carry = Buffer::new(ctx, "accumulation carry", carry_size, BufferUsage::Storage)?;
        let counters = Buffer::new(ctx, "frame counters", 4 * shared::NUM_COUNTERS as u64, BufferUsage::Storage)?;
        let counters_readback =
            Buffer::new(ctx, "frame counters readback", 4 * shared::NUM_COUNTERS as u64, BufferUsage::Readback)?;

        let learning = match &scene.guide {
            None => None,
            Some(cfg) => {
                let entries = cfg.entries() as u32;
                let cells = cfg.cells();
                let size = 4 * entries as u64;
                let sums_size = 4 * (entries + cells) as u64;
                let rows = cfg.sampling_rows() as u64;
                let sampler_size = cfg.sampling_rows_bytes();
                let bindings: Vec<(u32, Binding)> = (0..9).map(|i| (i, Binding::Storage)).collect();
                let learn = |name: &str, group: u32, stage_words: u32| {
                    Pipeline::new_specialized(
                        ctx,
                        name,
                        shader("learn"),
                        &bindings,
                        4 * LEARN_PUSH_WORDS as u32,
                        &[group, stage_words],
                    )
                };
                let l = Learning {
                    fold: learn("learn_fold", shared::LEARN_FOLD_GROUP, 1)?,
                    build: learn("learn_rows", shared::LEARN_ROW_GROUP, cfg.bins.count())?,
                    refine: learn("learn_refine", shared::REFINE_GROUP, 1)?,
                    q: Buffer::new(ctx, "Q table", size, BufferUsage::Storage)?,
                    visits: Buffer::new(ctx, "Q visits", size, BufferUsage::Storage)?,
                    sums: Buffer::new(ctx, "frame target sums", sums_size, BufferUsage::Storage)?,
                    counts: Buffer::new(ctx, "frame target counts", sums_size, BufferUsage::Storage)?,
                    fractions: Buffer::new(ctx, "guided fractions", 4 * rows, BufferUsage::Storage)?,
                    fraction_states: Buffer::new(
                        ctx,
                        "fraction states",
                        cells as u64 * std::mem::size_of::<crate::guide::FractionState>() as u64,
                        BufferUsage::Storage,
                    )?,
                    sampler: Buffer::new(ctx, "sampling rows", sampler_size, BufferUsage::Storage)?,
                    rows_read: Buffer::new(ctx, "rows read", 4 * rows, BufferUsage::Storage)?,
                    tree: Buffer::new(ctx, "cell tree", tree_bytes(cfg), BufferUsage::Storage)?,
                    cfg: *cfg,
                    schedule: RecordSchedule::for_render(cfg, p.width, p.height),
                    exchange: None,
                    cpu_device: ctx.info.cpu,
                };
                let buffers = [
                    &l.q,
                    &l.visits,
                    &l.sums,
                    &l.counts,
                    &l.sampler,
                    &l.fractions,
                    &l.fraction_states,
                    &l.rows_read,
                    &l.tree,
                ];
                l.fold.bind(&buffers);
                l.build.bind(&buffers);
                l.refine.bind(&buffers);
                Some(l)
            }
        };
        ctx.run_commands("clear buffers", |cmd| {
            accum.cmd_clear(cmd);
            accum_carry.cmd_clear(cmd);
            counters.cmd_clear(cmd);
            if let Some(l) = &learning {
                // Fractions 0: every row unlearned.
                for b in [&l.q, &l.visits, &l.sums, &l.counts, &l.fractions, &l.fraction_states, &l.rows_read] {
                    b.cmd_clear(cmd);
                }
                // Every row starts with nothing learned (and BSDF sampling alone).
                l.sampler.cmd_fill(cmd, crate::guide::UNLEARNED);
            }
        })?;
        if let Some(l) = &learning {
            // Every cell a leaf of depth 0, the grid's own cells in use (as `QTable::new`).
            let leaves = vec![crate::guide::CellNode::default(); l.cfg.cells() as usize];
            l.upload_tree(ctx, &leaves, l.cfg.grid.cells())?;
        }
        if let (Some(l), Some(field)) = (&learning, &scene.guide_start) {
            l.load_field(ctx, field)?;
        }
        scene_buffers.shrink_to_fit();
        let renderer = GpuRenderer {
            ctx: ctx.clone(),
            kernel,
            pipeline,
            recording,
            unguided,
            race: racing.then(FrameRace::default),
            counts: FrameCounts::default(),
            learning,
            scene_buffers,
            geometry_buffers,
            scene_constants,
            geometry,
            room: scene.room,
            accum,
            accum_carry,
            readback,
            counters,
            counters_readback,
            // Two per learning pass of a round, and its start and end.
            timer: Timer::new(ctx, 3 + 2 * ROUND_MAX_FRAMES)?,
            width: p.width,
            height: p.height,
            params: *p,
            frame_offset: 0,
            learned: crate::film::Learned::Fold,
            table_frames: if scene.guide_start.is_some() { crate::guide::GuideField::table_frames() } else { 0 },
            ablate: 0,
            lose_device_after: std::env::var(DEVICE_LOST_HOOK).ok().and_then(|v| v.trim().parse().ok()),
            round_frame_ms: None,
            round_first_ms: None,
        };
        renderer.bind_path_pipelines();
        Ok(renderer)
    }

    /// Points the path-tracing pipelines' descriptors at the buffers, in the order
    /// of the bindings `path_pipeline` declares.
    fn bind_path_pipelines(&self) {
        let mut all: Vec<&Buffer> = self.scene_buffers.iter().collect();
        all.extend([&self.accum, &self.accum_carry]);
        if let Some(l) = &self.learning {
            all.extend([&l.q, &l.sums, &l.counts, &l.sampler]);
        }
        all.push(&self.counters);
        all.push(&self.scene_constants);
        if let Some(l) = &self.learning {
            all.extend([&l.fractions, &l.rows_read]);
        }
        all.extend(self.geometry_buffers.iter());
        if let Some(l) = &self.learning {
            all.push(&l.tree);
        }
        self.pipeline.bind(&all);
        if let Some(r) = &self.recording {
            r.bind(&all);
        }
        if let Some(u) = &self.unguided {
            // The unguided kernel's bindings: the same less the table's.
            let mut plain: Vec<&Buffer> = self.scene_buffers.iter().collect();
            plain.extend([&self.accum, &self.accum_carry, &self.counters, &self.scene_constants]);
            plain.extend(self.geometry_buffers.iter());
            u.bind(&plain);
        }
    }

    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Sets the random numbers' frame offset of the image's frames (`rng_frame`),
    /// before the first frame: a part of a split render (`crate::parts`).
    pub fn set_frame_offset(&mut self, offset: u32) {
        assert_eq!(self.counts.frames_traced, 0, "the frame offset is set before the first frame");
        self.frame_offset = offset;
    }

    /// What the image's first frame does with the learning frames
    /// (`crate::film::Learned::for_render`), before the first frame. On several
    /// GPUs they stay out (`Keep`): each device holds some of them, and folding
    /// each device's share as a frame would weigh them unevenly.
    pub fn set_learned(&mut self, learned: crate::film::Learned) {
        assert_eq!(self.counts.frames_traced, 0, "the learning frames' place is set before the first frame");
        self.learned = learned;
    }

    /// Frames in the accumulation.
    pub fn frames(&self) -> u32 {
        self.counts.accum_frames
    }

    /// The samples per pixel of a last frame cut short at a time limit, 0 where
    /// every frame is whole ([`GpuRenderer::render_frame_samples`]).
    pub fn partial_spp(&self) -> u32 {
        self.counts.partial_spp
    }

    /// Whether the accumulation's first frame is the learning frames' mean
    /// (`crate::film::Learned::Fold`), not one of the image's own frames.
    pub fn learning_folded(&self) -> bool {
        self.counts.learning_folded
    }

    /// Replaces the render parameters (camera, NEE flag...) for the following frames.
    /// The image size and the guiding geometry must stay those the renderer was made
    /// with; restart the accumulation when the image they describe changes.
    /// Where a change of flags (NEE...) or of the bounce limit changes the kernel's
    /// specialization constants, the path-tracing pipeline is built anew; so too
    /// where the camera moves out of the scene's room or back in
    /// (`Room::camera_may_enter`).
    pub fn set_params(&mut self, params: &crate::layout::RenderParams) -> Result<(), GpuError> {
        let p = &self.params;
        assert_eq!(
            (p.width, p.height, p.guide_bins, p.guide_cells),
            (params.width, params.height, params.guide_bins, params.guide_cells),
            "set_params keeps the image size and the guiding geometry"
        );
        let entering = self.room.camera_may_enter(params);
        if specialization(params) != specialization(p) || entering != self.room.entering {
            self.room.entering = entering;
            self.geometry[crate::prepared::geometry_index(shared::SPEC_ROOM_ENTERING)] = entering as u32;
            // No frame is in flight: run_commands waits for each submission.
            (self.pipeline, self.recording) =
                path_pipelines(&self.ctx, self.kernel, self.learning.is_some(), params, &self.geometry)?;
            if self.unguided.is_some() {
                self.unguided = Some(unguided_twin(&self.ctx, params, &self.geometry)?);
            }
            self.bind_path_pipelines();
        }
        self.params = *params;
        // The uniform is host-visible; run_commands waited for every frame that read it.
        self.scene_buffers[0].write(bytemuck::bytes_of(params));
        Ok(())
    }

    /// The render parameters in use.
    pub fn params(&self) -> &crate::layout::RenderParams {
        &self.params
    }

    /// The accumulation buffer (`AccumPixel` per pixel), for passes that display it.
    pub fn accumulation(&self) -> &Buffer {
        &self.accum
    }

    /// The table's cell holding `p`, down the adaptive grid's tree as the GPU has
    /// it (read back); None without guiding.
    pub fn cell_at(&self, p: crate::math::Vec3) -> Result<Option<u32>, GpuError> {
        let Some(l) = &self.learning else { return Ok(None) };
        if !l.cfg.grid.adaptive() {
            return Ok(Some(l.cfg.grid.cell(p)));
        }
        let rt = Buffer::new(&self.ctx, "cell tree readback", l.tree.size, BufferUsage::Readback)?;
        self.ctx.run_commands("read cell tree", |cmd| {
            self.ctx.barrier(cmd);
            l.tree.cmd_copy_to(cmd, &rt);
        })?;
        let (nodes, _) = learning::tree_of_words(&rt.read()[..l.tree.size as usize]);
        Ok(Some(crate::guide::cell_in_tree(&l.cfg.grid, &nodes, p)))
    }

    /// The learned values Q of every direction bin of voxel `cell` (None without guiding).
    pub fn cell_values(&self, cell: u32) -> Result<Option<Vec<f32>>, GpuError> {
        let Some(l) = &self.learning else { return Ok(None) };
        assert!(cell < l.cfg.cells(), "voxel {cell} is outside the grid");
        let n = l.cfg.bins.count();
        self.read_floats(&l.q, cell * n, n, "read Q row").map(Some)
    }

    /// The guided fractions of voxel `cell`'s sampling rows, one per normal class
    /// (`QTable::fractions`: 0 where a row has learned nothing), or None without
    /// guiding.
    pub fn cell_fractions(&self, cell: u32) -> Result<Option<Vec<f32>>, GpuError> {
        let Some(l) = &self.learning else { return Ok(None) };
        assert!(cell < l.cfg.cells(), "voxel {cell} is outside the grid");
        let classes = crate::guide::NORMAL_CLASSES;
        self.read_floats(&l.fractions, cell * classes, classes, "read a voxel's fractions").map(Some)
    }

    /// `count` floats of `buffer` from float `first` on, read back after the
    /// work submitted so far.
    fn read_floats(&self, buffer: &Buffer, first: u32, count: u32, what: &str) -> Result<Vec<f32>, GpuError> {
        let size = 4 * count as u64;
        let rb = Buffer::new(&self.ctx, what, size, BufferUsage::Readback)?;
        self.ctx.run_commands(what, |cmd| {
            self.ctx.barrier(cmd);
            buffer.cmd_copy_range_to(cmd, 4 * first as u64, &rb, size);
        })?;
        Ok(bytemuck::pod_collect_to_vec(&rb.read()[..size as usize]))
    }

    /// Starts a new accumulation on the next frame; what guiding learned is kept.
    pub fn reset_accumulation(&mut self) -> Result<(), GpuError> {
        self.ctx.run_commands("reset accumulation", |cmd| self.accum.cmd_clear(cmd))?;
        self.counts.accum_frames = 0;
        self.counts.accum_holds_learning = false;
        self.counts.learned_frames = 0;
        self.counts.learning_folded = false;
        self.counts.partial_spp = 0;
        self.counts.accum_weight = 0.0;
        self.counts.weighted = false;
        Ok(())
    }

    /// What the driver reports about the compiled pipelines (registers, shared
    /// memory...), by pipeline name; empty where the device cannot say.
    pub fn pipeline_statistics(&self) -> Result<Vec<(String, Vec<PipelineStatistic>)>, GpuError> {
        let mut out = vec![(self.pipeline.name.clone(), self.pipeline.statistics()?)];
        if let Some(r) = &self.recording {
            out.push((r.name.clone(), r.statistics()?));
        }
        if let Some(l) = &self.learning {
            out.push((l.fold.name.clone(), l.fold.statistics()?));
            out.push((l.build.name.clone(), l.build.statistics()?));
        }
        out.retain(|(_, s)| !s.is_empty());
        Ok(out)
    }

    /// Copies the accumulation back to the host.
    pub fn film(&self) -> Result<Film, GpuError> {
        self.ctx.run_commands("read accumulation", |cmd| {
            self.ctx.barrier(cmd);
            self.accum.cmd_copy_to(cmd, &self.readback);
        })?;
        let n = (self.width * self.height) as usize * std::mem::size_of::<AccumPixel>();
        let pixels: Vec<AccumPixel> = bytemuck::pod_collect_to_vec(&self.readback.read()[..n]);
        let (frames, partial_spp) = (self.counts.accum_frames, self.counts.partial_spp);
        let weight = self.counts.weighted.then_some(self.counts.accum_weight);
        Ok(Film { width: self.width, height: self.height, frames, partial_spp, weight, pixels, carry: Vec::new() })
    }

    /// Folds the targets recorded since the table last learned into it and
    /// rebuilds its rows: one learning pass (`crate::renderer::Renderer::learn_pending`;
    /// the CPU's is `CpuRenderer::learn_pending`).
    pub fn learn_pending(&mut self) -> Result<(), GpuError> {
        let Some(l) = &self.learning else { return Ok(()) };
        self.ctx.run_commands("learn pending targets", |cmd| l.cmd_learn(&self.ctx, cmd, |_| {}))
    }

    /// The learned table (None without guiding).
    pub fn table(&self) -> Result<Option<QTable>, GpuError> {
        let Some(l) = &self.learning else { return Ok(None) };
        let rq = Buffer::new(&self.ctx, "Q readback", l.q.size, BufferUsage::Readback)?;
        let rv = Buffer::new(&self.ctx, "visits readback", l.visits.size, BufferUsage::Readback)?;
        let rc = Buffer::new(&self.ctx, "sampling rows readback", l.sampler.size, BufferUsage::Readback)?;
        let rf = Buffer::new(&self.ctx, "fractions readback", l.fractions.size, BufferUsage::Readback)?;
        let rs = Buffer::new(&self.ctx, "fraction states readback", l.fraction_states.size, BufferUsage::Readback)?;
        let rr = Buffer::new(&self.ctx, "rows read readback", l.rows_read.size, BufferUsage::Readback)?;
        let rt = Buffer::new(&self.ctx, "cell tree readback", l.tree.size, BufferUsage::Readback)?;
        self.ctx.run_commands("read Q table", |cmd| {
            self.ctx.barrier(cmd);
            l.q.cmd_copy_to(cmd, &rq);
            l.visits.cmd_copy_to(cmd, &rv);
            l.sampler.cmd_copy_to(cmd, &rc);
            l.fractions.cmd_copy_to(cmd, &rf);
            l.fraction_states.cmd_copy_to(cmd, &rs);
            l.rows_read.cmd_copy_to(cmd, &rr);
            l.tree.cmd_copy_to(cmd, &rt);
        })?;
        let rows_read: Vec<u32> = bytemuck::pod_collect_to_vec(&rr.read()[..l.rows_read.size as usize]);
        let (nodes, used_cells) = learning::tree_of_words(&rt.read()[..l.tree.size as usize]);
        let n = l.entries() as usize * 4;
        Ok(Some(QTable {
            q: bytemuck::pod_collect_to_vec(&rq.read()[..n]),
            visits: bytemuck::pod_collect_to_vec(&rv.read()[..n]),
            rows: bytemuck::pod_collect_to_vec(&rc.read()[..l.sampler.size as usize]),
            fractions: bytemuck::pod_collect_to_vec(&rf.read()[..l.fractions.size as usize]),
            fraction_states: bytemuck::pod_collect_to_vec(&rs.read()[..l.fraction_states.size as usize]),
            rows_read: rows_read.into_iter().map(|r| r != 0).collect(),
            nodes,
            used_cells,
        }))
    }
}
