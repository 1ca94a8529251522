//! Probe kernels: the subgroup reduction, the GPU/host struct layout, and the
//! GLSL BSDFs against their Rust twins (and a chi-square test of the GLSL sampler).

mod common;

use common::readback;
use rlpt::gpu::{shader, Binding, Buffer, BufferUsage, Pipeline, PIPELINE_CACHE_SIZE};
use rlpt::layout::{
    GpuBvhNode, GpuLight, GpuMaterial, GpuQuad, GpuSphere, GpuTriangle, GpuTriangleNormals, RenderParams,
};
use rlpt::math::bsdf::{bsdf_eval, bsdf_pdf, bsdf_sample, Bsdf};
use rlpt::math::rng::Rng;
use rlpt::math::Vec3;
use rlpt::scene::MaterialKind;
use rlpt::shared;
use rlpt_chi2::{chi2_sphere, sidak, Chi2Options, Zoom};

#[test]
fn reduction_sums_64_samples_exactly_on_this_subgroup_size() {
    let ctx = common::gpu();
    let groups = 37u32;
    let group_size = shared::SAMPLES_PER_FRAME * shared::PIXELS_PER_GROUP;
    // Small integers and halves: every partial sum is exact in f32, whatever the order.
    let values: Vec<[f32; 4]> = (0..groups * group_size)
        .map(|i| {
            let h = rlpt::math::rng::pcg_hash(i);
            [(h % 1000) as f32, ((h >> 10) % 512) as f32 * 0.5, -(((h >> 20) % 100) as f32), ((h >> 27) % 32) as f32]
        })
        .collect();
    let input = Buffer::with_data(&ctx, "reduce inputs", bytemuck::cast_slice(&values), false).unwrap();
    let pixels = (groups * shared::PIXELS_PER_GROUP) as u64;
    let sums = Buffer::new(&ctx, "reduce sums", pixels * 16, BufferUsage::Storage).unwrap();
    let info = Buffer::new(&ctx, "reduce info", 16, BufferUsage::Storage).unwrap();
    let p = Pipeline::new(&ctx, "probe_reduce", shader("probe_reduce"), &[Binding::Storage; 3], 0).unwrap();
    p.bind(&[&input, &sums, &info]);
    ctx.run_commands("probe reduce", |cmd| {
        info.cmd_clear(cmd);
        ctx.barrier(cmd);
        p.cmd_dispatch(cmd, [groups, 1, 1], &[]);
    })
    .unwrap();
    let got: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &sums));
    let info: Vec<u32> = bytemuck::pod_collect_to_vec(&readback(&ctx, &info));
    assert_eq!(info[0], ctx.info.subgroup_size, "kernel and device agree on the subgroup size");
    assert_eq!(info[1], 0, "subgroups are runs of consecutive invocation indices");
    for (px, s) in got.iter().enumerate() {
        let mut want = [0.0f32; 4];
        for v in &values[px * 64..px * 64 + 64] {
            for c in 0..4 {
                want[c] += v[c];
            }
        }
        assert_eq!(&s[..], &want[..], "pixel {px} (subgroup size {})", ctx.info.subgroup_size);
    }
    common::assert_no_validation_messages(&ctx);
}

