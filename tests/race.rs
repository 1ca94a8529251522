//! Guided and unguided frames in one render (`guide::FrameRace`,
//! `--unguided-frames auto`): the image stays unbiased whichever kernel traces
//! each frame, and the GPU and CPU weigh a frame's variance alike.

mod common;

use common::*;
use rlpt::cpu::CpuRenderer;
use rlpt::film::{frame_variance_term, Film};
use rlpt::guide::{FrameKind, GuidingMode, UnguidedFrames};
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::shared;

fn racing(scene: &rlpt::scene::Scene, w: u32, h: u32, spp: u32, seed: u32) -> rlpt::options::RenderOptions {
    let mut o = options(scene, w, h, spp);
    o.guiding = GuidingMode::Sphere;
    o.unguided_frames = UnguidedFrames::Auto;
    o.seed = seed;
    o
}

/// seed-exp1 (no roulette: the image starts at once) at 24x16, racing, with `spp` and `seed`.
fn seed_exp1_racing(spp: u32, seed: u32) -> PreparedScene {
    let scene = scene("seed-exp1.toml");
    PreparedScene::new(&scene, &racing(&scene, 24, 16, spp, seed)).expect("valid options")
}

/// Renders `opts` frame by frame on the GPU (the race chooses per submission),
/// returning the film and the kinds of the frames.
fn race_gpu(
    ctx: &std::sync::Arc<rlpt::gpu::Context>,
    scene: &rlpt::scene::Scene,
    opts: &rlpt::options::RenderOptions,
) -> (Film, Vec<FrameKind>) {
    let prepared = PreparedScene::new(scene, opts).expect("valid options");
    let mut r = GpuRenderer::new(ctx, &prepared).expect("renderer");
    let kinds = (0..opts.frames() + prepared.learning_frames())
        .map(|_| r.render_frames(1).expect("frame").kind.expect("a guided render's frames have a kind"))
        .collect();
    (r.film().expect("readback"), kinds)
}

fn race_cpu(scene: &rlpt::scene::Scene, opts: &rlpt::options::RenderOptions) -> (Film, Vec<FrameKind>) {
    let prepared = PreparedScene::new(scene, opts).expect("valid options");
    let mut r = CpuRenderer::new(&prepared);
    let kinds = (0..opts.frames() + prepared.learning_frames())
        .map(|_| {
            r.render_frame();
            r.last_kind.expect("a guided render's frames have a kind")
        })
        .collect();
    (r.film().clone(), kinds)
}

/// An image of guided and unguided frames agrees with an unguided one on both
/// devices: door (the light through a gap; after its four learning frames an
/// unguided one, left out of the image too; the image's frames are as the race
/// finds) and seed-exp1 (roulette
/// off: the image starts at once; the race after eight guided frames, with two
/// of each kind).
#[test]
fn images_of_guided_and_unguided_frames_are_unbiased() {
    let ctx = gpu();
    for (name, spp) in [("door.toml", 2048), ("seed-exp1.toml", 1024)] {
        let scene = scene(name);
        let off = render_gpu(&ctx, &scene, &options(&scene, 36, 24, spp));
        let (film, kinds) = race_gpu(&ctx, &scene, &racing(&scene, 36, 24, spp, 41));
        let unguided = kinds.iter().filter(|&&k| k == FrameKind::Unguided).count();
        assert!(unguided >= 1 && unguided < kinds.len(), "{name}: {unguided} of {} frames unguided", kinds.len());
        if name == "seed-exp1.toml" {
            // Eight guided frames before the race starts, then two of each kind, unguided first.
            let head = shared::RECORD_FIRST_FRAMES as usize;
            assert!(kinds[..head].iter().all(|&k| k == FrameKind::Guided), "{name}: {kinds:?}");
            assert_eq!(kinds[head..head + 2], [FrameKind::Unguided, FrameKind::Unguided], "{name}");
            assert_eq!(kinds[head + 2..head + 4], [FrameKind::Guided, FrameKind::Guided], "{name}");
        } else {
            // Four guided learning frames, then the unguided one that measures its kind.
            assert_eq!(
                kinds[..5],
                [FrameKind::Guided, FrameKind::Guided, FrameKind::Guided, FrameKind::Guided, FrameKind::Unguided],
                "{name}: the learning frames"
            );
        }
        let z = assert_films_agree(&film, &off, 6, K, &format!("{name}: GPU guided and unguided frames vs off"));
        eprintln!("{name}, GPU: {unguided} of {} frames unguided, worst block {z:.2} sigma", kinds.len());

        let small_off = render_gpu(&ctx, &scene, &options(&scene, 18, 12, spp));
        let (film, kinds) = race_cpu(&scene, &racing(&scene, 18, 12, spp, 42));
        let unguided = kinds.iter().filter(|&&k| k == FrameKind::Unguided).count();
        assert!(unguided >= 1 && unguided < kinds.len(), "{name}: {unguided} of {} CPU frames unguided", kinds.len());
        let z =
            assert_films_agree(&film, &small_off, 4, K, &format!("{name}: CPU guided and unguided frames vs GPU off"));
        eprintln!("{name}, CPU: {unguided} of {} frames unguided, worst block {z:.2} sigma", kinds.len());
    }
    assert_no_validation_messages(&ctx);
}

