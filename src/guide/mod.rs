//! Learned guiding after Dahm & Keller, "Learning Light Transport the
//! Reinforced Way" (2017): the geometry of the Q-table, its learning and the
//! guided sampler.
//!
//! - **States** are the cells of a voxel [`Grid`] over the scene.
//! - **Actions** are [`Bins`] of directions over the whole sphere, equal in solid
//!   angle: rows uniform in cos(theta), columns uniform in phi (world space); by
//!   default 8x16, or 20x40 in scenes with Russian roulette ([`default_bins`]).
//! - **Q(cell, bin)** estimates the radiance arriving at the cell from the bin's
//!   directions (mean over RGB).
//! - **Learning**: when a path leaves x through bin a, reaches y and continues from
//!   y in the direction w it sampled there (weight f |cos| / pdf), Q(x, a) moves
//!   towards `Le(y -> x) + (f |cos| / pdf)(w) Q(y, bin(w))`, the i-th target of
//!   an entry with learning rate 1 / i^omega ([`batch_rate`]). At omega = 1, the
//!   default, this is Dahm & Keller's 1 / (1 + visits), and Q the running mean of
//!   its targets; omega in (1/2, 1) (`--learning-rate-exponent`) forgets sooner
//!   the first targets, which were bootstrapped from a table that had learned
//!   little, and converges to the same values (a polynomial rate: Even-Dar &
//!   Mansour, "Learning Rates for Q-learning", JMLR 2003). This target is the
//!   one-sample Monte Carlo estimate of Dahm & Keller's expected-SARSA target
//!   `Le(y) + integral Q(y, bin(w)) f(y; w -> x) |cos w| dw`: its expectation is
//!   that integral (over each bin, not only at its centre), so the estimates
//!   converge to the same values while each update costs O(1) instead of one BSDF
//!   evaluation per bin. Delta vertices pass through the bin of the direction they
//!   chose. With NEE, by default, `Le(y -> x)` counts with the MIS weight the image
//!   gives it and the light sample's estimate at y joins the target
//!   ([`QTargets::Mis`]): Q learns the light that BSDF and guided directions are
//!   there to find, and the same values as Dahm & Keller's but in the directions
//!   of the lights themselves. Targets are summed per entry and folded in after the frames
//!   [`RecordSchedule::learns_after`] names ([`QTable::learn`]), in batches. Without
//!   Russian roulette only the rays that leave guided vertices (below) record
//!   targets ([`record_vertices`]), and after the first frames only the paths of
//!   one pixel row in a stride that grows from 8 to 32 as the table fills
//!   ([`RecordSchedule`]).
//! - **Sampling** at a non-delta vertex among a path's first `guided_vertices`
//!   (by default all where Russian roulette is on; without roulette two with NEE,
//!   all without; deeper vertices sample the BSDF alone, see [`guided_vertices`]
//!   and `prepared::DEFAULT_GUIDED_VERTICES_NEE`) is a one-sample mixture: with the
//!   guided fraction of the vertex's cell (learned per cell by default,
//!   [`FractionState`], or fixed), times the lobe's share ([`lobe_share`]), a bin is drawn from the cell's sampling row for the vertex's
//!   orientation class (the signed axis nearest its shading normal,
//!   [`normal_class`]), in proportion to `(Q + floor * Qbar) cos(axis, bin)`
//!   (an alias table, rebuilt as [`RecordSchedule::learns_after`] says: one or two loads per
//!   sample, one per density), and a direction uniformly inside it; otherwise the BSDF is
//!   sampled. The mixture pdf weights the path and the MIS with light sampling, so
//!   the image stays unbiased, and no direction where the BSDF is non-zero gets pdf
//!   zero (`crate::cpu` `trace_path` says why the MIS weights use the mixture's
//!   density, not the BSDF's). Cells that have learned nothing use BSDF sampling alone. The cosine is
//!   that of the class axis, exact on axis-aligned walls; the BSDF's own lobe is
//!   left to the BSDF half of the mixture.
//! - **Russian roulette** with guiding keeps a path in proportion to its expected
//!   contribution, from the learned Q, relative to the pixel's estimate
//!   ([`survival_probability`]).
//!
//! `glsl/guide.glsl` and `glsl/learn.comp` are the GPU twins. The method's reasons
//! and measured effects are in docs/guiding.md.

use crate::layout::{AccumPixel, GpuMaterial, RenderParams, SceneArrays};
use crate::math::geometry::intersect;
use crate::math::rng::Rng;
use crate::math::{mean3, Frame, Vec3};
use crate::scene::GuidingSettings;
use crate::shared;
use std::f32::consts::PI;

/// Which guiding, if any (`--guiding`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GuidingMode {
    /// Plain path tracing.
    #[value(help = "plain path tracing")]
    Off,
    /// 2 x 4 bins: exactly the eight octants of the seed.
    #[value(help = "the seed's eight octants (2x4 bins)")]
    Octant,
    /// Finer bins over the sphere (by default 8 x 16 = 128, or 20 x 40 = 800 in
    /// scenes with Russian roulette: [`default_bins`]).
    #[value(help = "finer bins over the sphere (--bins)")]
    Sphere,
}

/// What a Q-learning target counts of the light its ray meets, where light
/// sampling (NEE) is on. Without NEE the two are the same, bit for bit.
///
/// Q(x, a) is learned for the guided mixture, which with NEE shares the direct
/// light with light sampling by MIS. `Full` is Dahm & Keller's target: the
/// emission Le(y) the ray meets counted in full, plus the reflected light
/// estimated from Q at y. `Mis` (the default) counts Le(y) with the MIS weight the
/// image gives it, and adds the light sample's estimate at y (without the path's
/// throughput) to the reflected light. The MIS weights of the two techniques sum
/// to one, so where y reflects, the light sample's estimate and the reflected
/// part's share of direct light sum to what `Full`'s reflected part estimates
/// alone: at convergence the two learn the same values but for the emission a
/// ray meets directly, of which `Mis` keeps the share that BSDF and guided
/// directions are weighted for. (`Mis` gets there sooner: the light sample's
/// estimate needs no learning; `mis_targets_leave_the_lamp_to_light_sampling`.)
/// Guided directions then go where light sampling does not already find the
/// light, in the spirit of Karlík et al.'s MIS compensation ("MIS Compensation:
/// Optimizing Sampling Techniques in Multiple Importance Sampling", SIGGRAPH Asia
/// 2019), which takes from a sampler's density what its MIS partner covers. The
/// image stays unbiased either way: the targets change what is learned, not how
/// a sample is weighed. docs/guiding.md, "Targets", has the measured effect.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum QTargets {
    /// The emission met counted with its MIS weight, the light sample at the
    /// vertex met added: the light the mixture is there to find.
    #[value(help = "the emission met as MIS weighs it, plus the light sample at the vertex met")]
    Mis,
    /// Dahm & Keller's: the emission met counted in full.
    #[value(help = "Dahm & Keller's: the emission met in full")]
    Full,
}

impl QTargets {
    pub fn name(self) -> &'static str {
        match self {
            QTargets::Mis => "mis",
            QTargets::Full => "full",
        }
    }
}

impl GuidingMode {
    pub fn name(self) -> &'static str {
        match self {
            GuidingMode::Off => "off",
            GuidingMode::Octant => "octant",
            GuidingMode::Sphere => "sphere",
        }
    }
}

/// Equal-area direction bins: `rows` bands uniform in cos(theta) (z from +1 down
/// to -1) times `cols` sectors uniform in phi.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bins {
    pub rows: u32,
    pub cols: u32,
}

impl Bins {
    pub const OCTANT: Bins = Bins { rows: 2, cols: 4 };
    /// `--guiding sphere`'s bins in scenes without Russian roulette ([`default_bins`]).
    pub const SPHERE_DEFAULT: Bins = Bins { rows: 8, cols: 16 };
    /// `--guiding sphere`'s bins in scenes with Russian roulette ([`default_bins`]).
    pub const SPHERE_ROULETTE_DEFAULT: Bins = Bins { rows: 20, cols: 40 };

    pub fn count(&self) -> u32 {
        self.rows * self.cols
    }

    /// Solid angle of every bin.
    pub fn solid_angle(&self) -> f32 {
        4.0 * PI / self.count() as f32
    }

