//! The learning pass on the GPU: the guiding table's buffers, `learn.comp`'s
//! two phases (the fold and the rows' rebuild) and how they are dispatched;
//! `crate::guide::QTable::learn` is the CPU twin.

use super::*;
use crate::guide::CellNode;

/// The guiding buffers and the pass that learns from them.
pub(super) struct Learning {
    /// `learn.comp` as phase 0 runs it (the fold), LEARN_FOLD_GROUP invocations per group.
    pub(super) fold: Pipeline,
    /// `learn.comp` as phase 1 runs it (the rows' rebuild), a group of
    /// LEARN_ROW_GROUP invocations building each row together.
    pub(super) build: Pipeline,
    /// `learn.comp` as phase 2 runs it (the adaptive grid's splits), one group of
    /// REFINE_GROUP invocations.
    pub(super) refine: Pipeline,
    pub(super) q: Buffer,
    pub(super) visits: Buffer,
    /// Targets summed per entry since the table last learned, then the fraction
    /// gradients per cell (`guide::FrameSums`); their counts likewise.
    pub(super) sums: Buffer,
    pub(super) counts: Buffer,
    pub(super) sampler: Buffer,
    /// Per sampling row, its guided fraction (`QTable::fractions`).
    pub(super) fractions: Buffer,
    /// Per cell, its fraction's learning state (`guide::FractionState`).
    pub(super) fraction_states: Buffer,
    /// Per sampling row, 1 once a recording path read it (`QTable::rows_read`).
    pub(super) rows_read: Buffer,
    /// Per cell its `CellNode`, then the cells in use ([`tree_bytes`]).
    pub(super) tree: Buffer,
    /// The table's shape and learning settings.
    pub(super) cfg: GuideConfig,
    /// Which pixel rows record targets, frame by frame, and when the table learns.
    pub(super) schedule: RecordSchedule,
    /// Host-visible copies of `sums`, `counts` and `rows_read`, kept from the
    /// first exchange of a render on several devices (`GpuRenderer::frame_sums`,
    /// `learn_from`; `make_exchange`) rather than made for each.
    pub(super) exchange: Option<Exchange>,
    /// The device is a CPU: the learning passes start fewer groups (`CPU_FOLD_STEPS`).
    pub(super) cpu_device: bool,
}

/// The host-visible buffers through which a device's frame sums go to the host
/// and every device's sums come back: sums, counts, rows read, each way.
pub(super) struct Exchange {
    pub(super) readback: [Buffer; 3],
    pub(super) upload: [Buffer; 3],
}

impl Exchange {
    fn new(ctx: &Arc<Context>, l: &Learning) -> Result<Exchange, GpuError> {
        let of = [(&l.sums, "frame sums"), (&l.counts, "frame counts"), (&l.rows_read, "rows read")];
        let buffer = |i: usize, way: &str, usage| Buffer::new(ctx, &format!("{} {way}", of[i].1), of[i].0.size, usage);
        let upload = BufferUsage::Upload { uniform: false };
        Ok(Exchange {
            readback: [
                buffer(0, "readback", BufferUsage::Readback)?,
                buffer(1, "readback", BufferUsage::Readback)?,
                buffer(2, "readback", BufferUsage::Readback)?,
            ],
            upload: [buffer(0, "upload", upload)?, buffer(1, "upload", upload)?, buffer(2, "upload", upload)?],
        })
    }
}

impl Learning {
    /// Makes the exchange buffers (`exchange`) at the first exchange.
    pub(super) fn make_exchange(&mut self, ctx: &Arc<Context>) -> Result<(), GpuError> {
        if self.exchange.is_none() {
            self.exchange = Some(Exchange::new(ctx, self)?);
        }
        Ok(())
    }
}

/// Words in learn.comp's push constants (`Learning::push`).
pub(super) const LEARN_PUSH_WORDS: usize = 12;

/// Bytes of the cell tree's buffer: a `CellNode` per cell of the table, then one
/// node's room whose first word is the cells in use.
pub(super) fn tree_bytes(cfg: &crate::guide::GuideConfig) -> u64 {
    (cfg.cells() as u64 + 1) * std::mem::size_of::<CellNode>() as u64
}

