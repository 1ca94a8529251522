//! Several GPUs in one render (`--gpus`): a [`MultiGpuRenderer`] drives one
//! [`GpuRenderer`] per device, each with its own context, queue and copy of the
//! scene, each from its own host thread, and is a `renderer::Renderer`, so that
//! the session's budget, progress, statistics and Ctrl-C work unchanged.
//!
//! The render goes in rounds (`render_round`): a round hands out frames from a
//! shared counter, so that a faster device takes more of them, at most
//! [`ROUND_FRAMES_PER_DEVICE`] per device on average and never past the frame
//! after which the table learns. Frame k draws the random numbers of frame k
//! whichever device traces it (`rng_frame`), so the devices' films add up to the
//! film of one device that traced the same frames. With guiding, a round that
//! reaches a learning point ends in a synchronization: every device's frame sums
//! are read back, added on the host and written to every device, which then runs
//! the same learning pass, so that all devices sample from the same table after
//! it. docs/ARCHITECTURE.md, "Several GPUs", tells the design and its time measure.

use super::*;
use crate::guide::FrameSums;
use crate::renderer::{FrameReport, Renderer, RoundReport};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Frames a round hands out per device, on average, at most: enough that a
/// faster device takes more frames within the round than a slower one, few
/// enough that progress, relMSE marks and Ctrl-C come every few frames.
pub const ROUND_FRAMES_PER_DEVICE: u32 = 4;

/// One device of a [`MultiGpuRenderer`].
struct Device {
    r: GpuRenderer,
    /// Its place in the contexts the renderer was made with.
    slot: usize,
    /// The image frames in its accumulation (their indices), rendered again by
    /// the others should the device be lost.
    image: Vec<u32>,
    /// Time of its last frame (timestamps, else wall clock), ms: the time budget
    /// takes its next frame to last as long.
    last_ms: Option<f64>,
    /// Its slowest frame so far, ms: how far past a time limit a frame slower
    /// than predicted can end at most.
    slowest_ms: f64,
    /// Frames it traced and the time they took, ms (`rlpt bench`).
    traced: u32,
    busy_ms: f64,
}

/// What a device did in one pass of a round.
#[derive(Default)]
struct Share {
    ms: f64,
    frames: u32,
    zero_paths: Option<u64>,
    /// The error that stopped it, and the frame it was tracing.
    failed: Option<(GpuError, u32)>,
}

/// What one device of a [`MultiGpuRenderer`] has done so far.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceStats {
    /// Its place in the contexts the renderer was made with.
    pub slot: usize,
    /// Its index in `rlpt devices`.
    pub index: usize,
    pub name: String,
    /// Frames it traced (learning frames included).
    pub frames: u32,
    /// Their time, ms: timestamps where the device has them, else wall clock.
    pub gpu_ms: f64,
    /// Its slowest frame, ms.
    pub slowest_frame_ms: f64,
    /// Whether it was lost and dropped from the render.
    pub lost: bool,
}

/// A render over several GPUs; see the module's description.
pub struct MultiGpuRenderer {
    devices: Vec<Device>,
    /// The devices lost so far, as they were when lost.
    lost: Vec<DeviceStats>,
    /// Frames handed out so far (learning frames included): the next new frame's index.
    next: u32,
    /// Image frames of lost devices, to be traced again by the others.
    redo: Vec<u32>,
    learning_frames: u32,
    /// Whether every device has timestamps (else the session times wall clock).
    timestamps: bool,
    /// Time of the last learning pass, ms: the time budget keeps room for the next.
    last_learn_ms: f64,
}

impl MultiGpuRenderer {
    /// A renderer of `scene` on each of `contexts` (several contexts may be on
    /// one physical device: the tests do so), built in parallel.
    pub fn new(contexts: &[Arc<Context>], scene: &PreparedScene) -> Result<MultiGpuRenderer, GpuError> {
        assert!(!contexts.is_empty(), "a render needs at least one GPU");
        let built: Vec<Result<GpuRenderer, GpuError>> = std::thread::scope(|s| {
            let handles: Vec<_> = contexts.iter().map(|ctx| s.spawn(move || GpuRenderer::new(ctx, scene))).collect();
            handles.into_iter().map(|h| h.join().expect("a renderer's set-up thread panicked")).collect()
        });
        let mut devices = Vec::with_capacity(built.len());
        for (slot, r) in built.into_iter().enumerate() {
            let mut r = r?;
            r.set_learned(crate::film::Learned::Keep);
            devices.push(Device {
                r,
                slot,
                image: Vec::new(),
                last_ms: None,
                slowest_ms: 0.0,
                traced: 0,
                busy_ms: 0.0,
            });
        }
        let learning_frames = devices[0].r.learning_frames();
        let timestamps = devices.iter().all(|d| d.r.context().info.timestamps);
        Ok(MultiGpuRenderer {
            devices,
            lost: Vec::new(),
            next: 0,
            redo: Vec::new(),
            learning_frames,
            timestamps,
            last_learn_ms: 0.0,
        })
    }

