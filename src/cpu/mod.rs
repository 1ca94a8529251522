//! The CPU renderer: the same camera, BSDFs, next-event estimation, MIS and
//! random numbers as `glsl/pathtrace.comp`, on all cores (rayon). It is the
//! reference the GPU renderer is tested against.

use crate::camera::camera_ray;
use crate::film::{Film, FrameWeight, Learned};
use crate::guide::{self, FrameSums, GuideConfig, QTable, Recorder};
use crate::layout::SceneArrays;
use crate::math::bsdf::Bsdf;
use crate::math::rng::mix_hash;
use crate::math::sampler::PathSampler;
use crate::math::{mean3, Vec3};
use crate::prepared::PreparedScene;
use crate::shared;
use rayon::prelude::*;
use std::time::{Duration, Instant};

fn xyz(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

/// The material's BSDF at a hit of texture coordinates `uv`, its textures
/// applied where the scene has any (`glsl/pathtrace.comp` `material_bsdf`).
fn material_bsdf(scene: &PreparedScene, mat: u32, uv: glam::Vec2) -> Bsdf {
    let m = &scene.materials[mat as usize];
    let mut b = m.bsdf();
    if !scene.textures.is_empty() {
        crate::math::texture::apply_textures(scene, m, uv, &mut b);
    }
    b
}

/// The material a hit on `mat` shades with: `mat` itself, or where it is a mix
/// (`shared::MAT_MIX`) one of its two materials, the second with chance its
/// amount (times its amount texture at `uv`) by [`mix_hash`] of the hit point
/// `p` and `wo`, level by level (at most `shared::MIX_MAX_DEPTH`).
/// `glsl/pathtrace.comp` `resolve_mix` is its twin.
pub fn resolve_mix(scene: &SceneArrays, mat: u32, p: Vec3, wo: Vec3, uv: glam::Vec2) -> u32 {
    let mut mat = mat;
    for _ in 0..shared::MIX_MAX_DEPTH {
        let m = &scene.materials[mat as usize];
        if m.kind != shared::MAT_MIX {
            break;
        }
        let mut amount = m.albedo_roughness[0];
        if !scene.textures.is_empty() && m.albedo_texture != shared::NO_TEXTURE {
            amount *= crate::math::texture::colour_texture(scene, m.albedo_texture - 1, uv).x;
        }
        mat = if mix_hash(p, wo, mat) < amount { m.k[1] as u32 } else { m.k[0] as u32 };
    }
    mat
}

/// The guiding state a path reads: configuration and the table of the previous frames.
#[derive(Clone, Copy)]
pub struct Guide<'a> {
    pub cfg: &'a GuideConfig,
    pub q: &'a [f32],
    pub rows: &'a [guide::AliasBin],
    /// The guided fraction of each sampling row, 0 where it is unlearned ([`QTable::fractions`]).
    pub fractions: &'a [f32],
    /// The adaptive grid's tree ([`QTable::nodes`]), empty for a uniform grid.
    pub nodes: &'a [guide::CellNode],
}

impl<'a> Guide<'a> {
    /// The guiding state of a learned table.
    pub fn new(cfg: &'a GuideConfig, table: &'a QTable) -> Guide<'a> {
        let nodes = if cfg.grid.adaptive() { &table.nodes[..] } else { &[] };
        Guide { cfg, q: &table.q, rows: &table.rows, fractions: &table.fractions, nodes }
    }

    /// The table's cell holding `p` (`glsl/guide.glsl` `cell_index`).
    pub fn cell(&self, p: Vec3) -> u32 {
        guide::cell_in_tree(&self.cfg.grid, self.nodes, p)
    }
}

mod passes;
mod path;
pub use passes::pass_sample;
pub use path::{shading_side, sides_agree, trace_path};

