//! Statistical tests of whole renders, on the GPU (lavapipe in CI) and the CPU:
//! analytic furnaces, NEE on versus off, GPU versus CPU on every shipped scene,
//! the rays each counts, and calibrated variance estimates. Tolerances are k
//! standard deviations of the estimate, the deviation measured from the renders'
//! own per-pixel variance (spread of the 64-sample frame means). The kernel's
//! specializations, in `render_specialization.rs`.

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

/// The file names of the scenes in `scenes/`, sorted (at least 11 of them).
fn shipped_scene_names() -> Vec<String> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 11);
    names
}

/// On every shipped scene the GPU and the CPU agree, with the independent
/// sampler (512 spp) and with the Sobol sampler (256 spp), and the GPU's Sobol
/// image agrees with its independent one (both unbiased). One test, so that the
/// GPU's independent render serves both comparisons (its seed 0, the Sobol
/// render's 5, the CPU's 99).
#[test]
fn gpu_and_cpu_agree_on_every_shipped_scene_with_either_sampler() {
    let ctx = gpu();
    for name in shipped_scene_names() {
        let scene = scene(&name);
        let mut opts = options(&scene, 32, 24, 512);
        let independent = render_gpu(&ctx, &scene, &opts);
        opts.seed = 99;
        let c = render_cpu(&scene, &opts);
        let z = assert_films_agree(&independent, &c, 4, K, &format!("{name}: GPU vs CPU"));
        eprintln!("{name}: worst block differs by {z:.2} sigma");
        let mut opts = options(&scene, 32, 24, 256);
        opts.sampler = SamplerKind::Sobol;
        opts.seed = 5;
        let g = render_gpu(&ctx, &scene, &opts);
        opts.seed = 99;
        let c = render_cpu(&scene, &opts);
        let z = assert_films_agree(&g, &c, 4, K, &format!("{name}: Sobol, GPU vs CPU"));
        eprintln!("{name}, Sobol: worst block differs by {z:.2} sigma");
        let z = assert_films_agree(&g, &independent, 4, K, &format!("{name}: Sobol vs independent"));
        eprintln!("{name}, Sobol vs independent: worst block differs by {z:.2} sigma");
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
    let compiled = ctx.pipelines_compiled();
    let b = render_gpu(&ctx, &scene, &opts);
    assert_eq!(ctx.pipelines_compiled(), compiled, "the second renderer takes the first's pipelines");
    assert_eq!(a.pixels, b.pixels, "GPU renders with one seed are identical");
    let c = render_cpu(&scene, &opts);
    let d = render_cpu(&scene, &opts);
    assert_eq!(c.pixels, d.pixels, "CPU renders with one seed are identical");
    let mut other = opts.clone();
    other.seed = 5;
    assert_ne!(render_gpu(&ctx, &scene, &other).pixels, a.pixels, "another seed gives another image");
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
