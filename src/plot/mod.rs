//! The convergence plot: relMSE against render time, both axes logarithmic,
//! one curve per [`RenderStats`] record.
//!
//! Everything is drawn on an [`image::RgbImage`] (`canvas.rs`): anti-aliased
//! lines from their distance to each pixel centre, and text from the
//! pre-rasterised Noto Sans Mono glyphs that the `noto-sans-mono-bitmap` crate
//! compiles into the binary, so a plot needs no system font and no plotting
//! library. The logarithmic axes and their tick labels are in `axis.rs`; the
//! layout of the plot, its curves and legend here.

use std::path::Path;

use anyhow::{bail, Context};
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder, RgbImage};
use noto_sans_mono_bitmap::RasterHeight;

use crate::stats::RenderStats;

mod axis;
mod canvas;

use axis::LogAxis;
use canvas::{Canvas, Coverage, Font, Mask, Rect, Span};

/// Width of the plot in pixels.
pub const PLOT_WIDTH: u32 = 900;
/// Height of the plot in pixels.
pub const PLOT_HEIGHT: u32 = 600;

/// The curve colours, in run order (matplotlib's "tab10"); runs past the tenth
/// cycle through them again.
const PALETTE: [[u8; 3]; 10] = [
    [0x1f, 0x77, 0xb4],
    [0xff, 0x7f, 0x0e],
    [0x2c, 0xa0, 0x2c],
    [0xd6, 0x27, 0x28],
    [0x94, 0x67, 0xbd],
    [0x8c, 0x56, 0x4b],
    [0xe3, 0x77, 0xc2],
    [0x7f, 0x7f, 0x7f],
    [0xbc, 0xbd, 0x22],
    [0x17, 0xbe, 0xcf],
];

const WHITE: [u8; 3] = [255, 255, 255];
const BLACK: [u8; 3] = [0, 0, 0];
const TEXT: [u8; 3] = [0x20, 0x20, 0x20];
const GRID: [u8; 3] = [0xe3, 0xe3, 0xe3];
const LEGEND_BORDER: [u8; 3] = [0xb0, 0xb0, 0xb0];

/// Half the width of a curve, in pixels.
const LINE_HALF_WIDTH: f64 = 1.1;
/// Radius of the point markers drawn on curves with few points.
const MARKER_RADIUS: f64 = 3.2;
/// Curves with at most this many points get a marker on each point.
const MAX_MARKED_POINTS: usize = 30;
const MAJOR_TICK: i64 = 6;
const MINOR_TICK: i64 = 3;

/// The colour of the curve of the `index`-th run (0-based).
pub fn run_colour(index: usize) -> [u8; 3] {
    PALETTE[index % PALETTE.len()]
}

/// The dashes (on, off lengths in pixels) of the `index`-th run's curve: solid
/// for the first ten runs, then dashed, then dotted, as the colours repeat.
fn dash_pattern(index: usize) -> Option<(f64, f64)> {
    match index / PALETTE.len() % 3 {
        0 => None,
        1 => Some((6.0, 6.0)),
        _ => Some((0.01, 5.0)),
    }
}

/// Which relMSE a plot draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Metric {
    /// `rel_mse`: against the reference.
    #[default]
    RelMse,
    /// `rel_mse_debiased`: less the reference's own variance, the error against
    /// the true image (`render --reference-variance`).
    RelMseDebiased,
}

impl Metric {
    /// The metric's value at a frame, where it was measured.
    pub fn of(self, f: &crate::stats::FrameStats) -> Option<f64> {
        match self {
            Metric::RelMse => f.rel_mse,
            Metric::RelMseDebiased => f.rel_mse_debiased,
        }
    }

    /// The metric as the axis and the messages name it.
    pub fn name(self) -> &'static str {
        match self {
            Metric::RelMse => "relMSE",
            Metric::RelMseDebiased => "relMSE less the reference's variance",
        }
    }

    /// The options of `rlpt render` that record it.
    fn recorded_by(self) -> &'static str {
        match self {
            Metric::RelMse => "--reference",
            Metric::RelMseDebiased => "--reference and --reference-variance",
        }
    }
}