/// What a frame measured besides the image.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCounters {
    /// Paths whose radiance was exactly zero.
    pub zero_paths: u64,
    /// Rays traced (camera, bounce and shadow rays).
    pub segments: u64,
    /// The pixels' `crate::film::frame_variance_term`s summed (0 where no race
    /// weighs the frame).
    pub variance: f64,
}

impl FrameCounters {
    /// Both counts added.
    pub fn plus(self, o: FrameCounters) -> FrameCounters {
        FrameCounters {
            zero_paths: self.zero_paths + o.zero_paths,
            segments: self.segments + o.segments,
            variance: self.variance + o.variance,
        }
    }
}

/// The CPU renderer's guiding state.
struct Learning {
    table: QTable,
    /// Which pixel rows record targets, frame by frame, and when the table learns
    /// (as on the GPU).
    schedule: guide::RecordSchedule,
    /// The targets recorded since the table last learned.
    pending: FrameSums,
    /// Guided frames traced, the learning frames included: the recording
    /// schedule's and learned roulette's frame count (as on the GPU).
    guided_traced: u32,
    /// The choice of kernel of the image's frames, where it may choose.
    race: Option<guide::FrameRace>,
}

/// The CPU renderer: the film, the learned table (with guiding) and the frame counter.
pub struct CpuRenderer {
    scene: PreparedScene,
    learning: Option<Learning>,
    film: Film,
    /// Frames traced so far (decorrelates random numbers; not reset with the film).
    frames_traced: u32,
    /// Added to the random numbers' frame index on the image's frames
    /// (`crate::math::sampler::rng_frame`).
    frame_offset: u32,
    /// The learning frames left out of the image once it starts (0 until then,
    /// after `reset_film`, and where they are folded into it): learned
    /// roulette's estimate still counts them.
    learned_frames: u32,
    /// What the image's first frame does with the learning frames
    /// (`crate::film::Learned`): a part of a split render keeps them out.
    learned: Learned,
    /// Whether the film's first frame is the learning frames' mean.
    learning_folded: bool,
    pub last_counters: FrameCounters,
    /// The kind of the last frame traced (None without guiding).
    pub last_kind: Option<guide::FrameKind>,
    /// The last frame's mean relative variance, where it is weighed
    /// (`FLAG_FRAME_VARIANCE`; `crate::render::FrameTimings::variance`).
    pub last_variance: Option<f64>,
    /// What the last frame weighs in the image, where a timed race weighs
    /// frames by their kind (`crate::render::FrameTimings::weight`).
    pub last_weight: Option<f32>,
    /// The last frame's wall time, its learning included, and where it was
    /// traced in passes, its last pass's: what the next is predicted to take.
    last_frame_ms: Option<f64>,
    pass_ms: Option<f64>,
}

impl CpuRenderer {
    pub fn new(scene: &PreparedScene) -> CpuRenderer {
        let (w, h) = (scene.params.width, scene.params.height);
        let learning = scene.guide.map(|g| Learning {
            table: scene.guide_start.as_ref().map_or_else(|| QTable::new(&g), |f| f.table(&g)),
            schedule: guide::RecordSchedule::for_render(&g, w, h),
            pending: FrameSums::for_config(&g),
            guided_traced: 0,
            race: g.unguided_frames.then(guide::FrameRace::default),
        });
        CpuRenderer {
            scene: scene.clone(),
            learning,
            film: Film::new(w, h),
            frames_traced: 0,
            frame_offset: 0,
            learned_frames: 0,
            learned: Learned::Fold,
            learning_folded: false,
            last_counters: FrameCounters::default(),
            last_kind: None,
            last_variance: None,
            last_weight: None,
            last_frame_ms: None,
            pass_ms: None,
        }
    }

    /// The race of the image's frames' kernels, where there is one.
    pub fn race(&self) -> Option<&guide::FrameRace> {
        self.learning.as_ref().and_then(|l| l.race.as_ref())
    }

    pub fn film(&self) -> &Film {
        &self.film
    }

