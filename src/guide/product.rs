//! The product with a glossy lobe: at a glossy vertex (GGX, glossy or rough
//! conductor) guided directions are drawn in proportion to Q times the lobe,
//! over a window of bins around the lobe's centre; `glsl/product.glsl` is the
//! GPU twin, function for function (docs/guiding.md, "Glossy lobes").

use super::*;
use crate::math::bsdf::{ggx_d, ggx_g2, Bsdf};

/// Whether a render with `FLAG_GLOSSY_PRODUCT` draws the guided directions of a
/// vertex of BSDF `b` from the product ([`product_sums`]) instead of the cell's
/// sampling row times [`lobe_share`]: GGX reflection lobes of alpha from
/// `PRODUCT_MIN_ALPHA` (narrower ones fit inside a bin, where a bin's uniform
/// directions miss them) up to the cosine lobe's width (4 alpha^2 < 1, wider
/// lobes take the whole fraction from the row already), and only where the
/// window's cap of radius `PRODUCT_RADIUS_PER_ALPHA` alpha fits in
/// `PRODUCT_WINDOW_BINS` of `bins` (a window cut short by `PRODUCT_MAX_BINS`
/// missed most of a wide lobe: docs/guiding.md, "Glossy lobes").
/// `glsl/product.glsl` `product_applies`.
pub fn product_applies(b: &Bsdf, bins: &Bins) -> bool {
    let r = shared::PRODUCT_RADIUS_PER_ALPHA * b.alpha;
    product_lobe(b) && PI * r * r <= shared::PRODUCT_WINDOW_BINS as f32 * bins.solid_angle()
}

/// The lobes the product may apply to whatever the bins ([`product_applies`]).
fn product_lobe(b: &Bsdf) -> bool {
    matches!(b.kind, crate::scene::MaterialKind::Glossy | crate::scene::MaterialKind::Conductor)
        && b.alpha >= shared::PRODUCT_MIN_ALPHA
        && 4.0 * b.alpha * b.alpha < 1.0
}

/// Whether a material has a lobe the product may apply to, whatever the bins,
/// from its kernel record (the host sets `FLAG_GLOSSY_PRODUCT` only where one has).
pub fn product_material(m: &GpuMaterial) -> bool {
    product_lobe(&m.bsdf())
}

/// The window of bins around a lobe's centre `m` (a unit direction): rows
/// `r0..=r1`, and in each row the columns [`window_columns`] gives. What it
/// depends on is kept, so that whether a bin lies inside costs one row's
/// arithmetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeWindow {
    /// cos(theta) of the centre, its azimuth in [0, 2 pi), and the cosine of the
    /// window's angular radius.
    pub zm: f32,
    pub phi_m: f32,
    pub cos_r: f32,
    pub r0: u32,
    pub r1: u32,
}

/// The window of a lobe of GGX width `alpha` centred on `m`: the bins within
/// angle R = min(`PRODUCT_RADIUS_PER_ALPHA` alpha, pi) of it (a bin counts where
/// its band of rows and its columns overlap the cap), at most `PRODUCT_MAX_BINS`
/// bins: rows are added alternately above and below the centre's row while
/// they fit, and a row wider than the bound keeps the columns nearest the
/// centre. `glsl/product.glsl` `lobe_window`.
pub fn lobe_window(bins: &Bins, m: Vec3, alpha: f32) -> LobeWindow {
    let zm = m.z.clamp(-1.0, 1.0);
    let theta_m = zm.acos();
    let r = (shared::PRODUCT_RADIUS_PER_ALPHA * alpha).min(PI);
    let mut phi_m = m.y.atan2(m.x);
    if phi_m < 0.0 {
        phi_m += 2.0 * PI;
    }
    let row_of = |z: f32| (((1.0 - z) * 0.5 * bins.rows as f32) as u32).min(bins.rows - 1);
    let (r_hi, r_lo) = (row_of((theta_m - r).max(0.0).cos()), row_of((theta_m + r).min(PI).cos()));
    let rm = row_of(zm);
    let mut w = LobeWindow { zm, phi_m, cos_r: r.cos(), r0: rm, r1: rm };
    let mut total = window_columns(bins, &w, rm).1;
    let (mut up, mut down) = (rm > r_hi, rm < r_lo);
    while up || down {
        if up {
            let n = window_columns(bins, &w, w.r0 - 1).1;
            up = total + n <= shared::PRODUCT_MAX_BINS;
            if up {
                total += n;
                w.r0 -= 1;
                up = w.r0 > r_hi;
            }
        }
        if down {
            let n = window_columns(bins, &w, w.r1 + 1).1;
            down = total + n <= shared::PRODUCT_MAX_BINS;
            if down {
                total += n;
                w.r1 += 1;
                down = w.r1 < r_lo;
            }
        }
    }
    w
}