    /// The bin of a unit direction; `glsl/guide.glsl` `bin_index`.
    pub fn index(&self, d: Vec3) -> u32 {
        let row = (((1.0 - d.z) * 0.5 * self.rows as f32) as u32).min(self.rows - 1);
        row * self.cols + self.column(d.x, d.y)
    }

    /// The column of the azimuth phi = atan2(y, x) in [0, 2 pi): the sector
    /// `floor(phi cols / 2 pi)`. Where `cols` is a multiple of 4 (the octant's 4,
    /// the defaults 16 and 40), without the arctangent: (x, y) is turned back by whole
    /// quarter turns into the first quadrant, (u, v) with u, v >= 0, and the
    /// sector within it counted by the sides of its `cols / 4 - 1` inner edges
    /// (v cos t - u sin t >= 0 from edge angle t on). The same function up to
    /// rounding at the edges (where either bin's density will do); on the GPU
    /// the arctangent was most of the bin lookup that a guided vertex, and with
    /// learned roulette every vertex, pays. `glsl/guide.glsl` `bin_column`.
    pub fn column(&self, x: f32, y: f32) -> u32 {
        if !self.cols.is_multiple_of(4) {
            let mut phi = y.atan2(x);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            return ((phi * (0.5 / PI) * self.cols as f32) as u32).min(self.cols - 1);
        }
        let per_quadrant = self.cols / 4;
        // The quadrant q and (x, y) turned back by q quarter turns; the boundary
        // rays go with the quadrant they start (phi = 0, pi / 2, pi, 3 pi / 2).
        let (q, u, v) = match (y >= 0.0, x > 0.0) {
            (true, true) => (0, x, y),
            (true, false) => (1, y, -x),
            (false, false) => (2, -x, -y),
            (false, true) => (3, -y, x),
        };
        // u = 0 (v > 0): phi is the next quadrant's first edge. Only q = 1 and
        // 2 reach it (phi = pi and 3 pi / 2); the poles (0, 0) take column 0.
        if u <= 0.0 {
            return if v > 0.0 { (q + 1) * per_quadrant } else { 0 };
        }
        let step = 0.5 * PI / per_quadrant as f32;
        let inside = (1..per_quadrant)
            .filter(|&j| {
                let (s, c) = (j as f32 * step).sin_cos();
                v * c - u * s >= 0.0
            })
            .count() as u32;
        q * per_quadrant + inside
    }

    /// A direction uniformly distributed in bin `b`; `glsl/guide.glsl` `bin_sample`.
    pub fn sample(&self, b: u32, u: [f32; 2]) -> Vec3 {
        let (row, col) = (b / self.cols, b % self.cols);
        let z = 1.0 - 2.0 * (row as f32 + u[0]) / self.rows as f32;
        let phi = 2.0 * PI * (col as f32 + u[1]) / self.cols as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// The direction at the centre of bin `b` (where the sampling weights are evaluated).
    pub fn center(&self, b: u32) -> Vec3 {
        self.sample(b, [0.5, 0.5])
    }

    /// Parses `ROWSxCOLS`, e.g. `8x16`.
    pub fn parse(s: &str) -> Result<Bins, String> {
        let (r, c) = s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}`: expected ROWSxCOLS, e.g. 8x16"))?;
        let rows: u32 = r.trim().parse().map_err(|_| format!("`{s}`: rows `{r}` is not a positive integer"))?;
        let cols: u32 = c.trim().parse().map_err(|_| format!("`{s}`: columns `{c}` is not a positive integer"))?;
        Bins::check(rows, cols).map_err(|e| format!("`{s}`: {e}"))?;
        Ok(Bins { rows, cols })
    }

    /// Most bins a table may have. Finer tables learn too slowly to pay
    /// (docs/guiding.md, "The table"), and the bound keeps a row's 16-bit alias
    /// indices far from the marker [`UNLEARNED`].
    pub const MAX_COUNT: u64 = 1024;

    /// Whether `rows` x `cols` bins are a table the renderers can build: at least
    /// one of each, at most [`Bins::MAX_COUNT`] in all. The message says what was
    /// expected.
    pub fn check(rows: u32, cols: u32) -> Result<(), String> {
        if rows == 0 || cols == 0 || rows as u64 * cols as u64 > Bins::MAX_COUNT {
            return Err(format!("rows and columns must be at least 1, and at most {} bins in all", Bins::MAX_COUNT));
        }
        Ok(())
    }
}

/// The voxel grid whose cells are the states.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub min: Vec3,
    pub max: Vec3,
    pub res: [u32; 3],
}

impl Grid {
    pub fn cells(&self) -> u32 {
        self.res[0] * self.res[1] * self.res[2]
    }

    /// Cells per unit length along each axis.
    pub fn inv_cell_size(&self) -> Vec3 {
        Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32) / (self.max - self.min)
    }

    /// The cell containing `p`; points outside the box use the nearest cell.
    /// `glsl/guide.glsl` `cell_index`.
    pub fn cell(&self, p: Vec3) -> u32 {
        let g = (p - self.min) * self.inv_cell_size();
        let clampi = |v: f32, n: u32| (v.max(0.0) as u32).min(n - 1);
        let (x, y, z) = (clampi(g.x, self.res[0]), clampi(g.y, self.res[1]), clampi(g.z, self.res[2]));
        (z * self.res[1] + y) * self.res[0] + x
    }

    /// The grid of a scene: the `[guiding]` table where it says so; otherwise the
    /// box around the points that camera rays and their first diffuse bounce reach
    /// (so huge wall spheres do not stretch it), and 16 cells along its longest axis.
    pub fn for_scene(scene: &SceneArrays, settings: &GuidingSettings) -> Grid {
        let (min, max) = match (settings.bounds_min, settings.bounds_max) {
            (Some(a), Some(b)) => (a, b),
            _ => probe_bounds(scene),
        };
        let res = settings.resolution.unwrap_or_else(|| {
            let e = max - min;
            let longest = e.max_element();
            let n = |x: f32| ((16.0 * x / longest).round() as u32).clamp(1, 16);
            [n(e.x), n(e.y), n(e.z)]
        });
        Grid { min, max, res }
    }
}

/// A warning for stderr where the scene's own `[guiding]` box does not overlap
/// [`probe_bounds`], the box of what the camera sees: every point of the scene
/// then falls in the grid's edge cells (points outside the box use the nearest
/// cell), and the table learns one blur of the whole scene. None where the box
/// is chosen automatically, or guiding is off.
pub fn grid_warning(scene: &SceneArrays, cfg: Option<&GuideConfig>, settings: &GuidingSettings) -> Option<String> {
    let cfg = cfg?;
    settings.bounds_min?;
    let (lo, hi) = probe_bounds(scene);
    let (min, max) = (cfg.grid.min, cfg.grid.max);
    let overlaps = (0..3).all(|a| min[a] < hi[a] && max[a] > lo[a]);
    (!overlaps).then(|| {
        let v = |p: Vec3| format!("[{}, {}, {}]", p.x, p.y, p.z);
        format!(
            "the [guiding] box from {} to {} does not overlap what the camera sees (about {} to {}): every \
             point falls in one of its edge cells, and guiding learns little",
            v(min),
            v(max),
            v(lo),
            v(hi)
        )
    })
}

/// The bounding box of the camera and of the surface points seen from it
/// directly and after one bounce, enlarged by 1% of its diagonal.
pub fn probe_bounds(scene: &SceneArrays) -> (Vec3, Vec3) {
    let p = &scene.params;
    let eye = Vec3::new(p.cam_position_near[0], p.cam_position_near[1], p.cam_position_near[2]);
    let (mut lo, mut hi) = (eye, eye);
    let n = 64u32;
    let mut rng = Rng::new(0x5eed, 0, 0, 0);
    let mut probe = p.to_owned();
    probe.width = n;
    probe.height = n;
    for y in 0..n {
        for x in 0..n {
            let (o, d) = crate::camera::camera_ray(&probe, x, y, rng.next_2d());
            let Some(h) = intersect(scene, o, d, f32::INFINITY) else { continue };
            lo = lo.min(h.p);
            hi = hi.max(h.p);
            let nrm = if h.n.dot(d) < 0.0 { h.n } else { -h.n };
            let dir = Frame::from_normal(nrm).to_world(crate::math::sampling::cosine_hemisphere(rng.next_2d()));
            let o2 = crate::math::geometry::offset_origin(h.p, h.n, h.eps, dir);
            if let Some(h2) = intersect(scene, o2, dir, f32::INFINITY) {
                lo = lo.min(h2.p);
                hi = hi.max(h2.p);
            }
        }
    }
    let margin = 0.01 * (hi - lo).length().max(1e-3);
    (lo - Vec3::splat(margin), hi + Vec3::splat(margin))
}

/// Everything the guided sampler needs besides the table itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideConfig {
    pub mode: GuidingMode,
    pub bins: Bins,
    pub grid: Grid,
    /// Probability of guided sampling at a non-delta vertex: fixed, or where
    /// `learn_fraction`, each cell's starting value.
    pub fraction: f32,
    /// Whether each cell learns its own fraction ([`FractionState`]).
    pub learn_fraction: bool,
    /// Exploration floor: bins are sampled in proportion to `(Q + floor * mean Q of
    /// the cell) f |cos|`, so directions not yet learned keep some guided probability
    /// ([`DEFAULT_FLOOR`] by default).
    pub floor: f32,
    /// The exponent omega of Q's learning rate 1 / i^omega ([`batch_rate`]), in
    /// (1/2, 1]; 1, the default, is the running mean.
    pub rate_exponent: f32,
    /// Frames at the start of the render that teach the table and are then left
    /// out of the image ([`default_learning_frames`]); their radiance stays the
    /// pixels' estimate for learned roulette.
    pub learning_frames: u32,
}

impl GuideConfig {
    pub fn entries(&self) -> usize {
        (self.grid.cells() * self.bins.count()) as usize
    }

    /// Sampling rows of the table: [`NORMAL_CLASSES`] per cell.
    pub fn sampling_rows(&self) -> usize {
        self.grid.cells() as usize * NORMAL_CLASSES as usize
    }
}

/// Recorded paths per table entry at which the recording stride first doubles
/// ([`RecordSchedule`]); it doubles again at twice as many, and so on.
pub const RECORD_PATHS_PER_ENTRY: f64 = 1024.0;

/// Which pixel rows hand their paths' Q-learning targets to the table, frame by
/// frame (counted from the first frame traced): all rows in the first
/// `RECORD_ALL_FRAMES` frames, then one row in a stride, a different one each
/// frame. The stride starts at `RECORD_ROW_STRIDE` and doubles, up to
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
}

impl RecordSchedule {
    /// The schedule of a render of `pixels` pixels (`SAMPLES_PER_FRAME` paths each
    /// per frame) over a table of `entries` entries.
    pub fn new(pixels: u64, entries: u64) -> RecordSchedule {
        use shared::{RECORD_ALL_FRAMES, RECORD_MAX_STRIDE, RECORD_ROW_STRIDE, SAMPLES_PER_FRAME};
        // In frames of every row: recorded so far, and needed for the next doubling.
        let per_entry = (pixels * SAMPLES_PER_FRAME as u64) as f64 / entries.max(1) as f64;
        let mut recorded = RECORD_ALL_FRAMES as f64;
        let mut needed = RECORD_PATHS_PER_ENTRY / per_entry.max(1e-12);
        let (mut frame, mut stride) = (RECORD_ALL_FRAMES as u64, RECORD_ROW_STRIDE as u64);
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
        RecordSchedule { doublings }
    }

