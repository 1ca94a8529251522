//! The image environment light (`[environment] file`): its sampler against its
//! density (chi-square, CPU), the GLSL sampler and lookup against the Rust ones,
//! renders that must agree with the uniform sky and with themselves NEE on and
//! off, and the loader's errors. The images are written here, into a temporary
//! directory.

mod bvh_support;
mod common;

use common::{assert_films_agree, gpu, options, readback, render_cpu, render_gpu, K};
use rlpt::gpu::{shader, Binding, Buffer, BufferUsage, Pipeline};
use rlpt::math::envmap::{env_lookup, env_sample};
use rlpt::math::rng::Rng;
use rlpt::math::Vec3;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;
use rlpt::shared;
use rlpt_chi2::{chi2_sphere, Chi2Options};
use std::path::{Path, PathBuf};

/// Writes a `w` x `h` float image of `texel(x, y)` to `path` (EXR or HDR by extension).
fn write_image(path: &Path, w: u32, h: u32, texel: impl Fn(u32, u32) -> [f32; 3]) {
    let img = image::Rgb32FImage::from_fn(w, h, |x, y| image::Rgb(texel(x, y)));
    img.save(path).unwrap();
}

/// A diffuse ball on a diffuse floor, lit by the environment `env` (the body of
/// an `[environment]` table).
fn ball_scene(env: &str, dir: &Path) -> Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 1.2, 4.0]\nlook_at = [0.0, 0.3, 0.0]\nvfov = 45.0\n\
         [render]\nmax_bounces = 4\n[environment]\n{env}\n\
         [[material]]\nname = \"ball\"\ntype = \"diffuse\"\nalbedo = [0.7, 0.5, 0.3]\n\
         [[material]]\nname = \"floor\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[sphere]]\ncenter = [0.0, 0.5, 0.0]\nradius = 0.5\nmaterial = \"ball\"\n\
         [[quad]]\norigin = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"floor\"\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).expect("valid scene")
}

/// A map of varied texels with one bright one, which the sampler must find.
fn varied(x: u32, y: u32) -> [f32; 3] {
    let h = rlpt::math::rng::pcg_hash(x * 131 + y * 7 + 1);
    let base = (h % 1000) as f32 / 1000.0;
    if (x, y) == (11, 3) {
        [40.0, 30.0, 20.0]
    } else if y == 6 {
        [0.0; 3] // a black row: never sampled
    } else {
        [base, 0.5 * base, 0.2 + base]
    }
}

fn varied_scene(test: &str, rotate: f32) -> (PreparedScene, PathBuf) {
    let dir = common::cli::fresh_dir(test);
    write_image(&dir.join("sky.exr"), 16, 8, varied);
    let scene = ball_scene(&format!("file = \"sky.exr\"\nscale = 2.0\nrotate = {rotate}"), &dir);
    let o = options(&scene, 8, 8, 64);
    (PreparedScene::new(&scene, &o).unwrap(), dir)
}

/// The sampler draws directions by the density it reports, which integrates to 1
/// over the sphere (chi-square over 10 x 20 bins of the sphere, the density
/// integrated adaptively); a sample's reported density and radiance are those the
/// lookup gives for its direction.
#[test]
fn env_sampler_draws_its_density() {
    let (p, _) = varied_scene("chi2", 30.0);
    assert_eq!(p.lights.last().unwrap().kind, shared::LIGHT_ENV);
    let n = 1_000_000;
    let mut rng = Rng::new(3, 1, 4, 1);
    let mut mismatched = 0;
    let samples: Vec<Option<[f64; 3]>> = (0..n)
        .map(|_| {
            let (wi, le, pdf) = env_sample(&p, rng.next_2d())?;
            let (le_l, pdf_l) = env_lookup(&p, wi);
            if le != le_l || (pdf - pdf_l).abs() > 1e-3 * pdf {
                mismatched += 1;
            }
            Some([wi.x as f64, wi.y as f64, wi.z as f64])
        })
        .collect();
    // Texel edges: the lookup of a sample on an edge may round into the neighbour.
    assert!(mismatched < n / 1000, "{mismatched} samples disagree with the lookup of their direction");
    let pdf = |d: [f64; 3]| env_lookup(&p, Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)).1 as f64;
    let out = chi2_sphere(&samples, pdf, &Chi2Options::default());
    assert!(out.passed(0.01), "{out}");
    assert!((out.pdf_integral - 1.0).abs() < 1e-3, "the density integrates to {}", out.pdf_integral);
}

