//! Per-pass GPU timestamps.

use ash::vk;

use crate::error::{Result, VkContext};
use crate::vk::Context;

/// Most timestamps one frame writes.
const MAX_MARKS: u32 = 32;

/// A timestamp query pool that records a mark after each pass of a frame.
pub struct PassTimer {
    pool: vk::QueryPool,
    names: Vec<&'static str>,
    enabled: bool,
    ctx: Context,
}

impl PassTimer {
    /// Creates the query pool (timestamps are skipped where the queue has none).
    pub fn new(ctx: &Context) -> Result<Self> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(MAX_MARKS);
        let pool =
            unsafe { ctx.device().create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        Ok(PassTimer {
            pool,
            names: Vec::new(),
            enabled: ctx.info().timestamps,
            ctx: ctx.clone(),
        })
    }

    /// Resets the pool and writes the frame's first timestamp.
    pub fn begin(&mut self, cmd: vk::CommandBuffer) {
        self.names.clear();
        if self.enabled {
            unsafe {
                self.ctx
                    .device()
                    .cmd_reset_query_pool(cmd, self.pool, 0, MAX_MARKS)
            };
        }
        self.mark(cmd, "start");
    }

    /// Writes a timestamp once the work recorded so far is done; `name` is the pass it closes.
    pub fn mark(&mut self, cmd: vk::CommandBuffer, name: &'static str) {
        if !self.enabled || self.names.len() as u32 >= MAX_MARKS {
            return;
        }
        unsafe {
            self.ctx.device().cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                self.pool,
                self.names.len() as u32,
            )
        };
        self.names.push(name);
    }

    /// After the frame completed: milliseconds per pass, in order (empty without timestamps).
    pub fn read(&self) -> Result<Vec<(&'static str, f64)>> {
        if !self.enabled || self.names.len() < 2 {
            return Ok(Vec::new());
        }
        let mut ticks = vec![0u64; self.names.len()];
        unsafe {
            self.ctx.device().get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let period = self.ctx.info().timestamp_period_ns as f64;
        Ok(self.names[1..]
            .iter()
            .zip(ticks.windows(2))
            .map(|(name, w)| (*name, w[1].saturating_sub(w[0]) as f64 * period * 1e-6))
            .collect())
    }
}

impl Drop for PassTimer {
    fn drop(&mut self) {
        unsafe { self.ctx.device().destroy_query_pool(self.pool, None) };
    }
}
