//! The GLSL BVH walk (glsl/bvh.glsl, through glsl/probe_bvh.comp) against its
//! Rust twin (src/math/bvh.rs), which tests/bvh.rs holds to brute force: the
//! same nearest primitive at the same distance, and the same occlusion verdicts,
//! on 64k rays through the bunny and through a mixed scene.

mod bvh_support;
mod common;

use bvh_support::*;
use rlpt::gpu::{shader, Binding, Buffer, BufferUsage, Pipeline};
use rlpt::layout::SceneArrays;
use rlpt::math::bvh::{closest_hit, occluded};
use rlpt::math::rng::Rng;
use rlpt::shared;

/// glsl/probe_bvh.comp `ProbeRay`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ProbeRay {
    o: [f32; 3],
    t_max: f32,
    d: [f32; 3],
    skip: u32,
}

/// Per ray: the closest hit's t (bits) and reference, and the occlusion verdict.
fn run_probe(ctx: &common::Gpu, s: &SceneArrays, rays: &[ProbeRay]) -> Vec<[u32; 4]> {
    let data = |name: &str, bytes: &[u8]| Buffer::with_data(ctx, name, bytes, false).unwrap();
    let bufs = [
        data("spheres", bytemuck::cast_slice(&s.spheres)),
        data("quads", bytemuck::cast_slice(&s.quads)),
        data("triangles", bytemuck::cast_slice(&s.triangles)),
        data("bvh nodes", bytemuck::cast_slice(&s.bvh_nodes)),
        data("prim refs", bytemuck::cast_slice(&s.prim_refs)),
        data("probe rays", bytemuck::cast_slice(rays)),
    ];
    let out = Buffer::new(ctx, "probe results", 16 * rays.len() as u64, BufferUsage::Storage).unwrap();
    let bindings: Vec<(u32, Binding)> = [
        shared::BINDING_SPHERES,
        shared::BINDING_QUADS,
        shared::BINDING_TRIANGLES,
        shared::BINDING_BVH_NODES,
        shared::BINDING_PRIM_REFS,
        20,
        21,
    ]
    .map(|b| (b, Binding::Storage))
    .to_vec();
    let p = Pipeline::new_with_numbers(ctx, "probe_bvh", shader("probe_bvh"), &bindings, 4).unwrap();
    p.bind(&[&bufs[0], &bufs[1], &bufs[2], &bufs[3], &bufs[4], &bufs[5], &out]);
    let count = rays.len() as u32;
    ctx.run_commands("probe bvh", |cmd| p.cmd_dispatch(cmd, [count.div_ceil(64), 1, 1], bytemuck::bytes_of(&count)))
        .unwrap();
    bytemuck::pod_collect_to_vec(&common::readback(ctx, &out))
}

/// What a scene's comparison found.
#[derive(Debug, Default)]
struct Tally {
    hits: usize,
    /// Nearest hits on two primitives at the same distance, GPU and CPU taking different ones.
    ties: usize,
    blocked: usize,
    /// Verdicts that differ where a primitive lies within rounding of the segment's end.
    end_ties: usize,
    max_rel_t: f32,
}

/// 64k rays (bundles of 512 from one origin, as tests/bvh.rs makes them) on the
/// GPU and the CPU. Occlusion: half the rays that hit end on their hit and skip
/// its primitive (a shadow ray to a light point), the rest are segments of
/// random length.
fn compare(ctx: &common::Gpu, s: &SceneArrays, angle: f64, seed: u32) -> Tally {
    let (lo, hi) = bounds(s);
    let size = (hi - lo).length();
    let mut rng = Rng::new(seed, 1, 0, 0);
    let mut rays = Vec::new();
    for b in bundles(s, 128, 512, angle, seed) {
        for d in b.rays {
            let (t_max, skip) = match closest_hit(s, b.origin, d, f32::INFINITY) {
                Some((t, r)) if rng.next_f32() < 0.5 => (t, r),
                Some((t, _)) => (2.0 * t * rng.next_f32(), shared::NO_PRIM),
                None => (size * rng.next_f32(), shared::NO_PRIM),
            };
            rays.push(ProbeRay { o: b.origin.into(), t_max, d: d.into(), skip });
        }
    }
    let got = run_probe(ctx, s, &rays);
    let mut tally = Tally::default();
    for (r, g) in rays.iter().zip(&got) {
        let (o, d) = (r.o.into(), r.d.into());
        let gpu = (g[1] != shared::NO_PRIM).then(|| (f32::from_bits(g[0]), g[1]));
        match (gpu, closest_hit(s, o, d, f32::INFINITY)) {
            (None, None) => {}
            (Some((tg, rg)), Some((tc, rc))) => {
                tally.hits += 1;
                let rel = (tg - tc).abs() / tc;
                tally.max_rel_t = tally.max_rel_t.max(rel);
                assert!(rel <= 1e-5, "ray {o} {d}: t {tg} on the GPU, {tc} on the CPU");
                if rg != rc {
                    let t_other = prim_t(s, rg, o, d, f32::INFINITY);
                    assert!(
                        t_other.is_some_and(|t| (t - tc).abs() <= 1e-5 * tc),
                        "ray {o} {d}: primitive {rg:#x} on the GPU (the CPU puts it at {t_other:?}), {rc:#x} at {tc} on the CPU"
                    );
                    tally.ties += 1;
                }
            }
            (gpu, cpu) => panic!("ray {o} {d}: GPU {gpu:?}, CPU {cpu:?}"),
        }
        let blocked = g[2] != 0;
        tally.blocked += blocked as usize;
        if blocked != occluded(s, o, d, r.t_max, r.skip) {
            // Allowed only where the verdict turns within rounding of the end.
            let near = occluded(s, o, d, r.t_max * (1.0 - 1e-5), r.skip);
            let far = occluded(s, o, d, r.t_max * (1.0 + 1e-5), r.skip);
            assert!(near != far, "ray {o} {d}, t_max {}, skip {:#x}: GPU says blocked {blocked}", r.t_max, r.skip);
            tally.end_ties += 1;
        }
    }
    tally
}

#[test]
fn glsl_bvh_walk_matches_the_rust_twin() {
    let ctx = common::gpu();
    for (name, s, angle) in [("bunny", bunny(), 0.01), ("mixed", mixed(), 0.03)] {
        let tally = compare(&ctx, &s, angle, 7);
        eprintln!("{name}: {tally:?}");
        assert!(tally.hits > 10_000 && tally.blocked > 2000, "{name}: {tally:?}");
        assert!(tally.ties + tally.end_ties < 10, "{name}: {tally:?}");
    }
    common::assert_no_validation_messages(&ctx);
}
