//! The viewer's camera: orbit about a point in front of it, move, change the field of view.

use crate::guide::probe_bounds;
use crate::math::geometry::intersect;
use crate::math::Vec3;
use crate::prepared::PreparedScene;
use crate::scene::Camera;
use glam::Quat;

/// Radians of orbit per pixel of mouse drag.
const ORBIT_PER_PIXEL: f32 = 0.005;

/// A pinhole camera with a point of interest `focus` units ahead (what left-drag orbits about).
#[derive(Clone, Debug, PartialEq)]
pub struct ViewCamera {
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// The scene's up: orbits turn about it, Q and E move along it.
    pub up: Vec3,
    pub vfov_deg: f32,
    pub near: f32,
    /// Distance to the orbit centre.
    pub focus: f32,
    /// Size of the visible scene (diagonal of what the camera sees), for step lengths.
    pub scale: f32,
}

impl ViewCamera {
    /// The scene's camera; it orbits about the surface at the centre of the view
    /// (or, when that is far off or missing, a point a third of the scene's size ahead).
    pub fn new(cam: &Camera, scene: &PreparedScene) -> ViewCamera {
        let (lo, hi) = probe_bounds(scene);
        let scale = (hi - lo).length().max(1e-3);
        let focus = match intersect(scene, cam.position, cam.forward, f32::INFINITY) {
            Some(h) if h.t > 1e-4 * scale && h.t < 2.0 * scale => h.t,
            _ => scale / 3.0,
        };
        ViewCamera {
            position: cam.position,
            forward: cam.forward.normalize(),
            up: cam.up.normalize(),
            vfov_deg: cam.vfov_deg,
            near: cam.near,
            focus,
            scale,
        }
    }

    /// Length of one movement key press: 2% of the scene.
    pub fn step(&self) -> f32 {
        0.02 * self.scale
    }

    fn right(&self) -> Vec3 {
        self.forward.cross(self.up).normalize()
    }

    /// Orbits about the focus point by a mouse drag of (dx, dy) pixels: across turns
    /// about `up`, up and down tilts (never past straight up or down).
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        let pivot = self.position + self.forward * self.focus;
        let yaw = Quat::from_axis_angle(self.up, -dx * ORBIT_PER_PIXEL);
        let mut offset = yaw * (self.position - pivot);
        let forward = (-offset).normalize();
        let right = forward.cross(self.up).normalize();
        let tilted = Quat::from_axis_angle(right, -dy * ORBIT_PER_PIXEL) * offset;
        if (-tilted).normalize().dot(self.up).abs() < 0.995 {
            offset = tilted;
        }
        self.position = pivot + offset;
        self.forward = (pivot - self.position).normalize();
    }

    /// Moves by `ahead` along the view direction, `right` to the right and `up` along the scene's up.
    pub fn translate(&mut self, ahead: f32, right: f32, up: f32) {
        self.position += self.forward * ahead + self.right() * right + self.up * up;
    }

    /// Narrows the field of view by 10% per wheel line up (widens it down), within 5..150 degrees.
    pub fn zoom(&mut self, lines: f32) {
        self.vfov_deg = (self.vfov_deg * 0.9f32.powf(lines)).clamp(5.0, 150.0);
    }

    pub fn to_scene_camera(&self) -> Camera {
        Camera { position: self.position, forward: self.forward, up: self.up, vfov_deg: self.vfov_deg, near: self.near }
    }
}
