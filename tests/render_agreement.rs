//! Statistical tests of whole renders, on the GPU (lavapipe in CI) and the CPU:
//! analytic furnaces, NEE on versus off, and GPU versus CPU on every shipped scene.
//! Tolerances are k standard deviations of the estimate, the deviation measured
//! from the renders' own per-pixel variance (spread of the 64-sample frame means).

mod common;

use common::*;
use rlpt::camera::camera_ray;
use rlpt::film::Film;
use rlpt::math::geometry::intersect_sphere;
use rlpt::math::sampler::SamplerKind;
use rlpt::options::{Counters, RenderOptions};
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;

/// 5 sigma: with a few hundred comparisons per test the chance of a false alarm stays below 1e-3.
const K: f64 = 5.0;

fn check_furnace_open(film: &Film, prepared: &PreparedScene, what: &str) {
    // Pixels whose whole footprint sees the ball, and pixels whose whole footprint misses it.
    let hits = |x: u32, y: u32| {
        [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
            .iter()
            .filter(|u| {
                let (o, d) = camera_ray(&prepared.params, x, y, **u);
                intersect_sphere(&prepared.spheres[0], o, d, f32::INFINITY).is_some()
            })
            .count()
    };
    let (ball, ball_var, n_ball) = region_stats(film, |x, y| hits(x, y) == 4);
    let (sky, sky_var, n_sky) = region_stats(film, |x, y| hits(x, y) == 0);
    assert!(n_ball > 100 && n_sky > 100);
    // Every path hits the convex ball once and escapes, so each sample is exactly
    // albedo x sky: the only deviation left is f32 rounding.
    let z_ball = (ball - 0.5) / ball_var.sqrt();
    assert!(z_ball.abs() < K, "{what}: ball {ball:.7}, expected 0.5 ({z_ball:.2} sigma)");
    // The sky is seen directly: exactly 1 with no noise at all.
    assert!((sky - 1.0).abs() < 1e-6 && sky_var.sqrt() < 1e-5, "{what}: background {sky}, expected exactly 1");
}

#[test]
fn furnace_open_gpu_and_cpu() {
    let scene = scene("furnace-open.toml");
    let opts = options(&scene, 48, 48, 512);
    let prepared = PreparedScene::new(&scene, &opts).expect("valid options");
    let ctx = gpu();
    check_furnace_open(&render_gpu(&ctx, &scene, &opts), &prepared, "GPU");
    check_furnace_open(&render_cpu(&scene, &opts), &prepared, "CPU");
}

#[test]
fn furnace_open_without_nee_gpu_and_cpu() {
    let scene = scene("furnace-open.toml");
    let mut opts = options(&scene, 48, 48, 512);
    opts.nee = false;
    let prepared = PreparedScene::new(&scene, &opts).expect("valid options");
    check_furnace_open(&render_gpu(&gpu(), &scene, &opts), &prepared, "GPU, NEE off");
    check_furnace_open(&render_cpu(&scene, &opts), &prepared, "CPU, NEE off");
}

fn check_furnace_closed(film: &Film, what: &str) {
    // Without NEE every path gathers 0.5 (1 + 1/2 + 1/4 + ...) exactly: the deviation
    // is then f32 rounding alone (region_stats includes its bound).
    let (mean, var, _) = region_stats(film, |_, _| true);
    let z = (mean - 1.0) / var.sqrt();
    assert!(z.abs() < K, "{what}: radiance {mean:.5}, expected 1.0 ({z:.2} sigma)");
}

#[test]
fn furnace_closed_gpu_and_cpu() {
    let scene = scene("furnace-closed.toml");
    let mut opts = options(&scene, 24, 24, 512);
    let ctx = gpu();
    check_furnace_closed(&render_gpu(&ctx, &scene, &opts), "GPU, NEE on");
    check_furnace_closed(&render_cpu(&scene, &opts), "CPU, NEE on");
    opts.nee = false;
    check_furnace_closed(&render_gpu(&ctx, &scene, &opts), "GPU, NEE off");
    check_furnace_closed(&render_cpu(&scene, &opts), "CPU, NEE off");
}

#[test]
fn nee_on_and_off_agree() {
    let ctx = gpu();
    for name in ["seed-exp1.toml", "seed-exp2.toml"] {
        let scene = scene(name);
        let mut opts = options(&scene, 36, 24, 1024);
        let on = render_gpu(&ctx, &scene, &opts);
        opts.nee = false;
        opts.seed = 1;
        let off = render_gpu(&ctx, &scene, &opts);
        assert_films_agree(&on, &off, 6, K, &format!("{name}: NEE on vs off"));
        // Balance heuristic too.
        opts.nee = true;
        opts.power_heuristic = false;
        opts.seed = 2;
        let balance = render_gpu(&ctx, &scene, &opts);
        assert_films_agree(&on, &balance, 6, K, &format!("{name}: power vs balance heuristic"));
    }
}

#[test]
fn gpu_and_cpu_agree_on_every_shipped_scene() {
    let ctx = gpu();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 11);
    for name in names {
        let scene = scene(&name);
        let mut opts = options(&scene, 32, 24, 512);
        let g = render_gpu(&ctx, &scene, &opts);
        opts.seed = 99;
        let c = render_cpu(&scene, &opts);
        let z = assert_films_agree(&g, &c, 4, K, &format!("{name}: GPU vs CPU"));
        eprintln!("{name}: worst block differs by {z:.2} sigma");
    }
}

