//! Warps from the unit square to directions; `glsl/sampling.glsl`.

use super::Vec3;
use std::f32::consts::PI;

/// Cosine-weighted hemisphere around +z (Malley's method, concentric disk).
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d[0] * d[0] - d[1] * d[1]).max(0.0).sqrt();
    Vec3::new(d[0], d[1], z)
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Shirley-Chiu concentric map of [0,1)^2 to the unit disk.
pub fn concentric_disk(u: [f32; 2]) -> [f32; 2] {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, theta) = if a.abs() > b.abs() { (a, (PI / 4.0) * (b / a)) } else { (b, PI / 2.0 - (PI / 4.0) * (a / b)) };
    [r * theta.cos(), r * theta.sin()]
}

/// Uniform on the whole sphere.
pub fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Power heuristic (beta = 2) or balance heuristic weight of strategy `a`
/// against `b`, given their pdfs (Veach 1997).
pub fn mis_weight(pdf_a: f32, pdf_b: f32, power: bool) -> f32 {
    if power {
        let a = pdf_a * pdf_a;
        let b = pdf_b * pdf_b;
        if a + b > 0.0 {
            a / (a + b)
        } else {
            0.0
        }
    } else if pdf_a + pdf_b > 0.0 {
        pdf_a / (pdf_a + pdf_b)
    } else {
        0.0
    }
}
