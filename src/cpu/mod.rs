//! The CPU renderer: the same camera, BSDFs, next-event estimation, MIS and
//! random numbers as `glsl/pathtrace.comp`, on all cores (rayon). It is the
//! reference the GPU renderer is tested against.

use crate::camera::camera_ray;
use crate::film::Film;
use crate::guide::{self, FrameSums, GuideConfig, QTable, Recorder};
use crate::math::bsdf::{bsdf_eval_pdf, bsdf_sample, Bsdf};
use crate::math::envmap;
use crate::math::geometry::{
    emitted, intersect, light_pdf, meets_light, occluded, offset_origin, sample_light, shadow_ray,
};
use crate::math::sampler::{bounce_dim, PathSampler};
use crate::math::sampling::mis_weight;
use crate::math::{max_component, mean3, Frame, Vec3};
use crate::prepared::PreparedScene;
use crate::scene::MaterialKind;
use crate::shared;
use rayon::prelude::*;

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

/// Traces one path from the camera ray (o, d) and returns the radiance it
/// carries and the number of rays it traced. With guiding and a `learn`
/// (the path records), every ray that leaves a vertex of depth below
/// [`guide::record_vertices`] and reaches a surface or escapes hands its
/// Q-learning target to `learn`, and where cells learn their fractions and the
/// vertex mixed, the gradient sample of its cell's fraction.
pub fn trace_path(
    scene: &PreparedScene,
    guide: Option<Guide>,
    mut o: Vec3,
    mut d: Vec3,
    rng: &mut PathSampler,
    pixel_estimate: f32,
    mut learn: Option<&mut dyn Recorder>,
) -> (Vec3, u32) {
    let record = learn.is_some();
    let p = &scene.params;
    let guided_vertices = guide::guided_vertices(p);
    let record_vertices = guide::record_vertices(p);
    let nee = p.flags & shared::FLAG_NEE != 0 && p.num_lights > 0;
    let power = p.flags & shared::FLAG_POWER_HEURISTIC != 0;
    let rr = p.flags & shared::FLAG_RUSSIAN_ROULETTE != 0;
    let mut radiance = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    // Density of the direction that led to the current vertex, and whether it was a delta choice.
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut prev_p = o;
    // Q-table entry of the ray being traced (none for camera rays).
    let mut prev_key = shared::NO_KEY;
    // The fraction-gradient factor of that ray (guide::fraction_gradient_factor),
    // 0 where its vertex did not mix or the path does not learn fractions.
    let mut prev_factor = 0.0f32;
    let learn_fraction = record && guide.is_some_and(|g| g.cfg.learn_fraction);
    // Targets that count the emission met as the image weighs it and the light
    // sample at the vertex met (`guide::QTargets::Mis`), where the path records.
    let mis_targets = record && p.flags & shared::FLAG_MIS_TARGETS != 0;
    let bins_per_cell = guide.map_or(1, |g| g.cfg.bins.count());
    let mut depth = 0u32;
    let mut segments = 0u32;
    // The ray into the last vertex adds only the emission it meets; where the
    // environment is black and its line meets no light, it adds nothing, and the
    // closest-hit walk is skipped (unless the path records that vertex's target).
    let last_ray_to_lights =
        p.flags & shared::FLAG_LAST_RAY_TO_LIGHTS != 0 && !(record && record_vertices >= p.max_bounces);
    loop {
        segments += 1;
        if last_ray_to_lights && depth >= p.max_bounces && !meets_light(scene, o, d) {
            break;
        }
        let Some(hit) = intersect(scene, o, d, f32::INFINITY) else {
            // The uniform sky, or the image environment: a light, whose emission is
            // weighed against light sampling as the other lights' is.
            let (env, w) = if p.env_width > 0 {
                let (le, pdf_env) = envmap::env_lookup(scene, d);
                let pmf = scene.lights[p.num_lights as usize - 1].pmf;
                (le, if nee && !prev_delta { mis_weight(prev_pdf, pdf_env * pmf, power) } else { 1.0 })
            } else {
                (xyz(p.environment), 1.0)
            };
            if let Some(learn) = learn.as_mut().filter(|_| depth <= record_vertices && prev_key != shared::NO_KEY) {
                let target = if mis_targets { mean3(env) * w } else { mean3(env) };
                record_to(&mut **learn, prev_key, target, mean3(env) * w, prev_factor, bins_per_cell);
            }
            radiance += beta * env * w;
            break;
        };
        let wo = -d;
        let le = emitted(scene, hit.material, hit.n, wo);
        // The emission as the image counts it here (MIS-weighted against light
        // sampling), which is what the fraction's gradient weighs, and with
        // `mis_targets` the target too.
        let mut le_counted = 0.0f32;
        if le.max_element() > 0.0 {
            let w = if !nee || prev_delta || hit.light == shared::NO_LIGHT {
                1.0
            } else {
                mis_weight(prev_pdf, light_pdf(scene, hit.light, prev_p, d), power)
            };
            radiance += beta * le * w;
            le_counted = mean3(le) * w;
        }
        // What the target of the ray that arrived here counts of that emission.
        let le_target = if mis_targets { le_counted } else { mean3(le) };
        let bsdf = material_bsdf(scene, hit.material, hit.uv);
        // Reflecting materials are two-sided: shade with the normal on wo's side.
        let n = if bsdf.transmits() || hit.n.dot(wo) >= 0.0 { hit.n } else { -hit.n };
        let ns = shading_side(n, hit, wo);
        let frame = Frame::from_normal(ns);
        let wo_local = frame.to_local(wo);

        // Guiding at this vertex: its cell's row of the table and sampling row.
        let mut cell_key = 0u32;
        let mut sampler: &[guide::AliasBin] = &[];
        let mut row_fraction = 0.0f32;
        if let Some(g) = guide {
            let (cell, bins) = (g.cell(hit.p), g.cfg.bins.count());
            cell_key = cell * bins;
            let row = guide::sampler_row(cell, guide::normal_class(n), bins);
            sampler = &g.rows[row..row + bins as usize];
            row_fraction = g.fractions[row / bins as usize];
            // A recording path marks the rows its guided vertices read (`QTable::rows_read`).
            if let Some(learn) = learn.as_mut().filter(|_| depth < guided_vertices) {
                learn.row_read(row / bins as usize);
            }
        }
        if bsdf.kind == MaterialKind::Emissive {
            // Reflects nothing: the target is the emission alone.
            if let Some(learn) = learn.as_mut().filter(|_| depth <= record_vertices && prev_key != shared::NO_KEY) {
                record_to(&mut **learn, prev_key, le_target, le_counted, prev_factor, bins_per_cell);
            }
            break;
        }
        // Probability of guided sampling here: the row's fraction (0 where
        // nothing is learned) times the lobe's share (less on narrow glossy
        // lobes); zero at delta vertices and past the guided vertices.
        let g_frac = match guide {
            Some(_) if depth < guided_vertices && !bsdf.is_delta() => row_fraction * guide::lobe_share(&bsdf),
            _ => 0.0,
        };
        // The bin of a direction, where guiding reads it.
        let bin_of = |wi: Vec3| guide.map_or(0, |g| g.cfg.bins.index(wi));
        // A direction of the mixture at a vertex that mixes (g_frac > 0), whichever
        // sampler chose it: (wi, BSDF x cos / mixture pdf, the mixture pdf, not
        // delta, bin, fraction-gradient factor), or None where the BSDF or the
        // density is zero.
        //
        // The MIS weights between light sampling and the mixture use the mixture's
        // density, the one the direction was drawn from: at the light sample too,
        // which costs it the guided density of its bin. The BSDF's density in
        // their place is unbiased too and cheaper, but hands the light guided
        // directions find to light sampling, which loses badly where light
        // sampling finds a lamp worse (smallpt; docs/guiding.md, "The mixture").
        let mixture_sample = |wi: Vec3, bin: u32| {
            let wi_local = frame.to_local(wi);
            let (f, pb) = bsdf_eval_pdf(&bsdf, wo_local, wi_local);
            let pg = guide::bin_pdf(sampler, bin);
            let pdf = guide::mixture_pdf(g_frac, pb, pg);
            (pdf > 0.0 && f.max_element() > 0.0).then(|| {
                let weight = f * (wi_local.z.abs() / pdf);
                let factor = if learn_fraction {
                    guide::fraction_gradient_factor(g_frac, row_fraction, pg, pb, pdf, mean3(weight))
                } else {
                    0.0
                };
                (wi, weight, pdf, false, bin, factor)
            })
        };
        let last = depth >= p.max_bounces;

        let u_sel = rng.sample_1d(bounce_dim(depth, shared::SAMPLE_LIGHT_SELECT));
        let u_light = rng.sample_2d(bounce_dim(depth, shared::SAMPLE_LIGHT));
        // The light sample's estimate here, without the path's throughput: the
        // part of the target of the ray that arrived here that light sampling
        // found (`mis_targets`).
        let mut nee_here = 0.0f32;
        if nee && !last && !bsdf.is_delta() {
            if let Some(ls) = sample_light(scene, hit.p, u_sel, u_light).filter(|ls| sides_agree(n, ns, ls.wi)) {
                let wi_local = frame.to_local(ls.wi);
                let (f, pb) = bsdf_eval_pdf(&bsdf, wo_local, wi_local);
                if ls.le.max_element() > 0.0 && f.max_element() > 0.0 {
                    let (origin, dir, len) = shadow_ray(hit.p, hit.n, hit.eps, &ls);
                    segments += 1;
                    if !occluded(scene, origin, dir, len, ls.skip) {
                        // MIS against the mixture's density where the vertex mixes
                        // (see `mixture_sample`).
                        let pdf = if g_frac > 0.0 {
                            guide::mixture_pdf(g_frac, pb, guide::bin_pdf(sampler, bin_of(ls.wi)))
                        } else {
                            pb
                        };
                        let w = mis_weight(ls.pdf, pdf, power);
                        radiance += beta * f * wi_local.z.abs() * ls.le * (w / ls.pdf);
                        if mis_targets {
                            nee_here = mean3(f * wi_local.z.abs() * ls.le * (w / ls.pdf));
                        }
                    }
                }
            }
        }

        // The continuation: sampled even at the last bounce when the path records,
        // since the Q-learning target of the previous vertex is estimated from it.
        let wants_target = record && depth <= record_vertices && prev_key != shared::NO_KEY;
        if last && !wants_target {
            break;
        }
        let u_mix = rng.sample_1d(bounce_dim(depth, shared::SAMPLE_MIX));
        let uc = rng.sample_1d(bounce_dim(depth, shared::SAMPLE_LOBE));
        let u = rng.sample_2d(bounce_dim(depth, shared::SAMPLE_DIRECTION));
        // First the direction, from the table or the BSDF; then, where the two are
        // mixed, one evaluation of the BSDF and the mixture density for either
        // choice (the GPU runs it once for a warp that holds both). A guided
        // direction comes with its bin, a BSDF direction's is found once.
        let sampled = if u_mix < g_frac {
            // A guided direction: its weight and density are those of the mixture.
            let g = guide.expect("g_frac > 0 only with guiding");
            let (wi, bin) = guide::guided_direction_bin(&g.cfg.bins, sampler, uc, u);
            mixture_sample(wi, bin)
        } else {
            match bsdf_sample(&bsdf, wo_local, uc, u) {
                // A BSDF direction at a vertex that mixes: the same evaluation.
                Some(s) if g_frac > 0.0 && !s.delta => {
                    let wi = frame.to_world(s.wi).normalize();
                    mixture_sample(wi, bin_of(wi))
                }
                Some(s) => {
                    let wi = frame.to_world(s.wi).normalize();
                    Some((wi, s.weight, s.pdf, s.delta, bin_of(wi), 0.0))
                }
                None => None,
            }
        };
        // A direction on one side of the shading normal and the other of the
        // surface would leak light through it: dropped.
        let sampled = sampled.filter(|s| sides_agree(n, ns, s.0));
        if let (Some(g), Some(learn)) = (guide, learn.as_mut().filter(|_| wants_target)) {
            // One-sample estimate of the expected-SARSA target (see src/guide/mod.rs).
            let reflected = match sampled {
                Some((_, weight, _, _, bin, _)) => mean3(weight) * g.q[(cell_key + bin) as usize],
                None => 0.0,
            };
            // With `mis_targets` the target is the light as the image counts it
            // from here on, and the fraction's gradient weighs the same (`nee_here`
            // is 0 without it).
            let target = le_target + nee_here + reflected;
            let counted = if mis_targets { target } else { le_counted + reflected };
            record_to(&mut **learn, prev_key, target, counted, prev_factor, bins_per_cell);
        }
        if last {
            break;
        }
        let Some((wi, weight, pdf, delta, bin, factor)) = sampled else { break };
        beta *= weight;
        prev_pdf = pdf;
        prev_delta = delta;
        prev_p = hit.p;
        if guide.is_some() {
            prev_key = cell_key + bin;
            prev_factor = factor;
        }
        o = offset_origin(hit.p, hit.n, hit.eps, wi);
        d = wi;
        depth += 1;
        if rr && depth >= p.rr_depth {
            let q = match guide {
                // The radiance learned for the ray about to be traced, times the throughput.
                Some(g) if pixel_estimate > 0.0 => {
                    guide::survival_probability(mean3(beta) * g.q[prev_key as usize], pixel_estimate)
                }
                _ => max_component(beta).min(0.95),
            };
            if rng.sample_1d(bounce_dim(depth, shared::SAMPLE_ROULETTE)) >= q {
                break;
            }
            beta /= q;
        }
        if beta.max_element() <= 0.0 {
            break;
        }
    }
    (radiance, segments)
}

