//! The BVH over every primitive of a scene: built on the CPU (`build.rs`: binned
//! SAH with spatial splits), walked by [`closest_hit`] and [`occluded`] here and by their twins in
//! `glsl/bvh.glsl` (`bvh_closest`, `bvh_occluded`), the same walk and the same tests.
//!
//! Each node holds both children's boxes (`GpuBvhNode`), so one read of 64 bytes
//! decides which children a ray enters. The walk keeps a stack of node indices:
//! at each node it tests the leaves it enters at once (the nearer first), then
//! descends into the nearer interior child and pushes the farther.

use super::geometry::{intersect_quad, intersect_sphere, sphere_blocks};
use super::triangle::TriangleRay;
use super::Vec3;
use crate::layout::{prim_kind_index, prim_ref, GpuBvhNode, GpuQuad, GpuSphere, GpuTriangle, SceneArrays};
use crate::shared;
use build::Tree;
pub use build::{MAX_DEPTH, MAX_LEAF};

mod build;
#[cfg(test)]
mod tests;

/// A primitive to build over: its reference (`crate::layout::prim_ref`) and its box.
#[derive(Clone, Copy, Debug)]
pub struct PrimBox {
    pub prim: u32,
    pub lo: Vec3,
    pub hi: Vec3,
    /// A triangle's vertices, which spatial splits clip; `None` for spheres and
    /// quads, which they leave whole.
    pub tri: Option<[Vec3; 3]>,
}

impl PrimBox {
    /// Sphere `i`'s box: centre -+ radius.
    pub fn sphere(i: u32, s: &GpuSphere) -> PrimBox {
        let (c, r) = (Vec3::new(s.center_radius[0], s.center_radius[1], s.center_radius[2]), s.center_radius[3]);
        PrimBox { prim: prim_ref(shared::PRIM_SPHERE, i), lo: c - r, hi: c + r, tri: None }
    }

    /// Quad `i`'s box: around its four corners.
    pub fn quad(i: u32, q: &GpuQuad) -> PrimBox {
        let xyz = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
        let (o, u, v) = (xyz(q.origin), xyz(q.edge_u), xyz(q.edge_v));
        let corners = [o, o + u, o + v, o + u + v];
        let lo = corners.iter().fold(Vec3::INFINITY, |a, &c| a.min(c));
        let hi = corners.iter().fold(Vec3::NEG_INFINITY, |a, &c| a.max(c));
        PrimBox { prim: prim_ref(shared::PRIM_QUAD, i), lo, hi, tri: None }
    }

    /// Triangle `i`'s box: around its three vertices.
    pub fn triangle(i: u32, t: &GpuTriangle) -> PrimBox {
        PrimBox::from_vertices(prim_ref(shared::PRIM_TRIANGLE, i), t.vertices())
    }

    /// The triangle `prim` (a reference) of vertices `v`.
    pub fn from_vertices(prim: u32, v: [Vec3; 3]) -> PrimBox {
        PrimBox { prim, lo: v[0].min(v[1]).min(v[2]), hi: v[0].max(v[1]).max(v[2]), tri: Some(v) }
    }
}

/// A built BVH: its nodes (root first) and the leaves' primitive references, as
/// `SceneArrays::bvh_nodes` and `SceneArrays::prim_refs` hold them.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<GpuBvhNode>,
    pub prim_refs: Vec<u32>,
    /// Nodes on the longest path from the root (the root alone: 1; empty: 0). The
    /// walk's stack holds at most depth - 1 entries.
    pub depth: u32,
}

/// Every box written to a node grows by this much of its largest coordinate:
/// a few ulps, so that the f32 boxes the caller rounded (a sphere's centre +- radius,
/// a quad's corners) and the primitive tests' own rounding stay inside it.
const BOX_PAD: f32 = 1.0 / (1u32 << 20) as f32;
/// A box's exit distance is scaled by this before the slab test compares it
/// (Ize, "Robust BVH Ray Traversal", JCGT 2013): it covers the rounding of
/// (plane - o) * (1 / d), the GPU's reciprocal of 2.5 ulp included, so that no
/// box the ray meets is culled.
const EXIT_SCALE: f32 = 1.0 + 1.0 / (1u32 << 19) as f32;
/// Direction components smaller than this are taken as this (of their sign, + for
/// 0) before the reciprocal: 1 / d stays finite and 0 * (1 / d) never makes a NaN,
/// and the ray moves off its line by 1e-30 t, far below `BOX_PAD`.
const MIN_DIR: f32 = 1e-30;

