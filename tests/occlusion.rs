//! Shadow rays skip the quads that bound the scene (`rlpt::prepared::occluding_order`).
//! On every shipped scene, for shadow rays built as the renderers build them, the
//! culled test must give the answer of the test against every primitive (but the
//! light the segment ends on), except where a skipped quad blocks the segment at
//! one of its ends: the origin within twice its hit epsilon of the quad's plane
//! (its offset moves it by one), or the light point within a hit epsilon of it.
//! There the full test's answer is rounding, and such points are measure zero.

use rlpt::layout::{prim_ref, GpuQuad, GpuSphere};
use rlpt::math::geometry::{
    hit_epsilon, intersect, intersect_quad, intersect_sphere, occluded, offset_origin, sample_light, shadow_ray,
    sphere_blocks,
};
use rlpt::math::rng::Rng;
use rlpt::math::sampling::uniform_sphere;
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;
use rlpt::shared::{PRIM_QUAD, PRIM_SPHERE};

/// The hit test against every primitive but the light the segment ends on.
fn occluded_by_all(scene: &PreparedScene, o: Vec3, d: Vec3, t_max: f32, skip: u32) -> bool {
    let spheres = scene.spheres.iter().enumerate().filter(|&(i, _)| prim_ref(PRIM_SPHERE, i as u32) != skip);
    let quads = scene.quads.iter().enumerate().filter(|&(i, _)| prim_ref(PRIM_QUAD, i as u32) != skip);
    spheres.into_iter().any(|(_, s)| intersect_sphere(s, o, d, t_max).is_some())
        || quads.into_iter().any(|(_, q)| intersect_quad(q, o, d, t_max).is_some())
}

fn plane_distance(q: &GpuQuad, p: Vec3) -> f32 {
    (Vec3::new(q.normal[0], q.normal[1], q.normal[2]).dot(p) - q.normal[3]).abs()
}

#[test]
fn shadow_rays_skip_only_quads_that_cannot_block_them() {
    let mut scenes: Vec<_> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 7, "the shipped scenes: {scenes:?}");
    let mut skipped_somewhere = false;
    for path in &scenes {
        let scene = Scene::load(path).unwrap();
        let prepared = PreparedScene::new(&scene, &RenderOptions::from_scene(&scene)).expect("valid options");
        if !prepared.bvh_nodes.is_empty() {
            // The BVH tests every primitive: nothing is skipped (tests/bvh.rs
            // checks its occlusion against brute force).
            assert_eq!(prepared.params.occluding_quads as usize, prepared.quads.len());
            continue;
        }
        let n_occ = prepared.params.occluding_quads as usize;
        skipped_somewhere |= n_occ < prepared.quads.len();
        let bounding = &prepared.quads[n_occ..];
        let mut rng = Rng::new(3, 0, 0, 0);
        let (mut rays, mut blocked, mut rounding) = (0u32, 0u32, 0u32);
        for _ in 0..20_000 {
            // A point seen from the camera (a cone about its view direction), then up
            // to two more along random directions.
            let mut o = scene.camera.position;
            let mut d = (scene.camera.forward + 0.6 * uniform_sphere(rng.next_2d())).normalize();
            for _ in 0..3 {
                let Some(hit) = intersect(&prepared, o, d, f32::INFINITY) else { break };
                if let Some(ls) = sample_light(&prepared, hit.p, rng.next_f32(), rng.next_2d()) {
                    let (origin, dir, len) = shadow_ray(hit.p, hit.n, hit.eps, &ls);
                    let target = ls.end;
                    let (culled, full) = (
                        occluded(&prepared, origin, dir, len, ls.skip),
                        occluded_by_all(&prepared, origin, dir, len, ls.skip),
                    );
                    rays += 1;
                    blocked += full as u32;
                    if culled != full {
                        // A skipped quad blocks the segment (the spheres' test, without
                        // roots in `occluded`, must agree with the roots here), and each
                        // such quad has an end of the segment at its plane.
                        let skipped: Vec<_> =
                            bounding.iter().filter(|q| intersect_quad(q, origin, dir, len).is_some()).collect();
                        assert!(
                            !skipped.is_empty(),
                            "{}: the shadow ray {origin} -> {target} is {} by `occluded` but not by the \
                             test against every primitive, and no skipped quad blocks it",
                            path.display(),
                            if culled { "blocked" } else { "free" }
                        );
                        for q in skipped {
                            assert!(
                                plane_distance(q, origin) <= 2.0 * hit.eps
                                    || plane_distance(q, target) <= hit_epsilon(target, 0.0),
                                "{}: the skipped quad at {:?} blocks the segment {origin} -> {target}, \
                                 whose ends are far from its plane",
                                path.display(),
                                q.origin
                            );
                        }
                        rounding += 1;
                    }
                }
                d = uniform_sphere(rng.next_2d());
                o = offset_origin(hit.p, hit.n, hit.eps, d);
            }
        }
        if prepared.lights.is_empty() {
            continue; // furnace-open: lit by the sky, no shadow rays
        }
        assert!(rays > 10_000, "{}: {rays} shadow rays", path.display());
        eprintln!(
            "{}: {} of {} quads tested by shadow rays; {rays} rays, {blocked} blocked, {rounding} differ at a plane",
            path.display(),
            n_occ,
            prepared.quads.len()
        );
    }
    assert!(skipped_somewhere, "no shipped scene has a quad that bounds it");
}

