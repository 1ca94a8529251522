//! PLACEHOLDER (replaced by the bvh branch): one leaf of every primitive.
use super::geometry::{intersect_quad, intersect_sphere, sphere_blocks};
use super::triangle::intersect_triangle;
use crate::layout::{prim_kind_index, GpuBvhNode, SceneArrays};
use crate::shared;
use glam::Vec3;

pub struct PrimBox {
    pub prim: u32,
    pub lo: Vec3,
    pub hi: Vec3,
}

pub struct Bvh {
    pub nodes: Vec<GpuBvhNode>,
    pub prim_refs: Vec<u32>,
    pub depth: u32,
}

pub fn build(prims: &[PrimBox]) -> Bvh {
    if prims.is_empty() {
        return Bvh { nodes: Vec::new(), prim_refs: Vec::new(), depth: 0 };
    }
    let lo = prims.iter().fold(Vec3::splat(f32::INFINITY), |a, p| a.min(p.lo));
    let hi = prims.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, p| a.max(p.hi));
    let node = GpuBvhNode {
        a_lo: lo.into(),
        a_child: shared::BVH_LEAF,
        a_hi: hi.into(),
        a_count: prims.len() as u32,
        b_lo: [0.0; 3],
        b_child: shared::BVH_LEAF,
        b_hi: [0.0; 3],
        b_count: 0,
    };
    Bvh { nodes: vec![node], prim_refs: prims.iter().map(|p| p.prim).collect(), depth: 1 }
}

fn hit(s: &SceneArrays, r: u32, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
    let (k, i) = prim_kind_index(r);
    let i = i as usize;
    match k {
        shared::PRIM_TRIANGLE => {
            let [a, b, c] = s.triangles[i].vertices();
            intersect_triangle(a, b, c, o, d, t_max)
        }
        shared::PRIM_SPHERE => intersect_sphere(&s.spheres[i], o, d, t_max),
        _ => intersect_quad(&s.quads[i], o, d, t_max),
    }
}

pub fn closest_hit(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
    let mut best = t_max;
    let mut found = None;
    for &r in &s.prim_refs {
        if let Some(t) = hit(s, r, o, d, best) {
            best = t;
            found = Some(r);
        }
    }
    found.map(|r| (best, r))
}

pub fn occluded(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32, skip: u32) -> bool {
    s.prim_refs.iter().any(|&r| {
        r != skip && {
            let (k, i) = prim_kind_index(r);
            if k == shared::PRIM_SPHERE {
                sphere_blocks(&s.spheres[i as usize], o, d, t_max)
            } else {
                hit(s, r, o, d, t_max).is_some()
            }
        }
    })
}
