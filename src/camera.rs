//! The camera's primary rays, the same on both devices: `glsl/camera.glsl`
//! `camera_ray`.

use crate::layout::RenderParams;
use glam::Vec3;

fn xyz(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
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
