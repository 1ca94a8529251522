//! The product of Q and a glossy lobe (src/guide/product.rs, glsl/product.glsl):
//! it samples what its density says, windows crossing the azimuth's seam and at a
//! pole included; the GLSL twin computes the same; and glossy scenes rendered
//! with it stay unbiased.

mod common;

use common::guiding::*;
use common::*;
use rlpt::gpu::{shader, Binding, Buffer, BufferUsage, Pipeline};
use rlpt::guide::{
    lobe_window, product_applies, product_bin, product_pdf, product_sums, window_columns, window_contains, window_sums,
    Bins, GuidingMode, LobeWindow, Product, ProductVertex,
};
use rlpt::math::bsdf::Bsdf;
use rlpt::math::rng::Rng;
use rlpt::math::{Frame, Vec3};
use rlpt::prepared::PreparedScene;
use rlpt::scene::{MaterialKind, Scene};
use rlpt_chi2::{chi2_sphere, sidak, Chi2Options, Zoom};

/// A Q row with structure: a few bright bins, many dim, some zero.
fn q_row(bins: Bins, seed: u32) -> Vec<f32> {
    let mut rng = Rng::new(seed, 5, 0, 0);
    (0..bins.count())
        .map(|_| {
            let r = rng.next_f32();
            if r < 0.2 {
                5.0 * rng.next_f32()
            } else if r < 0.4 {
                0.0
            } else {
                0.05 * rng.next_f32()
            }
        })
        .collect()
}

/// A vertex of shading normal `n` whose lobe is centred on `m` (world space).
fn vertex(n: Vec3, m: Vec3, alpha: f32, q: &[f32]) -> ProductVertex<'_> {
    let (n, m) = (n.normalize(), m.normalize());
    assert!(n.dot(m) > 0.0, "the lobe's centre {m} lies above the surface {n}");
    let frame = Frame::from_normal(n);
    let wo = frame.to_local(n * (2.0 * n.dot(m)) - m);
    ProductVertex { frame, wo, alpha, q }
}

/// Whether some row of the window wraps past the last column.
fn crosses_seam(bins: &Bins, p: &Product) -> bool {
    (p.window.r0..=p.window.r1).any(|row| {
        let (c0, n) = window_columns(bins, &p.window, row);
        c0 + n > bins.cols
    })
}

/// The cases: (what, bins, normal, lobe centre, alpha).
fn cases() -> Vec<(&'static str, Bins, Vec3, Vec3, f32)> {
    let b = Bins::SPHERE_ROULETTE_DEFAULT;
    vec![
        ("seam", b, Vec3::new(0.3, 0.2, 1.0), Vec3::new(1.0, -0.02, 0.3), 0.09),
        ("pole", b, Vec3::new(0.1, 0.0, 1.0), Vec3::new(0.01, 0.02, 1.0), 0.09),
        ("wide", b, Vec3::new(0.0, 1.0, 0.2), Vec3::new(-0.5, 0.7, -0.4), 0.3),
        ("narrow", Bins::SPHERE_DEFAULT, Vec3::new(1.0, 0.1, 0.0), Vec3::new(0.8, 0.5, 0.3), 0.02),
        // A pole row of 128 columns, more than a window holds: it keeps a wedge.
        ("capped pole", Bins { rows: 8, cols: 128 }, Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.05, 0.0, -1.0), 0.1),
    ]
}

/// The windows are what the cases are for: one crosses the seam, one holds a
/// pole row whole, one is capped, and every window holds the bin of its centre.
#[test]
fn windows_cross_the_seam_hold_poles_and_are_capped() {
    for (what, bins, n, m, alpha) in cases() {
        let q = q_row(bins, 1);
        let v = vertex(n, m, alpha, &q);
        let p = product_sums(&bins, &v, 0.1);
        let count: u32 = (p.window.r0..=p.window.r1).map(|r| window_columns(&bins, &p.window, r).1).sum();
        assert!(count <= rlpt::shared::PRODUCT_MAX_BINS, "{what}: {count} bins");
        assert!(window_contains(&bins, &p.window, bins.index(v.mirror())), "{what}: the centre's bin");
        assert_eq!(lobe_window(&bins, v.mirror(), alpha), p.window, "{what}");
        let inside = (0..bins.count()).filter(|&b| window_contains(&bins, &p.window, b)).count() as u32;
        assert_eq!(inside, count, "{what}: window_contains and window_columns disagree");
        match what {
            "seam" => assert!(crosses_seam(&bins, &p), "{what}: {:?}", p.window),
            "pole" => {
                assert_eq!(p.window.r0, 0, "{what}");
                assert_eq!(window_columns(&bins, &p.window, 0).1, bins.cols, "{what}: the pole row whole");
            }
            "capped pole" => {
                assert_eq!(p.window.r1, bins.rows - 1, "{what}");
                assert_eq!(count, rlpt::shared::PRODUCT_MAX_BINS, "{what}");
            }
            "wide" => assert!(p.window.r1 > p.window.r0 + 1 && count > 16, "{what}: {:?}", p.window),
            _ => {}
        }
    }
}