#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: Vec3,
    hi: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb { lo: Vec3::INFINITY, hi: Vec3::NEG_INFINITY };
    fn grow(&mut self, b: &Aabb) {
        self.lo = self.lo.min(b.lo);
        self.hi = self.hi.max(b.hi);
    }
    fn grow_point(&mut self, p: Vec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    fn union(mut self, b: &Aabb) -> Aabb {
        self.grow(b);
        self
    }
    /// The box both boxes hold (empty where they do not meet).
    fn intersect(&self, b: &Aabb) -> Aabb {
        Aabb { lo: self.lo.max(b.lo), hi: self.hi.min(b.hi) }
    }
    fn is_empty(&self) -> bool {
        self.lo.cmpgt(self.hi).any()
    }
    /// Half the surface area (0 for an empty box).
    fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// A node's box grown by [`BOX_PAD`].
fn padded(b: &Aabb) -> ([f32; 3], [f32; 3]) {
    let pad = b.lo.abs().max(b.hi.abs()).max_element() * BOX_PAD;
    ((b.lo - pad).into(), (b.hi + pad).into())
}

/// Lays the tree out depth first (a node's first child right after it, a leaf's
/// references appended as it is met); returns the node's index and the depth below it.
fn lay_out(children: &[(Aabb, Tree); 2], nodes: &mut Vec<GpuBvhNode>, refs: &mut Vec<u32>) -> (u32, u32) {
    let index = nodes.len() as u32;
    nodes.push(GpuBvhNode::default());
    let mut words = [(0u32, 0u32); 2];
    let mut depth = 1;
    for (k, (_, tree)) in children.iter().enumerate() {
        words[k] = match tree {
            Tree::Leaf(prims) => {
                let first = refs.len() as u32;
                refs.extend_from_slice(prims);
                (shared::BVH_LEAF | first, prims.len() as u32)
            }
            Tree::Inner(c) => {
                let (child, d) = lay_out(c, nodes, refs);
                depth = depth.max(d + 1);
                (child, 0)
            }
        };
    }
    let ((a_lo, a_hi), (b_lo, b_hi)) = (padded(&children[0].0), padded(&children[1].0));
    nodes[index as usize] = GpuBvhNode {
        a_lo,
        a_child: words[0].0,
        a_hi,
        a_count: words[0].1,
        b_lo,
        b_child: words[1].0,
        b_hi,
        b_count: words[1].1,
    };
    (index, depth)
}

/// Builds the BVH over `prims` (`build.rs`): binned SAH over the centroids and,
/// where the children of the best object split overlap, over spatial planes that
/// clip the triangles, within a budget of added references (a triangle may then
/// lie in several leaves, at most once in each); leaves of up to `MAX_LEAF` where
/// the SAH prefers them, more only where the centroids coincide; subtrees in
/// parallel. Its depth stays at most `BVH_STACK - 8`: near that, nodes split at
/// the median. No primitives, no nodes; one leaf (a single primitive, or a few the
/// SAH keeps together) becomes a root whose second child is an empty leaf.
pub fn build(prims: &[PrimBox]) -> Bvh {
    build_with(prims, true)
}

/// [`build`], with or without spatial splits (without, every primitive is in one leaf).
pub fn build_with(prims: &[PrimBox], spatial_splits: bool) -> Bvh {
    if prims.is_empty() {
        return Bvh::default();
    }
    let (tree, bounds) = build::build_tree(prims, spatial_splits);
    let children = match tree {
        Tree::Inner(c) => c,
        // The root as a leaf: the second child holds nothing (count 0; its box, a
        // point, costs a ray that meets it no primitive test).
        leaf => Box::new([(bounds, leaf), (Aabb { lo: bounds.lo, hi: bounds.lo }, Tree::Leaf(vec![]))]),
    };
    let mut nodes = Vec::with_capacity(2 * prims.len() / MAX_LEAF.max(2) + 1);
    let mut prim_refs = Vec::with_capacity(prims.len());
    let (_, depth) = lay_out(&children, &mut nodes, &mut prim_refs);
    Bvh { nodes, prim_refs, depth }
}

/// A ray as the walk uses it: origin, direction, the reciprocal of the direction
/// for the slab tests ([`MIN_DIR`]) and the triangle test's shear.
struct WalkRay {
    o: Vec3,
    d: Vec3,
    inv_d: Vec3,
    tri: TriangleRay,
}

impl WalkRay {
    fn new(o: Vec3, d: Vec3) -> WalkRay {
        let safe = |x: f32| {
            if x.abs() < MIN_DIR {
                if x < 0.0 {
                    -MIN_DIR
                } else {
                    MIN_DIR
                }
            } else {
                x
            }
        };
        let inv_d = Vec3::ONE / Vec3::new(safe(d.x), safe(d.y), safe(d.z));
        WalkRay { o, d, inv_d, tri: TriangleRay::new(o, d) }
    }

    /// The slab test: the distance where the ray enters the box, if it meets it
    /// within (0, t_max), the exit scaled by [`EXIT_SCALE`] so that rounding never culls.
    fn enters(&self, lo: [f32; 3], hi: [f32; 3], t_max: f32) -> Option<f32> {
        let t0 = (Vec3::from(lo) - self.o) * self.inv_d;
        let t1 = (Vec3::from(hi) - self.o) * self.inv_d;
        let (near, far) = (t0.min(t1), t0.max(t1));
        let enter = near.x.max(near.y).max(near.z.max(0.0));
        let exit = far.x.min(far.y).min(far.z.min(t_max)) * EXIT_SCALE;
        (enter <= exit).then_some(enter)
    }

    /// The distance to primitive `r` in (0, t_max).
    fn prim_t(&self, s: &SceneArrays, r: u32, t_max: f32) -> Option<f32> {
        let (kind, i) = prim_kind_index(r);
        let i = i as usize;
        match kind {
            shared::PRIM_TRIANGLE => {
                let [a, b, c] = s.triangles[i].vertices();
                self.tri.intersect(a, b, c, t_max)
            }
            shared::PRIM_SPHERE => intersect_sphere(&s.spheres[i], self.o, self.d, t_max),
            _ => intersect_quad(&s.quads[i], self.o, self.d, t_max),
        }
    }

    /// Whether primitive `r` blocks the segment (0, t_max): spheres by
    /// `sphere_blocks`, as `crate::math::geometry::occluded` tests them.
    fn prim_blocks(&self, s: &SceneArrays, r: u32, t_max: f32) -> bool {
        let (kind, i) = prim_kind_index(r);
        if kind == shared::PRIM_SPHERE {
            return sphere_blocks(&s.spheres[i as usize], self.o, self.d, t_max);
        }
        self.prim_t(s, r, t_max).is_some()
    }
}

/// One node's children as the walk sees them: which it enters, where, nearer first.
struct Children {
    /// (child word, count, entry distance) of each child the ray enters, nearer first.
    entered: [(u32, u32, f32); 2],
    len: usize,
}

fn children(ray: &WalkRay, n: &GpuBvhNode, t_max: f32) -> Children {
    let a = ray.enters(n.a_lo, n.a_hi, t_max).map(|t| (n.a_child, n.a_count, t));
    let b = ray.enters(n.b_lo, n.b_hi, t_max).map(|t| (n.b_child, n.b_count, t));
    let none = (0, 0, 0.0);
    match (a, b) {
        (Some(a), Some(b)) if b.2 < a.2 => Children { entered: [b, a], len: 2 },
        (Some(a), Some(b)) => Children { entered: [a, b], len: 2 },
        (Some(x), None) | (None, Some(x)) => Children { entered: [x, none], len: 1 },
        (None, None) => Children { entered: [none, none], len: 0 },
    }
}

/// The walk shared by [`closest_hit`] and [`occluded`]: `leaf` tests a leaf's
/// references against the current `t_max` and returns the new one (or `None` to
/// stop the walk). Leaves are tested where they are met, nearer first; of the
/// interior children met, the nearer is walked next and the farther pushed.
/// `glsl/bvh.glsl` `bvh_walk` (its `any_hit` picking the leaf test).
fn walk(s: &SceneArrays, ray: &WalkRay, mut t_max: f32, mut leaf: impl FnMut(&[u32], f32) -> Option<f32>) {
    if s.bvh_nodes.is_empty() {
        return;
    }
    let mut stack = [0u32; shared::BVH_STACK as usize];
    let mut sp = 0;
    let mut node = 0u32;
    loop {
        let c = children(ray, &s.bvh_nodes[node as usize], t_max);
        let mut next = [0u32; 2];
        let mut inner = 0;
        for &(child, count, enter) in &c.entered[..c.len] {
            // A leaf before may have brought t_max nearer than this child.
            if enter > t_max * EXIT_SCALE {
                continue;
            }
            if child & shared::BVH_LEAF != 0 {
                let first = (child & !shared::BVH_LEAF) as usize;
                match leaf(&s.prim_refs[first..first + count as usize], t_max) {
                    Some(t) => t_max = t,
                    None => return,
                }
            } else {
                next[inner] = child;
                inner += 1;
            }
        }
        node = match inner {
            2 => {
                stack[sp] = next[1];
                sp += 1;
                next[0]
            }
            1 => next[0],
            _ if sp == 0 => return,
            _ => {
                sp -= 1;
                stack[sp]
            }
        };
    }
}

/// The nearest primitive the ray from `o` along unit `d` meets in (0, t_max):
/// its distance and reference. `glsl/bvh.glsl` `bvh_closest`.
pub fn closest_hit(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
    let ray = WalkRay::new(o, d);
    let mut found = None;
    walk(s, &ray, t_max, |refs, mut best| {
        for &r in refs {
            if let Some(t) = ray.prim_t(s, r, best) {
                best = t;
                found = Some((t, r));
            }
        }
        Some(best)
    });
    found
}

/// Whether anything but the primitive `skip` (a reference, or `shared::NO_PRIM`)
/// blocks the segment from `o` to `o + t_max d` (`d` unit): the walk stops at the
/// first blocker. `glsl/bvh.glsl` `bvh_occluded`.
pub fn occluded(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32, skip: u32) -> bool {
    let ray = WalkRay::new(o, d);
    let mut blocked = false;
    walk(s, &ray, t_max, |refs, t| {
        blocked = refs.iter().any(|&r| r != skip && ray.prim_blocks(s, r, t));
        (!blocked).then_some(t)
    });
    blocked
}