/// A timed race weighs each kind's frames by the inverse of its variance
/// (`FrameRace::frame_weight`): on either device the film holds its frames'
/// total weight, and its image agrees with an unguided one. Budgets of 40 of
/// the device's unguided frames or more, so that the head start and the
/// race trace guided frames beside the unguided ones.
#[test]
fn a_timed_race_weighs_its_frames_and_stays_unbiased() {
    let ctx = gpu();
    let mut scene = scene("seed-exp1.toml");
    let off = render_gpu(&ctx, &scene, &options(&scene, 24, 16, 4096));
    // A small table: the head start's frames learn after each, and the default
    // table's pass takes lavapipe ten times the frame.
    scene.guiding.resolution = Some([4, 4, 4]);
    let mut o = racing(&scene, 24, 16, 64, 13);
    o.bins = Some(rlpt::guide::Bins { rows: 4, cols: 8 });
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    // The budget: 64 unguided frames, and at least 25 guided ones (of the
    // second, which records every row and learns: the first of a kernel runs
    // cold), so that the head start holds two, and the race explores though
    // its first frame, on a loaded machine, runs slower than the probe's.
    let unguided = GpuRenderer::new(&ctx, &prepared).expect("renderer").render_round(1, Some(1e9)).expect("round");
    let mut probe = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    probe.render_frames(1).expect("frame");
    let g_ms = probe.render_frames(1).expect("frame").total_ms();
    let u_ms = unguided.gpu_ms.expect("lavapipe's timestamps time the frame");
    let mut left = (64.0 * u_ms).max(25.0 * g_ms);
    let mut g = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    loop {
        let r = g.render_round(64, Some(left)).expect("round");
        left -= r.gpu_ms.unwrap_or(0.0);
        if r.frames == 0 || r.time_up == Some(true) {
            break;
        }
    }
    let film = g.film().expect("readback");
    let race = *g.race().expect("a race");
    assert!(race.guided.frames + race.unguided.frames > 0, "{race:?}");
    let weight = film.weight.expect("guided frames weighed other than 1");
    assert!(weight > 0.0 && weight != film.samples_per_pixel() as f64 / 64.0, "{weight}");
    let z = assert_films_agree(&film, &off, 4, K, "GPU: a timed race's weighted frames vs off");
    eprintln!("GPU: {} frames of total weight {weight:.2}, worst block {z:.2} sigma", film.frames);

    let mut c = CpuRenderer::new(&prepared);
    let start = std::time::Instant::now();
    c.render_frame_within(1e9);
    let budget = 40.0 * start.elapsed().as_secs_f64() * 1e3;
    let mut c = CpuRenderer::new(&prepared);
    let start = std::time::Instant::now();
    loop {
        let (samples, time_up) = c.render_frame_within(budget - start.elapsed().as_secs_f64() * 1e3);
        if samples == 0 || time_up {
            break;
        }
    }
    let film = c.film().clone();
    let weight = film.weight.expect("guided frames weighed other than 1");
    assert!(weight > 0.0 && weight != film.samples_per_pixel() as f64 / 64.0, "{weight}");
    let z = assert_films_agree(&film, &off, 4, K, "CPU: a timed race's weighted frames vs off");
    eprintln!("CPU: {} frames of total weight {weight:.2}, worst block {z:.2} sigma", film.frames);
    assert_no_validation_messages(&ctx);
}

