//! Learned guiding keeps the image unbiased: guided and unguided renders agree
//! (GPU and CPU), glossy vertices mix a share of the fraction, guided frames trace
//! every pixel once, the MIS weights with the mixture sum to one, and guiding
//! limited to a path's first vertices records targets only there without roulette.

mod common;

use common::guiding::*;
use common::*;
use rlpt::guide::{lobe_share, GuidingMode, QTable, Recorder};
use rlpt::math::bsdf::Bsdf;
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::{MaterialKind, Scene};

#[test]
fn guided_and_unguided_renders_agree_in_mean() {
    let ctx = gpu();
    for (name, w, h, spp) in
        [("door.toml", 36, 24, 2048), ("seed-exp1.toml", 36, 24, 1024), ("seed-exp2.toml", 36, 24, 1024)]
    {
        let scene = scene(name);
        let base = options(&scene, w, h, spp);
        let off = render_gpu(&ctx, &scene, &base);
        for (i, mode) in [GuidingMode::Octant, GuidingMode::Sphere].into_iter().enumerate() {
            let mut o = guided(&base, mode);
            o.seed = 10 + i as u32;
            let g = render_gpu(&ctx, &scene, &o);
            let z = assert_films_agree(&g, &off, 6, K, &format!("{name}: guiding {mode:?} vs off (GPU)"));
            eprintln!("{name} {mode:?}: worst block {z:.2} sigma");
        }
    }
}

/// A scene of `scenes/` with the text `from` (which it must hold) replaced by `to`.
fn edited_scene(name: &str, from: &str, to: &str) -> Scene {
    let text = std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).expect(name);
    assert!(text.contains(from), "{name} holds {from:?}");
    Scene::parse(&text.replace(from, to), &format!("{name}, edited")).expect("the edited scene parses")
}

fn share_of(kind: MaterialKind, roughness: f32) -> f32 {
    lobe_share(&Bsdf::new(kind, Vec3::splat(0.75), roughness * roughness, 1.5))
}

/// The share of the guided fraction is 1 on diffuse surfaces and 4 alpha^2 on
/// glossy ones, at most 1, growing with the roughness, and 0 where 4 alpha^2 is
/// below 1/16 (roughness below 0.354: the seed's copper, 0.3, and gold, 0.08).
#[test]
fn lobe_share_is_the_glossy_lobes_width_over_the_cosine_lobes() {
    assert_eq!(share_of(MaterialKind::Diffuse, 0.0), 1.0);
    for (roughness, share) in [
        (0.08, 0.0),
        (0.3, 0.0),
        (0.353, 0.0),
        (0.354, 0.062_816_4),
        (0.5, 0.25),
        (0.7, 0.9604),
        (0.8, 1.0),
        (1.0, 1.0),
    ] {
        let s = share_of(MaterialKind::Glossy, roughness);
        assert!((s - share).abs() <= 1e-6 * share.max(1.0), "roughness {roughness}: share {s}, expected {share}");
    }
    let mut last = 0.0;
    for i in 1..=100 {
        let s = share_of(MaterialKind::Glossy, i as f32 / 100.0);
        assert!(s >= last && s <= 1.0, "share {s} at roughness {} after {last}", i as f32 / 100.0);
        last = s;
    }
}

/// Glossy vertices take part of the guided fraction (`guide::lobe_share`): seed-exp1
/// with its white walls, floor, ceiling and ball made glossy of roughness 0.6
/// (share 4 alpha^2 = 0.52), so that most guided vertices mix at a fraction
/// between 0 and the setting's. If sampling and density disagreed about the
/// fraction, the guided images would be biased there: GPU and CPU guided renders
/// agree with the unguided one.
#[test]
fn glossy_vertices_mix_a_share_of_the_fraction_without_bias() {
    let scene = edited_scene(
        "seed-exp1.toml",
        "name = \"white\"\ntype = \"diffuse\"\nalbedo = [0.75, 0.75, 0.75]",
        "name = \"white\"\ntype = \"glossy\"\nalbedo = [0.75, 0.75, 0.75]\nroughness = 0.6",
    );
    assert!((share_of(MaterialKind::Glossy, 0.6) - 0.5184).abs() < 1e-4, "roughness 0.6's share");

    let ctx = gpu();
    let base = options(&scene, 36, 24, 1024);
    let off = render_gpu(&ctx, &scene, &base);
    let mut o = guided(&base, GuidingMode::Sphere);
    // The share of the row's fraction, not the product with the lobe (tests/guiding_product.rs).
    o.glossy_product = false;
    o.seed = 31;
    let z = assert_films_agree(&render_gpu(&ctx, &scene, &o), &off, 6, K, "glossy seed-exp1: GPU guided vs off");
    eprintln!("glossy seed-exp1, GPU guided: worst block {z:.2} sigma");
    (o.width, o.height, o.spp, o.seed) = (18, 12, 512, 32);
    let mut off_small = base.clone();
    (off_small.width, off_small.height, off_small.spp) = (18, 12, 512);
    let z = assert_films_agree(
        &render_cpu(&scene, &o),
        &render_gpu(&ctx, &scene, &off_small),
        4,
        K,
        "glossy seed-exp1: CPU guided vs GPU off",
    );
    eprintln!("glossy seed-exp1, CPU guided: worst block {z:.2} sigma");
    assert_no_validation_messages(&ctx);
}