    /// Whether the film's first frame is the learning frames' mean
    /// (`crate::film::Learned::Fold`), not one of the image's own frames.
    pub fn learning_folded(&self) -> bool {
        self.learning_folded
    }

    pub fn table(&self) -> Option<&QTable> {
        self.learning.as_ref().map(|l| &l.table)
    }

    /// Folds the targets recorded since the table last learned into it and
    /// rebuilds its rows (`crate::renderer::Renderer::learn_pending`; the GPU's
    /// is `GpuRenderer::learn_pending`).
    pub fn learn_pending(&mut self) {
        if let (Some(l), Some(cfg)) = (self.learning.as_mut(), self.scene.guide.as_ref()) {
            l.table.learn(cfg, &l.pending);
            l.pending = FrameSums::for_config(cfg);
        }
    }

    /// Sets the random numbers' frame offset of the image's frames
    /// (`crate::math::sampler::rng_frame`), before the first frame: a part of a split
    /// render (`crate::parts`).
    pub fn set_frame_offset(&mut self, offset: u32) {
        assert_eq!(self.frames_traced, 0, "the frame offset is set before the first frame");
        self.frame_offset = offset;
    }

    /// What the image's first frame does with the learning frames
    /// ([`Learned::for_render`]), before the first frame.
    pub fn set_learned(&mut self, learned: Learned) {
        assert_eq!(self.frames_traced, 0, "the learning frames' place is set before the first frame");
        self.learned = learned;
    }

    /// Starts a new accumulation; what guiding learned is kept.
    pub fn reset_film(&mut self) {
        self.film = Film::new(self.film.width, self.film.height);
        self.learned_frames = 0;
        self.learning_folded = false;
    }

    /// Renders one frame of 64 samples per pixel; with guiding, the table learns
    /// from its Q-learning targets after the frames the schedule names. The frame
    /// after the learning frames (`GuideConfig::learning_frames`) starts the
    /// image anew: the film then holds it alone (`crate::film::accumulate`).
    pub fn render_frame(&mut self) {
        self.trace_frame(FrameEnd::Whole);
    }

    /// Renders one frame, or as much of it as ends by `deadline`: passes of one
    /// sample per pixel over the whole image, each started only where it is
    /// predicted to end by then (the render's first always runs). Returns the
    /// samples per pixel traced: 0 where no pass fitted (nothing changed), below
    /// 64 where the frame was cut short, which ends the film ([`Film::partial_spp`]).
    pub fn render_frame_until(&mut self, deadline: Instant) -> u32 {
        self.trace_frame(FrameEnd::Deadline(deadline))
    }

    /// The frame of [`render_frame_until`](Self::render_frame_until) cut after
    /// `samples` passes (1 to 64) rather than at a deadline: the same samples, the
    /// same film.
    pub fn render_frame_samples(&mut self, samples: u32) {
        assert!((1..=shared::SAMPLES_PER_FRAME).contains(&samples), "a frame holds 1 to 64 samples per pixel");
        self.trace_frame(FrameEnd::Samples(samples));
    }

    /// Renders within `time_left_ms` of now: a whole frame as [`render_frame`](Self::render_frame)
    /// where twice the last frame's time is left (so that a frame slower than the
    /// last still ends in time), else [`render_frame_until`](Self::render_frame_until)
    /// the deadline. Returns the samples per pixel traced, and whether the time
    /// is up: the frame was cut short, or no further pass fits.
    pub fn render_frame_within(&mut self, time_left_ms: f64) -> (u32, bool) {
        if let Some(race) = self.learning.as_mut().and_then(|l| l.race.as_mut()) {
            race.set_time_left(time_left_ms);
        }
        let start = Instant::now();
        let deadline = start + Duration::from_secs_f64(time_left_ms.max(0.0) / 1e3);
        let samples = match self.last_frame_ms {
            Some(last) if time_left_ms >= 2.0 * last => {
                self.trace_frame(FrameEnd::Whole);
                shared::SAMPLES_PER_FRAME
            }
            _ => self.trace_frame(FrameEnd::Deadline(deadline)),
        };
        let more = passes::pass_fits(self.predicted_pass_ms(), Instant::now(), deadline);
        (samples, samples < shared::SAMPLES_PER_FRAME || !more)
    }

