//! `rlpt view`: a window that shows the render converge. Each redraw adds one
//! frame (64 samples per pixel) on the GPU, or a round of frames on several
//! (`--gpus`: the first presents, all render), by a `session::Session` as
//! `rlpt render` does; runs the display pass (`glsl/tonemap.comp`) and blits
//! the result, letterboxed, into a swapchain image. The camera can be moved (the accumulation restarts, what guiding
//! learned stays: it lives in world space), guiding and NEE switched, and the
//! learned distribution of the voxel under the cursor shown as an inset.
//!
//! The render size is fixed (the scene's, or `--width`/`--height`); the window
//! scales it to fit. Vulkan stays in `crate::gpu`; this module is winit and state.

mod camera;
mod frames;
mod input;
mod inset;
mod modes;
mod timings;

pub use camera::ViewCamera;
pub use inset::{inset_texels, letterbox, window_to_pixel};

use frames::{lost, MergeClock};
use modes::{make_renderer, ModeRenderer};
use timings::RecentFrames;

use crate::gpu::{Acquired, Context, ContextOptions, Swapchain, WindowTarget};
use crate::guide::{GuideField, GuidingMode};
use crate::math::geometry::intersect;
use crate::options::RenderOptions;
use crate::render::display::{Display, Inset, SharedAccumulation};
use crate::scene::Scene;
use crate::session::Renderer;
use crate::shared;
use anyhow::{anyhow, bail, Context as _, Result};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

/// What `rlpt view` was asked to do.
pub struct ViewOptions {
    pub scene_path: PathBuf,
    pub scene: Scene,
    /// Size, bounces, seed, NEE and the initial guiding mode.
    pub render: RenderOptions,
    /// The GPUs, one context each: the first presents, and all render.
    pub contexts: Vec<ContextOptions>,
    /// Scripted mode: render this many frames, save `screenshot`, exit.
    pub frames: Option<u32>,
    /// Where the scripted mode saves what the window shows (.png; the linear
    /// image goes beside it as .exr).
    pub screenshot: Option<PathBuf>,
    /// Scripted mode: resize the window to this size after the first frame.
    pub resize: Option<(u32, u32)>,
    /// A learned field (`--guide-in`, read from the path) that each guided mode
    /// of its bins starts from; modes of other bins start blank.
    pub guide_in: Option<(PathBuf, GuideField)>,
}

/// The controls, as `H` prints them.
pub const CONTROLS: &str = "\
controls:
  left drag   orbit around the point at the centre of the view
  W A S D     move forward, left, back, right
  Q E         move down, up
  wheel       field of view
  R           restart accumulation (guiding keeps what it learned)
  G           guiding: off -> octant -> sphere
  N           next-event estimation on/off
  V           show the learned light distribution of the voxel under the cursor
  Space       pause / resume
  P           save PNG and EXR of what is shown
  H           print these controls
  Esc         quit";