/// Plots `metric` (y; relMSE, or relMSE less the reference's variance) against
/// elapsed render time in seconds (x), both on log10 axes, one curve per run with
/// a legend of the labels, into a [`PLOT_WIDTH`]x[`PLOT_HEIGHT`] PNG at `out`,
/// which must end in `.png`.
///
/// Frames without the metric are skipped, and so are points with a non-positive
/// (or non-finite) time or value, which a log axis cannot show (the debiased
/// relMSE of a frame can be negative). A run without any value of the metric is
/// an error naming its label. The parent directory of `out` must exist.
pub fn plot_convergence(runs: &[RenderStats], out: &Path, metric: Metric) -> anyhow::Result<()> {
    let is_png = out.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !is_png {
        bail!("cannot write convergence plot {}: the output file must end in .png", out.display());
    }
    let image =
        render_convergence(runs, metric).with_context(|| format!("cannot plot convergence to {}", out.display()))?;
    let mut bytes = Vec::new();
    PngEncoder::new(&mut bytes)
        .write_image(image.as_raw(), image.width(), image.height(), ExtendedColorType::Rgb8)
        .with_context(|| format!("cannot encode convergence plot {}", out.display()))?;
    std::fs::write(out, bytes).with_context(|| format!("cannot write convergence plot {}", out.display()))
}

/// Draws the plot of [`plot_convergence`] into an image instead of a file.
pub fn render_convergence(runs: &[RenderStats], metric: Metric) -> anyhow::Result<RgbImage> {
    if runs.is_empty() {
        bail!("no runs to plot");
    }
    let curves = runs.iter().map(|r| curve_points(r, metric)).collect::<anyhow::Result<Vec<_>>>()?;
    let xs: Vec<f64> = curves.iter().flatten().map(|p| p.0).collect();
    let ys: Vec<f64> = curves.iter().flatten().map(|p| p.1).collect();
    let x_axis = LogAxis::fit(&xs);
    let y_axis = LogAxis::fit(&ys);

    let tick_font = Font::regular(RasterHeight::Size20);
    let exponent_font = Font::regular(RasterHeight::Size16);
    let label_font = Font::regular(RasterHeight::Size20);
    let title_font = Font::bold(RasterHeight::Size20);
    let legend_font = Font::regular(RasterHeight::Size16);

    let x_labels = x_axis.label_masks(tick_font, exponent_font);
    let y_labels = y_axis.label_masks(tick_font, exponent_font);
    let x_title = Mask::text(&[Span::new("time (s)", label_font)]);
    let y_title = Mask::text(&[Span::new(metric.name(), label_font)]).rotated_ccw();
    let title =
        Mask::text(&[Span::new(&elide(&title_text(runs, metric), title_font, PLOT_WIDTH as i64 - 40), title_font)]);

    // Layout: the plot area is what the title, the tick labels and the axis
    // titles leave free.
    let (width, height) = (PLOT_WIDTH as i64, PLOT_HEIGHT as i64);
    let y_label_width = y_labels.iter().map(|(_, m)| m.w).max().unwrap_or(0) as i64;
    let x_label_height = x_labels.iter().map(|(_, m)| m.h).max().unwrap_or(0) as i64;
    let left = 16 + y_title.w as i64 + 12 + y_label_width + 6 + MAJOR_TICK;
    let top = 16 + title.h as i64 + 12;
    let right = width - 28;
    let bottom = height - (14 + x_title.h as i64 + 6 + x_label_height + 4 + MAJOR_TICK);
    let area = Rect { x0: left, y0: top, x1: right, y1: bottom };
    // Pixel coordinates of a log10 value along each axis.
    let to_px = |log_x: f64| area.x0 as f64 + x_axis.frac(log_x) * (area.x1 - area.x0) as f64;
    let to_py = |log_y: f64| area.y1 as f64 - y_axis.frac(log_y) * (area.y1 - area.y0) as f64;
    let column = |log_x: f64| to_px(log_x).round() as i64;
    let row = |log_y: f64| to_py(log_y).round() as i64;

    let mut canvas = Canvas::new(PLOT_WIDTH, PLOT_HEIGHT);

    // Grid at the labelled ticks.
    for &(v, _) in &x_labels {
        canvas.vline(column(v), area.y0, area.y1, GRID);
    }
    for &(v, _) in &y_labels {
        canvas.hline(area.x0, area.x1, row(v), GRID);
    }

    // Curves, each rasterised to a coverage mask first so that overlapping
    // segments do not blend twice.
    let mut ink = vec![false; (width * height) as usize];
    for (index, points) in curves.iter().enumerate() {
        let pixels: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (to_px(x.log10()), to_py(y.log10()))).collect();
        let mut coverage = Coverage::new(area);
        coverage.polyline(&pixels, LINE_HALF_WIDTH, dash_pattern(index));
        if pixels.len() <= MAX_MARKED_POINTS {
            for &p in &pixels {
                coverage.disc(p, MARKER_RADIUS);
            }
        }
        coverage.composite(&mut canvas, run_colour(index), Some(&mut ink));
    }

    // Frame, outward ticks and their labels.
    canvas.hline(area.x0, area.x1, area.y0, BLACK);
    canvas.hline(area.x0, area.x1, area.y1, BLACK);
    canvas.vline(area.x0, area.y0, area.y1, BLACK);
    canvas.vline(area.x1, area.y0, area.y1, BLACK);
    let x_major = x_labels.iter().map(|l| l.0).chain(x_axis.major.iter().copied());
    let x_ticks = x_major.map(|v| (v, MAJOR_TICK)).chain(x_axis.minor.iter().map(|&v| (v, MINOR_TICK)));
    for (v, length) in x_ticks {
        canvas.vline(column(v), area.y1, area.y1 + length, BLACK);
    }
    let y_major = y_labels.iter().map(|l| l.0).chain(y_axis.major.iter().copied());
    let y_ticks = y_major.map(|v| (v, MAJOR_TICK)).chain(y_axis.minor.iter().map(|&v| (v, MINOR_TICK)));
    for (v, length) in y_ticks {
        canvas.hline(area.x0 - length, area.x0, row(v), BLACK);
    }
    for (v, label) in &x_labels {
        canvas.blit(label, column(*v) - label.w as i64 / 2, area.y1 + MAJOR_TICK + 4, TEXT);
    }
    for (v, label) in &y_labels {
        // Centre the digits (not a raised exponent) on the tick.
        let (top, bottom) = tick_font.digit_rows();
        let digits_centre = label.h as i64 - tick_font.size.val() as i64 + (top + bottom + 1) / 2;
        canvas.blit(label, area.x0 - MAJOR_TICK - 6 - label.w as i64, row(*v) - digits_centre, TEXT);
    }

    // Axis titles and the plot title.
    let centre_x = (area.x0 + area.x1) / 2;
    canvas.blit(&x_title, centre_x - x_title.w as i64 / 2, height - 14 - x_title.h as i64, TEXT);
    canvas.blit(&y_title, 16, (area.y0 + area.y1) / 2 - y_title.h as i64 / 2, TEXT);
    canvas.blit(&title, centre_x - title.w as i64 / 2, 16, TEXT);

    draw_legend(&mut canvas, runs, &curves, area, legend_font, &ink);
    Ok(canvas.image)
}