    /// The schedule of a guided render of `width` x `height` pixels.
    pub fn for_render(cfg: &GuideConfig, width: u32, height: u32) -> RecordSchedule {
        RecordSchedule::new(width as u64 * height as u64, cfg.entries() as u64)
    }

    /// One pixel row in this many records in frame `frame`: 1 (every row) in the
    /// first `RECORD_ALL_FRAMES` frames, then `RECORD_ROW_STRIDE` up to `RECORD_MAX_STRIDE`.
    pub fn stride(&self, frame: u32) -> u32 {
        if frame < shared::RECORD_ALL_FRAMES {
            return 1;
        }
        shared::RECORD_ROW_STRIDE << self.doublings.iter().filter(|&&d| frame >= d).count()
    }

    /// Whether the paths of pixel row `y` record their targets in frame `frame`.
    pub fn records(&self, frame: u32, y: u32) -> bool {
        (y + frame).is_multiple_of(self.stride(frame))
    }

    /// Whether the table learns after frame `frame`: the targets recorded since
    /// it last learned are folded into Q, and the sampling rows rebuilt from it
    /// ([`QTable::learn`]). After each of the first `RECORD_ALL_FRAMES` frames,
    /// while the table changes fast, then after the last frame of each cycle of
    /// the recording rows, one frame in `stride`, when every row has recorded once.
    /// In between, the targets are summed per entry, and paths read a table and
    /// sample rows a few frames old; the densities they evaluate are those of the
    /// same rows, so the estimate stays unbiased, and Q takes the same targets,
    /// folded later. The rebuild is a sequential loop per row, and learning
    /// once per cycle spares most frames its pass. Rows go staler as the stride
    /// grows, but only once the table has seen many targets per entry and changes
    /// little from frame to frame; that is why the stride follows the table's
    /// fill, not the frame count (docs/guiding.md, "The recording schedule").
    pub fn learns_after(&self, frame: u32) -> bool {
        let stride = self.stride(frame);
        frame % stride == stride - 1
    }
}

/// The vertices that mix guided sampling in: those of depth below this. The
/// params' `guide_vertices` where set (not 0), else the default for their flags:
/// every vertex where Russian roulette is on, whatever NEE says; without roulette
/// [`crate::layout::DEFAULT_GUIDED_VERTICES_NEE`] with NEE, every vertex without.
///
/// With roulette every vertex already records Q-learning targets
/// ([`record_vertices`]) and looks up its cell for learned roulette, so guided
/// sampling there costs only the sampling itself, and it paid at equal time
/// (docs/guiding.md, "Defaults").
///
/// `glsl/pathtrace.comp` takes it as the specialization constant
/// `SPEC_GUIDE_VERTICES`.
pub fn guided_vertices(p: &RenderParams) -> u32 {
    match p.guide_vertices {
        0 if p.flags & shared::FLAG_RUSSIAN_ROULETTE != 0 => u32::MAX,
        0 if p.flags & shared::FLAG_NEE != 0 => crate::layout::DEFAULT_GUIDED_VERTICES_NEE,
        0 => u32::MAX,
        n => n,
    }
}

/// The learning frames of a guided render (`GuideConfig::learning_frames`) where
/// none are asked for: with Russian roulette the frames before learned roulette
/// starts (`LEARNED_RR_FRAMES`), none without.
///
/// Those first frames run plain throughput roulette over a table that has learned
/// from a few frames at most, and each has most of unguided's variance, which the
/// image's average would keep. Without roulette the first frames gain gradually,
/// and leaving them out would cost more samples than error. Which frames are left
/// out is fixed before the render, so the image stays unbiased
/// (docs/guiding.md, "Learned Russian roulette and learning frames").
pub fn default_learning_frames(roulette: bool) -> u32 {
    if roulette {
        shared::LEARNED_RR_FRAMES
    } else {
        0
    }
}

/// The most learning frames taken (`--learning-frames`; [`check_learning_frames`]).
pub const MAX_LEARNING_FRAMES: u32 = 65_536;

/// Whether `n` learning frames can be asked for: 0 to [`MAX_LEARNING_FRAMES`].
/// The message says what was expected (shared with the command line's parser).
pub fn check_learning_frames(n: u32) -> Result<(), String> {
    if n <= MAX_LEARNING_FRAMES {
        Ok(())
    } else {
        Err(format!("0 to {MAX_LEARNING_FRAMES} frames: those that teach the table before the image starts"))
    }
}

/// The bins of `--guiding sphere` where the options name none
/// (`RenderOptions::bins` None): [`Bins::SPHERE_ROULETTE_DEFAULT`] (20x40) in a
/// scene with Russian roulette (`russian_roulette_depth`), [`Bins::SPHERE_DEFAULT`]
/// (8x16) without.
///
/// With roulette every vertex records targets ([`record_vertices`]), so each
/// entry sees several times the targets per frame and a finer table learns in
/// time; past 20x40 the frames grow faster than the error falls. Where only the
/// first two vertices are guided, finer bins gained nothing (docs/guiding.md,
/// "Defaults").
pub fn default_bins(roulette: bool) -> Bins {
    if roulette {
        Bins::SPHERE_ROULETTE_DEFAULT
    } else {
        Bins::SPHERE_DEFAULT
    }
}

/// The vertices whose outgoing rays record Q-learning targets: those of depth below
/// this. The guided vertices ([`guided_vertices`]), since sampling draws from a cell's
/// bins there alone; but every vertex where Russian roulette is on, since learned
/// roulette reads Q at the deep vertices too, and cells learned only from shallow
/// ones left it guessing. Without roulette, recording only the guided vertices
/// saves time with no loss per sample (docs/guiding.md, "Learning").
/// `glsl/pathtrace.comp` takes it as the specialization constant `SPEC_RECORD_VERTICES`.
pub fn record_vertices(p: &RenderParams) -> u32 {
    if p.flags & shared::FLAG_RUSSIAN_ROULETTE != 0 {
        u32::MAX
    } else {
        guided_vertices(p)
    }
}

/// One bin of a guided sampling row: its column of the row's alias table
/// (Walker's alias method, built by Vose's algorithm) and its density.
///
/// Drawing a bin takes one load (and a second where the column passes to its
/// alias); evaluating the density of a direction takes one. `glsl/guide.glsl`
/// reads the same 8 bytes as a `uvec2`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AliasBin {
    /// `threshold << 16 | alias`: column `i` keeps bin `i` when its uniform
    /// number is below `threshold / 65535`, else gives `alias`. [`UNLEARNED`] in
    /// every bin of a row that has nothing to sample.
    pub column: u32,
    /// Solid-angle density of guided sampling in this bin: exactly the probability
    /// the alias table gives the bin (thresholds as stored), over the bin's solid angle.
    pub pdf: f32,
}

