//! rlpt's BVH builder (src/math/bvh.rs) against the BVH crates of crates.io, on
//! the bunny and the BMW M6 (issue 36: keep the builder, or take a crate's if it
//! measures better). Each crate's binary tree is collapsed and laid out as rlpt's
//! 4-wide nodes (`GpuBvhNode`, its leaves' primitives as rlpt's references) and walked by
//! rlpt's own `closest_hit` and `occluded`, the walk the GPU twin repeats, so
//! that the rays per second and the SAH cost measure the trees and nothing else.
//! Ignored (it prints figures): `cargo test -p rlpt-bvh-crates -- --ignored --nocapture`;
//! docs/meshes.md says what was decided and BENCHMARKS.md gives the figures.

#[path = "../../tests/bvh_support/mod.rs"]
mod bvh_support;

use bvh_support::*;
use rayon::prelude::*;
use rlpt::layout::{prim_ref, GpuBvhNode, SceneArrays};
use rlpt::math::bvh::{self, closest_hit, occluded, Aabb, PrimBox};
use rlpt::math::rng::Rng;
use rlpt::math::Vec3;
use rlpt::shared;
use std::time::Instant;

/// A tree in rlpt's layout, as `rlpt::math::bvh::Bvh` holds one.
struct Tree {
    nodes: Vec<GpuBvhNode>,
    prim_refs: Vec<u32>,
}

/// A child while a crate's tree is laid out: a box and either one of the crate's
/// nodes or a leaf's triangle indices.
enum Child {
    Node(usize),
    Leaf(Vec<u32>),
}

/// Lays a crate's binary tree out as rlpt's: the same collapse into 4-wide nodes
/// and the same layout as `bvh::build` (`bvh::from_tree`, which also grows the
/// boxes as rlpt grows its own); `expand` gives a crate node's two children.
fn lay_out(root: [(Vec3, Vec3, Child); 2], expand: &dyn Fn(usize) -> [(Vec3, Vec3, Child); 2]) -> Tree {
    fn binary(children: [(Vec3, Vec3, Child); 2], expand: &dyn Fn(usize) -> [(Vec3, Vec3, Child); 2]) -> bvh::Tree {
        let [a, b] = children.map(|(lo, hi, child)| {
            let t = match child {
                Child::Leaf(tris) => {
                    bvh::Tree::Leaf(tris.iter().map(|&t| prim_ref(shared::PRIM_TRIANGLE, t)).collect())
                }
                Child::Node(n) => binary(expand(n), expand),
            };
            (Aabb { lo, hi }, t)
        });
        bvh::Tree::Inner(Box::new([a, b]))
    }
    let bounds = Aabb { lo: root[0].0.min(root[1].0), hi: root[0].1.max(root[1].1) };
    let b = bvh::from_tree(&binary(root, expand), bounds);
    Tree { nodes: b.nodes, prim_refs: b.prim_refs }
}

/// rlpt's tree, with spatial splits (`bvh::build`) or without.
fn rlpt_tree(tris: &[[Vec3; 3]], spatial_splits: bool) -> Tree {
    let prims: Vec<PrimBox> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| PrimBox::from_vertices(prim_ref(shared::PRIM_TRIANGLE, i as u32), *t))
        .collect();
    let b = bvh::build_with(&prims, spatial_splits);
    Tree { nodes: b.nodes, prim_refs: b.prim_refs }
}

/// obvhs's BVH2 (PLOC, reinsertion, leaf collapse, with `pre_split` the large
/// triangles' boxes split first), laid out: a leaf of a primitive range becomes
/// a leaf of those triangles (a split triangle in every leaf that holds a part).
fn obvhs_tree(tris: &[obvhs::triangle::Triangle], params: obvhs::BvhBuildParams) -> Tree {
    let b = obvhs::bvh2::builder::build_bvh2_from_tris(tris, params, &mut Default::default());
    let v = |a: obvhs_glam::Vec3A| Vec3::new(a.x, a.y, a.z);
    let child = |i: usize| {
        let n = &b.nodes[i];
        let c = if n.is_leaf() {
            let first = n.first_index as usize;
            Child::Leaf(b.primitive_indices[first..first + n.prim_count as usize].to_vec())
        } else {
            Child::Node(i)
        };
        (v(n.aabb.min), v(n.aabb.max), c)
    };
    let expand = |i: usize| {
        let first = b.nodes[i].first_index as usize;
        [child(first), child(first + 1)]
    };
    assert!(!b.nodes[0].is_leaf(), "obvhs: the root is a leaf");
    lay_out(expand(0), &expand)
}

