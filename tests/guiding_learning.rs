//! How the table learns: learn.comp builds the sampling rows Rust builds, past
//! one dispatch, and a table past the device's range is refused; the recording
//! schedule; the image starts after the learning frames; learning pays on door.toml.

mod common;

use common::guiding::*;
use common::*;
use rlpt::cpu::CpuRenderer;
use rlpt::film::{Film, Learned};
use rlpt::gpu::Context;
use rlpt::guide::{
    build_sampling_rows, class_cosines, learned, pool_sizes, pooled_q, AliasBin, Bins, GuideConfig, GuidingMode,
    QTable, RecordSchedule, NORMAL_CLASSES,
};
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;
use std::sync::Arc;

/// learn.comp's groups build the same rows as Rust: rows of fewer bins than a
/// group has invocations, of several bins each, and of an odd count; the largest,
/// 32x32, in `learning_reaches_past_one_dispatch`.
#[test]
fn glsl_learning_builds_the_same_sampling_rows_as_rust() {
    let ctx = gpu();
    for bins in
        [Bins { rows: 4, cols: 8 }, Bins { rows: 9, cols: 13 }, Bins::SPHERE_DEFAULT, Bins { rows: 20, cols: 40 }]
    {
        glsl_learning_matches_rust(&ctx, bins, false);
    }
    assert_no_validation_messages(&ctx);
}

/// With adaptive directions learn.comp weighs each bin by the same pooled Q as
/// Rust (`pooled_q`): blocks up to 4x4 (8x16, 20x40 bins), up to 2x2 (6x10), none
/// (9x13); and after three frames of door at 32x24 the pooling changes rows
/// (bins with few targets take their block's mean), which a test of rows built
/// from the bins' own Q would not see.
#[test]
fn glsl_adaptive_directions_pool_the_same_bins_as_rust() {
    let ctx = gpu();
    for bins in
        [Bins::SPHERE_DEFAULT, Bins { rows: 20, cols: 40 }, Bins { rows: 6, cols: 10 }, Bins { rows: 9, cols: 13 }]
    {
        let t = glsl_learning_matches_rust(&ctx, bins, true);
        let n = bins.count() as usize;
        let sizes = pool_sizes(&bins);
        let pooled_somewhere =
            t.q.chunks(n)
                .zip(t.visits.chunks(n))
                .any(|(q, v)| (0..n as u32).any(|b| pooled_q(&bins, &sizes, q, v, b) != q[b as usize]));
        assert_eq!(pooled_somewhere, sizes.len() > 1, "{bins:?}: pool sizes {sizes:?}");
    }
    assert_no_validation_messages(&ctx);
}

/// A table larger than one dispatch of learn.comp's fold covers (LEARN_MAX_GROUPS
/// groups, src/render/learning.rs `learn_groups`): the invocations step through the
/// rest, and the entries past the first dispatch's reach learn too (the rows'
/// rebuild steps the same way; its reach, a million rows, is past what a test
/// can allocate).
#[test]
fn learning_reaches_past_one_dispatch() {
    let ctx = gpu();
    // Door's 1056 cells of 32x32 bins: 1081344 entries, past the fold's 65535
    // groups of 16 (1048560 invocations).
    let t = glsl_learning_matches_rust(&ctx, Bins { rows: 32, cols: 32 }, false);
    let reach = (rlpt::shared::LEARN_MAX_GROUPS * rlpt::shared::LEARN_FOLD_GROUP) as usize;
    assert!(t.q.len() > reach, "{} entries", t.q.len());
    // Only the fold counts visits.
    let (first, rest) = t.visits.split_at(reach);
    assert!(first.iter().any(|&v| v > 0), "entries within one dispatch learned");
    assert!(rest.iter().any(|&v| v > 0), "entries past one dispatch learned");
    assert_no_validation_messages(&ctx);
}

/// A table whose sampling rows no storage buffer can hold (6 GB: past the 32-bit
/// range of every device) is refused with what to change, not left to the driver.
#[test]
fn a_table_past_the_devices_buffer_range_is_refused_by_name() {
    let ctx = gpu();
    let mut scene = scene("door.toml");
    scene.guiding.resolution = Some([64, 64, 32]);
    let mut o = options(&scene, 8, 8, 64);
    (o.guiding, o.bins) = (GuidingMode::Sphere, Some(Bins { rows: 32, cols: 32 }));
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    let Err(e) = GpuRenderer::new(&ctx, &prepared) else { panic!("a 6 GB table was taken") };
    let e = e.to_string();
    for part in
        ["sampling rows (131072 cells x 1024 bins x 6 orientations)", "maxStorageBufferRange", "[guiding] resolution"]
    {
        assert!(e.contains(part), "{part}: {e}");
    }
    assert_no_validation_messages(&ctx);
}

