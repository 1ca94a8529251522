//! Learned fields saved and loaded (`--guide-out`, `--guide-in`, `guide::GuideField`):
//! a field loads as the table it was, on the CPU and the GPU; a field of another
//! scene, other bins, or a damaged file is refused with a sentence naming it.

mod common;

use common::cli::tmp;
use common::*;
use rlpt::cpu::CpuRenderer;
use rlpt::guide::{scene_hash, Bins, GuideField, GuidingMode, QTable};
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;

fn guided(scene: &Scene, width: u32, height: u32) -> RenderOptions {
    let mut o = options(scene, width, height, 64);
    o.guiding = GuidingMode::Sphere;
    o
}

/// door.toml's table after `frames` CPU frames at 40x24, with its field.
fn learned_on_cpu(frames: u32) -> (Scene, RenderOptions, PreparedScene, QTable, GuideField) {
    let scene = scene("door.toml");
    let o = guided(&scene, 40, 24);
    let prepared = PreparedScene::new(&scene, &o).unwrap();
    let mut r = CpuRenderer::new(&prepared);
    for _ in 0..frames {
        r.render_frame();
    }
    let table = r.table().unwrap().clone();
    let field = GuideField::of_table(&table, prepared.guide.as_ref().unwrap(), scene_hash(&prepared));
    (scene, o, prepared, table, field)
}

/// Saved and loaded, a field is the table it was: Q, visits, fraction states and
/// rows read bit for bit, and the sampling rows and fractions rebuilt from them
/// are those the table held (it learned after its last frame).
#[test]
fn a_saved_field_loads_as_the_table_it_was() {
    let (_, o, mut prepared, table, field) = learned_on_cpu(6);
    assert!(table.visits.iter().any(|&v| v > 0), "the table learned nothing");
    let path = tmp("door.qtab");
    field.save(&path).unwrap();
    let loaded = GuideField::load(&path).unwrap();
    assert_eq!(loaded, field);
    prepared.start_from(loaded, &path, &o).unwrap();
    let fresh = CpuRenderer::new(&prepared);
    let t = fresh.table().unwrap();
    assert_eq!(
        (&t.q, &t.visits, &t.fraction_states, &t.rows_read),
        (&table.q, &table.visits, &table.fraction_states, &table.rows_read)
    );
    assert_eq!(t.rows, table.rows);
    assert_eq!(t.fractions, table.fractions);
    assert!(t.fractions.iter().any(|&f| f > 0.0), "a loaded table guides from its first frame");
    assert_eq!(prepared.guide.unwrap().learning_frames, 0, "a loaded field needs no learning frames");
}