    /// The frame of [`render_frame`](Self::render_frame) (each pixel's 64 paths
    /// together), or one in passes; returns the samples per pixel traced.
    fn trace_frame(&mut self, end: FrameEnd) -> u32 {
        assert_eq!(self.film.partial_spp, 0, "a frame cut short ends the film: reset it first");
        let start = Instant::now();
        if let FrameEnd::Deadline(d) = end {
            // Past the render's first pass, nothing is traced unless a pass fits.
            if self.frames_traced > 0 && !passes::pass_fits(self.predicted_pass_ms(), start, d) {
                return 0;
            }
        }
        let p = self.scene.params;
        let learning_frames = self.scene.learning_frames();
        // The image's frames are guided or not as the race says, where there is one.
        let kind = self
            .learning
            .as_ref()
            .map(|l| guide::frame_kind(l.race.as_ref(), self.frames_traced, l.guided_traced, learning_frames));
        let guided = kind == Some(guide::FrameKind::Guided);
        let frame = self.learning.as_ref().map_or(self.frames_traced, |l| l.guided_traced);
        // The first image frame takes the learning frames in as one frame, or leaves them out.
        let folds = self.film.frames > 0 && self.frames_traced == learning_frames;
        if folds {
            self.learned_frames = self.film.frames;
            self.film.frames = 0;
            self.film.weight = None;
        }
        // In a timed race each kind's frames weigh the inverse of their variance;
        // the learning frames weigh 1 (`crate::film::FrameWeight`).
        let image = self.frames_traced >= learning_frames;
        let race = self.learning.as_ref().and_then(|l| l.race.as_ref());
        let weight = match (race, kind) {
            (Some(race), Some(kind)) if image => race.frame_weight(kind),
            _ => 1.0,
        };
        let reported_weight = race.filter(|r| r.timed() && image).map(|_| weight);
        let weight_before = self.film.weight_frames();
        // A loaded field has learned: learned roulette need not wait for it.
        let table_frames = if self.scene.guide_start.is_some() { guide::GuideField::table_frames() } else { 0 };
        let scene = &self.scene;
        let learning = self.learning.as_ref();
        let setup = FrameSetup {
            scene,
            guide: scene.guide.as_ref().zip(learning).filter(|_| guided).map(|(cfg, l)| Guide::new(cfg, &l.table)),
            schedule: learning.filter(|_| guided).map(|l| &l.schedule),
            learning: self.frames_traced < learning_frames,
            frame,
            rng_frame: crate::math::sampler::rng_frame(self.frames_traced, learning_frames, self.frame_offset),
            accum_frames: self.film.frames,
            accum_weight: weight_before as f32,
            weight,
            learned_frames: self.learned_frames,
            learned: self.learned,
            roulette_frames: frame + table_frames,
        };
        let weigh = p.flags & shared::FLAG_FRAME_VARIANCE != 0;
        // Empty sums for the table (none without guiding).
        let no_sums = || scene.guide.as_ref().map_or_else(|| FrameSums::new(0, 0), FrameSums::for_config);
        let (sums, counters, samples) = match end {
            FrameEnd::Whole => {
                let (sums, counters) = setup.trace_whole(&mut self.film.pixels, &mut self.film.carry, weigh, &no_sums);
                self.pass_ms = None;
                (sums, counters, shared::SAMPLES_PER_FRAME)
            }
            FrameEnd::Deadline(_) | FrameEnd::Samples(_) => {
                let traced =
                    passes::trace_passes(&setup, &mut self.film.pixels, &mut self.film.carry, end, weigh, &no_sums);
                self.pass_ms = traced.pass_ms;
                (traced.sums, traced.counters, traced.samples)
            }
        };
        let whole = samples == shared::SAMPLES_PER_FRAME;
        let guided_before = self.learning.as_ref().map_or(0, |l| l.guided_traced);
        let (mut trace_ms, mut learn_ms, mut period) = (start.elapsed().as_secs_f64() * 1e3, None, 1);
        if let (Some(l), Some(cfg)) = (self.learning.as_mut(), self.scene.guide.as_ref()) {
            if guided {
                // A frame cut short recorded real targets, of fewer paths: they count as any
                // frame's. A frame whose rows recorded nothing has no sums to add.
                if let Some(sums) = &sums {
                    l.pending.add_all(sums);
                }
                trace_ms = start.elapsed().as_secs_f64() * 1e3;
                if l.schedule.learns_after(l.guided_traced) {
                    let learn_start = Instant::now();
                    l.table.learn(cfg, &l.pending);
                    l.pending = FrameSums::for_config(cfg);
                    learn_ms = Some(learn_start.elapsed().as_secs_f64() * 1e3);
                }
                period = l.schedule.learning_period(l.guided_traced);
                l.guided_traced += 1;
            }
        }
        let pixels = (p.width * p.height) as f64;
        // A frame cut short is the render's last: no race reads its weight.
        let variance = (weigh && whole).then(|| counters.variance / pixels);
        if let (Some(race), Some(kind), Some(v)) =
            (self.learning.as_mut().and_then(|l| l.race.as_mut()), kind, variance)
        {
            race.report_traced(
                (kind, self.frames_traced, guided_before, learning_frames),
                v,
                trace_ms,
                learn_ms,
                period,
            );
        }
        let folded = folds && self.learned == Learned::Fold;
        let this = FrameWeight { samples, weight, before: weight_before as f32 };
        let weight_after = weight_before + if folded { 1.0 } else { 0.0 } + this.frames();
        self.film.frames += 1;
        if folded {
            self.film.frames += 1;
            self.learned_frames = 0;
            self.learning_folded = true;
        }
        if !whole {
            self.film.partial_spp = samples;
        }
        if weight != 1.0 || self.film.weight.is_some() {
            self.film.weight = Some(weight_after);
        }
        self.frames_traced += 1;
        self.last_counters = counters;
        self.last_kind = kind;
        self.last_variance = variance;
        self.last_weight = reported_weight;
        self.last_frame_ms = Some(start.elapsed().as_secs_f64() * 1e3);
        samples
    }