/// The product's directions (`product_bin`, then uniform in the bin) follow
/// `product_pdf`, which integrates to one: chi-square over the sphere, zoomed on
/// the lobe's centre so that the window's bins spread over the test's.
#[test]
fn product_sampler_follows_its_pdf() {
    let cases = cases();
    let significance = sidak(0.01, cases.len());
    for (i, (what, bins, n, m, alpha)) in cases.into_iter().enumerate() {
        let q = q_row(bins, 2 + i as u32);
        let v = vertex(n, m, alpha, &q);
        let p = product_sums(&bins, &v, 0.1);
        assert!(p.sum_w > 0.0, "{what}");
        let zoom = Zoom::new(v.mirror().to_array().map(f64::from), 0.25 / alpha.max(0.05) as f64);
        let mut rng = Rng::new(3, i as u32, 0, 0);
        let samples: Vec<Option<[f64; 3]>> = (0..1_000_000)
            .map(|_| {
                let b = product_bin(&bins, &v, &p, rng.next_f32());
                let d = bins.sample(b, rng.next_2d());
                Some(zoom.sample([d.x as f64, d.y as f64, d.z as f64]))
            })
            .collect();
        let pdf = |d: [f64; 3]| {
            let d = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32).normalize();
            product_pdf(&bins, &v, &p, bins.index(d)) as f64
        };
        let r = chi2_sphere(&samples, |d| zoom.pdf(pdf, d), &Chi2Options::default());
        assert!(r.passed(significance), "{what}: {r}");
    }
}

/// The product applies to GGX lobes (glossy, rough conductor) from alpha 0.01
/// up to where the window's cap outgrows `PRODUCT_WINDOW_BINS` bins (alpha 0.122
/// at 20x40, 0.306 at 8x16), and never to lobes as wide as the cosine's.
#[test]
fn the_product_applies_to_lobes_its_window_holds() {
    let (fine, coarse) = (Bins::SPHERE_ROULETTE_DEFAULT, Bins::SPHERE_DEFAULT);
    let glossy = |alpha: f32| Bsdf::new(MaterialKind::Glossy, Vec3::splat(0.8), alpha, 1.5);
    for (alpha, at_fine, at_coarse) in
        [(0.005, false, false), (0.01, true, true), (0.09, true, true), (0.12, true, true), (0.125, false, true)]
    {
        assert_eq!(product_applies(&glossy(alpha), &fine), at_fine, "alpha {alpha}, 20x40");
        assert_eq!(product_applies(&glossy(alpha), &coarse), at_coarse, "alpha {alpha}, 8x16");
    }
    assert!(product_applies(&glossy(0.3), &coarse) && !product_applies(&glossy(0.31), &coarse));
    let wide = Bins { rows: 1, cols: 2 };
    assert!(product_applies(&glossy(0.49), &wide) && !product_applies(&glossy(0.5), &wide));
    assert!(product_applies(&Bsdf::conductor(Vec3::ONE, Vec3::ONE, 0.09), &fine));
    for kind in [MaterialKind::Diffuse, MaterialKind::Coated, MaterialKind::RoughDielectric] {
        assert!(!product_applies(&Bsdf::new(kind, Vec3::splat(0.8), 0.09, 1.5), &fine), "{kind:?}");
    }
}

/// A window whose Q is zero everywhere has nothing to sample: its sum is 0 and
/// so is its density (the vertex then samples the BSDF alone).
#[test]
fn a_window_without_light_has_no_density() {
    let bins = Bins::SPHERE_ROULETTE_DEFAULT;
    let q = vec![0.0; bins.count() as usize];
    let v = vertex(Vec3::Z, Vec3::new(0.3, 0.1, 1.0), 0.09, &q);
    let p = product_sums(&bins, &v, 0.1);
    assert_eq!(p.sum_w, 0.0);
    assert_eq!(product_pdf(&bins, &v, &p, bins.index(v.mirror())), 0.0);
}

