//! What the plot is drawn with: text from the bitmap font's glyphs, anti-aliased
//! lines and discs, and the image they are painted on.

use image::RgbImage;
use noto_sans_mono_bitmap::{get_raster, get_raster_width, FontWeight, RasterHeight};

use super::{PLOT_WIDTH, WHITE};

#[derive(Clone, Copy, Debug)]
pub(super) struct Font {
    pub(super) weight: FontWeight,
    pub(super) size: RasterHeight,
}

impl Font {
    pub(super) fn regular(size: RasterHeight) -> Font {
        Font { weight: FontWeight::Regular, size }
    }

    pub(super) fn bold(size: RasterHeight) -> Font {
        Font { weight: FontWeight::Bold, size }
    }

    pub(super) fn width(self) -> usize {
        get_raster_width(self.weight, self.size)
    }

    /// The first and last rows of the glyph box that the digits ink.
    pub(super) fn digit_rows(self) -> (i64, i64) {
        let glyph = self.glyph('0').expect("the font has digits");
        let inked: Vec<i64> =
            glyph.rows().enumerate().filter(|(_, r)| r.iter().any(|&a| a > 64)).map(|(y, _)| y as i64).collect();
        (inked.first().copied().unwrap_or(0), inked.last().copied().unwrap_or(0))
    }

    pub(super) fn glyph(self, c: char) -> Option<noto_sans_mono_bitmap::RasterizedChar> {
        get_raster(c, self.weight, self.size)
    }
}

/// A run of text in one font, moved right by `dx` pixels from the end of the
/// span before (negative: closer) and down by `dy` pixels (negative: raised).
pub(super) struct Span<'a> {
    pub(super) text: &'a str,
    pub(super) font: Font,
    pub(super) dx: i64,
    pub(super) dy: i64,
}

impl<'a> Span<'a> {
    pub(super) fn new(text: &'a str, font: Font) -> Span<'a> {
        Span { text, font, dx: 0, dy: 0 }
    }

    pub(super) fn shifted(text: &'a str, font: Font, dx: i64, dy: i64) -> Span<'a> {
        Span { text, font, dx, dy }
    }

    pub(super) fn advance(&self) -> i64 {
        (self.text.chars().count() * self.font.width()) as i64
    }
}

/// An 8-bit coverage mask (of text), `w` x `h`, row-major.
pub(super) struct Mask {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) alpha: Vec<u8>,
}

impl Mask {
    /// Lays out the spans left to right; the mask's top is the top of the
    /// highest span.
    pub(super) fn text(spans: &[Span]) -> Mask {
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
    pub(super) fn rotated_ccw(&self) -> Mask {
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
pub(super) struct Rect {
    pub(super) x0: i64,
    pub(super) y0: i64,
    pub(super) x1: i64,
    pub(super) y1: i64,
}

/// Anti-aliased coverage of shapes inside a clip rectangle, accumulated with
/// `max` so overlapping shapes of one curve do not darken each other.
pub(super) struct Coverage {
    pub(super) clip: Rect,
    pub(super) w: i64,
    pub(super) values: Vec<f32>,
}

impl Coverage {
    pub(super) fn new(clip: Rect) -> Coverage {
        let w = clip.x1 - clip.x0 + 1;
        let h = clip.y1 - clip.y0 + 1;
        Coverage { clip, w, values: vec![0.0; (w * h) as usize] }
    }

    /// Adds the pixels whose centre is near the shape: coverage falls from 1 to
    /// 0 over one pixel around distance `radius`, as `distance(centre)` says.
    pub(super) fn add(&mut self, bounds: (f64, f64, f64, f64), radius: f64, distance: impl Fn(f64, f64) -> f64) {
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

    pub(super) fn segment(&mut self, a: (f64, f64), b: (f64, f64), half_width: f64) {
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
    pub(super) fn polyline(&mut self, points: &[(f64, f64)], half_width: f64, dash: Option<(f64, f64)>) {
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

    pub(super) fn disc(&mut self, c: (f64, f64), radius: f64) {
        self.add((c.0, c.1, c.0, c.1), radius, |px, py| ((px - c.0).powi(2) + (py - c.1).powi(2)).sqrt());
    }

    /// Paints `colour` over the canvas by this coverage, and marks the pixels it
    /// touched in `ink` (a plot-sized mask), if given.
    pub(super) fn composite(&self, canvas: &mut Canvas, colour: [u8; 3], mut ink: Option<&mut [bool]>) {
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
pub(super) struct Canvas {
    pub(super) image: RgbImage,
}

impl Canvas {
    pub(super) fn new(width: u32, height: u32) -> Canvas {
        Canvas { image: RgbImage::from_pixel(width, height, image::Rgb(WHITE)) }
    }

    /// Blends `colour` over the pixel with opacity `alpha` in 0..=1.
    pub(super) fn blend(&mut self, x: i64, y: i64, colour: [u8; 3], alpha: f32) {
        if x < 0 || y < 0 || x >= self.image.width() as i64 || y >= self.image.height() as i64 {
            return;
        }
        let pixel = self.image.get_pixel_mut(x as u32, y as u32);
        for (p, &c) in pixel.0.iter_mut().zip(&colour) {
            *p = (*p as f32 + (c as f32 - *p as f32) * alpha).round() as u8;
        }
    }

    pub(super) fn fill(&mut self, r: Rect, colour: [u8; 3]) {
        for y in r.y0..=r.y1 {
            for x in r.x0..=r.x1 {
                self.blend(x, y, colour, 1.0);
            }
        }
    }

    pub(super) fn hline(&mut self, x0: i64, x1: i64, y: i64, colour: [u8; 3]) {
        self.fill(Rect { x0, y0: y, x1, y1: y }, colour);
    }

    pub(super) fn vline(&mut self, x: i64, y0: i64, y1: i64, colour: [u8; 3]) {
        self.fill(Rect { x0: x, y0, x1: x, y1 }, colour);
    }

    /// Paints `colour` through `mask` with its top left corner at (x, y).
    pub(super) fn blit(&mut self, mask: &Mask, x: i64, y: i64, colour: [u8; 3]) {
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
