//! The BVH (src/math/bvh.rs): the builder's trees, the walks against brute force,
//! and the watertight triangle test (src/math/triangle.rs) on a closed mesh, on
//! the CPU; the GPU twin is tested in tests/bvh_gpu.rs.
//!
//! Brute force over a million rays times the bunny's 69451 triangles would take
//! minutes, so the rays come in bundles of 500 from one origin within a narrow
//! cone, and the brute-force loop of a bundle runs over the primitives whose
//! (generous) bounding sphere meets the cone: the others cannot be hit by any of
//! its rays. `the_bundles_reference_is_all_of_brute_force` checks that on rays
//! of its own against every primitive.

mod bvh_support;

use bvh_support::*;
use rayon::prelude::*;
use rlpt::layout::SceneArrays;
use rlpt::math::bvh::{self, closest_hit, occluded};
use rlpt::math::rng::Rng;
use rlpt::math::Vec3;
use rlpt::shared;

/// What one scene's comparison found.
#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    hits: usize,
    /// Nearest hits on two primitives at the same distance, BVH and brute force taking different ones.
    ties: usize,
    blocked: usize,
}

/// Each ray of the bundles: the BVH's closest hit against brute force (t within
/// a relative 1e-6, the same primitive unless another lies at the same t), and
/// occlusion against brute force: a segment shorter or longer than the nearest
/// hit, and a shadow ray that ends on the nearest hit and skips its primitive.
fn compare(s: &SceneArrays, bundles: &[Bundle]) -> Tally {
    let tallies: Vec<Tally> = bundles
        .par_iter()
        .enumerate()
        .map(|(b, bundle)| {
            let mut tally = Tally::default();
            let mut rng = Rng::new(99, b as u32, 0, 0);
            let (lo, hi) = bounds(s);
            let size = (hi - lo).length();
            let o = bundle.origin;
            for &d in &bundle.rays {
                tally.rays += 1;
                let got = closest_hit(s, o, d, f32::INFINITY);
                let want = brute_closest(s, &bundle.candidates, o, d, f32::INFINITY);
                match (got, want) {
                    (None, None) => {}
                    (Some((tg, rg)), Some((tw, rw))) => {
                        tally.hits += 1;
                        assert!((tg - tw).abs() <= 1e-6 * tw, "ray {o} {d}: t {tg} (BVH) vs {tw}");
                        if rg != rw {
                            let t_other = prim_t(s, rg, o, d, f32::INFINITY);
                            assert!(
                                t_other.is_some_and(|t| (t - tw).abs() <= 1e-6 * tw),
                                "ray {o} {d}: primitive {rg:#x} (BVH) at {t_other:?}, brute force {rw:#x} at {tw}"
                            );
                            tally.ties += 1;
                        }
                    }
                    _ => panic!("ray {o} {d}: BVH {got:?}, brute force {want:?}"),
                }
                let u = rng.next_f32();
                let (t_max, skip) = match want {
                    Some((t, r)) if u < 0.5 => (t, r),
                    Some((t, _)) => (t * 2.0 * rng.next_f32(), shared::NO_PRIM),
                    None => (size * rng.next_f32(), shared::NO_PRIM),
                };
                let got = occluded(s, o, d, t_max, skip);
                assert_eq!(
                    got,
                    brute_occluded(s, &bundle.candidates, o, d, t_max, skip),
                    "ray {o} {d}, t_max {t_max}, skip {skip:#x}"
                );
                tally.blocked += got as usize;
            }
            tally
        })
        .collect();
    tallies.into_iter().fold(Tally::default(), |a, t| Tally {
        rays: a.rays + t.rays,
        hits: a.hits + t.hits,
        ties: a.ties + t.ties,
        blocked: a.blocked + t.blocked,
    })
}

#[test]
fn closest_hit_and_occlusion_match_brute_force_through_the_bunny() {
    let s = bunny();
    let tally = compare(&s, &bundles(&s, 2000, 500, 0.01, 1));
    eprintln!("bunny: {tally:?}");
    assert_eq!(tally.rays, 1_000_000);
    assert!(tally.hits > 150_000 && tally.blocked > 40_000, "{tally:?}");
    assert!(tally.ties * 1000 < tally.hits, "{tally:?}");
}