/// Door at 32x24 guided over `bins` for 3 frames on the GPU: its sampling rows
/// are those Rust builds from its Q, and most orientation rows of the cells that
/// learned are never read; the table.
fn glsl_learning_matches_rust(ctx: &Arc<Context>, bins: Bins, adaptive_directions: bool) -> QTable {
    let scene = scene("door.toml");
    let mut o = options(&scene, 32, 24, 64);
    o.guiding = GuidingMode::Sphere;
    o.bins = Some(bins);
    o.adaptive_directions = adaptive_directions;
    o.guide_floor = 0.2;
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    let cfg = prepared.guide.unwrap();
    let mut r = GpuRenderer::new(ctx, &prepared).unwrap();
    r.render_frames(3).unwrap();
    let t = r.table().unwrap().unwrap();
    assert!(t.visits.iter().any(|&v| v > 0), "the GPU learned nothing");
    assert_rows_built_from_table(&t, &cfg, &format!("{bins:?}"));
    // Door's cells hold one or two walls each: most orientation classes of a
    // cell that learned are never read, and stay unbuilt.
    let classes = NORMAL_CLASSES as usize;
    let learned_cells = t.visits.chunks(bins.count() as usize).filter(|v| v.iter().any(|&v| v > 0)).count();
    let read = t.rows_read.iter().filter(|&&r| r).count();
    assert!(
        read > 0 && 2 * read < learned_cells * classes,
        "{bins:?}: {read} rows read of {learned_cells} cells' {}",
        learned_cells * classes
    );
    t
}

/// The sampling rows of `t` are those Rust builds from its Q values (pooled as
/// `pooled_q` says with adaptive directions; to the rounding of the alias
/// thresholds), and each bin's density is its probability.
fn assert_rows_built_from_table(t: &QTable, cfg: &GuideConfig, what: &str) {
    let n = cfg.bins.count() as usize;
    let mut want = vec![AliasBin::default(); t.rows.len()];
    let cosines = class_cosines(&cfg.bins);
    let sizes = if cfg.adaptive_directions { pool_sizes(&cfg.bins) } else { vec![1] };
    for ((q, v), rows) in t.q.chunks(n).zip(t.visits.chunks(n)).zip(want.chunks_mut(n * NORMAL_CLASSES as usize)) {
        let q: Vec<f32> = (0..n as u32).map(|b| pooled_q(&cfg.bins, &sizes, q, v, b)).collect();
        build_sampling_rows(&cosines, &q, cfg.floor, rows);
    }
    let (mut worst, mut learned_rows) = (0.0f64, 0);
    assert_eq!(t.rows_read.len(), t.rows.len() / n, "a mark per sampling row");
    for ((got, want), &read) in t.rows.chunks(n).zip(want.chunks(n)).zip(&t.rows_read) {
        // Rows no recording path has read are not built (`QTable::rows_read`).
        assert_eq!(learned(got), read && learned(want), "the rows read and learned are built");
        if !learned(got) {
            continue;
        }
        learned_rows += 1;
        // Rounding may pair the columns differently; the distributions must agree.
        let (pg, pw) = (alias_probabilities(got), alias_probabilities(want));
        for b in 0..n {
            assert_eq!(pg[b] > 0.0, pw[b] > 0.0, "the same bins are possible");
            worst = worst.max((pg[b] - pw[b]).abs());
            // The density sums up to n terms in f32: n ulps of the probability, relative.
            let density = (got[b].pdf as f64 * cfg.bins.solid_angle() as f64 - pg[b]).abs();
            assert!(
                density <= 1e-6 + n as f64 * f32::EPSILON as f64 * pg[b],
                "GLSL density of bin {b} is not its alias probability: {} vs {}",
                got[b].pdf as f64 * cfg.bins.solid_angle() as f64,
                pg[b]
            );
        }
    }
    assert!(learned_rows > 0, "{what}: no row learned");
    assert!(worst <= 1e-4, "{what}: GLSL and Rust sampling rows differ by up to {worst} in a bin's probability");
}