#[test]
fn struct_layout_matches_the_rust_mirrors() {
    let ctx = common::gpu();
    // Distinct values in every field of element 1 of each array.
    let mut k = 0.0f32;
    let mut next = || {
        k += 1.0;
        k
    };
    let mut v4 = || [next(), next(), next(), next()];
    let mat = GpuMaterial {
        albedo_roughness: v4(),
        emission_ior: v4(),
        eta: v4(),
        k: v4(),
        kind: 101,
        two_sided: 102,
        albedo_texture: 103,
        roughness_texture: 104,
    };
    let sph =
        GpuSphere { center_radius: v4(), anchor_radius: v4(), axis: v4(), material: 201, light: 202, pad: [0; 2] };
    let quad = GpuQuad {
        origin: v4(),
        edge_u: v4(),
        edge_v: v4(),
        normal: v4(),
        dual_u: v4(),
        dual_v: v4(),
        material: 301,
        light: 302,
        pad: [0; 2],
    };
    let light = GpuLight { kind: 401, index: 402, pmf: 0.25, cdf: 0.75 };
    let params = RenderParams {
        cam_position_near: v4(),
        cam_forward_tan: v4(),
        cam_right_aspect: v4(),
        cam_up: v4(),
        environment: v4(),
        width: 501,
        height: 502,
        max_bounces: 503,
        rr_depth: 504,
        num_spheres: 505,
        num_quads: 506,
        num_lights: 507,
        flags: 508,
        seed: 509,
        guide_bins: 510,
        guide_rows: 511,
        guide_cols: 512,
        guide_min: v4(),
        guide_inv_cell: v4(),
        guide_res_x: 513,
        guide_res_y: 514,
        guide_res_z: 515,
        guide_cells: 516,
        guide_floor: 0.125,
        guide_vertices: 517,
        occluding_quads: 518,
        scene_kinds: 519,
        num_triangles: 520,
        bvh_nodes: 521,
        env_width: 522,
        env_height: 523,
        env_frame: [v4(), v4(), v4()],
    };
    let mut v3 = || [next(), next(), next()];
    let tri = GpuTriangle { v0: v3(), material: 601, v1: v3(), light: 602, v2: v3(), normals: 603 };
    let mut v4 = || [next(), next(), next(), next()];
    let normals = GpuTriangleNormals { n: [v4(), v4(), v4()] };
    let mut v4 = || [next(), next(), next(), next()];
    let node = GpuBvhNode {
        lo_x: v4(),
        lo_y: v4(),
        lo_z: v4(),
        hi_x: v4(),
        hi_y: v4(),
        hi_z: v4(),
        child: [701, 702, 703, 704],
        count: [705, 706, 707, 708],
    };
    let bufs = [
        Buffer::with_data(&ctx, "params", bytemuck::bytes_of(&params), true).unwrap(),
        Buffer::with_data(&ctx, "materials", bytemuck::cast_slice(&[GpuMaterial::default(), mat]), false).unwrap(),
        Buffer::with_data(&ctx, "spheres", bytemuck::cast_slice(&[GpuSphere::default(), sph]), false).unwrap(),
        Buffer::with_data(&ctx, "quads", bytemuck::cast_slice(&[GpuQuad::default(), quad]), false).unwrap(),
        Buffer::with_data(&ctx, "lights", bytemuck::cast_slice(&[GpuLight::default(), light]), false).unwrap(),
        Buffer::with_data(&ctx, "triangles", bytemuck::cast_slice(&[GpuTriangle::default(), tri]), false).unwrap(),
        Buffer::with_data(&ctx, "normals", bytemuck::cast_slice(&[GpuTriangleNormals::default(), normals]), false)
            .unwrap(),
        Buffer::with_data(&ctx, "bvh nodes", bytemuck::cast_slice(&[GpuBvhNode::default(), node]), false).unwrap(),
    ];
    let out = Buffer::new(&ctx, "layout out", 4 * 256, BufferUsage::Storage).unwrap();
    let storage = |b: u32| (b, Binding::Storage);
    let p = Pipeline::new_with_numbers(
        &ctx,
        "probe_layout",
        shader("probe_layout"),
        &[
            (shared::BINDING_PARAMS, Binding::Uniform),
            storage(shared::BINDING_MATERIALS),
            storage(shared::BINDING_SPHERES),
            storage(shared::BINDING_QUADS),
            storage(shared::BINDING_LIGHTS),
            storage(5),
            storage(shared::BINDING_TRIANGLES),
            storage(shared::BINDING_TRIANGLE_NORMALS),
            storage(shared::BINDING_BVH_NODES),
        ],
        0,
    )
    .unwrap();
    p.bind(&[&bufs[0], &bufs[1], &bufs[2], &bufs[3], &bufs[4], &out, &bufs[5], &bufs[6], &bufs[7]]);
    ctx.run_commands("probe layout", |cmd| p.cmd_dispatch(cmd, [1, 1, 1], &[])).unwrap();
    let got: Vec<u32> = bytemuck::pod_collect_to_vec(&readback(&ctx, &out));

    let f = |v: [f32; 4]| v.map(f32::to_bits).to_vec();
    let mut want = Vec::new();
    want.extend(f(mat.albedo_roughness));
    want.extend(f(mat.emission_ior));
    want.extend(f(mat.eta));
    want.extend(f(mat.k));
    want.extend([mat.kind, mat.two_sided, mat.albedo_texture, mat.roughness_texture]);
    want.extend(f(sph.center_radius));
    want.extend(f(sph.anchor_radius));
    want.extend(f(sph.axis));
    want.extend([sph.material, sph.light]);
    for v in [quad.origin, quad.edge_u, quad.edge_v, quad.normal, quad.dual_u, quad.dual_v] {
        want.extend(f(v));
    }
    want.extend([quad.material, quad.light]);
    want.extend([light.kind, light.index, light.pmf.to_bits(), light.cdf.to_bits()]);
    for v in
        [params.cam_position_near, params.cam_forward_tan, params.cam_right_aspect, params.cam_up, params.environment]
    {
        want.extend(f(v));
    }
    want.extend([
        params.width,
        params.height,
        params.max_bounces,
        params.rr_depth,
        params.num_spheres,
        params.num_quads,
        params.num_lights,
        params.flags,
        params.seed,
        params.guide_bins,
        params.guide_rows,
        params.guide_cols,
    ]);
    want.extend(f(params.guide_min));
    want.extend(f(params.guide_inv_cell));
    want.extend([
        params.guide_res_x,
        params.guide_res_y,
        params.guide_res_z,
        params.guide_cells,
        params.guide_floor.to_bits(),
        params.guide_vertices,
        params.occluding_quads,
        params.scene_kinds,
        params.num_triangles,
        params.bvh_nodes,
        params.env_width,
        params.env_height,
    ]);
    for v in params.env_frame {
        want.extend(f(v));
    }
    let f3 = |v: [f32; 3]| v.map(f32::to_bits).to_vec();
    for (v, w) in [(tri.v0, tri.material), (tri.v1, tri.light), (tri.v2, tri.normals)] {
        want.extend(f3(v));
        want.push(w);
    }
    for v in normals.n {
        want.extend(f(v));
    }
    for v in [node.lo_x, node.lo_y, node.lo_z, node.hi_x, node.hi_y, node.hi_z] {
        want.extend(f(v));
    }
    want.extend(node.child);
    want.extend(node.count);
    assert_eq!(&got[..want.len()], &want[..]);
    common::assert_no_validation_messages(&ctx);
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BsdfPush {
    albedo: [f32; 4],
    wo: [f32; 4],
    eta: [f32; 4],
    k: [f32; 4],
    kind: u32,
    mode: u32,
    alpha: f32,
    ior: f32,
    count: u32,
    pad: [u32; 3],
}

/// Runs probe_bsdf.comp in `mode` on `inputs`; returns two vec4 per input.
fn run_bsdf_probe(
    ctx: &std::sync::Arc<rlpt::gpu::Context>,
    b: &Bsdf,
    wo: Vec3,
    mode: u32,
    inputs: &[[f32; 4]],
) -> Vec<[f32; 4]> {
    let input = Buffer::with_data(ctx, "bsdf inputs", bytemuck::cast_slice(inputs), false).unwrap();
    let output = Buffer::new(ctx, "bsdf outputs", inputs.len() as u64 * 32, BufferUsage::Storage).unwrap();
    let p =
        Pipeline::new(ctx, "probe_bsdf", shader("probe_bsdf"), &[Binding::Storage; 2], size_of::<BsdfPush>() as u32)
            .unwrap();
    p.bind(&[&input, &output]);
    let push = BsdfPush {
        albedo: [b.albedo.x, b.albedo.y, b.albedo.z, 0.0],
        wo: [wo.x, wo.y, wo.z, 0.0],
        eta: [b.eta.x, b.eta.y, b.eta.z, 0.0],
        k: [b.k.x, b.k.y, b.k.z, b.base_alpha],
        kind: b.kind as u32,
        mode,
        alpha: b.alpha,
        ior: b.ior,
        count: inputs.len() as u32,
        pad: [0; 3],
    };
    ctx.run_commands("probe bsdf", |cmd| {
        p.cmd_dispatch(cmd, [(inputs.len() as u32).div_ceil(64), 1, 1], bytemuck::bytes_of(&push))
    })
    .unwrap();
    bytemuck::pod_collect_to_vec(&readback(ctx, &output))
}

/// pbrt's aluminium (RGB eta and k).
const AL_ETA: Vec3 = Vec3::new(1.65746, 0.880369, 0.521229);
const AL_K: Vec3 = Vec3::new(9.22387, 6.26952, 4.837);

fn test_bsdfs() -> Vec<(Bsdf, Vec3)> {
    let wo = |theta_deg: f32| {
        let t = theta_deg.to_radians();
        Vec3::new(t.sin() * 0.6, t.sin() * 0.8, t.cos())
    };
    let glossy = |r: f32| Bsdf::new(MaterialKind::Glossy, Vec3::new(0.9, 0.6, 0.5), r * r, 1.0);
    // pbrt's gold (RGB eta and k).
    let conductor =
        |r: f32| Bsdf::conductor(Vec3::new(0.143119, 0.374957, 1.44248), Vec3::new(3.98316, 2.38572, 1.60322), r * r);
    let rough_glass = |r: f32| Bsdf::new(MaterialKind::RoughDielectric, Vec3::ONE, r * r, 1.5);
    vec![
        (Bsdf::new(MaterialKind::Diffuse, Vec3::new(0.7, 0.5, 0.3), 1.0, 1.0), wo(30.0)),
        (glossy(0.05), wo(0.0)),
        (glossy(0.05), wo(50.0)),
        (glossy(0.08), wo(75.0)),
        (glossy(0.3), wo(10.0)),
        (glossy(0.3), wo(70.0)),
        (glossy(0.6), wo(45.0)),
        (glossy(1.0), wo(80.0)),
        (conductor(0.05), wo(30.0)),
        (conductor(0.3), wo(60.0)),
        (conductor(0.8), wo(5.0)),
        (rough_glass(0.3), wo(35.0)),
        (rough_glass(0.5), -wo(25.0)),
        (rough_glass(0.2), -wo(65.0)),
        (Bsdf::new(MaterialKind::Coated, Vec3::new(0.6, 0.3, 0.2), 0.04, 1.5), wo(20.0)),
        (Bsdf::new(MaterialKind::Coated, Vec3::new(0.2, 0.5, 0.8), 0.36, 2.0), wo(75.0)),
        // A smooth coat (its mirror lobe a delta the chi-square leaves out) and coated conductors (aluminium).
        (Bsdf::new(MaterialKind::Coated, Vec3::new(0.6, 0.3, 0.2), 0.0, 1.5), wo(40.0)),
        (Bsdf::coated_conductor(0.0, 1.5, AL_ETA, AL_K, 0.2236), wo(30.0)),
        (Bsdf::coated_conductor(0.09, 1.6, AL_ETA, AL_K, 0.36), wo(70.0)),
    ]
}

#[test]
fn glsl_bsdfs_match_rust_and_sample_their_pdf() {
    let ctx = common::gpu();
    let n = 400_000usize;
    let cases = test_bsdfs();
    let narrow = |b: &Bsdf| matches!(b.kind, MaterialKind::Glossy | MaterialKind::Conductor) && b.alpha < 0.01;
    let zoomed = cases.iter().filter(|(b, _)| narrow(b)).count();
    let alpha = sidak(0.01, cases.len() + zoomed);
    for (b, wo) in &cases {
        let mut rng = Rng::new(7, b.kind as u32, (b.alpha * 1000.0) as u32, (wo.z * 1000.0) as u32);
        let inputs: Vec<[f32; 4]> = (0..n).map(|_| [rng.next_f32(), rng.next_f32(), rng.next_f32(), 0.0]).collect();
        let out = run_bsdf_probe(&ctx, b, *wo, 0, &inputs);
        let mut samples = Vec::with_capacity(n);
        let mut mismatches = 0;
        for (i, x) in inputs.iter().enumerate() {
            let (g_dir, g_w) = (out[2 * i], out[2 * i + 1]);
            let cpu = bsdf_sample(b, *wo, x[0], [x[1], x[2]]);
            if cpu.is_some() != (g_dir[3] == 1.0) {
                // Only a direction on the horizon may round to success on one side and not
                // the other (the cosine lobe's edge, u on the unit square's border).
                let z = cpu.map_or(g_dir[2], |s| s.wi.z);
                assert!(z.abs() < 1e-3, "{b:?}: GPU and CPU disagree on success for input {x:?}");
                mismatches += 1;
                samples.push(None);
                continue;
            }
            if let Some(s) = cpu {
                let gw = Vec3::new(g_dir[0], g_dir[1], g_dir[2]);
                let weight = Vec3::new(g_w[0], g_w[1], g_w[2]);
                if (gw - s.wi).length() > 1e-3
                    || (g_w[3] - s.pdf).abs() > 1e-3 * s.pdf.max(1.0)
                    || (weight - s.weight).abs().max_element() > 1e-3
                {
                    mismatches += 1;
                }
                // A delta lobe (a smooth coat's) has no density: outside the chi-square's bins.
                samples.push((!s.delta).then_some([gw.x as f64, gw.y as f64, gw.z as f64]));
            } else {
                samples.push(None);
            }
        }
        // A handful of grazing samples may round differently in the two implementations.
        assert!(mismatches <= n / 10_000, "{b:?}: {mismatches} GLSL samples differ from the Rust ones");
        let b2 = *b;
        let w = *wo;
        let pdf = move |d: [f64; 3]| bsdf_pdf(&b2, w, Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)) as f64;
        let r = chi2_sphere(&samples, pdf, &Chi2Options::default());
        assert!(r.passed(alpha), "GLSL sampler of {b:?} wo={wo:?} fails chi-square: {r:?}");
        // A lobe narrower than the bins (roughness below 0.1): zoomed into, as in bsdf_cpu.rs.
        if narrow(b) {
            let zoom = Zoom::new([-wo.x as f64, -wo.y as f64, wo.z as f64], 0.5 / b.alpha as f64);
            let zoomed: Vec<_> = samples.iter().map(|s| s.map(|d| zoom.sample(d))).collect();
            let r = chi2_sphere(&zoomed, |d| zoom.pdf(pdf, d), &Chi2Options::default());
            assert!(r.passed(alpha), "GLSL sampler of {b:?} wo={wo:?}, zoomed into the lobe: {r:?}");
            assert!(r.degrees_of_freedom >= 100, "the zoom resolves the lobe: {r}");
        }

        // eval and pdf agree pointwise: at directions all over the sphere, and at
        // sampled ones, inside the lobe (which a narrow lobe's uniform ones miss).
        let sampled = samples.iter().flatten().take(4096).map(|d| [d[0] as f32, d[1] as f32, d[2] as f32, 0.0]);
        let dirs: Vec<[f32; 4]> = (0..4096)
            .map(|_| {
                let d = rlpt::math::sampling::uniform_sphere(rng.next_2d());
                [d.x, d.y, d.z, 0.0]
            })
            .chain(sampled)
            .collect();
        let ev = run_bsdf_probe(&ctx, b, *wo, 1, &dirs);
        for (i, d) in dirs.iter().enumerate() {
            let wi = Vec3::new(d[0], d[1], d[2]);
            let f = bsdf_eval(b, *wo, wi);
            let p = bsdf_pdf(b, *wo, wi);
            let g = ev[2 * i];
            let tol = |x: f32| 1e-4 * x.abs().max(1.0);
            assert!(
                (0..3).all(|c| (g[c] - f[c]).abs() <= tol(f[c])) && (g[3] - p).abs() <= tol(p),
                "{b:?} at {wi:?}: GPU f={g:?}, CPU f={f:?} pdf={p}"
            );
        }
    }
    common::assert_no_validation_messages(&ctx);
}

