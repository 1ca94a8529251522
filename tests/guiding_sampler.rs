//! The guided sampler follows its pdf, on the CPU and in GLSL; its alias rows
//! are distributions; the subgroup-aggregated atomics of learning lose nothing.

mod common;

use common::guiding::*;
use common::*;
use rlpt::gpu::{shader, Binding, Buffer, BufferUsage, Pipeline};
use rlpt::guide::{
    bin_cosine, build_alias_row, build_sampling_rows, class_axis, class_cosines, guided_direction,
    guided_direction_bin, guided_pdf, learned, sampler_row, AliasBin, Bins, GuidingMode, NORMAL_CLASSES, UNLEARNED,
};
use rlpt::math::rng::Rng;
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt_chi2::{chi2_sphere, sidak, Chi2Options};

/// A table row with structure (a few bright bins, many dim, some zero) and its sampling rows.
fn test_row(bins: Bins, seed: u32, floor: f32) -> (Vec<f32>, Vec<AliasBin>) {
    let mut rng = Rng::new(seed, 0, 0, 0);
    let q: Vec<f32> = (0..bins.count())
        .map(|_| {
            let r = rng.next_f32();
            if r < 0.2 {
                5.0 * rng.next_f32()
            } else if r < 0.5 {
                0.0
            } else {
                0.05 * rng.next_f32()
            }
        })
        .collect();
    let mut rows = vec![AliasBin::default(); q.len() * NORMAL_CLASSES as usize];
    build_sampling_rows(&class_cosines(&bins), &q, floor, &mut rows);
    (q, rows)
}

/// Row `class` of a cell's sampling rows.
fn class_row(rows: &[AliasBin], bins: Bins, class: u32) -> &[AliasBin] {
    let start = sampler_row(0, class, bins.count());
    &rows[start..start + bins.count() as usize]
}

#[test]
fn guided_sampler_follows_its_pdf_on_the_cpu() {
    let cases = [
        (Bins::OCTANT, 0.0),
        (Bins::SPHERE_DEFAULT, 0.0),
        (Bins::SPHERE_DEFAULT, 0.5),
        (Bins { rows: 5, cols: 7 }, 0.1),
    ];
    let significance = sidak(0.01, cases.len());
    for (i, (bins, floor)) in cases.into_iter().enumerate() {
        let (_, rows) = test_row(bins, 7 + i as u32, floor);
        let row = class_row(&rows, bins, i as u32 % NORMAL_CLASSES);
        let mut rng = Rng::new(1, i as u32, 0, 0);
        let samples: Vec<Option<[f64; 3]>> = (0..1_000_000)
            .map(|_| {
                let d = guided_direction(&bins, row, rng.next_f32(), rng.next_2d());
                Some([d.x as f64, d.y as f64, d.z as f64])
            })
            .collect();
        let pdf = |d: [f64; 3]| guided_pdf(&bins, row, Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)) as f64;
        let r = chi2_sphere(&samples, pdf, &Chi2Options::default());
        assert!(r.passed(significance), "bins {bins:?} floor {floor}: {r:?}");
    }
}

/// The renderers take a guided direction's density from the bin it was drawn in
/// (`guided_direction_bin`, glsl/guide.glsl) rather than finding its bin again:
/// the two must be the same function of the direction, so every direction drawn
/// in bin b lies in bin b by `Bins::index`, except within rounding of a bin's
/// edge (a set of measure zero, where either bin's density will do).
#[test]
fn a_guided_direction_lies_in_the_bin_it_was_drawn_in() {
    for bins in [Bins::OCTANT, Bins::SPHERE_DEFAULT, Bins { rows: 16, cols: 32 }, Bins { rows: 5, cols: 7 }] {
        let (_, rows) = test_row(bins, 3, 0.2);
        let row = class_row(&rows, bins, 1);
        let mut rng = Rng::new(2, bins.rows, bins.cols, 0);
        let (mut drawn, mut on_edges) = (vec![0u32; bins.count() as usize], 0);
        for _ in 0..200_000 {
            let (uc, u) = (rng.next_f32(), rng.next_2d());
            let (d, b) = guided_direction_bin(&bins, row, uc, u);
            assert_eq!(d, guided_direction(&bins, row, uc, u));
            drawn[b as usize] += 1;
            if bins.index(d) != b {
                let near_edge = |x: f32| !(1e-5..=1.0 - 1e-5).contains(&x);
                assert!(
                    near_edge(u[0]) || near_edge(u[1]),
                    "bins {bins:?}: u {u:?} drawn in bin {b}, lies in {}",
                    bins.index(d)
                );
                on_edges += 1;
            }
        }
        assert!(on_edges <= 10, "bins {bins:?}: {on_edges} directions off their bin");
        // Every bin with density is drawn from (the test rows have a floor).
        for (b, n) in drawn.iter().enumerate() {
            assert!(*n > 0 || row[b].pdf == 0.0, "bins {bins:?}: bin {b} never drawn");
        }
    }
}

