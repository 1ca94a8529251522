//! What a render takes of the device: each buffer against the largest one the
//! shaders can address, and all of them against the device's memory, checked
//! before anything is allocated.

use super::*;

/// Bytes per pixel of the accumulation's Kahan carry, a vec4 (`accum_carry` in
/// `glsl/pathtrace.comp`), which lies on the device alone.
pub(super) const ACCUM_CARRY_BYTES: u64 = 16;

/// An error naming `what` where `bytes` are more than one storage buffer the
/// device's shaders can address.
pub(super) fn fits_one_buffer(ctx: &Context, what: &str, bytes: u64, hint: &'static str) -> Result<(), GpuError> {
    let limit = ctx.info.max_storage_buffer_range as u64;
    if bytes > limit {
        return Err(GpuError::BufferTooLarge { what: what.into(), bytes, limit, hint });
    }
    Ok(())
}

/// `bytes` in MB, rounded up.
pub(super) fn mb(bytes: u64) -> u64 {
    bytes.div_ceil(1 << 20)
}

/// Bytes of the device-local scene data: triangles, shading normals, BVH nodes
/// and refs, the image environment, the textures the triangles' UVs and the delta lights.
pub fn scene_geometry_bytes(scene: &crate::layout::SceneArrays) -> u64 {
    (std::mem::size_of_val(scene.triangles.as_slice())
        + std::mem::size_of_val(scene.triangle_normals.as_slice())
        + std::mem::size_of_val(scene.bvh_nodes.as_slice())
        + std::mem::size_of_val(scene.prim_refs.as_slice())
        + std::mem::size_of_val(scene.env_texels.as_slice())
        + std::mem::size_of_val(scene.env_cdf.as_slice())
        + std::mem::size_of_val(scene.textures.as_slice())
        + std::mem::size_of_val(scene.texels.as_slice())
        + std::mem::size_of_val(scene.triangle_uvs.as_slice())
        + std::mem::size_of_val(scene.sphere_uvs.as_slice())
        + std::mem::size_of_val(scene.delta_lights.as_slice())) as u64
}

/// The device memory a render of `scene` takes, against what `ctx`'s device has:
/// an error that says what would not fit and what to do, before anything is
/// allocated. The storage buffers count; uploads and readbacks too where they
/// take the same memory ([`DeviceInfo::unified_memory`](crate::gpu::DeviceInfo)).
pub(super) fn fits_device_memory(ctx: &Context, scene: &PreparedScene) -> Result<(), GpuError> {
    let available = ctx.info.device_memory;
    let p = &scene.params;
    let pixels = p.width as u64 * p.height as u64;
    let accum = pixels * std::mem::size_of::<AccumPixel>() as u64;
    let carry = pixels * ACCUM_CARRY_BYTES;
    let table = scene.guide.as_ref().map_or(0, |cfg| {
        let entries = cfg.entries() as u64;
        let cells = cfg.cells() as u64;
        let rows = cfg.sampling_rows() as u64;
        2 * 4 * entries
            + 2 * 4 * (entries + cells)
            + 2 * 4 * rows
            + cells * std::mem::size_of::<crate::guide::FractionState>() as u64
            + cfg.sampling_rows_bytes()
            + super::learning::tree_bytes(cfg)
    });
    let uploads = [
        std::mem::size_of_val(&scene.params),
        std::mem::size_of_val(scene.materials.as_slice()),
        std::mem::size_of_val(scene.spheres.as_slice()),
        std::mem::size_of_val(scene.quads.as_slice()),
        std::mem::size_of_val(scene.lights.as_slice()),
    ]
    .iter()
    .map(|&b| b as u64)
    .sum::<u64>();
    let geometry = scene_geometry_bytes(scene);
    let unified = ctx.info.unified_memory;
    let needed = accum + carry + table + geometry + if unified { accum + uploads } else { 0 };
    if available == 0 || needed <= available {
        return Ok(());
    }
    let mut parts = vec![format!("{} MB for the {}x{} image", mb(accum + carry), p.width, p.height)];
    if geometry > 0 {
        let images = !scene.texels.is_empty() || !scene.env_texels.is_empty();
        let what = if images { "the meshes, the BVH and the images" } else { "the meshes and the BVH" };
        parts.push(format!("{} MB for {what}", mb(geometry)));
    }
    if unified {
        parts.push(format!("{} MB to read it back", mb(accum)));
    }
    if table > 0 {
        parts.push(format!("{} MB for the guiding table", mb(table)));
    }
    let hint = if geometry > accum + table {
        "render a scene with fewer triangles, or on the CPU (--device cpu)"
    } else if scene.guide.is_some() {
        "render a smaller image (--width, --height), with fewer guiding bins (--bins) or cells (the scene's \
         [guiding] resolution), or on the CPU (--device cpu)"
    } else {
        "render a smaller image (--width, --height), or on the CPU (--device cpu)"
    };
    Err(GpuError::DeviceMemoryTooSmall {
        what: parts.join(", "),
        needed,
        available,
        device: ctx.info.name.clone(),
        hint: hint.into(),
    })
}