/// The learning period (`RecordSchedule::learning_period`): images of
/// `LEARN_PIXEL_FRAMES` pixels and more learn once per recording cycle, smaller
/// ones once in the fewest frames, a power of two, that trace as many pixels.
/// Past the first frames (which learn after each) every pass ends a recording
/// cycle, and passes come exactly once per period.
#[test]
fn small_images_learn_once_in_several_cycles() {
    use rlpt::guide::{RecordSchedule, LEARN_PIXEL_FRAMES, MAX_LEARNING_PERIOD};
    use rlpt::shared::RECORD_FIRST_FRAMES;
    let n = LEARN_PIXEL_FRAMES;
    let min = RecordSchedule::min_learning_period;
    assert_eq!((min(n), min(2 * n), min(n - 1), min(n / 4), min(n / 4 - 1)), (1, 1, 2, 4, 8));
    assert_eq!((min(1), min(0)), (MAX_LEARNING_PERIOD, MAX_LEARNING_PERIOD));
    for period in [1, 4, 32, MAX_LEARNING_PERIOD] {
        for (pixels, entries) in [(64 * 40, 6400u64), (64 * 40, 1 << 20), (1 << 20, 4096)] {
            let s = RecordSchedule::new(pixels, entries, period);
            let mut since = 0; // frames since the last pass
            for f in 0..20000u32 {
                let (stride, learns) = (s.stride(f), s.learns_after(f));
                since += 1;
                if f < RECORD_FIRST_FRAMES {
                    assert!(learns, "period {period}, {pixels} px: frame {f} of the first frames does not learn");
                } else {
                    let expected = stride.max(period);
                    assert_eq!(s.learning_period(f), expected, "period {period}, {pixels} px: frame {f}");
                    assert_eq!(learns, f % expected == expected - 1, "period {period}, {pixels} px: frame {f}");
                    if learns {
                        assert_eq!(f % stride, stride - 1, "period {period}, {pixels} px: frame {f} ends no cycle");
                        assert!(
                            since <= expected,
                            "period {period}, {pixels} px: {since} frames before frame {f}'s pass"
                        );
                    }
                }
                if learns {
                    since = 0;
                }
            }
        }
    }
}

/// The recording schedule (`RecordSchedule`): every row records in the first
/// frames (one in `first_stride` over large images), then one row in 8, 16 and 32, the stride doubling at the first frame
/// that is a multiple of the new stride once the paths recorded so far reach
/// `RECORD_PATHS_PER_ENTRY` per table entry, then twice as many; within each
/// cycle of `stride` frames every row records exactly once, and the sampling rows
/// are rebuilt after the cycle's last frame.
#[test]
fn recording_stride_doubles_as_the_table_fills() {
    use rlpt::guide::{RecordSchedule, RECORD_PATHS_PER_ENTRY};
    use rlpt::shared::{RECORD_FIRST_FRAMES, RECORD_MAX_STRIDE, RECORD_ROW_STRIDE, SAMPLES_PER_FRAME};
    assert_eq!((RECORD_FIRST_FRAMES, RECORD_ROW_STRIDE, RECORD_MAX_STRIDE), (8, 8, 32), "the schedule documented");
    let frames = 20000u32;
    // (pixels, entries): a thumbnail and door.toml's size over door's table of 8x16
    // bins, door's size over its table of 20x40 bins (door has Russian roulette),
    // a large image over a small table. Door's tables are those of its 16-cell grid
    // (a small image's: `default_grid_cells`).
    let door_scene = scene("door.toml");
    let door_entries = |bins: Option<Bins>| {
        let mut o = guided(&options(&door_scene, 48, 32, 64), GuidingMode::Sphere);
        o.bins = bins;
        PreparedScene::new(&door_scene, &o).expect("valid options").guide.unwrap().entries() as u64
    };
    let (door_8x16, door_default) = (door_entries(Some(Bins::SPHERE_DEFAULT)), door_entries(None));
    assert_eq!(16 * door_default, 100 * door_8x16, "door's default bins are 20x40");
    let cases = [(48 * 32, door_8x16), (480 * 320, door_8x16), (480 * 320, door_default), (640 * 480, 4096)];
    for (case, (pixels, entries)) in cases.into_iter().enumerate() {
        let s = RecordSchedule::new(pixels, entries, 1);
        let per_entry = (pixels * SAMPLES_PER_FRAME as u64) as f64 / entries as f64;
        let mut recorded = 0.0; // paths per entry recorded before frame f
        let mut history = std::collections::HashMap::new(); // cycle start -> recorded before it
        let mut threshold = RECORD_PATHS_PER_ENTRY;
        let mut stride_start = 0; // where the current stride began
        let mut f = 0;
        while f < frames {
            let stride = s.stride(f);
            history.insert(f, recorded);
            let expected_stride = match f < RECORD_FIRST_FRAMES {
                true => RecordSchedule::first_stride(pixels),
                false => s.stride(f - 1).max(RECORD_ROW_STRIDE),
            };
            if stride != expected_stride {
                // A doubling: once the threshold is reached, at the first multiple of the
                // new stride since then (and since the last change of stride).
                assert_eq!(stride, 2 * expected_stride, "{pixels} px: frame {f}");
                // To the rounding of the sum above: door at 20x40 reaches 1024 paths
                // per entry after exactly 88 frames' worth, which sums to 1023.99999999.
                assert!(
                    recorded >= threshold * (1.0 - 1e-12),
                    "{pixels} px: doubled at frame {f} with {recorded} per entry"
                );
                if f >= stride && f - stride >= stride_start.max(RECORD_FIRST_FRAMES) {
                    let before = history[&(f - stride)];
                    assert!(
                        before < threshold,
                        "{pixels} px: frame {f} doubles late ({before} at frame {})",
                        f - stride
                    );
                }
                threshold *= 2.0;
            }
            if stride != expected_stride || f == RECORD_FIRST_FRAMES {
                stride_start = f;
            }
            assert!(stride <= RECORD_MAX_STRIDE, "{pixels} px: frame {f}");
            assert_eq!(f % stride, 0, "{pixels} px: a cycle starts at frame {f}, not a multiple of {stride}");
            for k in 0..stride {
                assert_eq!(s.stride(f + k), stride, "{pixels} px: the stride changes in the cycle from frame {f}");
                // The first frames learn after each, whatever their stride.
                let learns = s.learns_after(f + k);
                let expected = f + k < RECORD_FIRST_FRAMES || k == stride - 1;
                assert_eq!(learns, expected, "{pixels} px: the table learns after frame {}", f + k);
            }
            for y in 0..100 {
                let n = (f..f + stride).filter(|&g| s.records(g, y)).count();
                assert_eq!(n, 1, "{pixels} px: row {y} records {n} times in frames {f}..{}", f + stride);
            }
            recorded += per_entry;
            f += stride;
        }
        let last = s.stride(frames);
        match case {
            // A thumbnail over door's 8x16 table records one row in 8 for ten thousand
            // frames and more; door at its size (its first frames recording one row in
            // 2) reaches 16 from frame 96 and 32 from 320, and over its default table of
            // 6.25 times the entries, 16 from frame 688 and 32 from 2080; a small table at once.
            0 => assert_eq!((s.stride(8), s.stride(10000), last), (8, 8, 16), "{s:?}"),
            1 => assert_eq!((s.stride(8), s.stride(95), s.stride(96), s.stride(320)), (8, 8, 16, 32), "{s:?}"),
            2 => assert_eq!((s.stride(687), s.stride(688), s.stride(2079), s.stride(2080)), (8, 16, 16, 32), "{s:?}"),
            _ => assert_eq!((s.stride(8), s.stride(16), s.stride(32)), (8, 16, 32), "{s:?}"),
        }
    }
}