/// The window's columns in bin row `row`: the first and how many (taken modulo
/// the columns, so a window may cross the seam at phi = 0). The azimuths within
/// the cap at the band's cos(theta) nearest the centre's; every column where the
/// cap holds a pole of the band or reaches all round; at most
/// `PRODUCT_MAX_BINS`, those nearest the centre's azimuth. `glsl/product.glsl`
/// `window_columns`.
pub fn window_columns(bins: &Bins, w: &LobeWindow, row: u32) -> (u32, u32) {
    let cols = bins.cols;
    let (top, bottom) = (1.0 - 2.0 * row as f32 / bins.rows as f32, 1.0 - 2.0 * (row + 1) as f32 / bins.rows as f32);
    let z = w.zm.clamp(bottom, top);
    let den = (1.0 - z * z).max(0.0).sqrt() * (1.0 - w.zm * w.zm).max(0.0).sqrt();
    let per_radian = cols as f32 * (0.5 / PI);
    let mut n = cols;
    let mut c0 = 0i32;
    if den > 1e-6 {
        let cos_d = (w.cos_r - z * w.zm) / den;
        if cos_d > -1.0 {
            let d = cos_d.min(1.0).acos();
            let first = ((w.phi_m - d) * per_radian).floor() as i32;
            let last = ((w.phi_m + d) * per_radian).floor() as i32;
            if ((last - first + 1) as u32) < cols {
                n = (last - first + 1) as u32;
                c0 = first;
            }
        }
    }
    if n > shared::PRODUCT_MAX_BINS {
        n = shared::PRODUCT_MAX_BINS;
        c0 = (w.phi_m * per_radian).floor() as i32 - (n / 2) as i32;
    }
    (c0.rem_euclid(cols as i32) as u32, n)
}

/// Whether bin `b` lies in the window. `glsl/product.glsl` `window_contains`.
pub fn window_contains(bins: &Bins, w: &LobeWindow, b: u32) -> bool {
    let (row, col) = (b / bins.cols, b % bins.cols);
    if row < w.r0 || row > w.r1 {
        return false;
    }
    let (c0, n) = window_columns(bins, w, row);
    (col + bins.cols - c0) % bins.cols < n
}

/// The GGX reflection lobe times the cosine, without Fresnel and the factor
/// 1 / (4 cos_o) that is the same for every direction: D(h) G2(wo, wi), 0 below
/// the surface. `wo` and `wi` in the shading frame. `glsl/product.glsl` `glossy_lobe`.
pub fn glossy_lobe(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    ggx_d((wo + wi).normalize(), alpha) * ggx_g2(wo.z, wi.z, alpha)
}

/// A glossy vertex as the product reads it: its shading frame, `wo` in it, the
/// lobe's alpha, and the cell's Q row.
#[derive(Clone, Copy)]
pub struct ProductVertex<'a> {
    pub frame: Frame,
    pub wo: Vec3,
    pub alpha: f32,
    pub q: &'a [f32],
}

impl ProductVertex<'_> {
    /// The lobe at the centre of bin `b`.
    fn lobe(&self, bins: &Bins, b: u32) -> f32 {
        glossy_lobe(self.wo, self.frame.to_local(bins.center(b)), self.alpha)
    }

    /// The lobe's centre: `wo` mirrored about the shading normal, in world space.
    pub fn mirror(&self) -> Vec3 {
        self.frame.to_world(Vec3::new(-self.wo.x, -self.wo.y, self.wo.z))
    }
}

