//! What the cells learn: their guided fractions and Q values, the GPU's as the
//! CPU's, and the MIS-weighted targets against Dahm & Keller's.

mod common;

use common::guiding::*;
use common::*;
use rlpt::cpu::CpuRenderer;
use rlpt::gpu::Context;
use rlpt::guide::{
    evidence_weight, learned, Bins, GuidingMode, QTable, QTargets, Recorder, DEFAULT_RATE_EXPONENT, NORMAL_CLASSES,
};
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;
use std::sync::Arc;

/// The mean guided fraction of the learned rows of `t`, and how many there are.
/// The mean of the learned fractions of the cells' learned rows (the cells'
/// states', before the evidence weight), and how many rows.
fn mean_fraction(t: &QTable) -> (f64, usize) {
    let n = t.q.len() / t.fraction_states.len();
    let learned: Vec<f64> = (0..t.fractions.len())
        .filter(|&i| learned(&t.rows[i * n..(i + 1) * n]))
        .map(|i| t.fraction_states[i / NORMAL_CLASSES as usize].fraction(0.5) as f64)
        .collect();
    (learned.iter().sum::<f64>() / learned.len().max(1) as f64, learned.len())
}

/// Seed-exp1 at 48x32 guided by `mode` with NEE on or off, Q's learning rate
/// 1/i^`rate` and `targets`: the table after `frames` frames.
fn exp1_table(
    mode: GuidingMode,
    nee: bool,
    rate: f32,
    targets: QTargets,
    frames: u32,
    gpu: Option<&Arc<Context>>,
) -> QTable {
    let scene = scene("seed-exp1.toml");
    let mut o = guided(&options(&scene, 48, 32, 64), mode);
    // Learning once per recording cycle, as a large image does: the tests follow
    // the fractions over a few dozen frames.
    o.learning_period = Some(1);
    o.nee = nee;
    o.learning_rate_exponent = rate;
    o.q_targets = targets;
    assert!(o.learn_fraction, "cells learn their fractions by default");
    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    match gpu {
        Some(ctx) => {
            let mut r = GpuRenderer::new(ctx, &prepared).unwrap();
            r.render_frames(frames).unwrap();
            let table = r.table().unwrap().unwrap();
            // The viewer's per-voxel reads (V) give the same values and fractions as the whole table's.
            let classes = NORMAL_CLASSES as usize;
            let bins = prepared.guide.unwrap().bins.count() as usize;
            for cell in 0..table.fraction_states.len() {
                let read = r.cell_fractions(cell as u32).unwrap().unwrap();
                assert_eq!(read, table.fractions[cell * classes..(cell + 1) * classes], "voxel {cell}");
                let values = r.cell_values(cell as u32).unwrap().unwrap();
                assert_eq!(values, table.q[cell * bins..(cell + 1) * bins], "voxel {cell}");
            }
            table
        }
        None => {
            let mut r = CpuRenderer::new(&prepared);
            for _ in 0..frames {
                r.render_frame();
            }
            r.table().unwrap().clone()
        }
    }
}

/// Each cell learns its guided fraction from what its paths find. On seed-exp1
/// with NEE and Dahm & Keller's targets (`QTargets::Full`), Q holds the lamp that
/// light sampling already finds, guided directions aim at it and add little
/// (guided relMSE 1.03 to 1.36 times unguided at equal time with a fixed 0.5,
/// BENCHMARKS.md): the fractions fall. With the MIS-weighted targets (the
/// default) Q holds what light sampling leaves, the light from the lit walls and
/// the lamp's MIS share, and guided directions find it better than the BSDF's:
/// they rise. Without NEE only BSDF and guided directions reach the lamp, and
/// the sphere's guided ones reach it far more often (half the unguided relMSE at
/// equal time): they rise. (CPU renderer, 24 frames; at 128 the means with Full
/// targets are 0.32 and 0.87.)
#[test]
fn cells_learn_their_fractions_from_the_light_they_find() {
    let rate = DEFAULT_RATE_EXPONENT;
    let (full, rows) = mean_fraction(&exp1_table(GuidingMode::Sphere, true, rate, QTargets::Full, 24, None));
    let (mis, rows_mis) = mean_fraction(&exp1_table(GuidingMode::Sphere, true, rate, QTargets::Mis, 24, None));
    let (without_nee, rows_without) =
        mean_fraction(&exp1_table(GuidingMode::Sphere, false, rate, QTargets::Mis, 24, None));
    eprintln!(
        "mean fraction of {rows} / {rows_mis} / {rows_without} learned rows: NEE on, full targets {full:.3}; \
         NEE on, MIS targets {mis:.3}; NEE off {without_nee:.3}"
    );
    // Only the rows that guided vertices of recording paths read are built
    // (`QTable::rows_read`): 337 here, of more than 1000 whose cells learned.
    assert!(rows > 300 && rows_mis > 300 && rows_without > 300, "learned rows: {rows}, {rows_mis}, {rows_without}");
    assert!(full < 0.4, "with NEE and full targets the mean fraction is {full}");
    assert!(mis > 0.55, "with NEE and MIS-weighted targets the mean fraction is {mis}");
    assert!(without_nee > 0.65, "without NEE the mean fraction is {without_nee}");
}

