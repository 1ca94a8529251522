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
//!   and `layout::DEFAULT_GUIDED_VERTICES_NEE`) is a one-sample mixture: with the
//!   guided fraction of the vertex's cell (learned per cell by default,
//!   [`FractionState`], or fixed), times the lobe's share ([`lobe_share`]), a bin is drawn from the cell's sampling row for the vertex's
//!   orientation class (the signed axis nearest its shading normal,
//!   [`normal_class`]), in proportion to `(Q + floor * Qbar) cos(axis, bin)`
//!   (an alias table, rebuilt as [`RecordSchedule::learns_after`] says: one or two loads per
//!   sample, one per density), and a direction uniformly inside it; otherwise the BSDF is
//!   sampled. The mixture pdf weights the path and the MIS with light sampling, so
//!   the image stays unbiased, and no direction where the BSDF is non-zero gets pdf
//!   zero (`crate::cpu` `mixture_sample` says why the MIS weights use the mixture's
//!   density, not the BSDF's). Cells that have learned nothing use BSDF sampling alone. The cosine is
//!   that of the class axis, exact on axis-aligned walls; the BSDF's own lobe is
//!   left to the BSDF half of the mixture.
//! - **Russian roulette** with guiding keeps a path in proportion to its expected
//!   contribution, from the learned Q, relative to the pixel's estimate
//!   ([`survival_probability`]).
//!
//! One file a concept, each naming its GPU twin: `grid` (states), `bins`
//! (actions and orientation classes), `sampler` (alias rows, the mixture, the lobe's
//! share; `glsl/guide.glsl`), `product` (Q times a glossy lobe;
//! `glsl/product.glsl`), `table` (learning; `glsl/learn.comp`), `record` (the
//! recording schedule and frame sums; `glsl/record.glsl`), `fraction` (the learned
//! guided fraction) and `roulette`; this file holds the modes, the configuration
//! and the defaults. The method's reasons and measured effects are in
//! docs/guiding.md.

use crate::layout::{AccumPixel, GpuMaterial, RenderParams, SceneArrays};
use crate::math::geometry::intersect;
use crate::math::rng::Rng;
use crate::math::{mean3, Frame, Vec3};
use crate::scene::GuidingSettings;
use crate::shared;
use std::f32::consts::PI;

mod bins;
mod field;
mod fraction;
mod grid;
mod product;
mod race;
mod record;
mod roulette;
mod sampler;
mod table;
mod tree;

pub use bins::*;
pub use field::*;
pub use fraction::*;
pub use grid::*;
pub use product::*;
pub use race::*;
pub use record::*;
pub use roulette::*;
pub use sampler::*;
pub use table::*;
pub use tree::*;

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
    /// Frames at the start of the render that teach the table, whose mean is
    /// then one frame of the image (`crate::film::Learned`;
    /// [`default_learning_frames`]), and where the race may
    /// trace unguided frames, the unguided frame after them
    /// ([`frames_before_image`]); their radiance stays the pixels' estimate for
    /// learned roulette.
    pub learning_frames: u32,
    /// Whether image frames may be traced unguided where a [`FrameRace`] finds
    /// them more efficient.
    pub unguided_frames: bool,
    /// Frames per learning pass at least (a power of two), past the first frames;
    /// None: from the image's size ([`RecordSchedule::min_learning_period`]).
    pub learning_period: Option<u32>,
    /// Adaptive directions: each bin's sampling weight from the Q of the
    /// smallest block of bins around it that has taken enough targets ([`pooled_q`]).
    pub adaptive_directions: bool,
}

impl GuideConfig {
    /// Cells of the table: the grid's, or where it is adaptive, all it may split into.
    pub fn cells(&self) -> u32 {
        self.grid.capacity
    }

    pub fn entries(&self) -> usize {
        (self.cells() * self.bins.count()) as usize
    }

    /// Sampling rows of the table: [`NORMAL_CLASSES`] per cell.
    pub fn sampling_rows(&self) -> usize {
        self.cells() as usize * NORMAL_CLASSES as usize
    }

    /// Bytes of the table's sampling rows ([`sampling_rows_bytes`]).
    pub fn sampling_rows_bytes(&self) -> u64 {
        sampling_rows_bytes(self.cells(), self.bins)
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

/// Whether a learning period of `n` frames can be asked for: a power of two up to
/// [`MAX_LEARNING_PERIOD`], so that each pass ends a recording cycle. The message
/// says what was expected (shared with the command line's parser).
pub fn check_learning_period(n: u32) -> Result<(), String> {
    if n.is_power_of_two() && n <= MAX_LEARNING_PERIOD {
        Ok(())
    } else {
        Err(format!("a power of two from 1 to {MAX_LEARNING_PERIOD}: the fewest frames between learning passes"))
    }
}

/// Cells along the longest axis of the guide grid's box where the scene's
/// `[guiding]` table gives no `resolution`: 24 in a scene with Russian roulette
/// whose frames trace at least [`LEARN_PIXEL_FRAMES`] pixels, else 16.
///
/// With roulette every vertex records, and over a large image the finer grid
/// learns in time: at equal time it lowered door's, bunny-door's and smallpt's
/// error at their own sizes. Small images learn it too slowly (bunny-door at
/// 64x40 in its first 0.1 s), and the seed's scenes, which guide two vertices,
/// gained nothing (docs/guiding.md, "Cells").
pub fn default_grid_cells(roulette: bool, pixels: u64) -> u32 {
    if roulette && pixels >= LEARN_PIXEL_FRAMES {
        24
    } else {
        16
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

/// Whether glossy vertices draw guided directions from the product of Q and the
/// lobe by default (`--glossy-product`; docs/guiding.md, "Glossy lobes").
pub const DEFAULT_GLOSSY_PRODUCT: bool = false;

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
