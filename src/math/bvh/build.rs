//! The BVH builder: top-down binned SAH with spatial splits (Stich, Friedrich and
//! Dietrich 2009, "Spatial Splits in Bounding Volume Hierarchies"). docs/meshes.md
//! says why spatial splits and how the reference budget was chosen.

use super::{Aabb, PrimBox, Vec3, BOX_PAD};
use crate::shared;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// SAH bins per axis: object splits over the centroids' bounds, spatial splits
/// over the node's box.
const BINS: usize = 32;
/// SAH costs of a node visit (one read, two box tests) and of a primitive test.
const COST_NODE: f32 = 1.0;
const COST_PRIM: f32 = 1.0;
/// Leaves of up to this many primitives where the SAH prefers them to a split.
pub const MAX_LEAF: usize = 4;
/// The most nodes on a path of the binary tree, and so of the 4-wide one made
/// from it; the walk pushes up to 3 children per level, which its stack holds.
pub const MAX_DEPTH: u32 = 56;
const _: () = assert!(3 * (MAX_DEPTH - 1) <= shared::BVH_STACK);
/// Spatial splits are tried where the object split's children overlap by more
/// than this fraction of the root's area (Stich et al.'s alpha).
const SPATIAL_ALPHA: f32 = 1e-3;
/// References spatial splits may add, as a fraction of the primitives.
const SPATIAL_BUDGET: f32 = 0.25;
/// Subtrees of at least this many references are built in parallel, and nodes of
/// at least `PAR_BINNING` bin and bound their references in parallel.
const PAR_SUBTREE: usize = 2048;
const PAR_BINNING: usize = 1 << 16;

/// A reference during the build: its box (a whole primitive's, or the part of it
/// a spatial split left on one side), its box's centre times 2, and its primitive
/// (an index into the builder's `PrimBox`es).
#[derive(Clone, Copy)]
struct Item {
    b: Aabb,
    c: Vec3,
    prim: u32,
}

impl Item {
    fn new(b: Aabb, prim: u32) -> Item {
        Item { b, c: b.lo + b.hi, prim }
    }
}

/// The binary tree the builder makes, before `super::from_tree` collapses and lays
/// it out: a leaf's primitive references, or two children with their boxes.
pub enum Tree {
    Leaf(Vec<u32>),
    Inner(Box<[(Aabb, Tree); 2]>),
}

#[derive(Clone, Copy)]
struct Bin {
    b: Aabb,
    n: u32,
}

const EMPTY_BIN: Bin = Bin { b: Aabb::EMPTY, n: 0 };

/// A spatial bin: the clipped boxes in it, the references starting in it and those ending in it.
#[derive(Clone, Copy)]
struct SpatialBin {
    b: Aabb,
    enter: u32,
    exit: u32,
}

const EMPTY_SPATIAL: SpatialBin = SpatialBin { b: Aabb::EMPTY, enter: 0, exit: 0 };

/// A bin that takes in another's boxes and counts: parallel chunks' bins merge so.
trait MergeBin {
    fn merge(&mut self, other: &Self);
}

impl MergeBin for Bin {
    fn merge(&mut self, o: &Bin) {
        self.b.grow(&o.b);
        self.n += o.n;
    }
}

impl MergeBin for SpatialBin {
    fn merge(&mut self, o: &SpatialBin) {
        self.b.grow(&o.b);
        self.enter += o.enter;
        self.exit += o.exit;
    }
}

/// `a` with each of `b`'s bins merged into its own, axis by axis.
fn merge_bins<B: MergeBin, const AXES: usize>(
    mut a: Box<[[B; BINS]; AXES]>,
    b: &[[B; BINS]; AXES],
) -> Box<[[B; BINS]; AXES]> {
    for (aa, ba) in a.iter_mut().zip(b.iter()) {
        for (x, y) in aa.iter_mut().zip(ba.iter()) {
            x.merge(y);
        }
    }
    a
}

/// The best split found at a node: its SAH cost (areas times counts, unnormalised),
/// the children's boxes and what to partition by.
#[derive(Clone, Copy)]
struct Split {
    cost: f32,
    axis: usize,
    kind: SplitKind,
    lbox: Aabb,
    rbox: Aabb,
    counts: [u32; 2],
}