/// The furnaces hold with the Sobol sampler too, on the GPU and the CPU.
#[test]
fn furnaces_with_the_sobol_sampler() {
    let ctx = gpu();
    let open = scene("furnace-open.toml");
    let mut opts = options(&open, 48, 48, 512);
    opts.sampler = SamplerKind::Sobol;
    let prepared = PreparedScene::new(&open, &opts).expect("valid options");
    check_furnace_open(&render_gpu(&ctx, &open, &opts), &prepared, "GPU, Sobol");
    check_furnace_open(&render_cpu(&open, &opts), &prepared, "CPU, Sobol");
    let closed = scene("furnace-closed.toml");
    let mut opts = options(&closed, 24, 24, 512);
    opts.sampler = SamplerKind::Sobol;
    for nee in [true, false] {
        opts.nee = nee;
        check_furnace_closed(&render_gpu(&ctx, &closed, &opts), &format!("GPU, Sobol, NEE {nee}"));
        check_furnace_closed(&render_cpu(&closed, &opts), &format!("CPU, Sobol, NEE {nee}"));
    }
}

/// With the Sobol sampler the GPU and CPU agree on every shipped scene, and the
/// GPU's Sobol image agrees with its independent one (both unbiased).
#[test]
fn sobol_renders_agree_with_the_cpu_and_the_independent_sampler() {
    let ctx = gpu();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 11);
    for name in names {
        let scene = scene(&name);
        let mut opts = options(&scene, 32, 24, 256);
        opts.sampler = SamplerKind::Sobol;
        let g = render_gpu(&ctx, &scene, &opts);
        opts.seed = 99;
        let c = render_cpu(&scene, &opts);
        let z = assert_films_agree(&g, &c, 4, K, &format!("{name}: Sobol, GPU vs CPU"));
        eprintln!("{name}, Sobol: worst block differs by {z:.2} sigma");
        opts.sampler = SamplerKind::Independent;
        opts.seed = 5;
        let independent = render_gpu(&ctx, &scene, &opts);
        let z = assert_films_agree(&g, &independent, 4, K, &format!("{name}: Sobol vs independent"));
        eprintln!("{name}, Sobol vs independent: worst block differs by {z:.2} sigma");
    }
}

/// Guided renders with the Sobol sampler agree with the CPU's Sobol render (door:
/// roulette, every vertex guided and recording).
#[test]
fn sobol_guided_gpu_and_cpu_agree() {
    let scene = scene("door.toml");
    let mut opts = options(&scene, 32, 24, 512);
    opts.sampler = SamplerKind::Sobol;
    gpu_unguided_and_guided_agree_with_cpu(&scene, &mut opts, [99, 3], "door, Sobol");
}

#[test]
fn same_seed_same_image_on_one_device() {
    let ctx = gpu();
    let scene = scene("seed-exp2.toml");
    let opts = options(&scene, 24, 16, 128);
    let a = render_gpu(&ctx, &scene, &opts);
    let b = render_gpu(&ctx, &scene, &opts);
    assert_eq!(a.pixels, b.pixels, "GPU renders with one seed are identical");
    let c = render_cpu(&scene, &opts);
    let d = render_cpu(&scene, &opts);
    assert_eq!(c.pixels, d.pixels, "CPU renders with one seed are identical");
    let mut other = opts.clone();
    other.seed = 5;
    assert_ne!(render_gpu(&ctx, &scene, &other).pixels, a.pixels, "another seed gives another image");
}

/// A box lit by a quad lamp, with more spheres and quads than the GPU kernel
/// holds as specialization constants (16 of each) and in its uniform buffer (64
/// of each, glsl/geometry.glsl): a row of 72 small balls on the floor and 64 small
/// tiles on the back wall come first, the walls and the lamp after them, so hits
/// on primitives of all three sources shape the image.
fn crowded_scene() -> Scene {
    Scene::parse(&crowded_text(|_| None, |_| true), "crowded").expect("the crowded test scene loads")
}

