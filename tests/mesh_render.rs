//! Triangle meshes in whole renders, on the GPU (lavapipe in CI) and the CPU:
//! a tessellated ball in the open furnace, emissive triangles as lights (their
//! sampler's chi-square, NEE on versus off, guided versus unguided), GPU versus CPU.

mod bvh_support;
mod common;

use common::*;
use rlpt::camera::camera_ray;
use rlpt::film::Film;
use rlpt::math::geometry::{intersect, light_pdf, sample_light};
use rlpt::math::rng::Rng;
use rlpt::math::triangle::intersect_triangle;
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::scene::{Mesh, Scene};
use rlpt_chi2::{chi2_sphere, sidak, Chi2Options};
use std::path::PathBuf;

/// A closed icosphere of `level` subdivisions about `center` (counter-clockwise
/// seen from outside: the front faces out), every triangle of material `material`.
fn icosphere(center: Vec3, radius: f32, level: u32, material: u32) -> Mesh {
    let (unit, triangles) = bvh_support::icosphere(level);
    Mesh {
        source: PathBuf::from("icosphere"),
        positions: unit.iter().map(|p| center + radius * *p).collect(),
        normals: None,
        uvs: None,
        materials: vec![material; triangles.len()],
        triangles,
    }
}

fn material_index(scene: &Scene, name: &str) -> u32 {
    scene.materials.iter().position(|m| m.name == name).unwrap() as u32
}

/// The open furnace (scenes/furnace-open.toml) with its ball made of triangles.
fn tessellated_furnace() -> Scene {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/furnace-open.toml")).unwrap();
    let mut scene = Scene::parse(&text, "furnace-open.toml").unwrap();
    let grey = scene.spheres[0].material;
    scene.spheres.clear();
    scene.meshes.push(icosphere(Vec3::ZERO, 1.0, 3, grey));
    scene
}