#[derive(Clone, Copy)]
enum SplitKind {
    /// Centroid bins up to this one go left.
    Object(usize),
    /// References wholly below this plane go left, above it right; the rest are split or moved.
    Spatial(f32),
}

/// Maps a coordinate along `axis` to its bin over `[lo, lo + BINS / scale)`.
fn bin_of(x: f32, axis: usize, lo: Vec3, scale: Vec3) -> usize {
    (((x - lo[axis]) * scale[axis]).max(0.0) as usize).min(BINS - 1)
}

/// Runs `f` over the items, in parallel chunks where there are many, merging the results.
fn fold_items<T: Send>(
    items: &[Item],
    f: impl Fn(&[Item]) -> T + Sync + Send,
    merge: impl Fn(T, T) -> T + Sync + Send,
) -> T {
    if items.len() < PAR_BINNING {
        return f(items);
    }
    items.par_chunks(PAR_BINNING / 4).map(f).reduce_with(merge).expect("items")
}

/// The bounds of the items' boxes and of their centroids.
fn bounds_of(items: &[Item]) -> (Aabb, Aabb) {
    fold_items(
        items,
        |items| {
            let (mut b, mut c) = (Aabb::EMPTY, Aabb::EMPTY);
            for it in items {
                b.grow(&it.b);
                c.grow_point(it.c);
            }
            (b, c)
        },
        |a, b| (a.0.union(&b.0), a.1.union(&b.1)),
    )
}

/// The SAH sweep over one axis's bins: for each plane between bins, the left and
/// right counts and boxes; returns the cheapest as (cost, plane, boxes, counts).
fn sweep(bins: &[(Aabb, u32, u32); BINS]) -> Option<(f32, usize, Aabb, Aabb, [u32; 2])> {
    let mut right = [(0u32, Aabb::EMPTY); BINS];
    let (mut b, mut n) = (Aabb::EMPTY, 0u32);
    for i in (1..BINS).rev() {
        b.grow(&bins[i].0);
        n += bins[i].2;
        right[i - 1] = (n, b);
    }
    let (mut b, mut n) = (Aabb::EMPTY, 0u32);
    let mut best: Option<(f32, usize, Aabb, Aabb, [u32; 2])> = None;
    for i in 0..BINS - 1 {
        b.grow(&bins[i].0);
        n += bins[i].1;
        let (rn, rb) = right[i];
        if n == 0 || rn == 0 {
            continue;
        }
        let cost = n as f32 * b.half_area() + rn as f32 * rb.half_area();
        if best.as_ref().is_none_or(|x| cost < x.0) {
            best = Some((cost, i, b, rb, [n, rn]));
        }
    }
    best
}

/// How a node's references fall into object bins: along axes 0 to 2 by centroid
/// over the centroids' bounds; along "axis" 3 by size, one bin per halving of the
/// box's area from the node's (the largest first), so that a split can set the
/// few big references apart from the many small ones their centroids lie among.
#[derive(Clone, Copy)]
struct ObjectBins {
    lo: Vec3,
    scale: Vec3,
    node_area: f32,
}

/// The object bins' axes: the three centroid axes and size.
const OBJECT_AXES: usize = 4;

impl ObjectBins {
    fn bin(&self, it: &Item, axis: usize) -> usize {
        if axis < 3 {
            return bin_of(it.c[axis], axis, self.lo, self.scale);
        }
        let halvings = (self.node_area / it.b.half_area().max(f32::MIN_POSITIVE)).log2();
        (halvings.max(0.0) as usize).min(BINS - 1)
    }
}