/// The column of every bin of a row with nothing to sample (no alias index
/// reaches 65535: rows have at most 1024 bins). `glsl/common.glsl`.
pub const UNLEARNED: u32 = shared::UNLEARNED;

/// Scale of the 16-bit thresholds. `glsl/common.glsl` `ALIAS_THRESHOLD_ONE`.
const THRESHOLD_ONE: u32 = shared::ALIAS_THRESHOLD_ONE;

/// Draws a direction from a sampling row ([`build_alias_row`]): the column
/// from `uc`, the bin by comparing the remainder with the column's threshold,
/// then a direction uniformly inside the bin with `u`. Its density is
/// [`guided_pdf`], a function of the direction alone, which is what the mixture
/// with BSDF sampling needs for either choice. `glsl/guide.glsl` `guided_direction`.
pub fn guided_direction(bins: &Bins, row: &[AliasBin], uc: f32, u: [f32; 2]) -> Vec3 {
    guided_direction_bin(bins, row, uc, u).0
}

/// [`guided_direction`] and the bin it drew the direction in, whose density is
/// the direction's ([`bin_pdf`]); the renderers read it instead of finding the
/// direction's bin again.
pub fn guided_direction_bin(bins: &Bins, row: &[AliasBin], uc: f32, u: [f32; 2]) -> (Vec3, u32) {
    let n = row.len();
    let x = uc * n as f32;
    let i = (x as usize).min(n - 1);
    let rest = x - i as f32;
    let column = row[i].column;
    let b = if rest * (THRESHOLD_ONE as f32) < (column >> 16) as f32 { i } else { (column & 0xffff) as usize } as u32;
    (bins.sample(b, u), b)
}

/// Solid-angle density of [`guided_direction`] for direction `dir`.
pub fn guided_pdf(bins: &Bins, row: &[AliasBin], dir: Vec3) -> f32 {
    bin_pdf(row, bins.index(dir))
}

/// Solid-angle density of [`guided_direction`] in bin `b` of the row.
pub fn bin_pdf(row: &[AliasBin], b: u32) -> f32 {
    row[b as usize].pdf
}

/// True when a sampling row holds a distribution (its cell has learned something).
pub fn learned(row: &[AliasBin]) -> bool {
    row.first().is_some_and(|e| e.column != UNLEARNED)
}

/// The share of the guided fraction that a vertex with BSDF `b` takes, in
/// [0, 1]: 1 on diffuse surfaces, the width of the lobe relative to the cosine
/// lobe's on glossy ones. The sampling rows are Q times the cosine, the product
/// with a diffuse BSDF; a glossy BSDF's lobe is not in them, and the narrower the
/// lobe the more guided directions miss it and carry little, while each BSDF
/// direction's weight grows by up to 1 / (1 - fraction) (its mixture density is
/// (1 - fraction) times the BSDF's plus the guided density): twice the variance
/// at the default 0.5 for no gain. The width is measured by the peak density of
/// the sampled directions, 1 / pi for the cosine lobe and 1 / (4 pi alpha^2) for
/// GGX reflection (D(n) / 4 at normal incidence), so the share is min(1, 4 alpha^2):
/// 0.25 at roughness 0.5, 1 from roughness 0.71 up; below 1/16 (roughness 0.354)
/// none ([`glossy_share`]), so seed-exp2's and exp3's copper (roughness 0.3, 4
/// alpha^2 = 0.032) and seed-exp3's gold (0.08, 0.00016) take none
/// (docs/guiding.md, "Glossy lobes"). The share is a function of the vertex alone
/// and the mixture density uses it wherever it is evaluated, so the estimate
/// stays unbiased.
/// `glsl/pathtrace.comp` `lobe_share`.
pub fn lobe_share(b: &crate::math::bsdf::Bsdf) -> f32 {
    match b.kind {
        crate::scene::MaterialKind::Glossy => glossy_share(b.alpha),
        _ => 1.0,
    }
}

/// The share of the guided fraction at a glossy vertex of GGX width `alpha`:
/// 4 alpha^2, at most 1, and 0 below 1 / `GLOSSY_SHARE_MIN_INV` (1/16, roughness
/// below 0.354). Below it at most 1 direction in 32 would come from the table at
/// the default fraction, too few to find light the lobe misses, while the kernel
/// pays for such vertices with a second copy of the GGX evaluation, where the
/// mixture's density is computed: the host sets `SCENE_KIND_GUIDED_GLOSSY` only for
/// scenes with a glossy material at or above the bound ([`glossy_guided`]), and
/// without it the kernel leaves that copy out. Seed-exp2's copper (roughness 0.3)
/// and seed-exp3's gold (0.08) are below it. `glsl/pathtrace.comp` `glossy_share`
/// is the same arithmetic.
pub fn glossy_share(alpha: f32) -> f32 {
    let s = 4.0 * alpha * alpha;
    if s * (shared::GLOSSY_SHARE_MIN_INV as f32) < 1.0 {
        0.0
    } else {
        s.min(1.0)
    }
}

/// Whether a material takes guided directions as a glossy lobe ([`glossy_share`]
/// above zero), from its kernel record.
pub fn glossy_guided(m: &GpuMaterial) -> bool {
    let b = m.bsdf();
    b.kind == crate::scene::MaterialKind::Glossy && glossy_share(b.alpha) > 0.0
}

