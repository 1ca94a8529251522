use super::buffer::Buffer;
use super::context::{Context, GpuError, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// A 2D RGBA8 image in device memory that the viewer fills from a buffer and
/// blits to the swapchain; `Drop` frees it.
pub struct Image {
    ctx: Arc<Context>,
    pub raw: vk::Image,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    allocation: Option<Allocation>,
}

impl Image {
    /// An image that is copied into and blitted from (`TRANSFER_DST | TRANSFER_SRC`).
    pub fn new_transfer(ctx: &Arc<Context>, name: &str, width: u32, height: u32, format: vk::Format) -> Result<Image> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width, height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info on a live device.
        let raw = unsafe { ctx.device.create_image(&info, None) }.map_err(|e| GpuError::vk("vkCreateImage", e))?;
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { ctx.device.get_image_memory_requirements(raw) };
        let allocation = match ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        }) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: unused image without memory.
                unsafe { ctx.device.destroy_image(raw, None) };
                return Err(GpuError::Allocation { what: name.to_string(), source: e });
            }
        };
        // SAFETY: the allocation satisfies the image's requirements.
        if let Err(e) = unsafe { ctx.device.bind_image_memory(raw, allocation.memory(), allocation.offset()) } {
            let _ = ctx.allocator().free(allocation);
            // SAFETY: unused image.
            unsafe { ctx.device.destroy_image(raw, None) };
            return Err(GpuError::vk("vkBindImageMemory", e));
        }
        ctx.set_name(raw, name);
        Ok(Image { ctx: ctx.clone(), raw, format, width, height, allocation: Some(allocation) })
    }

    /// Records a copy of tightly packed RGBA8 texels from `src` into the whole image,
    /// leaving it in `TRANSFER_SRC_OPTIMAL`. `src` was written by a compute shader
    /// earlier in the same command buffer; its previous contents are discarded.
    pub fn cmd_fill_from(&self, cmd: vk::CommandBuffer, src: &Buffer) {
        let dev = &self.ctx.device;
        let to_dst = image_barrier(
            self.raw,
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            vk::AccessFlags::empty(),
            vk::AccessFlags::TRANSFER_WRITE,
        );
        let buffer = [vk::BufferMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .buffer(src.raw)
            .offset(0)
            .size(vk::WHOLE_SIZE)];
        let region = [vk::BufferImageCopy::default().image_subresource(color_layers()).image_extent(vk::Extent3D {
            width: self.width,
            height: self.height,
            depth: 1,
        })];
        let to_src = image_barrier(
            self.raw,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::TRANSFER_READ,
        );
        // SAFETY: `cmd` is recording outside a render pass; image and buffer are alive and
        // have TRANSFER usages; the buffer holds width * height texels.
        unsafe {
            dev.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &buffer,
                &[to_dst],
            );
            dev.cmd_copy_buffer_to_image(cmd, src.raw, self.raw, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &region);
            dev.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_src],
            );
        }
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator().free(a);
        }
        // SAFETY: callers wait for GPU work on this image before dropping it.
        unsafe { self.ctx.device.destroy_image(self.raw, None) };
    }
}

fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

fn color_layers() -> vk::ImageSubresourceLayers {
    vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: 0,
        base_array_layer: 0,
        layer_count: 1,
    }
}

fn image_barrier(
    image: vk::Image,
    from: vk::ImageLayout,
    to: vk::ImageLayout,
    src: vk::AccessFlags,
    dst: vk::AccessFlags,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .old_layout(from)
        .new_layout(to)
        .src_access_mask(src)
        .dst_access_mask(dst)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(color_range())
}

/// What [`Swapchain::acquire`] got.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Acquired {
    /// Image `index` is ours until presented; `suboptimal`: recreate after presenting.
    Image { index: u32, suboptimal: bool },
    /// The surface changed (resize): recreate the swapchain before drawing.
    OutOfDate,
}

/// The swapchain of the context's window surface, with the semaphores that
/// order acquisition, drawing and presentation. `Drop` waits for the device.
pub struct Swapchain {
    ctx: Arc<Context>,
    loader: ash::khr::swapchain::Device,
    pub raw: vk::SwapchainKHR,
    pub images: Vec<vk::Image>,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub present_mode: vk::PresentModeKHR,
    /// Signalled when an acquired image may be written (one: each frame's submission
    /// waits for it and finishes before the next acquisition).
    acquired: vk::Semaphore,
    /// Per image: signalled when its drawing is done, waited for by its presentation
    /// (one per image, so a semaphore is reused only once its image is acquired again).
    rendered: Vec<vk::Semaphore>,
}

