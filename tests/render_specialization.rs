//! The GPU kernel's specializations and the scene analyses it is compiled with
//! change no pixel: more primitives than its slots and uniform buffer hold,
//! spheres tested from their anchor, `set_params` recompiling for new flags, the
//! last ray traced only toward lights, the room's walls, and the conductor, rough
//! glass and coated kinds; each against the CPU renderer or an unspecialized
//! render, as `render_agreement.rs` compares them.

mod common;

use common::*;
use rlpt::options::Counters;
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;

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

/// The conductor (rough and smooth), the rough dielectric and the coated
/// material in a lit box: the GPU kernel specialized to these kinds, unguided and
/// guided, agrees with the CPU renderer. Light reaches the lamp through the rough
/// glass by both refraction and NEE (it is not a delta BSDF).
#[test]
fn gpu_and_cpu_agree_on_conductor_rough_glass_and_coated() {
    let t = four_spheres_in_a_lit_box(
        r#"
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
"#,
        ["gold", "copper mirror", "frosted", "paint"],
        "white",
    );
    let scene = Scene::parse(&t, "new materials").expect("the test scene loads");
    let mut opts = options(&scene, 32, 24, 512);
    let g = gpu_unguided_and_guided_agree_with_cpu(&scene, &mut opts, [41, 42], "conductor, rough glass, coated");
    let (mean, _, _) = region_stats(&g, |_, _| true);
    assert!(mean > 0.01, "the scene renders lit (mean {mean})");
}

/// A scene of `own` materials (TOML) beside "white" and "lamp": four spheres of
/// `materials` in a row, in a white box of floor `floor` lit by a lamp in its
/// ceiling, seen from the front at 32x24.
fn four_spheres_in_a_lit_box(own: &str, materials: [&str; 4], floor: &str) -> String {
    let mut t = format!(
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
name = "lamp"
type = "emissive"
emission = [12.0, 12.0, 12.0]
{own}"#
    );
    for (x, material) in [15.0, 38.0, 62.0, 85.0].into_iter().zip(materials) {
        t += &format!("\n[[sphere]]\ncenter = [{x}, 12.0, 60.0]\nradius = 11.0\nmaterial = \"{material}\"\n");
    }
    for (origin, u, v, material) in [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 160.0], [100.0, 0.0, 0.0], floor),
        ([0.0, 80.0, 0.0], [100.0, 0.0, 0.0], [0.0, 0.0, 160.0], "white"),
        ([0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 80.0, 0.0], "white"),
        ([0.0, 0.0, 0.0], [0.0, 80.0, 0.0], [0.0, 0.0, 160.0], "white"),
        ([100.0, 0.0, 0.0], [0.0, 0.0, 160.0], [0.0, 80.0, 0.0], "white"),
        ([35.0, 79.9, 40.0], [30.0, 0.0, 0.0], [0.0, 0.0, 30.0], "lamp"),
    ] {
        t += &format!("\n[[quad]]\norigin = {origin:?}\nedge_u = {u:?}\nedge_v = {v:?}\nmaterial = \"{material}\"\n");
    }
    t
}

/// Coated conductors (aluminium under smooth coats, one tinted, gold under a
/// rough coat) and a floor of a smooth coat over a dark diffuse base (whose light
/// is mostly its coat's),
/// in a lit box: the GPU kernel specialized to them (`SCENE_KIND_COATED_CONDUCTOR`,
/// `SCENE_KIND_SMOOTH_COAT`), unguided and guided (where the smooth coat's delta
/// lobe is chosen beside guided directions), agrees with the CPU renderer.
#[test]
fn gpu_and_cpu_agree_on_coated_conductors_and_smooth_coats() {
    let t = four_spheres_in_a_lit_box(
        r#"
[[material]]
name = "rim"
type = "coated"
roughness = 0
eta = [1.65746, 0.880369, 0.521229]
k = [9.22387, 6.26952, 4.837]
base_roughness = 0.47

[[material]]
name = "lacquered gold"
type = "coated"
roughness = 0.3
ior = 1.6
eta = [0.143119, 0.374957, 1.44248]
k = [3.98316, 2.38572, 1.60322]
base_roughness = 0.6

[[material]]
name = "black paint"
type = "coated"
albedo = [0.05, 0.02, 0.01]
roughness = 0

[[material]]
name = "tinted rim"
type = "coated"
albedo = [0.9, 0.6, 0.5]
roughness = 0
ior = 1.3
eta = [1.65746, 0.880369, 0.521229]
k = [9.22387, 6.26952, 4.837]
base_roughness = 0.2
"#,
        ["rim", "lacquered gold", "white", "tinted rim"],
        "black paint",
    );
    let scene = Scene::parse(&t, "coated conductors").expect("the test scene loads");
    let mut opts = options(&scene, 32, 24, 1024);
    let prepared = rlpt::prepared::PreparedScene::new(&scene, &opts).expect("prepared");
    let kinds = prepared.params.scene_kinds;
    for bit in [rlpt::shared::SCENE_KIND_COATED_CONDUCTOR, rlpt::shared::SCENE_KIND_SMOOTH_COAT] {
        assert!(kinds & 1 << bit != 0, "scene kinds {kinds:#x} name bit {bit}");
    }
    // A fixed, large guided fraction: a smooth coat's mirror lobe is then chosen at
    // vertices that mix with chance (1 - 0.8) times its own, which its weight must count.
    (opts.guided_fraction, opts.learn_fraction) = (0.8, false);
    let g = gpu_unguided_and_guided_agree_with_cpu(&scene, &mut opts, [43, 44], "coated conductors, smooth coats");
    let (mean, _, _) = region_stats(&g, |_, _| true);
    assert!(mean > 0.01, "the scene renders lit (mean {mean})");
}