/// After the first frames the GPU table learns after the last frame of each
/// recording cycle (`RecordSchedule::learns_after`), or with a learning period
/// of 32 frames, of each 32-frame block: then the targets of the cycles since
/// the last pass are folded in and the sampling rows built from the table as it
/// stands; after the other frames the table, its visit counts and its rows are
/// the previous frame's, bit for bit. Both ways of rendering a frame (batched and
/// profiled); a table of one cell of 8x16 bins, so that the stride reaches 8 and
/// 16 within the frames rendered. Every row records once per cycle, so a fold adds
/// about as many targets per cycle as one of the first frames, where every row
/// records (a fold that kept the last frame's targets alone would add 1/8 or 1/16
/// of it).
#[test]
fn the_table_learns_on_schedule() {
    let ctx = gpu();
    let mut scene = scene("door.toml");
    scene.guiding.resolution = Some([1, 1, 1]);
    // After frames 0 to 7, 15 (stride 8), 31 (16), 63 and 95 (32); with a period
    // of 32 after frames 0 to 7, 31, 63 and 95.
    for (period, passes) in [(1, 12), (32, 11)] {
        let mut o = guided(&options(&scene, 32, 24, 64), GuidingMode::Sphere);
        // 8x16 bins: door's default, 20x40 (door has Russian roulette), has 6.25 times
        // the entries, and over it the stride would reach 32 only after the frames rendered.
        o.bins = Some(Bins::SPHERE_DEFAULT);
        o.learning_period = Some(period);
        let prepared = PreparedScene::new(&scene, &o).expect("valid options");
        let cfg = prepared.guide.unwrap();
        let schedule = RecordSchedule::for_render(&cfg, 32, 24);
        let mut r = GpuRenderer::new(&ctx, &prepared).unwrap();
        let mut before: Option<QTable> = None;
        let frames = 3 * rlpt::shared::RECORD_MAX_STRIDE;
        assert_eq!((schedule.stride(8), schedule.stride(frames - 1)), (8, 32), "{schedule:?}");
        let visits = |t: &QTable| t.visits.iter().map(|&v| v as u64).sum::<u64>();
        let (mut learned, mut kept) = (0, 0);
        let mut all_rows_frame = Vec::new(); // targets folded after each of frames 1 to 7
        let mut cycles = 0.0; // recording cycles since the last pass
        for frame in 0..frames {
            if frame % 2 == 0 {
                r.render_frames(1).unwrap();
            } else {
                r.render_frame_profiled().unwrap();
            }
            cycles += 1.0 / schedule.stride(frame) as f64;
            let t = r.table().unwrap().unwrap();
            let at = format!("period {period}, after frame {frame}");
            if schedule.learns_after(frame) {
                assert_rows_built_from_table(&t, &cfg, &at);
                if let Some(b) = &before {
                    let added = visits(&t) - visits(b);
                    if frame < rlpt::shared::RECORD_FIRST_FRAMES {
                        all_rows_frame.push(added as f64);
                    } else {
                        let mean = all_rows_frame.iter().sum::<f64>() / all_rows_frame.len() as f64;
                        assert!(
                            (0.7..1.4).contains(&(added as f64 / (mean * cycles))),
                            "{at}: the fold added {added} targets over {cycles} recording cycles, \
                             against {mean} after a frame where every row records"
                        );
                    }
                    assert!(t.q != b.q, "{at}: the table learned nothing");
                }
                learned += 1;
                cycles = 0.0;
            } else {
                let b = before.as_ref().expect("the first frame learns");
                assert!(t.rows == b.rows, "{at}: the rows changed, though the table does not learn then");
                assert!(t.q == b.q && t.visits == b.visits, "{at}: the table changed");
                kept += 1;
            }
            before = Some(t);
        }
        assert_eq!((learned, kept), (passes, frames - passes), "period {period}: the schedule was exercised");
    }
    assert_no_validation_messages(&ctx);
}