    /// Sets every device's frame offset (`GpuRenderer::set_frame_offset`).
    pub fn set_frame_offset(&mut self, offset: u32) {
        for d in &mut self.devices {
            d.r.set_frame_offset(offset);
        }
    }

    /// Devices still rendering.
    pub fn device_count(&self) -> usize {
        self.devices.len()
    }

    /// The renderer of device `i` of those still rendering (tests: to lose one).
    pub fn device_mut(&mut self, i: usize) -> &mut GpuRenderer {
        &mut self.devices[i].r
    }

    /// What each device did so far, those still rendering first, then those lost.
    pub fn device_stats(&self) -> Vec<DeviceStats> {
        let alive = self.devices.iter().map(|d| Self::stats(d, false));
        alive.chain(self.lost.iter().cloned()).collect()
    }

    fn stats(d: &Device, lost: bool) -> DeviceStats {
        let info = &d.r.context().info;
        DeviceStats {
            slot: d.slot,
            index: info.index,
            name: info.name.clone(),
            frames: d.traced,
            gpu_ms: d.busy_ms,
            slowest_frame_ms: d.slowest_ms,
            lost,
        }
    }

    /// The first device still rendering: its parameters and its table, which
    /// every device shares after each learning pass.
    pub fn first(&self) -> Option<&GpuRenderer> {
        self.devices.first().map(|d| &d.r)
    }

    /// Replaces every device's render parameters (`GpuRenderer::set_params`).
    /// A device lost meanwhile is dropped, as in a round.
    pub fn set_params(&mut self, params: &crate::layout::RenderParams) -> Result<(), GpuError> {
        self.on_each(|r| r.set_params(params))
    }

    /// Starts a new accumulation on every device (the viewer's camera moved);
    /// what guiding learned is kept, and the frames handed out go on from where
    /// they were, so that the new image's random numbers are fresh.
    pub fn reset_accumulation(&mut self) -> Result<(), GpuError> {
        self.on_each(|r| r.reset_accumulation())?;
        self.redo.clear();
        self.devices.iter_mut().for_each(|d| d.image.clear());
        Ok(())
    }

    /// Runs `f` on every device in turn, dropping those found lost; fails where
    /// none is left.
    fn on_each(&mut self, mut f: impl FnMut(&mut GpuRenderer) -> Result<(), GpuError>) -> Result<(), GpuError> {
        for i in (0..self.devices.len()).rev() {
            match f(&mut self.devices[i].r) {
                Ok(()) => {}
                Err(GpuError::DeviceLost(detail)) => self.drop_lost(i, &detail, None),
                Err(e) => return Err(e),
            }
        }
        if self.devices.is_empty() {
            return Err(Self::all_lost());
        }
        Ok(())
    }

    /// Each device's learned table (None without guiding), in device order.
    pub fn device_tables(&self) -> Result<Vec<Option<QTable>>, GpuError> {
        self.devices.iter().map(|d| d.r.table()).collect()
    }

    /// The end (exclusive) of the next round's new frames: at most `max` and
    /// [`ROUND_FRAMES_PER_DEVICE`] per device, and no frame past the next one
    /// after which the table learns.
    fn round_end(&self, max: u32) -> u32 {
        let cap = ROUND_FRAMES_PER_DEVICE * self.devices.len() as u32;
        let end = self.next.saturating_add(max.min(cap));
        let r = &self.devices[0].r;
        (self.next..end).find(|&k| r.learns_after(k)).map_or(end, |k| k + 1)
    }

