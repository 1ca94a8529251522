//! Several GPUs in one render (`render::MultiGpuRenderer`), tested with two
//! contexts on the one device the test machine has: the merged film against one
//! device's, guided and not, the tables after a learning pass, a lost device,
//! and the session's budget.

mod common;
use common::*;
use rlpt::film::Film;
use rlpt::guide::GuidingMode;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::render::{GpuRenderer, GpuSet, MultiGpuRenderer, ROUND_FRAMES_PER_DEVICE};
use rlpt::scene::GridKind;
use rlpt::scene::Scene;
use rlpt::session::{Budget, Renderer, Session, Stop};
use std::sync::atomic::AtomicBool;

/// Held by each test here that renders: they run one at a time, so that the
/// time budget's test sees frames as long as those it measured its limit from
/// (two contexts share the test machine's cores with any other render).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Renders `frames` frames in rounds, as the session does, and returns the film.
fn render_multi(r: &mut MultiGpuRenderer, frames: u32) -> Film {
    let mut traced = 0;
    while traced < frames {
        let round = r.render_round(frames - traced, None).expect("round");
        assert!(round.frames >= 1 && round.frames <= frames - traced, "{round:?}");
        traced += round.frames;
    }
    Renderer::film(r).expect("films")
}

/// Each pixel's sum of `a` and `b` (films of the same frames, added in another
/// order) agree to the rounding of adding `frames` nonnegative frame sums.
fn assert_same_sums(a: &Film, b: &Film, what: &str) {
    assert_eq!(a.frames, b.frames, "{what}: frames");
    let u = f32::EPSILON as f64 / 2.0;
    let bound = 2.0 * a.frames as f64 * u;
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..3 {
            let (x, y) = (p.sum[c] as f64, q.sum[c] as f64);
            assert!((x - y).abs() <= bound * x.abs().max(y.abs()) + 1e-30, "{what}: pixel {i} channel {c}: {x} vs {y}");
        }
    }
}

fn door(width: u32, height: u32, spp: u32) -> (Scene, RenderOptions) {
    let s = scene("door.toml");
    let o = options(&s, width, height, spp);
    (s, o)
}

/// Frame k draws the same random numbers on either context: the same frame
/// traced alone on each gives the same bits. Two contexts that trace 10 frames
/// between them (handed out as they finish) give the film of one context that
/// traces them all, to the rounding of the order the frames' sums are added in,
/// and the same spread of the frames' means.
#[test]
fn two_contexts_render_what_one_renders() {
    let _serial = one_at_a_time();
    let (scene, opts) = door(32, 24, 10 * 64);
    let prepared = PreparedScene::new(&scene, &opts).unwrap();
    let (a, b) = (gpu(), gpu());
    {
        let mut one = GpuRenderer::new(&a, &prepared).unwrap();
        let mut two = GpuRenderer::new(&b, &prepared).unwrap();
        one.trace_frame(5).unwrap();
        two.trace_frame(5).unwrap();
        let (f1, f2) = (one.film().unwrap(), two.film().unwrap());
        assert!(f1.pixels.iter().zip(&f2.pixels).all(|(p, q)| p.sum == q.sum), "frame 5 differs between contexts");
    }
    let single = render_gpu(&a, &scene, &opts);
    let mut multi = MultiGpuRenderer::new(&[a.clone(), b.clone()], &prepared).unwrap();
    let merged = render_multi(&mut multi, 10);
    let stats = multi.device_stats();
    assert_eq!(stats.iter().map(|d| d.frames).sum::<u32>(), 10, "{stats:?}");
    assert!(stats.iter().all(|d| d.frames > 0), "both contexts traced frames: {stats:?}");
    drop(multi);
    assert_same_sums(&single, &merged, "two contexts against one");
    let (v1, v2) = (single.variance_of_mean().unwrap(), merged.variance_of_mean().unwrap());
    let total = |v: &rlpt::image::Image| v.pixels.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>();
    let (t1, t2) = (total(&v1), total(&v2));
    assert!((t1 - t2).abs() <= 1e-3 * t1, "the frames' spread: {t1} against {t2}");
    assert_no_validation_messages(&a);
    assert_no_validation_messages(&b);
}

