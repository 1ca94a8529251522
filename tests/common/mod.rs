//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod cli;
pub mod files;
pub mod guiding;
pub mod scene_pieces;

use rlpt::film::Film;
use rlpt::gpu::{Context, ContextOptions, ValidationCounter};
use rlpt::image::Image;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;
use std::sync::Arc;

/// A GPU context with the Khronos validation layer on (tests fail if it is missing),
/// synchronization validation included. Derefs to the `Arc<Context>`; when dropped it
/// drops the context and fails the test if the layer reported anything, at the
/// context's destruction included (leaked objects are reported there).
pub fn gpu() -> Gpu {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let ctx = Context::new(&ContextOptions { gpu: None, validation: true, window: None })
        .expect("a Vulkan device (lavapipe: apt install mesa-vulkan-drivers) and the validation layer");
    let counter = ctx.validation_counter();
    Gpu { ctx: Some(ctx), counter }
}

/// A test's GPU context; see [`gpu`].
pub struct Gpu {
    ctx: Option<Arc<Context>>,
    counter: ValidationCounter,
}

impl std::ops::Deref for Gpu {
    type Target = Arc<Context>;
    fn deref(&self) -> &Arc<Context> {
        self.ctx.as_ref().expect("context alive until drop")
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        let ctx = self.ctx.take().expect("dropped once");
        let others = Arc::strong_count(&ctx) - 1;
        drop(ctx);
        if std::thread::panicking() {
            return; // the test already failed; a second panic would abort the others
        }
        assert_eq!(others, 0, "a GPU resource outlives the test's context: its teardown is not checked");
        assert_eq!(self.counter.get(), 0, "the validation layer reported problems, at teardown included (see stderr)");
    }
}

/// The bytes of a device buffer (a probe kernel's output), copied back after a barrier.
pub fn readback(ctx: &Arc<Context>, src: &rlpt::gpu::Buffer) -> Vec<u8> {
    let rb = rlpt::gpu::Buffer::new(ctx, "probe readback", src.size, rlpt::gpu::BufferUsage::Readback).unwrap();
    ctx.run_commands("probe readback", |cmd| {
        ctx.barrier(cmd);
        src.cmd_copy_to(cmd, &rb);
    })
    .unwrap();
    rb.read().to_vec()
}

/// Asserts the validation layer said nothing on `ctx` so far.
pub fn assert_no_validation_messages(ctx: &Context) {
    assert!(ctx.validation_enabled());
    assert_eq!(ctx.validation_messages(), 0, "the validation layer reported problems (see stderr)");
}

/// 5 sigma: with a few hundred comparisons per test the chance of a false alarm stays below 1e-3.
pub const K: f64 = 5.0;

pub fn scene(name: &str) -> Scene {
    Scene::load(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).expect("shipped scene loads")
}

/// Render options for a test: the scene's settings at a small size.
pub fn options(scene: &Scene, width: u32, height: u32, spp: u32) -> RenderOptions {
    let mut o = RenderOptions::from_scene(scene);
    o.width = width;
    o.height = height;
    o.spp = spp;
    o
}

pub fn render_gpu(ctx: &Arc<Context>, scene: &Scene, opts: &RenderOptions) -> Film {
    let prepared = PreparedScene::new(scene, opts).expect("valid options");
    let mut r = GpuRenderer::new(ctx, &prepared).expect("renderer");
    r.render_frames(opts.frames()).expect("render");
    let film = r.film().expect("readback");
    assert_no_validation_messages(ctx);
    film
}

pub fn render_cpu(scene: &Scene, opts: &RenderOptions) -> Film {
    let prepared = PreparedScene::new(scene, opts).expect("valid options");
    let mut film = Film::new(opts.width, opts.height);
    rlpt::cpu::render(&prepared, &mut film, opts.frames(), |_| {});
    film
}

/// An unguided GPU render of `scene` (seed `opts.seed`), a CPU render (seed
/// `seeds[0]`) and a guided GPU render (sphere, seed `seeds[1]`) agree region by
/// region; returns the unguided GPU film.
pub fn gpu_unguided_and_guided_agree_with_cpu(
    scene: &Scene,
    opts: &mut RenderOptions,
    seeds: [u32; 2],
    what: &str,
) -> Film {
    let ctx = gpu();
    let g = render_gpu(&ctx, scene, opts);
    opts.seed = seeds[0];
    let c = render_cpu(scene, opts);
    let z = assert_films_agree(&g, &c, 4, K, &format!("{what}: GPU vs CPU"));
    eprintln!("{what}: worst block differs by {z:.2} sigma");
    opts.seed = seeds[1];
    opts.guiding = rlpt::guide::GuidingMode::Sphere;
    let guided = render_gpu(&ctx, scene, opts);
    let z = assert_films_agree(&guided, &c, 4, K, &format!("{what}: guided GPU vs CPU"));
    eprintln!("{what}, guided: worst block differs by {z:.2} sigma");
    g
}

