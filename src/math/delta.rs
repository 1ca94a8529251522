//! Delta lights: distant, point and spot (`glsl/delta.glsl`, the GPU twin;
//! docs/correctness.md, "Delta lights"). Each sends light along one direction to a
//! shading point, so only next-event estimation finds it: chosen by power among
//! the lights, its one direction has probability 1 (the pdf is the light's pmf)
//! and no MIS weight against BSDF sampling, which never meets it.

use glam::Vec3;

use super::geometry::LightSample;
use crate::layout::{GpuDeltaLight, GpuLight, SceneArrays};
use crate::scene::DeltaLight;
use crate::shared;

/// pbrt-v4's spot falloff: 1 inside the cone of cosine `cos_start`, 0 outside
/// that of `cos_end`, a smoothstep in the cosine between.
/// `glsl/delta.glsl` `spot_falloff`.
pub fn spot_falloff(cos_theta: f32, cos_start: f32, cos_end: f32) -> f32 {
    if cos_theta >= cos_start {
        return 1.0;
    }
    if cos_theta <= cos_end {
        return 0.0;
    }
    let t = (cos_theta - cos_end) / (cos_start - cos_end);
    t * t * (3.0 - 2.0 * t)
}

/// The light's kind (`shared::LIGHT_*`) and its record for `delta_lights[]`.
pub fn gpu_delta_light(l: &DeltaLight) -> (u32, GpuDeltaLight) {
    let v = |a: Vec3, w: f32| [a.x, a.y, a.z, w];
    match *l {
        DeltaLight::Distant { to_light, radiance } => (
            shared::LIGHT_DISTANT,
            GpuDeltaLight {
                position_cos_start: v(to_light, 1.0),
                intensity_cos_end: v(radiance, -1.0),
                axis: [0.0; 4],
            },
        ),
        DeltaLight::Point { position, intensity } => (
            shared::LIGHT_POINT,
            GpuDeltaLight {
                position_cos_start: v(position, 1.0),
                intensity_cos_end: v(intensity, -1.0),
                axis: [0.0; 4],
            },
        ),
        DeltaLight::Spot { position, axis, intensity, cos_start, cos_end } => (
            shared::LIGHT_SPOT,
            GpuDeltaLight {
                position_cos_start: v(position, cos_start),
                intensity_cos_end: v(intensity, cos_end),
                axis: v(axis, 0.0),
            },
        ),
    }
}

/// The light's power for choosing among the lights, as pbrt-v4's `Phi` of the
/// mean channel: a point's 4 pi I, a spot's 2 pi I (1 - (cos_start + cos_end) / 2),
/// a distant light's pi r^2 L with r the radius of the scene's bounding sphere.
pub fn delta_power(l: &DeltaLight, scene_radius: f64) -> f64 {
    let mean = |c: Vec3| (c.x as f64 + c.y as f64 + c.z as f64) / 3.0;
    let pi = std::f64::consts::PI;
    match *l {
        DeltaLight::Distant { radiance, .. } => pi * scene_radius * scene_radius * mean(radiance),
        DeltaLight::Point { intensity, .. } => 4.0 * pi * mean(intensity),
        DeltaLight::Spot { intensity, cos_start, cos_end, .. } => {
            2.0 * pi * mean(intensity) * (1.0 - 0.5 * (cos_start as f64 + cos_end as f64))
        }
    }
}

/// The one direction from `p` to the delta light `light`, its radiance factor
/// (L, or I times the spot's falloff over r^2) and its pmf as the pdf; the shadow
/// ray ends on the point, or leaves the scene towards a distant light (`dist`
/// infinite, as the image environment's). `glsl/delta.glsl` `sample_delta_light`.
pub fn sample_delta_light(scene: &SceneArrays, light: &GpuLight, p: Vec3) -> Option<LightSample> {
    let d = &scene.delta_lights[light.index as usize];
    let xyz = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
    let pdf = light.pmf;
    if !(pdf > 0.0) {
        return None;
    }
    let skip = shared::NO_PRIM;
    if light.kind == shared::LIGHT_DISTANT {
        let wi = xyz(d.position_cos_start);
        let le = xyz(d.intensity_cos_end);
        return Some(LightSample { wi, dist: f32::INFINITY, end: wi, skip, le, pdf, delta: true });
    }
    let lp = xyz(d.position_cos_start);
    let v = lp - p;
    let d2 = v.dot(v);
    if !(d2 > 0.0) {
        return None;
    }
    let dist = d2.sqrt();
    let wi = v / dist;
    let mut le = xyz(d.intensity_cos_end) / d2;
    if light.kind == shared::LIGHT_SPOT {
        le *= spot_falloff((-wi).dot(xyz(d.axis)), d.position_cos_start[3], d.intensity_cos_end[3]);
    }
    Some(LightSample { wi, dist, end: lp, skip, le, pdf, delta: true })
}