/// A triangle as the `bvh` crate builds over it: its box and its node.
struct BvhShape {
    lo: Vec3,
    hi: Vec3,
    node: usize,
}

type NPoint = bvh_nalgebra::Point3<f32>;

impl ::bvh::aabb::Bounded<f32, 3> for BvhShape {
    fn aabb(&self) -> ::bvh::aabb::Aabb<f32, 3> {
        let p = |v: Vec3| NPoint::new(v.x, v.y, v.z);
        ::bvh::aabb::Aabb::with_bounds(p(self.lo), p(self.hi))
    }
}

impl ::bvh::bounding_hierarchy::BHShape<f32, 3> for BvhShape {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// The `bvh` crate's tree (binned SAH, one triangle a leaf), laid out.
fn bvh_crate_tree(shapes: &mut [BvhShape]) -> Tree {
    use ::bvh::bounding_hierarchy::BoundingHierarchy;
    use ::bvh::bvh::BvhNode;
    let b = ::bvh::bvh::Bvh::<f32, 3>::build_par(shapes);
    let v = |p: &NPoint| Vec3::new(p.x, p.y, p.z);
    let child = |i: usize, bx: &::bvh::aabb::Aabb<f32, 3>| {
        let c = match b.nodes[i] {
            BvhNode::Leaf { shape_index, .. } => Child::Leaf(vec![shape_index as u32]),
            BvhNode::Node { .. } => Child::Node(i),
        };
        (v(&bx.min), v(&bx.max), c)
    };
    let expand = |i: usize| match &b.nodes[i] {
        BvhNode::Node { child_l_index, child_l_aabb, child_r_index, child_r_aabb, .. } => {
            [child(*child_l_index, child_l_aabb), child(*child_r_index, child_r_aabb)]
        }
        BvhNode::Leaf { .. } => unreachable!("leaves are laid out by their parents"),
    };
    lay_out(expand(0), &expand)
}

/// What a tree is made of: nodes, leaves, references, depth (nodes on the longest
/// path) and its SAH cost with rlpt's costs (a visit of a 4-wide node 1, a
/// primitive test 1): each node's visit and each leaf's tests weighted by its
/// box's area over the root's.
struct Shape {
    nodes: usize,
    leaves: usize,
    refs: usize,
    depth: u32,
    sah: f64,
    /// The SAH cost split by the level (the root's 0) of the node whose visit,
    /// or of the leaf whose tests, it counts: node visits, then leaf tests.
    levels: Vec<[f64; 2]>,
}

fn shape(t: &Tree) -> Shape {
    let area = |lo: [f32; 3], hi: [f32; 3]| {
        let e: [f64; 3] = std::array::from_fn(|k| (hi[k] - lo[k]).max(0.0) as f64);
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    };
    let (lo, hi) = t.nodes[0].bounds();
    let root = area(lo, hi);
    let mut s = Shape { nodes: t.nodes.len(), leaves: 0, refs: t.prim_refs.len(), depth: 0, sah: 0.0, levels: vec![] };
    // (node, the area of its box, its level)
    let mut todo = vec![(0u32, root, 0usize)];
    while let Some((i, a, level)) = todo.pop() {
        if s.levels.len() <= level + 1 {
            s.levels.resize(level + 2, [0.0; 2]);
        }
        s.depth = s.depth.max(level as u32 + 1);
        s.sah += a;
        s.levels[level][0] += a / root;
        let n = &t.nodes[i as usize];
        for k in (0..4).filter(|&k| n.child[k] != shared::BVH_EMPTY) {
            let (child, count, (lo, hi)) = (n.child[k], n.count[k], n.slot_box(k));
            if child & shared::BVH_LEAF != 0 {
                s.leaves += 1;
                s.sah += count as f64 * area(lo, hi);
                s.levels[level + 1][1] += count as f64 * area(lo, hi) / root;
            } else {
                todo.push((child, area(lo, hi), level + 1));
            }
        }
    }
    s.sah /= root;
    s
}

/// `Shape::levels` as text, "level:visits+tests" with the root's level 1: where
/// in the tree the cost lies.
fn sah_by_level(t: &Tree) -> String {
    let levels = shape(t).levels;
    levels.iter().enumerate().map(|(l, [n, p])| format!("{}:{n:.2}+{p:.2}", l + 1)).collect::<Vec<_>>().join(" ")
}

/// Rays through a mesh, as `measure_build_and_walk` in tests/bvh.rs shoots them:
/// from points around it (a sphere of its box's diagonal) towards random points of
/// its box, "outside" (camera-like, most hit), and from random points inside its
/// box in random directions, "inside". A shadow segment for each: to the target
/// point outside, of a random length up to the diagonal inside.
struct Rays {
    outside: Vec<(Vec3, Vec3, f32)>,
    inside: Vec<(Vec3, Vec3, f32)>,
}

fn rays(tris: &[[Vec3; 3]], n: usize) -> Rays {
    let (lo, hi) = tris.iter().flatten().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), p| (l.min(*p), h.max(*p)));
    let mut rng = Rng::new(5, 36, 0, 0);
    let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let diag = (hi - lo).length();
    let sphere = rlpt::math::sampling::uniform_sphere;
    let outside = (0..n)
        .map(|_| {
            let o = (lo + hi) * 0.5 + sphere([r3().x, r3().y]) * diag;
            let to = lo + (hi - lo) * r3() - o;
            (o, to.normalize(), to.length())
        })
        .collect();
    let inside = (0..n)
        .map(|_| {
            let o = lo + (hi - lo) * r3();
            let u = r3();
            (o, sphere([u.x, u.y]), u.z * diag)
        })
        .collect();
    Rays { outside, inside }
}