    /// Drops device `i`, lost: a warning on stderr, and its image frames (which
    /// a lost device's film cannot be read back for) go to be traced again.
    fn drop_lost(&mut self, i: usize, detail: &str, in_flight: Option<u32>) {
        let d = self.devices.remove(i);
        let info = &d.r.context().info;
        let mut again = d.image.clone();
        again.extend(in_flight.filter(|&k| k >= self.learning_frames));
        eprintln!(
            "warning: GPU {} \"{}\" stopped responding (device lost: {detail}) after {} frame(s); the render goes on \
             with the other {} GPU(s), which trace its {} image frame(s) again",
            info.index,
            info.name,
            d.traced,
            self.devices.len(),
            again.len()
        );
        self.lost.push(Self::stats(&d, true));
        self.redo.extend(again);
    }

    /// Each device in its own thread traces frames until none are left: first
    /// the frames of lost devices, then new frames from `range`, taken from a
    /// shared counter; a device stops where its next frame, taken to last as long
    /// as its last (plus `reserve_ms`, the learning pass that ends the round),
    /// would end past `time_left` ms. Returns the pass's time (the
    /// busiest device's), its zero-radiance paths and the new frames handed out;
    /// drops the devices lost on the way.
    fn pass(
        &mut self,
        range: std::ops::Range<u32>,
        time_left: Option<f64>,
        reserve_ms: f64,
    ) -> Result<(f64, Option<u64>, u32), GpuError> {
        let counter = AtomicU32::new(range.start);
        let redo = Mutex::new(std::mem::take(&mut self.redo));
        let (timestamps, learning_frames) = (self.timestamps, self.learning_frames);
        // A device that traced nothing yet is taken to be as slow as the slowest
        // that did: only the render's first frames start unjudged.
        let slowest = self.devices.iter().filter_map(|d| d.last_ms).reduce(f64::max);
        let shares: Vec<Share> = std::thread::scope(|s| {
            let handles: Vec<_> = self
                .devices
                .iter_mut()
                .map(|d| {
                    let (counter, redo, range) = (&counter, &redo, range.clone());
                    s.spawn(move || {
                        let mut share = Share::default();
                        loop {
                            if let (Some(left), Some(last)) = (time_left, d.last_ms.or(slowest)) {
                                if share.ms + last + reserve_ms > left {
                                    break;
                                }
                            }
                            let again = redo.lock().unwrap_or_else(|e| e.into_inner()).pop();
                            let k = match again {
                                Some(k) => k,
                                None => match counter.fetch_add(1, Ordering::SeqCst) {
                                    k if k < range.end => k,
                                    _ => break,
                                },
                            };
                            let start = Instant::now();
                            match d.r.trace_frame(k) {
                                Ok(t) => {
                                    let ms =
                                        if timestamps { t.total_ms() } else { start.elapsed().as_secs_f64() * 1e3 };
                                    share.ms += ms;
                                    share.frames += 1;
                                    share.zero_paths = t.zero_paths.map(|z| z + share.zero_paths.unwrap_or(0));
                                    d.last_ms = Some(ms);
                                    d.slowest_ms = d.slowest_ms.max(ms);
                                    d.traced += 1;
                                    d.busy_ms += ms;
                                    if k >= learning_frames {
                                        d.image.push(k);
                                    }
                                }
                                Err(e) => {
                                    share.failed = Some((e, k));
                                    break;
                                }
                            }
                        }
                        share
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().expect("a GPU's render thread panicked")).collect()
        });
        // Frames that no device took (time ran out) wait for the next round.
        self.redo.extend(redo.into_inner().unwrap_or_else(|e| e.into_inner()));
        let handed = counter.load(Ordering::SeqCst).min(range.end) - range.start;
        let ms = shares.iter().map(|s| s.ms).fold(0.0, f64::max);
        let zero_paths = shares.iter().filter_map(|s| s.zero_paths).reduce(|a, b| a + b);
        for (i, share) in shares.into_iter().enumerate().rev() {
            match share.failed {
                None => {}
                Some((GpuError::DeviceLost(detail), k)) => self.drop_lost(i, &detail, Some(k)),
                Some((e, _)) => return Err(e),
            }
        }
        Ok((ms, zero_paths, handed))
    }

    /// The learning pass of every device at once: their frame sums read back and
    /// added on the host (in device order), written to each and learned from.
    /// Returns the pass's time (the slowest device's).
    fn learn_together(&mut self) -> Result<f64, GpuError> {
        let sums: Vec<Result<Option<FrameSums>, GpuError>> = std::thread::scope(|s| {
            let handles: Vec<_> = self.devices.iter_mut().map(|d| s.spawn(move || d.r.frame_sums())).collect();
            handles.into_iter().map(|h| h.join().expect("a GPU's thread panicked")).collect()
        });
        let mut total: Option<FrameSums> = None;
        for (i, r) in sums.into_iter().enumerate().rev() {
            match r {
                Ok(Some(s)) => match &mut total {
                    None => total = Some(s),
                    Some(t) => t.add_all(&s),
                },
                Ok(None) => {}
                Err(GpuError::DeviceLost(detail)) => self.drop_lost(i, &detail, None),
                Err(e) => return Err(e),
            }
        }
        let Some(total) = total else { return Ok(0.0) };
        let learned: Vec<Result<f64, GpuError>> = std::thread::scope(|s| {
            let total = &total;
            let handles: Vec<_> = self.devices.iter_mut().map(|d| s.spawn(move || d.r.learn_from(total))).collect();
            handles.into_iter().map(|h| h.join().expect("a GPU's thread panicked")).collect()
        });
        let mut ms = 0.0f64;
        for (i, r) in learned.into_iter().enumerate().rev() {
            match r {
                Ok(t) => ms = ms.max(t),
                Err(GpuError::DeviceLost(detail)) => self.drop_lost(i, &detail, None),
                Err(e) => return Err(e),
            }
        }
        Ok(ms)
    }

    /// Passes over the frames of lost devices until none are left, none fits the
    /// time left, or no device is left. Returns their time and zero-radiance paths.
    fn trace_again(&mut self, time_left: Option<f64>) -> Result<(f64, Option<u64>), GpuError> {
        let (mut ms, mut zero) = (0.0, None);
        while !self.redo.is_empty() && !self.devices.is_empty() {
            let before = self.redo.len();
            let (t, z, _) = self.pass(0..0, time_left.map(|l| l - ms), 0.0)?;
            ms += t;
            zero = add_counts(zero, z);
            if self.redo.len() >= before && t == 0.0 {
                break;
            }
        }
        Ok((ms, zero))
    }

    fn all_lost() -> GpuError {
        GpuError::DeviceLost("every GPU of the render was lost".into())
    }
}

fn add_counts(a: Option<u64>, b: Option<u64>) -> Option<u64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    }
}

/// Adds `b` to `a`, films of the same render: the sums add, and the spread of
/// the frames' means combines by Chan's formula, as if one device had traced
/// both films' frames. A film of no frames adds nothing.
pub fn add_film(a: &mut Film, b: &Film) {
    assert_eq!((a.width, a.height), (b.width, b.height), "films of one render");
    if b.frames == 0 {
        return;
    }
    if a.frames == 0 {
        *a = b.clone();
        return;
    }
    let per_frame = shared::SAMPLES_PER_FRAME as f64;
    // Frames weighed by a race (one GPU's alone today) add their weights.
    let weight = (a.weight.is_some() || b.weight.is_some()).then(|| a.weight_frames() + b.weight_frames());
    let (na, nb) = (a.weight_frames(), b.weight_frames());
    for (p, q) in a.pixels.iter_mut().zip(&b.pixels) {
        for c in 0..3 {
            let delta = q.sum[c] as f64 / (per_frame * nb) - p.sum[c] as f64 / (per_frame * na);
            p.m2_frame_mean[c] =
                (p.m2_frame_mean[c] as f64 + q.m2_frame_mean[c] as f64 + delta * delta * na * nb / (na + nb)) as f32;
            p.sum[c] += q.sum[c];
        }
        p.sum[3] += q.sum[3];
    }
    a.frames += b.frames;
    a.weight = weight;
}

impl Renderer for MultiGpuRenderer {
    fn render_frame(&mut self) -> Result<FrameReport, GpuError> {
        let r = self.render_round(1, None)?;
        Ok(FrameReport {
            gpu_ms: r.gpu_ms,
            learn_ms: r.learn_ms,
            zero_paths: r.zero_paths,
            kind: None,
            variance: None,
            weight: None,
        })
    }

