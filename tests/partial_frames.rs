//! A frame cut short by `--time` (on the CPU `CpuRenderer::render_frame_until`
//! and `render_frame_samples`, on the GPU `GpuRenderer::render_round` and
//! `render_frame_samples`): its film is its samples accumulated (the image, the
//! sample count, the variance of the mean), its samples land anywhere in their
//! pixels, the film's variance stays unbiased with the frame's smaller weight,
//! and the GPU's frame cut short is the CPU's.

mod common;

use common::{options, scene, K};
use rlpt::camera::camera_ray;
use rlpt::cpu::{pass_sample, trace_path, CpuRenderer};
use rlpt::film::{accumulate, accumulate_samples, Film, FrameWeight, Learned};
use rlpt::layout::AccumPixel;
use rlpt::math::rng::Rng;
use rlpt::math::sampler::{rng_frame, PathSampler};
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::session::Renderer;

fn prepared(width: u32, height: u32, seed: u32) -> PreparedScene {
    let s = scene("cornell-box.toml");
    let mut o = options(&s, width, height, 64);
    o.seed = seed;
    PreparedScene::new(&s, &o).expect("valid options")
}

/// Sample `sample` of pixel (x, y) in random-number frame `frame`, as the renderer traces it (unguided).
fn trace(p: &PreparedScene, x: u32, y: u32, frame: u32, sample: u32) -> [f64; 3] {
    let params = &p.params;
    let mut rng = PathSampler::for_flags(params.flags, params.seed, y * params.width + x, frame, sample);
    let u = rng.sample_pixel(sample);
    let (o, d) = camera_ray(params, x, y, u);
    let (l, _) = trace_path(p, None, o, d, &mut rng, 0.0, None);
    if l.is_finite() {
        [l.x as f64, l.y as f64, l.z as f64]
    } else {
        [0.0; 3]
    }
}

/// Two whole frames, then one cut after 11 passes, of a part whose frames start
/// at 3, against the same samples traced one by one and summed in f64: the same
/// image, 139 samples per pixel, and the variance of the mean from the frames'
/// means weighted by their samples, sum n_i (m_i - m)^2 / ((F - 1) N).
#[test]
fn a_frame_cut_short_is_its_samples_accumulated() {
    let (w, h, offset, k) = (12u32, 9u32, 3u32, 11u32);
    let p = prepared(w, h, 7);
    let mut r = CpuRenderer::new(&p);
    r.set_frame_offset(offset);
    r.render_frame();
    r.render_frame();
    r.render_frame_samples(k);
    let film = r.film();
    assert_eq!((film.frames, film.partial_spp, film.samples_per_pixel()), (3, k, 2 * 64 + k as u64));
    let (mean, var) = (film.mean(), film.variance_of_mean().expect("3 frames"));
    let mut worst = (0.0f64, 0.0f64);
    let (mut var_sum, mut ref_var_sum) = (0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let pixel = y * w + x;
            // Each frame's samples: all 64 of the whole frames, the passes' of the last.
            let frames: Vec<Vec<u32>> = vec![
                (0..64).collect(),
                (0..64).collect(),
                (0..k).map(|j| pass_sample(p.params.seed, pixel, rng_frame(2, 0, offset), j)).collect(),
            ];
            let mut sums = Vec::new();
            for (f, samples) in frames.iter().enumerate() {
                let frame = rng_frame(f as u32, 0, offset);
                let mut s = [0.0f64; 3];
                for &i in samples {
                    let l = trace(&p, x, y, frame, i);
                    (0..3).for_each(|c| s[c] += l[c]);
                }
                sums.push((s, samples.len() as f64));
            }
            let n: f64 = sums.iter().map(|s| s.1).sum();
            for c in 0..3 {
                let m = sums.iter().map(|s| s.0[c]).sum::<f64>() / n;
                let dev: f64 = sums.iter().map(|(s, ni)| ni * (s[c] / ni - m).powi(2)).sum();
                let v = dev / (2.0 * n);
                let got = (mean.pixels[pixel as usize][c] as f64, var.pixels[pixel as usize][c] as f64);
                worst.0 = worst.0.max((got.0 - m).abs() / m.abs().max(1e-3));
                worst.1 = worst.1.max((got.1 - v).abs() / v.abs().max(1e-6));
                var_sum += got.1;
                ref_var_sum += v;
            }
        }
    }
    assert!(worst.0 < 1e-5, "image against the samples summed: relative difference {}", worst.0);
    assert!(worst.1 < 1e-3, "variance against the samples' frames: relative difference {}", worst.1);
    assert!(ref_var_sum > 0.0 && (var_sum / ref_var_sum - 1.0).abs() < 1e-4);
}

