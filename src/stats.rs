//! The convergence-statistics file: one JSON record per render, written by
//! `rlpt render --stats FILE.json` and read back by the convergence plot
//! ([`crate::plot::plot_convergence`]).
//!
//! The format is plain serde JSON of [`RenderStats`]; optional values that are
//! absent are written as `null`.

use std::path::Path;

use anyhow::{bail, Context};
use serde::{Deserialize, Serialize};

/// One render's convergence record, written by `rlpt render --stats FILE.json`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct RenderStats {
    /// Short label for plots, e.g. "door.toml guiding=sphere nee=on".
    pub label: String,
    /// The scene file rendered.
    pub scene: String,
    /// The device that rendered it (GPU name, or "cpu").
    pub device: String,
    pub width: u32,
    pub height: u32,
    /// "off" | "octant" | "sphere".
    pub guiding: String,
    /// The guided fraction: "learned" or the fixed number; None without
    /// guiding (and in files written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub guided_fraction: Option<String>,
    /// The exponent of Q's learning rate (`guide::batch_rate`); None without
    /// guiding (and in files written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learning_rate_exponent: Option<f32>,
    /// The exploration floor of guided sampling (`guide::GuideConfig::floor`); None
    /// without guiding (and in files written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exploration_floor: Option<f32>,
    /// What Q-learning targets counted (`guide::QTargets`): "mis" or "full"; None
    /// without guiding or NEE (and in files written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_targets: Option<String>,
    /// Whether next-event estimation was on.
    pub nee: bool,
    /// Frames that taught the table before the image started
    /// (`guide::GuideConfig::learning_frames`); None without guiding (and in files
    /// written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learning_frames: Option<u32>,
    /// One entry per frame traced, in order (per round of frames with several
    /// GPUs, `crate::session::Session::frames`).
    pub frames: Vec<FrameStats>,
}

/// The state of a render after one more frame was traced.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FrameStats {
    /// 1-based count of frames traced, learning frames included.
    pub frame: u32,
    /// Samples per pixel of the image so far (the image the render would write
    /// if it stopped here): until the learning frames end, theirs; after them,
    /// those of the frames since, not counting the learning frames' mean that
    /// the image holds as one more frame (`film::Learned::Fold`).
    pub spp: u32,
    /// GPU time of this frame (path tracing + learning), from timestamps;
    /// `None` on the CPU renderer.
    pub gpu_ms: Option<f64>,
    /// Cumulative render time so far: GPU time where available, else wall
    /// clock of the CPU renderer.
    pub elapsed_ms: f64,
    /// Relative MSE against the `--reference` image, if one was given.
    pub rel_mse: Option<f64>,
    /// The relMSE less the reference's own variance (`--reference-variance`;
    /// `metrics::rel_mse_debiased`): the error against the true image. None
    /// without it (and in files written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rel_mse_debiased: Option<f64>,
    /// Fraction of this frame's paths that carried zero radiance.
    pub zero_fraction: Option<f64>,
    /// With guiding, whether the frame was traced unguided (`guide::FrameRace`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub unguided: bool,
    /// The frame's mean relative variance as the race weighs it
    /// (`crate::film::frame_variance_term`), where it was weighed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_variance: Option<f64>,
    /// What each of the frame's (a round's) image frames weighs in the image,
    /// where a timed race weighs frames by their kind (`FrameRace::frame_weight`:
    /// the unguided kind's variance over theirs); absent where every frame weighs 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weight: Option<f64>,
}

impl RenderStats {
    /// Writes the record as pretty-printed JSON. Errors name the path.
    ///
    /// JSON has no NaN or infinity (serde_json would write `null`, which would
    /// not load back into `elapsed_ms`), so a non-finite `elapsed_ms` is refused.
    pub fn save(&self, path: &Path) -> anyhow::Result<()> {
        if let Some(f) = self.frames.iter().find(|f| !f.elapsed_ms.is_finite()) {
            bail!(
                "cannot save render statistics {}: frame {} has a non-finite elapsed_ms ({})",
                path.display(),
                f.frame,
                f.elapsed_ms
            );
        }
        let mut json = serde_json::to_string_pretty(self)
            .with_context(|| format!("cannot save render statistics {}", path.display()))?;
        json.push('\n');
        std::fs::write(path, json).with_context(|| format!("cannot save render statistics {}", path.display()))
    }

    /// Reads a record written by [`save`](Self::save). Errors name the path and,
    /// for malformed JSON or missing fields, the `line:column` of the problem
    /// (as `PATH:LINE:COLUMN: message`).
    pub fn load(path: &Path) -> anyhow::Result<RenderStats> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read render statistics {}", path.display()))?;
        serde_json::from_str(&text).map_err(|e| {
            // A `rlpt bench --json` report has passes: say what it is rather than
            // which of the statistics' fields it lacks (parsed again only then).
            if let Ok(serde_json::Value::Object(o)) = serde_json::from_str::<serde_json::Value>(&text) {
                if o.contains_key("passes") && !o.contains_key("label") {
                    return anyhow::anyhow!(
                        "{} is a `rlpt bench --json` report, not render statistics: those come from \
                         `rlpt render ... --reference REF.exr --stats STATS.json`",
                        path.display()
                    );
                }
            }
            let (line, column) = (e.line(), e.column());
            // serde_json's message ends in " at line L column C"; say it once, up front.
            let message = e.to_string();
            let message = message.strip_suffix(&format!(" at line {line} column {column}")).unwrap_or(&message);
            anyhow::anyhow!("invalid render statistics {}:{line}:{column}: {message}", path.display())
        })
    }
}
