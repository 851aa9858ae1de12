//! Per-pass GPU timestamps, compute-invocation counts and debug labels.
//!
//! Each pass of a frame is bracketed by [`PassTimer::begin_pass`] / [`PassTimer::end_pass`]:
//! a `VK_EXT_debug_utils` label (so RenderDoc and Nsight captures show pass names), a
//! timestamp after the pass, and, where the device has pipeline-statistics queries, the number
//! of compute-shader invocations the pass ran. The timestamps can go into a query pool of the
//! caller's ([`PassTimer::with_engine_pool`], installed with `Renderer::set_timer`).

use ash::vk;

use crate::error::{Result, VkContext};
use crate::vk::Context;

/// Most passes one frame times.
pub const MAX_PASSES: u32 = 31;

/// What one pass of the last frame cost.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTiming {
    /// Pass name (the debug label).
    pub name: &'static str,
    /// GPU milliseconds from the end of the previous pass to the end of this one.
    pub ms: f64,
    /// Compute-shader invocations, where the device counts them.
    pub invocations: Option<u64>,
}

/// Query pools that time and count the passes of a frame.
pub struct PassTimer {
    timestamps: vk::QueryPool,
    /// First query of `timestamps` this timer uses (0 unless the pool is an engine's).
    first: u32,
    /// Whether the timer created `timestamps` (and so destroys it).
    owns_timestamps: bool,
    statistics: Option<vk::QueryPool>,
    names: Vec<&'static str>,
    open: bool,
    enabled: bool,
    ctx: Context,
}

impl PassTimer {
    /// Creates the query pools (timestamps are skipped where the queue has none, statistics
    /// where the device lacks `pipelineStatisticsQuery`).
    pub fn new(ctx: &Context) -> Result<Self> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(MAX_PASSES + 1);
        let timestamps =
            unsafe { ctx.device().create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        let statistics = if ctx.info().pipeline_statistics {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::PIPELINE_STATISTICS)
                .pipeline_statistics(vk::QueryPipelineStatisticFlags::COMPUTE_SHADER_INVOCATIONS)
                .query_count(MAX_PASSES);
            Some(unsafe { ctx.device().create_query_pool(&info, None) }.vk("vkCreateQueryPool")?)
        } else {
            None
        };
        Ok(PassTimer {
            timestamps,
            first: 0,
            owns_timestamps: true,
            statistics,
            names: Vec::new(),
            open: false,
            enabled: ctx.info().timestamps,
            ctx: ctx.clone(),
        })
    }

    /// A timer with no queries: it only opens and closes the debug labels of the passes. Used
    /// by [`crate::Renderer::record`] when the caller passes no timer.
    pub fn labels_only(ctx: &Context) -> PassTimer {
        PassTimer {
            timestamps: vk::QueryPool::null(),
            first: 0,
            owns_timestamps: false,
            statistics: None,
            names: Vec::new(),
            open: false,
            enabled: false,
            ctx: ctx.clone(),
        }
    }

    /// A timer that writes its timestamps into queries `first .. first + MAX_PASSES + 1` of an
    /// engine's timestamp pool (no pipeline statistics). The timer resets those queries at the
    /// start of each frame and never destroys the pool.
    ///
    /// # Safety
    /// `pool` must be a `VK_QUERY_TYPE_TIMESTAMP` pool of `ctx`'s device with at least
    /// `first + MAX_PASSES + 1` queries, must outlive the timer, and those queries must not be
    /// used by anything else while frames recorded with the timer are pending.
    pub unsafe fn with_engine_pool(ctx: &Context, pool: vk::QueryPool, first: u32) -> PassTimer {
        PassTimer {
            timestamps: pool,
            first,
            owns_timestamps: false,
            statistics: None,
            names: Vec::new(),
            open: false,
            enabled: ctx.info().timestamps,
            ctx: ctx.clone(),
        }
    }

    /// Resets the pools and writes the frame's first timestamp.
    pub fn begin_frame(&mut self, cmd: vk::CommandBuffer) {
        self.names.clear();
        self.open = false;
        let device = self.ctx.device();
        unsafe {
            if self.enabled {
                device.cmd_reset_query_pool(cmd, self.timestamps, self.first, MAX_PASSES + 1);
                device.cmd_write_timestamp(
                    cmd,
                    vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                    self.timestamps,
                    self.first,
                );
            }
            if let Some(pool) = self.statistics {
                device.cmd_reset_query_pool(cmd, pool, 0, MAX_PASSES);
            }
        }
    }

    /// Opens pass `name`: its debug label and its invocation count start here.
    pub fn begin_pass(&mut self, cmd: vk::CommandBuffer, name: &'static std::ffi::CStr) {
        assert!(!self.open, "end_pass before the next begin_pass");
        self.ctx.begin_label(cmd, name);
        self.open = true;
        if self.names.len() as u32 >= MAX_PASSES {
            return;
        }
        if let Some(pool) = self.statistics {
            unsafe {
                self.ctx.device().cmd_begin_query(
                    cmd,
                    pool,
                    self.names.len() as u32,
                    vk::QueryControlFlags::empty(),
                )
            };
        }
    }

    /// Closes the open pass: a timestamp once its work is done, the end of its label.
    pub fn end_pass(&mut self, cmd: vk::CommandBuffer, name: &'static std::ffi::CStr) {
        assert!(self.open, "end_pass without begin_pass");
        self.open = false;
        let index = self.names.len() as u32;
        if index < MAX_PASSES {
            let device = self.ctx.device();
            unsafe {
                if let Some(pool) = self.statistics {
                    device.cmd_end_query(cmd, pool, index);
                }
                if self.enabled {
                    device.cmd_write_timestamp(
                        cmd,
                        vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                        self.timestamps,
                        self.first + index + 1,
                    );
                }
            }
            self.names
                .push(name.to_str().expect("pass names are ASCII"));
        }
        self.ctx.end_label(cmd);
    }

    /// After the frame completed: each pass in order (empty without timestamps).
    pub fn read(&self) -> Result<Vec<PassTiming>> {
        if !self.enabled || self.names.is_empty() {
            return Ok(Vec::new());
        }
        let n = self.names.len();
        let mut ticks = vec![0u64; n + 1];
        let flags = vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT;
        let device = self.ctx.device();
        unsafe { device.get_query_pool_results(self.timestamps, self.first, &mut ticks, flags) }
            .vk("vkGetQueryPoolResults")?;
        let mut invocations = vec![None; n];
        if let Some(pool) = self.statistics {
            let mut counts = vec![0u64; n];
            unsafe { device.get_query_pool_results(pool, 0, &mut counts, flags) }
                .vk("vkGetQueryPoolResults")?;
            invocations = counts.into_iter().map(Some).collect();
        }
        let period = self.ctx.info().timestamp_period_ns as f64;
        Ok(self
            .names
            .iter()
            .zip(ticks.windows(2))
            .zip(invocations)
            .map(|((name, w), invocations)| PassTiming {
                name,
                ms: w[1].saturating_sub(w[0]) as f64 * period * 1e-6,
                invocations,
            })
            .collect())
    }
}

impl Drop for PassTimer {
    fn drop(&mut self) {
        unsafe {
            if self.owns_timestamps {
                self.ctx.device().destroy_query_pool(self.timestamps, None);
            }
            if let Some(pool) = self.statistics {
                self.ctx.device().destroy_query_pool(pool, None);
            }
        }
    }
}
