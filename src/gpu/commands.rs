//! Submitting work to the context's queue: one-time command buffers, presentation, barriers.

use super::context::{Context, GpuError, Result};
use ash::vk;

impl Context {
    /// Records commands with `record`, submits them and waits for completion.
    pub fn run_commands(&self, name: &str, record: impl FnOnce(vk::CommandBuffer)) -> Result<()> {
        self.run_commands_synced(name, &[], &[], record)
    }

    /// [`run_commands`](Self::run_commands) whose submission first waits on `waits`
    /// (each semaphore at its stage) and signals `signals` when done (presentation).
    pub fn run_commands_synced(
        &self,
        name: &str,
        waits: &[(vk::Semaphore, vk::PipelineStageFlags)],
        signals: &[vk::Semaphore],
        record: impl FnOnce(vk::CommandBuffer),
    ) -> Result<()> {
        if self.is_lost() {
            return Err(GpuError::vk("vkQueueSubmit", vk::Result::ERROR_DEVICE_LOST));
        }
        let wait_semaphores: Vec<vk::Semaphore> = waits.iter().map(|w| w.0).collect();
        let wait_stages: Vec<vk::PipelineStageFlags> = waits.iter().map(|w| w.1).collect();
        let pool = self.command_pool.lock().unwrap_or_else(|e| e.into_inner());
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is locked for the duration; the command buffer is freed below.
        let cmd = unsafe { self.device.allocate_command_buffers(&alloc) }
            .map_err(|e| GpuError::vk("vkAllocateCommandBuffers", e))?[0];
        self.set_name(cmd, name);
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: fresh command buffer from our pool.
            unsafe { self.device.begin_command_buffer(cmd, &begin) }
                .map_err(|e| GpuError::vk("vkBeginCommandBuffer", e))?;
            record(cmd);
            // SAFETY: recording state.
            unsafe { self.device.end_command_buffer(cmd) }.map_err(|e| GpuError::vk("vkEndCommandBuffer", e))?;
            // SAFETY: plain fence.
            let fence = unsafe { self.device.create_fence(&vk::FenceCreateInfo::default(), None) }
                .map_err(|e| GpuError::vk("vkCreateFence", e))?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default()
                .command_buffers(&cmds)
                .wait_semaphores(&wait_semaphores)
                .wait_dst_stage_mask(&wait_stages)
                .signal_semaphores(signals)];
            // SAFETY: the queue is used from one thread at a time (the pool lock is held).
            let r = unsafe { self.device.queue_submit(self.queue, &submit, fence) }
                .map_err(|e| self.vk_error("vkQueueSubmit", e))
                // SAFETY: the fence was just submitted.
                .and_then(|_| {
                    unsafe { self.device.wait_for_fences(&[fence], true, u64::MAX) }
                        .map_err(|e| self.vk_error("vkWaitForFences", e))
                });
            // SAFETY: after the wait (or a failed submit) the fence is unused.
            unsafe { self.device.destroy_fence(fence, None) };
            r
        })();
        // SAFETY: the command buffer is no longer executing (waited above or never submitted).
        unsafe { self.device.free_command_buffers(*pool, &[cmd]) };
        result
    }

    /// Presents swapchain image `index` once `wait` is signalled, on the context's queue.
    /// `Ok(true)` when the swapchain no longer matches the surface (suboptimal or out of
    /// date) and should be recreated.
    pub fn present(
        &self,
        loader: &ash::khr::swapchain::Device,
        swapchain: vk::SwapchainKHR,
        index: u32,
        wait: vk::Semaphore,
    ) -> Result<bool> {
        // Queue access is serialised by the command pool's lock, as in run_commands.
        let _pool = self.command_pool.lock().unwrap_or_else(|e| e.into_inner());
        let (waits, swapchains, indices) = ([wait], [swapchain], [index]);
        let info =
            vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&swapchains).image_indices(&indices);
        // SAFETY: the swapchain belongs to this device and `index` was acquired from it.
        match unsafe { loader.queue_present(self.queue, &info) } {
            Ok(suboptimal) => Ok(suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(true),
            Err(e) => Err(self.vk_error("vkQueuePresentKHR", e)),
        }
    }

    /// A memory barrier making compute and transfer writes visible to later compute and transfer work.
    pub fn barrier(&self, cmd: vk::CommandBuffer) {
        let barrier = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(
                vk::AccessFlags::SHADER_READ
                    | vk::AccessFlags::SHADER_WRITE
                    | vk::AccessFlags::TRANSFER_READ
                    | vk::AccessFlags::TRANSFER_WRITE,
            )];
        let stages = vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER;
        // SAFETY: `cmd` is recording.
        unsafe {
            self.device.cmd_pipeline_barrier(cmd, stages, stages, vk::DependencyFlags::empty(), &barrier, &[], &[])
        };
    }
}
