use super::context::{Context, GpuError, Result};
use ash::vk;
use std::sync::Arc;

/// A pool of GPU timestamp queries: `cmd_stamp` records one, `read_ms`
/// turns pairs into milliseconds after the work has finished.
pub struct Timer {
    ctx: Arc<Context>,
    pool: vk::QueryPool,
    capacity: u32,
}

impl Timer {
    pub fn new(ctx: &Arc<Context>, capacity: u32) -> Result<Timer> {
        let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(capacity);
        // SAFETY: plain object creation.
        let pool =
            unsafe { ctx.device.create_query_pool(&info, None) }.map_err(|e| GpuError::vk("vkCreateQueryPool", e))?;
        ctx.set_name(pool, "rlpt timestamps");
        Ok(Timer { ctx: ctx.clone(), pool, capacity })
    }

    /// Timestamps the pool holds.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Records a reset of all queries (before the first stamp of a submission).
    pub fn cmd_reset(&self, cmd: vk::CommandBuffer) {
        // SAFETY: `cmd` is recording outside a render pass.
        unsafe { self.ctx.device.cmd_reset_query_pool(cmd, self.pool, 0, self.capacity) };
    }

    /// Records timestamp `index` after all previous work has finished.
    pub fn cmd_stamp(&self, cmd: vk::CommandBuffer, index: u32) {
        assert!(index < self.capacity);
        // SAFETY: `cmd` is recording; the query was reset in this submission.
        unsafe { self.ctx.device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, self.pool, index) };
    }

    /// Raw timestamps `0..count` (in ticks), waiting until they are available.
    pub fn read(&self, count: u32) -> Result<Vec<u64>> {
        let mut out = vec![0u64; count as usize];
        // SAFETY: the queries were written by finished work.
        unsafe {
            self.ctx.device.get_query_pool_results(
                self.pool,
                0,
                &mut out,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(|e| GpuError::vk("vkGetQueryPoolResults", e))?;
        Ok(out)
    }

    /// Milliseconds between two raw timestamps.
    pub fn ticks_to_ms(&self, start: u64, end: u64) -> f64 {
        end.wrapping_sub(start) as f64 * self.ctx.info.timestamp_period_ns as f64 * 1e-6
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        // SAFETY: no work using the pool is pending (run_commands waits).
        unsafe { self.ctx.device.destroy_query_pool(self.pool, None) };
    }
}