/// The map's image centre is -z, u grows towards +x, row 0 is up; `rotate`
/// turns it counter-clockwise about +y (seen from above).
#[test]
fn env_convention_puts_the_image_centre_at_minus_z() {
    let dir = common::cli::fresh_dir("convention");
    // One bright texel in the middle column of the middle row, one at u = 3/4.
    write_image(&dir.join("sky.exr"), 8, 4, |x, y| match (x, y) {
        (4, 2) => [1.0, 0.0, 0.0],
        (6, 2) => [0.0, 1.0, 0.0],
        (_, 0) => [0.0, 0.0, 1.0],
        _ => [0.0; 3],
    });
    // The texel centres (u, v) = (4.5 / 8, 2.5 / 4) and (6.5 / 8, 2.5 / 4) as
    // written out by the convention, and turned by 90 degrees: (x, y, z) -> (z, y, -x).
    let at = |u: f32, v: f32| {
        let (theta, phi) = (std::f32::consts::PI * v, 2.0 * std::f32::consts::PI * (u - 0.5));
        Vec3::new(theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos())
    };
    let (centre, quarter) = (at(4.5 / 8.0, 2.5 / 4.0), at(6.5 / 8.0, 2.5 / 4.0));
    assert!(centre.z < -0.8 && quarter.x > 0.8, "the image centre looks along -z, u = 3/4 along +x");
    let turn = |d: Vec3| Vec3::new(d.z, d.y, -d.x);
    for (rotate, centre, quarter) in [(0.0, centre, quarter), (90.0, turn(centre), turn(quarter))] {
        let scene = ball_scene(&format!("file = \"sky.exr\"\nrotate = {rotate}"), &dir);
        let p = PreparedScene::new(&scene, &options(&scene, 8, 8, 64)).unwrap();
        assert_eq!(env_lookup(&p, centre).0, Vec3::new(1.0, 0.0, 0.0), "rotate {rotate}: the image centre");
        assert_eq!(env_lookup(&p, quarter).0, Vec3::new(0.0, 1.0, 0.0), "rotate {rotate}: u = 3/4");
        assert_eq!(env_lookup(&p, Vec3::Y).0, Vec3::new(0.0, 0.0, 1.0), "row 0 is up");
    }
}