#[test]
fn closest_hit_and_occlusion_match_brute_force_through_a_mixed_scene() {
    let s = mixed();
    assert!(!s.spheres.is_empty() && !s.quads.is_empty() && !s.triangles.is_empty());
    let tally = compare(&s, &bundles(&s, 2000, 500, 0.03, 2));
    eprintln!("mixed: {tally:?}");
    assert_eq!(tally.rays, 1_000_000);
    assert!(tally.hits > 250_000 && tally.blocked > 60_000, "{tally:?}");
    assert!(tally.ties * 1000 < tally.hits, "{tally:?}");
}

#[test]
fn the_bundles_reference_is_all_of_brute_force() {
    for (s, angle) in [(bunny(), 0.01), (mixed(), 0.03)] {
        let all = all_prims(&s);
        let bundles = bundles(&s, 8, 150, angle, 3);
        let hits: usize = bundles
            .par_iter()
            .map(|b| {
                let mut hits = 0;
                for &d in &b.rays {
                    let want = brute_closest(&s, &all, b.origin, d, f32::INFINITY);
                    assert_eq!(brute_closest(&s, &b.candidates, b.origin, d, f32::INFINITY), want);
                    hits += want.is_some() as usize;
                }
                hits
            })
            .sum();
        assert!(hits > 100, "{hits} hits");
    }
}

#[test]
fn rays_from_inside_a_closed_mesh_at_its_vertices_and_edges_never_escape() {
    let (unit, faces) = icosphere(4);
    let mut edges: Vec<(u32, u32)> = faces.iter().flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)]).collect();
    edges.retain(|&(a, b)| a < b);
    let mut rng = Rng::new(36, 7, 0, 0);
    let mut rays = 0;
    for (center, radius) in [
        (Vec3::ZERO, 1.0),
        (Vec3::new(1000.0, -2000.0, 500.0), 1.0),
        (Vec3::new(123.4, 56.7, -89.1), 0.01),
        (Vec3::new(-3e4, 1e4, 2e4), 50.0),
    ] {
        let v: Vec<Vec3> = unit.iter().map(|p| center + radius * *p).collect();
        let s = triangle_scene(
            faces.iter().map(|&[a, b, c]| gpu_triangle([v[a as usize], v[b as usize], v[c as usize]])).collect(),
        );
        // The centre and random points inside (up to half the radius out).
        let mut origins = vec![center];
        origins.extend(
            (0..3).map(|_| {
                center + rlpt::math::sampling::uniform_sphere(rng.next_2d()) * (0.5 * radius * rng.next_f32())
            }),
        );
        // Every vertex; every edge's midpoint and a random point of it.
        let mut targets = v.clone();
        for &(a, b) in &edges {
            let (p, q) = (v[a as usize], v[b as usize]);
            targets.push(p + 0.5 * (q - p));
            targets.push(p + rng.next_f32() * (q - p));
        }
        for &o in &origins {
            let escaped: Vec<Vec3> = targets
                .par_iter()
                .filter(|&&p| {
                    let d = (p - o).normalize();
                    let dist = (p - o).length();
                    let hit = closest_hit(&s, o, d, f32::INFINITY);
                    // Convex: the one hit is the target, to rounding (of the radius,
                    // and of the coordinates: an ulp at 123 is 8e-6).
                    let tol = 1e-4 * radius + 1e-6 * center.abs().max_element();
                    let near_target = hit.is_some_and(|(t, _)| (t - dist).abs() <= tol);
                    !(near_target && occluded(&s, o, d, f32::INFINITY, shared::NO_PRIM))
                })
                .copied()
                .collect();
            assert!(
                escaped.is_empty(),
                "centre {center}, radius {radius}, origin {o}: {} of {} rays escaped, towards {:?} and more",
                escaped.len(),
                targets.len(),
                &escaped[..escaped.len().min(5)]
            );
            rays += targets.len();
        }
    }
    assert!(rays > 100_000, "{rays} rays");
}

