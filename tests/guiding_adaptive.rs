//! The adaptive grid (`--guide-grid adaptive`, src/guide/tree.rs): the GPU splits
//! the cells the CPU splits, renders split cells as the CPU does, and the image
//! stays unbiased.

mod common;

use common::*;
use rlpt::cpu::CpuRenderer;
use rlpt::guide::{scene_hash, split_targets, Bins, GuideField, GuidingMode, QTable};
use rlpt::math::rng::Rng;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::GridKind;
use rlpt::scene::Scene;

fn adaptive(scene: &Scene, width: u32, height: u32, spp: u32) -> RenderOptions {
    let mut o = options(scene, width, height, spp);
    o.guiding = GuidingMode::Sphere;
    o.bins = Some(Bins { rows: 8, cols: 16 });
    o.guide_grid = Some(GridKind::Adaptive);
    o
}

/// Every child a node names lies among the cells in use, after the grid's own.
fn assert_tree_valid(t: &QTable, roots: u32, what: &str) {
    for (i, n) in t.nodes.iter().enumerate() {
        if n.first_child != 0 {
            assert!(n.first_child >= roots && n.first_child + 8 <= t.used_cells, "{what}: cell {i}: {n:?}");
        }
    }
}

/// A table of made-up values loaded into the GPU and the CPU: the learning pass
/// that builds its rows splits the same cells on both, in the same order, the
/// children starting from the same values, until the table is full (more of the
/// grid's cells have learned enough than it has room for).
#[test]
fn the_gpu_splits_the_cells_the_cpu_splits() {
    let scene = scene("door.toml");
    let o = adaptive(&scene, 32, 24, 64);
    let prepared = PreparedScene::new(&scene, &o).unwrap();
    let cfg = *prepared.guide.as_ref().unwrap();
    let roots = cfg.grid.cells();
    assert!(cfg.grid.adaptive() && cfg.cells() > roots);
    let room = (cfg.cells() - roots) / 8;
    assert!(roots - roots.div_ceil(7) > room, "more cells want to split than fit: {roots} roots, room for {room}");

    let mut t = QTable::new(&cfg);
    let mut rng = Rng::new(11, 0, 0, 0);
    for (q, v) in t.q.iter_mut().zip(&mut t.visits) {
        *q = rng.next_f32() * 2.0;
        *v = (rng.next_f32() * 300.0) as u32;
    }
    for r in t.rows_read.iter_mut() {
        *r = rng.next_f32() < 0.5;
    }
    let enough = split_targets(cfg.bins.count());
    for (cell, n) in t.nodes.iter_mut().enumerate().take(roots as usize) {
        // Every seventh root just short of the threshold; the others past it.
        n.targets = if cell % 7 == 0 { enough - 1.0 } else { enough * (1.0 + rng.next_f32()) };
    }
    let field = GuideField::of_table(&t, &cfg, scene_hash(&prepared));

    let cpu = field.table(&cfg);
    assert_eq!(cpu.used_cells, roots + 8 * room, "the table filled up");
    assert_tree_valid(&cpu, roots, "CPU");

    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("adaptive-made-up.qtab");
    let mut loaded = prepared.clone();
    loaded.start_from(field, &path, &o).unwrap();
    let ctx = gpu();
    let r = GpuRenderer::new(&ctx, &loaded).unwrap();
    let gpu_table = r.table().unwrap().unwrap();
    assert_eq!(gpu_table.used_cells, cpu.used_cells);
    assert_eq!(gpu_table.nodes, cpu.nodes, "the same cells split, into the same children");
    assert_eq!(
        (&gpu_table.q, &gpu_table.visits, &gpu_table.fraction_states, &gpu_table.rows_read),
        (&cpu.q, &cpu.visits, &cpu.fraction_states, &cpu.rows_read)
    );
    let built = |t: &QTable| t.fractions.iter().map(|&f| f > 0.0).collect::<Vec<_>>();
    assert_eq!(built(&gpu_table), built(&cpu), "rows built on the GPU and the CPU");
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// door.toml guided on an adaptive grid: within the render the cells where
/// paths gather split (on the GPU and the CPU), and the guided images agree
/// with an unguided one within noise.
#[test]
fn an_adaptive_render_splits_cells_and_stays_unbiased() {
    let scene = scene("door.toml");
    let o = adaptive(&scene, 40, 24, 64 * 24);
    let prepared = PreparedScene::new(&scene, &o).unwrap();
    let roots = prepared.guide.as_ref().unwrap().grid.cells();
    let ctx = gpu();
    let mut r = GpuRenderer::new(&ctx, &prepared).unwrap();
    r.render_frames(o.frames()).unwrap();
    let guided_gpu = r.film().unwrap();
    let t = r.table().unwrap().unwrap();
    assert!(t.used_cells > roots, "no cell split on the GPU in {} frames", o.frames());
    assert_tree_valid(&t, roots, "GPU");
    drop(r);
    assert_no_validation_messages(&ctx);

    let mut c = CpuRenderer::new(&prepared);
    for _ in 0..o.frames() {
        c.render_frame();
    }
    let t = c.table().unwrap();
    assert!(t.used_cells > roots, "no cell split on the CPU in {} frames", o.frames());
    assert_tree_valid(t, roots, "CPU");

    let mut plain = o.clone();
    plain.guiding = GuidingMode::Off;
    plain.seed = 9;
    let unguided = render_gpu(&ctx, &scene, &plain);
    let z = assert_films_agree(&guided_gpu, &unguided, 4, K, "adaptive guided GPU vs unguided");
    eprintln!("GPU: worst block {z:.2} sigma");
    let z = assert_films_agree(c.film(), &unguided, 4, K, "adaptive guided CPU vs unguided");
    eprintln!("CPU: worst block {z:.2} sigma");
}