/// Fills one sampling row from non-negative bin weights (`row[b].pdf` holds the
/// weights on entry): Vose's alias-table construction, in place and in index
/// order so that `glsl/learn.comp` makes the same table. Each bin's density is
/// then read back from the table itself, so sampling and density agree exactly
/// whatever the rounding. A row whose weights sum to zero is marked [`UNLEARNED`].
pub fn build_alias_row(row: &mut [AliasBin]) {
    let n = row.len();
    let total: f32 = row.iter().map(|e| e.pdf).sum();
    if !(total > 0.0) {
        row.fill(AliasBin { column: UNLEARNED, pdf: 0.0 });
        return;
    }
    // Scaled weights (mean 1) in `pdf`; `column` UNLEARNED marks a column not yet set.
    let scale = n as f32 / total;
    for e in row.iter_mut() {
        e.pdf *= scale;
        e.column = UNLEARNED;
    }
    let open = |row: &[AliasBin], from: usize, small: bool| {
        (from..n).find(|&i| row[i].column == UNLEARNED && (row[i].pdf < 1.0) == small).unwrap_or(n)
    };
    // `s`: the small column being set; `next`: the scan for the small columns
    // of the start; `l`: the large bin that gives its excess to the small ones.
    let mut next = open(row, 0, true);
    let mut s = next;
    let mut l = open(row, 0, false);
    while s < n && l < n {
        let p = row[s].pdf;
        // Rounded up, so that a bin of any weight keeps some probability.
        let threshold = ((p * THRESHOLD_ONE as f32).ceil() as u32).min(THRESHOLD_ONE);
        row[s].column = threshold << 16 | l as u32;
        row[l].pdf = (row[l].pdf + p) - 1.0;
        if row[l].pdf < 1.0 {
            // The large bin has become small: its column is the next one to set.
            s = l;
            l = open(row, l + 1, false);
        } else {
            next = open(row, next + 1, true);
            s = next;
        }
    }
    // What is left is full (up to rounding): each such column keeps its own bin.
    for (i, e) in row.iter_mut().enumerate() {
        if e.column == UNLEARNED {
            e.column = THRESHOLD_ONE << 16 | i as u32;
        }
    }
    alias_densities(row);
}

/// Sets each bin's density to the probability the row's alias table gives it,
/// over the bin's solid angle (4 pi / n): `(threshold_b + sum over columns j
/// aliased to b of (1 - threshold_j)) / n / (4 pi / n)`.
fn alias_densities(row: &mut [AliasBin]) {
    let threshold = |c: u32| (c >> 16) as f32 / THRESHOLD_ONE as f32;
    for e in row.iter_mut() {
        e.pdf = threshold(e.column);
    }
    for i in 0..row.len() {
        let a = (row[i].column & 0xffff) as usize;
        if a != i {
            row[a].pdf += 1.0 - threshold(row[i].column);
        }
    }
    for e in row.iter_mut() {
        e.pdf *= 1.0 / (4.0 * PI);
    }
}

/// Guided sampling distributions per cell: one for each class of surface
/// orientation, so that the cosine at the vertex can weight the bins. A vertex's
/// class is the signed axis its shading normal is closest to ([`normal_class`]);
/// the class's distribution weights each bin by the cosine between that axis and
/// the bin's centre. The class is a function of the vertex alone, so the sampled
/// directions and the pdf that weights them always come from the same distribution.
pub const NORMAL_CLASSES: u32 = shared::NORMAL_CLASSES;

/// The class of a unit normal: `2 * axis + (component < 0)` for the axis of its
/// largest component (ties go to the lower axis). `glsl/guide.glsl` `normal_class`.
pub fn normal_class(n: Vec3) -> u32 {
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + (n[axis as usize] < 0.0) as u32
}

/// The unit axis of a normal class.
pub fn class_axis(class: u32) -> Vec3 {
    let mut v = [0.0f32; 3];
    v[(class / 2) as usize] = if class.is_multiple_of(2) { 1.0 } else { -1.0 };
    Vec3::from_array(v)
}

/// The cosine weight of bin `b` for a class axis: the cosine at the bin's centre,
/// zero where it is below 1e-6 (so rounding cannot split a bin whose centre lies on
/// the horizon between CPU and GPU). `glsl/learn.comp` `bin_cosine`. Bins of a
/// `ROWSxCOLS` grid with even rows and columns divisible by four lie wholly on one
/// side of every axis plane.
pub fn bin_cosine(bins: &Bins, b: u32, axis: Vec3) -> f32 {
    let c = bins.center(b).dot(axis);
    if c > 1e-6 {
        c
    } else {
        0.0
    }
}

/// The cosine weights of every bin for every normal class ([`bin_cosine`]), class
/// after class: they depend on the bins alone, so [`build_sampling_rows`] takes them
/// computed once rather than once per cell.
pub fn class_cosines(bins: &Bins) -> Vec<f32> {
    (0..NORMAL_CLASSES)
        .flat_map(|class| (0..bins.count()).map(move |b| bin_cosine(bins, b, class_axis(class))))
        .collect()
}

/// Index of the first bin of the sampling row for `cell` and normal `class` in a
/// table of `bins` bins per row. `glsl/guide.glsl` `sampler_row`.
pub fn sampler_row(cell: u32, class: u32, bins: u32) -> usize {
    ((cell * NORMAL_CLASSES + class) * bins) as usize
}

/// Builds a cell's sampling rows, one of `q.len()` bins per normal class, from its
/// Q row and the bins' [`class_cosines`]: bin b of class c in proportion to
/// `(Q_b + floor * Qbar_c) cos_c(b)` where `Qbar_c` is the cosine-weighted mean
/// of Q over the class's hemisphere, so a share `floor / (1 + floor)` of the guided
/// probability is spread like the cosine and directions not yet learned keep some.
/// A class row is [`UNLEARNED`] where it has nothing to sample (no Q above its
/// horizon). Each row is an alias table ([`build_alias_row`]). `glsl/learn.comp`
/// is the same.
pub fn build_sampling_rows(cosines: &[f32], q: &[f32], floor: f32, rows: &mut [AliasBin]) {
    let n = q.len();
    for (cos, row) in cosines.chunks(n).zip(rows.chunks_mut(n)) {
        let qc: f32 = q.iter().zip(cos).map(|(v, w)| v * w).sum();
        let c: f32 = cos.iter().sum();
        let q_floor = if c > 0.0 { floor * qc / c } else { 0.0 };
        for ((e, &v), &w) in row.iter_mut().zip(q).zip(cos) {
            e.pdf = (v + q_floor) * w;
        }
        build_alias_row(row);
    }
}

/// The learned table on the host (the CPU renderer's, and the GPU's when read back).
#[derive(Clone, Debug)]
pub struct QTable {
    /// Q per (cell, bin), cell-major.
    pub q: Vec<f32>,
    /// Targets folded into each entry so far.
    pub visits: Vec<u32>,
    /// Sampling rows, [`NORMAL_CLASSES`] per cell (see [`build_sampling_rows`]).
    pub rows: Vec<AliasBin>,
    /// The guided fraction of each sampling row: its cell's, 0 where the row is
    /// [`UNLEARNED`] (so one load tells a vertex both).
    pub fractions: Vec<f32>,
    /// Per cell, the state of its learned fraction.
    pub fraction_states: Vec<FractionState>,
    /// Per sampling row, whether a guided vertex of a recording path has read it
    /// (set for good): only those rows are rebuilt when the table learns, the
    /// others stay [`UNLEARNED`] with fraction 0 (BSDF sampling alone). Most rows
    /// are never read: a cell's six orientation classes exist for whichever
    /// surfaces it holds, and the rebuild, a sequential loop per row, would do
    /// several times the work it needs (docs/guiding.md, "Learning"). A row that a
    /// path which does not record reads first samples the BSDF alone until a
    /// recording path reads it too, which every row's paths do in turn
    /// ([`RecordSchedule`]). `glsl/pathtrace.comp` marks them, `glsl/learn.comp`
    /// reads the marks.
    pub rows_read: Vec<bool>,
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
        FrameSums::new(cfg.entries(), cfg.grid.cells() as usize)
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

/// A cell's learned guided fraction: `sigmoid(theta)`, within [`FRACTION_MIN`,
/// 1 - `FRACTION_MIN`], `theta` moved by Adam (Kingma & Ba 2015) down the
/// gradient of the Kullback-Leibler divergence between the product of BSDF,
/// cosine and incident radiance, normalised, and the mixture density
/// `q = (1 - g) p_bsdf + g p_guided` (g the fraction times the lobe's share),
/// as in Müller, "Practical Path Guiding in Production" (SIGGRAPH 2019 course
/// notes, learning the BSDF-sampling fraction). For a direction sampled from q
/// with `F / q` its contribution (the weight `f |cos| / q` times the ray's
/// Q-learning target, the one-step estimate of the radiance it brings), the
/// gradient's sample is `-(F / q) (p_guided - p_bsdf) / q * share * g (1 - g)`;
/// a cell's samples since the table last learned are averaged and take one Adam
/// step ([`QTable::learn`]). The divergence is scale-free per cell: its gradient
/// up to the cell's total radiance, which Adam's normalisation cancels.
/// `glsl/learn.comp` is the same.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct FractionState {
    /// The fraction's logit, relative to the starting fraction's.
    pub theta: f32,
    /// Adam's first and second moments of the gradient.
    pub m: f32,
    pub v: f32,
    /// Adam steps taken (bias correction), as a float for the GPU's layout.
    pub steps: f32,
}