/// Per-pixel variance of a render, from two independent renders a and b: mean over
/// pixels and channels of (a - b)^2 / 2.
fn variance_from_pair(a: &Film, b: &Film) -> (f64, f64) {
    let (ma, mb) = (a.mean(), b.mean());
    let (mut s, mut rel) = (0.0f64, 0.0f64);
    for (x, y) in ma.pixels.iter().zip(&mb.pixels) {
        for c in 0..3 {
            let d = (x[c] - y[c]) as f64;
            let m = (x[c] + y[c]) as f64 / 2.0;
            s += d * d / 2.0;
            rel += d * d / 2.0 / (m * m + 0.01);
        }
    }
    let n = (3 * ma.pixels.len()) as f64;
    (s / n, rel / n)
}

/// Renders `frames` frames after `warmup` frames of learning whose image is discarded.
fn render_after_warmup(ctx: &Arc<Context>, scene: &Scene, opts: &RenderOptions, warmup: u32, frames: u32) -> Film {
    let prepared = PreparedScene::new(scene, opts).expect("valid options");
    let mut r = GpuRenderer::new(ctx, &prepared).unwrap();
    if warmup > 0 {
        r.render_frames(warmup).unwrap();
        r.reset_accumulation().unwrap();
    }
    r.render_frames(frames).unwrap();
    r.film().unwrap()
}

