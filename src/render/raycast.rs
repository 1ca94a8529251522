//! The traversal alone, timed by GPU timestamps (`rlpt bench --rays`): the
//! camera rays, a diffuse bounce ray from each of their hits, and an any-hit ray
//! along the same bounce direction, each through the renderer's own
//! `intersect_scene` and `occluded` (glsl/raycast.comp).

use super::{geometry_buffers, specialization, GpuError, GEOMETRY_BINDINGS};
use crate::gpu::{Binding, Buffer, BufferUsage, Context, Pipeline, Timer};
use crate::prepared::PreparedScene;
use crate::shared;
use std::sync::Arc;

/// Rays per second of each kind, the median over the repetitions.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RayRates {
    /// Rays traced per repetition: one per pixel (camera); one per pixel whose
    /// camera ray hit (bounce, shadow).
    pub camera_rays: u64,
    pub bounce_rays: u64,
    /// Milliseconds per repetition (median) and millions of rays per second.
    pub camera_ms: f64,
    pub bounce_ms: f64,
    pub shadow_ms: f64,
    pub camera_mrays_per_s: f64,
    pub bounce_mrays_per_s: f64,
    pub shadow_mrays_per_s: f64,
    /// Of the bounce rays, the share that hit something; of the shadow rays, the share blocked.
    pub bounce_hit_share: f64,
    pub shadow_blocked_share: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Times `repeats` dispatches of each kind of ray on `scene` (its image size).
pub fn measure_ray_rates(ctx: &Arc<Context>, scene: &PreparedScene, repeats: u32) -> Result<RayRates, GpuError> {
    let p = &scene.params;
    let mut buffers = vec![
        Buffer::with_data(ctx, "render params", bytemuck::bytes_of(p), true)?,
        Buffer::with_data(ctx, "materials", bytemuck::cast_slice(&scene.materials), false)?,
        Buffer::with_data(ctx, "spheres", bytemuck::cast_slice(&scene.spheres), false)?,
        Buffer::with_data(ctx, "quads", bytemuck::cast_slice(&scene.quads), false)?,
        Buffer::with_data(ctx, "lights", bytemuck::cast_slice(&scene.lights), false)?,
        Buffer::with_data(ctx, "scene constants", bytemuck::cast_slice(&scene.scene_constants()), true)?,
    ];
    buffers.extend(geometry_buffers(ctx, scene)?);
    let pixels = p.width as u64 * p.height as u64;
    buffers.push(Buffer::new(ctx, "ray hits", 32 * pixels, BufferUsage::Storage)?);
    buffers.push(Buffer::new(ctx, "ray count", 16, BufferUsage::Storage)?);
    let count_readback = Buffer::new(ctx, "ray count readback", 16, BufferUsage::Readback)?;
    let mut bindings: Vec<(u32, Binding)> = vec![
        (shared::BINDING_PARAMS, Binding::Uniform),
        (shared::BINDING_MATERIALS, Binding::Storage),
        (shared::BINDING_SPHERES, Binding::Storage),
        (shared::BINDING_QUADS, Binding::Storage),
        (shared::BINDING_LIGHTS, Binding::Storage),
        (shared::BINDING_SCENE_CONSTANTS, Binding::Uniform),
    ];
    bindings.extend(GEOMETRY_BINDINGS.map(|b| (b, Binding::Storage)));
    bindings.push((shared::BINDING_RAYCAST_HITS, Binding::Storage));
    bindings.push((shared::BINDING_RAYCAST_COUNT, Binding::Storage));
    let mut constants = specialization(p).to_vec();
    constants[shared::SPEC_PIXELS_PER_GROUP as usize] = 1;
    constants.extend_from_slice(&scene.geometry_specialization());
    let pipeline = Pipeline::new_specialized(ctx, "raycast", crate::gpu::shader("raycast"), &bindings, 8, &constants)?;
    pipeline.bind(&buffers.iter().collect::<Vec<_>>());
    let groups = [pixels.div_ceil(shared::RAYCAST_GROUP as u64) as u32, 1, 1];
    let timer = Timer::new(ctx, 2)?;
    let count = &buffers[buffers.len() - 1];
    let run = |mode: u32, seed: u32| -> Result<(f64, u64), GpuError> {
        let push: Vec<u8> = [mode, seed].iter().flat_map(|w| w.to_le_bytes()).collect();
        ctx.run_commands("raycast", |cmd| {
            timer.cmd_reset(cmd);
            count.cmd_clear(cmd);
            ctx.barrier(cmd);
            timer.cmd_stamp(cmd, 0);
            pipeline.cmd_dispatch(cmd, groups, &push);
            timer.cmd_stamp(cmd, 1);
            ctx.barrier(cmd);
            count.cmd_copy_to(cmd, &count_readback);
        })?;
        let t = timer.read(2)?;
        let n = u32::from_le_bytes(count_readback.read()[..4].try_into().unwrap()) as u64;
        Ok((timer.ticks_to_ms(t[0], t[1]), n))
    };
    let (mut cam, mut bounce, mut shadow) = (Vec::new(), Vec::new(), Vec::new());
    let (mut camera_hits, mut bounce_hits, mut blocked) = (0, 0, 0);
    for r in 0..repeats.max(1) {
        let (ms, n) = run(shared::RAYCAST_CAMERA, r)?;
        cam.push(ms);
        camera_hits = n;
        let (ms, n) = run(shared::RAYCAST_BOUNCE, r)?;
        bounce.push(ms);
        bounce_hits = n;
        let (ms, n) = run(shared::RAYCAST_SHADOW, r)?;
        shadow.push(ms);
        blocked = n;
    }
    let (camera_ms, bounce_ms, shadow_ms) = (median(cam), median(bounce), median(shadow));
    let rate = |rays: u64, ms: f64| rays as f64 / (ms * 1e-3) / 1e6;
    let share = |n: u64| if camera_hits > 0 { n as f64 / camera_hits as f64 } else { 0.0 };
    Ok(RayRates {
        camera_rays: pixels,
        bounce_rays: camera_hits,
        camera_ms,
        bounce_ms,
        shadow_ms,
        camera_mrays_per_s: rate(pixels, camera_ms),
        bounce_mrays_per_s: rate(camera_hits, bounce_ms),
        shadow_mrays_per_s: rate(camera_hits, shadow_ms),
        bounce_hit_share: share(bounce_hits),
        shadow_blocked_share: share(blocked),
    })
}
