//! The builder's trees checked for structure, and the walks against brute force.

use super::build::MAX_DEPTH;
use super::*;
use crate::layout::{prim_ref, GpuTriangle};
use crate::math::rng::Rng;
use crate::math::triangle::intersect_triangle;

fn tri_boxes(tris: &[GpuTriangle]) -> Vec<PrimBox> {
    tris.iter().enumerate().map(|(i, t)| PrimBox::triangle(i as u32, t)).collect()
}

fn scene(triangles: Vec<GpuTriangle>) -> SceneArrays {
    let bvh = build(&tri_boxes(&triangles));
    SceneArrays { bvh_nodes: bvh.nodes, prim_refs: bvh.prim_refs, ..SceneArrays::of_triangles(triangles) }
}

fn tri(a: Vec3, b: Vec3, c: Vec3) -> GpuTriangle {
    GpuTriangle { v0: a.into(), v1: b.into(), v2: c.into(), ..Default::default() }
}

fn random_triangles(n: usize, seed: u32, size: f32) -> Vec<GpuTriangle> {
    let mut rng = Rng::new(seed, 0, 0, 0);
    let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    (0..n)
        .map(|_| {
            let c = r3() * 10.0;
            tri(c, c + (r3() - 0.5) * size, c + (r3() - 0.5) * size)
        })
        .collect()
}