/// The hit's shading normal on the side of `n` (the geometric normal as the
/// vertex shades with it); `n` itself where `wo` lies on one side of the shading
/// normal and the other of the surface, where the shading frame cannot describe
/// the vertex. `glsl/pathtrace.comp` `shading_side`.
pub fn shading_side(n: Vec3, hit: crate::math::geometry::Hit, wo: Vec3) -> Vec3 {
    let ns = if n == hit.n { hit.ns } else { -hit.ns };
    if ns.dot(wo) * n.dot(wo) < 0.0 {
        n
    } else {
        ns
    }
}

/// Whether `w` lies on the same side of the geometric normal `n` as of the
/// shading normal `ns`: always where the two are one. `glsl/pathtrace.comp` `sides_agree`.
pub fn sides_agree(n: Vec3, ns: Vec3, w: Vec3) -> bool {
    !(w.dot(n) * w.dot(ns) < 0.0)
}

/// Hands the target of the ray that left through `key` to `r`, and where `factor`
/// is not 0 the fraction-gradient sample of the ray's cell, `-factor * counted`
/// (`guide::FractionState`): `counted` is the target with the emission the ray
/// met weighted as the image weighs it (MIS against light sampling), since the
/// fraction should serve what BSDF and guided sampling contribute, and with NEE
/// most direct light is light sampling's. A target that is not finite (a
/// direction whose density underflowed, say) is dropped with its gradient, as
/// non-finite samples are dropped from the image: summed in, it would make its
/// entry NaN or infinite for good. `glsl/pathtrace.comp` `record`.
fn record_to(r: &mut dyn Recorder, key: u32, target: f32, counted: f32, factor: f32, bins: u32) {
    if !target.is_finite() {
        return;
    }
    r.target(key, target);
    if factor != 0.0 {
        r.fraction_gradient(key / bins, -factor * counted);
    }
}