/// probe_env.comp runs the GLSL sampler and lookup on the Rust ones' inputs:
/// the same directions, radiance and densities, to rounding.
#[test]
fn glsl_env_sampler_and_lookup_match_rust() {
    let (p, _) = varied_scene("probe", -75.0);
    let ctx = gpu();
    let n = 20_000usize;
    let mut rng = Rng::new(9, 9, 2, 6);
    let mut inputs = Vec::with_capacity(2 * n);
    let mut dirs = Vec::with_capacity(n);
    for _ in 0..n {
        let u = rng.next_2d();
        let d = rlpt::math::sampling::uniform_sphere(rng.next_2d());
        inputs.push([u[0], u[1], d.x, d.y]);
        inputs.push([d.z, 0.0, 0.0, 0.0]);
        dirs.push((u, d));
    }
    let params = Buffer::with_data(&ctx, "params", bytemuck::bytes_of(&p.params), true).unwrap();
    let texels = Buffer::with_data(&ctx, "env texels", bytemuck::cast_slice(&p.env_texels), false).unwrap();
    let cdf = Buffer::with_data(&ctx, "env cdf", bytemuck::cast_slice(&p.env_cdf), false).unwrap();
    let input = Buffer::with_data(&ctx, "inputs", bytemuck::cast_slice(&inputs), false).unwrap();
    let output = Buffer::new(&ctx, "outputs", n as u64 * 48, BufferUsage::Storage).unwrap();
    let bindings = [
        (shared::BINDING_PARAMS, Binding::Uniform),
        (shared::BINDING_ENV_TEXELS, Binding::Storage),
        (shared::BINDING_ENV_CDF, Binding::Storage),
        (30, Binding::Storage),
        (31, Binding::Storage),
    ];
    let pipe = Pipeline::new_specialized(&ctx, "probe_env", shader("probe_env"), &bindings, 4, &[]).unwrap();
    pipe.bind(&[&params, &texels, &cdf, &input, &output]);
    ctx.run_commands("probe env", |cmd| {
        pipe.cmd_dispatch(cmd, [(n as u32).div_ceil(64), 1, 1], bytemuck::bytes_of(&(n as u32)))
    })
    .unwrap();
    let out: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &output));
    let (mut edge_sample, mut edge_lookup) = (0, 0);
    for (i, (u, d)) in dirs.iter().enumerate() {
        let (wi, ok, le, pdf) = (out[3 * i], out[3 * i][3] != 0.0, out[3 * i + 1], out[3 * i + 1][3]);
        match env_sample(&p, *u) {
            None => assert!(!ok, "input {i}: the GPU samples where the CPU does not"),
            Some((cwi, cle, cpdf)) => {
                assert!(ok, "input {i}: the CPU samples where the GPU does not");
                let gwi = Vec3::new(wi[0], wi[1], wi[2]);
                assert!((gwi - cwi).length() < 1e-4, "input {i}: direction {gwi} on the GPU, {cwi} on the CPU");
                assert!((pdf - cpdf).abs() <= 1e-4 * cpdf, "input {i}: density {pdf} on the GPU, {cpdf} on the CPU");
                if Vec3::new(le[0], le[1], le[2]) != cle {
                    edge_sample += 1;
                }
            }
        }
        let (cle, cpdf) = env_lookup(&p, *d);
        let l = out[3 * i + 2];
        if Vec3::new(l[0], l[1], l[2]) != cle || (l[3] - cpdf).abs() > 1e-4 * cpdf {
            // A direction within rounding of a texel edge may look up either texel.
            edge_lookup += 1;
        }
    }
    assert!(edge_sample < n / 1000, "{edge_sample} samples' radiance differs");
    assert!(edge_lookup < n / 1000, "{edge_lookup} lookups differ");
    common::assert_no_validation_messages(&ctx);
}

/// A constant image renders as the uniform sky of its colour, NEE on and off
/// (CPU), and the GPU renders the image environment as the CPU does.
#[test]
fn constant_image_renders_as_the_uniform_sky() {
    let dir = common::cli::fresh_dir("constant");
    let c = [0.4f32, 0.7, 1.1];
    write_image(&dir.join("sky.exr"), 8, 4, |_, _| c);
    let image = ball_scene("file = \"sky.exr\"", &dir);
    let uniform = ball_scene(&format!("radiance = [{}, {}, {}]", c[0], c[1], c[2]), &dir);
    for nee in [true, false] {
        let mut o = options(&image, 24, 18, 64 * 8);
        o.nee = nee;
        let a = render_cpu(&image, &o);
        let b = render_cpu(&uniform, &o);
        assert_films_agree(&a, &b, 6, K, &format!("constant image vs uniform sky, NEE {nee} (CPU)"));
    }
    let ctx = gpu();
    let o = options(&image, 24, 18, 64 * 8);
    let g = render_gpu(&ctx, &image, &o);
    let c = render_cpu(&image, &o);
    assert_films_agree(&g, &c, 6, K, "constant image environment, GPU vs CPU");
}