    /// How long the next pass of one sample per pixel is taken to last: the last
    /// frame's last pass's time where it was traced in passes, else a 64th of the
    /// last frame's (None before any frame).
    fn predicted_pass_ms(&self) -> Option<f64> {
        self.pass_ms.or(self.last_frame_ms.map(|f| f / shared::SAMPLES_PER_FRAME as f64))
    }
}

/// Where a frame ends: after its 64 samples per pixel (each pixel's together),
/// or in passes of one sample per pixel, at a deadline or after a number of them.
#[derive(Clone, Copy)]
enum FrameEnd {
    Whole,
    Deadline(Instant),
    Samples(u32),
}

/// What every path of a frame reads besides its pixel and sample.
pub(super) struct FrameSetup<'a> {
    scene: &'a PreparedScene,
    guide: Option<Guide<'a>>,
    /// The recording schedule, on guided frames.
    schedule: Option<&'a guide::RecordSchedule>,
    /// Whether this is a learning frame, whose paths that record no targets
    /// trace unguided ([`FrameSetup::trace_sample`]).
    learning: bool,
    /// The frame's index in the recording schedule.
    frame: u32,
    /// The random numbers' frame index (`crate::math::sampler::rng_frame`).
    rng_frame: u32,
    /// The film's frames before this one, their total weight in whole frames,
    /// this frame's weight (`crate::film::FrameWeight`), and the learning
    /// frames left out of the film.
    accum_frames: u32,
    accum_weight: f32,
    weight: f32,
    learned_frames: u32,
    learned: Learned,
    /// The table's frames, for learned roulette's wait (`guide::roulette_estimate`).
    roulette_frames: u32,
}

