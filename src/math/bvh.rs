//! The BVH over every primitive of a scene: built here on the CPU (binned SAH),
//! walked by [`closest_hit`] and [`occluded`] here and by their twins in
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
use rayon::prelude::*;

/// A primitive to build over: its reference (`crate::layout::prim_ref`) and its box.
#[derive(Clone, Copy, Debug)]
pub struct PrimBox {
    pub prim: u32,
    pub lo: Vec3,
    pub hi: Vec3,
}

impl PrimBox {
    /// Sphere `i`'s box: centre -+ radius.
    pub fn sphere(i: u32, s: &GpuSphere) -> PrimBox {
        let (c, r) = (Vec3::new(s.center_radius[0], s.center_radius[1], s.center_radius[2]), s.center_radius[3]);
        PrimBox { prim: prim_ref(shared::PRIM_SPHERE, i), lo: c - r, hi: c + r }
    }

    /// Quad `i`'s box: around its four corners.
    pub fn quad(i: u32, q: &GpuQuad) -> PrimBox {
        let xyz = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
        let (o, u, v) = (xyz(q.origin), xyz(q.edge_u), xyz(q.edge_v));
        let corners = [o, o + u, o + v, o + u + v];
        let lo = corners.iter().fold(Vec3::INFINITY, |a, &c| a.min(c));
        let hi = corners.iter().fold(Vec3::NEG_INFINITY, |a, &c| a.max(c));
        PrimBox { prim: prim_ref(shared::PRIM_QUAD, i), lo, hi }
    }