#[test]
fn glsl_dielectric_mirror_and_smooth_conductor_match_rust() {
    let ctx = common::gpu();
    let cases = [
        (Bsdf::new(MaterialKind::Dielectric, Vec3::ONE, 1.0, 1.5), Vec3::new(0.3, 0.4, 0.866).normalize()),
        (Bsdf::new(MaterialKind::Dielectric, Vec3::ONE, 1.0, 1.5), Vec3::new(0.6, 0.0, -0.8)),
        (Bsdf::new(MaterialKind::Specular, Vec3::splat(0.9), 1.0, 1.0), Vec3::new(0.6, 0.0, 0.8)),
        // A smooth conductor (copper): a mirror weighted by the complex Fresnel.
        (
            Bsdf::conductor(Vec3::new(0.200438, 0.924033, 1.10221), Vec3::new(3.91295, 2.45285, 2.14219), 0.0),
            Vec3::new(0.5, 0.6, 0.5).normalize(),
        ),
    ];
    for (b, wo) in cases {
        let inputs: Vec<[f32; 4]> = (0..1000).map(|i| [i as f32 / 1000.0, 0.5, 0.5, 0.0]).collect();
        let out = run_bsdf_probe(&ctx, &b, wo, 0, &inputs);
        for (i, x) in inputs.iter().enumerate() {
            let cpu = bsdf_sample(&b, wo, x[0], [x[1], x[2]]);
            let g = out[2 * i];
            assert_eq!(cpu.is_some(), g[3] == 1.0);
            if let Some(s) = cpu {
                assert!((Vec3::new(g[0], g[1], g[2]) - s.wi).length() < 1e-5, "{b:?}: direction");
                let gw = out[2 * i + 1];
                assert!((Vec3::new(gw[0], gw[1], gw[2]) - s.weight).length() < 1e-5, "{b:?}: weight");
            }
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// The GPU's random numbers are the CPU's, bit for bit (glsl/rng.glsl and
/// src/math/rng.rs): stream seeding, the 32-bit outputs and the floats, over
/// many pixels, samples, two seeds and two frames.
#[test]
fn glsl_random_numbers_match_rust_bit_for_bit() {
    let ctx = common::gpu();
    let n = 4096u32;
    let output = Buffer::new(&ctx, "rng outputs", n as u64 * 32, BufferUsage::Storage).unwrap();
    let p = Pipeline::new(&ctx, "probe_rng", shader("probe_rng"), &[Binding::Storage], 12).unwrap();
    p.bind(&[&output]);
    for (seed, frame) in [(0u32, 0u32), (7, 123_456)] {
        ctx.run_commands("probe rng", |cmd| {
            let push = [n, seed, frame];
            p.cmd_dispatch(cmd, [n.div_ceil(64), 1, 1], bytemuck::cast_slice(&push));
        })
        .unwrap();
        let got: Vec<[u32; 8]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &output));
        for (i, g) in got.iter().enumerate() {
            let mut rng = Rng::new(seed, i as u32, frame, i as u32 % 64);
            let mut want = [0u32; 8];
            want[0] = rng.next_u32();
            for w in &mut want[1..4] {
                *w = rng.next_f32().to_bits();
            }
            let [x, y] = rng.next_2d();
            (want[4], want[5]) = (x.to_bits(), y.to_bits());
            for w in &mut want[6..] {
                *w = rng.next_f32().to_bits();
            }
            assert_eq!(*g, want, "seed {seed}, frame {frame}, invocation {i}");
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// The samplers of glsl/sampler.glsl match src/math/sampler.rs bit for bit, both
/// kinds: pixel samples and dimensions of several vertices, over many pixels,
/// samples, two seeds and two frames.
#[test]
fn glsl_samplers_match_rust_bit_for_bit() {
    use rlpt::math::sampler::{bounce_dim, PathSampler, SamplerKind};
    use rlpt::shared::{SAMPLE_DIRECTION, SAMPLE_LIGHT, SAMPLE_LIGHT_SELECT, SAMPLE_ROULETTE};
    let ctx = common::gpu();
    let n = 4096u32;
    let output = Buffer::new(&ctx, "sampler outputs", n as u64 * 32, BufferUsage::Storage).unwrap();
    let p = Pipeline::new(&ctx, "probe_sampler", shader("probe_sampler"), &[Binding::Storage], 16).unwrap();
    p.bind(&[&output]);
    for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
        for (seed, frame) in [(0u32, 0u32), (7, 123_456)] {
            ctx.run_commands("probe sampler", |cmd| {
                let push = [n, seed, frame, (kind == SamplerKind::Sobol) as u32];
                p.cmd_dispatch(cmd, [n.div_ceil(64), 1, 1], bytemuck::cast_slice(&push));
            })
            .unwrap();
            let got: Vec<[u32; 8]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &output));
            for (i, g) in got.iter().enumerate() {
                let mut s = PathSampler::new(kind, seed, i as u32, frame, i as u32 % 64);
                let pix = s.sample_pixel(i as u32 % 64);
                let sel = s.sample_1d(bounce_dim(0, SAMPLE_LIGHT_SELECT));
                let light = s.sample_2d(bounce_dim(0, SAMPLE_LIGHT));
                let rr = s.sample_1d(bounce_dim(3, SAMPLE_ROULETTE));
                let dir = s.sample_2d(bounce_dim(7, SAMPLE_DIRECTION));
                let want = [pix[0], pix[1], sel, light[0], light[1], rr, dir[0], dir[1]].map(f32::to_bits);
                assert_eq!(*g, want, "{kind:?}, seed {seed}, frame {frame}, invocation {i}");
            }
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// The frame counters' 64-bit sums (glsl/counters.glsl): 100 000 invocations add
/// values near 2^28 each to one pair, so that its low word wraps about 6000 times;
/// the pair holds the exact total. (A 4K frame traces more rays than 32 bits
/// hold.) Without the carry the high word stays 0 and the test fails.
#[test]
fn frame_counters_sum_past_32_bits() {
    let ctx = common::gpu();
    let n = 100_000u32;
    let values: Vec<u32> = (0..n).map(|i| 0x1000_0000 + rlpt::math::rng::pcg_hash(i) % 0x100_0000).collect();
    let vb = Buffer::with_data(&ctx, "counter values", bytemuck::cast_slice(&values), false).unwrap();
    let cb = Buffer::new(&ctx, "counter pair", 8, BufferUsage::Storage).unwrap();
    let p = Pipeline::new(&ctx, "probe_counters", shader("probe_counters"), &[Binding::Storage; 2], 4).unwrap();
    p.bind(&[&vb, &cb]);
    ctx.run_commands("probe counters", |cmd| {
        cb.cmd_clear(cmd);
        ctx.barrier(cmd);
        p.cmd_dispatch(cmd, [n.div_ceil(256), 1, 1], &n.to_le_bytes());
    })
    .unwrap();
    let got: Vec<u32> = bytemuck::pod_collect_to_vec(&readback(&ctx, &cb));
    let want: u64 = values.iter().map(|&v| v as u64).sum();
    assert!(want >> 32 > 1000, "the test wraps the low word many times");
    assert_eq!(got[0] as u64 | (got[1] as u64) << 32, want);
    common::assert_no_validation_messages(&ctx);
}

/// glsl/film.glsl's `kahan_add` is src/film.rs's bit for bit, and after 2^20
/// terms of nearly one size (a furnace's frames; each exact in f32, so that the
/// devices add the same terms) its sum is the exact one to float precision where
/// a plain f32 sum has lost a part in ten thousand.
#[test]
fn the_compensated_sum_matches_its_twin_and_keeps_a_million_terms() {
    let ctx = common::gpu();
    let (count, invocations, per_dispatch) = (1u32 << 20, 8u32, 1u32 << 15);
    let zeros = vec![0u8; invocations as usize * 32];
    let state = Buffer::with_data(&ctx, "film state", &zeros, false).unwrap();
    let p = Pipeline::new(&ctx, "probe_film", shader("probe_film"), &[Binding::Storage], 12).unwrap();
    p.bind(&[&state]);
    // Many dispatches, each adding its share of the terms to what the last left.
    ctx.run_commands("probe film", |cmd| {
        for first in (0..count).step_by(per_dispatch as usize) {
            p.cmd_dispatch(cmd, [1, 1, 1], bytemuck::cast_slice(&[first, per_dispatch, invocations]));
            ctx.barrier(cmd);
        }
    })
    .unwrap();
    let got: Vec<[u32; 8]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &state));
    for (i, g) in got.iter().enumerate() {
        let term = |k: u32| {
            let wobble = 1.0 + ((k % 7) as f32 - 3.0) / 4096.0;
            [23.6875f32, 11.125, 40.3125].map(|b| b * ((i as f32 + 1.0) * wobble))
        };
        let (mut sum, mut carry, mut plain, mut exact) = ([0.0f32; 3], [0.0f32; 3], [0.0f32; 3], [0.0f64; 3]);
        for k in 0..count {
            for (c, x) in term(k).into_iter().enumerate() {
                rlpt::film::kahan_add(&mut sum[c], &mut carry[c], x);
                plain[c] += x;
                exact[c] += x as f64;
            }
        }
        assert_eq!(g[..3], sum.map(f32::to_bits), "invocation {i}: the sums");
        assert_eq!(g[4..7], carry.map(f32::to_bits), "invocation {i}: the carries");
        for c in 0..3 {
            let err = (f32::from_bits(g[c]) as f64 - exact[c]).abs() / exact[c];
            assert!(err < 1e-7, "invocation {i}, channel {c}: relative error {err:e}");
            let plain_err = (plain[c] as f64 - exact[c]).abs() / exact[c];
            assert!(plain_err > 1e-4, "invocation {i}, channel {c}: a plain sum lost only {plain_err:e}");
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// A context compiles a pipeline of one shader, bindings and specialization
/// once: the next of the same key shares it, another specialization compiles
/// its own. It keeps the `PIPELINE_CACHE_SIZE` most recently used; one pushed
/// out still works for those that hold it, and the next of its key compiles
/// again. (probe_rng has no specialization constants: the values only tell
/// the keys apart.)
#[test]
fn a_context_compiles_each_pipeline_once_and_keeps_the_latest() {
    let ctx = common::gpu();
    let rng = |c: u32| {
        Pipeline::new_specialized(&ctx, "probe_rng", shader("probe_rng"), &[(0, Binding::Storage)], 12, &[c]).unwrap()
    };
    let start = ctx.pipelines_compiled();
    let first = rng(1);
    assert_eq!(ctx.pipelines_compiled(), start + 1);
    let again = rng(1);
    assert_eq!(ctx.pipelines_compiled(), start + 1, "the same key compiles nothing");
    assert_eq!(again.raw(), first.raw());
    assert_ne!(again.set, first.set, "each pipeline binds its own buffers");
    assert_ne!(rng(2).raw(), first.raw());
    assert_eq!(ctx.pipelines_compiled(), start + 2, "another specialization compiles its own");
    for c in 0..PIPELINE_CACHE_SIZE as u32 {
        rng(100 + c);
    }
    assert_eq!(ctx.pipelines_compiled(), start + 2 + PIPELINE_CACHE_SIZE as u64);
    drop(again);
    let later = rng(1);
    assert_eq!(ctx.pipelines_compiled(), start + 3 + PIPELINE_CACHE_SIZE as u64, "pushed out, compiled again");
    // The pipeline pushed out still runs: the random numbers of one invocation.
    let n = 64u32;
    let output = Buffer::new(&ctx, "rng outputs", n as u64 * 32, BufferUsage::Storage).unwrap();
    for (p, seed) in [(&first, 3u32), (&later, 4)] {
        p.bind(&[&output]);
        ctx.run_commands("probe rng", |cmd| p.cmd_dispatch(cmd, [1, 1, 1], bytemuck::cast_slice(&[n, seed, 0])))
            .unwrap();
        let got: Vec<[u32; 8]> = bytemuck::pod_collect_to_vec(&readback(&ctx, &output));
        assert_eq!(got[5][0], Rng::new(seed, 5, 0, 5).next_u32(), "seed {seed}");
    }
    common::assert_no_validation_messages(&ctx);
}
