//! The logarithmic axes of the plot: their range, ticks and tick labels.

use super::canvas::{Font, Mask, Span};

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

/// A log10 axis: its visible range and its ticks.
pub(super) struct LogAxis {
    /// log10 of the smallest and largest visible value.
    pub(super) lo: f64,
    pub(super) hi: f64,
    /// The labelled ticks, as (m, k) for m x 10^k; each gets a grid line.
    pub(super) labels: Vec<(u32, i32)>,
    /// log10 of the unlabelled long ticks (decades between labelled ones).
    pub(super) major: Vec<f64>,
    /// log10 of the short ticks.
    pub(super) minor: Vec<f64>,
    /// Label with plain decimals ("0.01", "100") instead of powers of ten.
    pub(super) plain: bool,
}

impl LogAxis {
    /// The range of the (positive) `values`, at least 0.75 decades, with a
    /// small margin. Decades are labelled (at most 8 of them) where the range
    /// holds two or more, else 1, 2 and 5 times each decade.
    pub(super) fn fit(values: &[f64]) -> LogAxis {
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
    pub(super) fn frac(&self, log_value: f64) -> f64 {
        (log_value - self.lo) / (self.hi - self.lo)
    }

    /// The labels, each with the log10 of its position.
    pub(super) fn label_masks(&self, font: Font, exponent_font: Font) -> Vec<(f64, Mask)> {
        self.labels
            .iter()
            .map(|&(m, k)| (k as f64 + (m as f64).log10(), tick_label(m, k, self.plain, font, exponent_font)))
            .collect()
    }
}
