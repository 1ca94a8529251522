//! What a render is asked to be: the size, samples, bounces, seed and flags, and
//! guiding's settings ([`RenderOptions`]), checked before anything is prepared
//! ([`RenderOptions::check`], [`OptionError`]).

use crate::guide::{self, Bins, GuidingMode};
use crate::layout::{MAX_BOUNCES, MAX_IMAGE_SIDE, MAX_SPP};
use crate::math::sampler::SamplerKind;
use crate::scene::{GridKind, Scene};
use crate::shared;

/// A render option outside the values the renderers can honour: which option,
/// its value and what was expected. [`RenderOptions::check`] finds it, and
/// [`crate::prepared::PreparedScene::new`] refuses to prepare a render with one.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("render option `{option}` is {value}: {expected}")]
pub struct OptionError {
    pub option: &'static str,
    pub value: String,
    pub expected: String,
}

/// `guided_fraction`: a probability in [0, 1), since some BSDF sampling must remain
/// so that no direction where the BSDF is non-zero has density zero. The message
/// is what was expected (shared with the command line's parser).
pub fn check_guided_fraction(f: f32) -> Result<(), String> {
    if (0.0..1.0).contains(&f) {
        Ok(())
    } else {
        Err("a number in [0, 1): some BSDF sampling must remain so that no direction has pdf zero".into())
    }
}

/// How to render: the scene's `[render]` table with command-line overrides.
/// Every field is public; [`RenderOptions::check`] says whether the values are
/// ones the renderers can honour.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel asked for; renders take `frames()` frames of 64.
    pub spp: u32,
    pub max_bounces: u32,
    pub russian_roulette_depth: Option<u32>,
    pub seed: u32,
    /// Next-event estimation (light sampling combined with BSDF sampling by MIS).
    pub nee: bool,
    /// Power heuristic (true) or balance heuristic for MIS.
    pub power_heuristic: bool,
    /// Learned guiding: off, octant (2x4 bins) or sphere (`bins`).
    pub guiding: GuidingMode,
    /// Bins of `GuidingMode::Sphere`. None: the default for the scene,
    /// [`crate::guide::default_bins`] (20x40 with Russian roulette, 8x16 without),
    /// which [`crate::prepared::PreparedScene::new`] resolves; the prepared scene's
    /// `guide.bins` holds the bins used.
    pub bins: Option<Bins>,
    /// Probability of guided sampling at a non-delta vertex: fixed, or each
    /// cell's starting value where `learn_fraction`.
    pub guided_fraction: f32,
    /// Whether each cell learns its own guided fraction (`guide::FractionState`).
    pub learn_fraction: bool,
    /// Exploration floor of the guided distribution (see `GuideConfig::floor`).
    pub guide_floor: f32,
    /// Exponent of Q's learning rate (see `guide::batch_rate`), in (1/2, 1].
    pub learning_rate_exponent: f32,
    /// Frames that teach the table before the image starts (see
    /// `GuideConfig::learning_frames`). None: [`guide::default_learning_frames`].
    pub learning_frames: Option<u32>,
    /// Frames per learning pass at least (see `GuideConfig::learning_period`).
    /// None: from the image's size (`guide::RecordSchedule::min_learning_period`).
    pub learning_period: Option<u32>,
    /// Whether a guided render's image frames may be traced unguided, frame by
    /// frame, where that gives the image more for its time ([`guide::FrameRace`]).
    pub unguided_frames: guide::UnguidedFrames,
    /// Uniform or adaptive guiding cells, over the scene's `[guiding] grid`
    /// (None: the scene's, else uniform; [`GridKind`]).
    pub guide_grid: Option<GridKind>,
    /// Adaptive directions: a bin's sampling weight from the smallest block of
    /// bins around it that has taken enough targets (`guide::pooled_q`).
    pub adaptive_directions: bool,
    /// What Q-learning targets count of the light their rays meet where NEE is on
    /// ([`guide::QTargets`]; `FLAG_MIS_TARGETS`).
    pub q_targets: guide::QTargets,
    /// Guided sampling at the first this many vertices (at least 1) of each path
    /// (depth 0 is the camera ray's hit); deeper vertices sample the BSDF alone.
    /// None: every vertex with Russian roulette (`russian_roulette_depth`);
    /// without it [`crate::layout::DEFAULT_GUIDED_VERTICES_NEE`] with NEE, every vertex without
    /// ([`crate::guide::guided_vertices`]).
    pub guided_vertices: Option<u32>,
    /// What the GPU kernel counts per frame (`FrameTimings`). The CPU renderer
    /// counts paths and rays always.
    pub counters: Counters,
    /// The paths' random numbers (`FLAG_SOBOL`): independent or Owen-scrambled Sobol.
    pub sampler: SamplerKind,
    /// Guided directions at glossy vertices from the product of Q and the lobe
    /// (`FLAG_GLOSSY_PRODUCT`, `guide::product_sums`); else the share of the row's.
    pub glossy_product: bool,
}

/// What the GPU kernel counts per frame; what it does not count it is compiled
/// without, at no cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Counters {
    /// Nothing.
    #[value(help = "nothing (the kernel render and view run)")]
    Off,
    /// The paths that carried no radiance (`FLAG_COUNTERS`): one sum per subgroup
    /// after its paths end. `render --stats` counts these.
    #[value(name = "paths", help = "the paths that carried no radiance (the kernel render --stats runs)")]
    ZeroPaths,
    /// Also the rays traced and the lane utilization (`FLAG_COUNT_RAYS`), counted
    /// inside the path loop, which costs a frame measurably. `rlpt bench` counts
    /// these unless `--counters off` or `paths`.
    #[value(name = "on", help = "also the rays traced and the lane utilization")]
    All,
}