/// A guided render on two contexts (each recording its own paths' targets, the
/// sums added at each learning pass) agrees within noise with a guided render on
/// one and with the CPU renderer.
#[test]
fn a_guided_render_on_two_contexts_agrees_with_one_and_the_cpu() {
    let _serial = one_at_a_time();
    let (scene, mut opts) = door(32, 24, 24 * 64);
    opts.guiding = GuidingMode::Sphere;
    let prepared = PreparedScene::new(&scene, &opts).unwrap();
    let (a, b) = (gpu(), gpu());
    let single = render_gpu(&a, &scene, &opts);
    let mut multi = MultiGpuRenderer::new(&[a.clone(), b.clone()], &prepared).unwrap();
    let merged = render_multi(&mut multi, prepared.learning_frames() + opts.frames());
    drop(multi);
    assert_eq!(merged.frames, opts.frames(), "the image's frames");
    let z = assert_films_agree(&merged, &single, 4, K, "guided: two contexts against one");
    eprintln!("guided, two contexts against one: worst block {z:.2} sigma");
    opts.seed = 7;
    let cpu = render_cpu(&scene, &opts);
    let z = assert_films_agree(&merged, &cpu, 4, K, "guided: two contexts against the CPU");
    eprintln!("guided, two contexts against the CPU: worst block {z:.2} sigma");
    assert_no_validation_messages(&a);
    assert_no_validation_messages(&b);
}

/// After each learning pass every device holds the same table, bit for bit: Q,
/// visits, sampling rows, fractions, their states and the rows read. The devices
/// learn from the same sums (added on the host, in device order) with the same
/// kernel, which has no atomics, from the same table. Checked after the
/// one-frame rounds of the first frames and after a round of several.
#[test]
fn every_device_holds_the_same_table_after_a_learning_pass() {
    let _serial = one_at_a_time();
    for grid in [GridKind::Uniform, GridKind::Adaptive] {
        same_tables_on_two_devices(grid);
    }
}

fn same_tables_on_two_devices(grid: GridKind) {
    let (scene, mut opts) = door(24, 16, 64);
    opts.guiding = GuidingMode::Sphere;
    opts.guide_grid = Some(grid);
    // Learning once per recording cycle, so that a round of several frames ends
    // at a pass (a small image's default period is longer than the rounds).
    opts.learning_period = Some(1);
    if grid == GridKind::Adaptive {
        // Fewer bins: cells learn enough to split within the rounds.
        opts.bins = Some(rlpt::guide::Bins { rows: 8, cols: 16 });
    }
    let prepared = PreparedScene::new(&scene, &opts).unwrap();
    let (a, b) = (gpu(), gpu());
    let mut multi = MultiGpuRenderer::new(&[a.clone(), b.clone()], &prepared).unwrap();
    let mut traced = 0;
    for round in 0..10 {
        let r = multi.render_round(64, None).unwrap();
        traced += r.frames;
        // Each round ends at a learning point: one frame each in the first
        // frames, then a cycle of the recording rows, capped per device.
        assert!(r.frames <= 2 * ROUND_FRAMES_PER_DEVICE, "{r:?}");
        let tables = multi.device_tables().unwrap();
        let (t0, t1) = (tables[0].as_ref().unwrap(), tables[1].as_ref().unwrap());
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert!(t0.q.iter().any(|&q| q > 0.0), "round {round}: the table learned");
        assert_eq!(bits(&t0.q), bits(&t1.q), "round {round} (frames {traced}): Q");
        assert_eq!(t0.visits, t1.visits, "round {round}: visits");
        assert_eq!(bytemuck::cast_slice::<_, u32>(&t0.rows), bytemuck::cast_slice::<_, u32>(&t1.rows), "rows");
        assert_eq!(bits(&t0.fractions), bits(&t1.fractions), "round {round}: fractions");
        assert_eq!(
            bytemuck::cast_slice::<_, u32>(&t0.fraction_states),
            bytemuck::cast_slice::<_, u32>(&t1.fraction_states),
            "round {round}: fraction states"
        );
        assert_eq!(t0.rows_read, t1.rows_read, "round {round}: rows read");
        assert_eq!((&t0.nodes, t0.used_cells), (&t1.nodes, t1.used_cells), "round {round}: the cell tree");
    }
    assert!(traced > 10, "rounds of several frames after the first ({traced} frames in 10 rounds)");
    if grid == GridKind::Adaptive {
        let t = multi.device_tables().unwrap().remove(0).unwrap();
        assert!(t.used_cells > prepared.guide.unwrap().grid.cells(), "cells split within the rounds");
    }
    drop(multi);
    assert_no_validation_messages(&a);
    assert_no_validation_messages(&b);
}