/// The (seconds, value) points of one run that a log-log plot of `metric` can show.
fn curve_points(run: &RenderStats, metric: Metric) -> anyhow::Result<Vec<(f64, f64)>> {
    let recorded: Vec<(f64, f64)> =
        run.frames.iter().filter_map(|f| metric.of(f).map(|v| (f.elapsed_ms / 1000.0, v))).collect();
    let name = metric.name();
    if recorded.is_empty() {
        bail!("run '{}' has no {name} values: render with {} to record it", run.label, metric.recorded_by());
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let points: Vec<(f64, f64)> = recorded.into_iter().filter(|&(x, y)| positive(x) && positive(y)).collect();
    if points.is_empty() {
        bail!("run '{}' has no frame with a positive time and {name} to put on log axes", run.label);
    }
    Ok(points)
}

/// What a plot of `runs` leaves out or mixes, as notes for stderr: each run's
/// recorded points that log axes cannot show (a time or relMSE at or below 0,
/// such as a first frame that matches its own reference exactly), and runs of
/// different scenes or sizes, whose relMSE do not compare.
pub fn plot_notes(runs: &[RenderStats], metric: Metric) -> Vec<String> {
    let mut notes = Vec::new();
    let name = metric.name();
    for run in runs {
        let recorded = run.frames.iter().filter(|f| metric.of(f).is_some()).count();
        let shown = curve_points(run, metric).map_or(0, |p| p.len());
        if shown > 0 && shown < recorded {
            notes.push(format!(
                "run '{}': {} of its {recorded} {name} points have a time or value at or below 0 and are not \
                 on the log axes",
                run.label,
                recorded - shown
            ));
        }
    }
    if let Some(first) = runs.first() {
        if runs.iter().any(|r| r.scene != first.scene || (r.width, r.height) != (first.width, first.height)) {
            let list: Vec<String> = runs.iter().map(|r| format!("{} {}x{}", r.scene, r.width, r.height)).collect();
            notes.push(format!(
                "the runs are of different scenes or sizes ({}): their relMSE do not compare",
                list.join(", ")
            ));
        }
    }
    notes
}

/// "relMSE against time", with the scene and resolution when all runs share them.
fn title_text(runs: &[RenderStats], metric: Metric) -> String {
    let first = &runs[0];
    let mut title = format!("{} against render time", metric.name());
    if !first.scene.is_empty() && runs.iter().all(|r| r.scene == first.scene) {
        title += &format!(": {}", first.scene);
        if runs.iter().all(|r| (r.width, r.height) == (first.width, first.height)) {
            title += &format!(" ({}x{})", first.width, first.height);
        }
    }
    title
}

/// The legend: a sample of each curve and its label, in the corner of the plot
/// area where it hides the least of the curves.
fn draw_legend(
    canvas: &mut Canvas,
    runs: &[RenderStats],
    curves: &[Vec<(f64, f64)>],
    area: Rect,
    font: Font,
    ink: &[bool],
) {
    const PAD: i64 = 8;
    const SAMPLE: i64 = 30;
    const GAP: i64 = 8;
    const INSET: i64 = 10;
    let row = font.size.val() as i64 + 4;
    let max_text = ((area.x1 - area.x0) * 6 / 10 - 2 * PAD - SAMPLE - GAP).max(font.width() as i64 * 4);
    let labels: Vec<Mask> =
        runs.iter().map(|r| Mask::text(&[Span::new(&elide(&r.label, font, max_text), font)])).collect();
    let text_width = labels.iter().map(|m| m.w as i64).max().unwrap_or(0);
    let w = PAD + SAMPLE + GAP + text_width + PAD;
    let h = 2 * PAD - 4 + row * runs.len() as i64;

    let corners = [
        (area.x1 - INSET - w, area.y0 + INSET), // top right
        (area.x0 + INSET, area.y1 - INSET - h), // bottom left
        (area.x0 + INSET, area.y0 + INSET),     // top left
        (area.x1 - INSET - w, area.y1 - INSET - h),
    ];
    let hidden = |&(x0, y0): &(i64, i64)| {
        let mut count = 0usize;
        for y in y0.max(0)..(y0 + h).min(PLOT_HEIGHT as i64) {
            for x in x0.max(0)..(x0 + w).min(PLOT_WIDTH as i64) {
                count += ink[(y * PLOT_WIDTH as i64 + x) as usize] as usize;
            }
        }
        count
    };
    // The first corner that hides the fewest curve pixels (min_by_key keeps the first minimum).
    let (x0, y0) = *corners.iter().min_by_key(|c| hidden(c)).unwrap();

    canvas.fill(Rect { x0, y0, x1: x0 + w, y1: y0 + h }, WHITE);
    canvas.hline(x0, x0 + w, y0, LEGEND_BORDER);
    canvas.hline(x0, x0 + w, y0 + h, LEGEND_BORDER);
    canvas.vline(x0, y0, y0 + h, LEGEND_BORDER);
    canvas.vline(x0 + w, y0, y0 + h, LEGEND_BORDER);
    for (index, (label, points)) in labels.iter().zip(curves).enumerate() {
        let top = y0 + PAD - 2 + row * index as i64;
        let cy = top as f64 + row as f64 / 2.0 - 1.5;
        let sample = Rect { x0: x0 + 1, y0: y0 + 1, x1: x0 + w, y1: y0 + h };
        let mut coverage = Coverage::new(sample);
        let (sx0, sx1) = ((x0 + PAD) as f64, (x0 + PAD + SAMPLE) as f64);
        coverage.polyline(&[(sx0, cy), (sx1, cy)], LINE_HALF_WIDTH, dash_pattern(index));
        if points.len() <= MAX_MARKED_POINTS {
            coverage.disc(((sx0 + sx1) / 2.0, cy), MARKER_RADIUS);
        }
        coverage.composite(canvas, run_colour(index), None);
        canvas.blit(label, x0 + PAD + SAMPLE + GAP, top, TEXT);
    }
}

/// `text`, cut to fit in `max_width` pixels with "..." at the end if needed;
/// characters the font lacks become '?'.
fn elide(text: &str, font: Font, max_width: i64) -> String {
    let chars: Vec<char> = text.chars().map(|c| if font.glyph(c).is_some() { c } else { '?' }).collect();
    let max_chars = (max_width / font.width() as i64).max(4) as usize;
    if chars.len() <= max_chars {
        chars.into_iter().collect()
    } else {
        chars[..max_chars - 3].iter().chain(['.', '.', '.'].iter()).collect()
    }
}