/// Smallest learned fraction, and 1 minus the largest. `glsl/common.glsl`.
pub const FRACTION_MIN: f32 = shared::FRACTION_MIN;

/// ln(p / (1 - p)), for p in (0, 1).
fn logit(p: f32) -> f32 {
    (p / (1.0 - p)).ln()
}

impl FractionState {
    /// The fraction for starting value `start` (in (0, 1)).
    pub fn fraction(&self, start: f32) -> f32 {
        let l = logit(start) + self.theta;
        (1.0 / (1.0 + (-l).exp())).clamp(FRACTION_MIN, 1.0 - FRACTION_MIN)
    }

    /// One Adam step on the mean gradient `gradient`, `theta` kept where the
    /// fraction stays within its bounds. A gradient that is not finite (a sum
    /// that overflowed) is skipped: Adam's moments would keep it for good.
    pub fn step(&mut self, gradient: f32, start: f32) {
        use shared::{FRACTION_BETA1, FRACTION_BETA2, FRACTION_RATE};
        if !gradient.is_finite() {
            return;
        }
        self.steps += 1.0;
        self.m = FRACTION_BETA1 * self.m + (1.0 - FRACTION_BETA1) * gradient;
        self.v = FRACTION_BETA2 * self.v + (1.0 - FRACTION_BETA2) * gradient * gradient;
        let m_hat = self.m / (1.0 - FRACTION_BETA1.powf(self.steps));
        let v_hat = self.v / (1.0 - FRACTION_BETA2.powf(self.steps));
        if v_hat > 0.0 {
            self.theta -= FRACTION_RATE * m_hat / v_hat.sqrt();
        }
        let bound = ((1.0 - FRACTION_MIN) / FRACTION_MIN).ln();
        let start_logit = logit(start);
        self.theta = self.theta.clamp(-bound - start_logit, bound - start_logit);
    }
}

/// The density of the one-sample mixture at a vertex that mixes: guided sampling
/// with probability `g_frac`, the BSDF otherwise. It weights the path and the MIS
/// with light sampling alike (`crate::cpu` `trace_path`); `glsl/guide.glsl`
/// `mixture_pdf` is the same arithmetic.
pub fn mixture_pdf(g_frac: f32, p_bsdf: f32, p_guided: f32) -> f32 {
    (1.0 - g_frac) * p_bsdf + g_frac * p_guided
}

/// The gradient factor of a direction sampled at a vertex that mixes:
/// `share * g (1 - g) (p_guided - p_bsdf) / q` times the mean of its weight `f
/// |cos| / q`, for the row's fraction `g` and the lobe's share, whose product
/// `g_frac` is the mixture's guided probability. The recorder multiplies it by
/// minus the ray's Q-learning target ([`FractionState`]). `glsl/pathtrace.comp`
/// is the same arithmetic.
pub fn fraction_gradient_factor(g_frac: f32, g: f32, p_guided: f32, p_bsdf: f32, q: f32, mean_weight: f32) -> f32 {
    g_frac * (1.0 - g) * (p_guided - p_bsdf) / q * mean_weight
}

/// The default exponent of Q's learning rate ([`batch_rate`]): 1, the running
/// mean. A polynomial rate pays where few targets reach each entry, but at the
/// GPU's image sizes learned roulette, reading a Q that follows its latest
/// targets, keeps paths longer, and it did not pay at equal time
/// (docs/guiding.md, "Learning").
pub const DEFAULT_RATE_EXPONENT: f32 = 1.0;

/// The exploration floor by default ([`GuideConfig::floor`]). With MIS-weighted
/// targets ([`QTargets::Mis`]) Q no longer aims at the lamps light sampling finds,
/// and a sharper guided distribution pays: 0.1 had less error at equal time than
/// 0.25 and 0.5 on most shipped scenes (docs/guiding.md, "Defaults").
pub const DEFAULT_FLOOR: f32 = 0.1;

/// The largest exploration floor taken ([`check_floor`]): a bin's weight is then
/// all but its cell's mean, guided sampling all but the cosine's, and a larger
/// floor would only bring the weights nearer to overflow.
pub const MAX_FLOOR: f32 = 10_000.0;

/// Whether `f` is an exploration floor ([`GuideConfig::floor`]): in [0,
/// [`MAX_FLOOR`]]. 0 draws bins by Q alone; the mixture's BSDF sampling still
/// reaches every direction the BSDF reflects into. The message says what was
/// expected (shared with the command line's parser).
pub fn check_floor(f: f32) -> Result<(), String> {
    if (0.0..=MAX_FLOOR).contains(&f) {
        Ok(())
    } else {
        Err(format!("a number in [0, {MAX_FLOOR}]: each bin's share of its cell's mean Q in the guided weights"))
    }
}

/// Whether `w` is an exponent of Q's learning rate 1 / i^w that converges to the
/// learned values: (1/2, 1] (Even-Dar & Mansour 2003). Below 1/2 [`batch_rate`]
/// still runs, but the weighted mean no longer settles. The message says what was
/// expected (shared with the command line's parser).
pub fn check_rate_exponent(w: f32) -> Result<(), String> {
    if w > 0.5 && w <= 1.0 {
        Ok(())
    } else {
        Err("a number in (0.5, 1]: a rate 1/i^W converges to the learned values only for W in that range".into())
    }
}

/// The weight with which `k` targets, folded in at once, move an entry that has
/// already taken `n` towards their mean: `Q <- Q + w (S / k - Q)`.
///
/// Taken one by one, the i-th target of an entry has learning rate `1 / i^omega`,
/// and the k steps leave `prod (1 - 1 / i^omega)` (i = n+1 .. n+k) of the old
/// value; that product is taken as `exp(-sum 1 / i^omega)` with the sum as its
/// integral from n to n + k, `F(n + k) - F(n)`, `F(x) = x^(1-omega) / (1 - omega)`
/// (`ln x` at omega = 1). Batches then compose (a batch of k1 and one of k2 with
/// the same mean move Q as one of k1 + k2 does), and at omega = 1 the product is
/// exact: `w = k / (n + k)`, the running mean. An entry's first batch sets it to
/// the batch's mean (w = 1: the first step's rate is 1). Written so that a fold
/// into an entry of millions of targets keeps its precision in f32.
/// `glsl/learn.comp` `batch_rate` is the same.
pub fn batch_rate(n: f32, k: f32, omega: f32) -> f32 {
    if n <= 0.0 {
        return 1.0;
    }
    if omega >= 1.0 {
        return k / (n + k);
    }
    let a = 1.0 - omega;
    // (1 + x)^a - 1, by its series where x is small.
    let x = k / n;
    let growth = if x < 1e-3 { a * x * (1.0 + 0.5 * (a - 1.0) * x) } else { (1.0 + x).powf(a) - 1.0 };
    let s = n.powf(a) / a * growth;
    // 1 - exp(-s), likewise.
    if s < 1e-3 {
        s * (1.0 - 0.5 * s)
    } else {
        1.0 - (-s).exp()
    }
}

impl QTable {
    pub fn new(cfg: &GuideConfig) -> QTable {
        let entries = cfg.entries();
        let rows = cfg.sampling_rows();
        QTable {
            q: vec![0.0; entries],
            visits: vec![0; entries],
            rows: vec![AliasBin { column: UNLEARNED, pdf: 0.0 }; entries * NORMAL_CLASSES as usize],
            fractions: vec![0.0; rows],
            fraction_states: vec![FractionState::default(); cfg.grid.cells() as usize],
            rows_read: vec![false; rows],
        }
    }