/// A frame traced in 64 passes is the whole frame: the same samples, summed in
/// another order (each pixel's from its own first index).
#[test]
fn a_frame_of_64_passes_is_the_whole_frame() {
    let p = prepared(10, 8, 3);
    let (mut whole, mut passes) = (CpuRenderer::new(&p), CpuRenderer::new(&p));
    for _ in 0..2 {
        whole.render_frame();
        passes.render_frame_samples(64);
    }
    assert_eq!(passes.film().partial_spp, 0, "64 passes are a whole frame");
    let (a, b) = (whole.film().mean(), passes.film().mean());
    let d = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / p[c].abs().max(1e-3)))
        .fold(0.0, f32::max);
    assert!(d < 1e-5, "passes against the whole frame: {d}");
}

/// Pass j of a frame traces, over the pixels, each of the frame's 64 sample
/// indices equally often (chi-square), so its samples land anywhere in their
/// pixels (with independent samples, index i looks in sub-square i); the first
/// k indices of every pixel would see only the pixels' top rows. A pixel's 64
/// passes trace its 64 indices once each.
#[test]
fn passes_draw_every_sample_index_alike() {
    let pixels = 64 * 400u32;
    for (seed, frame, pass) in [(1u32, 0u32, 0u32), (1, 5, 7), (9, 2, 40)] {
        let mut counts = [0u32; 64];
        for pixel in 0..pixels {
            counts[pass_sample(seed, pixel, frame, pass) as usize] += 1;
        }
        let e = pixels as f64 / 64.0;
        let chi2: f64 = counts.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
        // 63 degrees of freedom: 120 is beyond the 1e-5 tail.
        assert!(chi2 < 120.0, "seed {seed} frame {frame} pass {pass}: chi-square {chi2} over 63 dof");
    }
    for pixel in [0u32, 17, 4095] {
        let mut seen: Vec<u32> = (0..64).map(|j| pass_sample(2, pixel, 3, j)).collect();
        seen.sort();
        assert_eq!(seen, (0..64).collect::<Vec<_>>());
    }
}

/// The film's variance of the mean, from frames of 64 samples and a last one of
/// k, against the analytic sigma^2 / N, over many pixels of independent uniform
/// samples (sigma^2 = 1/12): unbiased within K standard errors. Unweighted
/// (the last frame's mean taken as a whole frame's, `accumulate`), it would be
/// off by far more: 2.5 times for one whole frame and 8 samples.
#[test]
fn the_variance_with_a_frame_cut_short_is_unbiased() {
    let trials = 20_000u32;
    for (whole, k) in [(1u32, 8u32), (1, 1), (3, 40), (2, 63)] {
        let n = (whole * 64 + k) as f64;
        let truth = 1.0 / 12.0 / n;
        let (mut sum, mut sum_sq, mut unweighted) = (0.0f64, 0.0f64, 0.0f64);
        for t in 0..trials {
            let mut rng = Rng::new(whole * 100 + k, t, 0, 0);
            let mut frame = |samples: u32| {
                let s: f32 = (0..samples).map(|_| rng.next_f32()).sum();
                [s, s, s]
            };
            let (mut acc, mut plain) = (AccumPixel::default(), AccumPixel::default());
            let (mut carry, mut plain_carry) = ([0.0f32; 3], [0.0f32; 3]);
            for f in 0..whole {
                let s = frame(64);
                accumulate(&mut acc, &mut carry, f, 0, Learned::Fold, s);
                accumulate(&mut plain, &mut plain_carry, f, 0, Learned::Fold, s);
            }
            let s = frame(k);
            accumulate_samples(
                &mut acc,
                &mut carry,
                whole,
                0,
                Learned::Fold,
                s,
                FrameWeight { samples: k, ..FrameWeight::whole(whole) },
            );
            // The cut frame's mean scaled to a whole frame's sum, and weighted as one.
            accumulate(&mut plain, &mut plain_carry, whole, 0, Learned::Fold, s.map(|v| v * 64.0 / k as f32));
            let film = Film {
                width: 1,
                height: 1,
                frames: whole + 1,
                partial_spp: k,
                weight: None,
                pixels: vec![acc],
                carry: vec![carry],
            };
            let v = film.variance_of_mean().expect("2 frames or more").pixels[0][0] as f64;
            sum += v;
            sum_sq += v * v;
            let plain = Film { partial_spp: 0, pixels: vec![plain], ..film };
            unweighted += plain.variance_of_mean().unwrap().pixels[0][0] as f64;
        }
        let mean = sum / trials as f64;
        let se = ((sum_sq / trials as f64 - mean * mean) / trials as f64).sqrt();
        assert!(
            (mean - truth).abs() < K * se,
            "{whole} frames and {k} samples: mean variance {mean:.4e}, sigma^2/N {truth:.4e} (standard error {se:.2e})"
        );
        if k <= 8 {
            let u = unweighted / trials as f64;
            assert!(u > 2.0 * truth, "{whole} frames and {k} samples: unweighted {u:.4e} against {truth:.4e}");
        }
    }
}