/// After the first frames, a guided frame traces its pixel rows in two dispatches
/// (`frame_dispatches`: the rows that record targets by one kernel, the others by
/// another). Every camera ray here escapes to a sky of radiance 1, so each sample
/// is exactly 1, and a row traced twice or not at all in a frame shows in its
/// mean exactly. The film is checked after every frame (errors of different
/// frames could cancel over a cycle of the rows that record); 13 rows is no
/// multiple of the row stride.
#[test]
fn guided_frames_trace_every_pixel_once() {
    let ctx = gpu();
    let scene = edited_scene("furnace-open.toml", "look_at = [0.0, 0.0, 0.0]", "look_at = [0.0, 0.0, 8.0]");
    let mut o = guided(&options(&scene, 9, 13, 64), GuidingMode::Sphere);
    o.seed = 3;
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    assert!(prepared.guide.is_some(), "the render is guided");
    let mut r = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    let stride = rlpt::shared::RECORD_ROW_STRIDE;
    for frame in 0..rlpt::shared::RECORD_FIRST_FRAMES + 2 * stride {
        // Both ways of rendering a frame: in a batch, and one per submission.
        if frame % 2 == 0 {
            r.render_frames(1).expect("render");
        } else {
            r.render_frame_profiled().expect("render, profiled");
        }
        let film = r.film().expect("readback");
        assert_eq!(film.frames, frame + 1);
        for (i, p) in film.mean().pixels.iter().enumerate() {
            assert_eq!(*p, [1.0; 3], "pixel ({}, {}) after frame {frame}", i % 9, i / 9);
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Learning frames over an image of at least twice `FIRST_RECORD_PIXELS` pixels
/// record one row in `RecordSchedule::first_stride`, and trace the other rows by
/// the unguided kernel (`GpuRenderer::cmd_trace`; on the CPU, unguided paths):
/// every pixel is still traced once per frame, on the GPU and the CPU alike, as
/// are the image's frames after them, whose first takes the learning frames' mean
/// in (`film::Learned::Fold`). Every camera ray escapes to a sky of radiance 1;
/// the ball is a mirror, whose guided kernel groups more pixels than the unguided.
#[test]
fn learning_frames_over_large_images_trace_every_pixel_once() {
    let ctx = gpu();
    let text = std::fs::read_to_string(format!("{}/scenes/furnace-open.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let text = text.replace("look_at = [0.0, 0.0, 0.0]", "look_at = [0.0, 0.0, 8.0]");
    let scene =
        Scene::parse(&text.replace("type = \"diffuse\"", "type = \"specular\""), "furnace-open, edited").unwrap();
    assert_eq!(scene.materials[0].kind, MaterialKind::Specular, "the ball is a mirror");
    let (w, h) = (512, 256);
    assert_eq!(rlpt::guide::RecordSchedule::first_stride(w as u64 * h as u64), 2);
    let mut o = guided(&options(&scene, w, h, 64), GuidingMode::Sphere);
    o.learning_frames = Some(2);
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    let mut gpu = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    let mut cpu = rlpt::cpu::CpuRenderer::new(&prepared);
    // Two learning frames, then two of the image: the first holds the learning frames' mean.
    for (frame, frames) in [(0, 1), (1, 2), (2, 2), (3, 3)] {
        gpu.render_frames(1).expect("render");
        cpu.render_frame();
        for (film, what) in [(gpu.film().expect("readback"), "GPU"), (cpu.film().clone(), "CPU")] {
            assert_eq!(film.frames, frames, "{what}: frame {frame}");
            for (i, p) in film.mean().pixels.iter().enumerate() {
                assert_eq!(*p, [1.0; 3], "{what}: pixel ({}, {}) after frame {frame}", i as u32 % w, i as u32 / w);
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn guided_cpu_agrees_with_unguided_gpu() {
    let ctx = gpu();
    let scene = scene("seed-exp2.toml");
    let base = options(&scene, 32, 24, 512);
    let off = render_gpu(&ctx, &scene, &base);
    let mut o = guided(&base, GuidingMode::Sphere);
    o.seed = 3;
    let g = render_cpu(&scene, &o);
    assert_films_agree(&g, &off, 4, K, "seed-exp2: CPU guided sphere vs GPU unguided");
    o.nee = false;
    o.seed = 4;
    let g = render_cpu(&scene, &o);
    assert_films_agree(&g, &off, 4, K, "seed-exp2: CPU guided sphere NEE off vs GPU unguided");
}

/// The MIS weights between light sampling and the guided mixture use the
/// mixture's density, at the light sample and where a mixture direction meets the
/// light alike (src/cpu/path.rs `light_sample`, `mixture_sample`): weights that sum to one keep the
/// image unbiased. Seed-exp1, lit directly by a small light, guided with a fixed
/// fraction of 0.9 so that the mixture's density toward the light is far from the
/// BSDF's: the CPU's guided render agrees with the GPU's unguided one over the
/// whole image (one block, whose mean has a small deviation) and block by block.
/// With the light sample weighed against the mixture's density and the light hit
/// against the BSDF's, weights that no longer sum to one, the whole-image test
/// failed at 28 sigma (a mutation tried once).
#[test]
fn mis_weights_with_the_mixture_sum_to_one() {
    let ctx = gpu();
    let scene = scene("seed-exp1.toml");
    let base = options(&scene, 32, 24, 2048);
    let off = render_gpu(&ctx, &scene, &base);
    let mut o = guided(&base, GuidingMode::Sphere);
    (o.learn_fraction, o.guided_fraction, o.seed) = (false, 0.9, 5);
    let g = render_cpu(&scene, &o);
    let z = assert_films_agree(&g, &off, 32, K, "seed-exp1: CPU guided (fraction 0.9) vs GPU unguided, whole image");
    eprintln!("seed-exp1, guided fraction 0.9 against unguided: whole image {z:.2} sigma");
    assert_films_agree(&g, &off, 4, K, "seed-exp1: CPU guided (fraction 0.9) vs GPU unguided, 4x4 blocks");
    o.seed = 6;
    let g = render_gpu(&ctx, &scene, &o);
    let z = assert_films_agree(&g, &off, 32, K, "seed-exp1: GPU guided (fraction 0.9) vs GPU unguided, whole image");
    eprintln!("seed-exp1, GPU guided fraction 0.9 against unguided: whole image {z:.2} sigma");
    assert_no_validation_messages(&ctx);
}

/// Guided sampling at every vertex or limited to a path's first vertices
/// (`guided_vertices`; the other tests render the default: every vertex on door.toml,
/// which has Russian roulette, the first 2 with NEE on the seed's scenes) keeps the image
/// unbiased: GPU renders guided at the first vertex and at all of them agree
/// with the unguided render within noise, and so does the CPU's. The setting
/// is seen to take effect on the CPU, path by path (guided renders do not repeat
/// bit for bit: learning sums targets in thread order).
#[test]
fn guiding_limited_to_first_vertices_stays_unbiased() {
    let ctx = gpu();
    let scene = scene("door.toml");
    let base = options(&scene, 36, 24, 2048);
    let off = render_gpu(&ctx, &scene, &base);
    let mut all = guided(&base, GuidingMode::Sphere);
    all.guided_vertices = Some(u32::MAX);
    for (limit, seed) in [(1, 21), (u32::MAX, 22)] {
        let mut o = all.clone();
        (o.guided_vertices, o.seed) = (Some(limit), seed);
        let what = format!("door: GPU guided at the first {limit} vertices vs off");
        let z = assert_films_agree(&render_gpu(&ctx, &scene, &o), &off, 6, K, &what);
        eprintln!("{what}: worst block {z:.2} sigma");
    }

    // On the CPU, recording paths traced one by one with the same random numbers
    // through the same learned table: a limit past the bounce limit changes no
    // path, a limit of 1 changes some. door.toml uses Russian roulette, so its
    // paths record at every vertex whatever the limit.
    (all.width, all.height, all.spp, all.seed) = (12, 8, 256, 23);
    let table = cpu_table(&scene, &all);
    let unlimited = cpu_paths(&scene, &all, u32::MAX, &table);
    assert_eq!(
        cpu_paths(&scene, &all, all.max_bounces + 1, &table),
        unlimited,
        "CPU: a limit past the bounce limit changes no path"
    );
    let first = cpu_paths(&scene, &all, 1, &table);
    let changed = first.iter().zip(&unlimited).filter(|(a, b)| a != b).count();
    assert!(
        changed > first.len() / 10,
        "CPU: guiding the first vertex alone changed only {changed} of {} paths",
        first.len()
    );
    assert!(most_records(&first) > 2, "CPU: with roulette, paths record past their guided vertices");
    let mut first_opts = all.clone();
    first_opts.guided_vertices = Some(1);
    let c_first = render_cpu(&scene, &first_opts);
    let mut off_small = base.clone();
    (off_small.width, off_small.height, off_small.spp) = (12, 8, 256);
    assert_films_agree(
        &c_first,
        &render_gpu(&ctx, &scene, &off_small),
        4,
        K,
        "door: CPU guided at 1 vertex vs GPU off",
    );
    assert_no_validation_messages(&ctx);
}

/// Recording paths of every pixel of `o` (16 each) traced on the CPU through
/// `table` with guided sampling at `limit` vertices: (radiance bits, rays, targets).
fn cpu_paths(scene: &Scene, o: &RenderOptions, limit: u32, table: &QTable) -> Vec<([u32; 3], u32, u32)> {
    let mut o = o.clone();
    o.guided_vertices = Some(limit);
    trace_recording_paths(scene, &o, table, || CountTargets(0))
        .into_iter()
        .map(|(radiance, segments, count)| (radiance, segments, count.0))
        .collect()
}

/// Counts the Q-learning targets a path records.
struct CountTargets(u32);

impl Recorder for CountTargets {
    fn target(&mut self, _: u32, _: f32) {
        self.0 += 1;
    }
    fn fraction_gradient(&mut self, _: u32, _: f32) {}
    fn row_read(&mut self, _: usize) {}
}

fn most_records(paths: &[([u32; 3], u32, u32)]) -> u32 {
    paths.iter().map(|p| p.2).max().unwrap_or(0)
}

/// Without Russian roulette (seed-exp1) only the rays that leave guided vertices
/// record targets: on the CPU a path guided at N vertices records at most N (and
/// some exactly N); on the GPU, in the first frames, where every path records, the
/// table's visits (exact integer counts) are at most N per path. With roulette
/// (door.toml) every vertex records, since learned roulette reads Q there.
#[test]
fn paths_record_only_from_guided_vertices_without_roulette() {
    let ctx = gpu();
    let exp1 = scene("seed-exp1.toml");
    let o = guided(&options(&exp1, 12, 8, 256), GuidingMode::Sphere);
    assert_eq!(o.russian_roulette_depth, None, "seed-exp1 renders without roulette");
    let table = cpu_table(&exp1, &o);
    assert!(most_records(&cpu_paths(&exp1, &o, u32::MAX, &table)) > 2, "CPU: unlimited paths record past 2 vertices");
    assert_eq!(most_records(&cpu_paths(&exp1, &o, 2, &table)), 2, "CPU: guided at 2 vertices, at most 2 targets");
    assert_eq!(most_records(&cpu_paths(&exp1, &o, 1, &table)), 1, "CPU: guided at 1 vertex, at most 1 target");

    let frames = 2;
    assert!(frames <= rlpt::shared::RECORD_FIRST_FRAMES, "every path records in these frames");
    let paths = (frames * 16 * 8 * rlpt::shared::SAMPLES_PER_FRAME) as u64;
    let per_path = |scene: &Scene, limit: u32| {
        let mut o = guided(&options(scene, 16, 8, 64), GuidingMode::Sphere);
        o.guided_vertices = Some(limit);
        let mut r = GpuRenderer::new(&ctx, &PreparedScene::new(scene, &o).expect("valid options")).unwrap();
        r.render_frames(frames).unwrap();
        let visits: u64 = r.table().unwrap().unwrap().visits.iter().map(|&v| v as u64).sum();
        if o.russian_roulette_depth.is_none() {
            assert!(visits <= limit as u64 * paths, "limit {limit}: {visits} targets from {paths} paths");
        }
        let per_path = visits as f64 / paths as f64;
        eprintln!("limit {limit}: {per_path:.3} targets per path");
        per_path
    };
    // Camera rays that reach the lamp or the sky record nothing, so per path the
    // counts are below the limits; each limit raised records clearly more.
    let (one, two, all) = (per_path(&exp1, 1), per_path(&exp1, 2), per_path(&exp1, u32::MAX));
    assert!(one > 0.3 && two > 1.3 * one && all > 1.3 * two, "seed-exp1: {one:.3}, {two:.3}, {all:.3} per path");
    let door_scene = scene("door.toml");
    assert!(door_scene.render.russian_roulette_depth.is_some(), "door.toml renders with roulette");
    let door = per_path(&door_scene, u32::MAX);
    let door_one = per_path(&door_scene, 1);
    assert!(
        door_one > 0.9 * door,
        "door (roulette), guided at 1 vertex: {door_one:.3} targets per path, {door:.3} at all"
    );
    assert_no_validation_messages(&ctx);
}