/// The best binned object split (centroids in `BINS` bins per axis over `cb`, and
/// sizes against `node_area`) and the binning it partitions by.
fn object_split(items: &[Item], cb: &Aabb, node_area: f32) -> Option<(Split, ObjectBins)> {
    let extent = cb.hi - cb.lo;
    let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), BINS as f32 / extent, Vec3::ZERO) * (1.0 - 1e-6);
    let ob = ObjectBins { lo: cb.lo, scale, node_area };
    let bins = fold_items(
        items,
        |items| {
            let mut bins = Box::new([[EMPTY_BIN; BINS]; OBJECT_AXES]);
            for it in items {
                for (axis, axis_bins) in bins.iter_mut().enumerate() {
                    let bin = &mut axis_bins[ob.bin(it, axis)];
                    bin.b.grow(&it.b);
                    bin.n += 1;
                }
            }
            bins
        },
        |a, b| merge_bins(a, &b),
    );
    let mut best: Option<Split> = None;
    for (axis, bins) in bins.iter().enumerate() {
        if axis < 3 && extent[axis] <= 0.0 {
            continue;
        }
        let b: [(Aabb, u32, u32); BINS] = std::array::from_fn(|i| (bins[i].b, bins[i].n, bins[i].n));
        if let Some((cost, i, lbox, rbox, counts)) = sweep(&b) {
            if best.as_ref().is_none_or(|x| cost < x.cost) {
                best = Some(Split { cost, axis, kind: SplitKind::Object(i), lbox, rbox, counts });
            }
        }
    }
    best.map(|s| (s, ob))
}

/// The boxes of the parts of triangle `tri` (within its reference's box `b`)
/// below and above the plane at `pos` along `axis`: clipped in f64, rounded
/// outwards, grown by `pad` (the whole triangle's `BOX_PAD`), so that they hold
/// every point the triangle test can report, and cut to `b` (grown alike) and at
/// the plane, where the two boxes meet. An empty side gives an empty box.
fn split_triangle(tri: &[Vec3; 3], pad: f32, b: &Aabb, axis: usize, pos: f32) -> (Aabb, Aabb) {
    let v = tri.map(|v| v.as_dvec3());
    let plane = pos as f64;
    // Boxes as (lo, -hi), so that one min grows both ends.
    let (mut l, mut r) = ([f64::INFINITY; 6], [f64::INFINITY; 6]);
    let grow = |bx: &mut [f64; 6], q: glam::DVec3| {
        for k in 0..3 {
            bx[k] = bx[k].min(q[k]);
            bx[k + 3] = bx[k + 3].min(-q[k]);
        }
    };
    for i in 0..3 {
        let (a, c) = (v[i], v[(i + 1) % 3]);
        if a[axis] <= plane {
            grow(&mut l, a);
        }
        if a[axis] >= plane {
            grow(&mut r, a);
        }
        if (a[axis] < plane && c[axis] > plane) || (a[axis] > plane && c[axis] < plane) {
            let mut x = a + (c - a) * ((plane - a[axis]) / (c[axis] - a[axis]));
            x[axis] = plane;
            grow(&mut l, x);
            grow(&mut r, x);
        }
    }
    let within = *b;
    let to_f32 = |bx: [f64; 6]| {
        if bx[0] == f64::INFINITY {
            return Aabb::EMPTY;
        }
        let lo = Vec3::from_array(std::array::from_fn(|k| (bx[k] as f32).next_down()));
        let hi = Vec3::from_array(std::array::from_fn(|k| (-bx[k + 3] as f32).next_up()));
        Aabb { lo: lo - pad, hi: hi + pad }.intersect(&within)
    };
    let (mut l, mut r) = (to_f32(l), to_f32(r));
    l.hi[axis] = l.hi[axis].min(pos);
    r.lo[axis] = r.lo[axis].max(pos);
    (l, r)
}

/// A triangle's vertices and the pad its parts' boxes grow by; `None` for spheres
/// and quads, which spatial splits do not cut (they go to their centroid's side).
fn splittable(p: &PrimBox) -> Option<(&[Vec3; 3], f32)> {
    p.tri.as_ref().map(|t| (t, p.lo.abs().max(p.hi.abs()).max_element() * BOX_PAD))
}

/// The plane after spatial bin `i` along `axis` of the node box `nb`.
fn plane(nb: &Aabb, axis: usize, i: usize) -> f32 {
    nb.lo[axis] + (nb.hi[axis] - nb.lo[axis]) * ((i + 1) as f32 / BINS as f32)
}