/// What a frame measured besides the image.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCounters {
    /// Paths whose radiance was exactly zero.
    pub zero_paths: u64,
    /// Rays traced (camera, bounce and shadow rays).
    pub segments: u64,
    /// The pixels' `crate::film::frame_variance_term`s summed (0 where no race
    /// weighs the frame).
    pub variance: u64,
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
    /// (`crate::render::rng_frame`).
    frame_offset: u32,
    /// The learning frames left out of the image once it starts (0 until then, and
    /// after `reset_film`): learned roulette's estimate still counts them.
    learned_frames: u32,
    pub last_counters: FrameCounters,
    /// The kind of the last frame traced (None without guiding).
    pub last_kind: Option<guide::FrameKind>,
    /// The last frame's mean relative variance, where it is weighed
    /// (`FLAG_FRAME_VARIANCE`; `crate::render::FrameTimings::variance`).
    pub last_variance: Option<f64>,
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
            last_counters: FrameCounters::default(),
            last_kind: None,
            last_variance: None,
        }
    }

    /// The race of the image's frames' kernels, where there is one.
    pub fn race(&self) -> Option<&guide::FrameRace> {
        self.learning.as_ref().and_then(|l| l.race.as_ref())
    }

    pub fn film(&self) -> &Film {
        &self.film
    }

    pub fn table(&self) -> Option<&QTable> {
        self.learning.as_ref().map(|l| &l.table)
    }

    /// Sets the random numbers' frame offset of the image's frames
    /// (`crate::render::rng_frame`), before the first frame: a part of a split
    /// render (`crate::parts`).
    pub fn set_frame_offset(&mut self, offset: u32) {
        assert_eq!(self.frames_traced, 0, "the frame offset is set before the first frame");
        self.frame_offset = offset;
    }

    /// Starts a new accumulation; what guiding learned is kept.
    pub fn reset_film(&mut self) {
        self.film = Film::new(self.film.width, self.film.height);
        self.learned_frames = 0;
    }

    /// Renders one frame of 64 samples per pixel; with guiding, the table learns
    /// from its Q-learning targets after the frames the schedule names. The frame
    /// after the learning frames (`GuideConfig::learning_frames`) starts the
    /// image anew: the film then holds it alone (`crate::film::accumulate`).
    pub fn render_frame(&mut self) {
        let start = std::time::Instant::now();
        let p = self.scene.params;
        let learning_frames = self.scene.learning_frames();
        // The image's frames are guided or not as the race says, where there is one.
        let kind = self
            .learning
            .as_ref()
            .map(|l| guide::frame_kind(l.race.as_ref(), self.frames_traced, l.guided_traced, learning_frames));
        let guided = kind == Some(guide::FrameKind::Guided);
        let frame = self.learning.as_ref().map_or(self.frames_traced, |l| l.guided_traced);
        if self.film.frames > 0 && self.frames_traced == learning_frames {
            self.learned_frames = self.film.frames;
            self.film.frames = 0;
        }
        let (accum_frames, learned_frames) = (self.film.frames, self.learned_frames);
        let rng_frame = crate::render::rng_frame(self.frames_traced, learning_frames, self.frame_offset);
        // A loaded field has learned: learned roulette need not wait for it.
        let table_frames = if self.scene.guide_start.is_some() { guide::GuideField::table_frames() } else { 0 };
        let scene = &self.scene;
        let learning = self.learning.as_ref();
        let guide = scene.guide.as_ref().zip(learning).filter(|_| guided).map(|(cfg, l)| Guide::new(cfg, &l.table));
        let weigh = p.flags & shared::FLAG_FRAME_VARIANCE != 0;
        // Empty sums for the table (none without guiding).
        let no_sums = || scene.guide.as_ref().map_or_else(|| FrameSums::new(0, 0), FrameSums::for_config);
        let schedule = learning.filter(|_| guided).map(|l| &l.schedule);
        let (sums, counters) = self
            .film
            .pixels
            .par_chunks_mut(p.width as usize)
            .enumerate()
            .fold(
                || (no_sums(), FrameCounters::default()),
                |(mut sums, mut counters), (y, row)| {
                    let record = schedule.is_some_and(|s| s.records(frame, y as u32));
                    for (x, acc) in row.iter_mut().enumerate() {
                        let pixel = y as u32 * p.width + x as u32;
                        let (mut sum, mut sum_sq) = (Vec3::ZERO, 0.0f32);
                        let estimate = match guide {
                            Some(_) => {
                                guide::roulette_estimate(acc, accum_frames, learned_frames, frame + table_frames)
                            }
                            None => 0.0,
                        };
                        for sample in 0..shared::SAMPLES_PER_FRAME {
                            let mut rng = PathSampler::for_flags(p.flags, p.seed, pixel, rng_frame, sample);
                            let u = rng.sample_pixel(sample);
                            let (o, d) = camera_ray(&p, x as u32, y as u32, u);
                            let learn = record.then_some(&mut sums as &mut dyn Recorder);
                            let (l, segs) = trace_path(scene, guide, o, d, &mut rng, estimate, learn);
                            counters.segments += segs as u64;
                            // A NaN or infinite sample would poison the pixel forever; it is dropped
                            // (as on the GPU) and counted as carrying nothing.
                            if l.is_finite() {
                                sum += l;
                                sum_sq += mean3(l) * mean3(l);
                            }
                            if !(l.max_element() > 0.0) {
                                counters.zero_paths += 1;
                            }
                        }
                        if weigh {
                            let before = pixel_mean_before(acc, accum_frames, learned_frames, mean3(sum));
                            counters.variance += crate::film::frame_variance_term(mean3(sum), sum_sq, before) as u64;
                        }
                        crate::film::accumulate(acc, accum_frames, learned_frames, sum.to_array());
                    }
                    (sums, counters)
                },
            )
            .reduce(
                || (no_sums(), FrameCounters::default()),
                |(a, ca), (b, cb)| {
                    (
                        a.merge(b),
                        FrameCounters {
                            zero_paths: ca.zero_paths + cb.zero_paths,
                            segments: ca.segments + cb.segments,
                            variance: ca.variance + cb.variance,
                        },
                    )
                },
            );
        let guided_before = self.learning.as_ref().map_or(0, |l| l.guided_traced);
        let (mut trace_ms, mut learn_ms, mut period) = (start.elapsed().as_secs_f64() * 1e3, None, 1);
        if let (Some(l), Some(cfg)) = (self.learning.as_mut(), self.scene.guide.as_ref()) {
            if guided {
                l.pending.add_all(&sums);
                trace_ms = start.elapsed().as_secs_f64() * 1e3;
                if l.schedule.learns_after(l.guided_traced) {
                    let learn_start = std::time::Instant::now();
                    l.table.learn(cfg, &l.pending);
                    l.pending = FrameSums::for_config(cfg);
                    learn_ms = Some(learn_start.elapsed().as_secs_f64() * 1e3);
                }
                period = l.schedule.learning_period(l.guided_traced);
                l.guided_traced += 1;
            }
        }
        let pixels = (p.width * p.height) as f64;
        let variance = weigh.then(|| counters.variance as f64 / shared::FRAME_VARIANCE_SCALE as f64 / pixels);
        if let (Some(race), Some(kind), Some(v)) =
            (self.learning.as_mut().and_then(|l| l.race.as_mut()), kind, variance)
        {
            if guide::race_weighs(kind, self.frames_traced, guided_before, learning_frames) {
                race.report_frame(kind, v, trace_ms, learn_ms, period);
            }
        }
        self.film.frames += 1;
        self.frames_traced += 1;
        self.last_counters = counters;
        self.last_kind = kind;
        self.last_variance = variance;
    }
}

