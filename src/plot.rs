//! The convergence plot: relMSE against render time, both axes logarithmic,
//! one curve per [`RenderStats`] record.
//!
//! Everything is drawn here on an [`image::RgbImage`]: anti-aliased lines from
//! their distance to each pixel centre, and text from the pre-rasterised Noto
//! Sans Mono glyphs that the `noto-sans-mono-bitmap` crate compiles into the
//! binary, so a plot needs no system font and no plotting library.

use std::path::Path;

use anyhow::{bail, Context};
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder, RgbImage};
use noto_sans_mono_bitmap::{get_raster, get_raster_width, FontWeight, RasterHeight};

use crate::stats::RenderStats;

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

/// A tick label for m x 10^k: plain decimals ("0.05", "100") where the axis
/// allows, else "10" (or "2×10") with a raised exponent.
fn tick_label(m: u32, k: i32, plain: bool, font: Font, exponent_font: Font) -> Mask {
    if plain {
        let text = if k >= 0 {
            format!("{m}{}", "0".repeat(k as usize))
        } else {
            format!("0.{}{m}", "0".repeat(-k as usize - 1))
        };
        Mask::text(&[Span::new(&text, font)])
    } else {
        let base = if m == 1 { "10".to_string() } else { format!("{m}\u{d7}10") };
        // The exponent's digits end a little above the middle of the base's.
        let (base_top, base_bottom) = font.digit_rows();
        let (_, exponent_bottom) = exponent_font.digit_rows();
        let dy = (base_top + base_bottom) / 2 - 1 - exponent_bottom;
        Mask::text(&[Span::new(&base, font), Span::shifted(&k.to_string(), exponent_font, -1, dy)])
    }
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

/// A log10 axis: its visible range and its ticks.
struct LogAxis {
    /// log10 of the smallest and largest visible value.
    lo: f64,
    hi: f64,
    /// The labelled ticks, as (m, k) for m x 10^k; each gets a grid line.
    labels: Vec<(u32, i32)>,
    /// log10 of the unlabelled long ticks (decades between labelled ones).
    major: Vec<f64>,
    /// log10 of the short ticks.
    minor: Vec<f64>,
    /// Label with plain decimals ("0.01", "100") instead of powers of ten.
    plain: bool,
}

impl LogAxis {
    /// The range of the (positive) `values`, at least 0.75 decades, with a
    /// small margin. Decades are labelled (at most 8 of them) where the range
    /// holds two or more, else 1, 2 and 5 times each decade.
    fn fit(values: &[f64]) -> LogAxis {
        let logs = values.iter().map(|v| v.log10());
        let (mut min, mut max) = logs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        const MIN_SPAN: f64 = 0.75;
        if max - min < MIN_SPAN {
            let centre = (min + max) / 2.0;
            (min, max) = (centre - MIN_SPAN / 2.0, centre + MIN_SPAN / 2.0);
        }
        let pad = 0.04 * (max - min);
        let (lo, hi) = (min - pad, max + pad);
        let inside = |v: f64| v >= lo - 1e-9 && v <= hi + 1e-9;
        let decades: Vec<i32> = (lo.ceil() as i32..=hi.floor() as i32).collect();
        let (mut labels, mut major, mut minor) = (Vec::new(), Vec::new(), Vec::new());
        if decades.len() >= 2 {
            let step = (decades.len() as i32 + 7) / 8;
            for &k in &decades {
                if k.rem_euclid(step) == 0 {
                    labels.push((1, k));
                } else {
                    major.push(k as f64);
                }
            }
            if step == 1 {
                for k in lo.floor() as i32..=hi.ceil() as i32 {
                    minor.extend((2..=9).map(|m| k as f64 + (m as f64).log10()).filter(|&v| inside(v)));
                }
            }
        } else {
            // Under two decades: with the span of at least 0.75 decades, at
            // least two of 1, 2 and 5 times a decade are in range.
            for k in lo.floor() as i32..=hi.ceil() as i32 {
                for m in 1..=9u32 {
                    let v = k as f64 + (m as f64).log10();
                    if inside(v) {
                        if [1, 2, 5].contains(&m) {
                            labels.push((m, k));
                        } else {
                            minor.push(v);
                        }
                    }
                }
            }
        }
        let plain = labels.iter().all(|&(_, k)| (-2..=3).contains(&k));
        LogAxis { lo, hi, labels, major, minor, plain }
    }

    /// Where `log_value` (a log10) lies along the axis: 0 at the low end, 1 at the high end.
    fn frac(&self, log_value: f64) -> f64 {
        (log_value - self.lo) / (self.hi - self.lo)
    }

    /// The labels, each with the log10 of its position.
    fn label_masks(&self, font: Font, exponent_font: Font) -> Vec<(f64, Mask)> {
        self.labels
            .iter()
            .map(|&(m, k)| (k as f64 + (m as f64).log10(), tick_label(m, k, self.plain, font, exponent_font)))
            .collect()
    }
}

#[derive(Clone, Copy, Debug)]
struct Font {
    weight: FontWeight,
    size: RasterHeight,
}

impl Font {
    fn regular(size: RasterHeight) -> Font {
        Font { weight: FontWeight::Regular, size }
    }

    fn bold(size: RasterHeight) -> Font {
        Font { weight: FontWeight::Bold, size }
    }

    fn width(self) -> usize {
        get_raster_width(self.weight, self.size)
    }

    /// The first and last rows of the glyph box that the digits ink.
    fn digit_rows(self) -> (i64, i64) {
        let glyph = self.glyph('0').expect("the font has digits");
        let inked: Vec<i64> =
            glyph.rows().enumerate().filter(|(_, r)| r.iter().any(|&a| a > 64)).map(|(y, _)| y as i64).collect();
        (inked.first().copied().unwrap_or(0), inked.last().copied().unwrap_or(0))
    }

    fn glyph(self, c: char) -> Option<noto_sans_mono_bitmap::RasterizedChar> {
        get_raster(c, self.weight, self.size)
    }
}

/// A run of text in one font, moved right by `dx` pixels from the end of the
/// span before (negative: closer) and down by `dy` pixels (negative: raised).
struct Span<'a> {
    text: &'a str,
    font: Font,
    dx: i64,
    dy: i64,
}

