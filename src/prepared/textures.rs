//! The scene's textures as the renderers read them: one header per texture a
//! material names (its image's texels and its UV transform), every image's
//! texels in one array, and the materials' references to the headers
//! (docs/ARCHITECTURE.md, "Textures").

use crate::layout::{GpuMaterial, GpuSphereUv, GpuTexture};
use crate::scene::procedural::{Combine, Procedural};
use crate::scene::texture::{find, TextureRef};
use crate::scene::Scene;
use crate::shared;

/// Each sphere's UV frame, as the renderers read it.
pub(super) fn sphere_uvs(scene: &Scene) -> Vec<GpuSphereUv> {
    let row = |v: glam::Vec3, w: f32| [v.x, v.y, v.z, w];
    (scene.spheres.iter())
        .map(|s| GpuSphereUv {
            x: row(s.uv.to_object[0], s.uv.phi_max),
            y: row(s.uv.to_object[1], s.uv.theta_min),
            z: row(s.uv.to_object[2], s.uv.theta_max),
        })
        .collect()
}

/// The headers and texels of the textures `scene`'s materials name; sets each
/// material's `albedo_texture` and `roughness_texture` (1 + its header). An
/// image read with two UV transforms has two headers over the same texels. A
/// procedural texture's header (`shared::TEXTURE_CHECKER`, ...) points at its
/// operands in the texels: the three operands' headers (1 + index, or
/// `NO_TEXTURE`), then their three constant colours (f32 bits).
pub(super) fn scene_textures(scene: &Scene, materials: &mut [GpuMaterial]) -> (Vec<GpuTexture>, Vec<u32>) {
    let mut offsets = Vec::with_capacity(scene.textures.len());
    let mut texels = Vec::new();
    for t in &scene.textures {
        offsets.push(texels.len() as u32);
        texels.extend_from_slice(&t.texels);
    }
    let mut headers: Vec<GpuTexture> = Vec::new();
    let mut add = |h: GpuTexture| -> u32 {
        let k = headers.iter().position(|x| *x == h).unwrap_or_else(|| {
            headers.push(h);
            headers.len() - 1
        });
        k as u32 + 1
    };
    let image = |r: &TextureRef| -> GpuTexture {
        let i = find(&scene.textures, r).expect("Scene::textures holds every image a material names (load_textures)");
        let t = &scene.textures[i];
        GpuTexture { offset: offsets[i], width: t.width, height: t.height, format: t.format, transform: r.transform }
    };
    for (g, m) in materials.iter_mut().zip(&scene.materials) {
        g.albedo_texture = m.albedo_texture.as_ref().map_or(shared::NO_TEXTURE, |r| add(image(r)));
        g.roughness_texture = m.roughness_texture.as_ref().map_or(shared::NO_TEXTURE, |r| add(image(r)));
        if let Some(p) = &m.albedo_procedural {
            let h = procedural(p, &mut texels, &mut |r| add(image(r)));
            g.albedo_texture = add(h);
        }
    }
    if headers.is_empty() {
        texels.clear();
    }
    (headers, texels)
}

/// The header of procedural texture `p`, its operands appended to `texels`;
/// `image` adds an operand image's header and gives 1 + its index.
fn procedural(p: &Procedural, texels: &mut Vec<u32>, image: &mut dyn FnMut(&TextureRef) -> u32) -> GpuTexture {
    let offset = texels.len() as u32;
    let ops = [&p.a, &p.b, &p.amount];
    for o in ops {
        texels.push(o.image.as_ref().map_or(shared::NO_TEXTURE, &mut *image));
    }
    texels.extend(ops.iter().flat_map(|o| o.value.to_array().map(f32::to_bits)));
    let (format, transform) = match p.combine {
        Combine::Checker(t) => (shared::TEXTURE_CHECKER, t),
        Combine::Scale => (shared::TEXTURE_SCALE, [1.0, 1.0, 0.0, 0.0]),
        Combine::Mix => (shared::TEXTURE_MIX, [1.0, 1.0, 0.0, 0.0]),
    };
    GpuTexture { offset, width: 0, height: 0, format, transform }
}