/// A frame's rows (each with its index) dealt round-robin to one group per thread
/// of the pool. Each group records its targets into sums of its own, added in
/// group order ([`add_sums`]): a table's sums are tens of megabytes, too large for
/// one set per row or per split of a parallel loop, and fixed groups keep a seed's
/// guided render the same run to run.
pub(super) fn row_groups<T>(rows: impl Iterator<Item = T>) -> Vec<Vec<(u32, T)>> {
    let n = rayon::current_num_threads().max(1);
    let mut groups: Vec<Vec<(u32, T)>> = (0..n).map(|_| Vec::new()).collect();
    for (y, row) in rows.enumerate() {
        groups[y % n].push((y as u32, row));
    }
    groups
}

/// Two groups' target sums added (None: a group that recorded nothing).
pub(super) fn add_sums(a: Option<FrameSums>, b: Option<FrameSums>) -> Option<FrameSums> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.merge(b)),
        (a, b) => a.or(b),
    }
}

/// One pixel's radiance sum over a frame's samples so far.
#[derive(Clone, Copy, Default)]
pub(super) struct PixelSums {
    sum: Vec3,
}

impl FrameSetup<'_> {
    /// Whether the paths of pixel row `y` record Q-learning targets.
    pub(super) fn records(&self, y: u32) -> bool {
        self.schedule.is_some_and(|s| s.records(self.frame, y))
    }

    /// The pixel estimate learned roulette compares with (0 without guiding).
    pub(super) fn estimate(&self, acc: &crate::layout::AccumPixel) -> f32 {
        match self.guide {
            Some(_) => guide::roulette_estimate(
                acc,
                (self.accum_frames, self.accum_weight),
                self.learned_frames,
                self.roulette_frames,
            ),
            None => 0.0,
        }
    }

    /// Traces a whole frame into `film`, each pixel's 64 samples together, its
    /// rows in the groups of [`row_groups`]; returns the targets recorded (None
    /// where no row recorded) and the counts.
    fn trace_whole(
        &self,
        film: &mut [crate::layout::AccumPixel],
        carry: &mut [[f32; 3]],
        weigh: bool,
        no_sums: &(dyn Fn() -> FrameSums + Sync),
    ) -> (Option<FrameSums>, FrameCounters) {
        // A pixel without its carry would be skipped by the zip below, not traced.
        assert_eq!(film.len(), carry.len(), "a film accumulated on the host keeps a carry per pixel");
        let traced: Vec<(Option<FrameSums>, FrameCounters)> = row_groups(
            film.chunks_mut(self.scene.params.width as usize).zip(carry.chunks_mut(self.scene.params.width as usize)),
        )
        .into_par_iter()
        .map(|rows| {
            let (mut sums, mut counters) = (None::<FrameSums>, FrameCounters::default());
            for (y, (row, carries)) in rows {
                let record = self.records(y);
                for (x, (acc, carry)) in row.iter_mut().zip(carries.iter_mut()).enumerate() {
                    let (mut px, estimate) = (PixelSums::default(), self.estimate(acc));
                    for sample in 0..shared::SAMPLES_PER_FRAME {
                        let learn = record.then(|| sums.get_or_insert_with(no_sums) as &mut dyn Recorder);
                        self.trace_sample((x as u32, y), sample, estimate, learn, &mut px, &mut counters);
                    }
                    self.finish_pixel(acc, carry, px, shared::SAMPLES_PER_FRAME, weigh, &mut counters);
                }
            }
            (sums, counters)
        })
        .collect();
        traced.into_iter().fold((None, FrameCounters::default()), |(all, c), (sums, counters)| {
            (add_sums(all, sums), c.plus(counters))
        })
    }

    /// Traces sample `sample` (0..64) of pixel (x, y) into `px`, counting its rays
    /// and whether it carried nothing.
    #[inline(always)]
    pub(super) fn trace_sample(
        &self,
        (x, y): (u32, u32),
        sample: u32,
        estimate: f32,
        learn: Option<&mut dyn Recorder>,
        px: &mut PixelSums,
        counters: &mut FrameCounters,
    ) {
        let p = &self.scene.params;
        let pixel = y * p.width + x;
        let mut rng = PathSampler::for_flags(p.flags, p.seed, pixel, self.rng_frame, sample);
        let u = rng.sample_pixel(sample);
        let (o, d) = camera_ray(p, x, y, u);
        // A learning frame's rows that record nothing trace unguided: as fast as an
        // unguided frame and as good while the table knows little. The GPU's
        // twin is `crate::render::GpuRenderer::cmd_trace`.
        let guide = if self.learning && learn.is_none() { None } else { self.guide };
        let (l, segs) = trace_path(self.scene, guide, o, d, &mut rng, estimate, learn);
        counters.segments += segs as u64;
        // A NaN or infinite sample would poison the pixel forever; it is dropped
        // (as on the GPU) and counted as carrying nothing.
        if l.is_finite() {
            px.sum += l;
        }
        if !(l.max_element() > 0.0) {
            counters.zero_paths += 1;
        }
    }

    /// Adds a pixel's frame of `samples` samples to its accumulation, and where
    /// `weigh`, its variance term to `counters`.
    pub(super) fn finish_pixel(
        &self,
        acc: &mut crate::layout::AccumPixel,
        carry: &mut [f32; 3],
        px: PixelSums,
        samples: u32,
        weigh: bool,
        counters: &mut FrameCounters,
    ) {
        if weigh {
            let before =
                pixel_mean_before(acc, (self.accum_frames, self.accum_weight), self.learned_frames, mean3(px.sum));
            let frame_mean = mean3(px.sum) / shared::SAMPLES_PER_FRAME as f32;
            counters.variance += crate::film::frame_variance_term(frame_mean, before) as f64;
        }
        crate::film::accumulate_samples(
            acc,
            carry,
            self.accum_frames,
            self.learned_frames,
            self.learned,
            px.sum.to_array(),
            FrameWeight { samples, weight: self.weight, before: self.accum_weight },
        );
    }
}