    /// A round: new frames up to the round's end (`round_end`), handed out to
    /// the devices as they finish, then those of any device lost meanwhile; where
    /// the round's last frame is one after which the table learns, every device
    /// learns from all devices' sums. Its time is the busiest device's plus the
    /// slowest learning pass. `time_up`: whether no device's next frame fits the
    /// time left.
    fn render_round(&mut self, max: u32, time_left_ms: Option<f64>) -> Result<RoundReport, GpuError> {
        if self.devices.is_empty() {
            return Err(Self::all_lost());
        }
        let end = self.round_end(max);
        let learns = self.devices[0].r.learns_after(end - 1);
        let reserve = if learns { self.last_learn_ms } else { 0.0 };
        let (mut ms, mut zero, handed) = self.pass(self.next..end, time_left_ms, reserve)?;
        self.next += handed;
        let (t, z) = self.trace_again(time_left_ms.map(|l| l - ms))?;
        (ms, zero) = (ms + t, add_counts(zero, z));
        let mut learn_ms = 0.0;
        if self.next == end && learns && !self.devices.is_empty() {
            self.last_learn_ms = self.learn_together()?;
            learn_ms = self.last_learn_ms;
            ms += self.last_learn_ms;
            let (t, z) = self.trace_again(time_left_ms.map(|l| l - ms))?;
            (ms, zero) = (ms + t, add_counts(zero, z));
        }
        if self.devices.is_empty() {
            return Err(Self::all_lost());
        }
        let slowest = self.devices.iter().filter_map(|d| d.last_ms).reduce(f64::max);
        let time_up =
            time_left_ms.map(|left| self.devices.iter().all(|d| d.last_ms.or(slowest).is_some_and(|l| l > left - ms)));
        Ok(RoundReport {
            frames: handed,
            gpu_ms: self.timestamps.then_some(ms),
            learn_ms: self.timestamps.then_some(learn_ms),
            zero_paths: zero,
            time_up: Some(time_up.unwrap_or(false)),
            kind: None,
            variance: None,
            weight: None,
            cut_spp: None,
        })
    }