    /// Folds the targets recorded since the last call into the table,
    /// Q <- Q + w (S / c - Q) with w = [`batch_rate`]`(n, c, omega)` (n the
    /// entry's visits, c its new targets, S their sum), takes an Adam step on each cell's fraction where it
    /// learns them and has gradients, then rebuilds the sampling rows and their
    /// fractions; after the frames that [`RecordSchedule::learns_after`] names.
    /// `glsl/learn.comp` is the same.
    pub fn learn(&mut self, cfg: &GuideConfig, targets: &FrameSums) {
        for i in 0..self.q.len() {
            let c = targets.counts[i];
            if c > 0 {
                let w = batch_rate(self.visits[i] as f32, c as f32, cfg.rate_exponent);
                self.q[i] += w * (targets.sums[i] / c as f32 - self.q[i]);
                self.visits[i] += c;
            }
        }
        if cfg.learn_fraction {
            for (cell, state) in self.fraction_states.iter_mut().enumerate() {
                let c = targets.gradient_counts[cell];
                if c > 0 {
                    state.step(targets.gradients[cell] / c as f32, cfg.fraction);
                }
            }
        }
        for (read, &now) in self.rows_read.iter_mut().zip(&targets.rows_read) {
            *read |= now;
        }
        let n = cfg.bins.count() as usize;
        let cosines = class_cosines(&cfg.bins);
        let classes = NORMAL_CLASSES as usize;
        let mut built = vec![AliasBin::default(); n * classes];
        for (cell, (q, rows)) in self.q.chunks(n).zip(self.rows.chunks_mut(n * classes)).enumerate() {
            let read = &self.rows_read[cell * classes..(cell + 1) * classes];
            if !read.iter().any(|&r| r) {
                continue;
            }
            build_sampling_rows(&cosines, q, cfg.floor, &mut built);
            let g = if cfg.learn_fraction { self.fraction_states[cell].fraction(cfg.fraction) } else { cfg.fraction };
            for (class, (row, new)) in rows.chunks_mut(n).zip(built.chunks(n)).enumerate() {
                if read[class] {
                    row.copy_from_slice(new);
                    self.fractions[cell * classes + class] = if learned(row) { g } else { 0.0 };
                }
            }
        }
    }
}

/// Russian roulette with guiding: the probability that a path goes on, from its
/// expected contribution (throughput times the radiance the table has learned for
/// the ray it is about to trace) relative to the pixel's estimate so far. Paths
/// that can still matter to the pixel survive; a path whose every continuation is
/// dim is cut early (after Vorba & Křivánek, "Adjoint-Driven Russian Roulette and
/// Splitting in Light Transport Simulation", 2016, without the splitting). Plain
/// throughput-based roulette gives up exactly where guiding pays, in dim regions
/// lit through long paths. At least `RR_MIN_PERCENT` %, so that a dark estimate
/// in a bin not yet learned costs little variance; any probability above zero
/// keeps the estimate unbiased. `glsl/pathtrace.comp` is the same.
pub fn survival_probability(expected: f32, pixel_estimate: f32) -> f32 {
    (shared::RR_WINDOW as f32 * expected / pixel_estimate).clamp(shared::RR_MIN_PERCENT as f32 / 100.0, 1.0)
}

