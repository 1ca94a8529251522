//! The meshes' triangles as the renderers trace them, their lights, and the
//! boxes the BVH is built from (`crate::math::bvh`).

use crate::layout::{v4, GpuLight, GpuQuad, GpuSphere, GpuTriangle, GpuTriangleNormals, GpuTriangleUvs};
use crate::math::bvh;
use crate::math::Vec3;
use crate::scene::Scene;
use crate::shared;

/// Scenes with more spheres and quads than this are traced through a BVH, as
/// every scene with triangles is; smaller ones keep the specialized walk.
pub const BVH_MIN_ANALYTIC: usize = 256;

/// Whether the renderers walk a BVH over every primitive (`shared::SPEC_BVH`):
/// where the scene has triangles, or more than [`BVH_MIN_ANALYTIC`] spheres and quads.
pub fn uses_bvh(scene: &Scene) -> bool {
    scene.meshes.iter().any(|m| !m.triangles.is_empty()) || scene.spheres.len() + scene.quads.len() > BVH_MIN_ANALYTIC
}

/// The meshes' triangles, the shading normals of the smooth ones, and with
/// `uvs` every triangle's vertex UVs (zero where its mesh has none: a textured
/// material there was replaced, `crate::scene::texture::load_textures`); a
/// triangle of an emitting material becomes a light (appended to `lights`, its
/// power to `powers`), as spheres and quads do.
pub(super) fn mesh_triangles(
    scene: &Scene,
    lights: &mut Vec<GpuLight>,
    powers: &mut Vec<f64>,
    power: &dyn Fn(u32, f64) -> f64,
    with_uvs: bool,
) -> (Vec<GpuTriangle>, Vec<GpuTriangleNormals>, Vec<GpuTriangleUvs>) {
    let count = scene.meshes.iter().map(|m| m.triangles.len()).sum();
    let mut triangles = Vec::with_capacity(count);
    let mut normals = Vec::new();
    let mut uvs = Vec::with_capacity(if with_uvs { count } else { 0 });
    for mesh in &scene.meshes {
        for (t, &[a, b, c]) in mesh.triangles.iter().enumerate() {
            if with_uvs {
                let uv = |i: u32| mesh.uvs.as_ref().map_or([0.0; 2], |u| u[i as usize].to_array());
                uvs.push(GpuTriangleUvs { uv: [uv(a), uv(b), uv(c)] });
            }
            let material = mesh.materials[t];
            let v = [a, b, c].map(|i| mesh.positions[i as usize]);
            let mut light = shared::NO_LIGHT;
            if scene.material_emits(material) {
                light = lights.len() as u32;
                let index = triangles.len() as u32;
                lights.push(GpuLight { kind: shared::LIGHT_TRIANGLE, index, pmf: 0.0, cdf: 0.0 });
                let d = |x: Vec3| x.as_dvec3();
                powers.push(power(material, 0.5 * (d(v[1]) - d(v[0])).cross(d(v[2]) - d(v[0])).length()));
            }
            let mut tri_normals = shared::NO_NORMALS;
            if let Some(n) = &mesh.normals {
                tri_normals = normals.len() as u32;
                normals.push(GpuTriangleNormals { n: [a, b, c].map(|i| v4(n[i as usize], 0.0)) });
            }
            triangles.push(GpuTriangle {
                v0: v[0].into(),
                material,
                v1: v[1].into(),
                light,
                v2: v[2].into(),
                normals: tri_normals,
            });
        }
    }
    (triangles, normals, uvs)
}

/// The boxes of every primitive, for the BVH's build (and `rlpt info`'s bounds).
pub fn prim_boxes(spheres: &[GpuSphere], quads: &[GpuQuad], triangles: &[GpuTriangle]) -> Vec<bvh::PrimBox> {
    let spheres = spheres.iter().enumerate().map(|(i, s)| bvh::PrimBox::sphere(i as u32, s));
    let quads = quads.iter().enumerate().map(|(i, q)| bvh::PrimBox::quad(i as u32, q));
    let triangles = triangles.iter().enumerate().map(|(i, t)| bvh::PrimBox::triangle(i as u32, t));
    spheres.chain(quads).chain(triangles).collect()
}