/// The best binned spatial split over the node box `nb`: each reference enters the
/// bin of its box's low end and leaves at that of its high end, its parts clipped
/// into the bins between.
fn spatial_split(prims: &[PrimBox], items: &[Item], nb: &Aabb) -> Option<Split> {
    let extent = nb.hi - nb.lo;
    let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), BINS as f32 / extent, Vec3::ZERO) * (1.0 - 1e-6);
    let bins = fold_items(
        items,
        |items| {
            let mut bins = Box::new([[EMPTY_SPATIAL; BINS]; 3]);
            for it in items {
                for (axis, axis_bins) in bins.iter_mut().enumerate() {
                    if extent[axis] <= 0.0 {
                        continue;
                    }
                    let Some((tri, pad)) = splittable(&prims[it.prim as usize]) else {
                        let bin = &mut axis_bins[bin_of(it.c[axis] * 0.5, axis, nb.lo, scale)];
                        bin.b.grow(&it.b);
                        bin.enter += 1;
                        bin.exit += 1;
                        continue;
                    };
                    let first = bin_of(it.b.lo[axis], axis, nb.lo, scale);
                    let last = bin_of(it.b.hi[axis], axis, nb.lo, scale).max(first);
                    axis_bins[first].enter += 1;
                    axis_bins[last].exit += 1;
                    let mut rest = it.b;
                    for (i, bin) in axis_bins.iter_mut().enumerate().take(last).skip(first) {
                        let (l, r) = split_triangle(tri, pad, &rest, axis, plane(nb, axis, i));
                        bin.b.grow(&l);
                        rest = r;
                    }
                    axis_bins[last].b.grow(&rest);
                }
            }
            bins
        },
        |a, b| merge_bins(a, &b),
    );
    let mut best: Option<Split> = None;
    for (axis, bins) in bins.iter().enumerate() {
        if extent[axis] <= 0.0 {
            continue;
        }
        let b: [(Aabb, u32, u32); BINS] = std::array::from_fn(|i| (bins[i].b, bins[i].enter, bins[i].exit));
        if let Some((cost, i, lbox, rbox, counts)) = sweep(&b) {
            if best.as_ref().is_none_or(|x| cost < x.cost) {
                let kind = SplitKind::Spatial(plane(nb, axis, i));
                best = Some(Split { cost, axis, kind, lbox, rbox, counts });
            }
        }
    }
    best
}

struct Builder<'a> {
    prims: &'a [PrimBox],
    root_area: f32,
    /// References spatial splits may still add.
    budget: AtomicUsize,
}