/// A device lost in the middle of a round is dropped, and the other traces its
/// image frames again (frame k draws the same numbers on either): the render
/// ends with every frame asked for, the film of one context that traced them.
/// With every device lost, the round fails as one lost device does, and a
/// session stops with `Stop::DeviceLost`.
#[test]
fn a_lost_device_is_dropped_and_its_frames_traced_again() {
    let _serial = one_at_a_time();
    let (scene, opts) = door(24, 16, 12 * 64);
    let prepared = PreparedScene::new(&scene, &opts).unwrap();
    let (a, b) = (gpu(), gpu());
    let single = render_gpu(&a, &scene, &opts);
    let mut multi = MultiGpuRenderer::new(&[a.clone(), b.clone()], &prepared).unwrap();
    let first = multi.render_round(4, None).unwrap();
    assert_eq!(first.frames, 4);
    multi.device_mut(1).lose_device_at(Some(6));
    let merged = render_multi(&mut multi, 8);
    assert_eq!(multi.device_count(), 1, "the lost device is dropped");
    let stats = multi.device_stats();
    assert!(stats[1].lost && !stats[0].lost, "{stats:?}");
    assert_eq!(Renderer::image_frames(&multi), 12);
    assert_same_sums(&single, &merged, "after a lost device");
    drop(multi);
    drop(b); // lost for good: Context::lose_device

    let (c, d) = (gpu(), gpu());
    let mut multi = MultiGpuRenderer::new(&[c.clone(), d.clone()], &prepared).unwrap();
    multi.device_mut(0).lose_device_at(Some(3));
    multi.device_mut(1).lose_device_at(Some(3));
    let mut session = Session::new(Box::new(multi), None, 1.0);
    let (stop, _) = session.run(Budget { frames: 12, time_ms: None }, &AtomicBool::new(false)).unwrap();
    assert!(matches!(stop, Stop::DeviceLost(_)), "{stop:?}");
    assert!(session.renderer.film().is_err(), "no film is read back from lost devices");
    drop(session);
    assert_no_validation_messages(&a);
}

/// The session gives a render on two contexts the frames it asks for, neither
/// more nor less, whatever the rounds; and with a time limit it ends by it.
#[test]
fn a_session_on_two_contexts_keeps_its_budget() {
    let _serial = one_at_a_time();
    let (scene, opts) = door(16, 16, 64);
    let prepared = PreparedScene::new(&scene, &opts).unwrap();
    let (a, b) = (gpu(), gpu());
    let multi = MultiGpuRenderer::new(&[a.clone(), b.clone()], &prepared).unwrap();
    let mut session = Session::new(Box::new(multi), None, 1.0);
    let (stop, _) = session.run(Budget { frames: 11, time_ms: None }, &AtomicBool::new(false)).unwrap();
    assert_eq!(stop, Stop::Finished);
    assert_eq!(session.traced(), 11);
    assert_eq!(session.renderer.image_frames(), 11);
    assert_eq!(session.renderer.film().unwrap().frames, 11);
    let limit = session.elapsed_ms / 2.0;
    drop(session);

    let mut multi = MultiGpuRenderer::new(&[a.clone(), b.clone()], &prepared).unwrap();
    let mut session = Session::new(Box::new(&mut multi), None, 1.0);
    let (stop, _) = session.run(Budget { frames: 1000, time_ms: Some(limit) }, &AtomicBool::new(false)).unwrap();
    assert_eq!(stop, Stop::Finished);
    assert!(session.traced() < 1000, "the time ran out first");
    assert_eq!(session.renderer.image_frames(), session.traced());
    let elapsed = session.elapsed_ms;
    drop(session);
    let stats = multi.device_stats();
    drop(multi);
    // A GPU starts a frame only where, taken to last as long as its last, it ends
    // by the limit: a frame slower than predicted can overrun by the difference,
    // never by more than the slowest frame (as a render that checked the clock
    // only before each round could).
    let slowest = stats.iter().map(|d| d.slowest_frame_ms).fold(0.0, f64::max);
    assert!(slowest > 0.0);
    assert!(
        elapsed <= limit + slowest,
        "{elapsed} ms: past the limit of {limit} ms by more than the slowest frame ({slowest} ms)"
    );
    assert_no_validation_messages(&a);
    assert_no_validation_messages(&b);
}