/// Checks the structure: every node reached once, boxes nested, the depth as
/// reported and within the stack; every primitive in a leaf, at most once in each;
/// a primitive in one leaf inside its box, one that spatial splits cut in several
/// covered by their boxes (its vertices, edges and points inside each in one).
fn check(bvh: &Bvh, prims: &[PrimBox]) {
    let index: std::collections::HashMap<u32, usize> = prims.iter().enumerate().map(|(i, p)| (p.prim, i)).collect();
    // The boxes of the leaves that hold each primitive.
    let mut leaves = vec![Vec::<([f32; 3], [f32; 3])>::new(); prims.len()];
    // (node, level, the entries the walk's stack may hold on reaching it: the
    // interior siblings pending at each level above)
    let mut todo = vec![(0u32, 1u32, 0u32)];
    let mut max_pending = 0;
    let mut max_depth = 0;
    let mut reached = 0;
    while let Some((node, depth, pending)) = todo.pop() {
        max_pending = max_pending.max(pending);
        reached += 1;
        max_depth = max_depth.max(depth);
        let n = &bvh.nodes[node as usize];
        let (mut used, mut inner) = (0, 0u32);
        let inner_here = (0..4).filter(|&k| n.child[k] & shared::BVH_LEAF == 0).count() as u32;
        for k in 0..4 {
            let (child, count, (lo, hi)) = (n.child[k], n.count[k], n.slot_box(k));
            if child == shared::BVH_EMPTY {
                // Empty slots come last, inverted, no ray enters them.
                assert_eq!((count, lo, hi), (0, [f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), "an empty slot");
                continue;
            }
            assert_eq!(used, k, "an empty slot before a used one");
            used += 1;
            if child & shared::BVH_LEAF != 0 {
                let first = (child & !shared::BVH_LEAF) as usize;
                let refs = &bvh.prim_refs[first..first + count as usize];
                for (k, r) in refs.iter().enumerate() {
                    assert!(!refs[..k].contains(r), "a primitive twice in one leaf");
                    leaves[index[r]].push((lo, hi));
                }
            } else {
                assert_eq!(count, 0);
                inner += 1;
                // The child's own children lie in this box.
                let (l, h) = bvh.nodes[child as usize].bounds();
                assert!((0..3).all(|k| lo[k] <= l[k] && h[k] <= hi[k]), "nested boxes");
                todo.push((child, depth + 1, pending + inner_here - 1));
            }
        }
        // The collapse opens interior children until there are four: fewer only
        // where all are leaves (a root that is a leaf has one).
        assert!(used == 4 || inner == 0, "a node of {used} children, {inner} interior");
        assert!(used >= 2 || bvh.nodes.len() == 1, "a node of {used} children");
    }
    assert_eq!(reached, bvh.nodes.len(), "every node reached once");
    let inside = |(lo, hi): &([f32; 3], [f32; 3]), p: Vec3| (0..3).all(|k| lo[k] <= p[k] && p[k] <= hi[k]);
    let mut rng = Rng::new(3, 1, 0, 0);
    for (p, boxes) in prims.iter().zip(&leaves) {
        match boxes.len() {
            0 => panic!("primitive {:#x} in no leaf", p.prim),
            1 => assert!(inside(&boxes[0], p.lo) && inside(&boxes[0], p.hi), "leaf box holds its primitive"),
            _ => {
                let v = p.tri.expect("only triangles are split");
                let mut points = vec![v[0], v[1], v[2]];
                for i in 0..3 {
                    for k in 1..8 {
                        points.push(v[i].lerp(v[(i + 1) % 3], k as f32 / 8.0));
                    }
                }
                for _ in 0..32 {
                    let (a, b) = (rng.next_f32(), rng.next_f32());
                    let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                    points.push(v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b);
                }
                for q in points {
                    assert!(boxes.iter().any(|b| inside(b, q)), "{q} of a split triangle in none of its leaves");
                }
            }
        }
    }
    assert!(bvh.prim_refs.len() >= prims.len());
    assert_eq!(max_depth, bvh.depth);
    assert!(bvh.depth <= MAX_DEPTH);
    assert!(max_pending <= shared::BVH_STACK && max_pending <= 3 * (bvh.depth.max(1) - 1));
}

#[test]
fn builds_valid_trees_for_empty_single_coincident_and_random_inputs() {
    let empty = build(&[]);
    assert!(empty.nodes.is_empty() && empty.prim_refs.is_empty() && empty.depth == 0);

    let one = tri_boxes(&random_triangles(1, 1, 1.0));
    let b = build(&one);
    assert_eq!(b.nodes.len(), 1);
    assert_eq!((b.nodes[0].child[0], b.nodes[0].count[0]), (shared::BVH_LEAF, 1));
    assert_eq!(b.nodes[0].child[1..], [shared::BVH_EMPTY; 3]);
    check(&b, &one);
    // The walks find the one triangle through its root's single slot, and the
    // empty slots' inverted boxes let nothing through.
    let s = scene(random_triangles(1, 1, 1.0));
    let [v0, v1, v2] = s.triangles[0].vertices();
    let n = (v1 - v0).cross(v2 - v0).normalize();
    let o = (v0 + v1 + v2) / 3.0 - n;
    let hit = closest_hit(&s, o, n, f32::INFINITY).expect("the one triangle");
    assert!((hit.0 - 1.0).abs() < 1e-4 && hit.1 == prim_ref(shared::PRIM_TRIANGLE, 0), "{hit:?}");
    assert!(occluded(&s, o, n, 2.0, shared::NO_PRIM) && !occluded(&s, o, n, 0.5, shared::NO_PRIM));
    assert_eq!(closest_hit(&s, o, -n, f32::INFINITY), None);

    // Many copies of one triangle: their centroids coincide, one leaf holds them.
    let t = random_triangles(1, 2, 1.0)[0];
    let same: Vec<_> = tri_boxes(&vec![t; 40]);
    let b = build(&same);
    check(&b, &same);
    assert_eq!(b.nodes.len(), 1);

    for n in [2, 3, 5, 17, 1000, 70_000] {
        let prims = tri_boxes(&random_triangles(n, n as u32, 0.3));
        let b = build(&prims);
        check(&b, &prims);
        let max_leaf = b.nodes.iter().flat_map(|n| n.count).max().unwrap();
        assert!(max_leaf as usize <= MAX_LEAF, "{n}: a leaf of {max_leaf}");
    }
}

#[test]
fn depth_stays_within_the_stack_on_a_skewed_input() {
    // Triangles at x = 1.1^k: the SAH peels a few off the far end at each level.
    let tris: Vec<_> = (0..3000)
        .map(|k| {
            let x = 1.01f32.powi(k) - 1.0;
            tri(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1e-3 * (x + 1.0), 1.0, 0.0), Vec3::new(x, 0.0, 1.0))
        })
        .collect();
    let prims = tri_boxes(&tris);
    let b = build(&prims);
    check(&b, &prims);
    let s = scene(tris);
    let mut rng = Rng::new(5, 0, 0, 0);
    for _ in 0..2000 {
        let o = Vec3::new(rng.next_f32() * 30.0, rng.next_f32(), -1.0);
        let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 1.0).normalize();
        assert_eq!(closest_hit(&s, o, d, f32::INFINITY), brute(&s, o, d));
    }
}

