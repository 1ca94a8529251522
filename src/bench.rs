//! `rlpt bench`: where the time of a frame goes. Each frame is one submission
//! with a timestamp query after every pass (`GpuRenderer::render_frame_profiled`);
//! this module turns those per-frame times into a table, a JSON report and a
//! Chrome trace-event file (opened by Perfetto and chrome://tracing).

use crate::cpu::CpuRenderer;
use crate::gpu::GpuError;
use crate::render::{GpuRenderer, PassTimes};
use crate::renderer::{forward_renderer_queries, FrameReport, Renderer};
use serde::Serialize;
use std::time::Instant;

/// The renderer whose frames `rlpt bench` times.
pub enum ProfiledDevice {
    Gpu(Box<GpuRenderer>),
    Cpu(Box<CpuRenderer>),
}

/// A renderer as `rlpt bench` runs it in a `crate::session::Session`: each frame
/// in a submission of its own with its passes timed
/// (`GpuRenderer::render_frame_profiled`; on the CPU, the frame's wall clock as
/// path tracing's), every frame's times kept in `times` for the report.
pub struct Profiled {
    pub device: ProfiledDevice,
    pub times: Vec<PassTimes>,
}

impl Profiled {
    pub fn new(device: ProfiledDevice) -> Self {
        Profiled { device, times: Vec::new() }
    }

    fn renderer(&self) -> &dyn Renderer {
        match &self.device {
            ProfiledDevice::Gpu(r) => &**r,
            ProfiledDevice::Cpu(r) => &**r,
        }
    }
}

impl Renderer for Profiled {
    fn render_frame(&mut self) -> Result<FrameReport, GpuError> {
        let t = match &mut self.device {
            ProfiledDevice::Gpu(r) => r.render_frame_profiled()?,
            ProfiledDevice::Cpu(r) => {
                let start = Instant::now();
                r.render_frame();
                let ms = start.elapsed().as_secs_f64() * 1e3;
                let c = r.last_counters;
                PassTimes {
                    start_ms: 0.0,
                    pathtrace_ms: ms,
                    zero_paths: Some(c.zero_paths),
                    segments: Some(c.segments),
                    ..Default::default()
                }
            }
        };
        self.times.push(t);
        let timestamps = matches!(self.device, ProfiledDevice::Gpu(_));
        Ok(FrameReport {
            gpu_ms: timestamps.then_some(t.pathtrace_ms + t.learn_fold_ms + t.learn_rows_ms),
            learn_ms: timestamps.then_some(t.learn_fold_ms + t.learn_rows_ms),
            zero_paths: t.zero_paths,
            kind: None,
            variance: None,
            weight: None,
        })
    }
    forward_renderer_queries!(self => self.renderer());
}

/// Median, minimum, maximum and mean of one pass over the measured frames (ms).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub pass: String,
    pub median_ms: f64,
    pub min_ms: f64,
    pub max_ms: f64,
    pub mean_ms: f64,
}

impl Summary {
    /// Summarises `times` (ms); the median of an even count is the mean of the middle two.
    /// `None` for an empty slice or one with a NaN.
    pub fn of(pass: &str, times: &[f64]) -> Option<Summary> {
        if times.is_empty() || times.iter().any(|t| t.is_nan()) {
            return None;
        }
        let mut sorted = times.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let median = if n % 2 == 1 { sorted[n / 2] } else { 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]) };
        Some(Summary {
            pass: pass.to_string(),
            median_ms: median,
            min_ms: sorted[0],
            max_ms: sorted[n - 1],
            mean_ms: sorted.iter().sum::<f64>() / n as f64,
        })
    }
}

/// One measured frame as it appears in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    pub frame: u32,
    pub pathtrace_ms: f64,
    pub learn_fold_ms: f64,
    pub learn_rows_ms: f64,
    pub total_ms: f64,
    /// Rays traced and paths that carried nothing; null with `--counters off`
    /// (the rays also with `--counters paths`).
    pub segments: Option<u64>,
    pub zero_paths: Option<u64>,
    /// The rays the subgroups ran the path loop for (`FrameTimings::subgroup_segments`);
    /// null likewise, and on the CPU renderer.
    pub subgroup_segments: Option<u64>,
}