/// `rlpt ARGS` as the command-line tests run it (`common::cli::rlpt`), with `env` set.
fn rlpt(args: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    cli::rlpt().args(args).envs(env.iter().copied()).output().expect("rlpt runs")
}

fn door_path() -> String {
    format!("{}/scenes/door.toml", env!("CARGO_MANIFEST_DIR"))
}

/// `--gpus` refuses, each with a sentence, on render, bench and view (before
/// any window opens): `--gpu` beside it, a device named twice, a device past
/// the last (listing those found), a word that is no index.
#[test]
fn bad_gpu_lists_are_refused_with_a_sentence() {
    let dir = cli::fresh_dir("multi-gpu-refusals");
    let out = dir.join("out.png");
    let door_toml = door_path();
    for (gpus, extra, want) in [
        ("0", &["--gpu", "0"][..], "--gpu 0 and --gpus 0 both pick GPUs: give one of them"),
        ("0,0", &[][..], "--gpus 0,0: device 0 is named twice"),
        ("0,9", &[][..], "--gpus 0,9: there is no device 9; 1 Vulkan device(s) found: 0 \""),
        ("0,x", &[][..], "`x` is not a device index"),
    ] {
        for command in ["render", "bench", "view"] {
            let mut args = vec![command, door_toml.as_str(), "--width", "8", "--height", "8", "--gpus", gpus];
            if command == "render" {
                args.extend(["-o", out.to_str().unwrap()]);
            } else if command == "bench" {
                args.extend(["--frames", "1", "--warmup", "0"]);
            }
            args.extend(extra);
            let o = rlpt(&args, &[]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!o.status.success() && err.contains(want), "{command} --gpus {gpus}: {err}");
            assert!(!out.exists(), "nothing written");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `render --gpus` and `bench --gpus` end to end, on two contexts of the one
/// device (the test hook allows it): the image has the samples asked for and
/// agrees with the library's two-context film; bench reports each device.
#[test]
fn render_and_bench_on_two_gpus_from_the_command_line() {
    let _serial = one_at_a_time();
    let dir = cli::fresh_dir("multi-gpu-cli");
    let (exr, json) = (dir.join("two.exr"), dir.join("bench.json"));
    let door_toml = door_path();
    let hook = [("RLPT_TEST_DUPLICATE_GPUS", "1")];
    let args = ["render", &door_toml, "--width", "24", "--height", "16", "--spp", "384", "--gpus", "0,0", "-o"];
    let o = rlpt(&[&args[..], &[exr.to_str().unwrap()]].concat(), &hook);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(said.contains("384 spp") && said.contains("on 2 GPUs"), "{said}");
    let image = rlpt::image::Image::load(&exr).unwrap();
    let (scene, opts) = door(24, 16, 384);
    let single = render_gpu(&gpu(), &scene, &opts);
    let mean = single.mean();
    let close =
        image.pixels.iter().zip(&mean.pixels).all(|(a, b)| (0..3).all(|c| (a[c] - b[c]).abs() <= 1e-5 * b[c].abs()));
    assert!(close, "the two-GPU image is the one-GPU image of the same frames");

    let args =
        ["bench", &door_toml, "--width", "16", "--height", "16", "--frames", "6", "--warmup", "2", "--gpus", "0,0"];
    let o = rlpt(&[&args[..], &["--json", json.to_str().unwrap()]].concat(), &hook);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let devices = report["devices"].as_array().unwrap();
    assert_eq!(devices.len(), 2, "{report}");
    let frames: u64 = devices.iter().map(|d| d["frames"].as_u64().unwrap()).sum();
    assert_eq!((frames, report["frames"].as_u64()), (6, Some(6)), "{report}");
    assert!(report["frames_per_second"].as_f64().unwrap() > 0.0, "{report}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--part` on two GPUs: each part's frames are handed out over the GPUs from its
/// own range, so the merged parts are the one-GPU unsplit render to rounding.
#[test]
fn parts_rendered_on_two_gpus_merge_to_the_one_gpu_render() {
    let _serial = one_at_a_time();
    let dir = cli::fresh_dir("multi-gpu-parts");
    let door_toml = door_path();
    let hook = [("RLPT_TEST_DUPLICATE_GPUS", "1")];
    let base = ["render", &door_toml, "--width", "20", "--height", "12", "--spp", "640"];
    let mut parts = Vec::new();
    for k in 0..2 {
        let path = dir.join(format!("part-{k}.exr"));
        let spec = format!("{k}/2");
        let args = [&base[..], &["--gpus", "0,0", "--part", &spec, "-o", path.to_str().unwrap()]].concat();
        let o = rlpt(&args, &hook);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(String::from_utf8_lossy(&o.stdout).contains("on 2 GPUs"));
        parts.push(path);
    }
    let merged = dir.join("merged.exr");
    let o =
        rlpt(&["merge", parts[0].to_str().unwrap(), parts[1].to_str().unwrap(), "-o", merged.to_str().unwrap()], &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let merged = rlpt::image::Image::load(&merged).unwrap();
    let (scene, opts) = door(20, 12, 640);
    let single = render_gpu(&gpu(), &scene, &opts).mean();
    let worst = merged
        .pixels
        .iter()
        .zip(&single.pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].abs().max(1e-6)))
        .fold(0.0f32, f32::max);
    assert!(worst <= 1e-5, "merged two-GPU parts differ from the one-GPU render by {worst} (relative)");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The viewer's restart on several GPUs (`GpuSet::set_params` and
/// `reset_accumulation`, a camera move and NEE off): every device drops what it
/// accumulated, and the frames after it are those one context traces after the
/// same restart (the frame indices go on on both), to the rounding of the
/// order their sums are added in.
#[test]
fn a_restart_resets_every_gpu() {
    let _serial = one_at_a_time();
    let (scene, opts) = door(24, 16, 64);
    let prepared = PreparedScene::new(&scene, &opts).unwrap();
    let (a, b) = (gpu(), gpu());
    let mut camera = scene.camera.clone();
    camera.position += camera.forward * 0.3;
    let mut moved = prepared.params;
    moved.set_camera(&camera);
    moved.set_nee(false);
    let restart = |r: &mut GpuSet| {
        r.set_params(&moved).unwrap();
        r.reset_accumulation().unwrap();
    };
    let mut one = GpuSet::new(std::slice::from_ref(&a), &prepared, 0, rlpt::film::Learned::Fold).unwrap();
    let mut two = GpuSet::new(&[a.clone(), b.clone()], &prepared, 0, rlpt::film::Learned::Fold).unwrap();
    let mut films = Vec::new();
    for r in [&mut one, &mut two] {
        for _ in 0..5 {
            r.render_frame().unwrap();
        }
        restart(r);
        assert_eq!(Renderer::film(r).unwrap().frames, 0, "the restart emptied every device");
        let mut traced = 0;
        while traced < 6 {
            traced += r.render_round(6 - traced, None).unwrap().frames;
        }
        films.push(Renderer::film(r).unwrap());
    }
    if let GpuSet::Several(m) = &two {
        assert!(m.device_stats().iter().all(|d| d.frames > 0), "both contexts traced frames");
    }
    drop((one, two));
    assert_eq!(films[0].frames, 6, "the frames after the restart only");
    assert_same_sums(&films[0], &films[1], "restarted: two contexts against one");
    assert_no_validation_messages(&a);
    assert_no_validation_messages(&b);
}