/// The crowded scene's text: `after_ball(i)` may add a sphere after ball i, and
/// `wall(name)` leaves a wall quad out where it says false.
fn crowded_text(after_ball: impl Fn(usize) -> Option<String>, wall: impl Fn(&str) -> bool) -> String {
    let mut t = String::from(
        r#"
[camera]
position = [50.0, 40.0, 200.0]
look_at = [50.0, 40.0, 0.0]
vfov = 50.0

[render]
width = 32
height = 24
spp = 64
max_bounces = 4

[[material]]
name = "white"
type = "diffuse"
albedo = [0.75, 0.75, 0.75]

[[material]]
name = "green"
type = "diffuse"
albedo = [0.25, 0.75, 0.25]

[[material]]
name = "lamp"
type = "emissive"
emission = [10.0, 10.0, 10.0]
"#,
    );
    for i in 0..72 {
        let (x, z) = (6.0 + 11.0 * (i % 8) as f64, 8.0 + 12.0 * (i / 8) as f64);
        t += &format!("\n[[sphere]]\ncenter = [{x}, 4.0, {z}]\nradius = 4.0\nmaterial = \"green\"\n");
        t += &after_ball(i).unwrap_or_default();
    }
    for i in 0..64 {
        let (x, y) = (4.0 + 12.0 * (i % 8) as f64, 4.0 + 9.0 * (i / 8) as f64);
        t += &format!(
            "\n[[quad]]\norigin = [{x}, {y}, 1.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 5.0, 0.0]\nmaterial = \"green\"\n"
        );
    }
    // A 65th panel among the balls, so that shadow rays reach the storage buffer's quads.
    t += "\n[[quad]]\norigin = [40.0, 20.0, 60.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 5.0, 0.0]\nmaterial = \"green\"\n";
    for (name, origin, u, v, material) in [
        ("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 160.0], [100.0, 0.0, 0.0], "white"),
        ("ceiling", [0.0, 80.0, 0.0], [100.0, 0.0, 0.0], [0.0, 0.0, 160.0], "white"),
        ("back", [0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 80.0, 0.0], "white"),
        ("left", [0.0, 0.0, 0.0], [0.0, 80.0, 0.0], [0.0, 0.0, 160.0], "white"),
        ("right", [100.0, 0.0, 0.0], [0.0, 0.0, 160.0], [0.0, 80.0, 0.0], "white"),
        ("lamp", [35.0, 79.9, 60.0], [30.0, 0.0, 0.0], [0.0, 0.0, 30.0], "lamp"), // facing down
    ] {
        if wall(name) {
            t += &format!(
                "\n[[quad]]\norigin = {origin:?}\nedge_u = {u:?}\nedge_v = {v:?}\nmaterial = \"{material}\"\n"
            );
        }
    }
    t
}

/// Both GPU pipelines, unguided and guided, test the specialized primitives,
/// the uniform buffer's and the storage buffers' past them.
#[test]
fn gpu_and_cpu_agree_past_the_uniform_primitives() {
    let scene = crowded_scene();
    assert!(scene.spheres.len() > 64 && scene.quads.len() > 64);
    let mut opts = options(&scene, 32, 24, 512);
    // Shadow rays walk both loops too: the 65 panels can block them; the room's
    // five walls cannot, nor the lamp, the one light, on which they end
    // (`prepared::occluding_order`).
    assert_eq!(PreparedScene::new(&scene, &opts).expect("valid options").params.occluding_quads, 65);
    let g = gpu_unguided_and_guided_agree_with_cpu(&scene, &mut opts, [99, 3], "crowded scene");
    let (mean, _, _) = region_stats(&g, |_, _| true);
    assert!(mean > 0.01, "the crowded scene renders lit (mean {mean})");
}

/// An unguided GPU render of `scene` (seed `opts.seed`), a CPU render (seed
/// `seeds[0]`) and a guided GPU render (sphere, seed `seeds[1]`) agree region by
/// region; returns the unguided GPU film.
fn gpu_unguided_and_guided_agree_with_cpu(
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

/// Spheres too large for their centre's test (2r > |C|, tested from the anchor on
/// their surface, `intersect_sphere_anchored` and `sphere_blocks_at`) past the
/// specialized slots: the crowded scene's floor and right wall as smallpt's walls
/// are made, spheres of radius 1e5, the floor after ball 20 (the uniform buffer's
/// spheres) and the wall after the last ball (the storage buffer's). Most of the
/// image is lit by light off them.
#[test]
fn gpu_and_cpu_agree_on_anchored_spheres_past_the_slots() {
    let wall = |center: [f64; 3]| format!("\n[[sphere]]\ncenter = {center:?}\nradius = 1e5\nmaterial = \"white\"\n");
    let text = crowded_text(
        |i| match i {
            20 => Some(wall([50.0, -1e5, 80.0])),
            71 => Some(wall([1e5 + 100.0, 40.0, 80.0])),
            _ => None,
        },
        |name| name != "floor" && name != "right",
    );
    let scene = Scene::parse(&text, "crowded, sphere walls").expect("the test scene loads");
    let mut opts = options(&scene, 32, 24, 512);
    let prepared = PreparedScene::new(&scene, &opts).expect("valid options");
    assert_eq!(prepared.spheres.len(), 74);
    for i in [21, 73] {
        assert!(!prepared.spheres[i].compact(), "sphere {i} is a wall, tested from its anchor");
    }
    assert!(prepared.spheres[..21].iter().all(|s| s.compact()), "the balls are compact");
    let g = gpu_unguided_and_guided_agree_with_cpu(&scene, &mut opts, [77, 5], "sphere walls");
    // The floor's pixels, the lowest rows.
    let (floor, _, _) = region_stats(&g, |_, y| y >= 20);
    assert!(floor > 0.01, "the sphere floor is lit (mean {floor})");
}

/// The kernel is compiled for the render's flags and bounce limit
/// (specialization constants); a change through `set_params`, as the viewer's
/// NEE key makes, must reach it. Same seed, same frame: a renderer made with NEE
/// on and 8 bounces, then set to NEE off and 2 bounces, renders exactly the image
/// of one made with NEE off and 2 bounces.
#[test]
fn set_params_recompiles_the_kernel_for_new_flags() {
    let ctx = gpu();
    let scene = scene("seed-exp1.toml");
    let mut opts = options(&scene, 24, 16, 64);
    let first = render_gpu(&ctx, &scene, &opts);
    let mut r = GpuRenderer::new(&ctx, &PreparedScene::new(&scene, &opts).expect("valid options")).expect("renderer");
    opts.nee = false;
    opts.max_bounces = 2;
    let fresh = render_gpu(&ctx, &scene, &opts);
    assert_ne!(first.pixels, fresh.pixels, "NEE and the bounce limit change the image");
    let mut p = *r.params();
    p.set_nee(false);
    p.max_bounces = 2;
    r.set_params(&p).expect("set_params");
    r.render_frames(1).expect("render");
    let switched = r.film().expect("readback");
    assert_no_validation_messages(&ctx);
    assert_eq!(switched.pixels, fresh.pixels, "set_params switched NEE off and the bounces to 2");
}

/// The rays a frame traces (camera, bounce and shadow rays), as the GPU kernels
/// count them and as the CPU renderer does, with roulette (door: the kernels keep
/// the count in the high half of the depth's register, `depth_rays` in
/// `glsl/pathtrace.comp`) and without (seed-exp1), unguided and guided. The two
/// renderers draw the same random numbers, but rounding sends some paths another
/// way, so the totals need not be equal; they must agree within K deviations of
/// two independent totals, each path's count in [1, 2 (bounces + 1)] bounding its
/// deviation by half that range. A loose bound (the totals differed by under 0.1
/// of it on lavapipe), but one ray per path lost from the packed count fails it
/// by 19.
#[test]
fn gpu_and_cpu_count_the_same_rays() {
    let ctx = gpu();
    for name in ["door.toml", "seed-exp1.toml"] {
        for guiding in [rlpt::guide::GuidingMode::Off, rlpt::guide::GuidingMode::Sphere] {
            let scene = scene(name);
            let mut opts = options(&scene, 32, 24, 256);
            opts.guiding = guiding;
            opts.counters = Counters::All;
            let prepared = PreparedScene::new(&scene, &opts).expect("valid options");
            let mut gpu = GpuRenderer::new(&ctx, &prepared).expect("renderer");
            let mut cpu = rlpt::cpu::CpuRenderer::new(&prepared);
            let (mut g, mut c) = (0u64, 0u64);
            for _ in 0..opts.frames() {
                g += gpu.render_frames(1).expect("render").segments.expect("counted");
                cpu.render_frame();
                c += cpu.last_counters.segments;
            }
            assert_no_validation_messages(&ctx);
            let paths = (opts.width * opts.height * opts.frames() * rlpt::shared::SAMPLES_PER_FRAME) as f64;
            let half_range = (2.0 * (opts.max_bounces as f64 + 1.0) - 1.0) / 2.0;
            let sd = (2.0 * paths).sqrt() * half_range;
            let z = (g as f64 - c as f64).abs() / sd;
            eprintln!(
                "{name} {guiding:?}: GPU {g} rays, CPU {c} ({:.4} per path), {z:.3} bound deviations",
                g as f64 / paths
            );
            assert!(
                g >= paths as u64 && c >= paths as u64,
                "{name} {guiding:?}: at least one ray per path: GPU {g}, CPU {c}"
            );
            assert!(z < K, "{name} {guiding:?}: GPU counted {g} rays, CPU {c}: {z:.2} deviations apart");
        }
    }
}

/// The frame counters at each level (`RenderOptions::counters`, the kernel
/// compiled without what it does not count): the same image bit for bit, and
/// counts only where kept: none when off, the paths without radiance alone with
/// `ZeroPaths` (`render --stats`), the same number of them and the rays with
/// `All`; with roulette (door, whose kernels pack the ray count beside the depth
/// when they count rays) and without, unguided and guided.
///
/// The guided renders take Dahm & Keller's targets (`QTargets::Full`): the
/// second frame samples the table the first frame's targets built, and float
/// atomics sum them in whatever order the invocations run, so the same image
/// twice needs sums that no order changes. With the table empty, the first
/// frame's full targets are the emission a ray meets alone, a few equal values
/// whose sums are exact; the MIS-weighted ones hold light samples' estimates, and
/// two runs of the same kernel differ (lavapipe: 97 of 384 pixels after the
/// second frame of seed-exp1, while the first frames agree).
#[test]
fn the_counters_change_no_pixel_and_count_only_what_they_keep() {
    let ctx = gpu();
    for name in ["door.toml", "seed-exp1.toml"] {
        for guiding in [rlpt::guide::GuidingMode::Off, rlpt::guide::GuidingMode::Sphere] {
            let scene = scene(name);
            let mut opts = options(&scene, 24, 16, 128);
            opts.guiding = guiding;
            opts.q_targets = rlpt::guide::QTargets::Full;
            if std::env::var_os("FULLT").is_some() {
                opts.q_targets = rlpt::guide::QTargets::Full;
            }
            let render = |counters: Counters| {
                let o = RenderOptions { counters, ..opts.clone() };
                let prepared = PreparedScene::new(&scene, &o).expect("valid options");
                let flags = prepared.params.flags;
                assert_eq!(flags & rlpt::shared::FLAG_COUNTERS != 0, counters != Counters::Off);
                assert_eq!(flags & rlpt::shared::FLAG_COUNT_RAYS != 0, counters == Counters::All);
                let mut r = GpuRenderer::new(&ctx, &prepared).expect("renderer");
                let counts: Vec<_> = (0..o.frames())
                    .map(|_| {
                        let t = r.render_frames(1).expect("render");
                        (t.zero_paths, t.segments, t.subgroup_segments)
                    })
                    .collect();
                (r.film().expect("readback"), counts)
            };
            let (all, all_counts) = render(Counters::All);
            let (zero, zero_counts) = render(Counters::ZeroPaths);
            let (off, off_counts) = render(Counters::Off);
            assert_no_validation_messages(&ctx);
            let what = format!("{name} {guiding:?}");
            assert!(all.pixels.iter().any(|p| p.sum[0] > 0.0), "{what}: the image has light");
            assert!(all.pixels == off.pixels, "{what}: counting everything changed the image");
            assert!(zero.pixels == off.pixels, "{what}: counting paths changed the image");
            let lanes = ctx.info.subgroup_size as u64;
            for (i, (&(z, s, g), &(z0, s0, g0))) in all_counts.iter().zip(&zero_counts).enumerate() {
                let (s, g) = (s.expect("rays counted"), g.expect("subgroups counted"));
                // Each subgroup runs as long as its longest path: at least the rays
                // traced, at most every lane's worth of them.
                assert!(s > 0 && s <= g && g <= lanes * s, "{what}, frame {i}: {s} rays, {g} subgroup rays");
                assert!(z.is_some() && z == z0, "{what}, frame {i}: paths without radiance {z:?} and {z0:?}");
                assert_eq!((s0, g0), (None, None), "{what}, frame {i}: rays counted by ZeroPaths");
            }
            assert!(off_counts.iter().all(|&c| c == (None, None, None)), "{off_counts:?}");
        }
    }
}

/// The lane utilization's denominator, the rays each subgroup's longest path sets
/// (`FrameTimings::subgroup_segments`). In the closed furnace without NEE or
/// roulette every path traces the same rays, and the two counts are equal. On
/// unguided door (roulette from the fifth bounce) they are the sums, over groups
/// of subgroup-size consecutive samples of a pixel, of the CPU's paths' longest,
/// times the group's lanes: the CPU traces the GPU's paths from the same random
/// numbers (`gpu_and_cpu_count_the_same_rays`), so the two agree but for the
/// few paths that rounding sends another way, each moving its group's count by
/// at most a path's longest, 2 (bounces + 1) rays per lane.
#[test]
fn the_subgroups_count_the_rays_of_their_longest_paths() {
    let ctx = gpu();
    let lanes = ctx.info.subgroup_size.min(rlpt::shared::SAMPLES_PER_FRAME);
    let scene_f = scene("furnace-closed.toml");
    let mut opts = options(&scene_f, 16, 16, 64);
    opts.nee = false;
    opts.max_bounces = 6;
    opts.counters = Counters::All;
    let prepared = PreparedScene::new(&scene_f, &opts).expect("valid options");
    assert_eq!(prepared.params.flags & rlpt::shared::FLAG_RUSSIAN_ROULETTE, 0);
    let mut r = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    let t = r.render_frames(1).expect("render");
    let paths = (opts.width * opts.height * rlpt::shared::SAMPLES_PER_FRAME) as u64;
    assert_eq!(t.segments, Some(paths * (opts.max_bounces as u64 + 1)), "furnace: every path as long");
    assert_eq!(t.subgroup_segments, t.segments, "furnace: every lane busy");

    let scene_d = scene("door.toml");
    let mut opts = options(&scene_d, 24, 16, 64);
    opts.counters = Counters::All;
    let prepared = PreparedScene::new(&scene_d, &opts).expect("valid options");
    let p = &prepared.params;
    assert!(p.flags & rlpt::shared::FLAG_RUSSIAN_ROULETTE != 0);
    let mut r = GpuRenderer::new(&ctx, &prepared).expect("renderer");
    let t = r.render_frames(1).expect("render");
    assert_no_validation_messages(&ctx);
    let (gpu_rays, gpu_longest) = (t.segments.expect("counted"), t.subgroup_segments.expect("counted"));
    let (mut cpu_rays, mut cpu_longest) = (0u64, 0u64);
    for y in 0..p.height {
        for x in 0..p.width {
            let pixel = y * p.width + x;
            let mut longest = 0u32;
            for sample in 0..rlpt::shared::SAMPLES_PER_FRAME {
                let mut rng = rlpt::math::sampler::PathSampler::for_flags(p.flags, p.seed, pixel, 0, sample);
                let u = rng.sample_pixel(sample);
                let (o, d) = camera_ray(p, x, y, u);
                let (_, rays) = rlpt::cpu::trace_path(&prepared, None, o, d, &mut rng, 0.0, None);
                cpu_rays += rays as u64;
                longest = longest.max(rays);
                if (sample + 1) % lanes == 0 {
                    cpu_longest += (longest * lanes) as u64;
                    longest = 0;
                }
            }
        }
    }
    let utilization = gpu_rays as f64 / gpu_longest as f64;
    let per_path = 2 * (opts.max_bounces as u64 + 1);
    let diff = gpu_longest.abs_diff(cpu_longest);
    eprintln!(
        "door: GPU {gpu_rays} rays, {gpu_longest} subgroup rays ({utilization:.3} utilization, {lanes} lanes); \
         CPU {cpu_rays}, {cpu_longest}"
    );
    assert!(utilization < 0.9, "door: roulette leaves lanes idle, utilization {utilization:.3}");
    // A hundredth of the groups' counts may move, each by at most a longest path in every lane.
    let groups = cpu_longest / (lanes as u64 * per_path) + 1;
    assert!(
        diff <= (groups / 100 + 1) * lanes as u64 * per_path,
        "door: GPU {gpu_longest} subgroup rays against the CPU's {cpu_longest}"
    );
}

/// The ray into a path's last vertex traced in full only where its line meets a
/// light (`FLAG_LAST_RAY_TO_LIGHTS`) changes nothing: the same image, bit for bit,
/// and the same rays counted, on the GPU (unguided and guided) and on the CPU.
/// seed-exp3 (mirror, glass, glossy and diffuse; a quad lamp and a spherical
/// one) with 2 bounces, so that many paths reach the last vertex and many of
/// those rays meet a lamp: a `meets_light` that missed a light of either kind
/// would lose their emission.
#[test]
fn the_last_ray_to_lights_changes_no_pixel() {
    let ctx = gpu();
    let scene = scene("seed-exp3.toml");
    let mut opts = options(&scene, 24, 16, 128);
    opts.max_bounces = 2;
    opts.counters = Counters::All;
    // Bit for bit across two GPU runs needs a table the same bit for bit: the
    // first frame's full targets are emission alone, summed exactly whatever the
    // order of the float atomics; MIS-weighted ones hold light-sample estimates,
    // whose sums depend on it (as in `the_counters_change_no_pixel_and_count_only_what_they_keep`). With
    // fewer rows built since `QTable::rows_read`, that order showed in frame 2's
    // image in 2 of 3 runs of this file.
    opts.q_targets = rlpt::guide::QTargets::Full;
    for guiding in [rlpt::guide::GuidingMode::Off, rlpt::guide::GuidingMode::Sphere] {
        opts.guiding = guiding;
        let with = PreparedScene::new(&scene, &opts).expect("valid options");
        assert!(with.params.flags & rlpt::shared::FLAG_LAST_RAY_TO_LIGHTS != 0, "seed-exp3 takes the flag");
        let mut without = with.clone();
        without.params.flags &= !rlpt::shared::FLAG_LAST_RAY_TO_LIGHTS;
        let gpu_render = |p: &PreparedScene| {
            let mut r = GpuRenderer::new(&ctx, p).expect("renderer");
            let segments: u64 =
                (0..opts.frames()).map(|_| r.render_frames(1).expect("render").segments.expect("counted")).sum();
            (r.film().expect("readback"), segments)
        };
        let cpu_render = |p: &PreparedScene| {
            let mut r = rlpt::cpu::CpuRenderer::new(p);
            let segments: u64 = (0..opts.frames())
                .map(|_| {
                    r.render_frame();
                    r.last_counters.segments
                })
                .sum();
            (r.film().clone(), segments)
        };
        let (a, b) = (gpu_render(&with), gpu_render(&without));
        assert_no_validation_messages(&ctx);
        assert!(a.0.pixels.iter().any(|p| p.sum[0] > 0.0), "{guiding:?}: the image has light");
        assert_eq!(a.1, b.1, "{guiding:?}: GPU rays counted");
        assert!(a.0.pixels == b.0.pixels, "{guiding:?}: GPU image");
        let (c, d) = (cpu_render(&with), cpu_render(&without));
        assert_eq!(c.1, d.1, "{guiding:?}: CPU rays counted");
        assert!(c.0.pixels == d.0.pixels, "{guiding:?}: CPU image");
    }
}

/// The room's slab test (`Room`, `room_hit`) finds the walls the quads' own
/// tests find: the GPU renders seed-exp2 (five walls, looked into through its
/// open face) and door (six, the camera inside) as it does with every quad
/// walked (`Room::NONE`), unguided and guided, and seed-exp2 from outside its
/// left wall too, where the camera's rays meet that wall from outside and the
/// kernel tests the face a ray enters by (`Room::entering`). The same to
/// rounding: a ray that leaves the box along an edge may take either wall.
#[test]
fn the_room_finds_the_walls_the_quads_find_on_the_gpu() {
    let ctx = gpu();
    let mut outside = scene("seed-exp2.toml");
    outside.camera.position = glam::Vec3::new(-60.0, 40.0, 230.0);
    outside.camera.forward = (glam::Vec3::new(50.0, 38.0, 60.0) - outside.camera.position).normalize();
    let cases = [
        (scene("seed-exp2.toml"), rlpt::guide::GuidingMode::Off, false),
        (scene("seed-exp2.toml"), rlpt::guide::GuidingMode::Sphere, false),
        (scene("door.toml"), rlpt::guide::GuidingMode::Off, false),
        (scene("door.toml"), rlpt::guide::GuidingMode::Sphere, false),
        (outside, rlpt::guide::GuidingMode::Off, true),
    ];
    for (scene, guiding, entering) in cases {
        let mut opts = options(&scene, 32, 24, 128);
        opts.guiding = guiding;
        opts.counters = Counters::All;
        let with = PreparedScene::new(&scene, &opts).expect("valid options");
        assert!(with.room.quads >= 5, "{guiding:?}: the scene has a room");
        assert_eq!(with.room.entering, entering, "{guiding:?}");
        let mut without = with.clone();
        without.room = rlpt::layout::Room::NONE;
        let render = |p: &PreparedScene| {
            let mut r = GpuRenderer::new(&ctx, p).expect("renderer");
            let segments: u64 =
                (0..opts.frames()).map(|_| r.render_frames(1).expect("render").segments.expect("counted")).sum();
            (r.film().expect("readback"), segments)
        };
        let ((a, sa), (b, sb)) = (render(&with), render(&without));
        assert_no_validation_messages(&ctx);
        let total: f64 = b.pixels.iter().map(|p| p.sum[..3].iter().map(|&v| v as f64).sum::<f64>()).sum();
        let diff: f64 = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| (0..3).map(|c| (p.sum[c] as f64 - q.sum[c] as f64).abs()).sum::<f64>())
            .sum();
        assert!(total > 0.0, "{guiding:?}: the image has light");
        assert!(
            diff <= 1e-4 * total,
            "{guiding:?}, entering {entering}: images differ by {:e} of their sum",
            diff / total
        );
        assert!(sa.abs_diff(sb) as f64 <= 1e-5 * sb as f64, "{guiding:?}: rays {sa} with the room, {sb} without");
        if entering {
            // The wall hides part of the room from the camera: some pixels are black
            // that a ray passing through the wall's outside would light.
            let dark = a.pixels.iter().filter(|p| p.sum[0] == 0.0).count();
            assert!(dark > a.pixels.len() / 10, "the left wall's outside fills part of the view: {dark} black pixels");
        }
    }
}

/// A camera that moves out of the room (the viewer's `set_params`) turns on the
/// test of the face a ray enters by, and one that moves back turns it off: the
/// renderer rebuilds its kernels both times, and renders what a renderer made
/// for that camera renders.
#[test]
fn a_camera_moving_out_of_the_room_turns_the_entering_test_on() {
    let ctx = gpu();
    let scene = scene("seed-exp2.toml");
    let opts = options(&scene, 32, 24, 64);
    let inside = PreparedScene::new(&scene, &opts).expect("valid options");
    assert!(!inside.room.entering);
    let mut moved = scene.clone();
    moved.camera.position = glam::Vec3::new(-60.0, 40.0, 230.0);
    moved.camera.forward = (glam::Vec3::new(50.0, 38.0, 60.0) - moved.camera.position).normalize();
    let outside = PreparedScene::new(&moved, &opts).expect("valid options");
    assert!(outside.room.entering);
    let frame = |r: &mut GpuRenderer| {
        r.reset_accumulation().expect("reset");
        r.render_frames(1).expect("render");
        r.film().expect("readback").pixels
    };
    // Frame k of a renderer draws frame k's random numbers, whatever came before.
    let nth = |p: &PreparedScene, k: usize| {
        let mut r = GpuRenderer::new(&ctx, p).expect("renderer");
        (0..=k).map(|_| frame(&mut r)).last().unwrap()
    };
    let (want_out, want_in) = (nth(&outside, 1), nth(&inside, 2));
    assert!(want_out != nth(&inside, 1), "the two cameras see different images");
    let mut r = GpuRenderer::new(&ctx, &inside).expect("renderer");
    frame(&mut r);
    r.set_params(&outside.params).expect("camera moved out");
    assert!(frame(&mut r) == want_out, "the moved camera renders as a renderer made for it");
    r.set_params(&inside.params).expect("camera moved back");
    assert!(frame(&mut r) == want_in, "and back in, as one made for the first camera");
    assert_no_validation_messages(&ctx);
}

/// A unit ball of `material` under a uniform sky of radiance 1, seen whole.
fn ball_furnace(material: &str, max_bounces: u32) -> Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov = 40.0\n\
         [render]\nmax_bounces = {max_bounces}\n[environment]\nradiance = [1.0, 1.0, 1.0]\n\
         [[material]]\nname = \"ball\"\n{material}\n\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"ball\"\n"
    );
    Scene::parse(&text, "ball furnace").expect("valid scene")
}