/// The cell tree's buffer contents for `nodes` and `used` cells in use.
fn tree_words(nodes: &[CellNode], used: u32) -> Vec<CellNode> {
    let mut words = nodes.to_vec();
    words.push(CellNode { first_child: used, ..Default::default() });
    words
}

/// The nodes and the cells in use of the cell tree's buffer contents.
pub(super) fn tree_of_words(bytes: &[u8]) -> (Vec<CellNode>, u32) {
    let mut nodes: Vec<CellNode> = bytemuck::pod_collect_to_vec(bytes);
    let used = nodes.pop().map_or(0, |n| n.first_child);
    (nodes, used)
}

/// Whether one storage buffer can hold the guiding table's sampling rows
/// (`fits_one_buffer`): a table past the device's buffer range is refused as such.
pub(super) fn sampling_rows_fit(ctx: &Context, cfg: &crate::guide::GuideConfig) -> Result<(), GpuError> {
    fits_one_buffer(
        ctx,
        &format!(
            "the guiding table's sampling rows ({} cells x {} bins x {} orientations)",
            cfg.cells(),
            cfg.bins.count(),
            shared::NORMAL_CLASSES
        ),
        cfg.sampling_rows_bytes(),
        "use fewer cells (the scene's [guiding] resolution) or bins (--bins)",
    )
}

/// Groups of `group` invocations for `n` items of learn.comp's work, each
/// invocation stepping through `steps` of them, at most LEARN_MAX_GROUPS (the
/// shader steps through the rest): 65535 is the most that every device takes,
/// and door's table of 32x32 bins (1081344 entries) needed 67584 groups of 16
/// for its fold, which lavapipe's validation refused.
pub(super) fn learn_groups(n: u32, group: u32, steps: u32) -> u32 {
    n.div_ceil(group * steps).clamp(1, shared::LEARN_MAX_GROUPS)
}

/// Entries each fold invocation steps through on a CPU device
/// (`DeviceInfo::cpu`), 1 elsewhere: every group costs lavapipe a fixed start,
/// most of the learning pass of a small table, and a few cores need few groups
/// (docs/ARCHITECTURE.md, "Learning on a CPU device"). The rows' rebuild keeps a
/// group per row there too: lavapipe crashed where its groups stepped through
/// several rows, each with its barriers.
const CPU_FOLD_STEPS: u32 = 512;

/// Bytes of shared memory learn.comp's rows' rebuild takes for rows of `bins`
/// bins: the row staged (8 bytes a bin, `AliasBin`), its bins' probabilities in
/// units (4 a bin) and the row's total.
pub(super) const fn rebuild_shared_bytes(bins: u32) -> u32 {
    bins * (std::mem::size_of::<AliasBin>() as u32 + 4) + 4
}

// The largest row fits the shared memory every Vulkan device has.
const _: () = assert!(rebuild_shared_bytes(crate::guide::Bins::MAX_COUNT as u32) <= 16384);

impl Learning {
    /// Entries of the table (`GuideConfig::entries`).
    pub(super) fn entries(&self) -> u32 {
        self.cfg.entries() as u32
    }

    /// Phase 0 of learn.comp: fold the targets recorded since the last fold into the table.
    pub(super) fn cmd_fold(&self, cmd: crate::gpu::vk::CommandBuffer) {
        let push = self.push(0);
        let steps = if self.cpu_device { CPU_FOLD_STEPS } else { 1 };
        let groups = learn_groups(self.entries(), shared::LEARN_FOLD_GROUP, steps);
        self.fold.cmd_dispatch(cmd, [groups, 1, 1], bytemuck::bytes_of(&push));
    }

    /// Phase 1 of learn.comp: rebuild the sampling row of each cell and normal class.
    pub(super) fn cmd_build_rows(&self, cmd: crate::gpu::vk::CommandBuffer) {
        let push = self.push(1);
        let rows = self.cfg.sampling_rows() as u32;
        let groups = learn_groups(rows, 1, 1);
        self.build.cmd_dispatch(cmd, [groups, 1, 1], bytemuck::bytes_of(&push));
    }

    /// Phase 2 of learn.comp: the adaptive grid's leaves that have learned enough split.
    pub(super) fn cmd_refine(&self, cmd: crate::gpu::vk::CommandBuffer) {
        let push = self.push(2);
        self.refine.cmd_dispatch(cmd, [1, 1, 1], bytemuck::bytes_of(&push));
    }

