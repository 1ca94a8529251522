//! What [`MultiGpuRenderer`](super::MultiGpuRenderer) asks of each device's
//! [`GpuRenderer`]: a frame of a given index, traced without learning, and the
//! learning pass split in two, the frame sums read back and, once every
//! device's are added on the host, written to each device and learned from.

use super::*;
use crate::guide::FrameSums;

impl GpuRenderer {
    /// Traces frame `frame` of the render (its random numbers `rng_frame(frame, ..)`,
    /// its recording rows `RecordSchedule::records(frame, ..)`) into the
    /// accumulation, whatever frames this renderer traced before, and does not
    /// learn: the targets wait in the frame sums for [`GpuRenderer::learn_from`].
    pub fn trace_frame(&mut self, frame: u32) -> Result<FrameTimings, GpuError> {
        assert!(self.race.is_none(), "frames handed out by index are every one guided (no FrameRace)");
        self.counts.frames_traced = frame;
        self.counts.guided_traced = frame;
        self.submit_frames(1, false)
    }

    /// Whether the accumulation holds learning frames, which the first image frame
    /// replaces: such a device has no image frame yet.
    pub fn holds_learning_frames(&self) -> bool {
        self.counts.accum_holds_learning
    }

    /// The targets, fraction gradients and rows read recorded since the table
    /// last learned (None without guiding).
    pub fn frame_sums(&mut self) -> Result<Option<FrameSums>, GpuError> {
        let Some(l) = &mut self.learning else { return Ok(None) };
        l.make_exchange(&self.ctx)?;
        let l = &*l;
        let [rs, rc, rr] = &l.exchange.as_ref().expect("made above").readback;
        self.ctx.run_commands("read frame sums", |cmd| {
            self.ctx.barrier(cmd);
            l.sums.cmd_copy_to(cmd, rs);
            l.counts.cmd_copy_to(cmd, rc);
            l.rows_read.cmd_copy_to(cmd, rr);
        })?;
        // Entries' sums and counts, then the cells' fraction gradients and their counts.
        let entries = l.entries() as usize;
        let mut sums: Vec<f32> = bytemuck::pod_collect_to_vec(&rs.read()[..l.sums.size as usize]);
        let mut counts: Vec<u32> = bytemuck::pod_collect_to_vec(&rc.read()[..l.counts.size as usize]);
        let rows_read: Vec<u32> = bytemuck::pod_collect_to_vec(&rr.read()[..l.rows_read.size as usize]);
        let (gradients, gradient_counts) = (sums.split_off(entries), counts.split_off(entries));
        Ok(Some(FrameSums {
            sums,
            counts,
            gradients,
            gradient_counts,
            rows_read: rows_read.into_iter().map(|r| r != 0).collect(),
        }))
    }

    /// Replaces the frame sums and the rows read with `sums` (every device's,
    /// added) and runs the learning pass (`learn.comp`'s fold and rebuild) on
    /// them: devices that start from the same table and learn from the same sums
    /// hold the same table after it. Returns the pass's GPU time in ms (0 where
    /// the queue has no timestamps).
    pub fn learn_from(&mut self, sums: &FrameSums) -> Result<f64, GpuError> {
        let Some(l) = &mut self.learning else { return Ok(0.0) };
        assert_eq!(
            4 * (sums.sums.len() + sums.gradients.len()) as u64,
            l.sums.size,
            "frame sums of this table's shape"
        );
        l.make_exchange(&self.ctx)?;
        let [us, uc, ur] = &mut l.exchange.as_mut().expect("made above").upload;
        let n = 4 * sums.sums.len();
        us.write_at(0, bytes(&sums.sums));
        us.write_at(n, bytes(&sums.gradients));
        uc.write_at(0, bytes(&sums.counts));
        uc.write_at(n, bytes(&sums.gradient_counts));
        let rows_read: Vec<u32> = sums.rows_read.iter().map(|&r| r as u32).collect();
        ur.write_at(0, bytes(&rows_read));
        let l = &*l;
        let x = l.exchange.as_ref().expect("made above");
        let staged = [(&x.upload[0], &l.sums), (&x.upload[1], &l.counts), (&x.upload[2], &l.rows_read)];
        let timestamps = self.ctx.info.timestamps;
        self.ctx.run_commands("learn from every device's sums", |cmd| {
            if timestamps {
                self.timer.cmd_reset(cmd);
            }
            self.ctx.barrier(cmd);
            for (from, to) in &staged {
                from.cmd_copy_to(cmd, to);
            }
            if timestamps {
                self.timer.cmd_stamp(cmd, 0);
            }
            l.cmd_learn(&self.ctx, cmd, |_| {});
            if timestamps {
                self.timer.cmd_stamp(cmd, 1);
            }
        })?;
        if !timestamps {
            return Ok(0.0);
        }
        let s = self.timer.read(2)?;
        Ok(self.timer.ticks_to_ms(s[0], s[1]))
    }

    /// Whether the table learns after frame `frame` (`RecordSchedule::learns_after`;
    /// false without guiding).
    pub fn learns_after(&self, frame: u32) -> bool {
        self.learning.as_ref().is_some_and(|l| l.schedule.learns_after(frame))
    }

    /// The learning frames of this render (`GuideConfig::learning_frames`; 0 without guiding).
    pub fn learning_frames(&self) -> u32 {
        self.learning.as_ref().map_or(0, |l| l.cfg.learning_frames)
    }

    /// Makes the device be lost when it would trace a frame of index `frame` or
    /// later (tests: [`DEVICE_LOST_HOOK`] for one device of several).
    pub fn lose_device_at(&mut self, frame: Option<u32>) {
        self.lose_device_after = frame;
    }
}
