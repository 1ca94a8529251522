//! The BVH over every primitive of a scene: built on the CPU (`build.rs`: binned
//! SAH with spatial splits), walked by [`closest_hit`] and [`occluded`] here and by their twins in
//! `glsl/bvh.glsl` (`bvh_closest`, `bvh_occluded`), the same walk and the same tests.
//!
//! The tree is 4-wide: each node holds its four children's boxes (`GpuBvhNode`,
//! as vec4s of each coordinate), so that one read of 128 bytes tests all four.
//! The builder makes a binary tree, which `lay_out` collapses. The walk keeps a
//! stack of node indices: at each node it tests the leaves it enters at once
//! (the nearer first), then goes on with the nearest interior child it enters and
//! pushes the others, farthest first.

use super::geometry::{intersect_quad, intersect_sphere, sphere_blocks};
use super::triangle::TriangleRay;
use super::Vec3;
use crate::layout::{prim_kind_index, prim_ref, GpuBvhNode, GpuQuad, GpuSphere, GpuTriangle, SceneArrays};
use crate::shared;
pub use build::{Tree, MAX_DEPTH, MAX_LEAF};
use glam::Vec4;

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
    /// walk's stack holds at most 3 (depth - 1) entries.
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

/// An axis-aligned box: a node's bounds while the tree is built.
#[derive(Clone, Copy, Debug)]
pub struct Aabb {
    pub lo: Vec3,
    pub hi: Vec3,
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

/// The children a node of the 4-wide tree takes from its binary node's two:
/// while fewer than 4, the interior child of the largest area is opened (replaced
/// in place by its own two). Leaves stay leaves.
fn collapse(children: &[(Aabb, Tree); 2]) -> Vec<&(Aabb, Tree)> {
    let mut wide: Vec<&(Aabb, Tree)> = children.iter().collect();
    while wide.len() < 4 {
        let largest = wide
            .iter()
            .enumerate()
            .filter(|(_, (_, t))| matches!(t, Tree::Inner(_)))
            .max_by(|a, b| a.1 .0.half_area().total_cmp(&b.1 .0.half_area()));
        let Some((k, &(_, Tree::Inner(c)))) = largest else { break };
        wide.splice(k..=k, c.iter());
    }
    wide
}

/// Lays the 4-wide tree out depth first (a node's first interior child right
/// after it, a leaf's references appended as it is met), collapsing the binary
/// tree as it goes ([`collapse`]); returns the node's index and the depth below it.
fn lay_out(children: &[(Aabb, Tree); 2], nodes: &mut Vec<GpuBvhNode>, refs: &mut Vec<u32>) -> (u32, u32) {
    let index = nodes.len() as u32;
    nodes.push(GpuBvhNode::default());
    let mut node = GpuBvhNode::default();
    let mut depth = 1;
    for (k, (b, tree)) in collapse(children).into_iter().enumerate() {
        (node.child[k], node.count[k]) = match tree {
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
        let (lo, hi) = padded(b);
        node.set_box(k, lo, hi);
    }
    nodes[index as usize] = node;
    (index, depth)
}

/// Builds the BVH over `prims` (`build.rs`): binned SAH over the centroids and,
/// where the children of the best object split overlap, over spatial planes that
/// clip the triangles, within a budget of added references (a triangle may then
/// lie in several leaves, at most once in each); leaves of up to `MAX_LEAF` where
/// the SAH prefers them, more only where the centroids coincide; subtrees in
/// parallel. Its depth stays at most `MAX_DEPTH`: near that, nodes split at
/// the median. No primitives, no nodes; one leaf (a single primitive, or a few the
/// SAH keeps together) becomes a root of that leaf and three empty slots. The
/// binary tree is then collapsed into the 4-wide one the walk takes ([`from_tree`]).
pub fn build(prims: &[PrimBox]) -> Bvh {
    build_with(prims, true)
}

/// [`build`], with or without spatial splits (without, every primitive is in one leaf).
pub fn build_with(prims: &[PrimBox], spatial_splits: bool) -> Bvh {
    if prims.is_empty() {
        return Bvh::default();
    }
    let (tree, bounds) = build::build_tree(prims, spatial_splits);
    from_tree(&tree, bounds)
}

/// Lays a binary tree out as the 4-wide BVH the walk takes: each node takes its
/// binary node's two children and opens the interior child of the largest area
/// until it has four (`collapse`). A root that is a leaf (whose primitives' box
/// is `bounds`) becomes a node of that leaf and three empty slots.
pub fn from_tree(tree: &Tree, bounds: Aabb) -> Bvh {
    let mut nodes = Vec::new();
    let mut prim_refs = Vec::new();
    let depth = match tree {
        Tree::Inner(children) => lay_out(children, &mut nodes, &mut prim_refs).1,
        Tree::Leaf(prims) => {
            let mut root = GpuBvhNode::default();
            (root.child[0], root.count[0]) = (shared::BVH_LEAF, prims.len() as u32);
            let (lo, hi) = padded(&bounds);
            root.set_box(0, lo, hi);
            nodes.push(root);
            prim_refs.extend_from_slice(prims);
            1
        }
    };
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

/// A node's children as the walk takes them: (entry distance, child word, count)
/// of each slot, nearest first; a slot the ray does not enter is
/// (+inf, `shared::BVH_EMPTY`, count).
type Children = [(f32, u32, u32); 4];

/// What walks did, summed by [`closest_hit_counted`] and [`occluded_counted`]
/// (the walk's tool for comparing trees and walks; docs/meshes.md).
#[derive(Clone, Copy, Debug, Default)]
pub struct WalkStats {
    /// Walks summed.
    pub rays: u64,
    /// Interior nodes read.
    pub nodes: u64,
    /// Child boxes slab-tested (slots holding a child).
    pub boxes: u64,
    /// Child boxes the ray entered within its interval.
    pub entered: u64,
    /// Nodes where two children or more were entered at distance 0 (the origin in their boxes).
    pub zero_ties: u64,
    /// Leaves tested.
    pub leaves: u64,
    pub triangles: u64,
    pub quads: u64,
    pub spheres: u64,
    /// Node indices pushed on the stack.
    pub pushes: u64,
    /// Nodes read after the closest hit was found (closest-hit walks that hit).
    pub nodes_after_hit: u64,
    nodes_at_hit: u64,
}

impl WalkStats {
    /// Adds another sum to this one.
    pub fn add(&mut self, o: &WalkStats) {
        self.rays += o.rays;
        self.nodes += o.nodes;
        self.boxes += o.boxes;
        self.entered += o.entered;
        self.zero_ties += o.zero_ties;
        self.leaves += o.leaves;
        self.triangles += o.triangles;
        self.quads += o.quads;
        self.spheres += o.spheres;
        self.pushes += o.pushes;
        self.nodes_after_hit += o.nodes_after_hit;
    }
}

/// What the walk reports as it goes: nothing for `()`, the normal walk (its
/// calls compile away); counts for [`WalkStats`].
trait Tally {
    fn node(&mut self, _n: &GpuBvhNode, _c: &Children) {}
    fn leaf(&mut self) {}
    fn prim(&mut self, _r: u32) {}
    fn push(&mut self) {}
    fn hit(&mut self) {}
}

impl Tally for () {}

impl Tally for WalkStats {
    fn node(&mut self, n: &GpuBvhNode, c: &Children) {
        self.nodes += 1;
        self.boxes += n.child.iter().filter(|&&w| w != shared::BVH_EMPTY).count() as u64;
        let entered = c.iter().filter(|e| e.1 != shared::BVH_EMPTY);
        self.entered += entered.clone().count() as u64;
        self.zero_ties += (entered.filter(|e| e.0 == 0.0).count() > 1) as u64;
    }
    fn leaf(&mut self) {
        self.leaves += 1;
    }
    fn prim(&mut self, r: u32) {
        match prim_kind_index(r).0 {
            shared::PRIM_TRIANGLE => self.triangles += 1,
            shared::PRIM_SPHERE => self.spheres += 1,
            _ => self.quads += 1,
        }
    }
    fn push(&mut self) {
        self.pushes += 1;
    }
    fn hit(&mut self) {
        self.nodes_at_hit = self.nodes;
    }
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

    /// The distances to the near and the far planes of four boxes along one axis:
    /// the near plane is the low one where the direction is positive, so that an
    /// inverted (empty) box is entered at +inf and left at -inf. On a box it is
    /// min and max of the two distances, rounding being monotonic.
    fn planes(&self, lo: [f32; 4], hi: [f32; 4], axis: usize) -> (Vec4, Vec4) {
        let (o, inv) = (Vec4::splat(self.o[axis]), Vec4::splat(self.inv_d[axis]));
        let (near, far) = if self.inv_d[axis] < 0.0 { (hi, lo) } else { (lo, hi) };
        ((Vec4::from(near) - o) * inv, (Vec4::from(far) - o) * inv)
    }

    /// The slab test of node `n`'s four boxes against (0, t_max), the exits scaled
    /// by [`EXIT_SCALE`] so that rounding never culls a box the ray meets; the
    /// children it enters, nearest first with `SORTED` (a sorting network: the
    /// GPU's registers hold it), else in slot order. `glsl/bvh.glsl` `bvh_children`.
    fn children<const SORTED: bool>(&self, n: &GpuBvhNode, t_max: f32) -> Children {
        let (nx, fx) = self.planes(n.lo_x, n.hi_x, 0);
        let (ny, fy) = self.planes(n.lo_y, n.hi_y, 1);
        let (nz, fz) = self.planes(n.lo_z, n.hi_z, 2);
        let enter = nx.max(ny).max(nz.max(Vec4::ZERO));
        let exit = fx.min(fy).min(fz.min(Vec4::splat(t_max))) * EXIT_SCALE;
        let inside = enter.cmple(exit).bitmask();
        let mut c: Children = std::array::from_fn(|k| {
            if inside & (1 << k) != 0 {
                (enter[k], n.child[k], n.count[k])
            } else {
                (f32::INFINITY, shared::BVH_EMPTY, n.count[k])
            }
        });
        // One child or none entered: nothing to order.
        if SORTED && inside.count_ones() > 1 {
            for (i, j) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                if c[j].0 < c[i].0 {
                    c.swap(i, j);
                }
            }
        }
        c
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

    /// The leaf of `count` references from `first` in `prim_refs`: with `ANY_HIT`,
    /// whether one but `skip` blocks (0, best); else `best` and `prim` brought to
    /// its nearest hit nearer than `best`, and false. `glsl/bvh.glsl` `bvh_leaf`.
    #[allow(clippy::too_many_arguments)]
    fn leaf<const ANY_HIT: bool>(
        &self,
        s: &SceneArrays,
        first: u32,
        count: u32,
        skip: u32,
        best: &mut f32,
        prim: &mut u32,
        tally: &mut impl Tally,
    ) -> bool {
        tally.leaf();
        for &r in &s.prim_refs[first as usize..(first + count) as usize] {
            if ANY_HIT {
                if r != skip {
                    tally.prim(r);
                    if self.prim_blocks(s, r, *best) {
                        return true;
                    }
                }
            } else {
                tally.prim(r);
                if let Some(t) = self.prim_t(s, r, *best) {
                    (*best, *prim) = (t, r);
                    tally.hit();
                }
            }
        }
        false
    }
}

/// The walk shared by [`closest_hit`] (`ANY_HIT` false: the nearest primitive in
/// (0, t_max), its distance and reference, or `shared::NO_PRIM`) and [`occluded`]
/// (`ANY_HIT` true: whether anything but `skip` blocks (0, t_max); the first
/// blocker ends the walk; its children are taken in slot order, unsorted). Each
/// node is read once; the leaves the ray enters are
/// tested there, the nearer first; of the interior children it enters, the walk
/// goes on with the nearest and pushes the others, farthest first.
/// `glsl/bvh.glsl` `bvh_walk`.
fn walk<const ANY_HIT: bool>(
    s: &SceneArrays,
    ray: &WalkRay,
    t_max: f32,
    skip: u32,
    tally: &mut impl Tally,
) -> (bool, f32, u32) {
    let (mut best, mut prim) = (t_max, shared::NO_PRIM);
    if s.bvh_nodes.is_empty() {
        return (false, best, prim);
    }
    let mut stack = [0u32; shared::BVH_STACK as usize];
    let mut sp = 0;
    let mut node = 0u32;
    loop {
        // Shadow rays take the children in slot order: any blocker ends the walk, and
        // the nearest first walked bunny-door's bunny before the wall that blocks (docs/meshes.md).
        let n = &s.bvh_nodes[node as usize];
        let c = if ANY_HIT { ray.children::<false>(n, best) } else { ray.children::<true>(n, best) };
        tally.node(n, &c);
        // A leaf before may bring best nearer than the children after it (not
        // with ANY_HIT, whose best stays t_max, which the slab test bounds).
        let beyond = |enter: f32, best: f32| !ANY_HIT && enter > best * EXIT_SCALE;
        for &(enter, child, count) in &c {
            if child == shared::BVH_EMPTY || child & shared::BVH_LEAF == 0 || beyond(enter, best) {
                continue;
            }
            if ray.leaf::<ANY_HIT>(s, child & !shared::BVH_LEAF, count, skip, &mut best, &mut prim, tally) {
                return (true, best, prim);
            }
        }
        // The interior children, farthest first: all but the nearest pushed.
        let mut next = shared::BVH_EMPTY;
        for &(enter, child, _) in c.iter().rev() {
            // BVH_EMPTY has the leaf bit.
            if child & shared::BVH_LEAF != 0 || beyond(enter, best) {
                continue;
            }
            if next != shared::BVH_EMPTY {
                stack[sp] = next;
                sp += 1;
                tally.push();
            }
            next = child;
        }
        node = if next != shared::BVH_EMPTY {
            next
        } else if sp == 0 {
            break;
        } else {
            sp -= 1;
            stack[sp]
        };
    }
    (prim != shared::NO_PRIM, best, prim)
}

/// The nearest primitive the ray from `o` along unit `d` meets in (0, t_max):
/// its distance and reference. `glsl/bvh.glsl` `bvh_closest`.
pub fn closest_hit(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
    let (hit, t, prim) = walk::<false>(s, &WalkRay::new(o, d), t_max, shared::NO_PRIM, &mut ());
    hit.then_some((t, prim))
}

/// Whether anything but the primitive `skip` (a reference, or `shared::NO_PRIM`)
/// blocks the segment from `o` to `o + t_max d` (`d` unit): the walk stops at the
/// first blocker. `glsl/bvh.glsl` `bvh_occluded`.
pub fn occluded(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32, skip: u32) -> bool {
    walk::<true>(s, &WalkRay::new(o, d), t_max, skip, &mut ()).0
}

/// [`closest_hit`], its walk counted into `stats`.
pub fn closest_hit_counted(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32, stats: &mut WalkStats) -> Option<(f32, u32)> {
    let mut one = WalkStats { rays: 1, ..WalkStats::default() };
    let (hit, t, prim) = walk::<false>(s, &WalkRay::new(o, d), t_max, shared::NO_PRIM, &mut one);
    if hit {
        one.nodes_after_hit = one.nodes - one.nodes_at_hit;
    }
    stats.add(&one);
    hit.then_some((t, prim))
}

/// [`occluded`], its walk counted into `stats`.
pub fn occluded_counted(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32, skip: u32, stats: &mut WalkStats) -> bool {
    let mut one = WalkStats { rays: 1, ..WalkStats::default() };
    let blocked = walk::<true>(s, &WalkRay::new(o, d), t_max, skip, &mut one).0;
    stats.add(&one);
    blocked
}
