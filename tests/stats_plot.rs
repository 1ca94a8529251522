//! The convergence-statistics file round-trips through JSON and names the path
//! and line:column of malformed input; the convergence plot is a 900x600 PNG
//! with a curve per run, and refuses runs without relMSE and non-PNG outputs.

mod common;

use common::cli::fresh_dir;

use rlpt::plot::{plot_convergence, run_colour, Metric, PLOT_HEIGHT, PLOT_WIDTH};
use rlpt::stats::{FrameStats, RenderStats};

/// A run whose relMSE falls as `constant / t`, with a little deterministic
/// wobble, over `frames` frames of `frame_ms` each.
fn synthetic_run(label: &str, constant: f64, frame_ms: f64, frames: u32) -> RenderStats {
    let frames = (1..=frames)
        .map(|frame| {
            let elapsed_ms = frame as f64 * frame_ms;
            let wobble = 1.0 + 0.15 * (frame as f64 * 1.7).sin() / (frame as f64).sqrt();
            FrameStats {
                frame,
                spp: frame * 4,
                gpu_ms: Some(frame_ms),
                elapsed_ms,
                rel_mse: Some(constant / (elapsed_ms / 1000.0) * wobble),
                rel_mse_debiased: None,
                zero_fraction: Some(0.25),
                unguided: false,
                frame_variance: None,
                weight: None,
            }
        })
        .collect();
    RenderStats {
        label: label.to_string(),
        scene: "scenes/door.toml".to_string(),
        device: "NVIDIA H100".to_string(),
        width: 640,
        height: 480,
        guiding: "sphere".to_string(),
        guided_fraction: Some("learned".to_string()),
        learning_rate_exponent: Some(0.75),
        exploration_floor: Some(0.25),
        q_targets: Some("mis".to_string()),
        nee: true,
        learning_frames: Some(4),
        frames,
    }
}

#[test]
fn json_round_trip() {
    let dir = fresh_dir("round_trip");
    let path = dir.join("stats.json");
    let mut stats = synthetic_run("door.toml guiding=sphere nee=on", 0.02, 12.5, 5);
    // The CPU renderer's shape: no GPU time, and a frame without relMSE.
    stats.frames[1].gpu_ms = None;
    stats.frames[2].rel_mse = None;
    stats.frames[3].zero_fraction = None;
    stats.frames[4].elapsed_ms = 0.1 + 0.2; // not exactly representable: must still round-trip exactly
                                            // Against a reference with its variance, the debiased relMSE too (it may be negative).
    stats.frames[0].rel_mse_debiased = Some(-1.25e-7);
    stats.frames[4].rel_mse_debiased = Some(0.1 + 0.2);
    stats.save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("\n  \"label\": \"door.toml guiding=sphere nee=on\""), "not pretty JSON:\n{text}");
    assert!(text.contains("\"gpu_ms\": null"), "{text}");
    // Absent where no variance was given, as in files written before it existed.
    assert_eq!(text.matches("rel_mse_debiased").count(), 2, "{text}");
    let loaded = RenderStats::load(&path).unwrap();
    assert_eq!(loaded, stats);
}

#[test]
fn malformed_file_names_path_and_position() {
    let dir = fresh_dir("malformed");
    let path = dir.join("broken.json");
    std::fs::write(&path, "{\n  \"label\": \"x\",\n  \"scene\": oops\n}\n").unwrap();
    let message = format!("{:#}", RenderStats::load(&path).unwrap_err());
    assert!(message.contains(&format!("{}:3:12", path.display())), "{message}");

    // A missing field is reported too, at the end of the object.
    let path = dir.join("incomplete.json");
    std::fs::write(&path, "{\"label\": \"x\"}").unwrap();
    let message = format!("{:#}", RenderStats::load(&path).unwrap_err());
    assert!(message.contains(&format!("{}:1:14", path.display())), "{message}");
    assert!(message.contains("missing field"), "{message}");

    let missing = dir.join("missing.json");
    let message = format!("{:#}", RenderStats::load(&missing).unwrap_err());
    assert!(message.contains(&missing.display().to_string()), "{message}");
}

#[test]
fn plot_of_two_runs_shows_both() {
    let dir = fresh_dir("two_runs");
    let out = dir.join("convergence.png");
    let runs = [
        synthetic_run("door.toml guiding=off nee=on", 0.5, 20.0, 200),
        synthetic_run("door.toml guiding=sphere nee=on", 0.08, 24.0, 200),
    ];
    plot_convergence(&runs, &out, Metric::RelMse).unwrap();

    let image = image::open(&out).unwrap().into_rgb8();
    assert_eq!((image.width(), image.height()), (PLOT_WIDTH, PLOT_HEIGHT));
    assert_eq!((PLOT_WIDTH, PLOT_HEIGHT), (900, 600));
    assert_ne!(run_colour(0), run_colour(1));
    let count = |colour: [u8; 3]| image.pixels().filter(|p| p.0 == colour).count();
    let white = count([255, 255, 255]);
    assert!(white < image.pixels().count() * 99 / 100, "the plot is blank");
    // Each curve spans the plot: hundreds of pixels of exactly its colour.
    for index in 0..runs.len() {
        let n = count(run_colour(index));
        assert!(n > 300, "run {index} has only {n} pixels of its colour {:?}", run_colour(index));
    }
}