/// A guided frame's targets reach the table whether the frame is whole, in 64
/// passes or cut short: the first frame's paths are the same in each (the same
/// table, the same random numbers), so the table learns from 64 passes exactly
/// the targets of the whole frame (Q to float summation order), and from 16
/// passes a subset of them, entry by entry.
#[test]
fn a_guided_frame_cut_short_teaches_its_targets() {
    let s = scene("cornell-box.toml");
    let mut o = options(&s, 16, 12, 64);
    o.guiding = rlpt::guide::GuidingMode::Sphere;
    let p = PreparedScene::new(&s, &o).expect("valid options");
    let (mut whole, mut passes, mut cut) = (CpuRenderer::new(&p), CpuRenderer::new(&p), CpuRenderer::new(&p));
    whole.render_frame();
    passes.render_frame_samples(64);
    cut.render_frame_samples(16);
    let (w, ps, c) = (whole.table().unwrap(), passes.table().unwrap(), cut.table().unwrap());
    let total = |v: &[u32]| v.iter().map(|&n| n as u64).sum::<u64>();
    assert!(total(&w.visits) > 0, "the whole frame taught the table nothing");
    let differ = w.visits.iter().zip(&ps.visits).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "64 passes recorded other targets than the whole frame in {differ} entries");
    let dq = w.q.iter().zip(&ps.q).map(|(a, b)| (a - b).abs() / a.abs().max(1e-3)).fold(0.0, f32::max);
    assert!(dq < 1e-4, "Q from 64 passes against the whole frame's: {dq}");
    assert!(w.visits.iter().zip(&c.visits).all(|(a, b)| b <= a), "16 passes recorded targets the frame has not");
    let (tw, tc) = (total(&w.visits), total(&c.visits));
    assert!(tc > 0 && tc < tw, "16 passes recorded {tc} targets of the whole frame's {tw}");
}

/// The GPU's frame cut short (`GpuRenderer::render_frame_samples`: the frame's
/// first k lanes of each pixel trace the sample indices the CPU's k passes
/// do) is the CPU's: two whole frames and one of 11 samples, of a part whose
/// frames start at 3, give the same image, sample count and variance, to the
/// rounding of the order the samples are summed in (seed-exp1, whose paths
/// the two devices trace alike; a frame cut short to other indices, as the
/// first k, which see only the pixels' top rows, gives another image).
#[test]
fn the_gpus_frame_cut_short_is_the_cpus() {
    let ctx = common::gpu();
    let (w, h, offset, k) = (32u32, 24u32, 3u32, 11u32);
    let s = scene("seed-exp1.toml");
    let mut o = options(&s, w, h, 64);
    o.seed = 7;
    let p = PreparedScene::new(&s, &o).expect("valid options");
    let mut cpu = CpuRenderer::new(&p);
    let mut gpu = GpuRenderer::new(&ctx, &p).expect("renderer");
    cpu.set_frame_offset(offset);
    gpu.set_frame_offset(offset);
    for _ in 0..2 {
        cpu.render_frame();
        gpu.render_frames(1).expect("frame");
    }
    cpu.render_frame_samples(k);
    gpu.render_frame_samples(k).expect("frame cut short");
    let (c, g) = (cpu.film().clone(), gpu.film().expect("readback"));
    assert_eq!((g.frames, g.partial_spp, g.samples_per_pixel()), (3, k, 2 * 64 + k as u64));
    assert_eq!(Renderer::image_spp(&gpu), 2 * 64 + k);
    let worst = |a: &rlpt::image::Image, b: &rlpt::image::Image, floor: f32| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .flat_map(|(p, q)| (0..3).map(move |i| (p[i] - q[i]).abs() / p[i].abs().max(floor)))
            .fold(0.0f32, f32::max)
    };
    let d = worst(&g.mean(), &c.mean(), 1e-3);
    assert!(d < 1e-4, "GPU against CPU image: relative difference {d}");
    let (gv, cv) = (g.variance_of_mean().expect("3 frames"), c.variance_of_mean().expect("3 frames"));
    let d = worst(&gv, &cv, 1e-6);
    assert!(d < 1e-3, "GPU against CPU variance: relative difference {d}");
    common::assert_no_validation_messages(&ctx);
}