/// `pathtrace.comp` `add_frame_variance`'s mean of the pixel before the frame:
/// the accumulation's, the learning frames' where the image has none yet, else
/// this frame's (`frame_sum`, mean3 of its sum).
fn pixel_mean_before(acc: &crate::layout::AccumPixel, accum_frames: u32, learned_frames: u32, frame_sum: f32) -> f32 {
    let n = if accum_frames > 0 { accum_frames } else { learned_frames };
    let per_frame = shared::SAMPLES_PER_FRAME as f32;
    if n > 0 {
        mean3(Vec3::from_slice(&acc.sum[..3])) / (per_frame * n as f32)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// What `record_to` hands on.
    #[derive(Default)]
    struct Seen {
        targets: Vec<(u32, f32)>,
        gradients: Vec<(u32, f32)>,
    }

    impl Recorder for Seen {
        fn target(&mut self, key: u32, target: f32) {
            self.targets.push((key, target));
        }
        fn fraction_gradient(&mut self, cell: u32, gradient: f32) {
            self.gradients.push((cell, gradient));
        }
        fn row_read(&mut self, _: usize) {}
    }

    /// A finite target goes to its key and, where the vertex mixed, the gradient
    /// sample to its cell; a target that is not finite goes nowhere, gradient included.
    #[test]
    fn targets_that_are_not_finite_are_dropped() {
        let mut seen = Seen::default();
        record_to(&mut seen, 130, 2.0, 1.5, 0.25, 128);
        assert_eq!(seen.targets, [(130, 2.0)]);
        assert_eq!(seen.gradients, [(1, -0.375)]);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut seen = Seen::default();
            record_to(&mut seen, 130, bad, bad, 0.25, 128);
            assert!(seen.targets.is_empty() && seen.gradients.is_empty(), "{bad}");
        }
    }
}