/// A ray: origin, unit direction and the end of its shadow segment.
type Ray = (Vec3, Vec3, f32);

/// Rays as a render of the BMW shoots them (issue 36's camera: from (-11, 0.8, 5)
/// towards (-2, -0.5, 0), up +y, 30 degrees vertically, 1400x1000): `n` camera
/// rays through random pixels, and from each hit a diffuse bounce (cosine about the
/// normal on the ray's side, leaving the surface by 1e-4 of the hit's scale) with
/// its sky shadow ray (the same direction, unbounded). Rays, then bounces.
fn render_rays(s: &SceneArrays, n: usize) -> (Vec<Ray>, Vec<Ray>) {
    let (eye, at) = (Vec3::new(-11.0, 0.8, 5.0), Vec3::new(-2.0, -0.5, 0.0));
    let w = (at - eye).normalize();
    let u = w.cross(Vec3::Y).normalize();
    let v = u.cross(w);
    let tan = (15.0f32).to_radians().tan();
    let mut rng = Rng::new(9, 36, 0, 0);
    let camera: Vec<_> = (0..n)
        .map(|_| {
            let (x, y) = (rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0);
            (eye, (w + u * (x * tan * 1.4) + v * (y * tan)).normalize(), f32::INFINITY)
        })
        .collect();
    let bounces = camera
        .iter()
        .filter_map(|&(o, d, _)| {
            let (t, r) = closest_hit(s, o, d, f32::INFINITY)?;
            let [a, b, c] = s.triangles[(r & shared::PRIM_INDEX_MASK) as usize].vertices();
            let mut nrm = (b - a).cross(c - a).normalize();
            if nrm.dot(d) > 0.0 {
                nrm = -nrm;
            }
            let p = o + d * t;
            let local = rlpt::math::sampling::cosine_hemisphere([rng.next_f32(), rng.next_f32()]);
            let tu = if nrm.x.abs() > 0.9 { Vec3::Y } else { Vec3::X }.cross(nrm).normalize();
            let dir = (tu * local.x + nrm.cross(tu) * local.y + nrm * local.z).normalize();
            Some((p + nrm * (1e-4 * p.abs().max_element().max(1.0)), dir, f32::INFINITY))
        })
        .collect();
    (camera, bounces)
}

