use super::context::{Context, GpuError, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// What a buffer is for; decides its memory and usage flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BufferUsage {
    /// Written by the host, read by shaders (scene data, uniforms): host-visible.
    Upload { uniform: bool },
    /// Read and written by shaders only; cleared and copied by transfers: device-local.
    Storage,
    /// Copied into by the GPU and read by the host: host-visible, cached.
    Readback,
}

/// A Vulkan buffer and its memory; `Drop` frees both.
pub struct Buffer {
    ctx: Arc<Context>,
    pub raw: vk::Buffer,
    pub size: u64,
    allocation: Option<Allocation>,
    /// Bytes counted against the device's memory (`Context::note_allocation`).
    counted: u64,
}

/// `bytes` for a message: in MB, or in bytes below one.
fn megabytes(bytes: u64) -> String {
    if bytes < 1 << 20 {
        format!("{bytes} bytes")
    } else {
        format!("{} MB", bytes.div_ceil(1 << 20))
    }
}

impl Buffer {
    /// A buffer of `size` bytes (at least 16: Vulkan has no empty buffers), named `name`.
    pub fn new(ctx: &Arc<Context>, name: &str, size: u64, usage: BufferUsage) -> Result<Buffer> {
        let size = size.max(16);
        let (flags, location) = match usage {
            BufferUsage::Upload { uniform: true } => {
                (vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)
            }
            BufferUsage::Upload { uniform: false } => {
                (vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)
            }
            BufferUsage::Storage => (
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            ),
            BufferUsage::Readback => (vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu),
        };
        let info = vk::BufferCreateInfo::default().size(size).usage(flags).sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info on a live device.
        let raw = unsafe { ctx.device.create_buffer(&info, None) }.map_err(|e| GpuError::vk("vkCreateBuffer", e))?;
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let what = format!("the {name} buffer ({})", megabytes(size));
        if let Err(e) = ctx.note_allocation(&what, requirements.size) {
            // SAFETY: the buffer has no memory bound and is unused.
            unsafe { ctx.device.destroy_buffer(raw, None) };
            return Err(e);
        }
        let allocation = ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                ctx.note_free(requirements.size);
                // SAFETY: the buffer has no memory bound and is unused.
                unsafe { ctx.device.destroy_buffer(raw, None) };
                return Err(match e {
                    gpu_allocator::AllocationError::OutOfMemory => GpuError::OutOfMemory { what },
                    e => GpuError::Allocation { what: name.to_string(), source: e },
                });
            }
        };
        // SAFETY: memory and offset come from an allocation that satisfies the buffer's requirements.
        if let Err(e) = unsafe { ctx.device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) } {
            let _ = ctx.allocator().free(allocation);
            ctx.note_free(requirements.size);
            // SAFETY: unused buffer.
            unsafe { ctx.device.destroy_buffer(raw, None) };
            return Err(GpuError::vk("vkBindBufferMemory", e));
        }
        ctx.set_name(raw, name);
        Ok(Buffer { ctx: ctx.clone(), raw, size, allocation: Some(allocation), counted: requirements.size })
    }

    /// An upload buffer holding `data`.
    pub fn with_data(ctx: &Arc<Context>, name: &str, data: &[u8], uniform: bool) -> Result<Buffer> {
        let mut b = Buffer::new(ctx, name, data.len() as u64, BufferUsage::Upload { uniform })?;
        b.write(data);
        Ok(b)
    }

    /// A device-local storage buffer holding `data`, copied there through a
    /// host-visible one: large scene data (meshes, the BVH) read from host memory
    /// would cross the bus at every read.
    pub fn device_with_data(ctx: &Arc<Context>, name: &str, data: &[u8]) -> Result<Buffer> {
        let buffer = Buffer::new(ctx, name, data.len() as u64, BufferUsage::Storage)?;
        let staging = Buffer::with_data(ctx, &format!("{name} upload"), data, false)?;
        ctx.run_commands(&format!("upload {name}"), |cmd| staging.cmd_copy_to(cmd, &buffer))?;
        Ok(buffer)
    }

    /// Copies `data` to the start of a host-visible buffer.
    pub fn write(&mut self, data: &[u8]) {
        self.write_at(0, data);
    }

    /// Copies `data` into a host-visible buffer from byte `offset` on.
    pub fn write_at(&mut self, offset: usize, data: &[u8]) {
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .expect("write() needs a host-visible (Upload) buffer");
        slice[offset..offset + data.len()].copy_from_slice(data);
    }

    /// The contents of a host-visible buffer (call after the GPU work that wrote it has finished).
    pub fn read(&self) -> &[u8] {
        let slice =
            self.allocation.as_ref().and_then(|a| a.mapped_slice()).expect("read() needs a host-visible buffer");
        &slice[..self.size as usize]
    }

    /// Records a fill of the whole buffer with zeros.
    pub fn cmd_clear(&self, cmd: vk::CommandBuffer) {
        self.cmd_fill(cmd, 0);
    }

    /// Records filling the whole buffer with copies of the 32-bit word `word`.
    pub fn cmd_fill(&self, cmd: vk::CommandBuffer, word: u32) {
        // SAFETY: `cmd` is recording; the buffer has TRANSFER_DST usage (Storage).
        unsafe { self.ctx.device.cmd_fill_buffer(cmd, self.raw, 0, vk::WHOLE_SIZE, word) };
    }

    /// Records a copy of `size` bytes of `self`, from byte `offset`, to the start of `dst`.
    pub fn cmd_copy_range_to(&self, cmd: vk::CommandBuffer, offset: u64, dst: &Buffer, size: u64) {
        assert!(offset + size <= self.size && size <= dst.size, "copy range outside the buffers");
        let region = [vk::BufferCopy { src_offset: offset, dst_offset: 0, size }];
        // SAFETY: `cmd` is recording; the range lies inside both buffers; usages as in cmd_copy_to.
        unsafe { self.ctx.device.cmd_copy_buffer(cmd, self.raw, dst.raw, &region) };
    }

    /// Records a copy of all of `self` into `dst`.
    pub fn cmd_copy_to(&self, cmd: vk::CommandBuffer, dst: &Buffer) {
        let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size: self.size.min(dst.size) }];
        // SAFETY: `cmd` is recording; usages are TRANSFER_SRC (Storage) and TRANSFER_DST (Readback).
        unsafe { self.ctx.device.cmd_copy_buffer(cmd, self.raw, dst.raw, &region) };
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator().free(a);
            self.ctx.note_free(self.counted);
        }
        // SAFETY: callers wait for GPU work on this buffer before dropping it (run_commands waits).
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
    }
}