impl<'a> Span<'a> {
    fn new(text: &'a str, font: Font) -> Span<'a> {
        Span { text, font, dx: 0, dy: 0 }
    }

    fn shifted(text: &'a str, font: Font, dx: i64, dy: i64) -> Span<'a> {
        Span { text, font, dx, dy }
    }

    fn advance(&self) -> i64 {
        (self.text.chars().count() * self.font.width()) as i64
    }
}

/// An 8-bit coverage mask (of text), `w` x `h`, row-major.
struct Mask {
    w: usize,
    h: usize,
    alpha: Vec<u8>,
}

impl Mask {
    /// Lays out the spans left to right; the mask's top is the top of the
    /// highest span.
    fn text(spans: &[Span]) -> Mask {
        let top = spans.iter().map(|s| s.dy).min().unwrap_or(0).min(0);
        let bottom = spans.iter().map(|s| s.dy + s.font.size.val() as i64).max().unwrap_or(0);
        let w = spans.iter().fold(0, |x, s| (x + s.dx).max(0) + s.advance()) as usize;
        let h = (bottom - top) as usize;
        let mut mask = Mask { w, h, alpha: vec![0; w * h] };
        let mut x0 = 0;
        for span in spans {
            x0 = (x0 as i64 + span.dx).max(0) as usize;
            let y0 = (span.dy - top) as usize;
            for c in span.text.chars() {
                let glyph = span.font.glyph(c).or_else(|| span.font.glyph('?')).expect("the font has '?'");
                for (y, row) in glyph.rows().enumerate() {
                    for (x, &a) in row.iter().enumerate() {
                        let i = (y0 + y) * w + x0 + x;
                        mask.alpha[i] = mask.alpha[i].max(a);
                    }
                }
                x0 += span.font.width();
            }
        }
        mask
    }

    /// The mask turned a quarter counter-clockwise (text reading upwards).
    fn rotated_ccw(&self) -> Mask {
        let (w, h) = (self.h, self.w);
        let mut alpha = vec![0; w * h];
        for y in 0..self.h {
            for x in 0..self.w {
                alpha[(self.w - 1 - x) * w + y] = self.alpha[y * self.w + x];
            }
        }
        Mask { w, h, alpha }
    }
}

/// A pixel rectangle, `x0..x1` by `y0..y1` (inclusive bounds).
#[derive(Clone, Copy, Debug)]
struct Rect {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
}

/// Anti-aliased coverage of shapes inside a clip rectangle, accumulated with
/// `max` so overlapping shapes of one curve do not darken each other.
struct Coverage {
    clip: Rect,
    w: i64,
    values: Vec<f32>,
}

impl Coverage {
    fn new(clip: Rect) -> Coverage {
        let w = clip.x1 - clip.x0 + 1;
        let h = clip.y1 - clip.y0 + 1;
        Coverage { clip, w, values: vec![0.0; (w * h) as usize] }
    }

    /// Adds the pixels whose centre is near the shape: coverage falls from 1 to
    /// 0 over one pixel around distance `radius`, as `distance(centre)` says.
    fn add(&mut self, bounds: (f64, f64, f64, f64), radius: f64, distance: impl Fn(f64, f64) -> f64) {
        let reach = radius + 1.0;
        let x0 = ((bounds.0 - reach).floor() as i64).max(self.clip.x0);
        let x1 = ((bounds.2 + reach).ceil() as i64).min(self.clip.x1);
        let y0 = ((bounds.1 - reach).floor() as i64).max(self.clip.y0);
        let y1 = ((bounds.3 + reach).ceil() as i64).min(self.clip.y1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = distance(x as f64 + 0.5, y as f64 + 0.5);
                let c = (radius + 0.5 - d).clamp(0.0, 1.0) as f32;
                let i = ((y - self.clip.y0) * self.w + (x - self.clip.x0)) as usize;
                self.values[i] = self.values[i].max(c);
            }
        }
    }

    fn segment(&mut self, a: (f64, f64), b: (f64, f64), half_width: f64) {
        let bounds = (a.0.min(b.0), a.1.min(b.1), a.0.max(b.0), a.1.max(b.1));
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        self.add(bounds, half_width, |px, py| {
            let t = if len2 > 0.0 { (((px - a.0) * dx + (py - a.1) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            ((px - a.0 - t * dx).powi(2) + (py - a.1 - t * dy).powi(2)).sqrt()
        });
    }

    /// The polyline through `points`, solid or with `dash` = (on, off) lengths
    /// measured along it.
    fn polyline(&mut self, points: &[(f64, f64)], half_width: f64, dash: Option<(f64, f64)>) {
        let Some((on, off)) = dash else {
            for pair in points.windows(2) {
                self.segment(pair[0], pair[1], half_width);
            }
            return;
        };
        let period = on + off;
        let mut start = 0.0; // arc length at the start of the current segment
        for pair in points.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            let length = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
            if !(length > 0.0) {
                continue;
            }
            let at = |s: f64| {
                let t = (s - start) / length;
                (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
            };
            let end = start + length;
            let mut s = start;
            while s < end {
                let phase = s % period;
                let (drawn, next) = if phase < on { (true, s - phase + on) } else { (false, s - phase + period) };
                let next = next.min(end);
                if drawn {
                    self.segment(at(s), at(next), half_width);
                }
                s = next;
            }
            start = end;
        }
    }

    fn disc(&mut self, c: (f64, f64), radius: f64) {
        self.add((c.0, c.1, c.0, c.1), radius, |px, py| ((px - c.0).powi(2) + (py - c.1).powi(2)).sqrt());
    }

    /// Paints `colour` over the canvas by this coverage, and marks the pixels it
    /// touched in `ink` (a plot-sized mask), if given.
    fn composite(&self, canvas: &mut Canvas, colour: [u8; 3], mut ink: Option<&mut [bool]>) {
        for (i, &c) in self.values.iter().enumerate() {
            if c > 0.0 {
                let x = self.clip.x0 + i as i64 % self.w;
                let y = self.clip.y0 + i as i64 / self.w;
                canvas.blend(x, y, colour, c);
                if let Some(slot) = ink.as_deref_mut().and_then(|ink| ink.get_mut((y * PLOT_WIDTH as i64 + x) as usize))
                {
                    *slot = true;
                }
            }
        }
    }
}

/// The image being drawn; every write is clipped to it.
struct Canvas {
    image: RgbImage,
}

impl Canvas {
    fn new(width: u32, height: u32) -> Canvas {
        Canvas { image: RgbImage::from_pixel(width, height, image::Rgb(WHITE)) }
    }

    /// Blends `colour` over the pixel with opacity `alpha` in 0..=1.
    fn blend(&mut self, x: i64, y: i64, colour: [u8; 3], alpha: f32) {
        if x < 0 || y < 0 || x >= self.image.width() as i64 || y >= self.image.height() as i64 {
            return;
        }
        let pixel = self.image.get_pixel_mut(x as u32, y as u32);
        for (p, &c) in pixel.0.iter_mut().zip(&colour) {
            *p = (*p as f32 + (c as f32 - *p as f32) * alpha).round() as u8;
        }
    }

    fn fill(&mut self, r: Rect, colour: [u8; 3]) {
        for y in r.y0..=r.y1 {
            for x in r.x0..=r.x1 {
                self.blend(x, y, colour, 1.0);
            }
        }
    }

    fn hline(&mut self, x0: i64, x1: i64, y: i64, colour: [u8; 3]) {
        self.fill(Rect { x0, y0: y, x1, y1: y }, colour);
    }

    fn vline(&mut self, x: i64, y0: i64, y1: i64, colour: [u8; 3]) {
        self.fill(Rect { x0: x, y0, x1: x, y1 }, colour);
    }

    /// Paints `colour` through `mask` with its top left corner at (x, y).
    fn blit(&mut self, mask: &Mask, x: i64, y: i64, colour: [u8; 3]) {
        for my in 0..mask.h {
            for mx in 0..mask.w {
                let a = mask.alpha[my * mask.w + mx];
                if a > 0 {
                    self.blend(x + mx as i64, y + my as i64, colour, a as f32 / 255.0);
                }
            }
        }
    }
}