/// The pixel estimate learned Russian roulette compares with (the mean3 of the
/// pixel's mean radiance so far), or 0, meaning plain throughput roulette, where
/// the pixel has no frames yet or the table has learned from fewer than
/// `LEARNED_RR_FRAMES` frames (`frames_traced`, which a restart of the
/// accumulation keeps): a roulette driven by the first frames' table puts, through
/// its 1/q weights, fireflies into the image that the average keeps for a long
/// time. The frames so far are the accumulation's `accum_frames` and the
/// `learned_frames` left out of the image before it (`GuideConfig::learning_frames`),
/// whose mean3 sum the pixel keeps in `sum[3]` once the image has a frame
/// (`crate::film::accumulate`); before that (`accum_frames` 0) the pixel still
/// holds them as its sum. `glsl/pathtrace.comp` is the same.
pub fn roulette_estimate(acc: &AccumPixel, accum_frames: u32, learned_frames: u32, frames_traced: u32) -> f32 {
    let frames = accum_frames + learned_frames;
    if frames == 0 || frames_traced < shared::LEARNED_RR_FRAMES {
        return 0.0;
    }
    let learned = if accum_frames > 0 { acc.sum[3] } else { 0.0 };
    (mean3(Vec3::from_slice(&acc.sum[..3])) + learned) / (shared::SAMPLES_PER_FRAME * frames) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Bins::column` without the arctangent is `floor(phi cols / 2 pi)`: for
    /// every direction away from a column's edge (by more than rounding), for
    /// column counts that take the quadrant form and for ones that do not; on the
    /// axes, phi = 0, pi / 2, pi and 3 pi / 2 start their columns, -0 as +0; the
    /// poles take a column in range (0 in the quadrant form).
    #[test]
    fn column_is_the_sector_of_the_azimuth() {
        for cols in [4u32, 8, 12, 16, 24, 32, 64, 5, 7] {
            let bins = Bins { rows: 1, cols };
            let mut rng = Rng::new(7, cols, 0, 0);
            let mut checked = 0;
            for _ in 0..100_000 {
                let phi = 2.0 * std::f64::consts::PI * rng.next_f32() as f64;
                let r = 0.05 + rng.next_f32() as f64;
                let (x, y) = ((r * phi.cos()) as f32, (r * phi.sin()) as f32);
                let exact = (y as f64).atan2(x as f64).rem_euclid(2.0 * std::f64::consts::PI);
                let sector = exact * cols as f64 / (2.0 * std::f64::consts::PI);
                if (sector - sector.round()).abs() < 1e-5 {
                    continue;
                }
                assert_eq!(bins.column(x, y), sector.floor() as u32, "cols {cols}, ({x}, {y}), sector {sector}");
                checked += 1;
            }
            assert!(checked > 99_000, "cols {cols}: {checked}");
            let axes = [((1.0, 0.0), 0), ((0.0, 1.0), cols / 4), ((-1.0, 0.0), cols / 2), ((0.0, -1.0), 3 * cols / 4)];
            if cols % 4 == 0 {
                for ((x, y), col) in axes {
                    assert_eq!(bins.column(x, y), col, "cols {cols}, ({x}, {y})");
                }
                assert_eq!(bins.column(1.0, -0.0), 0);
                assert_eq!(bins.column(-1.0, -0.0), cols / 2);
            }
            for (x, y) in [(0.0, 0.0), (-0.0, -0.0), (0.0, -0.0), (-0.0, 0.0)] {
                let col = bins.column(x, y);
                assert!(col < cols && (cols % 4 != 0 || col == 0), "cols {cols}, pole ({x}, {y}): {col}");
            }
        }
    }

    /// At omega = 1 a batch's weight is the running mean's, k / (n + k); an
    /// entry's first batch sets it; a single target's weight lies between the
    /// rates 1/(n+1)^omega and 1/n^omega that the integral brackets, also where
    /// n is in the millions (the series keep f32's precision there).
    #[test]
    fn batch_rate_is_the_running_mean_at_one_and_a_polynomial_rate_below() {
        for n in [1u32, 2, 7, 100, 4095, 1 << 20, 10_000_000] {
            for k in [1u32, 3, 64, 5000] {
                let w = batch_rate(n as f32, k as f32, 1.0);
                assert_eq!(w, k as f32 / (n + k) as f32, "n {n}, k {k}");
            }
            for omega in [0.6f32, 0.75, 0.9] {
                let (n, w) = (n as f64, batch_rate(n as f32, 1.0, omega) as f64);
                let (lo, hi) = (1.0 - (-(n + 1.0).powf(-omega as f64)).exp(), n.powf(-omega as f64));
                assert!(
                    w >= lo * (1.0 - 1e-4) && w <= hi * (1.0 + 1e-4),
                    "n {n}, omega {omega}: {w} not in [{lo}, {hi}]"
                );
            }
        }
        for omega in [0.6f32, 0.75, 1.0] {
            assert_eq!(batch_rate(0.0, 1.0, omega), 1.0);
            assert_eq!(batch_rate(0.0, 300.0, omega), 1.0);
        }
    }

    /// Folding targets in one batch or in two moves Q the same way (the rates
    /// compose), where the two batches have the same mean.
    #[test]
    fn batches_compose() {
        for omega in [0.6f32, 0.75, 1.0] {
            for (n, k1, k2) in [(1.0f32, 1.0f32, 1.0f32), (10.0, 5.0, 20.0), (1000.0, 900.0, 3.0), (2.0e6, 64.0, 64.0)]
            {
                let (q0, t) = (0.25f64, 3.0f64);
                let w1 = batch_rate(n, k1, omega) as f64;
                let w2 = batch_rate(n + k1, k2, omega) as f64;
                let two = (q0 + w1 * (t - q0)) + w2 * (t - (q0 + w1 * (t - q0)));
                let one = q0 + batch_rate(n, k1 + k2, omega) as f64 * (t - q0);
                assert!((two - one).abs() <= 1e-5 * t, "omega {omega}, n {n}, {k1} + {k2}: {two} against {one}");
            }
        }
    }

    /// What the rate is for: an entry whose first targets were too low (bootstrapped
    /// from a table that knew little) and whose later ones are right. Both rates
    /// converge to the right value; the polynomial one gets there sooner. And with
    /// noisy targets of a fixed mean it still converges to that mean.
    #[test]
    fn a_polynomial_rate_forgets_early_targets_sooner_and_converges_to_the_mean() {
        let run = |omega: f32, noisy: bool| {
            let (mut q, mut n) = (0.0f32, 0.0f32);
            let mut rng = Rng::new(3, 0, 0, 0);
            let mut at = Vec::new();
            for batch in 0..2000 {
                let k = 64.0;
                let sum: f32 = (0..64)
                    .map(|_| {
                        let mean = if noisy || batch >= 20 { 1.0 } else { 0.2 };
                        if noisy {
                            mean * 2.0 * rng.next_f32()
                        } else {
                            mean
                        }
                    })
                    .sum();
                q += batch_rate(n, k, omega) * (sum / k - q);
                n += k;
                if [99, 1999].contains(&batch) {
                    at.push(q);
                }
            }
            at
        };
        let (linear, polynomial) = (run(1.0, false), run(0.75, false));
        // After 100 batches the running mean still holds a fifth of the early error.
        assert!((linear[0] - 0.84).abs() < 1e-3, "{linear:?}");
        assert!(1.0 - polynomial[0] < 0.5 * (1.0 - linear[0]), "{polynomial:?} against {linear:?}");
        assert!(1.0 - polynomial[1] < 1e-3 && 1.0 - linear[1] < 0.01, "{polynomial:?} {linear:?}");
        for omega in [0.75, 1.0] {
            let q = run(omega, true)[1];
            assert!((q - 1.0).abs() < 0.01, "omega {omega}: noisy targets of mean 1 gave {q}");
        }
    }

    #[test]
    fn a_fresh_state_gives_the_starting_fraction() {
        for start in [0.1f32, 0.25, 0.5, 0.75, 0.9] {
            let g = FractionState::default().fraction(start);
            assert!((g - start).abs() < 1e-6, "start {start}: {g}");
        }
    }

    /// Adam's first step is the rate itself (bias-corrected m / sqrt(v) is the
    /// gradient's sign); steady gradients drive the fraction to the bound on
    /// their side and no further; the gradient is that of the divergence, so a
    /// negative one raises the fraction.
    #[test]
    fn adam_steps_move_the_fraction_against_the_gradient_within_bounds() {
        for (gradient, sign) in [(-3.0e-4f32, 1.0f32), (2.5e3, -1.0)] {
            let mut s = FractionState::default();
            s.step(gradient, 0.5);
            assert!((s.theta - sign * shared::FRACTION_RATE).abs() < 1e-6, "{s:?}");
            assert_eq!(s.steps, 1.0);
            let mut last = s.fraction(0.5);
            for _ in 0..200 {
                s.step(gradient, 0.5);
                let g = s.fraction(0.5);
                assert!(sign * (g - last) >= 0.0, "the fraction moved the wrong way: {last} -> {g}");
                last = g;
            }
            let bound = if sign > 0.0 { 1.0 - FRACTION_MIN } else { FRACTION_MIN };
            assert!((last - bound).abs() < 1e-5, "after 201 steps {last}, bound {bound}");
            // Turning back starts as soon as the momentum turns (7 steps of the
            // opposite gradient): theta was held at the bound, not past it.
            let before = s.fraction(0.5);
            for _ in 0..15 {
                s.step(-gradient, 0.5);
            }
            assert!(sign * (s.fraction(0.5) - before) < -0.01, "{before} -> {}", s.fraction(0.5));
        }
    }

    #[test]
    fn a_gradient_that_is_not_finite_leaves_the_state_as_it_was() {
        let mut s = FractionState::default();
        s.step(-1.0, 0.5);
        let before = s;
        for g in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            s.step(g, 0.5);
            assert_eq!(s, before, "gradient {g}");
        }
    }

    #[test]
    fn the_gradient_factor_favours_the_density_that_is_larger_where_light_is() {
        // A direction the guided density likes more than the BSDF: a positive
        // factor, so that a positive target gives a negative gradient sample,
        // which raises the fraction.
        assert!(fraction_gradient_factor(0.5, 0.5, 2.0, 0.3, 1.15, 0.8) > 0.0);
        assert!(fraction_gradient_factor(0.5, 0.5, 0.1, 0.3, 0.2, 0.8) < 0.0);
        // A narrow glossy lobe's share scales it; fractions at the bounds keep some.
        let full = fraction_gradient_factor(0.5, 0.5, 2.0, 0.3, 1.15, 0.8);
        let shared = fraction_gradient_factor(0.125, 0.5, 2.0, 0.3, 1.15, 0.8);
        assert!((shared / full - 0.25).abs() < 1e-6);
    }

    #[test]
    fn learned_roulette_waits_for_a_table_of_several_frames() {
        let n = shared::LEARNED_RR_FRAMES;
        let pixel = |sum: Vec3, w: f32| AccumPixel { sum: [sum.x, sum.y, sum.z, w], m2_frame_mean: [0.0; 4] };
        let sum = Vec3::new(3.0, 6.0, 9.0) * (shared::SAMPLES_PER_FRAME * n) as f32;
        for traced in 0..n {
            assert_eq!(roulette_estimate(&pixel(sum, 0.0), traced, 0, traced), 0.0, "{traced} frames");
        }
        assert_eq!(roulette_estimate(&pixel(sum, 0.0), n, 0, n), 6.0);
        assert_eq!(roulette_estimate(&pixel(sum, 0.0), 2 * n, 0, 2 * n), 3.0);
        // After a restart of the accumulation the table is still learned.
        assert_eq!(roulette_estimate(&pixel(sum / n as f32, 0.0), 1, 0, 3 * n), 6.0);
        assert_eq!(roulette_estimate(&pixel(Vec3::ZERO, 0.0), 0, 0, 3 * n), 0.0);
    }

    /// After the learning frames the estimate counts them: first as the sum the
    /// pixel still holds, then as its `sum[3]` beside the image's frames.
    #[test]
    fn learned_roulette_counts_the_learning_frames() {
        let n = shared::LEARNED_RR_FRAMES;
        let per_frame = shared::SAMPLES_PER_FRAME as f32;
        // n learning frames of mean3 6, held as the sum before the image's first frame.
        let mut acc = AccumPixel {
            sum: [3.0 * per_frame * n as f32, 6.0 * per_frame * n as f32, 9.0 * per_frame * n as f32, 0.0],
            m2_frame_mean: [5.0; 4],
        };
        assert_eq!(roulette_estimate(&acc, 0, n, n), 6.0);
        // The image's first frame, of mean3 2 (and 1, 2, 3 per channel), replaces them and keeps their share.
        crate::film::accumulate(&mut acc, 0, n, [per_frame, 2.0 * per_frame, 3.0 * per_frame]);
        assert_eq!(acc.sum, [per_frame, 2.0 * per_frame, 3.0 * per_frame, 6.0 * per_frame * n as f32]);
        assert_eq!(acc.m2_frame_mean, [0.0; 4]);
        assert_eq!(roulette_estimate(&acc, 1, n, n + 1), (2.0 + 6.0 * n as f32) / (n + 1) as f32);
        // Without learning frames the first frame keeps nothing of what the pixel held.
        crate::film::accumulate(&mut acc, 0, 0, [per_frame; 3]);
        assert_eq!(acc.sum, [per_frame, per_frame, per_frame, 0.0]);
    }
}