/// Swapchain formats rlpt can blit its RGBA8 display image to, best first.
const FORMATS: [vk::Format; 4] =
    [vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM, vk::Format::B8G8R8A8_SRGB, vk::Format::R8G8B8A8_SRGB];

impl Swapchain {
    /// A swapchain for the window's current size (`size` where the surface leaves it to
    /// the application), replacing `old` if given. `Ok(None)` while the window has no
    /// area (minimised). Presentation prefers mailbox, then immediate, then FIFO: the
    /// display never paces rendering more than it must.
    pub fn new(ctx: &Arc<Context>, size: (u32, u32), old: Option<&Swapchain>) -> Result<Option<Swapchain>> {
        let surface = ctx
            .surface
            .as_ref()
            .ok_or_else(|| GpuError::NoPresentation("the context was made without a window".into()))?;
        let (loader_s, s) = (&surface.loader, surface.raw);
        let physical = ctx.physical;
        // SAFETY (this block): queries on objects of this instance.
        let (caps, formats, modes) = unsafe {
            (
                loader_s
                    .get_physical_device_surface_capabilities(physical, s)
                    .map_err(|e| GpuError::vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR", e))?,
                loader_s
                    .get_physical_device_surface_formats(physical, s)
                    .map_err(|e| GpuError::vk("vkGetPhysicalDeviceSurfaceFormatsKHR", e))?,
                loader_s
                    .get_physical_device_surface_present_modes(physical, s)
                    .map_err(|e| GpuError::vk("vkGetPhysicalDeviceSurfacePresentModesKHR", e))?,
            )
        };
        let extent = if caps.current_extent.width == u32::MAX {
            vk::Extent2D {
                width: size.0.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size.1.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        } else {
            caps.current_extent
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(None);
        }
        if !caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_DST) {
            return Err(GpuError::NoPresentation("the window's swapchain images cannot be copied to".into()));
        }
        let blittable = |f: vk::Format| {
            // SAFETY: plain query.
            let props = unsafe { ctx.instance.get_physical_device_format_properties(physical, f) };
            props.optimal_tiling_features.contains(vk::FormatFeatureFlags::BLIT_DST)
        };
        let format = FORMATS
            .iter()
            .find_map(|&want| {
                formats
                    .iter()
                    .find(|f| f.format == want && f.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR && blittable(want))
            })
            .copied()
            .ok_or_else(|| {
                GpuError::NoPresentation(format!(
                    "the window offers no 8-bit RGBA format rlpt can blit to (it offers {:?})",
                    formats.iter().map(|f| f.format).collect::<Vec<_>>()
                ))
            })?;
        let present_mode = [vk::PresentModeKHR::MAILBOX, vk::PresentModeKHR::IMMEDIATE]
            .into_iter()
            .find(|m| modes.contains(m))
            .unwrap_or(vk::PresentModeKHR::FIFO);
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = [vk::CompositeAlphaFlagsKHR::OPAQUE, vk::CompositeAlphaFlagsKHR::INHERIT]
            .into_iter()
            .find(|a| caps.supported_composite_alpha.contains(*a))
            .unwrap_or(vk::CompositeAlphaFlagsKHR::from_raw(caps.supported_composite_alpha.as_raw() & 0xf));
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(s)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            .present_mode(present_mode)
            .clipped(true)
            .old_swapchain(old.map(|o| o.raw).unwrap_or_default());
        let loader = ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device);
        // SAFETY: valid create info; `old` (if any) belongs to this surface and is retired by this call.
        let raw =
            unsafe { loader.create_swapchain(&info, None) }.map_err(|e| GpuError::vk("vkCreateSwapchainKHR", e))?;
        let mut sc = Swapchain {
            ctx: ctx.clone(),
            loader,
            raw,
            images: Vec::new(),
            format: format.format,
            extent,
            present_mode,
            acquired: vk::Semaphore::null(),
            rendered: Vec::new(),
        };
        // From here on, Drop cleans up whatever was made.
        // SAFETY: the swapchain was just created.
        sc.images =
            unsafe { sc.loader.get_swapchain_images(raw) }.map_err(|e| GpuError::vk("vkGetSwapchainImagesKHR", e))?;
        sc.acquired = sc.semaphore("swapchain image acquired")?;
        for i in 0..sc.images.len() {
            let s = sc.semaphore(&format!("swapchain image {i} drawn"))?;
            sc.rendered.push(s);
            ctx.set_name(sc.images[i], &format!("swapchain image {i}"));
        }
        ctx.set_name(raw, "rlpt swapchain");
        Ok(Some(sc))
    }