fn with_tree(s: &mut SceneArrays, t: &Tree) {
    s.bvh_nodes.clone_from(&t.nodes);
    s.prim_refs.clone_from(&t.prim_refs);
}

/// Seconds of CPU time: of this thread, or of the whole process (every thread).
fn cpu_seconds(clock: libc::clockid_t) -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes the timespec it is given and nothing else.
    assert_eq!(unsafe { libc::clock_gettime(clock, &mut ts) }, 0);
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// The medians of `reps` builds' wall times (all threads) and CPU times (summed
/// over the threads), and the last tree.
fn time_build(reps: usize, build: &mut dyn FnMut() -> Tree) -> (f64, f64, Tree) {
    let mut times = Vec::new();
    let mut tree = None;
    for _ in 0..reps {
        let (t, cpu) = (Instant::now(), cpu_seconds(libc::CLOCK_PROCESS_CPUTIME_ID));
        tree = Some(build());
        times.push((t.elapsed().as_secs_f64(), cpu_seconds(libc::CLOCK_PROCESS_CPUTIME_ID) - cpu));
    }
    let mut wall: Vec<f64> = times.iter().map(|t| t.0).collect();
    let mut cpu: Vec<f64> = times.iter().map(|t| t.1).collect();
    wall.sort_by(f64::total_cmp);
    cpu.sort_by(f64::total_cmp);
    (wall[reps / 2], cpu[reps / 2], tree.unwrap())
}

