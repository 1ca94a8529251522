//! The image environment light: an equirectangular (latitude-longitude) map,
//! importance sampled by luminance times solid angle. `glsl/envmap.glsl`
//! (`env_*`) has the same functions for the GPU.
//!
//! Convention: row v = 0 of the image is straight up (+y), the last row straight
//! down; the image centre (u = 0.5) is the direction -z, and u grows towards +x
//! (seen from inside, the image is not mirrored). The map's frame is turned
//! against the world's by `RenderParams::env_frame` (`[environment] rotate`
//! turns it about +y). Texels are looked up nearest (piecewise constant), the
//! same values the sampler's weights come from.

use super::Vec3;
use crate::layout::SceneArrays;
use std::f32::consts::PI;

/// The direction of image coordinates (u, v) in [0, 1]^2, in the map's own frame.
pub fn env_local_direction(u: f32, v: f32) -> Vec3 {
    let theta = PI * v;
    let phi = 2.0 * PI * (u - 0.5);
    let s = theta.sin();
    Vec3::new(s * phi.sin(), theta.cos(), -s * phi.cos())
}

/// World direction `d` in the map's frame (`RenderParams::env_frame`'s rows).
pub fn env_to_map(frame: &[[f32; 4]; 3], d: Vec3) -> Vec3 {
    let row = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]).dot(d);
    Vec3::new(row(frame[0]), row(frame[1]), row(frame[2]))
}

/// Direction `l` of the map's frame in the world's (the transpose of [`env_to_map`]).
pub fn env_to_world(frame: &[[f32; 4]; 3], l: Vec3) -> Vec3 {
    let col = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]);
    l.x * col(frame[0]) + l.y * col(frame[1]) + l.z * col(frame[2])
}

/// The image coordinates (u, v) of `l`, a unit direction in the map's frame.
pub fn env_uv(l: Vec3) -> (f32, f32) {
    let u = l.x.atan2(-l.z) / (2.0 * PI) + 0.5;
    let v = l.y.clamp(-1.0, 1.0).acos() / PI;
    (u, v)
}

/// The texel index of (u, v) in a `w` x `h` map (nearest, clamped to the edges).
pub fn env_texel(u: f32, v: f32, w: u32, h: u32) -> usize {
    let x = ((u * w as f32) as u32).min(w - 1);
    let y = ((v * h as f32) as u32).min(h - 1);
    (y * w + x) as usize
}

/// The 2D piecewise-constant distribution of a `w` x `h` map of (scaled) RGB
/// texels: per texel its RGB and, in w, its density over the unit square of
/// (u, v); and the cdfs, the marginal over rows (h + 1 values) then each row's
/// conditional (w + 1 values each). A texel weighs luminance x sin(theta) at its
/// centre, the solid angle it covers; a row of zero weight keeps a uniform cdf
/// (it is never chosen). None where the whole map is black.
pub fn env_distribution(w: u32, h: u32, rgb: &[[f32; 3]]) -> Option<(Vec<[f32; 4]>, Vec<f32>)> {
    let (wu, hu) = (w as usize, h as usize);
    let weight = |i: usize| {
        let y = i / wu;
        let [r, g, b] = rgb[i];
        let lum = 0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64;
        lum * (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin()
    };
    let weights: Vec<f64> = (0..wu * hu).map(weight).collect();
    let total: f64 = weights.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut cdf = vec![0.0f32; hu + 1 + hu * (wu + 1)];
    let mut acc = 0.0f64;
    for y in 0..hu {
        let row = &weights[y * wu..(y + 1) * wu];
        let row_sum: f64 = row.iter().sum();
        acc += row_sum;
        cdf[y + 1] = (acc / total) as f32;
        let base = hu + 1 + y * (wu + 1);
        let mut c = 0.0f64;
        for (x, wt) in row.iter().enumerate() {
            c += wt;
            cdf[base + x + 1] = if row_sum > 0.0 { (c / row_sum) as f32 } else { (x + 1) as f32 / w as f32 };
        }
        cdf[base + wu] = 1.0;
    }
    cdf[hu] = 1.0;
    let scale = (wu * hu) as f64 / total;
    let texels = rgb.iter().zip(&weights).map(|(c, wt)| [c[0], c[1], c[2], (wt * scale) as f32]).collect();
    Some((texels, cdf))
}

/// The interval of `n` whose cdf (n + 1 values from `base`) holds `u`: the first
/// i with u < cdf[i + 1], and u's place within it in [0, 1).
/// `glsl/envmap.glsl` `env_find`.
pub fn env_find(cdf: &[f32], base: usize, n: u32, u: f32) -> (u32, f32) {
    let (mut lo, mut hi) = (0u32, n - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if u < cdf[base + mid as usize + 1] {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    let (a, b) = (cdf[base + lo as usize], cdf[base + lo as usize + 1]);
    let t = if b > a { ((u - a) / (b - a)).clamp(0.0, 0.99999994) } else { 0.5 };
    (lo, t)
}

/// A direction sampled from the map by `u`: (world direction, radiance, solid-angle
/// density of the map alone, without the light's choice). None where the map has
/// no distribution or the density is degenerate. `glsl/envmap.glsl` `env_sample`.
pub fn env_sample(scene: &SceneArrays, u: [f32; 2]) -> Option<(Vec3, Vec3, f32)> {
    let (w, h) = (scene.params.env_width, scene.params.env_height);
    let (y, ty) = env_find(&scene.env_cdf, 0, h, u[1]);
    let (x, tx) = env_find(&scene.env_cdf, (h + 1 + y * (w + 1)) as usize, w, u[0]);
    let (uu, vv) = ((x as f32 + tx) / w as f32, (y as f32 + ty) / h as f32);
    let t = scene.env_texels[(y * w + x) as usize];
    let sin_theta = (PI * vv).sin();
    let pdf = t[3] / (2.0 * PI * PI * sin_theta);
    if !(pdf > 0.0 && pdf.is_finite()) {
        return None;
    }
    let d = env_to_world(&scene.params.env_frame, env_local_direction(uu, vv));
    Some((d.normalize(), Vec3::new(t[0], t[1], t[2]), pdf))
}

/// The map's radiance towards -`d` (seen along `d`), and the solid-angle density
/// with which [`env_sample`] picks `d`. `glsl/envmap.glsl` `env_lookup`.
pub fn env_lookup(scene: &SceneArrays, d: Vec3) -> (Vec3, f32) {
    let (w, h) = (scene.params.env_width, scene.params.env_height);
    let l = env_to_map(&scene.params.env_frame, d);
    let (u, v) = env_uv(l);
    let t = scene.env_texels[env_texel(u, v, w, h)];
    // sin(theta) from the direction itself: acos near the poles loses it.
    let sin_theta = (l.x * l.x + l.z * l.z).sqrt();
    let pdf = if sin_theta > 0.0 { t[3] / (2.0 * PI * PI * sin_theta) } else { 0.0 };
    (Vec3::new(t[0], t[1], t[2]), pdf)
}