#[test]
fn sampling_rows_are_distributions_and_unlearned_rows_are_empty() {
    let bins = Bins::SPHERE_DEFAULT;
    let omega = bins.solid_angle() as f64;
    for floor in [0.0, 0.5] {
        let (q, rows) = test_row(bins, 3, floor);
        for class in 0..NORMAL_CLASSES {
            let row = class_row(&rows, bins, class);
            let axis = class_axis(class);
            assert!(learned(row), "class {class}");
            // The stored densities are the alias table's probabilities, and sum to one.
            let p = alias_probabilities(row);
            assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9);
            for (b, e) in row.iter().enumerate() {
                assert!((e.pdf as f64 * omega - p[b]).abs() <= 1e-6, "class {class} bin {b}: {} vs {}", e.pdf, p[b]);
                // A bin behind the class's surface is never chosen; one in front is
                // chosen when it has learned light, or always with a floor.
                let cos = bin_cosine(&bins, b as u32, axis);
                assert_eq!(p[b] > 0.0, cos > 0.0 && (q[b] > 0.0 || floor > 0.0), "floor {floor} class {class} bin {b}");
            }
            // Each bin's probability follows its weight (Q + floor Qbar) cos, up to the
            // 16-bit thresholds: at most 2^-16 of a column per column that gives to it.
            let w: Vec<f64> = (0..q.len())
                .map(|b| {
                    let cos = bin_cosine(&bins, b as u32, axis) as f64;
                    let cos_sum: f64 = (0..q.len()).map(|c| bin_cosine(&bins, c as u32, axis) as f64).sum();
                    let qbar: f64 =
                        (0..q.len()).map(|c| q[c] as f64 * bin_cosine(&bins, c as u32, axis) as f64).sum::<f64>()
                            / cos_sum;
                    (q[b] as f64 + floor as f64 * qbar) * cos
                })
                .collect();
            let total: f64 = w.iter().sum();
            let n = q.len() as f64;
            for b in 0..q.len() {
                let givers = row.iter().filter(|e| (e.column & 0xffff) as usize == b).count() as f64 + 1.0;
                let bound = givers / 65535.0 / n + 1e-6;
                assert!(
                    (p[b] - w[b] / total).abs() <= bound,
                    "floor {floor} class {class} bin {b}: {} vs {}",
                    p[b],
                    w[b] / total
                );
            }
        }
    }
    let mut empty = vec![AliasBin::default(); 8 * NORMAL_CLASSES as usize];
    build_sampling_rows(&class_cosines(&Bins::OCTANT), &[0.0; 8], 0.5, &mut empty);
    assert!(!learned(&empty[..8]) && empty.iter().all(|e| e.column == UNLEARNED && e.pdf == 0.0));
}

#[test]
fn alias_rows_of_extreme_weights_sample_what_they_say() {
    // One bin with all the weight, one with a vanishing share, and uniform rows:
    // every bin with weight keeps some probability, none without weight gets any.
    let cases: Vec<Vec<f32>> = vec![
        (0..16).map(|b| if b == 5 { 1.0 } else { 0.0 }).collect(),
        (0..16)
            .map(|b| {
                if b == 0 {
                    1e6
                } else if b == 15 {
                    1e-3
                } else {
                    0.0
                }
            })
            .collect(),
        vec![1.0; 128],
        (0..35).map(|b| (b % 3) as f32).collect(),
    ];
    for w in cases {
        let mut row: Vec<AliasBin> = w.iter().map(|&x| AliasBin { column: 0, pdf: x }).collect();
        build_alias_row(&mut row);
        let p = alias_probabilities(&row);
        for (b, &x) in w.iter().enumerate() {
            assert_eq!(p[b] > 0.0, x > 0.0, "weights {w:?}: bin {b} has probability {}", p[b]);
        }
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    }
}