    /// Triangle `i`'s box: around its three vertices.
    pub fn triangle(i: u32, t: &GpuTriangle) -> PrimBox {
        let [a, b, c] = t.vertices();
        PrimBox { prim: prim_ref(shared::PRIM_TRIANGLE, i), lo: a.min(b).min(c), hi: a.max(b).max(c) }
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

/// SAH bins per axis, over the centroids' bounds.
const BINS: usize = 32;
/// SAH costs of a node visit (one read, two box tests) and of a primitive test.
const COST_NODE: f32 = 1.0;
const COST_PRIM: f32 = 1.0;
/// Leaves of up to this many primitives where the SAH prefers them to a split.
pub const MAX_LEAF: usize = 4;
/// The most nodes on a path; kept below `BVH_STACK` with room to spare.
pub const MAX_DEPTH: u32 = shared::BVH_STACK - 8;
/// Subtrees of at least this many primitives are built in parallel, and nodes of
/// at least `PAR_BINNING` bin and bound their primitives in parallel.
const PAR_SUBTREE: usize = 2048;
const PAR_BINNING: usize = 1 << 16;
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
    /// Half the surface area (0 for an empty box).
    fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// A primitive during the build: its box, its centroid (times 2) and reference.
#[derive(Clone, Copy)]
struct Item {
    b: Aabb,
    c: Vec3,
    prim: u32,
}

/// The build's tree before it is laid out: a leaf (a range of the items) or two children.
enum Tree {
    Leaf { first: u32, count: u32 },
    Inner(Box<[(Aabb, Tree); 2]>),
}

#[derive(Clone, Copy)]
struct Bin {
    b: Aabb,
    n: u32,
}

type Bins = [[Bin; BINS]; 3];
const EMPTY_BIN: Bin = Bin { b: Aabb::EMPTY, n: 0 };

/// The bin of centroid `c` along `axis`, from the centroids' bounds.
fn bin_of(c: Vec3, axis: usize, c_lo: Vec3, scale: Vec3) -> usize {
    (((c[axis] - c_lo[axis]) * scale[axis]) as usize).min(BINS - 1)
}

fn bin_items(items: &[Item], c_lo: Vec3, scale: Vec3) -> Box<Bins> {
    let bin_seq = |items: &[Item]| {
        let mut bins = Box::new([[EMPTY_BIN; BINS]; 3]);
        for it in items {
            for (axis, axis_bins) in bins.iter_mut().enumerate() {
                let bin = &mut axis_bins[bin_of(it.c, axis, c_lo, scale)];
                bin.b.grow(&it.b);
                bin.n += 1;
            }
        }
        bins
    };
    if items.len() < PAR_BINNING {
        return bin_seq(items);
    }
    items.par_chunks(PAR_BINNING / 4).map(bin_seq).reduce_with(merge_bins).expect("items")
}

fn merge_bins(mut a: Box<Bins>, b: Box<Bins>) -> Box<Bins> {
    for (aa, ba) in a.iter_mut().zip(b.iter()) {
        for (x, y) in aa.iter_mut().zip(ba.iter()) {
            x.b.grow(&y.b);
            x.n += y.n;
        }
    }
    a
}

/// The bounds of the items' centroids.
fn centroid_bounds(items: &[Item]) -> Aabb {
    let seq = |items: &[Item]| {
        let mut b = Aabb::EMPTY;
        items.iter().for_each(|it| b.grow_point(it.c));
        b
    };
    if items.len() < PAR_BINNING {
        return seq(items);
    }
    items.par_chunks(PAR_BINNING / 4).map(seq).reduce_with(|a, b| a.union(&b)).expect("items")
}

/// The best binned SAH split: (cost, axis, last bin on the left, left box, right box).
fn best_split(bins: &Bins) -> Option<(f32, usize, usize, Aabb, Aabb)> {
    let mut best: Option<(f32, usize, usize, Aabb, Aabb)> = None;
    for (axis, bins) in bins.iter().enumerate() {
        // Right-to-left sweep: the count and box right of a split after bin i.
        let mut right = [(0u32, Aabb::EMPTY); BINS];
        let (mut b, mut n) = (Aabb::EMPTY, 0u32);
        for i in (1..BINS).rev() {
            b.grow(&bins[i].b);
            n += bins[i].n;
            right[i - 1] = (n, b);
        }
        let (mut b, mut n) = (Aabb::EMPTY, 0u32);
        for i in 0..BINS - 1 {
            b.grow(&bins[i].b);
            n += bins[i].n;
            let (rn, rb) = right[i];
            if n == 0 || rn == 0 {
                continue;
            }
            let cost = n as f32 * b.half_area() + rn as f32 * rb.half_area();
            if best.as_ref().is_none_or(|x| cost < x.0) {
                best = Some((cost, axis, i, b, rb));
            }
        }
    }
    best
}

/// Builds the subtree of `items`, which start at `first` in the final order and
/// lie in `bounds`; its node is at level `depth` (the root's is 1).
fn build_node(items: &mut [Item], first: usize, bounds: Aabb, depth: u32) -> Tree {
    let n = items.len();
    let leaf = Tree::Leaf { first: first as u32, count: n as u32 };
    if n <= 1 {
        return leaf;
    }
    let cb = centroid_bounds(items);
    let extent = cb.hi - cb.lo;
    if extent.max_element() <= 0.0 {
        return leaf; // centroids coincide: no split separates them
    }
    // Levels a balanced split of the rest needs; past the budget, split at the median.
    let balanced_levels = usize::BITS - (n.div_ceil(MAX_LEAF) - 1).leading_zeros();
    let (mid, lbox, rbox) = if depth + balanced_levels + 1 >= MAX_DEPTH {
        if n <= MAX_LEAF {
            return leaf;
        }
        median_split(items, extent)
    } else {
        let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), BINS as f32 / extent, Vec3::ZERO) * (1.0 - 1e-6);
        let bins = bin_items(items, cb.lo, scale);
        let Some((cost, axis, split, lbox, rbox)) = best_split(&bins) else {
            let (mid, l, r) = median_split(items, extent);
            return inner(items, first, depth, mid, l, r);
        };
        let split_cost = COST_NODE + COST_PRIM * cost / bounds.half_area().max(f32::MIN_POSITIVE);
        if n <= MAX_LEAF && n as f32 * COST_PRIM <= split_cost {
            return leaf;
        }
        let mid = partition(items, |it| bin_of(it.c, axis, cb.lo, scale) <= split);
        (mid, lbox, rbox)
    };
    inner(items, first, depth, mid, lbox, rbox)
}