/// `learn.comp` learns the fractions as `QTable::learn` does: each row's fraction
/// is its cell's (from the cell's state) times the cell's evidence weight where
/// the row is learned, 0 where not;
/// and the GPU's cells, tracing the same paths up to rounding, end where the
/// CPU's do. Adam's steps are nearly the gradient's sign while it keeps its
/// sign, so the two agree exactly but where a cell's mean gradient is near 0.
/// Likewise Q, folded with `batch_rate`, at the running mean's rate and at a
/// polynomial one. (`exp1_table` also checks `GpuRenderer::cell_fractions` and
/// `cell_values`, the viewer's reads.)
#[test]
fn gpu_learns_the_fractions_and_values_the_cpu_learns() {
    let ctx = gpu();
    for (rate, targets) in [(DEFAULT_RATE_EXPONENT, QTargets::Mis), (0.75, QTargets::Full)] {
        let gpu_table = exp1_table(GuidingMode::Octant, true, rate, targets, 24, Some(&ctx));
        let cpu_table = exp1_table(GuidingMode::Octant, true, rate, targets, 24, None);
        assert_gpu_learns_what_the_cpu_learns(&gpu_table, &cpu_table, rate);
    }
    assert_no_validation_messages(&ctx);
}

fn assert_gpu_learns_what_the_cpu_learns(gpu_table: &QTable, cpu_table: &QTable, rate: f32) {
    let classes = NORMAL_CLASSES as usize;
    let n = Bins::OCTANT.count() as usize;
    for (i, &f) in gpu_table.fractions.iter().enumerate() {
        let row = &gpu_table.rows[i * n..(i + 1) * n];
        let cell = i / classes;
        let targets: f32 = gpu_table.visits[cell * n..(cell + 1) * n].iter().map(|&v| v as f32).sum();
        let want = if learned(row) {
            gpu_table.fraction_states[cell].fraction(0.5) * evidence_weight(targets, n as u32)
        } else {
            0.0
        };
        assert!((f - want).abs() < 1e-6, "row {i}: fraction {f}, its cell's state and evidence say {want}");
    }
    let (cpu_mean, _) = mean_fraction(cpu_table);
    assert!((cpu_mean - 0.5).abs() > 0.05, "rate {rate}: the CPU's fractions did not move from 0.5: mean {cpu_mean}");
    let (mut compared, mut far, mut sum) = (0, 0, 0.0f64);
    for (g, c) in gpu_table.fraction_states.iter().zip(&cpu_table.fraction_states) {
        if g.steps > 0.0 && c.steps > 0.0 {
            let d = (g.fraction(0.5) - c.fraction(0.5)).abs() as f64;
            compared += 1;
            sum += d;
            far += (d > 0.1) as usize;
        }
    }
    let mean = sum / compared.max(1) as f64;
    eprintln!("rate {rate}: cells compared {compared}, mean |difference| {mean:.4}, over 0.1: {far}");
    assert!(compared > 100, "rate {rate}: cells that learned on both: {compared}");
    assert!(
        mean < 0.03 && far * 20 < compared,
        "rate {rate}: mean |difference| {mean}, {far} of {compared} differ by over 0.1"
    );
    // Entries that took the same number of targets on both hold the same values,
    // up to the rounding of sums taken in another order and of the GPU's pow and exp.
    assert!(cpu_table.visits.iter().any(|&v| v > 0), "the CPU learned nothing");
    let (mut same_visits, mut rel_sum, mut worst) = (0usize, 0.0f64, 0.0f64);
    for i in 0..cpu_table.q.len() {
        let (vg, vc) = (gpu_table.visits[i], cpu_table.visits[i]);
        if vg == vc && vc > 0 {
            let (qg, qc) = (gpu_table.q[i] as f64, cpu_table.q[i] as f64);
            let rel = (qg - qc).abs() / qc.abs().max(1e-3);
            same_visits += 1;
            rel_sum += rel;
            worst = worst.max(rel);
        }
    }
    // The same rows were read, but for paths that rounding sent elsewhere.
    let both = gpu_table.rows_read.iter().zip(&cpu_table.rows_read).filter(|(&g, &c)| g && c).count();
    let either = gpu_table.rows_read.iter().zip(&cpu_table.rows_read).filter(|(&g, &c)| g || c).count();
    assert!(both > 0 && both * 50 >= either * 49, "rate {rate}: rows read by both {both}, by either {either}");
    let nonzero = cpu_table.visits.iter().filter(|&&v| v > 0).count();
    let rel_mean = rel_sum / same_visits.max(1) as f64;
    eprintln!("rate {rate}: Q entries with the same visits {same_visits} of {nonzero}, relative difference mean {rel_mean:.2e}, worst {worst:.2e}");
    assert!(
        same_visits * 2 > nonzero,
        "rate {rate}: only {same_visits} of {nonzero} entries took as many targets on both"
    );
    assert!(rel_mean < 1e-3, "rate {rate}: GPU and CPU Q differ by {rel_mean} on average (worst {worst})");
}