/// The race starts after eight guided frames with two unguided, then two guided;
/// on either device the first unguided frame traces the same paths (no table in
/// them) from the same accumulation up to rounding, so its variance is the same.
#[test]
fn gpu_and_cpu_weigh_a_frame_alike() {
    let ctx = gpu();
    let prepared = seed_exp1_racing(768, 7);
    assert_eq!(prepared.learning_frames(), 0, "seed-exp1 has no roulette: the image starts at once");
    let mut g = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    let mut c = CpuRenderer::new(&prepared);
    let head = shared::RECORD_FIRST_FRAMES as usize;
    for frame in 0..head + 4 {
        let t = g.render_frames(1).expect("frame");
        c.render_frame();
        assert_eq!(t.kind, c.last_kind, "frame {frame}: the same kind on both devices");
        let unguided = (head..head + 2).contains(&frame);
        let want = if unguided { FrameKind::Unguided } else { FrameKind::Guided };
        assert_eq!(t.kind, Some(want), "frame {frame}");
        let (gv, cv) = (t.variance.expect("GPU variance"), c.last_variance.expect("CPU variance"));
        // The first frame's mean is the pixel's mean before it: no deviation.
        if frame == 0 {
            assert_eq!((gv, cv), (0.0, 0.0), "frame 0");
            continue;
        }
        assert!(gv > 0.0 && cv > 0.0, "frame {frame}: variances {gv}, {cv}");
        eprintln!("frame {frame} {want:?}: variance GPU {gv:.5e}, CPU {cv:.5e}");
        // The first unguided frame exactly, up to rounding; the others trace a
        // table learned from targets summed in another order.
        let tolerance = if frame == head { 1e-3 } else { 0.05 };
        assert!((gv - cv).abs() < tolerance * cv, "frame {frame}: GPU {gv}, CPU {cv}");
    }
    assert_no_validation_messages(&ctx);
}

/// A timed render's race takes its budget from the time left at its first
/// round (`FrameRace::set_time_left`), on the GPU (`GpuRenderer::render_round`)
/// and the CPU (`CpuRenderer::render_frame_within`): where a second guided frame
/// would take the head start past `RACE_HEAD_START_SHARE` of it (a budget of
/// 12 frames: one is 8 %, two 17 %), the head start ends after the first and
/// the next frame is unguided; without a time limit the head start is its eight frames.
#[test]
fn a_timed_render_bounds_the_head_start_by_its_budget() {
    let ctx = gpu();
    let prepared = seed_exp1_racing(640, 9);
    for timed in [true, false] {
        let mut g = GpuRenderer::new(&ctx, &prepared).expect("renderer");
        let mut c = CpuRenderer::new(&prepared);
        let t = g.render_frames(1).expect("frame");
        let start = std::time::Instant::now();
        c.render_frame();
        let cpu_ms = start.elapsed().as_secs_f64() * 1e3;
        assert_eq!((t.kind, c.last_kind), (Some(FrameKind::Guided), Some(FrameKind::Guided)));
        let gpu_ms = t.total_ms();
        assert!(gpu_ms > 0.0, "lavapipe's timestamps time the frame");
        // The time left for twelve frames: the budget.
        let left = timed.then_some(12.0 * gpu_ms);
        let round = g.render_round(1, left).expect("round");
        assert_eq!(round.frames, 1);
        if timed {
            c.render_frame_within(12.0 * cpu_ms);
        } else {
            c.render_frame();
        }
        let want = if timed { FrameKind::Unguided } else { FrameKind::Guided };
        assert_eq!(round.kind, Some(want), "GPU, timed: {timed}");
        assert_eq!(c.last_kind, Some(want), "CPU, timed: {timed}");
    }
    assert_no_validation_messages(&ctx);
}

