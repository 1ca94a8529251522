//! The scene's textures as the renderers read them: one header per texture a
//! material names (its image's texels and its UV transform), every image's
//! texels in one array, and the materials' references to the headers
//! (docs/ARCHITECTURE.md, "Textures").

use crate::layout::{GpuMaterial, GpuSphereUv, GpuTexture};
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
/// image read with two UV transforms has two headers over the same texels.
pub(super) fn scene_textures(scene: &Scene, materials: &mut [GpuMaterial]) -> (Vec<GpuTexture>, Vec<u32>) {
    let mut offsets = Vec::with_capacity(scene.textures.len());
    let mut texels = Vec::new();
    for t in &scene.textures {
        offsets.push(texels.len() as u32);
        texels.extend_from_slice(&t.texels);
    }
    let mut headers: Vec<GpuTexture> = Vec::new();
    let mut header = |r: &Option<TextureRef>| -> u32 {
        let Some(r) = r else { return shared::NO_TEXTURE };
        let i = find(&scene.textures, r).expect("Scene::textures holds every image a material names (load_textures)");
        let t = &scene.textures[i];
        let h = GpuTexture {
            offset: offsets[i],
            width: t.width,
            height: t.height,
            format: t.format,
            transform: r.transform,
        };
        let k = headers.iter().position(|x| *x == h).unwrap_or_else(|| {
            headers.push(h);
            headers.len() - 1
        });
        k as u32 + 1
    };
    for (g, m) in materials.iter_mut().zip(&scene.materials) {
        g.albedo_texture = header(&m.albedo_texture);
        g.roughness_texture = header(&m.roughness_texture);
    }
    if headers.is_empty() {
        texels.clear();
    }
    (headers, texels)
}