/// A round's first frame is taken to last as long as the last round's first
/// frame (timed apart) where that was longer than its mean: a time left short
/// of that gets no whole frame, only one cut short (or none), since a frame
/// alone in its submission runs from cold caches. Before any round, no estimate.
#[test]
fn a_lone_last_frame_is_timed_as_a_rounds_first() {
    let ctx = common::gpu();
    let p = prepared(16, 12, 6);
    let mut r = GpuRenderer::new(&ctx, &p).expect("renderer");
    assert_eq!(r.lone_frame_ms(), None);
    let t = r.render_frames(4).expect("round");
    let mean = t.total_ms() / 4.0;
    assert!(t.first_trace_ms > 0.0 && mean > 0.0, "lavapipe's timestamps time the frames: {t:?}");
    let lone = r.lone_frame_ms().expect("an estimate");
    assert_eq!(lone, t.first_trace_ms.max(mean));
    eprintln!("a round of 4 frames: the first {} ms, the mean {mean} ms", t.first_trace_ms);
    let round = r.render_round(10, Some(0.98 * lone)).expect("round");
    assert!(
        round.frames == 0 || round.cut_spp.is_some(),
        "a whole frame in {} ms, a lone frame taken as {lone} ms (mean {mean} ms): {round:?}",
        0.98 * lone
    );
    assert_eq!(round.time_up, Some(true));
    common::assert_no_validation_messages(&ctx);
}

/// A timed round where no whole frame fits the time left traces a last frame
/// cut short to the samples that do, whole subgroups of them, a frame of k
/// samples taken to cost `CUT_FRAME_FIXED` of the last frame's time plus k / 64
/// of it (`GpuRenderer::samples_that_fit`), and says the time is up; a learning
/// frame is whole or none.
#[test]
fn a_timed_round_cuts_the_last_frame_to_the_samples_that_fit() {
    let ctx = common::gpu();
    let p = prepared(16, 12, 5);
    let mut r = GpuRenderer::new(&ctx, &p).expect("renderer");
    let first = r.render_frames(1).expect("frame");
    let ms = first.total_ms();
    assert!(ms > 0.0, "lavapipe's timestamps time the frame");
    let lanes = ctx.info.subgroup_size.min(64);
    assert_eq!(r.samples_that_fit(ms, ms), 64);
    assert_eq!(r.samples_that_fit(ms, 0.0), 0);
    // The fixed cost and k / 64 of the frame: 0.55 of it past the fixed cost fits
    // 35 samples, whole subgroups of them (32 of lavapipe's 8 lanes, 32 of 32).
    let fixed = rlpt::render::CUT_FRAME_FIXED;
    assert_eq!(r.samples_that_fit(ms, fixed * ms), 0);
    let left = (fixed + 0.55) * ms;
    let want = (0.55 * (64 / lanes) as f64) as u32 * lanes;
    assert_eq!(r.samples_that_fit(ms, left), want);
    let round = r.render_round(10, Some(left)).expect("round");
    if want == 0 {
        assert_eq!((round.frames, round.time_up), (0, Some(true)));
    } else {
        assert_eq!((round.frames, round.cut_spp, round.time_up), (1, Some(want), Some(true)), "{round:?}");
        assert_eq!(round.variance, None, "the race does not weigh a frame cut short");
        let film = r.film().expect("readback");
        assert_eq!((film.frames, film.partial_spp, Renderer::image_spp(&r)), (2, want, 64 + want));
    }

    // Door learns for four frames before its image starts: none of them is cut short.
    let s = scene("door.toml");
    let mut o = options(&s, 16, 12, 64);
    o.guiding = rlpt::guide::GuidingMode::Sphere;
    let door = PreparedScene::new(&s, &o).expect("valid options");
    assert!(door.learning_frames() > 0);
    let r = GpuRenderer::new(&ctx, &door).expect("renderer");
    assert_eq!((r.samples_that_fit(1.0, 0.9), r.samples_that_fit(1.0, 1.0)), (0, 64));
    common::assert_no_validation_messages(&ctx);
}
