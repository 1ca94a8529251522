//! Shadow rays skip the quads that bound the scene (`rlpt::prepared::occluding_order`).
//! On every shipped scene, for shadow rays built as the renderers build them, the
//! culled test must give the answer of the test against every primitive, except
//! where a skipped quad blocks the segment at one of its ends, within twice that
//! end's hit epsilon of the quad's plane (the offset of an end moves it by one):
//! there the full test's answer is rounding, which the offset exists to avoid,
//! and such points are measure zero.

use rlpt::math::geometry::{intersect, intersect_quad, intersect_sphere, occluded, offset_origin, sample_light};
use rlpt::math::rng::Rng;
use rlpt::math::sampling::uniform_sphere;
use rlpt::math::Vec3;
use rlpt::prepared::{GpuQuad, PreparedScene, RenderOptions};
use rlpt::scene::Scene;

fn occluded_by_all(scene: &PreparedScene, o: Vec3, d: Vec3, t_max: f32) -> bool {
    scene.spheres.iter().any(|s| intersect_sphere(s, o, d, t_max).is_some())
        || scene.quads.iter().any(|q| intersect_quad(q, o, d, t_max).is_some())
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
        let prepared = PreparedScene::new(&scene, &RenderOptions::from_scene(&scene));
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
                    let origin = offset_origin(hit.p, hit.n, hit.eps, ls.wi);
                    let target = offset_origin(ls.p, ls.n, ls.eps, -ls.wi);
                    let seg = target - origin;
                    let len = seg.length();
                    let dir = seg / len;
                    let (culled, full) =
                        (occluded(&prepared, origin, dir, len), occluded_by_all(&prepared, origin, dir, len));
                    rays += 1;
                    blocked += full as u32;
                    if culled != full {
                        // Each skipped quad that blocks the segment has an end of it at its plane.
                        for q in bounding.iter().filter(|q| intersect_quad(q, origin, dir, len).is_some()) {
                            assert!(
                                plane_distance(q, origin) <= 2.0 * hit.eps || plane_distance(q, target) <= 2.0 * ls.eps,
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