/// A timed render opens with two unguided frames on either device (timed, not
/// weighed by the race); where its budget fits fewer than
/// `RACE_MIN_FRAMES` frames of that time (here a quarter of it) the frames after
/// them are unguided too, and where it fits many (about 1000) the guided head
/// start follows. Budgets from the unguided first frame of a
/// render with a long one, far from the threshold on either side: lavapipe's
/// frames vary under load.
#[test]
fn a_timed_render_opens_unguided_and_guides_only_where_enough_frames_fit() {
    let ctx = gpu();
    let prepared = seed_exp1_racing(640, 11);
    let long = 1e9;
    let probe = GpuRenderer::new(&ctx, &prepared).expect("renderer").render_round(1, Some(long)).expect("round");
    assert_eq!(probe.kind, Some(FrameKind::Unguided));
    let gpu_ms = probe.gpu_ms.expect("lavapipe's timestamps time the frame");
    let mut c = CpuRenderer::new(&prepared);
    let start = std::time::Instant::now();
    c.render_frame_within(long);
    let cpu_ms = start.elapsed().as_secs_f64() * 1e3;
    assert_eq!(c.last_kind, Some(FrameKind::Unguided));
    let short = rlpt::guide::RACE_MIN_FRAMES / 4.0;
    for (frames, then) in [(short, FrameKind::Unguided), (1000.0, FrameKind::Guided)] {
        let mut g = GpuRenderer::new(&ctx, &prepared).expect("renderer");
        let budget = frames * gpu_ms;
        let first = g.render_round(1, Some(budget)).expect("round");
        assert_eq!(g.race().expect("a race").unguided.frames, 0, "the first frame is timed, not weighed");
        let left = budget - first.gpu_ms.expect("timestamps");
        let second = g.render_round(1, Some(left)).expect("round");
        assert_eq!(g.race().expect("a race").unguided.frames, 0, "the opening is not the race's");
        let third = g.render_round(1, Some(left - second.gpu_ms.expect("timestamps"))).expect("round");
        let kinds = [first.kind, second.kind, third.kind];
        let want = [Some(FrameKind::Unguided), Some(FrameKind::Unguided), Some(then)];
        assert_eq!(kinds, want, "GPU, {frames} frames");

        let mut c = CpuRenderer::new(&prepared);
        let budget = frames * cpu_ms;
        let (samples, _) = c.render_frame_within(budget);
        assert_eq!((samples, c.last_kind), (64, Some(FrameKind::Unguided)), "CPU, {frames} frames");
        c.render_frame_within(budget / 2.0);
        assert_eq!(c.last_kind, Some(FrameKind::Unguided), "CPU, {frames} frames: the second");
        c.render_frame_within(budget / 2.0);
        assert_eq!(c.last_kind, Some(then), "CPU, {frames} frames");
    }
    assert_no_validation_messages(&ctx);
}

/// A round of frames in one submission times its first frame apart
/// (`FrameTimings::first_trace_ms`): the first of a kernel after the other's
/// runs from cold caches, and the race times a kind by the frames after it.
/// Here the race's opening round of three unguided frames after the head start.
#[test]
fn a_round_times_its_first_frame_apart() {
    let ctx = gpu();
    let prepared = seed_exp1_racing(1024, 5);
    let mut g = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    let head = g.render_frames(shared::RECORD_FIRST_FRAMES).expect("head start");
    assert_eq!(head.kind, Some(FrameKind::Guided));
    assert_eq!(g.race().expect("a race").unguided.frames, 0);
    let t = g.render_frames(3).expect("round");
    assert_eq!(t.kind, Some(FrameKind::Unguided));
    assert!(0.0 < t.first_trace_ms && t.first_trace_ms < t.pathtrace_ms, "{t:?}");
    let warm = (t.pathtrace_ms - t.first_trace_ms) / 2.0;
    let race = g.race().expect("a race");
    assert_eq!(race.unguided.frames, 3);
    assert!((race.unguided.ms - warm).abs() <= 1e-9 * warm, "the race's {} ms against {warm} ms", race.unguided.ms);
    assert_no_validation_messages(&ctx);
}

/// `frame_variance_term` against values worked by hand: a frame whose mean is
/// the pixel's mean before it adds nothing; one of mean 1 where the pixel held
/// 0.5 adds 0.5^2 / (0.5^2 + 0.01), relative to the mean before as relMSE is.
#[test]
fn frame_variance_term_is_the_frames_squared_deviation_from_the_pixels_mean() {
    assert_eq!(frame_variance_term(0.7, 0.7), 0.0);
    let want = 0.25 / (0.25 + 0.01);
    assert!((frame_variance_term(1.0, 0.5) - want).abs() <= 1e-6 * want);
    assert!((frame_variance_term(0.0, 0.5) - want).abs() <= 1e-6 * want);
    // A firefly is clamped.
    assert_eq!(frame_variance_term(1e6, 0.0), shared::FRAME_VARIANCE_MAX);
}