/// Prints build times, nodes and depth for the bunny and the BMW M6's 114 meshes,
/// and the CPU walk's rays per second on the bunny:
/// `cargo test --test bvh -- --ignored --nocapture`.
#[test]
#[ignore]
fn measure_build_and_walk() {
    use std::time::Instant;
    let boxes = |tris: &[[Vec3; 3]]| triangle_boxes(&tris.iter().copied().map(gpu_triangle).collect::<Vec<_>>());
    let bunny_tris = ply_triangles(&read_ply(&asset("stanford_bunny/bun_zipper.ply")));
    let t0 = Instant::now();
    let (bmw_tris, files) = bmw_triangles();
    eprintln!("BMW: {files} files, {} triangles, read in {:.2} s", bmw_tris.len(), t0.elapsed().as_secs_f64());
    for (name, tris) in [("bunny", &bunny_tris), ("BMW M6", &bmw_tris)] {
        let prims = boxes(tris);
        let _ = bvh::build(&prims); // warm up the thread pool and the allocator
        let mut times = Vec::new();
        let mut built = None;
        for _ in 0..5 {
            let t = Instant::now();
            built = Some(bvh::build(&prims));
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let b = built.unwrap();
        let leaves = b
            .nodes
            .iter()
            .flat_map(|n| n.child)
            .filter(|&c| c != shared::BVH_EMPTY && c & shared::BVH_LEAF != 0)
            .count();
        eprintln!(
            "{name}: {} triangles, build {:.3} s (median of 5, {} threads), {} nodes, {leaves} leaves, depth {}",
            tris.len(),
            times[2],
            rayon::current_num_threads(),
            b.nodes.len(),
            b.depth
        );
    }
    // Rays/s of closest_hit on the bunny: from points around it towards random
    // points of its box (most hit), and from inside its box in random directions.
    let s = bunny();
    let (lo, hi) = bounds(&s);
    let mut rng = Rng::new(5, 0, 0, 0);
    let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let n = 1_000_000;
    let rays: Vec<(Vec3, Vec3)> = (0..n)
        .map(|i| {
            if i % 2 == 0 {
                let o = (lo + hi) * 0.5 + rlpt::math::sampling::uniform_sphere([r3().x, r3().y]) * (hi - lo).length();
                (o, (lo + (hi - lo) * r3() - o).normalize())
            } else {
                (lo + (hi - lo) * r3(), rlpt::math::sampling::uniform_sphere([r3().x, r3().y]))
            }
        })
        .collect();
    // The best of three passes each, one thread and all.
    let time = |f: &dyn Fn() -> usize| {
        (0..3)
            .map(|_| {
                let t = Instant::now();
                (f(), t.elapsed().as_secs_f64())
            })
            .fold((0, f64::INFINITY), |a, b| (b.0, a.1.min(b.1)))
    };
    let (hits, one) = time(&|| rays.iter().filter(|(o, d)| closest_hit(&s, *o, *d, f32::INFINITY).is_some()).count());
    let (hits_par, all) =
        time(&|| rays.par_iter().filter(|(o, d)| closest_hit(&s, *o, *d, f32::INFINITY).is_some()).count());
    assert_eq!(hits, hits_par);
    eprintln!(
        "bunny closest_hit: {:.2} Mrays/s on one thread, {:.2} Mrays/s on {} ({hits} of {n} hit)",
        n as f64 / one / 1e6,
        n as f64 / all / 1e6,
        rayon::current_num_threads()
    );
    let (blocked, all) =
        time(&|| rays.par_iter().filter(|(o, d)| occluded(&s, *o, *d, f32::INFINITY, shared::NO_PRIM)).count());
    eprintln!(
        "bunny occluded: {:.2} Mrays/s on {} threads ({blocked} blocked)",
        n as f64 / all / 1e6,
        rayon::current_num_threads()
    );
}