/// White furnaces for the delta materials: an albedo-1 mirror ball and an albedo-1
/// glass ball under a uniform sky of 1 render 1 in every pixel, NEE on and off, GPU
/// and CPU. A mirror path's throughput is 1 x 1, exactly; a glass path enters and
/// leaves the convex ball, its radiance scaled by 1/eta^2 and then eta^2, the Fresnel
/// split taken by probability with weight 1 (its internal reflections have albedo 1
/// too, and a sphere has no total internal reflection, so with 1024 bounces a path
/// is cut with a probability far below f32 rounding). What is left is f32 rounding,
/// bounded by [`rounding_bound`] (a glass sample's own, from 1/eta^2 times eta^2,
/// is a few units of 2^-24, inside it; lavapipe and the CPU show at most one).
/// A mirror sample is exactly 1, and so is its pixel.
#[test]
fn mirror_and_glass_balls_of_albedo_one_render_exactly_one() {
    let ctx = gpu();
    for (name, material) in
        [("mirror", "type = \"specular\"\nalbedo = [1.0, 1.0, 1.0]"), ("glass", "type = \"dielectric\"\nior = 1.5")]
    {
        let scene = ball_furnace(material, 1024);
        for nee in [true, false] {
            let mut opts = options(&scene, 24, 24, 256);
            opts.nee = nee;
            for (device, film) in [("GPU", render_gpu(&ctx, &scene, &opts)), ("CPU", render_cpu(&scene, &opts))] {
                for p in &film.mean().pixels {
                    for &m in p {
                        let bound = if name == "mirror" { 0.0 } else { rounding_bound(&film, m) };
                        assert!(
                            (m as f64 - 1.0).abs() <= bound,
                            "{name} ball, {device}, NEE {nee}: a pixel renders {m:.9}, not 1 within f32 rounding"
                        );
                    }
                }
            }
        }
    }
}

