//! The GPU renderer: uploads a [`PreparedScene`], runs `pathtrace.comp` once
//! per frame (64 samples per pixel), and reads the accumulation back.

use crate::film::Film;
use crate::gpu::{shader, Binding, Buffer, BufferUsage, Context, GpuError, Pipeline, Timer};
use crate::prepared::{AccumPixel, PreparedScene};
use crate::shared;
use std::sync::Arc;

pub struct GpuRenderer {
    ctx: Arc<Context>,
    pipeline: Pipeline,
    // Kept alive while the descriptor set points at them.
    _scene_buffers: [Buffer; 5],
    accum: Buffer,
    readback: Buffer,
    timer: Timer,
    width: u32,
    height: u32,
    frames: u32,
}

fn bytes<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

impl GpuRenderer {
    pub fn new(ctx: &Arc<Context>, scene: &PreparedScene) -> Result<GpuRenderer, GpuError> {
        let p = &scene.params;
        let pipeline = Pipeline::new(
            ctx,
            "pathtrace",
            shader("pathtrace"),
            &[
                Binding::Uniform,
                Binding::Storage,
                Binding::Storage,
                Binding::Storage,
                Binding::Storage,
                Binding::Storage,
            ],
            4,
        )?;
        let scene_buffers = [
            Buffer::with_data(ctx, "render params", bytemuck::bytes_of(p), true)?,
            Buffer::with_data(ctx, "materials", bytes(&scene.materials), false)?,
            Buffer::with_data(ctx, "spheres", bytes(&scene.spheres), false)?,
            Buffer::with_data(ctx, "quads", bytes(&scene.quads), false)?,
            Buffer::with_data(ctx, "lights", bytes(&scene.lights), false)?,
        ];
        let accum_size = (p.width as u64) * (p.height as u64) * std::mem::size_of::<AccumPixel>() as u64;
        let accum = Buffer::new(ctx, "accumulation", accum_size, BufferUsage::Storage)?;
        let readback = Buffer::new(ctx, "accumulation readback", accum_size, BufferUsage::Readback)?;
        let [b0, b1, b2, b3, b4] = &scene_buffers;
        pipeline.bind(&[b0, b1, b2, b3, b4, &accum]);
        ctx.run_commands("clear accumulation", |cmd| accum.cmd_clear(cmd))?;
        Ok(GpuRenderer {
            ctx: ctx.clone(),
            pipeline,
            _scene_buffers: scene_buffers,
            accum,
            readback,
            timer: Timer::new(ctx, 2)?,
            width: p.width,
            height: p.height,
            frames: 0,
        })
    }

    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Frames rendered so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Renders `count` frames in one submission; returns their GPU time in milliseconds
    /// (from timestamp queries; `None` where the queue has no timestamps).
    pub fn render_frames(&mut self, count: u32) -> Result<Option<f64>, GpuError> {
        let groups = [self.width.div_ceil(shared::PIXELS_PER_GROUP), self.height, 1];
        let first = self.frames;
        let timestamps = self.ctx.info.timestamps;
        self.ctx.run_commands("pathtrace frames", |cmd| {
            if timestamps {
                self.timer.cmd_reset(cmd);
                self.timer.cmd_stamp(cmd, 0);
            }
            for f in 0..count {
                if f > 0 {
                    self.ctx.barrier(cmd);
                }
                self.pipeline.cmd_dispatch(cmd, groups, &(first + f).to_le_bytes());
            }
            if timestamps {
                self.timer.cmd_stamp(cmd, 1);
            }
        })?;
        self.frames += count;
        if !timestamps {
            return Ok(None);
        }
        let t = self.timer.read(2)?;
        Ok(Some(self.timer.ticks_to_ms(t[0], t[1])))
    }

    /// Copies the accumulation back to the host.
    pub fn film(&self) -> Result<Film, GpuError> {
        self.ctx.run_commands("read accumulation", |cmd| {
            self.ctx.barrier(cmd);
            self.accum.cmd_copy_to(cmd, &self.readback);
        })?;
        let pixels: Vec<AccumPixel> = bytemuck::pod_collect_to_vec(
            &self.readback.read()[..(self.width * self.height) as usize * std::mem::size_of::<AccumPixel>()],
        );
        Ok(Film { width: self.width, height: self.height, frames: self.frames, pixels })
    }
}