fn brute(s: &SceneArrays, o: Vec3, d: Vec3) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    for (i, t) in s.triangles.iter().enumerate() {
        let [a, b, c] = t.vertices();
        if let Some(h) = intersect_triangle(a, b, c, o, d, best.map_or(f32::INFINITY, |b| b.0)) {
            best = Some((h, prim_ref(shared::PRIM_TRIANGLE, i as u32)));
        }
    }
    best
}

#[test]
fn walks_find_what_brute_force_finds_axis_parallel_rays_included() {
    let s = scene(random_triangles(3000, 9, 1.0));
    let mut rng = Rng::new(7, 0, 0, 0);
    let (mut hits, mut ties) = (0, 0);
    for i in 0..20_000 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 14.0 - 2.0;
        let mut d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
        // Directions with zero components: the slab test's 0 * inf.
        if i % 4 == 0 {
            d[i % 3] = 0.0;
        }
        if i % 8 == 0 {
            d[(i + 1) % 3] = 0.0;
        }
        let d = d.normalize();
        let (got, want) = (closest_hit(&s, o, d, f32::INFINITY), brute(&s, o, d));
        assert_eq!(got.map(|g| g.0), want.map(|w| w.0), "ray {o} {d}");
        ties += (got != want) as u32;
        hits += got.is_some() as u32;
        let t_max = want.map_or(5.0, |w| w.0 * 1.5);
        assert_eq!(occluded(&s, o, d, t_max, shared::NO_PRIM), brute(&s, o, d).is_some_and(|w| w.0 < t_max));
        if let Some((t, r)) = want {
            assert!(!occluded(&s, o, d, t * 0.999, shared::NO_PRIM) || brute_any(&s, o, d, t * 0.999, r));
        }
    }
    assert!(hits > 3000 && ties < 5, "{hits} hits, {ties} ties");
}

fn brute_any(s: &SceneArrays, o: Vec3, d: Vec3, t_max: f32, skip: u32) -> bool {
    s.triangles.iter().enumerate().any(|(i, t)| {
        let [a, b, c] = t.vertices();
        prim_ref(shared::PRIM_TRIANGLE, i as u32) != skip && intersect_triangle(a, b, c, o, d, t_max).is_some()
    })
}

/// Small triangles inside a few big ones, slanted (a backdrop about an object):
/// spatial splits cut the big ones, and the walks still find what brute force finds.
#[test]
fn spatial_splits_cut_big_triangles_and_the_walks_still_find_every_hit() {
    let mut tris = random_triangles(3000, 11, 0.3);
    let big = [
        [Vec3::new(-40.0, -3.0, -40.0), Vec3::new(50.0, -3.0, -40.0), Vec3::new(-40.0, 1.0, 50.0)],
        [Vec3::new(50.0, -3.0, 50.0), Vec3::new(50.0, -3.0, -40.0), Vec3::new(-40.0, 1.0, 50.0)],
        [Vec3::new(-30.0, -5.0, 25.0), Vec3::new(45.0, 30.0, 20.0), Vec3::new(-30.0, 30.0, 28.0)],
        [Vec3::new(25.0, -5.0, -30.0), Vec3::new(20.0, 30.0, 45.0), Vec3::new(28.0, 30.0, -30.0)],
    ];
    tris.extend(big.iter().map(|&[a, b, c]| tri(a, b, c)));
    let prims = tri_boxes(&tris);
    let b = build(&prims);
    check(&b, &prims);
    assert!(b.prim_refs.len() > prims.len(), "{} refs: the big triangles were not split", b.prim_refs.len());
    let plain = build_with(&prims, false);
    check(&plain, &prims);
    assert_eq!(plain.prim_refs.len(), prims.len());
    let s = scene(tris);
    let mut rng = Rng::new(13, 0, 0, 0);
    for i in 0..20_000 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 30.0 - 10.0;
        let mut d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
        if i % 4 == 0 {
            d[i % 3] = 0.0;
        }
        let d = d.normalize();
        let want = brute(&s, o, d);
        assert_eq!(closest_hit(&s, o, d, f32::INFINITY).map(|g| g.0), want.map(|w| w.0), "ray {o} {d}");
        let t_max = want.map_or(50.0, |w| w.0 * (0.5 + rng.next_f32()));
        let blocked = want.is_some_and(|w| w.0 < t_max);
        assert_eq!(occluded(&s, o, d, t_max, shared::NO_PRIM), blocked, "ray {o} {d} to {t_max}");
    }
}