/// The per-pixel variance estimate is calibrated: for two independent renders
/// (different seeds) of seed-exp1 at 48x32 with 64 frames (4096 spp), z = (a - b) /
/// sqrt(va + vb) per pixel follows a standard normal. Each channel is tested on its
/// own, its z-scores independent across pixels (the channels of one pixel share
/// their paths): the Kolmogorov-Smirnov distance from the normal below its 0.1 %
/// critical value 1.95 / sqrt(n), and the mean of z^2 within 4 standard errors
/// sqrt(2 / n) of its expectation. No Russian roulette in this scene, and 64
/// samples per frame mean: the frame means are near normal. On lavapipe and the
/// CPU the mean z^2 came out 1.06 to 1.09 and the KS distance 0.015 to 0.037
/// (limit 0.053); an estimate 30 % too small or too large fails the mean z^2.
fn check_calibrated(render: impl Fn(&Scene, &RenderOptions) -> Film, what: &str) {
    let scene = scene("seed-exp1.toml");
    let frames = 64;
    let mut opts = options(&scene, 48, 32, 64 * frames);
    let a = render(&scene, &opts);
    opts.seed += 1;
    let b = render(&scene, &opts);
    let (va, vb) = (a.variance_of_mean().unwrap(), b.variance_of_mean().unwrap());
    let (ma, mb) = (a.mean(), b.mean());
    for c in 0..3 {
        let grey = |img: &rlpt::image::Image| rlpt::image::Image {
            width: img.width,
            height: img.height,
            pixels: img.pixels.iter().map(|p| [p[c]; 3]).collect(),
        };
        let r = rlpt::metrics::agreement(&grey(&ma), &grey(&va), &grey(&mb), &grey(&vb), 0.0).unwrap();
        // The three copies of one channel: the statistics of that channel's z alone.
        let n = (r.pixels / 3) as f64;
        assert!(n > 300.0, "{what}: only {n} pixels with noise");
        let (ks_limit, z2_limit) = (1.95 / n.sqrt(), 4.0 * (2.0 / n).sqrt());
        // Each variance is estimated from `frames` frame means: z is t-distributed with
        // about nu = 2 (frames - 1) degrees of freedom, and E z^2 = nu / (nu - 2) (1.016).
        let nu = 2.0 * (frames as f64 - 1.0);
        let z2_expected = nu / (nu - 2.0);
        assert!(
            r.pixel_ks < ks_limit,
            "{what}, channel {c}: z-scores' KS distance from the normal {:.4}, above {ks_limit:.4}",
            r.pixel_ks
        );
        assert!(
            (r.pixel_mean_z2 - z2_expected).abs() < z2_limit,
            "{what}, channel {c}: mean z^2 {:.4}, not {z2_expected:.3} within {z2_limit:.3}",
            r.pixel_mean_z2
        );
    }
}

