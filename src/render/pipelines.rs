//! The path-tracing kernel's pipelines: its bindings and the specialization
//! constants each render's parameters and geometry give it.

use super::*;

/// The path-tracing pipelines for the render `p` describes: the one without
/// recording code and, with guiding, the one that records targets.
pub(super) fn path_pipelines(
    ctx: &Arc<Context>,
    kernel: &str,
    guided: bool,
    p: &crate::layout::RenderParams,
    geometry: &[u32],
) -> Result<(Pipeline, Option<Pipeline>), GpuError> {
    let plain = path_pipeline(ctx, kernel, guided, false, p, geometry)?;
    let recording = if guided { Some(path_pipeline(ctx, kernel, guided, true, p, geometry)?) } else { None };
    Ok((plain, recording))
}

/// Whether `scene`'s learning frames have pixel rows that record no targets
/// (`crate::guide::RecordSchedule::first_stride` above 1): the unguided kernel
/// traces those ([`GpuRenderer::cmd_trace`]), as fast as an unguided frame and
/// as good while the table knows little (docs/guiding.md, "Learning frames in
/// the image").
pub(super) fn learning_rows_unguided(scene: &crate::prepared::PreparedScene) -> bool {
    let pixels = scene.params.width as u64 * scene.params.height as u64;
    scene.learning_frames() > 0 && crate::guide::RecordSchedule::first_stride(pixels) > 1
}

/// The unguided kernel of a guided render, for the frames its [`crate::guide::FrameRace`]
/// traces unguided and the learning frames' rows that record nothing: the same
/// scene and flags, none of the table's bindings.
pub(super) fn unguided_twin(
    ctx: &Arc<Context>,
    p: &crate::layout::RenderParams,
    geometry: &[u32],
) -> Result<Pipeline, GpuError> {
    // A race's unguided frames sum their variance by float atomics, which the plain
    // unguided kernel leaves out for devices without them.
    let kernel = if p.flags & shared::FLAG_FRAME_VARIANCE != 0 { "pathtrace_racing" } else { "pathtrace" };
    path_pipeline(ctx, kernel, false, false, p, geometry)
}

/// The path-tracing pipeline, specialized to the scene and settings of `p`;
/// with `recording`, the guided kernel that records Q-learning targets;
/// `geometry` is the scene's `PreparedScene::geometry_specialization`.
fn path_pipeline(
    ctx: &Arc<Context>,
    kernel: &str,
    guided: bool,
    recording: bool,
    p: &crate::layout::RenderParams,
    geometry: &[u32],
) -> Result<Pipeline, GpuError> {
    let mut bindings = vec![(shared::BINDING_PARAMS, Binding::Uniform)];
    for b in [shared::BINDING_MATERIALS, shared::BINDING_SPHERES, shared::BINDING_QUADS, shared::BINDING_LIGHTS] {
        bindings.push((b, Binding::Storage));
    }
    bindings.push((shared::BINDING_ACCUM, Binding::Storage));
    bindings.push((shared::BINDING_ACCUM_CARRY, Binding::Storage));
    if guided {
        for b in [shared::BINDING_Q, shared::BINDING_FRAME_SUMS, shared::BINDING_FRAME_COUNTS, shared::BINDING_SAMPLER]
        {
            bindings.push((b, Binding::Storage));
        }
    }
    bindings.push((shared::BINDING_COUNTERS, Binding::Storage));
    bindings.push((shared::BINDING_SCENE_CONSTANTS, Binding::Uniform));
    if guided {
        bindings.push((shared::BINDING_FRACTIONS, Binding::Storage));
        bindings.push((shared::BINDING_ROWS_READ, Binding::Storage));
    }
    bindings.extend(GEOMETRY_BINDINGS.map(|b| (b, Binding::Storage)));
    if guided {
        bindings.push((shared::BINDING_GUIDE_TREE, Binding::Storage));
    }
    let mut constants = specialization(p).to_vec();
    constants[shared::SPEC_RECORDING as usize] = recording as u32;
    constants[shared::SPEC_PIXELS_PER_GROUP as usize] = pixels_per_group(recording, p.scene_kinds);
    constants.extend_from_slice(geometry);
    debug_assert_eq!(constants.len(), shared::NUM_SPEC_CONSTANTS as usize);
    let name = if recording { format!("{kernel} (recording)") } else { kernel.to_string() };
    Pipeline::new_specialized(
        ctx,
        &name,
        crate::gpu::shader(kernel),
        &bindings,
        std::mem::size_of::<PathPush>() as u32,
        &constants,
    )
}