/// The shadow rays' sphere test (`sphere_blocks`: the sides of the segment's
/// ends and the line's nearest approach, no roots) gives the answer of the hit
/// test (`intersect_sphere`: a root in (0, t_max)) on random segments about
/// random spheres, compact (powers from the centre) and not (from the anchor),
/// radii from 0.01 to 1e5, ends inside and outside, near the centre's scale and
/// near the anchor at the scale of a room. Where the two differ, the
/// segment must be degenerate in f64: an end or the line within rounding of the
/// surface (1e-5 of the sizes around, the scale of the renderers' offsets).
/// Each root found lies on the surface within that too.
#[test]
fn sphere_blocks_agrees_with_the_roots() {
    let mut rng = Rng::new(11, 0, 0, 0);
    let (mut compact, mut anchored, mut degenerate) = (0u32, 0u32, 0u32);
    // Outcomes: blocked with the ends on opposite sides, both outside and
    // blocked, both outside and free, both inside.
    let mut seen = [0u32; 4];
    for i in 0..400 {
        let dir = uniform_sphere(rng.next_2d());
        let (radius, center) = if i % 2 == 0 {
            // Centre at 0 to 3 radii from the world origin: both kinds of sphere.
            let radius = 10f32.powf(-2.0 + 7.0 * rng.next_f32());
            (radius, dir * radius * 3.0 * rng.next_f32())
        } else {
            // Smallpt's walls: radius 100 to 1e5, the surface 0.1 to 100 from the world origin.
            let radius = 10f32.powf(2.0 + 3.0 * rng.next_f32());
            (radius, dir * (radius + 10f32.powf(-1.0 + 3.0 * rng.next_f32())))
        };
        let s = GpuSphere::new(center, radius, 0, 0);
        if s.compact() {
            compact += 1;
        } else {
            anchored += 1;
        }
        let c64 = center.as_dvec3();
        let r64 = radius as f64;
        let anchor = glam::Vec3::from_slice(&s.anchor_radius[..3]);
        for k in 0..1000 {
            // Ends from 0 to 2.5 radii from the centre, or (every other segment)
            // within 0.01 to 100 of the anchor, where a scene at the size of
            // the world origin's neighbourhood meets a large sphere (smallpt).
            let mut end = || {
                if k % 2 == 0 {
                    center + uniform_sphere(rng.next_2d()) * radius * 2.5 * rng.next_f32().sqrt()
                } else {
                    anchor + uniform_sphere(rng.next_2d()) * 10f32.powf(-2.0 + 4.0 * rng.next_f32())
                }
            };
            let (o, e) = (end(), end());
            let len = (e - o).length();
            if len.is_nan() || len <= 0.0 {
                continue;
            }
            let d = (e - o) / len;
            let blocks = sphere_blocks(&s, o, d, len);
            let root = intersect_sphere(&s, o, d, len);
            let roots = root.is_some();
            // The same segment in f64, from the f32 numbers the tests read.
            let (o64, d64) = (o.as_dvec3(), d.as_dvec3());
            let e64 = o64 + d64 * len as f64;
            let side = |p: glam::DVec3| (p - c64).length() - r64;
            let b = -(o64 - c64).dot(d64);
            let tangent = ((o64 - c64) + d64 * b).length() - r64;
            let tol = 1e-5 * (1.0 + o64.abs().max_element().max(e64.abs().max_element()));
            let near = side(o64).abs() <= tol || side(e64).abs() <= tol || tangent.abs() <= tol;
            if let Some(t) = root {
                // The root itself lies on the surface, within the same rounding.
                let off = side(o64 + d64 * t as f64);
                assert!(off.abs() <= tol, "sphere C {center} r {radius}: root {t} of {o} -> {e} is {off:e} off");
            }
            if blocks != roots {
                assert!(
                    near,
                    "sphere C {center} r {radius} ({}): segment {o} -> {e}: sphere_blocks {blocks}, roots {roots}; \
                     ends {:e} and {:e} from the surface, line {tangent:e}",
                    if s.compact() { "compact" } else { "anchored" },
                    side(o64),
                    side(e64)
                );
                degenerate += 1;
                continue;
            }
            let (in_o, in_e) = (side(o64) < 0.0, side(e64) < 0.0);
            let k = match (blocks, in_o, in_e) {
                (true, a, b) if a != b => 0,
                (true, false, false) => 1,
                (false, false, false) => 2,
                (_, true, true) => 3,
                _ => continue,
            };
            seen[k] += 1;
        }
    }
    eprintln!(
        "{compact} compact and {anchored} anchored spheres; outcomes {seen:?}; {degenerate} differ at the surface"
    );
    assert!(compact >= 50 && anchored >= 50, "{compact} compact, {anchored} anchored spheres");
    assert!(seen.iter().all(|&n| n >= 1000), "each outcome often: {seen:?}");
}