/// The GPU loads a field as the CPU does: the table read back holds its values,
/// and its rows are built where the CPU's are, with the same fractions.
#[test]
fn the_gpu_loads_the_field_the_cpu_loads() {
    let (_, o, mut prepared, table, field) = learned_on_cpu(6);
    let path = tmp("door-gpu.qtab");
    prepared.start_from(field, &path, &o).unwrap();
    let ctx = gpu();
    let r = GpuRenderer::new(&ctx, &prepared).unwrap();
    let t = r.table().unwrap().unwrap();
    assert_eq!(
        (&t.q, &t.visits, &t.fraction_states, &t.rows_read),
        (&table.q, &table.visits, &table.fraction_states, &table.rows_read)
    );
    let built = |t: &QTable| t.fractions.iter().map(|&f| f > 0.0).collect::<Vec<_>>();
    assert_eq!(built(&t), built(&table), "rows built on the GPU and the CPU");
    for (i, (g, c)) in t.fractions.iter().zip(&table.fractions).enumerate() {
        assert!((g - c).abs() < 1e-6, "row {i}: GPU fraction {g}, CPU {c}");
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// The scene hash follows what light transport depends on: the same for
/// another image size and camera, another for another material.
#[test]
fn the_scene_hash_follows_geometry_and_materials_not_the_view() {
    let scene0 = scene("door.toml");
    let hash = |s: &Scene, w, h| scene_hash(&PreparedScene::new(s, &guided(s, w, h)).unwrap());
    let h0 = hash(&scene0, 40, 24);
    assert_eq!(h0, hash(&scene0, 64, 40));
    let mut moved = scene0.clone();
    moved.camera.position += rlpt::math::Vec3::new(0.1, 0.0, 0.0);
    assert_eq!(h0, hash(&moved, 40, 24));
    let mut other = scene0.clone();
    other.materials[0].albedo *= 0.5;
    assert_ne!(h0, hash(&other, 40, 24));
}

/// A field of another scene, of other bins, a file that is not one, of another
/// version, cut short, with bytes after its table, or with a Q that is not a
/// radiance: each refused in one sentence naming the file.
#[test]
fn fields_that_do_not_fit_are_refused_with_the_reason() {
    let (_, o, prepared, _, field) = learned_on_cpu(2);
    let path = tmp("refused.qtab");
    field.save(&path).unwrap();
    let name = path.display().to_string();
    let bytes = std::fs::read(&path).unwrap();

    let smallpt = scene("smallpt.toml");
    let mut other = PreparedScene::new(&smallpt, &guided(&smallpt, 40, 24)).unwrap();
    let e = other.start_from(GuideField::load(&path).unwrap(), &path, &o).unwrap_err().to_string();
    assert!(e.contains(&name) && e.contains("another scene"), "{e}");

    let door = scene("door.toml");
    let mut o8 = guided(&door, 40, 24);
    o8.bins = Some(Bins { rows: 8, cols: 16 });
    let mut coarse = PreparedScene::new(&door, &o8).unwrap();
    let e = coarse.start_from(GuideField::load(&path).unwrap(), &path, &o8).unwrap_err().to_string();
    assert!(e.contains(&name) && e.contains("20x40 bins") && e.contains("8x16"), "{e}");

    let mut off = PreparedScene::new(&door, &options(&door, 40, 24, 64)).unwrap();
    let e = off.start_from(GuideField::load(&path).unwrap(), &path, &o).unwrap_err().to_string();
    assert!(e.contains("needs guiding on"), "{e}");

    let damaged = |what: &str, b: Vec<u8>, want: &str| {
        let p = tmp(&format!("{what}.qtab"));
        std::fs::write(&p, b).unwrap();
        let e = GuideField::load(&p).unwrap_err().to_string();
        assert!(e.contains(&p.display().to_string()) && e.contains(want), "{what}: {e}");
    };
    let mut magic = bytes.clone();
    magic[0] = b'X';
    damaged("magic", magic, "not an rlpt learned field");
    let mut version = bytes.clone();
    version[8] = 9;
    damaged("version", version, "format version 9");
    damaged("short", bytes[..bytes.len() - 5].to_vec(), "cut short");
    damaged("header", bytes[..30].to_vec(), "cut short");
    let mut long = bytes.clone();
    long.extend_from_slice(&[0, 0, 0]);
    damaged("long", long, "3 bytes after the table");
    let mut nan = bytes.clone();
    let q0 = 8 + 4 + 8 + 24 + 28;
    nan[q0..q0 + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    damaged("nan", nan, "Q entry 0 is NaN");
    // The cells in use beyond the table's; a tree node whose children lie outside those in use.
    let mut used = bytes.clone();
    used[q0 - 4..q0].copy_from_slice(&(field.grid.capacity + 1).to_le_bytes());
    damaged("used", used, "table shape");
    let mut node = bytes.clone();
    let last_node = bytes.len() - 16;
    node[last_node..last_node + 4].copy_from_slice(&field.grid.capacity.to_le_bytes());
    damaged("node", node, "points outside the");
    let e = GuideField::load(&tmp("missing.qtab")).unwrap_err().to_string();
    assert!(e.contains("cannot read the learned field") && e.contains("missing.qtab"), "{e}");
    drop(prepared);
}

/// The targets recorded after the table last learned reach it when the render
/// asks (`Renderer::learn_pending`, which `--guide-out` calls before saving): a
/// 40x24 door learns after its first 8 frames and then once in 128, so after 12
/// frames the targets recorded since frame 8 wait; the pass folds them in (more visits,
/// Q moved), and a second pass finds nothing left. On the CPU and the GPU.
#[test]
fn a_saved_field_holds_the_targets_after_the_last_pass() {
    let scene = scene("door.toml");
    let prepared = PreparedScene::new(&scene, &guided(&scene, 40, 24)).unwrap();
    let visits = |t: &QTable| t.visits.iter().map(|&v| v as u64).sum::<u64>();
    let check = |what: &str, before: QTable, after: QTable, again: QTable| {
        assert!(visits(&after) > visits(&before), "{what}: no pending target was folded in");
        assert!(after.q != before.q, "{what}: Q did not move");
        assert_eq!(visits(&again), visits(&after), "{what}: a second pass found targets");
        assert!(again.q == after.q, "{what}: a second pass moved Q");
    };
    let mut cpu = CpuRenderer::new(&prepared);
    for _ in 0..12 {
        cpu.render_frame();
    }
    let before = cpu.table().unwrap().clone();
    cpu.learn_pending();
    let after = cpu.table().unwrap().clone();
    cpu.learn_pending();
    check("CPU", before, after, cpu.table().unwrap().clone());
    let ctx = gpu();
    let mut r = GpuRenderer::new(&ctx, &prepared).unwrap();
    r.render_frames(12).unwrap();
    let before = r.table().unwrap().unwrap();
    r.learn_pending().unwrap();
    let after = r.table().unwrap().unwrap();
    r.learn_pending().unwrap();
    check("GPU", before, after, r.table().unwrap().unwrap());
    assert_no_validation_messages(&ctx);
}
