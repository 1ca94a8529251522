//! Helpers of the guiding tests (`tests/guiding_*.rs`).

use rlpt::camera::camera_ray;
use rlpt::cpu::{trace_path, CpuRenderer, Guide};
use rlpt::guide::{AliasBin, GuidingMode, QTable, Recorder};
use rlpt::math::sampler::PathSampler;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;

/// `opts` guided by `mode`.
pub fn guided(opts: &RenderOptions, mode: GuidingMode) -> RenderOptions {
    let mut o = opts.clone();
    o.guiding = mode;
    o
}

/// The table a guided CPU render has learned after 4 frames.
pub fn cpu_table(scene: &Scene, o: &RenderOptions) -> QTable {
    let mut cpu = CpuRenderer::new(&PreparedScene::new(scene, o).expect("valid options"));
    for _ in 0..4 {
        cpu.render_frame();
    }
    cpu.table().expect("guided renderer has a table").clone()
}

/// The paths of every pixel of `o` (16 each) traced one by one on the CPU
/// through `table`, with the same random numbers on every call, each recording
/// into a recorder of its own from `recorder`: (radiance bits, rays, recorder).
pub fn trace_recording_paths<R: Recorder>(
    scene: &Scene,
    o: &RenderOptions,
    table: &QTable,
    mut recorder: impl FnMut() -> R,
) -> Vec<([u32; 3], u32, R)> {
    let prepared = PreparedScene::new(scene, o).expect("valid options");
    let cfg = prepared.guide.expect("guided");
    let g = Guide::new(&cfg, table);
    let mut out = Vec::new();
    for pixel in 0..o.width * o.height {
        for sample in 0..16 {
            let mut rng = PathSampler::for_flags(prepared.params.flags, o.seed, pixel, 4, sample);
            let (ro, rd) = camera_ray(
                &prepared.params,
                pixel % o.width,
                pixel / o.width,
                rng.sample_2d(rlpt::shared::SAMPLE_CAMERA),
            );
            let mut r = recorder();
            let (l, segments) = trace_path(&prepared, Some(g), ro, rd, &mut rng, 0.0, Some(&mut r));
            out.push((l.to_array().map(f32::to_bits), segments, r));
        }
    }
    out
}

/// The probability of each bin under a row's alias table, counted from the
/// columns themselves (not from the densities the row stores).
pub fn alias_probabilities(row: &[AliasBin]) -> Vec<f64> {
    let n = row.len();
    let mut p = vec![0.0f64; n];
    for (i, e) in row.iter().enumerate() {
        let t = (e.column >> 16) as f64 / 65535.0;
        p[i] += t / n as f64;
        p[(e.column & 0xffff) as usize] += (1.0 - t) / n as f64;
    }
    p
}