/// Seed-exp1 at 48x32, sphere guiding, NEE on, `targets`: the CPU renderer's
/// tables after each of `frames` (ascending) frames.
fn exp1_tables(targets: QTargets, frames: &[u32]) -> (PreparedScene, Vec<QTable>) {
    let scene = scene("seed-exp1.toml");
    let mut o = guided(&options(&scene, 48, 32, 64), GuidingMode::Sphere);
    (o.q_targets, o.seed) = (targets, 5);
    o.learning_period = Some(1); // once per recording cycle, as exp1_table

    let prepared = PreparedScene::new(&scene, &o).expect("valid options");
    let mut r = CpuRenderer::new(&prepared);
    let (mut done, mut tables) = (0, Vec::new());
    for &f in frames {
        while done < f {
            r.render_frame();
            done += 1;
        }
        tables.push(r.table().unwrap().clone());
    }
    (prepared, tables)
}

/// What the paths of every pixel of `o` (16 each) record through `table`
/// ([`trace_recording_paths`]): (key, target bits) per target, (cell | 1 << 31,
/// bits) per fraction gradient, in path order, and each path's radiance.
fn recorded(scene: &Scene, o: &RenderOptions, table: &QTable) -> (Vec<(u32, u32)>, Vec<[u32; 3]>) {
    let paths = trace_recording_paths(scene, o, table, || LogTargets(Vec::new()));
    let radiance = paths.iter().map(|(l, _, _)| *l).collect();
    (paths.into_iter().flat_map(|(_, _, log)| log.0).collect(), radiance)
}

/// Logs what paths record (see `recorded`).
struct LogTargets(Vec<(u32, u32)>);

impl Recorder for LogTargets {
    fn target(&mut self, key: u32, target: f32) {
        self.0.push((key, target.to_bits()));
    }
    fn fraction_gradient(&mut self, cell: u32, gradient: f32) {
        self.0.push((cell | 1 << 31, gradient.to_bits()));
    }
    fn row_read(&mut self, _: usize) {}
}

/// The targets change what is learned, never a path's estimate. Without NEE there
/// is no light sampling to share the light with: the MIS-weighted targets are Dahm
/// & Keller's, bit for bit. With NEE they differ (the light a ray meets is counted
/// as the image counts it), while every path's radiance stays the same.
#[test]
fn mis_targets_are_the_full_ones_without_nee() {
    let scene = scene("seed-exp1.toml");
    for nee in [false, true] {
        let mut o = guided(&options(&scene, 12, 8, 64), GuidingMode::Sphere);
        (o.nee, o.seed, o.q_targets) = (nee, 9, QTargets::Full);
        let table = cpu_table(&scene, &o);
        let (full, full_radiance) = recorded(&scene, &o, &table);
        o.q_targets = QTargets::Mis;
        let (mis, mis_radiance) = recorded(&scene, &o, &table);
        assert!(full.len() > 1000, "NEE {nee}: {} records", full.len());
        assert_eq!(full_radiance, mis_radiance, "NEE {nee}: the paths' radiance");
        assert_eq!(full.len(), mis.len(), "NEE {nee}: as many records");
        let keys_differ = full.iter().zip(&mis).filter(|(a, b)| a.0 != b.0).count();
        assert_eq!(keys_differ, 0, "NEE {nee}: the same keys");
        let differ = full.iter().zip(&mis).filter(|(a, b)| a.1 != b.1).count();
        eprintln!("NEE {nee}: {differ} of {} records differ", full.len());
        if nee {
            assert!(differ * 4 > full.len(), "with NEE only {differ} of {} records differ", full.len());
        } else {
            assert_eq!(differ, 0, "without NEE {differ} of {} records differ", full.len());
        }
    }
}

