//! The numerical core of the CPU renderer. Each function here has a GLSL twin
//! of the same name in `glsl/*.glsl`; the two are tested against each other
//! (chi-square probes, GPU-vs-CPU renders), so change them together.

pub mod bsdf;
pub mod bvh;
pub mod delta;
pub mod envmap;
pub mod geometry;
pub mod rng;
pub mod sampler;
pub mod sampling;
pub mod texture;
pub mod triangle;

pub use glam::Vec3;

/// An orthonormal basis around a unit normal (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited"); `glsl/sampling.glsl` `make_frame`.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bb = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { t, b: bb, n }
    }
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// Largest component.
pub fn max_component(v: Vec3) -> f32 {
    v.x.max(v.y).max(v.z)
}

/// Mean of the three channels: the scalar that guiding's Q learns and learned
/// roulette compares (`glsl/sampling.glsl` `mean3`).
pub fn mean3(v: Vec3) -> f32 {
    (v.x + v.y + v.z) * (1.0 / 3.0)
}

/// Rec. 709 luminance.
pub fn luminance(v: Vec3) -> f32 {
    0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z
}