/// Issue 3: on door.toml, after a warm-up, guided sampling's per-pixel variance is
/// at most half the best unguided setting's at the same spp. Variance is measured
/// relative to each pixel's squared mean (the per-pixel term of relMSE, with the
/// same 0.01 in the denominator as `rlpt compare`): absolute variance is dominated
/// by the few bright pixels that see the lamp-lit far room through the gap, whose
/// light NEE already samples well, while the near room, lit only through the gap,
/// is where plain path tracing struggles. The absolute figures are printed too.
///
/// 32 warm-up frames, then 16 measured (1024 spp; learning goes on through them).
/// With 16 and 8 the guided renders were still learning fast and the test sat on
/// the bound: over six seed pairs the ratio averaged 0.49, and the named pair gave
/// 0.446, 0.499 or 0.500 from run to run (float atomics fold the targets in the
/// order lanes arrive), so it failed by chance. At 32 + 16 the six pairs gave 0.38
/// to 0.41 (BENCHMARKS.md, "Variance at equal samples") with the first two
/// vertices guided over 8x16 bins. With every vertex over 12x24 bins (door has
/// Russian roulette) the named pair gave 0.28 to 0.37 in four runs, and 16x32
/// bins learned too slowly for this size (0.43 to 0.62 over the six pairs, which
/// failed the test about half the time). With MIS-weighted targets, the floor at
/// 0.1 and 20x40 bins, today's defaults (`guide::default_bins`): 0.193
/// and 0.237 for the named pair, 0.165 to 0.223 over six others (seeds p and p + 100).
#[test]
fn learning_reduces_variance_on_door() {
    let ctx = gpu();
    let scene = scene("door.toml");
    let base = options(&scene, 48, 32, 64);
    let (warmup, frames) = (32, 16);
    let mut results = Vec::new();
    for (mode, nee) in [(GuidingMode::Off, true), (GuidingMode::Off, false), (GuidingMode::Sphere, true)] {
        let mut o = base.clone();
        o.guiding = mode;
        o.nee = nee;
        o.seed = 100;
        let a = render_after_warmup(&ctx, &scene, &o, if mode == GuidingMode::Off { 0 } else { warmup }, frames);
        o.seed = 200;
        let b = render_after_warmup(&ctx, &scene, &o, if mode == GuidingMode::Off { 0 } else { warmup }, frames);
        let (v, rel) = variance_from_pair(&a, &b);
        eprintln!(
            "door 48x32, {} spp after warm-up: guiding {mode:?} NEE {nee}: per-pixel variance {v:.4e}, relative {rel:.4e}",
            frames * 64
        );
        results.push((v, rel));
    }
    let best = |f: fn(&(f64, f64)) -> f64| f(&results[0]).min(f(&results[1]));
    let abs_ratio = results[2].0 / best(|r| r.0);
    let ratio = results[2].1 / best(|r| r.1);
    eprintln!("guided / best unguided: relative variance {ratio:.3}, absolute variance {abs_ratio:.3}");
    assert!(ratio <= 0.5, "guided relative variance is {ratio:.3} of the best unguided: learning does not pay");
    assert_no_validation_messages(&ctx);
}

/// mean3 of a pixel's sum, as `math::mean3` computes it.
fn mean3(sum: &[f32]) -> f32 {
    rlpt::math::mean3(Vec3::from_slice(&sum[..3]))
}

/// The frame after the learning frames starts the image (CPU renderer): the film
/// then holds the learning frames' mean as its first frame and that frame as its
/// second, whose samples are those of a render without learning frames (learned
/// roulette's estimate counts the same frames). A part of a split render
/// (`Learned::Keep`) leaves the learning frames out and keeps their mean3 sum
/// beside the image for learned roulette.
#[test]
fn the_cpu_image_takes_the_learning_frames_in_as_one_frame() {
    let scene = scene("door.toml");
    let mut o = guided(&options(&scene, 24, 16, 64), GuidingMode::Sphere);
    o.seed = 3;
    let learning = rlpt::guide::default_learning_frames(true);
    assert_eq!(learning, 4, "door has roulette");
    let render = |learning_frames: u32, frames: u32, learned: Learned| {
        let mut o = o.clone();
        o.learning_frames = Some(learning_frames);
        let mut r = CpuRenderer::new(&PreparedScene::new(&scene, &o).unwrap());
        r.set_learned(learned);
        let mut films = Vec::new();
        for _ in 0..frames {
            r.render_frame();
            films.push(r.film().clone());
        }
        films
    };
    let with = render(learning, learning + 2, Learned::Fold);
    let without = render(0, learning + 2, Learned::Fold);
    let l = learning as usize;
    // Until the image starts, the two renders are the same.
    assert_eq!(with[l - 1].pixels, without[l - 1].pixels);
    assert_eq!((with[l - 1].frames, with[l].frames, with[l + 1].frames), (learning, 2, 3));
    let mut lit = 0;
    for (i, p) in with[l].pixels.iter().enumerate() {
        let (before, after) = (&without[l - 1].pixels[i], &without[l].pixels[i]);
        assert_eq!(p.sum[3], 0.0, "pixel {i}: the learning frames are in the image");
        for c in 0..3 {
            // The same frame: the render without learning frames added it to their sums.
            let frame = after.sum[c] - before.sum[c];
            let held = before.sum[c] / learning as f32;
            let tol = 1e-5 * after.sum[c].abs().max(1.0);
            assert!((p.sum[c] - (held + frame)).abs() <= tol, "pixel {i}: {p:?} {held} + {frame}");
            // Welford over two frame means: half their squared difference.
            let (a, b) = (held / 64.0, frame / 64.0);
            let m2 = 0.5 * (a - b) * (a - b);
            assert!((p.m2_frame_mean[c] - m2).abs() <= 1e-4 * m2.max(1e-3), "pixel {i}: {p:?} m2 {m2}");
        }
        lit += (p.sum[0] > 0.0) as u32;
    }
    assert!(lit > 50, "only {lit} pixels lit");
    // A part: the image starts anew and keeps the learning frames' mean3 sum.
    let part = render(learning, learning + 2, Learned::Keep);
    assert_eq!((part[l].frames, part[l + 1].frames), (1, 2));
    for (i, p) in part[l].pixels.iter().enumerate() {
        assert_eq!(p.sum[3], mean3(&part[l - 1].pixels[i].sum), "pixel {i} keeps the learning frames' mean3 sum");
        assert_eq!(p.m2_frame_mean, [0.0; 4], "pixel {i}: one frame has no spread");
    }
    assert!(part[l + 1].pixels.iter().zip(&part[l].pixels).all(|(b, a)| b.sum[3] == a.sum[3]));
}