/// Opens the window and runs until it is closed (or the scripted frames are done).
pub fn run(options: ViewOptions) -> Result<()> {
    if let Some(s) = &options.screenshot {
        // The EXR is written beside the PNG, with the same name.
        crate::output::check_output_path("--screenshot", s, Some(&["png"])).map_err(anyhow::Error::msg)?;
    }
    if options.frames.is_some() != options.screenshot.is_some() {
        bail!("--frames and --screenshot go together: the scripted mode renders N frames and saves what it shows");
    }
    if options.resize.is_some() && options.frames.is_none() {
        bail!("--resize is part of the scripted mode: give --frames and --screenshot too");
    }
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow!(
            "cannot open a window: {e}. `rlpt view` needs an X11 or Wayland display (is DISPLAY or \
             WAYLAND_DISPLAY set?); without one, use `rlpt render`"
        )
    })?;
    let mut app = App { options, viewer: None, error: None };
    event_loop.run_app(&mut app).map_err(|e| anyhow!("the window's event loop failed: {e}"))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App {
    options: ViewOptions,
    viewer: Option<Viewer>,
    error: Option<anyhow::Error>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        // Free the GPU objects before the event loop (and the window) goes.
        self.viewer = None;
        event_loop.exit();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.viewer.is_some() || self.error.is_some() {
            return;
        }
        match Viewer::new(event_loop, &self.options) {
            Ok(v) => {
                v.window.request_redraw();
                self.viewer = Some(v);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(v) = self.viewer.as_mut() else { return };
        match v.handle(event, &self.options) {
            Ok(Flow::Continue) => {}
            Ok(Flow::Exit) => {
                let result = v.finish();
                self.viewer = None;
                match result {
                    Ok(()) => event_loop.exit(),
                    Err(e) => self.fail(event_loop, e),
                }
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        // Redraw continuously while there is work (frames to add, a resize to finish);
        // otherwise sleep until an event: no busy loop when paused or minimised.
        event_loop.set_control_flow(ControlFlow::Wait);
        if let Some(v) = &self.viewer {
            if v.hidden() {
                // Not every window system says when a minimised window comes back:
                // look four times a second (a wait, not a busy loop).
                event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + Duration::from_millis(250)));
            } else if v.wants_frames(&self.options) {
                v.window.request_redraw();
            }
        }
    }
}

enum Flow {
    Continue,
    Exit,
}

struct Viewer {
    // Fields drop in order: GPU objects first, then the context, the window last
    // (the context's surface refers to it).
    display: Display,
    /// With several GPUs, their film merged on the presenting one, which the display shows.
    shared: Option<SharedAccumulation>,
    swapchain: Option<Swapchain>,
    swapchain_dirty: bool,
    renderers: Vec<ModeRenderer>,
    current: usize,
    /// The rendering contexts: `ctx` (which presents) first.
    contexts: Vec<Arc<Context>>,
    ctx: Arc<Context>,
    window: Arc<Window>,

    scene: Scene,
    base: RenderOptions,
    guide_in: Option<(PathBuf, GuideField)>,
    scene_name: String,
    camera: ViewCamera,
    nee: bool,
    paused: bool,
    inset_on: bool,
    inset_shown: Option<u32>,
    inset_checked: Instant,
    cursor: Option<(f64, f64)>,
    drag_from: Option<(f64, f64)>,
    recent: RecentFrames,
    merge: MergeClock,
    /// Frames rendered in this window (all modes), for the scripted mode.
    rendered: u32,
    resize_requested: bool,
    resized_at: Option<(u32, u32)>,
    started: Instant,
    occluded: bool,
    scripted_frames: Option<u32>,
}

impl Viewer {
    fn new(event_loop: &ActiveEventLoop, options: &ViewOptions) -> Result<Viewer> {
        let (w, h) = (options.render.width, options.render.height);
        let scene_name = options
            .scene_path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| options.scene_path.display().to_string());
        let attributes = Window::default_attributes()
            .with_title(format!("rlpt: {scene_name}"))
            .with_inner_size(PhysicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attributes).context("cannot create the window")?);
        let display = window.display_handle().map_err(|e| anyhow!("the window has no display handle: {e}"))?.as_raw();
        let handle = window.window_handle().map_err(|e| anyhow!("the window has no window handle: {e}"))?.as_raw();
        // SAFETY: the window outlives the context: both live in the Viewer, whose fields
        // drop in declaration order, GPU objects and context before `window`; `fail`
        // and exit drop the Viewer before the event loop ends.
        let target = unsafe { WindowTarget::new(display, handle) };
        let (presenting, others) = options.contexts.split_first().expect("at least one GPU");
        let mut ctx_options = presenting.clone();
        ctx_options.window = Some(target);
        let ctx = Context::new(&ctx_options)?;
        let mut contexts = vec![ctx.clone()];
        for o in others {
            contexts.push(Context::new(o)?);
        }
        let first = make_renderer(
            &contexts,
            &options.scene,
            &options.render,
            options.render.guiding,
            options.guide_in.as_ref(),
        )?;
        let size = window.inner_size();
        let swapchain = Swapchain::new(&ctx, (size.width, size.height), None)?;
        let srgb = swapchain.as_ref().is_some_and(|s| s.is_srgb());
        let shared = match contexts.len() {
            1 => None,
            _ => Some(SharedAccumulation::new(&ctx, w, h)?),
        };
        let shown = match &shared {
            Some(s) => s.buffer(),
            None => first.renderer.first().ok_or_else(lost)?.accumulation(),
        };
        let display = Display::new(&ctx, shown, w, h, srgb)?;
        let camera = ViewCamera::new(&options.scene.camera, &first.prepared);
        if let Some(s) = &swapchain {
            eprintln!(
                "rlpt view: {} ({}), {}x{} render in a {}x{} window, present mode {:?}",
                ctx.info.name, ctx.info.driver, w, h, s.extent.width, s.extent.height, s.present_mode
            );
        }
        if shared.is_some() {
            eprintln!("rlpt view: rendering on {}; the first presents", first.renderer.device_name());
        }
        if options.frames.is_none() {
            println!("{CONTROLS}");
        }
        Ok(Viewer {
            display,
            shared,
            swapchain,
            swapchain_dirty: false,
            renderers: vec![first],
            current: 0,
            contexts,
            ctx,
            window,
            scene: options.scene.clone(),
            base: options.render.clone(),
            guide_in: options.guide_in.clone(),
            scene_name,
            camera,
            nee: options.render.nee,
            paused: false,
            inset_on: false,
            inset_shown: None,
            inset_checked: Instant::now(),
            cursor: None,
            drag_from: None,
            recent: RecentFrames::default(),
            merge: MergeClock::default(),
            rendered: 0,
            resize_requested: false,
            resized_at: None,
            started: Instant::now(),
            occluded: false,
            scripted_frames: options.frames,
        })
    }

    /// Minimised or fully covered: nothing would be seen, so nothing is rendered
    /// (except in the scripted mode, which must finish).
    fn hidden(&self) -> bool {
        self.scripted_frames.is_none()
            && (self.occluded || self.window.is_minimized() == Some(true) || self.window.inner_size().width == 0)
    }

    /// True while redraws should follow each other without waiting for events.
    fn wants_frames(&self, options: &ViewOptions) -> bool {
        if self.swapchain.is_none() && !self.swapchain_dirty {
            return false; // no area: wait for a resize
        }
        match options.frames {
            Some(n) => self.rendered < n || (options.resize.is_some() && self.resized_at.is_none()),
            None => !self.paused || self.swapchain_dirty,
        }
    }

    /// Writes the camera and NEE into the current renderer (every GPU's) and
    /// restarts its accumulation.
    fn apply_params(&mut self) -> Result<()> {
        let cam = self.camera.to_scene_camera();
        let nee = self.nee;
        let r = &mut self.renderers[self.current].renderer;
        let mut p = *r.first().ok_or_else(lost)?.params();
        p.set_camera(&cam);
        p.set_nee(nee);
        r.set_params(&p)?;
        self.restart()
    }

    /// Starts a new accumulation on every GPU; guiding keeps what it learned.
    fn restart(&mut self) -> Result<()> {
        self.renderers[self.current].renderer.reset_accumulation()?;
        self.merge.restarted();
        self.recent.clear();
        self.inset_shown = None;
        self.window.request_redraw();
        Ok(())
    }

    /// Shows or hides the inset of the voxel under the cursor; re-reads the table at
    /// most four times a second (or at once with `force`).
    fn update_inset(&mut self, force: bool) -> Result<()> {
        if !force && self.inset_checked.elapsed() < Duration::from_millis(250) {
            return Ok(());
        }
        self.inset_checked = Instant::now();
        let mr = &self.renderers[self.current];
        let target = if !self.inset_on { None } else { self.voxel_under_cursor(mr) };
        let Some((cell, bins)) = target else {
            self.inset_shown = None;
            return self.display.set_inset(None).map_err(|e| anyhow!(e));
        };
        let first = mr.renderer.first().ok_or_else(lost)?;
        let Some(values) = first.cell_values(cell)? else { return Ok(()) };
        let (w, h) = self.display.size();
        let iw = (w / 2).min(256).max(bins.cols);
        let ih = (iw / 2).min(h / 2).max(bins.rows);
        if (iw as u64) * (ih as u64) * 4 > (w as u64) * (h as u64) || iw + 2 > w || ih + 2 > h {
            return self.display.set_inset(None).map_err(|e| anyhow!(e));
        }
        let texels = inset_texels(&values, bins, iw, ih);
        let inset = Inset { x: 2, y: 2, width: iw, height: ih, texels };
        self.display.set_inset(Some(&inset)).map_err(|e| anyhow!(e))?;
        if self.inset_shown != Some(cell) {
            let g = mr.prepared.guide.as_ref().map(|c| c.grid);
            if let Some(g) = g {
                let (x, y, z) = (cell % g.res[0], (cell / g.res[0]) % g.res[1], cell / (g.res[0] * g.res[1]));
                let best = values.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map(|(i, _)| i as u32);
                let dir = best.map(|b| bins.center(b)).unwrap_or_default();
                // Every learned row of a cell has the cell's fraction.
                let fraction = first.cell_fractions(cell)?.unwrap_or_default().into_iter().fold(0.0f32, f32::max);
                let fraction =
                    if fraction > 0.0 { format!("guided fraction {fraction:.2}") } else { "nothing learned".into() };
                println!(
                    "voxel ({x}, {y}, {z}): brightest bin towards ({:.2}, {:.2}, {:.2}), Q max {:.4}, {fraction}",
                    dir.x,
                    dir.y,
                    dir.z,
                    values.iter().cloned().fold(0.0f32, f32::max)
                );
            }
            self.inset_shown = Some(cell);
        }
        Ok(())
    }

    /// The voxel seen through the pixel under the cursor and the bins of its table.
    fn voxel_under_cursor(&self, mr: &ModeRenderer) -> Option<(u32, crate::guide::Bins)> {
        let cfg = mr.prepared.guide.as_ref()?;
        let (cx, cy) = self.cursor?;
        let sc = self.swapchain.as_ref()?;
        let (w, h) = self.display.size();
        let rect = letterbox((w, h), (sc.extent.width, sc.extent.height));
        let (px, py) = window_to_pixel(rect, (w, h), (cx, cy))?;
        let (o, d) = crate::camera::camera_ray(mr.renderer.first()?.params(), px, py, [0.5, 0.5]);
        let hit = intersect(&mr.prepared, o, d, f32::INFINITY)?;
        Some((mr.renderer.first()?.cell_at(hit.p).ok()??, cfg.bins))
    }

    fn recreate_swapchain(&mut self) -> Result<()> {
        let size = self.window.inner_size();
        let old = self.swapchain.take();
        let new = Swapchain::new(&self.ctx, (size.width, size.height), old.as_ref())?;
        drop(old);
        self.swapchain_dirty = false;
        if let Some(s) = &new {
            if s.is_srgb() != self.display_is_srgb() {
                let (w, h) = self.display.size();
                self.display = Display::new(&self.ctx, self.shown_accumulation()?, w, h, s.is_srgb())?;
            }
            eprintln!("rlpt view: swapchain recreated at {}x{}", s.extent.width, s.extent.height);
            self.resized_at = Some((s.extent.width, s.extent.height));
        }
        self.swapchain = new;
        Ok(())
    }

    fn display_is_srgb(&self) -> bool {
        self.display.image.format == crate::gpu::vk::Format::R8G8B8A8_SRGB
    }

    fn redraw(&mut self, options: &ViewOptions) -> Result<Flow> {
        if self.swapchain_dirty || self.swapchain.is_none() {
            self.recreate_swapchain()?;
        }
        if self.swapchain.is_none() {
            return Ok(Flow::Continue); // minimised
        }
        let render_more = match options.frames {
            Some(n) => self.rendered < n,
            None => !self.paused,
        };
        if render_more {
            let left = options.frames.map_or(u32::MAX, |n| n - self.rendered);
            self.trace(left)?;
        }
        // With several GPUs, the window is drawn where their film was merged, or
        // where nothing more comes this redraw (paused, exposed, or scripted frames done).
        let done = options.frames.is_some_and(|n| self.rendered >= n);
        if !self.merge_if_due(!render_more || done)? {
            return Ok(Flow::Continue);
        }
        if self.inset_on {
            self.update_inset(false)?;
        }
        let sc = self.swapchain.as_ref().expect("checked above");
        let index = match sc.acquire()? {
            Acquired::Image { index, .. } => index,
            Acquired::OutOfDate => {
                self.swapchain_dirty = true;
                return Ok(Flow::Continue);
            }
        };
        let (w, h) = self.display.size();
        let rect = letterbox((w, h), (sc.extent.width, sc.extent.height));
        let frames = self.shown_frames();
        let display = &self.display;
        let recreate = sc.draw_and_present(index, &display.image, rect, |cmd| display.cmd_draw(cmd, frames))?;
        if recreate {
            self.swapchain_dirty = true;
        }
        self.update_title();

        if let Some(n) = options.frames {
            if self.rendered == 1 && !self.resize_requested {
                if let Some((rw, rh)) = options.resize {
                    self.resize_requested = true;
                    let _ = self.window.request_inner_size(PhysicalSize::new(rw, rh));
                }
            }
            let resized = options.resize.is_none() || self.resized_at == options.resize;
            if self.rendered >= n && resized {
                if let Some(path) = &options.screenshot {
                    self.save(path)?;
                }
                return Ok(Flow::Exit);
            }
            if self.rendered >= n && self.started.elapsed() > Duration::from_secs(60) {
                let (rw, rh) = options.resize.unwrap_or_default();
                bail!(
                    "the window was not resized to {rw}x{rh} within a minute (the window system ignored the request)"
                );
            }
        }
        Ok(Flow::Continue)
    }

    fn update_title(&self) {
        let mr = self.renderer();
        let spp = self.shown_frames() * shared::SAMPLES_PER_FRAME;
        let (w, h) = self.display.size();
        let mean = self.recent.mean();
        let ms = mean.pathtrace_ms + mean.learn_ms;
        let msps = if ms > 0.0 { (w as f64 * h as f64 * shared::SAMPLES_PER_FRAME as f64) / (ms * 1e3) } else { 0.0 };
        let clock = if mean.gpu { "GPU" } else { "wall" };
        let learn = if mr.mode == GuidingMode::Off { String::new() } else { format!(" (learn {:.2})", mean.learn_ms) };
        let gpus = match mr.renderer.device_count() {
            1 => String::new(),
            n => format!(" on {n} GPUs"),
        };
        self.window.set_title(&format!(
            "rlpt: {} | {spp} spp | {ms:.2} ms/frame {clock}{learn} | {msps:.1} Msamples/s{gpus} | guiding {} | NEE {}{}",
            self.scene_name,
            mr.mode.name(),
            if self.nee { "on" } else { "off" },
            if self.paused { " | paused" } else { "" }
        ));
    }

    /// Saves what the window shows as `png` (the display pass's bytes, inset included)
    /// and the linear mean radiance beside it as .exr.
    fn save(&self, png: &Path) -> Result<()> {
        let (w, h) = self.display.size();
        if self.shared.is_some() {
            // The merged film may be newer than the window's last draw (`merge_if_due`).
            let frames = self.shown_frames();
            self.ctx.run_commands("display for a screenshot", |cmd| self.display.cmd_draw(cmd, frames))?;
        }
        let rgb = self.display.read_rgb8()?;
        image::save_buffer(png, &rgb, w, h, image::ExtendedColorType::Rgb8)
            .with_context(|| format!("writing {}", png.display()))?;
        let exr = png.with_extension("exr");
        let film = self.renderer().renderer.film()?;
        debug_assert!(self.shared.is_none() || film.frames == self.shown_frames(), "the shown image is merged");
        film.mean().save(&exr).with_context(|| format!("writing {}", exr.display()))?;
        println!(
            "saved {} and {} ({} spp, guiding {}, NEE {})",
            png.display(),
            exr.display(),
            film.samples_per_pixel(),
            self.renderer().mode.name(),
            if self.nee { "on" } else { "off" }
        );
        Ok(())
    }

    /// Checks on the way out: the validation layer, when on, must have said nothing.
    fn finish(&self) -> Result<()> {
        let n = self.ctx.validation_messages();
        if n > 0 {
            bail!("the Vulkan validation layer reported {n} problem(s) (printed above)");
        }
        Ok(())
    }
}