/// The same answers as rlpt's own tree on every ray: the nearest hit at the same
/// distance (bit for bit: the same triangle tests), on the same triangle unless
/// another lies at that distance too, and the same occlusion of each segment.
fn check_same_hits(s: &SceneArrays, reference: &SceneArrays, rays: &[(Vec3, Vec3, f32)], name: &str) -> (usize, usize) {
    rays.par_iter()
        .map(|&(o, d, t_max)| {
            let (got, want) = (closest_hit(s, o, d, f32::INFINITY), closest_hit(reference, o, d, f32::INFINITY));
            assert_eq!(got.map(|g| g.0), want.map(|w| w.0), "{name}: ray {o} {d}: {got:?}, rlpt's tree {want:?}");
            let tie = got.zip(want).is_some_and(|(g, w)| g.1 != w.1);
            if tie {
                let t = prim_t(s, got.unwrap().1, o, d, f32::INFINITY);
                assert_eq!(t, Some(want.unwrap().0), "{name}: ray {o} {d}: another triangle, not at the same distance");
            }
            assert_eq!(
                occluded(s, o, d, t_max, shared::NO_PRIM),
                occluded(reference, o, d, t_max, shared::NO_PRIM),
                "{name}: ray {o} {d}, t_max {t_max}"
            );
            (got.is_some() as usize, tie as usize)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

/// Mrays per second of this thread's CPU time (the machine's other jobs do not
/// count): closest hits, then occlusion, over `rays`.
fn walk_rates(s: &SceneArrays, rays: &[(Vec3, Vec3, f32)]) -> [f64; 2] {
    let clock = || cpu_seconds(libc::CLOCK_THREAD_CPUTIME_ID);
    let t = clock();
    let hits = rays.iter().filter(|(o, d, _)| closest_hit(s, *o, *d, f32::INFINITY).is_some()).count();
    let closest = clock() - t;
    let t = clock();
    let blocked = rays.iter().filter(|(o, d, t_max)| occluded(s, *o, *d, *t_max, shared::NO_PRIM)).count();
    let any = clock() - t;
    std::hint::black_box((hits, blocked));
    [rays.len() as f64 / closest / 1e6, rays.len() as f64 / any / 1e6]
}

/// Builds each tree of the bunny and the BMW M6 (median of 5 builds; 3 where a
/// build takes over a second; wall and CPU time), checks it gives rlpt's tree's
/// answers, and prints its shape, SAH cost and walk rates (per CPU second of one
/// thread, the best of 5 passes, the trees interleaved).
#[test]
#[ignore]
fn compare_bvh_builders() {
    let bunny = ply_triangles(&read_ply(&asset("stanford_bunny/bun_zipper.ply")));
    let (bmw, _) = bmw_triangles();
    let rays_per_kind = 250_000;
    eprintln!(
        "{} threads; {rays_per_kind} rays of each kind; walk rates in Mrays per CPU second of one thread",
        rayon::current_num_threads()
    );
    for (scene, tris) in [("bunny", &bunny), ("BMW M6", &bmw)] {
        let obvhs_tris: Vec<obvhs::triangle::Triangle> = tris
            .iter()
            .map(|t| {
                let [v0, v1, v2] = t.map(|p| obvhs_glam::Vec3A::new(p.x, p.y, p.z));
                obvhs::triangle::Triangle { v0, v1, v2 }
            })
            .collect();
        // Leaves of up to 4 and a node visit costing one primitive test, as rlpt's.
        let ob = |base: obvhs::BvhBuildParams| obvhs::BvhBuildParams {
            max_prims_per_leaf: 4,
            collapse_traversal_cost: 1.0,
            ..base
        };
        let mut shapes: Vec<BvhShape> =
            tris.iter().map(|[a, b, c]| BvhShape { lo: a.min(*b).min(*c), hi: a.max(*b).max(*c), node: 0 }).collect();
        type Builder<'a> = (&'a str, Box<dyn FnMut() -> Tree + 'a>);
        let builders: Vec<Builder> = vec![
            ("rlpt binned SAH, spatial splits", Box::new(|| rlpt_tree(tris, true))),
            ("rlpt binned SAH, object splits only", Box::new(|| rlpt_tree(tris, false))),
            (
                "obvhs very_fast_build",
                Box::new(|| obvhs_tree(&obvhs_tris, ob(obvhs::BvhBuildParams::very_fast_build()))),
            ),
            ("obvhs medium_build", Box::new(|| obvhs_tree(&obvhs_tris, ob(obvhs::BvhBuildParams::medium_build())))),
            ("obvhs slow_build", Box::new(|| obvhs_tree(&obvhs_tris, ob(obvhs::BvhBuildParams::slow_build())))),
            (
                "obvhs very_slow_build",
                Box::new(|| obvhs_tree(&obvhs_tris, ob(obvhs::BvhBuildParams::very_slow_build()))),
            ),
            ("bvh binned SAH", Box::new(|| bvh_crate_tree(&mut shapes))),
        ];
        // RLPT_BVH_BUILDERS=rlpt,medium keeps the builders whose names hold one of
        // the words (rlpt's first, the reference, always).
        let keep = std::env::var("RLPT_BVH_BUILDERS").ok();
        let kept = |k: usize, name: &str| {
            k == 0 || keep.as_deref().is_none_or(|w| w.split(',').any(|w| name.contains(w.trim())))
        };
        let mut built = Vec::new();
        for (k, (name, mut build)) in builders.into_iter().enumerate() {
            if !kept(k, name) {
                continue;
            }
            // The first build warms the thread pool and the allocator up.
            let t = Instant::now();
            let _ = build();
            let reps = if t.elapsed().as_secs_f64() > 1.0 { 3 } else { 5 };
            let (wall, cpu, tree) = time_build(reps, &mut build);
            built.push((name, wall, cpu, tree));
        }
        let rays = rays(tris, rays_per_kind);
        let mut reference = SceneArrays::of_triangles(tris.iter().copied().map(gpu_triangle).collect());
        with_tree(&mut reference, &built[0].3);
        let mut s = SceneArrays::of_triangles(tris.iter().copied().map(gpu_triangle).collect());
        let mut rates = vec![[0.0f64; 4]; built.len()];
        // The BMW's render rays (camera closest, bounce closest, bounce occluded).
        let render = (scene == "BMW M6").then(|| render_rays(&reference, rays_per_kind));
        let mut render_rates = vec![[0.0f64; 3]; built.len()];
        let mut walkable = vec![true; built.len()];
        for (k, (name, _, _, tree)) in built.iter().enumerate() {
            let depth = shape(tree).depth;
            // The walk's stack holds up to 3 entries per level above the deepest node.
            walkable[k] = 3 * depth.saturating_sub(1) <= shared::BVH_STACK;
            if !walkable[k] {
                eprintln!(
                    "{scene}, {name}: depth {depth} overflows the walk's stack of {}: not walked",
                    shared::BVH_STACK
                );
                continue;
            }
            let mut held = vec![false; tris.len()];
            tree.prim_refs.iter().for_each(|&r| held[(r & shared::PRIM_INDEX_MASK) as usize] = true);
            assert!(held.iter().all(|&h| h), "{scene}, {name}: a triangle in no leaf");
            if k == 0 {
                continue; // rlpt's own tree, the reference (tests/bvh.rs checks it against brute force)
            }
            with_tree(&mut s, tree);
            let (hits, ties) = check_same_hits(&s, &reference, &rays.outside, name);
            let (hits_in, ties_in) = check_same_hits(&s, &reference, &rays.inside, name);
            eprintln!(
                "{scene}, {name}: the same hits as rlpt's tree ({} hits, {} on another triangle at the same distance)",
                hits + hits_in,
                ties + ties_in
            );
        }
        for _ in 0..5 {
            for (k, (_, _, _, tree)) in built.iter().enumerate() {
                if !walkable[k] {
                    continue;
                }
                with_tree(&mut s, tree);
                let [c_out, o_out] = walk_rates(&s, &rays.outside);
                let [c_in, o_in] = walk_rates(&s, &rays.inside);
                for (best, r) in rates[k].iter_mut().zip([c_out, c_in, o_out, o_in]) {
                    *best = best.max(r);
                }
                if let Some((camera, bounces)) = &render {
                    let [c_cam, _] = walk_rates(&s, camera);
                    let [c_b, o_b] = walk_rates(&s, bounces);
                    for (best, r) in render_rates[k].iter_mut().zip([c_cam, c_b, o_b]) {
                        *best = best.max(r);
                    }
                }
            }
        }
        eprintln!("\n{scene}: {} triangles", tris.len());
        eprintln!("| builder | build s (CPU s) | nodes | leaves | refs | depth | SAH cost | closest outside | closest inside | occluded outside | occluded inside |");
        eprintln!("|---|---|---|---|---|---|---|---|---|---|---|");
        let base = rates[0];
        if std::env::var_os("RLPT_BVH_LEVELS").is_some() {
            for (name, _, _, tree) in &built {
                eprintln!("{scene}, {name}: SAH cost by level: {}", sah_by_level(tree));
            }
        }
        for (k, (name, wall, cpu, tree)) in built.iter().enumerate() {
            let sh = shape(tree);
            let r: Vec<String> = (0..4)
                .map(|i| {
                    if walkable[k] {
                        format!("{:.2} ({:+.0} %)", rates[k][i], 100.0 * (rates[k][i] / base[i] - 1.0))
                    } else {
                        "-".into()
                    }
                })
                .collect();
            eprintln!(
                "| {name} | {wall:.3} ({cpu:.3}) | {} | {} | {} | {} | {:.1} | {} |",
                sh.nodes,
                sh.leaves,
                sh.refs,
                sh.depth,
                sh.sah,
                r.join(" | ")
            );
        }
        if render.is_some() {
            eprintln!("\n{scene}, render rays (camera closest, bounce closest, bounce sky shadow), Mrays per CPU s:");
            for (k, (name, ..)) in built.iter().enumerate() {
                let r: Vec<String> = (0..3)
                    .map(|i| {
                        let (x, b) = (render_rates[k][i], render_rates[0][i]);
                        format!("{x:.2} ({:+.0} %)", 100.0 * (x / b - 1.0))
                    })
                    .collect();
                eprintln!("| {name} | {} |", r.join(" | "));
            }
        }
        eprintln!();
    }
}