#[test]
fn run_without_rel_mse_is_an_error_naming_it() {
    let dir = fresh_dir("no_rel_mse");
    let out = dir.join("convergence.png");
    let mut blind = synthetic_run("cornell.toml guiding=off nee=off", 0.3, 10.0, 10);
    for frame in &mut blind.frames {
        frame.rel_mse = None;
    }
    let runs = [synthetic_run("cornell.toml guiding=sphere nee=off", 0.1, 10.0, 10), blind];
    let message = format!("{:#}", plot_convergence(&runs, &out, Metric::RelMse).unwrap_err());
    assert!(message.contains("cornell.toml guiding=off nee=off"), "{message}");
    assert!(message.contains("--reference"), "{message}");
    assert!(!out.exists());
}

#[test]
fn frames_without_rel_mse_or_positive_values_are_skipped() {
    let dir = fresh_dir("skipped");
    let out = dir.join("convergence.png");
    let mut run = synthetic_run("partial", 0.1, 10.0, 20);
    run.frames[0].rel_mse = None;
    run.frames[1].rel_mse = Some(0.0);
    run.frames[2].rel_mse = Some(f64::NAN);
    run.frames[3].elapsed_ms = 0.0;
    plot_convergence(&[run], &out, Metric::RelMse).unwrap();
    assert!(out.is_file());
}

#[test]
fn non_png_output_is_refused() {
    let dir = fresh_dir("not_png");
    let runs = [synthetic_run("a", 0.1, 10.0, 10)];
    for name in ["convergence.jpg", "convergence", "convergence.png.txt"] {
        let out = dir.join(name);
        let message = format!("{:#}", plot_convergence(&runs, &out, Metric::RelMse).unwrap_err());
        assert!(message.contains(&out.display().to_string()), "{message}");
        assert!(message.contains(".png"), "{message}");
        assert!(!out.exists());
    }
    // The extension is not case-sensitive.
    plot_convergence(&runs, &dir.join("convergence.PNG"), Metric::RelMse).unwrap();
}

#[test]
fn plot_notes_name_dropped_points_and_mixed_runs() {
    let a = synthetic_run("a", 0.02, 10.0, 6);
    assert!(rlpt::plot::plot_notes(std::slice::from_ref(&a), Metric::RelMse).is_empty());
    // A first frame that matches its own reference exactly: relMSE 0, off the log axis.
    let mut exact = a.clone();
    exact.frames[0].rel_mse = Some(0.0);
    exact.frames[1].elapsed_ms = 0.0;
    let notes = rlpt::plot::plot_notes(&[exact], Metric::RelMse);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].contains("run 'a': 2 of its 6 relMSE points"), "{notes:?}");
    // Two scenes, or two sizes, on one plot.
    let mut other = synthetic_run("b", 0.02, 10.0, 6);
    other.scene = "scenes/seed-exp1.toml".into();
    let notes = rlpt::plot::plot_notes(&[a.clone(), other], Metric::RelMse);
    assert!(notes.len() == 1 && notes[0].contains("different scenes or sizes"), "{notes:?}");
    let mut smaller = synthetic_run("c", 0.02, 10.0, 6);
    smaller.width = 320;
    let notes = rlpt::plot::plot_notes(&[a, smaller], Metric::RelMse);
    assert!(notes.len() == 1 && notes[0].contains("scenes/door.toml 320x480"), "{notes:?}");
}

/// `plot --debiased`: the relMSE less the reference's variance, whose frames can
/// be negative (left off the log axes, and named); a run recorded without the
/// reference's variance is an error that says how to record it.
#[test]
fn the_debiased_relmse_plots_and_says_what_it_needs() {
    let dir = fresh_dir("debiased");
    let out = dir.join("debiased.png");
    let mut run = synthetic_run("door.toml guiding=sphere nee=on", 0.08, 24.0, 60);
    for (i, f) in run.frames.iter_mut().enumerate() {
        f.rel_mse_debiased = f.rel_mse.map(|r| if i == 3 { -1e-9 } else { 0.8 * r });
    }
    plot_convergence(std::slice::from_ref(&run), &out, Metric::RelMseDebiased).unwrap();
    let image = image::open(&out).unwrap().into_rgb8();
    let n = image.pixels().filter(|p| p.0 == run_colour(0)).count();
    assert!(n > 300, "the curve has only {n} pixels of its colour");
    let notes = rlpt::plot::plot_notes(std::slice::from_ref(&run), Metric::RelMseDebiased);
    assert!(
        notes.len() == 1 && notes[0].contains("1 of its 60 relMSE less the reference's variance points"),
        "{notes:?}"
    );
    let plain = synthetic_run("door.toml guiding=off nee=on", 0.5, 20.0, 10);
    let message = format!("{:#}", plot_convergence(&[run, plain], &out, Metric::RelMseDebiased).unwrap_err());
    assert!(
        message.contains("door.toml guiding=off nee=on")
            && message.contains("no relMSE less the reference's variance values")
            && message.contains("--reference-variance"),
        "{message}"
    );
}