    /// Image frames of every device (learning frames until the image starts).
    fn image_frames(&self) -> u32 {
        self.in_film().map(|d| d.r.frames()).sum()
    }

    /// The devices' films, read back in parallel, added in device order ([`add_film`]).
    fn film(&self) -> Result<Film, GpuError> {
        let read: Vec<Result<Film, GpuError>> = std::thread::scope(|s| {
            let handles: Vec<_> = self.in_film().map(|d| s.spawn(|| d.r.film())).collect();
            handles.into_iter().map(|h| h.join().expect("a GPU's thread panicked")).collect()
        });
        let mut films = read.into_iter();
        let mut film = films.next().ok_or_else(Self::all_lost)??;
        for f in films {
            add_film(&mut film, &f?);
        }
        Ok(film)
    }

    fn device_name(&self) -> String {
        let names: Vec<String> =
            self.devices.iter().map(|d| format!("{}: {}", d.r.context().info.index, d.r.context().info.name)).collect();
        format!("{} GPUs ({})", self.devices.len(), names.join(", "))
    }

    fn timestamps(&self) -> bool {
        self.timestamps
    }

    /// The table every device learned at the last learning pass (the first
    /// device's), with the rows read by any device since.
    /// Every device learns from all devices' pending sums at once.
    fn learn_pending(&mut self) -> Result<(), GpuError> {
        self.learn_together().map(|_| ())
    }

    fn table(&self) -> Result<Option<QTable>, GpuError> {
        let mut tables = self.devices.iter().map(|d| d.r.table());
        let Some(mut table) = tables.next().ok_or_else(Self::all_lost)?? else { return Ok(None) };
        for t in tables {
            if let Some(t) = t? {
                for (a, b) in table.rows_read.iter_mut().zip(t.rows_read) {
                    *a |= b;
                }
            }
        }
        Ok(Some(table))
    }
}

impl MultiGpuRenderer {
    /// The devices whose accumulation is part of the film: all of them until the
    /// image starts, then those that traced an image frame (a device that traced
    /// only learning frames so far holds those, which are not part of the image).
    fn in_film(&self) -> impl Iterator<Item = &Device> {
        let image = self.next > self.learning_frames;
        self.devices.iter().filter(move |d| !image || !d.r.holds_learning_frames())
    }
}