/// `pathtrace.comp` `add_frame_variance`'s mean of the pixel before the frame:
/// the accumulation's, the learning frames' where the image has none yet, else
/// this frame's (`frame_sum`, mean3 of its sum). The accumulation's frames
/// count by their total weight (`crate::film::FrameWeight`).
fn pixel_mean_before(
    acc: &crate::layout::AccumPixel,
    (accum_frames, accum_weight): (u32, f32),
    learned_frames: u32,
    frame_sum: f32,
) -> f32 {
    let n = if accum_frames > 0 { accum_weight } else { learned_frames as f32 };
    let per_frame = shared::SAMPLES_PER_FRAME as f32;
    if n > 0.0 {
        mean3(Vec3::from_slice(&acc.sum[..3])) / (per_frame * n)
    } else {
        frame_sum / per_frame
    }
}

/// Renders `frames` frames of 64 samples per pixel into a new film (no guiding
/// state kept), calling `on_frame` after each. The learning frames
/// (`GuideConfig::learning_frames`) count among them: past them, the film holds
/// the frames after them alone.
pub fn render(scene: &PreparedScene, film: &mut Film, frames: u32, mut on_frame: impl FnMut(&Film)) {
    let mut r = CpuRenderer::new(scene);
    assert_eq!(
        (film.width, film.height),
        (scene.params.width, scene.params.height),
        "film size matches the render size"
    );
    for _ in 0..frames {
        r.render_frame();
        on_frame(r.film());
    }
    *film = r.film;
}