    /// The table learns: the fold, the adaptive grid's splits where it is one, then
    /// the rows' rebuild, each after a barrier (`QTable::learn`'s order);
    /// `after(phase)` runs after the fold (0) and the rebuild (1), where a
    /// profiled frame stamps the time.
    pub(super) fn cmd_learn(&self, ctx: &Context, cmd: crate::gpu::vk::CommandBuffer, mut after: impl FnMut(u32)) {
        ctx.barrier(cmd);
        self.cmd_fold(cmd);
        after(0);
        if self.cfg.grid.adaptive() {
            ctx.barrier(cmd);
            self.cmd_refine(cmd);
        }
        ctx.barrier(cmd);
        self.cmd_build_rows(cmd);
        after(1);
    }

    /// Writes the cell tree: `nodes` and the cells in use.
    pub(super) fn upload_tree(&self, ctx: &Arc<Context>, nodes: &[CellNode], used: u32) -> Result<(), GpuError> {
        let staged = Buffer::with_data(ctx, "cell tree upload", bytes(&tree_words(nodes, used)), false)?;
        ctx.run_commands("upload cell tree", |cmd| staged.cmd_copy_to(cmd, &self.tree))
    }

    /// Starts the table from a learned field (`--guide-in`): Q, visits, the
    /// fraction states and the rows read copied in, then the sampling rows built
    /// from them by the learning pass (whose fold finds no targets).
    /// `crate::cpu::CpuRenderer::new` does the same through `GuideField::table`.
    pub(super) fn load_field(&self, ctx: &Arc<Context>, field: &crate::guide::GuideField) -> Result<(), GpuError> {
        let rows_read: Vec<u32> = field.rows_read.iter().map(|&r| r as u32).collect();
        let staged = [
            (Buffer::with_data(ctx, "Q upload", bytes(&field.q), false)?, &self.q),
            (Buffer::with_data(ctx, "visits upload", bytes(&field.visits), false)?, &self.visits),
            (
                Buffer::with_data(ctx, "fraction states upload", bytes(&field.fraction_states), false)?,
                &self.fraction_states,
            ),
            (Buffer::with_data(ctx, "rows read upload", bytes(&rows_read), false)?, &self.rows_read),
        ];
        let tree =
            Buffer::with_data(ctx, "cell tree upload", bytes(&tree_words(&field.nodes, field.used_cells)), false)?;
        ctx.run_commands("load learned field", |cmd| {
            for (from, to) in &staged {
                from.cmd_copy_to(cmd, to);
            }
            tree.cmd_copy_to(cmd, &self.tree);
            self.cmd_learn(ctx, cmd, |_| {});
        })
    }

    /// learn.comp's push constants for a phase.
    pub(super) fn push(&self, phase: u32) -> [u32; LEARN_PUSH_WORDS] {
        [
            phase,
            self.entries(),
            self.cfg.bins.count(),
            self.cfg.floor.to_bits(),
            self.cfg.bins.rows,
            self.cfg.bins.cols,
            self.cfg.cells(),
            self.cfg.fraction.to_bits(),
            self.cfg.learn_fraction as u32,
            self.cfg.rate_exponent.to_bits(),
            self.cfg.grid.adaptive() as u32,
            if self.cfg.adaptive_directions {
                *crate::guide::pool_sizes(&self.cfg.bins).last().unwrap_or(&1)
            } else {
                1
            },
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// learn.comp's dispatches stay within what every device takes.
    #[test]
    fn learn_dispatches_stay_within_the_group_limit() {
        assert_eq!(learn_groups(1, 64, 1), 1);
        assert_eq!(learn_groups(64 * 1000 + 1, 64, 1), 1001);
        assert_eq!(learn_groups(1_081_344, 16, 1), 65535);
        assert_eq!(learn_groups(u32::MAX, 64, 1), 65535);
        // A CPU device: a few groups, each stepping through its share.
        assert_eq!(learn_groups(524_288, 16, CPU_FOLD_STEPS), 64);
        assert_eq!(learn_groups(5, 16, CPU_FOLD_STEPS), 1);
    }
}