/// The same on the GPU: the kernel's first accumulation takes the learning
/// frames' mean in as the image's first frame (`fold_learned`), or for a part of
/// a split render (`Learned::Keep`) writes over them and keeps their mean3 sum in `sum.w`.
#[test]
fn the_gpu_image_takes_the_learning_frames_in_as_one_frame() {
    let ctx = gpu();
    let scene = scene("door.toml");
    let o = guided(&options(&scene, 24, 16, 64), GuidingMode::Sphere);
    let learning = rlpt::guide::default_learning_frames(true);
    let start = |learned: Learned| {
        let mut r = GpuRenderer::new(&ctx, &PreparedScene::new(&scene, &o).unwrap()).unwrap();
        r.set_learned(learned);
        r.render_frames(learning).unwrap();
        let before = r.film().unwrap();
        assert_eq!((r.frames(), before.frames), (learning, learning));
        r.render_frames(1).unwrap();
        (r, before)
    };
    let (mut r, before) = start(Learned::Fold);
    let first = r.film().unwrap();
    assert_eq!(first.frames, 2);
    let mut changed = 0;
    for (i, (p, b)) in first.pixels.iter().zip(&before.pixels).enumerate() {
        assert_eq!(p.sum[3], 0.0, "pixel {i}: the learning frames are in the image");
        for c in 0..3 {
            // The image's two frame means: the learning frames' and the new frame's.
            let held = b.sum[c] / learning as f32;
            let (a, m) = (held / 64.0, (p.sum[c] - held) / 64.0);
            let m2 = 0.5 * (a - m) * (a - m);
            let tol = 1e-4 * m2.max(1e-6) + 1e-5 * (a * a + m * m);
            assert!((p.m2_frame_mean[c] - m2).abs() <= tol, "pixel {i}: {p:?} against {m2} from {b:?}");
        }
        changed += (p.sum[..3] != b.sum[..3]) as u32;
    }
    assert!(changed > 50, "only {changed} pixels have a new sum");
    r.render_frames(2).unwrap();
    assert_eq!(r.film().unwrap().frames, 4);
    // Restarting the accumulation (the viewer, when the camera moves) starts with nothing held.
    r.reset_accumulation().unwrap();
    r.render_frames(1).unwrap();
    let restarted = r.film().unwrap();
    assert_eq!(restarted.frames, 1);
    assert!(restarted.pixels.iter().all(|p| p.sum[3] == 0.0));

    let (mut part, before) = start(Learned::Keep);
    let first = part.film().unwrap();
    assert_eq!(first.frames, 1);
    for (i, (p, b)) in first.pixels.iter().zip(&before.pixels).enumerate() {
        let kept = mean3(&b.sum);
        assert!((p.sum[3] - kept).abs() <= 1e-6 * kept.abs(), "pixel {i}: {} kept, {kept} learned", p.sum[3]);
        assert_eq!(p.m2_frame_mean, [0.0; 4], "pixel {i}: one frame has no spread");
    }
    part.render_frames(2).unwrap();
    let later = part.film().unwrap();
    assert_eq!(later.frames, 3);
    assert!(later.pixels.iter().zip(&first.pixels).all(|(b, a)| b.sum[3] == a.sum[3]));
    assert_no_validation_messages(&ctx);
}