/// What a vertex keeps of its window's sums: the window, the exploration floor's
/// share of each bin's Q (`floor_q`) and the weights' sum (`sum_w`, 0 where the
/// vertex has nothing to sample from the product).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Product {
    pub window: LobeWindow,
    pub floor_q: f32,
    pub sum_w: f32,
}

/// Calls `f(bin)` for each bin of the window, row by row and column by column
/// from each row's first.
fn for_window_bins(bins: &Bins, w: &LobeWindow, mut f: impl FnMut(u32) -> bool) {
    for row in w.r0..=w.r1 {
        let (c0, n) = window_columns(bins, w, row);
        for k in 0..n {
            if !f(row * bins.cols + (c0 + k) % bins.cols) {
                return;
            }
        }
    }
}

/// The first pass over the window: the bins' weights are `w_b = (Q_b + floor_q)
/// lobe(c_b)` at the bins' centres c_b, `floor_q` = `floor` times the
/// lobe-weighted mean of Q over the window, so that a share floor / (1 + floor)
/// of the draws is spread like the lobe (as the sampling rows spread theirs
/// like the cosine). `glsl/product.glsl` `product_sums`.
pub fn product_sums(bins: &Bins, v: &ProductVertex, floor: f32) -> Product {
    window_sums(bins, v, floor, lobe_window(bins, v.mirror(), v.alpha))
}

/// [`product_sums`] over a given window (the tests give the GPU's).
pub fn window_sums(bins: &Bins, v: &ProductVertex, floor: f32, window: LobeWindow) -> Product {
    let (mut sum_ql, mut sum_l) = (0.0f32, 0.0f32);
    for_window_bins(bins, &window, |b| {
        let l = v.lobe(bins, b);
        sum_l += l;
        sum_ql += v.q[b as usize] * l;
        true
    });
    let floor_q = if sum_l > 0.0 { floor * sum_ql / sum_l } else { 0.0 };
    let sum_w = if sum_ql > 0.0 { sum_ql + floor_q * sum_l } else { 0.0 };
    Product { window, floor_q, sum_w }
}

/// The weight of bin `b` ([`product_sums`]), whether or not it lies in the window.
fn product_weight(bins: &Bins, v: &ProductVertex, p: &Product, b: u32) -> f32 {
    (v.q[b as usize] + p.floor_q) * v.lobe(bins, b)
}

/// The second pass: the bin whose cumulative weight first exceeds `uc` times the
/// sum (the last bin of positive weight where rounding leaves none). The
/// direction is then drawn uniformly inside it (`Bins::sample`), and its density
/// is [`product_pdf`]. `glsl/product.glsl` `product_bin`.
pub fn product_bin(bins: &Bins, v: &ProductVertex, p: &Product, uc: f32) -> u32 {
    let target = uc * p.sum_w;
    let (mut acc, mut last, mut chosen) = (0.0f32, 0u32, None);
    for_window_bins(bins, &p.window, |b| {
        let w = product_weight(bins, v, p, b);
        acc += w;
        if w > 0.0 {
            last = b;
        }
        if target < acc && w > 0.0 {
            chosen = Some(b);
            return false;
        }
        true
    });
    chosen.unwrap_or(last)
}

/// Solid-angle density of the product's directions in bin `b`: `w_b / (sum_w
/// solid_angle)` inside the window, 0 outside (the BSDF's part of the mixture
/// covers those). One Q load and one lobe evaluation. `glsl/product.glsl` `product_pdf`.
pub fn product_pdf(bins: &Bins, v: &ProductVertex, p: &Product, b: u32) -> f32 {
    if !(p.sum_w > 0.0) || !window_contains(bins, &p.window, b) {
        return 0.0;
    }
    product_weight(bins, v, p, b) / (p.sum_w * bins.solid_angle())
}
