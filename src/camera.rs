//! The camera's primary rays, the same on both devices: `glsl/pathtrace.comp`
//! `camera_ray` and the sample positions of `main`.

use crate::layout::RenderParams;
use crate::shared;
use glam::Vec3;

fn xyz(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

/// Where in its pixel sample `sample` (0..64) of a frame looks: the pixel is cut
/// into the 8 x 8 grid of the workgroup's samples, and each sample is jittered by
/// `j` inside its own sub-square (stratified sampling: edges converge much faster
/// than with 64 independent positions). `glsl/pathtrace.comp` `main`.
pub fn pixel_jitter(sample: u32, j: [f32; 2]) -> [f32; 2] {
    let (sx, sy) = (shared::SAMPLES_X, shared::SAMPLES_Y);
    [((sample % sx) as f32 + j[0]) / sx as f32, ((sample / sx) as f32 + j[1]) / sy as f32]
}

/// The primary ray through pixel (x, y) jittered by `u`; `glsl/camera.glsl` `camera_ray`.
pub fn camera_ray(p: &RenderParams, x: u32, y: u32, u: [f32; 2]) -> (Vec3, Vec3) {
    let tan = p.cam_forward_tan[3];
    let aspect = p.cam_right_aspect[3];
    let sx = (2.0 * (x as f32 + u[0]) / p.width as f32 - 1.0) * tan * aspect;
    let sy = (1.0 - 2.0 * (y as f32 + u[1]) / p.height as f32) * tan;
    let d = (xyz(p.cam_forward_tan) + sx * xyz(p.cam_right_aspect) + sy * xyz(p.cam_up)).normalize();
    (xyz(p.cam_position_near) + p.cam_position_near[3] * d, d)
}