/// What `rlpt bench` measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// What was measured (its fields sit at the top level of the JSON).
    #[serde(flatten)]
    pub setup: BenchSetup,
    pub frames: Vec<FrameRecord>,
    /// One row per pass, then "frame" (all passes).
    pub passes: Vec<Summary>,
    /// Samples traced over the total measured time (the mean frame, not the median:
    /// with guiding the sampling rows are rebuilt after one frame in 8 to 32, which a
    /// median frame would leave out).
    pub msamples_per_s: f64,
    /// Rays traced (camera, bounce, shadow) over the total measured time; this
    /// and the next one are null where the frames counted no rays (`--counters
    /// off` or `paths`), the one after where they counted nothing (`off`).
    pub msegments_per_s: Option<f64>,
    /// Rays per path, averaged over the measured frames.
    pub segments_per_path: Option<f64>,
    /// Fraction of paths that carried no radiance, over the measured frames.
    pub zero_fraction: Option<f64>,
    /// Rays traced over the rays the subgroups ran the path loop for (each
    /// subgroup as long as its longest path): the share of lanes busy, 1 where
    /// every path of a subgroup is as long. Null on the CPU renderer.
    pub lane_utilization: Option<f64>,
    /// What the driver reports about each pipeline (registers, shared memory...).
    pub pipelines: Vec<PipelineReport>,
}

/// What a bench run measured: the scene, the device and the settings.
#[derive(Clone, Debug, Serialize)]
pub struct BenchSetup {
    pub scene: String,
    pub device: String,
    pub driver: String,
    /// "GPU timestamps" or "wall clock" (the CPU renderer).
    pub clock: String,
    pub width: u32,
    pub height: u32,
    pub samples_per_frame: u64,
    pub guiding: String,
    /// The guided fraction: "learned" or the fixed number; None without guiding.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub guided_fraction: Option<String>,
    /// The exponent of Q's learning rate (`guide::batch_rate`); None without guiding.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub learning_rate_exponent: Option<f32>,
    /// The exploration floor of guided sampling (`guide::GuideConfig::floor`); None without guiding.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exploration_floor: Option<f32>,
    /// What Q-learning targets counted (`guide::QTargets`); None without guiding or NEE.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub q_targets: Option<String>,
    pub nee: bool,
    /// The paths' random numbers (`math::sampler::SamplerKind::name`).
    pub sampler: String,
    /// Whether glossy vertices drew from the product with their lobe (`--glossy-product`); None without guiding.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glossy_product: Option<bool>,
    pub warmup_frames: u32,
}

/// Driver statistics of one pipeline.
#[derive(Clone, Debug, Serialize)]
pub struct PipelineReport {
    pub pipeline: String,
    pub statistics: Vec<crate::gpu::PipelineStatistic>,
}

impl BenchReport {
    /// Builds the report from the measured frames (warm-up frames already left out).
    pub fn new(setup: BenchSetup, times: &[PassTimes], pipelines: Vec<PipelineReport>) -> BenchReport {
        let frames: Vec<FrameRecord> = times
            .iter()
            .enumerate()
            .map(|(i, t)| FrameRecord {
                frame: setup.warmup_frames + i as u32 + 1,
                pathtrace_ms: t.pathtrace_ms,
                learn_fold_ms: t.learn_fold_ms,
                learn_rows_ms: t.learn_rows_ms,
                total_ms: t.pathtrace_ms + t.learn_fold_ms + t.learn_rows_ms,
                segments: t.segments,
                zero_paths: t.zero_paths,
                subgroup_segments: t.subgroup_segments,
            })
            .collect();
        let column = |f: fn(&FrameRecord) -> f64| frames.iter().map(f).collect::<Vec<f64>>();
        let mut passes = vec![Summary::of("pathtrace", &column(|f| f.pathtrace_ms))];
        if setup.guiding != "off" {
            passes.push(Summary::of("learn: fold targets", &column(|f| f.learn_fold_ms)));
            passes.push(Summary::of("learn: build sampling rows", &column(|f| f.learn_rows_ms)));
        }
        passes.push(Summary::of("frame", &column(|f| f.total_ms)));
        let passes: Vec<Summary> = passes.into_iter().flatten().collect();
        let total_ms: f64 = frames.iter().map(|f| f.total_ms).sum();
        // Summed where every frame counted.
        let segments: Option<u64> = frames.iter().map(|f| f.segments).sum();
        let zero: Option<u64> = frames.iter().map(|f| f.zero_paths).sum();
        let subgroup_segments: Option<u64> = frames.iter().map(|f| f.subgroup_segments).sum();
        let paths = setup.samples_per_frame as f64 * frames.len() as f64;
        BenchReport {
            setup,
            msamples_per_s: paths / total_ms * 1e-3,
            msegments_per_s: segments.map(|s| s as f64 / total_ms * 1e-3),
            segments_per_path: segments.map(|s| s as f64 / paths),
            zero_fraction: zero.map(|z| z as f64 / paths),
            lane_utilization: segments.zip(subgroup_segments).map(|(s, g)| s as f64 / g as f64),
            frames,
            passes,
            pipelines,
        }
    }