impl RenderOptions {
    /// The scene's own settings, seed 0, NEE on with the power heuristic.
    pub fn from_scene(scene: &Scene) -> RenderOptions {
        let r = &scene.render;
        RenderOptions {
            width: r.width,
            height: r.height,
            spp: r.spp,
            max_bounces: r.max_bounces,
            russian_roulette_depth: r.russian_roulette_depth,
            seed: 0,
            nee: true,
            power_heuristic: true,
            guiding: GuidingMode::Off,
            bins: None,
            guided_fraction: 0.5,
            learn_fraction: true,
            guide_floor: guide::DEFAULT_FLOOR,
            learning_rate_exponent: guide::DEFAULT_RATE_EXPONENT,
            learning_frames: None,
            learning_period: None,
            unguided_frames: guide::UnguidedFrames::Never,
            guide_grid: None,
            adaptive_directions: false,
            q_targets: guide::QTargets::Mis,
            guided_vertices: None,
            counters: Counters::Off,
            sampler: SamplerKind::Independent,
            glossy_product: guide::DEFAULT_GLOSSY_PRODUCT,
        }
    }

    /// The exponent of Q's learning rate, as reports give it: None without guiding.
    pub fn learning_rate_exponent_if_guided(&self) -> Option<f32> {
        (self.guiding != GuidingMode::Off).then_some(self.learning_rate_exponent)
    }

    /// The exploration floor of guided sampling (`guide::GuideConfig::floor`), as
    /// reports record it: None without guiding.
    pub fn exploration_floor_if_guided(&self) -> Option<f32> {
        (self.guiding != GuidingMode::Off).then_some(self.guide_floor)
    }

    /// What Q-learning targets count, as reports name it (`mis` or `full`): None
    /// without guiding, and without NEE, where the two are the same.
    pub fn q_targets_if_guided(&self) -> Option<&'static str> {
        (self.guiding != GuidingMode::Off && self.nee).then_some(self.q_targets.name())
    }

    /// Whether glossy vertices draw from the product with their lobe, as reports
    /// record it: None without guiding.
    pub fn glossy_product_if_guided(&self) -> Option<bool> {
        (self.guiding != GuidingMode::Off).then_some(self.glossy_product)
    }

    /// The guided fraction as reports name it: `learned`, the fixed number, or
    /// None without guiding.
    pub fn guided_fraction_name(&self) -> Option<String> {
        match (self.guiding, self.learn_fraction) {
            (GuidingMode::Off, _) => None,
            (_, true) => Some("learned".into()),
            (_, false) => Some(self.guided_fraction.to_string()),
        }
    }

    /// The first option whose value the renderers cannot honour, if any: an
    /// image side outside 1..=[`MAX_IMAGE_SIDE`], samples outside 1..=[`MAX_SPP`], more than
    /// [`MAX_BOUNCES`] bounces, bins outside [`Bins::check`]'s limits, a guided
    /// fraction outside [0, 1), an exploration floor that is negative or not
    /// finite, a learning-rate exponent outside (1/2, 1], or guided sampling at
    /// zero vertices. The command line refuses these as it parses them; this is
    /// the library's own check, which [`crate::prepared::PreparedScene::new`] makes.
    pub fn check(&self) -> Result<(), OptionError> {
        let err = |option: &'static str, value: String, expected: String| Err(OptionError { option, value, expected });
        for (option, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_IMAGE_SIDE).contains(&v) {
                return err(option, v.to_string(), format!("image sides are 1 to {MAX_IMAGE_SIDE} pixels"));
            }
        }
        if !(1..=MAX_SPP).contains(&self.spp) {
            return err("spp", self.spp.to_string(), format!("1 to {MAX_SPP} samples per pixel"));
        }
        if self.max_bounces > MAX_BOUNCES {
            return err("max_bounces", self.max_bounces.to_string(), format!("at most {MAX_BOUNCES} bounces"));
        }
        if let Some(bins) = self.bins {
            if let Err(e) = Bins::check(bins.rows, bins.cols) {
                return err("bins", format!("{}x{}", bins.rows, bins.cols), e);
            }
        }
        if let Err(e) = check_guided_fraction(self.guided_fraction) {
            return err("guided_fraction", self.guided_fraction.to_string(), e);
        }
        if let Err(e) = guide::check_floor(self.guide_floor) {
            return err("guide_floor", self.guide_floor.to_string(), e);
        }
        if let Err(e) = guide::check_rate_exponent(self.learning_rate_exponent) {
            return err("learning_rate_exponent", self.learning_rate_exponent.to_string(), e);
        }
        if let Some(n) = self.learning_frames {
            if let Err(e) = guide::check_learning_frames(n) {
                return err("learning_frames", n.to_string(), e);
            }
        }
        if let Some(n) = self.learning_period {
            if let Err(e) = guide::check_learning_period(n) {
                return err("learning_period", n.to_string(), e);
            }
        }
        if self.guided_vertices == Some(0) {
            return err(
                "guided_vertices",
                "0".into(),
                "at least 1 (the camera ray's hit), or None for the default".into(),
            );
        }
        Ok(())
    }

    /// Frames of 64 samples per pixel needed for at least `spp` samples.
    pub fn frames(&self) -> u32 {
        self.spp.div_ceil(shared::SAMPLES_PER_FRAME).max(1)
    }
}