    fn semaphore(&self, name: &str) -> Result<vk::Semaphore> {
        // SAFETY: plain object creation; destroyed in Drop.
        let s = unsafe { self.ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .map_err(|e| GpuError::vk("vkCreateSemaphore", e))?;
        self.ctx.set_name(s, name);
        Ok(s)
    }

    /// True when the images store sRGB-encoded values that a blit encodes on write
    /// (a `*_SRGB` format): the display image must then be `*_SRGB` too.
    pub fn is_srgb(&self) -> bool {
        matches!(self.format, vk::Format::B8G8R8A8_SRGB | vk::Format::R8G8B8A8_SRGB)
    }

    /// The next image to draw, in whatever order the presentation engine hands them out.
    pub fn acquire(&self) -> Result<Acquired> {
        // SAFETY: the semaphore is unsignalled: every successful acquisition is followed by
        // a submission that waits on it and completes before the next call.
        match unsafe { self.loader.acquire_next_image(self.raw, u64::MAX, self.acquired, vk::Fence::null()) } {
            Ok((index, suboptimal)) => Ok(Acquired::Image { index, suboptimal }),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Acquired::OutOfDate),
            Err(e) => Err(GpuError::vk("vkAcquireNextImageKHR", e)),
        }
    }

    /// Draws `display` into acquired image `index`, letterboxed at `rect` = (x, y, w, h)
    /// on black, and presents it. `before` records work that must precede the blit in the
    /// same submission (the display pass). `Ok(true)`: recreate the swapchain.
    pub fn draw_and_present(
        &self,
        index: u32,
        display: &Image,
        rect: (i32, i32, u32, u32),
        before: impl FnOnce(vk::CommandBuffer),
    ) -> Result<bool> {
        let image = self.images[index as usize];
        let rendered = self.rendered[index as usize];
        let dev = &self.ctx.device;
        self.ctx.run_commands_synced(
            "display frame",
            &[(self.acquired, vk::PipelineStageFlags::TRANSFER)],
            &[rendered],
            |cmd| {
                before(cmd);
                let to_dst = image_barrier(
                    image,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::empty(),
                    vk::AccessFlags::TRANSFER_WRITE,
                );
                let after_clear = image_barrier(
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::TRANSFER_WRITE,
                );
                let to_present = image_barrier(
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::PRESENT_SRC_KHR,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::empty(),
                );
                let (x, y, w, h) = rect;
                let blit = [vk::ImageBlit::default()
                    .src_subresource(color_layers())
                    .src_offsets([
                        vk::Offset3D { x: 0, y: 0, z: 0 },
                        vk::Offset3D { x: display.width as i32, y: display.height as i32, z: 1 },
                    ])
                    .dst_subresource(color_layers())
                    .dst_offsets([
                        vk::Offset3D { x, y, z: 0 },
                        vk::Offset3D { x: x + w as i32, y: y + h as i32, z: 1 },
                    ])];
                let black = vk::ClearColorValue { float32: [0.0, 0.0, 0.0, 1.0] };
                // SAFETY: `cmd` is recording; the swapchain image was acquired and its availability
                // is waited for at the transfer stage by this submission; `display` is in
                // TRANSFER_SRC_OPTIMAL (Image::cmd_fill_from, recorded by `before`).
                unsafe {
                    let transfer = vk::PipelineStageFlags::TRANSFER;
                    let none = vk::DependencyFlags::empty();
                    dev.cmd_pipeline_barrier(cmd, transfer, transfer, none, &[], &[], &[to_dst]);
                    dev.cmd_clear_color_image(
                        cmd,
                        image,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &black,
                        &[color_range()],
                    );
                    dev.cmd_pipeline_barrier(cmd, transfer, transfer, none, &[], &[], &[after_clear]);
                    if w > 0 && h > 0 {
                        dev.cmd_blit_image(
                            cmd,
                            display.raw,
                            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                            image,
                            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                            &blit,
                            vk::Filter::LINEAR,
                        );
                    }
                    dev.cmd_pipeline_barrier(
                        cmd,
                        transfer,
                        vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                        none,
                        &[],
                        &[],
                        &[to_present],
                    );
                }
            },
        )?;
        self.ctx.present(&self.loader, self.raw, index, rendered)
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        // SAFETY: waiting for the device makes sure no submission or presentation still uses
        // the semaphores or images; then they are destroyed, the swapchain last.
        unsafe {
            let _ = self.ctx.device.device_wait_idle();
            for &s in self.rendered.iter().chain([&self.acquired]) {
                if s != vk::Semaphore::null() {
                    self.ctx.device.destroy_semaphore(s, None);
                }
            }
            self.loader.destroy_swapchain(self.raw, None);
        }
    }
}