impl Builder<'_> {
    /// Builds the subtree of `items`, whose boxes' bounds are `bounds`; its node
    /// is at level `depth` (the root's is 1).
    fn node(&self, mut items: Vec<Item>, bounds: Aabb, depth: u32) -> Tree {
        let n = items.len();
        if n <= 1 {
            return self.leaf(&items);
        }
        let (_, cb) = bounds_of(&items);
        let extent = cb.hi - cb.lo;
        // Levels a balanced split of the rest needs; past the budget, split at the median.
        let balanced_levels = usize::BITS - (n.div_ceil(MAX_LEAF) - 1).leading_zeros();
        let near_limit = depth + balanced_levels + 1 >= MAX_DEPTH;
        if extent.max_element() <= 0.0 || (near_limit && n <= MAX_LEAF) {
            return self.leaf(&items); // centroids coincide: no object split separates them
        }
        let (left, right) = if near_limit {
            median_split(items, extent)
        } else {
            let Some((object, ob)) = object_split(&items, &cb, bounds.half_area()) else {
                return self.children(median_split(items, extent), depth);
            };
            let mut split = object;
            // Spatial splits (never near the depth limit: they may not shrink the count).
            if self.budget.load(Ordering::Relaxed) > 0
                && depth + balanced_levels + 8 < MAX_DEPTH
                && object.lbox.intersect(&object.rbox).half_area() > SPATIAL_ALPHA * self.root_area
            {
                if let Some(s) = spatial_split(self.prims, &items, &bounds) {
                    if s.cost < split.cost {
                        split = s;
                    }
                }
            }
            let split_cost = COST_NODE + COST_PRIM * split.cost / bounds.half_area().max(f32::MIN_POSITIVE);
            if n <= MAX_LEAF && n as f32 * COST_PRIM <= split_cost {
                return self.leaf(&items);
            }
            let spatial = match split.kind {
                SplitKind::Spatial(pos) => self.partition_spatial(&items, &split, pos),
                SplitKind::Object(_) => None,
            };
            spatial.unwrap_or_else(|| {
                let SplitKind::Object(bin) = object.kind else { unreachable!("the object split") };
                let axis = object.axis;
                let mid = partition(&mut items, |it| ob.bin(it, axis) <= bin);
                let right = items.split_off(mid);
                (items, right)
            })
        };
        self.children((left, right), depth)
    }

    fn children(&self, (l, r): (Vec<Item>, Vec<Item>), depth: u32) -> Tree {
        let (lb, rb) = (bounds_of(&l).0, bounds_of(&r).0);
        let (lt, rt) = if l.len().min(r.len()) >= PAR_SUBTREE {
            rayon::join(|| self.node(l, lb, depth + 1), || self.node(r, rb, depth + 1))
        } else {
            (self.node(l, lb, depth + 1), self.node(r, rb, depth + 1))
        };
        Tree::Inner(Box::new([(lb, lt), (rb, rt)]))
    }

    fn leaf(&self, items: &[Item]) -> Tree {
        Tree::Leaf(items.iter().map(|it| self.prims[it.prim as usize].prim).collect())
    }

    /// Partitions at a spatial plane: references on one side go there; one that
    /// straddles is split, or moved whole to the side where that costs less
    /// (Stich et al.'s unsplitting). `None` where the splits would overdraw the
    /// budget or leave a side empty.
    fn partition_spatial(&self, items: &[Item], s: &Split, pos: f32) -> Option<(Vec<Item>, Vec<Item>)> {
        let axis = s.axis;
        let (mut left, mut right) =
            (Vec::with_capacity(s.counts[0] as usize), Vec::with_capacity(s.counts[1] as usize));
        let (al, ar) = (s.lbox.half_area(), s.rbox.half_area());
        let (nl, nr) = (s.counts[0] as f32, s.counts[1] as f32);
        let mut added = 0;
        for it in items {
            let tri = splittable(&self.prims[it.prim as usize]);
            if it.b.hi[axis] <= pos || (tri.is_none() && it.c[axis] * 0.5 < pos) {
                left.push(*it);
            } else if it.b.lo[axis] >= pos || tri.is_none() {
                right.push(*it);
            } else {
                let (tri, pad) = tri.expect("a triangle");
                let (l, r) = split_triangle(tri, pad, &it.b, axis, pos);
                let c_split = al * nl + ar * nr;
                let c_left = s.lbox.union(&it.b).half_area() * nl + ar * (nr - 1.0);
                let c_right = al * (nl - 1.0) + s.rbox.union(&it.b).half_area() * nr;
                if l.is_empty() || (!r.is_empty() && c_right < c_split.min(c_left)) {
                    right.push(*it);
                } else if r.is_empty() || c_left < c_split {
                    left.push(*it);
                } else {
                    left.push(Item::new(l, it.prim));
                    right.push(Item::new(r, it.prim));
                    added += 1;
                }
            }
        }
        if left.is_empty() || right.is_empty() {
            return None;
        }
        self.budget.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |b| b.checked_sub(added)).ok()?;
        Some((left, right))
    }
}

/// Splits at the median centroid along the axis of the largest centroid extent.
fn median_split(mut items: Vec<Item>, extent: Vec3) -> (Vec<Item>, Vec<Item>) {
    let axis = extent.max_position();
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.c[axis].total_cmp(&b.c[axis]));
    let right = items.split_off(mid);
    (items, right)
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

/// Builds the tree over `prims` (at least one) and returns it with the bounds of everything.
pub(super) fn build_tree(prims: &[PrimBox], spatial: bool) -> (Tree, Aabb) {
    // A triangle's box grows by its pad from the start, so that its parts' boxes,
    // grown alike and cut to it, stay inside every box above them.
    let items: Vec<Item> = prims
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let pad = splittable(p).map_or(0.0, |t| t.1);
            Item::new(Aabb { lo: p.lo - pad, hi: p.hi + pad }, i as u32)
        })
        .collect();
    let (bounds, _) = bounds_of(&items);
    let budget = if spatial { (prims.len() as f32 * SPATIAL_BUDGET) as usize } else { 0 };
    let builder = Builder { prims, root_area: bounds.half_area(), budget: AtomicUsize::new(budget) };
    (builder.node(items, bounds, 1), bounds)
}