/// The open furnace under a constant image of radiance 1, its ball made of
/// triangles (the BVH's shadow rays to infinity): a convex ball of albedo 0.5
/// renders 0.5 and the background 1, NEE on and off, GPU and CPU.
#[test]
fn tessellated_ball_in_an_image_furnace_renders_its_albedo() {
    let dir = common::cli::fresh_dir("furnace");
    write_image(&dir.join("sky.exr"), 8, 4, |_, _| [1.0; 3]);
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/furnace-open.toml")).unwrap();
    let text = text.replace("radiance = [1.0, 1.0, 1.0]", "file = \"sky.exr\"\nrotate = 33.0");
    let path = dir.join("furnace.toml");
    std::fs::write(&path, text).unwrap();
    let mut scene = Scene::load(&path).unwrap();
    let grey = scene.spheres[0].material;
    scene.spheres.clear();
    let (unit, triangles) = bvh_support::icosphere(3);
    scene.meshes.push(rlpt::scene::Mesh {
        source: PathBuf::from("icosphere"),
        positions: unit,
        normals: None,
        uvs: None,
        materials: vec![grey; triangles.len()],
        triangles,
    });
    let ctx = gpu();
    for nee in [true, false] {
        let mut o = options(&scene, 32, 32, 256);
        o.nee = nee;
        let prepared = PreparedScene::new(&scene, &o).unwrap();
        assert!(!prepared.bvh_nodes.is_empty());
        let hits = |x: u32, y: u32| {
            [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
                .iter()
                .filter(|u| {
                    let (o, d) = rlpt::camera::camera_ray(&prepared.params, x, y, **u);
                    rlpt::math::geometry::intersect(&prepared, o, d, f32::INFINITY).is_some()
                })
                .count()
        };
        for (device, film) in [("GPU", render_gpu(&ctx, &scene, &o)), ("CPU", render_cpu(&scene, &o))] {
            let (ball, ball_var, n_ball) = common::region_stats(&film, |x, y| hits(x, y) == 4);
            let (sky, _, n_sky) = common::region_stats(&film, |x, y| hits(x, y) == 0);
            assert!(n_ball > 100 && n_sky > 100, "{device}: {n_ball} ball pixels, {n_sky} sky pixels");
            let z = (ball - 0.5) / ball_var.sqrt();
            assert!(z.abs() < K, "{device}, NEE {nee}: ball {ball:.7}, expected 0.5 ({z:.2} sigma)");
            assert!((sky - 1.0).abs() < 1e-6, "{device}, NEE {nee}: background {sky}, expected 1");
        }
    }
}

/// The ball scene under a dark 16 x 8 map with a spot of two texels, about 0.25 sr
/// at 34 degrees above the horizon: small enough that light sampling matters,
/// large enough that BSDF sampling alone finds it often enough for its noise to
/// be estimated. Written into the temporary folder `name`.
fn spot_lit_scene(name: &str) -> Scene {
    let dir = common::cli::fresh_dir(name);
    write_image(&dir.join("sky.exr"), 16, 8, |x, y| {
        if (9..11).contains(&x) && y == 2 {
            [20.0, 16.0, 12.0]
        } else {
            [0.05, 0.06, 0.08]
        }
    });
    ball_scene("file = \"sky.exr\"\nrotate = 20.0", &dir)
}

/// Lit by a small bright spot of a dark map, NEE on and off agree: an error in the
/// map's density would bias light sampling's estimate and not BSDF sampling's.
/// The spot sits where the ball's side and the floor see it.
#[test]
fn spot_lit_scene_agrees_with_nee_on_and_off() {
    let scene = spot_lit_scene("spot");
    let mut on = options(&scene, 24, 18, 64 * 12);
    on.nee = true;
    let mut off = on.clone();
    off.nee = false;
    let ctx = gpu();
    let (gon, goff) = (render_gpu(&ctx, &scene, &on), render_gpu(&ctx, &scene, &off));
    let con = render_cpu(&scene, &on);
    // 6 x 6 blocks, and the whole image, where a density wrong by a tenth at
    // the spot is several sigma.
    for block in [6, 24] {
        let z = assert_films_agree(&gon, &goff, block, K, "spot-lit scene: NEE on vs off (GPU)");
        eprintln!("spot-lit scene, blocks of {block}: worst {z:.2} sigma");
        assert_films_agree(&con, &goff, block, K, "spot-lit scene: CPU NEE on vs GPU NEE off");
    }
    // The spot lights the scene: the image is not the dim background's alone.
    let sum = |f: &rlpt::film::Film| f.mean().pixels.iter().map(|p| p[0] as f64).sum::<f64>();
    let dim = sum(&render_cpu(&ball_scene("radiance = [0.05, 0.06, 0.08]", &common::cli::fresh_dir("spot-dim")), &on));
    assert!(sum(&gon) > 2.0 * dim, "the spot adds {} to the dim sky's {dim}", sum(&gon) - dim);
}

/// Learned guiding counts the image environment as it counts the uniform sky
/// (its escaping rays' targets, MIS-weighted where the targets are): guided
/// renders of the spot-lit scene, both Q-target kinds, agree with the unguided
/// one (GPU), and the CPU's guided render too.
#[test]
fn guided_renders_of_an_image_environment_agree_with_unguided() {
    use rlpt::guide::{GuidingMode, QTargets};
    let scene = spot_lit_scene("guided");
    let off = options(&scene, 24, 18, 64 * 12);
    let ctx = gpu();
    let reference = render_gpu(&ctx, &scene, &off);
    for targets in [QTargets::Mis, QTargets::Full] {
        let mut o = off.clone();
        o.guiding = GuidingMode::Sphere;
        o.q_targets = targets;
        for block in [6, 24] {
            let what = format!("image environment: GPU guided ({targets:?} targets) vs unguided");
            assert_films_agree(&render_gpu(&ctx, &scene, &o), &reference, block, K, &what);
        }
        if targets == QTargets::Mis {
            let what = "image environment: CPU guided vs GPU unguided";
            assert_films_agree(&render_cpu(&scene, &o), &reference, 24, K, what);
        }
    }
}

fn load_error(env: &str, dir: &Path) -> String {
    let text = format!(
        "[camera]\nposition = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov = 40.0\n[environment]\n{env}\n\
         [[material]]\nname = \"m\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).expect_err("the scene is refused").to_string()
}

#[test]
fn env_loader_refuses_bad_images_naming_the_file() {
    let dir = common::cli::fresh_dir("errors");
    let scene_file = dir.join("scene.toml").display().to_string();
    let e = load_error("file = \"missing.exr\"", &dir);
    assert!(e.starts_with(&format!("{scene_file}:6:8:")), "{e}");
    assert!(e.contains("\"missing.exr\"") && e.contains(&dir.join("missing.exr").display().to_string()), "{e}");
    assert!(e.contains("does not exist"), "{e}");

    std::fs::write(dir.join("garbage.exr"), b"not an image").unwrap();
    let e = load_error("file = \"garbage.exr\"", &dir);
    assert!(e.contains("\"garbage.exr\"") && e.contains("cannot be read"), "{e}");

    write_image(&dir.join("negative.exr"), 4, 2, |x, y| if (x, y) == (3, 1) { [0.5, -1.0, 0.5] } else { [1.0; 3] });
    let e = load_error("file = \"negative.exr\"", &dir);
    assert!(e.contains("\"negative.exr\"") && e.contains("texel (3, 1)") && e.contains("not negative"), "{e}");

    write_image(&dir.join("nan.exr"), 4, 2, |x, y| if (x, y) == (0, 1) { [f32::NAN, 0.0, 0.0] } else { [1.0; 3] });
    let e = load_error("file = \"nan.exr\"", &dir);
    assert!(e.contains("\"nan.exr\"") && e.contains("texel (0, 1)") && e.contains("finite"), "{e}");

    write_image(&dir.join("ok.exr"), 4, 2, |_, _| [1.0; 3]);
    let e = load_error("file = \"ok.exr\"\nradiance = [1.0, 1.0, 1.0]", &dir);
    assert!(e.contains("`radiance` and `file` exclude each other"), "{e}");
    let e = load_error("radiance = [1.0, 1.0, 1.0]\nscale = 2.0", &dir);
    assert!(e.contains("`scale`") && e.contains("give `file` too"), "{e}");
    let e = load_error("file = \"ok.exr\"\nscale = -1.0", &dir);
    assert!(e.contains("key `scale` must be from 0 to 1e12"), "{e}");
}

/// Radiance .hdr images load as EXR ones do (to the format's 8-bit mantissas),
/// and `scale` multiplies the texels.
#[test]
fn hdr_images_load_and_scale_multiplies() {
    let dir = common::cli::fresh_dir("hdr");
    let texel = |x: u32, y: u32| [0.25 * (x + 1) as f32, 0.5 * (y + 1) as f32, 2.0];
    write_image(&dir.join("sky.hdr"), 4, 2, texel);
    write_image(&dir.join("sky.exr"), 4, 2, texel);
    let hdr = ball_scene("file = \"sky.hdr\"\nscale = 3.0", &dir).environment_map.unwrap();
    let exr = ball_scene("file = \"sky.exr\"", &dir).environment_map.unwrap();
    assert_eq!((hdr.width, hdr.height), (4, 2));
    for (i, (a, b)) in hdr.texels.iter().zip(&exr.texels).enumerate() {
        for c in 0..3 {
            assert!((a[c] - 3.0 * b[c]).abs() <= 0.01 * 3.0 * b[c], "texel {i}: {a:?} vs 3 x {b:?}");
        }
    }
}