    /// The table `rlpt bench` prints.
    pub fn table(&self) -> String {
        let s = &self.setup;
        let mut out = format!(
            "{} on {} ({}), {}x{}, guiding {}{}{}, NEE {}, {} sampler: {} frames of 64 spp after {} warm-up ({})\n",
            s.scene,
            s.device,
            s.driver,
            s.width,
            s.height,
            s.guiding,
            match (&s.guided_fraction, s.learning_rate_exponent, s.exploration_floor) {
                (Some(f), Some(w), Some(e)) => format!(" (fraction {f}, rate exponent {w}, floor {e})"),
                (Some(f), Some(w), None) => format!(" (fraction {f}, rate exponent {w})"),
                (Some(f), None, _) => format!(" (fraction {f})"),
                _ => String::new(),
            },
            s.q_targets.as_ref().map_or(String::new(), |t| format!(", {t} targets")),
            if s.nee { "on" } else { "off" },
            s.sampler,
            self.frames.len(),
            s.warmup_frames,
            s.clock
        );
        out += &format!("{:<22} {:>10} {:>10} {:>10} {:>10}\n", "pass", "median ms", "min ms", "max ms", "mean ms");
        for s in &self.passes {
            out += &format!(
                "{:<22} {:>10.4} {:>10.4} {:>10.4} {:>10.4}\n",
                s.pass, s.median_ms, s.min_ms, s.max_ms, s.mean_ms
            );
        }
        out += &match (self.msegments_per_s, self.segments_per_path, self.zero_fraction) {
            (Some(per_s), Some(per_path), Some(zero)) => format!(
                "{:.1} Msamples/s (mean frame), {per_s:.1} Msegments/s, {per_path:.2} segments per path, {zero:.4} of \
                 paths carried no radiance{}\n",
                self.msamples_per_s,
                self.lane_utilization.map_or(String::new(), |u| format!(
                    ", {u:.3} lane utilization (rays over those of each subgroup's longest path in every lane)"
                ))
            ),
            (None, None, Some(zero)) => format!(
                "{:.1} Msamples/s (mean frame), {zero:.4} of paths carried no radiance; segments not counted \
                 (--counters paths)\n",
                self.msamples_per_s
            ),
            _ => format!(
                "{:.1} Msamples/s (mean frame); segments and paths without radiance not counted (--counters off)\n",
                self.msamples_per_s
            ),
        };
        for p in &self.pipelines {
            let interesting: Vec<String> = p
                .statistics
                .iter()
                .filter(|s| !s.value.is_empty())
                .map(|s| format!("{} {}", s.name, s.value))
                .collect();
            out += &format!("pipeline {}: {}\n", p.pipeline, interesting.join(", "));
        }
        out
    }
}

/// The frames as Chrome trace events ("X" complete events, microseconds), one
/// row per pass on a common timeline of the device clock (gaps between frames are
/// host time: submission and readback).
pub fn chrome_trace(device: &str, times: &[PassTimes], first_frame: u32) -> serde_json::Value {
    let origin = times.first().map(|t| t.start_ms).unwrap_or(0.0);
    let mut events = vec![
        serde_json::json!({"name": "process_name", "ph": "M", "pid": 1, "args": {"name": format!("GPU: {device}")}}),
        serde_json::json!({"name": "thread_name", "ph": "M", "pid": 1, "tid": 1, "args": {"name": "compute queue"}}),
    ];
    for (i, t) in times.iter().enumerate() {
        let frame = first_frame + i as u32;
        let mut at = (t.start_ms - origin) * 1e3;
        for (name, ms) in [
            ("pathtrace", t.pathtrace_ms),
            ("learn: fold targets", t.learn_fold_ms),
            ("learn: build sampling rows", t.learn_rows_ms),
        ] {
            if ms <= 0.0 {
                continue;
            }
            events.push(serde_json::json!({
                "name": name, "cat": "gpu", "ph": "X", "pid": 1, "tid": 1,
                "ts": at, "dur": ms * 1e3,
                "args": {"frame": frame, "segments": t.segments, "zero_paths": t.zero_paths},
            }));
            at += ms * 1e3;
        }
    }
    serde_json::json!({"traceEvents": events, "displayTimeUnit": "ms"})
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_of_odd_and_even_counts() {
        let s = Summary::of("p", &[3.0, 1.0, 2.0]).unwrap();
        assert_eq!((s.median_ms, s.min_ms, s.max_ms, s.mean_ms), (2.0, 1.0, 3.0, 2.0));
        let s = Summary::of("p", &[4.0, 1.0, 2.0, 10.0]).unwrap();
        assert_eq!((s.median_ms, s.min_ms, s.max_ms, s.mean_ms), (3.0, 1.0, 10.0, 4.25));
        assert!(Summary::of("p", &[]).is_none());
        assert!(Summary::of("p", &[1.0, f64::NAN]).is_none());
    }

    #[test]
    fn trace_events_follow_each_other() {
        let t = |start: f64| PassTimes {
            start_ms: start,
            pathtrace_ms: 2.0,
            learn_fold_ms: 0.5,
            learn_rows_ms: 0.25,
            zero_paths: Some(1),
            segments: Some(10),
            subgroup_segments: Some(16),
        };
        let v = chrome_trace("dev", &[t(100.0), t(103.0)], 5);
        let ev = v["traceEvents"].as_array().unwrap();
        let x: Vec<_> = ev.iter().filter(|e| e["ph"] == "X").collect();
        assert_eq!(x.len(), 6);
        assert_eq!(x[0]["ts"], 0.0);
        assert_eq!(x[0]["dur"], 2000.0);
        assert_eq!(x[1]["ts"], 2000.0);
        assert_eq!(x[2]["ts"], 2500.0);
        assert_eq!(x[3]["ts"], 3000.0);
        assert_eq!(x[3]["args"]["frame"], 6);
    }
}