#[test]
fn variance_estimates_are_calibrated_on_the_gpu() {
    let ctx = gpu();
    check_calibrated(|s, o| render_gpu(&ctx, s, o), "GPU");
}

#[test]
fn variance_estimates_are_calibrated_on_the_cpu() {
    check_calibrated(render_cpu, "CPU");
}

/// The conductor (rough and smooth), the rough dielectric and the coated
/// material in a lit box: the GPU kernel specialized to these kinds, unguided and
/// guided, agrees with the CPU renderer. Light reaches the lamp through the rough
/// glass by both refraction and NEE (it is not a delta BSDF).
#[test]
fn gpu_and_cpu_agree_on_conductor_rough_glass_and_coated() {
    let mut t = String::from(
        r#"
[camera]
position = [50.0, 40.0, 200.0]
look_at = [50.0, 35.0, 0.0]
vfov = 45.0

[render]
width = 32
height = 24
spp = 64
max_bounces = 5

[[material]]
name = "white"
type = "diffuse"
albedo = [0.75, 0.75, 0.75]

[[material]]
name = "gold"
type = "conductor"
eta = [0.143119, 0.374957, 1.44248]
k = [3.98316, 2.38572, 1.60322]
roughness = 0.4

[[material]]
name = "copper mirror"
type = "conductor"
eta = [0.200438, 0.924033, 1.10221]
k = [3.91295, 2.45285, 2.14219]

[[material]]
name = "frosted"
type = "dielectric"
ior = 1.5
roughness = 0.3

[[material]]
name = "paint"
type = "coated"
albedo = [0.7, 0.2, 0.1]
roughness = 0.2
ior = 1.5

[[material]]
name = "lamp"
type = "emissive"
emission = [12.0, 12.0, 12.0]
"#,
    );
    for (x, material) in [(15.0, "gold"), (38.0, "copper mirror"), (62.0, "frosted"), (85.0, "paint")] {
        t += &format!("\n[[sphere]]\ncenter = [{x}, 12.0, 60.0]\nradius = 11.0\nmaterial = \"{material}\"\n");
    }
    for (origin, u, v, material) in [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 160.0], [100.0, 0.0, 0.0], "white"),
        ([0.0, 80.0, 0.0], [100.0, 0.0, 0.0], [0.0, 0.0, 160.0], "white"),
        ([0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 80.0, 0.0], "white"),
        ([0.0, 0.0, 0.0], [0.0, 80.0, 0.0], [0.0, 0.0, 160.0], "white"),
        ([100.0, 0.0, 0.0], [0.0, 0.0, 160.0], [0.0, 80.0, 0.0], "white"),
        ([35.0, 79.9, 40.0], [30.0, 0.0, 0.0], [0.0, 0.0, 30.0], "lamp"),
    ] {
        t += &format!("\n[[quad]]\norigin = {origin:?}\nedge_u = {u:?}\nedge_v = {v:?}\nmaterial = \"{material}\"\n");
    }
    let scene = Scene::parse(&t, "new materials").expect("the test scene loads");
    let mut opts = options(&scene, 32, 24, 512);
    let g = gpu_unguided_and_guided_agree_with_cpu(&scene, &mut opts, [41, 42], "conductor, rough glass, coated");
    let (mean, _, _) = region_stats(&g, |_, _| true);
    assert!(mean > 0.01, "the scene renders lit (mean {mean})");
}