#[test]
fn glsl_guided_sampler_matches_rust_and_follows_its_pdf() {
    let ctx = gpu();
    // A prepared scene provides the params block the GLSL reads (bins, solid angle).
    let scene = scene("furnace-open.toml");
    let mut o = RenderOptions::from_scene(&scene);
    o.guiding = GuidingMode::Sphere;
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    let bins = prepared.guide.unwrap().bins;
    let n = 400_000usize;
    for seed in [7u32, 8] {
        let (_, rows) = test_row(bins, seed, 0.1);
        let row = class_row(&rows, bins, seed % NORMAL_CLASSES).to_vec();
        let mut rng = Rng::new(2, seed, 0, 0);
        let inputs: Vec<[f32; 4]> = (0..n).map(|_| [rng.next_f32(), rng.next_f32(), rng.next_f32(), 0.0]).collect();
        let params = Buffer::with_data(&ctx, "params", bytemuck::bytes_of(&prepared.params), true).unwrap();
        let row_buf = Buffer::with_data(&ctx, "sampling row", bytemuck::cast_slice(&row), false).unwrap();
        let input = Buffer::with_data(&ctx, "inputs", bytemuck::cast_slice(&inputs), false).unwrap();
        let output = Buffer::new(&ctx, "outputs", n as u64 * 16, BufferUsage::Storage).unwrap();
        let p = Pipeline::new_with_numbers(
            &ctx,
            "probe_guide",
            shader("probe_guide"),
            &[(0, Binding::Uniform), (9, Binding::Storage), (10, Binding::Storage), (11, Binding::Storage)],
            4,
        )
        .unwrap();
        p.bind(&[&params, &row_buf, &input, &output]);
        ctx.run_commands("probe guide", |cmd| {
            p.cmd_dispatch(cmd, [(n as u32).div_ceil(64), 1, 1], &(n as u32).to_le_bytes())
        })
        .unwrap();
        let out: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &output));
        let mut differ = 0;
        let samples: Vec<Option<[f64; 3]>> = out
            .iter()
            .zip(&inputs)
            .map(|(g, x)| {
                let d = guided_direction(&bins, &row, x[0], [x[1], x[2]]);
                let gd = Vec3::new(g[0], g[1], g[2]);
                let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * b.max(1.0);
                if (gd - d).length() > 1e-3 || !close(g[3], guided_pdf(&bins, &row, d)) {
                    differ += 1;
                }
                Some([gd.x as f64, gd.y as f64, gd.z as f64])
            })
            .collect();
        // A direction on a bin edge may fall into the neighbouring bin after rounding.
        assert!(differ <= n / 10_000, "{differ} GLSL guided samples differ from Rust's");
        let pdf = |d: [f64; 3]| guided_pdf(&bins, &row, Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)) as f64;
        let r = chi2_sphere(&samples, pdf, &Chi2Options::default());
        assert!(r.passed(sidak(0.01, 2)), "GLSL guided sampler: {r:?}");
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn aggregated_atomics_lose_nothing() {
    let ctx = gpu();
    let n = 100_000u32;
    let mut variants = vec!["probe_atomics"];
    if ctx.info.subgroup_partitioned {
        variants.push("probe_atomics_partitioned");
    }
    for name in variants {
        for distinct in [1u32, 3, 17, 1000] {
            let mut rng = Rng::new(distinct, 1, 2, 3);
            let keys: Vec<u32> = (0..n).map(|_| rng.next_u32() % distinct).collect();
            // Small integers: every partial sum is exact in f32, in any order.
            let targets: Vec<f32> = (0..n).map(|_| (rng.next_u32() % 8) as f32).collect();
            let kb = Buffer::with_data(&ctx, "keys", bytemuck::cast_slice(&keys), false).unwrap();
            let tb = Buffer::with_data(&ctx, "targets", bytemuck::cast_slice(&targets), false).unwrap();
            let sums = Buffer::new(&ctx, "sums", 4 * distinct as u64, BufferUsage::Storage).unwrap();
            let counts = Buffer::new(&ctx, "counts", 4 * distinct as u64, BufferUsage::Storage).unwrap();
            let p = Pipeline::new(&ctx, name, shader(name), &[Binding::Storage; 4], 4).unwrap();
            p.bind(&[&kb, &tb, &sums, &counts]);
            ctx.run_commands("probe atomics", |cmd| {
                sums.cmd_clear(cmd);
                counts.cmd_clear(cmd);
                ctx.barrier(cmd);
                p.cmd_dispatch(cmd, [n.div_ceil(256), 1, 1], &n.to_le_bytes());
            })
            .unwrap();
            let got_s: Vec<f32> = bytemuck::pod_collect_to_vec(&readback(&ctx, &sums));
            let got_c: Vec<u32> = bytemuck::pod_collect_to_vec(&readback(&ctx, &counts));
            let mut want_s = vec![0.0f32; distinct as usize];
            let mut want_c = vec![0u32; distinct as usize];
            for i in 0..n {
                // The kernel skips the lanes whose hash says so (paths that ended early).
                if rlpt::math::rng::pcg_hash(i) & 7 == 0 {
                    continue;
                }
                want_s[keys[i as usize] as usize] += targets[i as usize];
                want_c[keys[i as usize] as usize] += 1;
            }
            assert_eq!(got_c[..distinct as usize], want_c[..], "{name}, {distinct} keys: counts");
            assert_eq!(got_s[..distinct as usize], want_s[..], "{name}, {distinct} keys: sums");
        }
    }
    assert_no_validation_messages(&ctx);
}