/// One device's share of a `rlpt bench --gpus` run.
#[derive(Clone, Debug, Serialize)]
pub struct DeviceBench {
    /// Its index in `rlpt devices`.
    pub index: usize,
    pub name: String,
    /// Measured frames it traced.
    pub frames: u32,
    /// Their GPU time, ms (the device's own timestamps).
    pub gpu_ms: f64,
    /// `frames` over `gpu_ms`: the device's own rate while it was busy.
    pub frames_per_second: f64,
    /// Whether it was lost during the run (its frames were traced again by the others).
    pub lost: bool,
}

/// What `rlpt bench --gpus` measured: the devices' frames and times, and the
/// whole. The measured frames run in rounds (`render::MultiGpuRenderer`); the
/// time of a round is its busiest device's GPU time plus the slowest learning
/// pass, as the devices run in parallel, and `gpu_ms` adds the rounds' times:
/// the wall-clock time the render would take if the host's work between rounds
/// (submission, the frame sums' transfers) took none. `wall_s` is the wall clock itself.
#[derive(Clone, Debug, Serialize)]
pub struct MultiBenchReport {
    #[serde(flatten)]
    pub setup: BenchSetup,
    pub gpus: usize,
    pub devices: Vec<DeviceBench>,
    /// Measured frames, all devices together.
    pub frames: u32,
    /// The rounds' times added, ms (see above).
    pub gpu_ms: f64,
    /// `frames` over `gpu_ms`.
    pub frames_per_second: f64,
    /// Samples traced over `gpu_ms`.
    pub msamples_per_s: f64,
    /// Wall-clock time of the measured rounds, s, and the frames over it.
    pub wall_s: f64,
    pub wall_frames_per_second: f64,
}

impl MultiBenchReport {
    /// The report's table, as `rlpt bench --gpus` prints it.
    pub fn table(&self) -> String {
        let s = &self.setup;
        let mut t = format!(
            "{} on {} GPUs, {}x{}, guiding {}, NEE {}, {} measured frames after {} warm-up frames:\n",
            s.scene,
            self.gpus,
            s.width,
            s.height,
            s.guiding,
            if s.nee { "on" } else { "off" },
            self.frames,
            s.warmup_frames
        );
        for d in &self.devices {
            t += &format!(
                "  GPU {} {:<32} {:>6} frames {:>10.1} ms GPU time {:>9.2} frames/s{}\n",
                d.index,
                format!("\"{}\"", d.name),
                d.frames,
                d.gpu_ms,
                d.frames_per_second,
                if d.lost { " (lost)" } else { "" }
            );
        }
        t += &format!(
            "  all GPUs{:>32} {:>6} frames {:>10.1} ms in rounds  {:>9.2} frames/s ({:.1} Msamples/s); wall clock \
             {:.3} s, {:.2} frames/s\n",
            "",
            self.frames,
            self.gpu_ms,
            self.frames_per_second,
            self.msamples_per_s,
            self.wall_s,
            self.wall_frames_per_second
        );
        t
    }
}