/// The default grid covers where light goes: smallpt framed wider than 4:3 starts
/// its edge rays behind the side walls, in an unlit gap that reaches far out
/// (what the camera sees spans hundreds of units there), and the grid still
/// covers the room alone, as at 4:3. Door, lit through a gap, keeps the box of
/// all it sees.
#[test]
fn the_default_grid_covers_the_lit_room_at_any_aspect() {
    let grid = |name: &str, w: u32, h: u32| {
        let scene = scene(name);
        let mut o = options(&scene, w, h, 64);
        o.guiding = GuidingMode::Sphere;
        let prepared = PreparedScene::new(&scene, &o).unwrap();
        (prepared.guide.as_ref().unwrap().grid, rlpt::guide::probe_bounds(&prepared))
    };
    let (wide, seen) = grid("smallpt.toml", 64, 40);
    assert!(seen.0.x < -100.0 && seen.1.x > 200.0, "the camera sees the gap behind the walls: {seen:?}");
    // The room spans x 1 to 99, y 0 to 81.6 and z 0 to 170; the camera, at z 295.6,
    // is no vertex and stays out.
    let margin = 0.01 * (Vec3::new(98.0, 81.6, 170.0).length() + 10.0);
    assert!(wide.min.cmpge(Vec3::new(1.0, 0.0, 0.0) - margin).all(), "{wide:?}");
    assert!(wide.max.cmple(Vec3::new(99.0, 81.6, 170.0) + margin).all(), "{wide:?}");
    let (square, _) = grid("smallpt.toml", 64, 48);
    assert_eq!(wide.res, square.res);
    assert!((wide.min - square.min).abs().max_element() < 0.01 && (wide.max - square.max).abs().max_element() < 0.01);
    let (door, door_seen) = grid("door.toml", 64, 40);
    let off = (door.min - door_seen.0).abs().max((door.max - door_seen.1).abs()).max_element();
    assert!(off < 1e-3, "door's grid {door:?} against what it sees {door_seen:?}");
}

/// The default grid: 24 cells along the longest axis with Russian roulette over
/// an image of at least LEARN_PIXEL_FRAMES pixels, 16 over smaller images and
/// without roulette, and fewer where the sampling rows would pass the storage
/// buffer every device allows.
#[test]
fn the_default_grid_is_finer_over_large_images_with_roulette() {
    use rlpt::guide::{default_grid_cells, LEARN_PIXEL_FRAMES, NORMAL_CLASSES, PORTABLE_BUFFER_BYTES};
    let cfg = |name: &str, w: u32, h: u32| {
        let scene = scene(name);
        let o = guided(&options(&scene, w, h, 64), GuidingMode::Sphere);
        *PreparedScene::new(&scene, &o).unwrap().guide.as_ref().unwrap()
    };
    assert_eq!(
        (default_grid_cells(true, LEARN_PIXEL_FRAMES), default_grid_cells(true, LEARN_PIXEL_FRAMES - 1)),
        (24, 16)
    );
    assert_eq!(default_grid_cells(false, 1 << 30), 16);
    // Door's box is 9.2 x 3.2 x 6.2.
    assert_eq!(cfg("door.toml", 480, 320).grid.res, [24, 8, 16]);
    assert_eq!(cfg("door.toml", 48, 32).grid.res, [16, 6, 11]);
    let exp1 = cfg("seed-exp1.toml", 360, 240).grid.res;
    assert_eq!(exp1.into_iter().max(), Some(16), "seed-exp1 has no roulette: {exp1:?}");
    // smallpt's room at 24 along z would take 14x12x24 cells, whose 20x40-bin rows pass 128 MiB.
    let big = cfg("smallpt.toml", 640, 480);
    let rows = |c: u32| c as u64 * big.bins.count() as u64 * NORMAL_CLASSES as u64 * 8;
    assert!(rows(14 * 12 * 24) > PORTABLE_BUFFER_BYTES);
    assert!(rows(big.grid.cells()) <= PORTABLE_BUFFER_BYTES, "{:?}", big.grid);
    assert_eq!(big.grid.res[2], 23, "{:?}", big.grid);
}

/// Guided renders of the scenes with roulette, whose rows of 20x40 bins the
/// learning pass rebuilds after each early frame, run to the end at 64x40: on
/// lavapipe, groups that stepped through several rows' rebuilds crashed inside
/// the shader on smallpt (src/render/learning.rs `CPU_FOLD_STEPS`).
#[test]
fn small_guided_renders_of_the_roulette_scenes_finish() {
    for scene in ["scenes/smallpt.toml", "scenes/door.toml"] {
        let out = common::cli::tmp("small-guided.exr");
        let args = [
            "render",
            scene,
            "--width",
            "64",
            "--height",
            "40",
            "--spp",
            "128",
            "--guiding",
            "sphere",
            "-o",
            out.to_str().unwrap(),
        ];
        let (ok, err) = common::cli::run(&args);
        assert!(ok, "{scene}: {err}");
        assert!(out.exists(), "{scene}: no image written");
    }
}
