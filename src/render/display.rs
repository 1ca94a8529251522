//! The viewer's display pass: `glsl/tonemap.comp` turns an accumulation into
//! sRGB RGBA8 texels (the same bytes `rlpt render` writes to a PNG), with an
//! optional inset drawn over them; the texels are copied into an image that the
//! swapchain blits to the window, and can be read back for screenshots.

use crate::gpu::{shader, vk, Binding, Buffer, BufferUsage, Context, GpuError, Image, Pipeline};
use crate::shared;
use std::sync::Arc;

/// A small RGBA8 picture drawn over the image at (x, y), in image pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Inset {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
    /// Row-major texels, R in the low byte.
    pub texels: Vec<u32>,
}

pub struct Display {
    ctx: Arc<Context>,
    pipeline: Pipeline,
    texels: Buffer,
    inset: Buffer,
    inset_rect: [u32; 4],
    readback: Buffer,
    /// The image the swapchain blits from.
    pub image: Image,
    width: u32,
    height: u32,
}

impl Display {
    /// A display pass for `width` x `height` images of `accumulation`. `srgb_target`:
    /// the swapchain's format encodes to sRGB on write, so the image must be `*_SRGB`
    /// for the blit to leave the encoded bytes as they are.
    pub fn new(
        ctx: &Arc<Context>,
        accumulation: &Buffer,
        width: u32,
        height: u32,
        srgb_target: bool,
    ) -> Result<Display, GpuError> {
        let pixels = width as u64 * height as u64;
        let format = if srgb_target { vk::Format::R8G8B8A8_SRGB } else { vk::Format::R8G8B8A8_UNORM };
        let d = Display {
            ctx: ctx.clone(),
            pipeline: Pipeline::new(ctx, "tonemap", shader("tonemap"), &[Binding::Storage; 3], 28)?,
            texels: Buffer::new(ctx, "display texels", 4 * pixels, BufferUsage::Storage)?,
            // Room for an inset of up to a quarter of the image.
            inset: Buffer::new(ctx, "display inset", 4 * pixels.div_ceil(4), BufferUsage::Upload { uniform: false })?,
            inset_rect: [0; 4],
            readback: Buffer::new(ctx, "display readback", 4 * pixels, BufferUsage::Readback)?,
            image: Image::new_transfer(ctx, "display image", width, height, format)?,
            width,
            height,
        };
        d.bind(accumulation);
        Ok(d)
    }

    /// Points the pass at another accumulation of the same size (call between frames).
    pub fn bind(&self, accumulation: &Buffer) {
        assert!(accumulation.size >= self.width as u64 * self.height as u64 * 32, "accumulation too small");
        self.pipeline.bind(&[accumulation, &self.texels, &self.inset]);
    }

    /// Shows `inset` from the next frame on, or no inset. An inset larger than a
    /// quarter of the image, or not inside it, is refused.
    pub fn set_inset(&mut self, inset: Option<&Inset>) -> Result<(), String> {
        match inset {
            None => self.inset_rect = [0; 4],
            Some(i) => {
                let n = i.width as u64 * i.height as u64;
                if n * 4 > self.inset.size || i.texels.len() as u64 != n {
                    return Err(format!("an inset of {}x{} does not fit the display buffer", i.width, i.height));
                }
                if i.x + i.width > self.width || i.y + i.height > self.height {
                    return Err(format!(
                        "an inset at ({}, {}) of {}x{} lies outside the image",
                        i.x, i.y, i.width, i.height
                    ));
                }
                self.inset.write(bytemuck::cast_slice(&i.texels));
                self.inset_rect = [i.x, i.y, i.width, i.height];
            }
        }
        Ok(())
    }

    /// Records the display pass over an accumulation of `frames` frames, then the
    /// copy of its texels into [`image`](Self::image).
    pub fn cmd_draw(&self, cmd: vk::CommandBuffer, frames: u32) {
        let [x, y, w, h] = self.inset_rect;
        let push: [u32; 7] = [self.width, self.height, frames, x, y, w, h];
        self.ctx.barrier(cmd);
        self.pipeline.cmd_dispatch(
            cmd,
            [self.width.div_ceil(shared::TONEMAP_GROUP_X), self.height.div_ceil(shared::TONEMAP_GROUP_Y), 1],
            bytemuck::bytes_of(&push),
        );
        self.image.cmd_fill_from(cmd, &self.texels);
    }

    /// The texels last drawn, as RGB8 rows (what the window shows, before scaling).
    pub fn read_rgb8(&self) -> Result<Vec<u8>, GpuError> {
        self.ctx.run_commands("read display", |cmd| {
            self.ctx.barrier(cmd);
            self.texels.cmd_copy_to(cmd, &self.readback);
        })?;
        let n = (self.width * self.height) as usize;
        let rgba = &self.readback.read()[..4 * n];
        Ok(rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect())
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}

/// The presenting GPU's copy of a film traced on several GPUs (their
/// accumulations read back and added, `MultiGpuRenderer`'s film): the display
/// pass reads it as it reads one GPU's accumulation.
pub struct SharedAccumulation {
    buffer: Buffer,
    frames: u32,
    pixels: usize,
}

impl SharedAccumulation {
    /// An empty accumulation (no frame) of `width` x `height` pixels on `ctx`.
    pub fn new(ctx: &Arc<Context>, width: u32, height: u32) -> Result<SharedAccumulation, GpuError> {
        let pixels = width as usize * height as usize;
        let size = (pixels * std::mem::size_of::<crate::layout::AccumPixel>()) as u64;
        let mut buffer = Buffer::new(ctx, "shared accumulation", size, BufferUsage::Upload { uniform: false })?;
        buffer.write(&vec![0u8; size as usize]);
        Ok(SharedAccumulation { buffer, frames: 0, pixels })
    }

    /// Replaces the accumulation with `film` (call between frames: every
    /// submission that read it has finished).
    pub fn upload(&mut self, film: &crate::film::Film) {
        assert_eq!(film.pixels.len(), self.pixels, "a film of the display's size");
        self.buffer.write(bytemuck::cast_slice(&film.pixels));
        self.frames = film.frames;
    }

    pub fn buffer(&self) -> &Buffer {
        &self.buffer
    }

    /// Frames in the accumulation.
    pub fn frames(&self) -> u32 {
        self.frames
    }
}