/// The values of pathtrace.comp's scalar specialization constants (`SPEC_*` of
/// glsl/common.glsl, by constant_id, up to `SPEC_QUAD_BASE`; the scene's
/// geometry follows) for the render `p` describes. Table shapes
/// are at least 1, also where guiding is off and the kernel does not read them.
pub(super) fn specialization(p: &crate::layout::RenderParams) -> [u32; shared::SPEC_QUAD_BASE as usize] {
    let mut c = [0u32; shared::SPEC_QUAD_BASE as usize];
    c[shared::SPEC_NUM_SPHERES as usize] = p.num_spheres;
    c[shared::SPEC_NUM_QUADS as usize] = p.num_quads;
    c[shared::SPEC_GUIDE_ROWS as usize] = p.guide_rows.max(1);
    c[shared::SPEC_GUIDE_COLS as usize] = p.guide_cols.max(1);
    c[shared::SPEC_GUIDE_RES_X as usize] = p.guide_res_x.max(1);
    c[shared::SPEC_GUIDE_RES_Y as usize] = p.guide_res_y.max(1);
    c[shared::SPEC_GUIDE_RES_Z as usize] = p.guide_res_z.max(1);
    c[shared::SPEC_FLAGS as usize] = p.flags;
    c[shared::SPEC_MAX_BOUNCES as usize] = p.max_bounces;
    c[shared::SPEC_GUIDE_VERTICES as usize] = crate::guide::guided_vertices(p);
    c[shared::SPEC_RECORD_VERTICES as usize] = crate::guide::record_vertices(p);
    c[shared::SPEC_OCCLUDING_QUADS as usize] = p.occluding_quads;
    c[shared::SPEC_SCENE_KINDS as usize] = p.scene_kinds;
    c[shared::SPEC_NUM_LIGHTS as usize] = p.num_lights;
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every specialization constant carries its own field of the parameters
    /// (distinct values, so a constant wired to the wrong field shows).
    #[test]
    fn specialization_constants_carry_their_fields() {
        let p = crate::layout::RenderParams {
            num_spheres: 11,
            num_quads: 12,
            guide_rows: 13,
            guide_cols: 14,
            guide_res_x: 15,
            guide_res_y: 16,
            guide_res_z: 17,
            flags: 16 | shared::FLAG_NEE,
            max_bounces: 19,
            guide_vertices: 20,
            occluding_quads: 21,
            scene_kinds: 22,
            num_lights: 23,
            ..Default::default()
        };
        let c = specialization(&p);
        let want = [
            (shared::SPEC_NUM_SPHERES, 11),
            (shared::SPEC_NUM_QUADS, 12),
            (shared::SPEC_GUIDE_ROWS, 13),
            (shared::SPEC_GUIDE_COLS, 14),
            (shared::SPEC_GUIDE_RES_X, 15),
            (shared::SPEC_GUIDE_RES_Y, 16),
            (shared::SPEC_GUIDE_RES_Z, 17),
            (shared::SPEC_FLAGS, 16 | shared::FLAG_NEE),
            (shared::SPEC_MAX_BOUNCES, 19),
            (shared::SPEC_GUIDE_VERTICES, 20),
            // No roulette in `flags`: the guided vertices.
            (shared::SPEC_RECORD_VERTICES, 20),
            (shared::SPEC_OCCLUDING_QUADS, 21),
            (shared::SPEC_SCENE_KINDS, 22),
            (shared::SPEC_NUM_LIGHTS, 23),
            // Set per pipeline by `path_pipeline`, not from the parameters.
            (shared::SPEC_RECORDING, 0),
            (shared::SPEC_PIXELS_PER_GROUP, 0),
        ];
        assert_eq!(want.len(), shared::SPEC_QUAD_BASE as usize);
        for (id, v) in want {
            assert_eq!(c[id as usize], v, "specialization constant {id}");
        }
        // With Russian roulette every vertex records (learned roulette reads Q there).
        let rr = crate::layout::RenderParams { flags: p.flags | shared::FLAG_RUSSIAN_ROULETTE, ..p };
        assert_eq!(specialization(&rr)[shared::SPEC_RECORD_VERTICES as usize], u32::MAX);
        // guide_vertices 0: without roulette the default of the NEE flag, so that switching NEE
        // (set_params) changes the constants and rebuilds the kernels.
        let mut d = crate::layout::RenderParams { guide_vertices: 0, ..p };
        let c = specialization(&d);
        let guided = shared::SPEC_GUIDE_VERTICES as usize;
        assert_eq!(c[guided], crate::layout::DEFAULT_GUIDED_VERTICES_NEE);
        d.set_nee(false);
        assert_eq!(specialization(&d)[guided], u32::MAX);
        // With roulette the default is every vertex, NEE on or off.
        d.flags |= shared::FLAG_RUSSIAN_ROULETTE;
        assert_eq!(specialization(&d)[guided], u32::MAX);
        d.set_nee(true);
        assert_eq!(specialization(&d)[guided], u32::MAX);
    }
}