/// With NEE the MIS-weighted targets learn Dahm & Keller's values but for the
/// emission a ray meets directly, of which they keep the share MIS gives the
/// BSDF and guided directions. Entries whose bin looks at the lamp from the
/// cell's centre hold a small part of what full targets hold (0.02 here). Entries
/// whose bin sees no light from anywhere in the cell hold the same at
/// convergence, the light sample at the vertex met standing in for the lamp that
/// Q there no longer holds in full. They converge from above: the light sample is
/// an unbiased estimate from the first frame, while full targets take the lamp
/// from Q entries that learn it over many visits, and the running mean keeps
/// their early low targets for long. MIS over full on those entries, seed 5, with
/// the exploration floor at 0.5: 1.38 after 8 frames, 1.29 after 24,
/// 1.16 after 96, 1.10 after 256; without the light sample's term, 0.06. At the
/// floor of 0.25: 1.40 and 1.31 after 8 and 24 frames; at 0.1 (the default)
/// 1.41 and 1.33, towards the lamp 0.027.
#[test]
fn mis_targets_leave_the_lamp_to_light_sampling() {
    let frames = [8, 24];
    let (prepared, full) = exp1_tables(QTargets::Full, &frames);
    let (_, mis) = exp1_tables(QTargets::Mis, &frames);
    let cfg = prepared.guide.expect("guiding");
    let bins = cfg.bins.count();
    let inv = cfg.grid.inv_cell_size();
    let [rx, ry, _] = cfg.grid.res;
    // The entries towards the lamp (the bin's centre direction from the cell's
    // centre meets it) and those whose bin sees no light from anywhere in the cell
    // (a 4x4 grid of directions from 8 points).
    let (mut lamp, mut clear) = (Vec::new(), Vec::new());
    for cell in 0..cfg.grid.cells() {
        let (x, y, z) = (cell % rx, (cell / rx) % ry, cell / (rx * ry));
        let centre = cfg.grid.min + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) / inv;
        for b in 0..bins {
            let meets = |o: Vec3, u: [f32; 2]| rlpt::math::geometry::meets_light(&prepared, o, cfg.bins.sample(b, u));
            let i = (cell * bins + b) as usize;
            if meets(centre, [0.5, 0.5]) {
                lamp.push(i);
                continue;
            }
            let cell_size = Vec3::ONE / inv;
            let sees_none = (0..8).all(|k| {
                let at = |bit: u32| if k & bit != 0 { 0.25 } else { -0.25 };
                let o = centre + Vec3::new(at(1), at(2), at(4)) * cell_size;
                (0..16).all(|j| !meets(o, [(j % 4) as f32 / 4.0 + 0.125, (j / 4) as f32 / 4.0 + 0.125]))
            });
            if sees_none {
                clear.push(i);
            }
        }
    }
    // Sums of Q over the entries both tables visited often: MIS over full.
    let ratio = |entries: &[usize], k: usize| {
        let (mut f, mut m, mut n) = (0.0f64, 0.0f64, 0);
        for &i in entries.iter().filter(|&&i| full[k].visits[i] >= 64 && mis[k].visits[i] >= 64) {
            (f, m, n) = (f + full[k].q[i] as f64, m + mis[k].q[i] as f64, n + 1);
        }
        (m / f, n)
    };
    let (lamp_ratio, lamp_n) = ratio(&lamp, 1);
    let (early, _) = ratio(&clear, 0);
    let (clear_ratio, clear_n) = ratio(&clear, 1);
    eprintln!(
        "Q with MIS-weighted over full targets: {lamp_n} entries towards the lamp {lamp_ratio:.3}; \
         {clear_n} entries that see no light {clear_ratio:.3} ({early:.3} after {} frames)",
        frames[0]
    );
    assert!(lamp_n >= 50 && clear_n >= 2000, "entries compared: {lamp_n} towards the lamp, {clear_n} seeing none");
    assert!(lamp_ratio < 0.2, "towards the lamp MIS-weighted Q is {lamp_ratio:.3} of the full");
    assert!(
        (1.0..1.5).contains(&clear_ratio) && clear_ratio < early,
        "where no light is seen MIS-weighted Q is {clear_ratio:.3} of the full ({early:.3} earlier): \
         not converging from above"
    );
}