/// `rlpt render --unguided-frames`: `auto` traces unguided frames and `--stats`
/// says which; `never` traces none; left out, the race runs only where the render
/// is timed, its scene has no Russian roulette and one GPU renders it
/// (`guide::default_unguided_frames`); it is a note with guiding off, and
/// refused with several GPUs, which trace every frame guided.
#[test]
fn the_command_line_takes_unguided_frames_and_says_where_they_do_not_apply() {
    use common::cli::{run, tmp};
    let (out, stats) = (tmp("race.exr"), tmp("race-stats.json"));
    let (out, stats) = (out.to_str().unwrap(), stats.to_str().unwrap());
    let size = ["--width", "16", "--height", "12"];
    let base = [&["render", "scenes/seed-exp1.toml"][..], &size, &["--spp", "1024"]].concat();
    // The frames of a guided render's --stats.
    let frames_of = |args: &[&str]| {
        let (ok, err) = run(&[args, &["--guiding", "sphere", "--stats", stats, "-o", out]].concat());
        assert!(ok, "{err}");
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(stats).unwrap()).unwrap();
        json["frames"].as_array().unwrap().clone()
    };
    // The kinds of the frames a guided render traces, 'g' or 'u', in order.
    let kinds = |args: &[&str]| {
        frames_of(args).iter().map(|f| if f["unguided"] == true { 'u' } else { 'g' }).collect::<String>()
    };
    // How many frames, and how many of them unguided.
    let unguided_frames = |args: &[&str]| {
        let k = kinds(args);
        (k.len(), k.matches('u').count())
    };
    // Eight guided frames, then two of each kind, unguided first: the race's start,
    // whole though the session traces a small image's frames in rounds.
    let untimed = frames_of(&[&base[..], &["--unguided-frames", "auto"]].concat());
    let k = untimed.iter().map(|f| if f["unguided"] == true { 'u' } else { 'g' }).collect::<String>();
    assert!(k.len() == 16 && k.starts_with("gggggggguugg"), "{k}");
    assert!(untimed.iter().all(|f| f.get("weight").is_none()), "an --spp race weighs every frame 1: no weights");
    assert_eq!(unguided_frames(&[&base[..], &["--unguided-frames", "never"]].concat()), (16, 0));
    // The default: every frame guided with --spp; the race with --time, but not in
    // a scene with roulette, nor on several GPUs.
    assert_eq!(unguided_frames(&base), (16, 0));
    let timed = [&size[..], &["--spp", "100000000", "--time", "1.5"]].concat();
    let (frames, unguided) = unguided_frames(&[&["render", "scenes/seed-exp1.toml"][..], &timed].concat());
    assert!(frames >= 12 && unguided >= 2, "seed-exp1 --time: {frames} frames, {unguided} unguided");
    // --stats says each timed frame's weight: 1 for unguided frames, the unguided
    // kind's variance over the guided kind's for guided ones once both are measured
    // (a far time limit: the head start's eight guided frames follow the opening).
    let far = [&size[..], &["--spp", "1024", "--time", "1000"]].concat();
    let race = frames_of(&[&["render", "scenes/seed-exp1.toml"][..], &far].concat());
    let weights: Vec<(bool, f64)> =
        race.iter().map(|f| (f["unguided"] == true, f["weight"].as_f64().unwrap())).collect();
    assert!(weights.iter().all(|&(u, w)| !u || w == 1.0), "{weights:?}");
    assert!(weights.iter().filter(|&&(u, w)| !u && w != 1.0 && w > 0.0).count() >= 7, "{weights:?}");
    // Door's fifth frame would be unguided where it raced (the learning frames' last):
    // its four learning frames and two of the image's, the time limit far (its first
    // eight frames learn after each, up to a second a frame on a loaded lavapipe).
    let door_timed = [&size[..], &["--spp", "128", "--time", "120"]].concat();
    let (frames, unguided) = unguided_frames(&[&["render", "scenes/door.toml"][..], &door_timed].concat());
    assert!(frames >= 5 && unguided == 0, "door --time: {frames} frames, {unguided} unguided");
    // Several GPUs refuse a race, so a render that succeeds there did not default to one.
    let o = common::cli::rlpt()
        .env("RLPT_TEST_DUPLICATE_GPUS", "1")
        .args(["render", "scenes/seed-exp1.toml"])
        .args(&timed)
        .args(["--guiding", "sphere", "--gpus", "0,0", "-o", out])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let (ok, err) = run(&[&base[..], &["--unguided-frames", "auto", "-o", out]].concat());
    assert!(
        ok && err.contains("--unguided-frames is a setting of learned guiding; ignored with --guiding off"),
        "{err}"
    );

    let o = common::cli::rlpt()
        .env("RLPT_TEST_DUPLICATE_GPUS", "1")
        .args(base)
        .args(["--guiding", "sphere", "--unguided-frames", "auto", "--gpus", "0,0", "-o", out])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("--unguided-frames auto chooses each frame's kernel on one GPU"),
        "{err}"
    );
}