fn inner(items: &mut [Item], first: usize, depth: u32, mid: usize, lbox: Aabb, rbox: Aabb) -> Tree {
    let (l, r) = items.split_at_mut(mid);
    let (lt, rt) = if l.len().min(r.len()) >= PAR_SUBTREE {
        rayon::join(|| build_node(l, first, lbox, depth + 1), || build_node(r, first + mid, rbox, depth + 1))
    } else {
        (build_node(l, first, lbox, depth + 1), build_node(r, first + mid, rbox, depth + 1))
    };
    Tree::Inner(Box::new([(lbox, lt), (rbox, rt)]))
}

/// Splits at the median centroid along the axis of the largest centroid extent.
fn median_split(items: &mut [Item], extent: Vec3) -> (usize, Aabb, Aabb) {
    let axis = extent.max_position();
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.c[axis].total_cmp(&b.c[axis]));
    let bound = |items: &[Item]| items.iter().fold(Aabb::EMPTY, |a, it| a.union(&it.b));
    (mid, bound(&items[..mid]), bound(&items[mid..]))
}

/// Moves the items for which `left` holds to the front; returns how many.
fn partition(items: &mut [Item], left: impl Fn(&Item) -> bool) -> usize {
    let mut i = 0;
    let mut j = items.len();
    loop {
        while i < j && left(&items[i]) {
            i += 1;
        }
        while i < j && !left(&items[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        items.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// A node's box grown by [`BOX_PAD`].
fn padded(b: &Aabb) -> ([f32; 3], [f32; 3]) {
    let pad = b.lo.abs().max(b.hi.abs()).max_element() * BOX_PAD;
    ((b.lo - pad).into(), (b.hi + pad).into())
}

/// Lays the tree out depth first (a node's first child right after it); returns
/// the node's index and the depth below it.
fn lay_out(children: &[(Aabb, Tree); 2], nodes: &mut Vec<GpuBvhNode>) -> (u32, u32) {
    let index = nodes.len() as u32;
    nodes.push(GpuBvhNode::default());
    let mut words = [(0u32, 0u32); 2];
    let mut depth = 1;
    for (k, (_, tree)) in children.iter().enumerate() {
        words[k] = match tree {
            Tree::Leaf { first, count } => (shared::BVH_LEAF | first, *count),
            Tree::Inner(c) => {
                let (child, d) = lay_out(c, nodes);
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

/// Builds the BVH over `prims` by binned SAH (`BINS` bins on the centroids'
/// bounds, leaves of up to `MAX_LEAF` where the SAH prefers them, more only where
/// the centroids coincide), subtrees in parallel. Its depth stays at most
/// `BVH_STACK - 8`: near that, nodes split at the median. No primitives, no nodes;
/// one leaf (a single primitive, or a few the SAH keeps together) becomes a root
/// whose second child is an empty leaf.
pub fn build(prims: &[PrimBox]) -> Bvh {
    if prims.is_empty() {
        return Bvh::default();
    }
    let mut items: Vec<Item> =
        prims.par_iter().map(|p| Item { b: Aabb { lo: p.lo, hi: p.hi }, c: p.lo + p.hi, prim: p.prim }).collect();
    let bounds =
        items.par_iter().fold(|| Aabb::EMPTY, |a, it| a.union(&it.b)).reduce(|| Aabb::EMPTY, |a, b| a.union(&b));
    let tree = build_node(&mut items, 0, bounds, 1);
    let children = match tree {
        Tree::Inner(c) => c,
        // The root as a leaf: the second child holds nothing (count 0; its box, a
        // point, costs a ray that meets it no primitive test).
        leaf => Box::new([(bounds, leaf), (Aabb { lo: bounds.lo, hi: bounds.lo }, Tree::Leaf { first: 0, count: 0 })]),
    };
    let mut nodes = Vec::with_capacity(2 * prims.len() / MAX_LEAF.max(2) + 1);
    let (_, depth) = lay_out(&children, &mut nodes);
    let prim_refs = items.iter().map(|it| it.prim).collect();
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