/// glsl/product.glsl computes what src/guide/product.rs does: the window, its
/// sums, the bin drawn and the densities, on random vertices (normals, lobe
/// centres, widths) of a 20x40 table.
#[test]
fn glsl_product_matches_rust() {
    let ctx = gpu();
    let scene = scene("furnace-open.toml");
    let mut o = guided(&options(&scene, 8, 8, 64), GuidingMode::Sphere);
    o.bins = Some(Bins::SPHERE_ROULETTE_DEFAULT);
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    let bins = prepared.guide.unwrap().bins;
    assert_eq!(bins, Bins::SPHERE_ROULETTE_DEFAULT, "the scene's bins");
    let q = q_row(bins, 9);
    let floor = 0.1f32;
    let n = 20_000usize;
    let mut rng = Rng::new(4, 4, 4, 4);
    let mut unit = || {
        let z = 1.0 - 2.0 * rng.next_f32();
        let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    let mut cases = Vec::new();
    while cases.len() < n {
        let (nrm, m, d) = (unit(), unit(), unit());
        if nrm.dot(m) < 0.05 {
            continue;
        }
        // Alpha from 0.01 to 0.5, and the direction near the lobe's centre half the time.
        let k = cases.len() as f32 / n as f32;
        let alpha = 0.01 + 0.49 * k * k;
        let d = if cases.len() % 2 == 0 { (m + d * 4.0 * alpha).normalize() } else { d };
        cases.push((nrm, m, alpha, d, (cases.len() as f32 + 0.5) / n as f32));
    }
    let inputs: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|&(nrm, m, alpha, d, uc)| {
            let v = vertex(nrm, m, alpha, &q);
            [nrm.extend(alpha).to_array(), v.wo.extend(uc).to_array(), d.extend(floor).to_array()]
        })
        .collect();
    let params = Buffer::with_data(&ctx, "params", bytemuck::bytes_of(&prepared.params), true).unwrap();
    let q_buf = Buffer::with_data(&ctx, "q", bytemuck::cast_slice(&q), false).unwrap();
    let input = Buffer::with_data(&ctx, "inputs", bytemuck::cast_slice(&inputs), false).unwrap();
    let output = Buffer::new(&ctx, "outputs", n as u64 * 48, BufferUsage::Storage).unwrap();
    let p = Pipeline::new_with_numbers(
        &ctx,
        "probe_product",
        shader("probe_product"),
        &[(0, Binding::Uniform), (6, Binding::Storage), (10, Binding::Storage), (11, Binding::Storage)],
        4,
    )
    .unwrap();
    p.bind(&[&params, &q_buf, &input, &output]);
    ctx.run_commands("probe product", |cmd| {
        p.cmd_dispatch(cmd, [(n as u32).div_ceil(64), 1, 1], &(n as u32).to_le_bytes())
    })
    .unwrap();
    let out: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &output));
    let close = |a: f32, b: f32, tol: f32| (a - b).abs() <= tol * a.abs().max(b.abs()) + 1e-30;
    let count = |w: &LobeWindow| (w.r0..=w.r1).map(|r| window_columns(&bins, w, r).1).sum::<u32>();
    let (mut windows, mut values) = (0, 0);
    for (i, &(nrm, m, alpha, d, uc)) in cases.iter().enumerate() {
        let v = vertex(nrm, m, alpha, &q);
        let cpu = lobe_window(&bins, v.mirror(), alpha);
        let [a, b, c] = [out[3 * i], out[3 * i + 1], out[3 * i + 2]];
        // The window's parameters agree to rounding (the GPU's arc functions).
        let rows = a[2].to_bits();
        let gpu = LobeWindow { zm: c[0], phi_m: c[1], cos_r: c[2], r0: rows & 0xffff, r1: rows >> 16 };
        assert!(
            (gpu.zm - cpu.zm).abs() < 1e-5
                && (gpu.phi_m - cpu.phi_m).abs() < 1e-4
                && (gpu.cos_r - cpu.cos_r).abs() < 1e-5,
            "case {i}: windows {gpu:?} (GPU) and {cpu:?} (CPU)"
        );
        // Its bins may differ where those roundings cross a bin's edge, rarely.
        if (gpu.r0, gpu.r1, count(&gpu)) != (cpu.r0, cpu.r1, count(&cpu)) {
            windows += 1;
        }
        // Over the GPU's window, the sums, the bin drawn and the densities are the
        // CPU's, to rounding: the lobe's value moves by 2 e / alpha relative for an
        // error e in the half vector, and by e / cos_i in G2 at grazing bins (1e-3
        // allows e = 1e-6 from alpha 0.01 and cos_i 0.001 on); a bug is off by more.
        let tol = 1e-3;
        let pr = window_sums(&bins, &v, floor, gpu);
        let bin = product_bin(&bins, &v, &pr, uc);
        let test_bin = bins.index(d);
        let contains = window_contains(&bins, &gpu, test_bin);
        // Which bins a row holds turns on an arccosine: rounding may add or drop
        // one at the window's edge; those cases go with the windows that differ.
        if b[3] as u32 != count(&gpu) {
            windows += 1;
            continue;
        }
        if !close(a[0], pr.sum_w, tol)
            || !close(a[1], pr.floor_q, tol)
            || a[3].to_bits() != bin
            || (b[2] == 1.0) != contains
            || !close(b[0], product_pdf(&bins, &v, &pr, bin), tol)
            || !close(b[1], product_pdf(&bins, &v, &pr, test_bin), tol)
        {
            values += 1;
            if values < 5 {
                let pdfs = (product_pdf(&bins, &v, &pr, bin), product_pdf(&bins, &v, &pr, test_bin));
                eprintln!("case {i}, alpha {alpha}: GPU {a:?} {b:?}, CPU {pr:?} bin {bin} {contains} {pdfs:?}");
            }
        }
    }
    eprintln!("{n} cases: windows differ {windows}, values over the same window {values}");
    assert!(windows <= n / 200, "{windows} windows of {n} differ");
    assert!(values <= n / 1000, "{values} cases of {n} differ over the same window");
    assert_no_validation_messages(&ctx);
}