#[test]
fn a_tessellated_ball_in_the_open_furnace_renders_its_albedo() {
    let scene = tessellated_furnace();
    let ctx = gpu();
    for nee in [true, false] {
        let mut opts = options(&scene, 40, 40, 256);
        opts.nee = nee;
        let prepared = PreparedScene::new(&scene, &opts).expect("valid options");
        assert!(!prepared.bvh_nodes.is_empty(), "a scene with triangles walks a BVH");
        let hits = |x: u32, y: u32| {
            [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
                .iter()
                .filter(|u| {
                    let (o, d) = camera_ray(&prepared.params, x, y, **u);
                    intersect(&prepared, o, d, f32::INFINITY).is_some()
                })
                .count()
        };
        for (device, film) in [("GPU", render_gpu(&ctx, &scene, &opts)), ("CPU", render_cpu(&scene, &opts))] {
            let (ball, ball_var, n_ball) = region_stats(&film, |x, y| hits(x, y) == 4);
            let (sky, _, n_sky) = region_stats(&film, |x, y| hits(x, y) == 0);
            assert!(n_ball > 100 && n_sky > 100, "{device}: {n_ball} ball pixels, {n_sky} sky pixels");
            // A convex polyhedron: every reflected ray escapes, each sample is 0.5 x 1.
            let z = (ball - 0.5) / ball_var.sqrt();
            assert!(z.abs() < K, "{device}, NEE {nee}: ball {ball:.7}, expected 0.5 ({z:.2} sigma)");
            assert!((sky - 1.0).abs() < 1e-6, "{device}, NEE {nee}: background {sky}, expected 1");
        }
    }
}

/// A closed box of quads lit by emissive triangles: a one-sided panel of two
/// triangles under the ceiling facing down, a two-sided triangle, and a
/// tessellated ball of glossy material; the camera inside.
fn triangle_lit_room() -> Scene {
    let text = r#"
[camera]
position = [0, 1, 3.5]
look_at = [0, 1, 0]
vfov = 50
[render]
width = 24
height = 24
max_bounces = 5
[[material]]
name = "white"
type = "diffuse"
albedo = [0.7, 0.7, 0.7]
[[material]]
name = "red"
type = "diffuse"
albedo = [0.7, 0.2, 0.2]
[[material]]
name = "metal"
type = "glossy"
albedo = [0.8, 0.8, 0.6]
roughness = 0.4
[[material]]
name = "lamp"
type = "emissive"
emission = [12, 12, 10]
[[material]]
name = "glow"
type = "emissive"
emission = [1, 3, 1]
two_sided = true
[[quad]]
origin = [-2, 0, -2]
edge_u = [0, 0, 6]
edge_v = [4, 0, 0]
material = "white"
[[quad]]
origin = [-2, 2.5, -2]
edge_u = [4, 0, 0]
edge_v = [0, 0, 6]
material = "white"
[[quad]]
origin = [-2, 0, -2]
edge_u = [4, 0, 0]
edge_v = [0, 2.5, 0]
material = "white"
[[quad]]
origin = [-2, 0, -2]
edge_u = [0, 2.5, 0]
edge_v = [0, 0, 6]
material = "red"
[[quad]]
origin = [2, 0, -2]
edge_u = [0, 0, 6]
edge_v = [0, 2.5, 0]
material = "white"
[[quad]]
origin = [-2, 0, 4]
edge_u = [0, 2.5, 0]
edge_v = [4, 0, 0]
material = "white"
"#;
    let mut scene = Scene::parse(text, "triangle-lit room").unwrap();
    let (lamp, glow, metal) =
        (material_index(&scene, "lamp"), material_index(&scene, "glow"), material_index(&scene, "metal"));
    // Facing down: (v1 - v0) x (v2 - v0) points to -y.
    scene.meshes.push(Mesh {
        source: PathBuf::from("panel"),
        positions: vec![
            Vec3::new(-0.5, 2.45, -0.5),
            Vec3::new(0.5, 2.45, -0.5),
            Vec3::new(0.5, 2.45, 0.5),
            Vec3::new(-0.5, 2.45, 0.5),
        ],
        normals: None,
        uvs: None,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        materials: vec![lamp; 2],
    });
    scene.meshes.push(Mesh {
        source: PathBuf::from("glow"),
        positions: vec![Vec3::new(1.2, 0.2, -1.5), Vec3::new(1.8, 0.2, -1.0), Vec3::new(1.5, 1.4, -1.3)],
        normals: None,
        uvs: None,
        triangles: vec![[0, 1, 2]],
        materials: vec![glow],
    });
    scene.meshes.push(icosphere(Vec3::new(-0.6, 0.6, -0.5), 0.6, 2, metal));
    scene
}

#[test]
fn emissive_triangles_light_a_room_alike_on_gpu_and_cpu_with_and_without_nee_and_guiding() {
    let scene = triangle_lit_room();
    let ctx = gpu();
    let mut opts = options(&scene, 24, 24, 1024);
    let prepared = PreparedScene::new(&scene, &opts).expect("valid options");
    assert_eq!(prepared.lights.len(), 3, "every emissive triangle is a light");
    let gpu_nee = render_gpu(&ctx, &scene, &opts);
    let (mean, _, _) = region_stats(&gpu_nee, |_, _| true);
    assert!(mean > 0.05, "the room renders lit (mean {mean})");
    opts.seed = 7;
    let cpu_nee = render_cpu(&scene, &opts);
    assert_films_agree(&gpu_nee, &cpu_nee, 4, K, "GPU vs CPU, NEE on");
    opts.nee = false;
    opts.seed = 11;
    let gpu_plain = render_gpu(&ctx, &scene, &opts);
    assert_films_agree(&gpu_nee, &gpu_plain, 4, K, "GPU NEE on vs off");
    opts.seed = 13;
    let cpu_plain = render_cpu(&scene, &opts);
    assert_films_agree(&cpu_nee, &cpu_plain, 4, K, "CPU NEE on vs off");
    opts.nee = true;
    opts.seed = 17;
    opts.guiding = rlpt::guide::GuidingMode::Sphere;
    let guided: Film = render_gpu(&ctx, &scene, &opts);
    assert_films_agree(&gpu_nee, &guided, 4, K, "GPU unguided vs guided");
}

#[test]
fn smooth_meshes_render_alike_on_gpu_and_cpu() {
    let mut scene = triangle_lit_room();
    // Shading normals on the ball: the sphere's own normals at its vertices.
    let ball = scene.meshes.last_mut().unwrap();
    let c = Vec3::new(-0.6, 0.6, -0.5);
    ball.normals = Some(ball.positions.iter().map(|p| (*p - c).normalize()).collect());
    let ctx = gpu();
    let mut opts = options(&scene, 24, 24, 512);
    let g = render_gpu(&ctx, &scene, &opts);
    opts.seed = 5;
    let c = render_cpu(&scene, &opts);
    assert_films_agree(&g, &c, 4, K, "smooth ball: GPU vs CPU");
}

/// The light sampler over emissive triangles: a light chosen by power, then a
/// point uniform by area; its directions follow `light_pdf`.
#[test]
fn emissive_triangle_directions_follow_light_pdf() {
    let scene = triangle_lit_room();
    let prepared = PreparedScene::new(&scene, &RenderOptions::from_scene(&scene)).expect("valid options");
    let points = [Vec3::new(0.3, 0.5, 1.0), Vec3::new(-1.5, 2.0, -1.0)];
    let significance = sidak(0.01, points.len());
    for (k, p) in points.iter().enumerate() {
        let mut rng = Rng::new(21, k as u32, 0, 0);
        let samples: Vec<Option<[f64; 3]>> = (0..1_000_000)
            .map(|_| {
                let (u_sel, u) = (rng.next_f32(), rng.next_2d());
                sample_light(&prepared, *p, u_sel, u).map(|s| [s.wi.x as f64, s.wi.y as f64, s.wi.z as f64])
            })
            .collect();
        let prep = prepared.clone();
        let pp = *p;
        let pdf = move |d: [f64; 3]| {
            let w = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32);
            prep.lights
                .iter()
                .enumerate()
                .filter_map(|(li, l)| {
                    let [a, b, c] = prep.triangles[l.index as usize].vertices();
                    intersect_triangle(a, b, c, pp, w, f32::INFINITY).map(|_| light_pdf(&prep, li as u32, pp, w) as f64)
                })
                .sum::<f64>()
        };
        let r = chi2_sphere(&samples, pdf, &Chi2Options::default());
        assert!(r.passed(significance), "shading point {p:?}: {r:?}");
    }
}