/// Mean and variance of the mean of channel-averaged radiance over the pixels
/// for which `select(x, y)` holds, from the film's per-pixel variance estimates,
/// with the f32 rounding bound ([`rounding_bound`]) added as a deviation.
pub fn region_stats(film: &Film, select: impl Fn(u32, u32) -> bool) -> (f64, f64, usize) {
    let mean = film.mean();
    let var = film.variance_of_mean().expect("at least two frames");
    let (mut s, mut v, mut r, mut n) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for y in 0..film.height {
        for x in 0..film.width {
            if select(x, y) {
                let i = (y * film.width + x) as usize;
                let m = mean.pixels[i];
                let q = var.pixels[i];
                s += (m[0] + m[1] + m[2]) as f64 / 3.0;
                // Channels of one pixel are correlated: bound the variance of their average by the average deviation squared.
                let sd = (q[0].sqrt() + q[1].sqrt() + q[2].sqrt()) as f64 / 3.0;
                v += sd * sd;
                r += rounding_bound(film, (m[0] + m[1] + m[2]) / 3.0);
                n += 1;
            }
        }
    }
    assert!(n > 0, "empty region");
    let n_f = n as f64;
    (s / n_f, v / (n_f * n_f) + (r / n_f) * (r / n_f), n)
}

/// Bound on the f32 rounding error of a pixel mean of `film`: a recursive sum of n
/// non-negative terms is off by at most (n - 1) u times their sum, u = 2^-24
/// (Higham, "Accuracy and Stability of Numerical Algorithms", 4.2). The 64
/// samples of a frame are summed first (at most 63 additions on the CPU, 6
/// levels on the GPU), then F frames. Where the estimator has (almost) no
/// variance, as in the closed furnace, this is the only difference two correct
/// renderers can show.
pub fn rounding_bound(film: &Film, mean: f32) -> f64 {
    let u = f32::EPSILON as f64 / 2.0;
    (63.0 + film.frames as f64) * u * mean.abs() as f64
}

/// Compares two films block by block (blocks of `block` x `block` pixels, each
/// channel): every difference of block means must lie within `k` standard
/// deviations, the deviation estimated from both films' per-pixel variances,
/// plus their f32 rounding bounds ([`rounding_bound`]). Returns the largest |z| seen.
pub fn assert_films_agree(a: &Film, b: &Film, block: u32, k: f64, what: &str) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let (ma, mb) = (a.mean(), b.mean());
    let (va, vb) = (a.variance_of_mean().unwrap(), b.variance_of_mean().unwrap());
    assert_means_agree(
        &ma,
        &mb,
        |i, c| va.pixels[i][c] as f64 + vb.pixels[i][c] as f64,
        |i, c| rounding_bound(a, ma.pixels[i][c]) + rounding_bound(b, mb.pixels[i][c]),
        block,
        k,
        what,
    )
}

/// The block test of [`assert_films_agree`] on two mean images, given for pixel `i`
/// and channel `c` the variance of their difference and a bound on its rounding error.
pub fn assert_means_agree(
    ma: &Image,
    mb: &Image,
    diff_variance: impl Fn(usize, usize) -> f64,
    rounding: impl Fn(usize, usize) -> f64,
    block: u32,
    k: f64,
    what: &str,
) -> f64 {
    assert_eq!((ma.width, ma.height), (mb.width, mb.height));
    let mut worst = 0.0f64;
    for by in (0..ma.height).step_by(block as usize) {
        for bx in (0..ma.width).step_by(block as usize) {
            for c in 0..3 {
                let (mut d, mut v, mut r, mut n) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for y in by..(by + block).min(ma.height) {
                    for x in bx..(bx + block).min(ma.width) {
                        let i = (y * ma.width + x) as usize;
                        d += ma.pixels[i][c] as f64 - mb.pixels[i][c] as f64;
                        v += diff_variance(i, c);
                        r += rounding(i, c);
                        n += 1.0;
                    }
                }
                let (d, v) = (d / n, v / (n * n) + (r / n) * (r / n));
                if v == 0.0 {
                    assert!(d.abs() < 1e-6, "{what}: block ({bx},{by}) channel {c} differs by {d} with no noise");
                    continue;
                }
                let z = d / v.sqrt();
                worst = worst.max(z.abs());
                assert!(
                    z.abs() < k,
                    "{what}: block at ({bx},{by}) channel {c} differs by {d:.5} = {z:.2} sigma (limit {k})"
                );
            }
        }
    }
    worst
}