/// A scene of `scenes/` with the text `from` (which it must hold) replaced by `to`.
fn edited_scene(name: &str, from: &str, to: &str) -> Scene {
    let text = std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).expect(name);
    assert!(text.contains(from), "{name} holds {from:?}");
    Scene::parse(&text.replace(from, to), &format!("{name}, edited")).expect("the edited scene parses")
}

/// Glossy scenes rendered with the product stay unbiased: seed-exp1 with its
/// white walls, floor, ceiling and ball glossy of roughness 0.3 (alpha 0.09,
/// where today's share would be 0 and the product applies), guided on the GPU and
/// the CPU, against an unguided GPU render.
#[test]
fn glossy_product_renders_agree_with_unguided() {
    let scene = edited_scene(
        "seed-exp1.toml",
        "name = \"white\"\ntype = \"diffuse\"\nalbedo = [0.75, 0.75, 0.75]",
        "name = \"white\"\ntype = \"glossy\"\nalbedo = [0.75, 0.75, 0.75]\nroughness = 0.3",
    );
    let ctx = gpu();
    let base = options(&scene, 36, 24, 1024);
    let off = render_gpu(&ctx, &scene, &base);
    let mut o = guided(&base, GuidingMode::Sphere);
    o.glossy_product = true;
    o.seed = 41;
    let flags = PreparedScene::new(&scene, &o).expect("valid options").params.flags;
    assert!(flags & rlpt::shared::FLAG_GLOSSY_PRODUCT != 0, "the product is on");
    let z = assert_films_agree(&render_gpu(&ctx, &scene, &o), &off, 6, K, "glossy product: GPU guided vs off");
    eprintln!("glossy product, GPU guided: worst block {z:.2} sigma");
    (o.width, o.height, o.spp, o.seed) = (18, 12, 512, 42);
    let mut off_small = base.clone();
    (off_small.width, off_small.height, off_small.spp) = (18, 12, 512);
    let z = assert_films_agree(
        &render_cpu(&scene, &o),
        &render_gpu(&ctx, &scene, &off_small),
        4,
        K,
        "glossy product: CPU guided vs GPU off",
    );
    eprintln!("glossy product, CPU guided: worst block {z:.2} sigma");
    assert_no_validation_messages(&ctx);
}
