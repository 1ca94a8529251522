//! What the BVH walk does per ray on a scene's render rays (issue 36: why the
//! 4-wide walk slowed bunny-door): nodes read, boxes tested and entered, leaves
//! and primitives tested (by kind), stack pushes, counted by
//! `rlpt::math::bvh::closest_hit_counted` and `occluded_counted` (the normal walk
//! counts nothing). Ignored (it prints a table):
//! `RLPT_WALK_SCENES=bunny-door,bmw-m6 cargo test -p rlpt-bvh-crates --test walk_counts -- --ignored --nocapture`
//! (scenes/NAME.toml; `RLPT_WALK_RAYS` camera rays, 200000 by default).
//! docs/meshes.md, "Bunny-door under the 4-wide walk", gives the figures.

use rlpt::layout::SceneArrays;
use rlpt::math::bvh::{closest_hit, closest_hit_counted, occluded, occluded_counted, WalkStats};
use rlpt::math::geometry::{offset_origin, prim_hit, sample_light, shadow_ray};
use rlpt::math::rng::Rng;
use rlpt::math::sampling::cosine_hemisphere;
use rlpt::math::{Frame, Vec3};
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;
use rlpt::shared;
use std::path::Path;
use std::time::Instant;

/// A ray: origin, unit direction, end of its interval, and the primitive a
/// shadow ray leaves out.
type Ray = (Vec3, Vec3, f32, u32);

/// A scene's render rays: camera rays through random pixels (closest hit), a
/// diffuse bounce from each camera ray's hit (closest hit), and that hit's
/// next-event shadow ray (any hit; to a sampled light point where the scene has
/// lights and the point faces it, else to the sky along the bounce).
fn render_rays(s: &SceneArrays, n: usize) -> [Vec<Ray>; 3] {
    let mut rays = [vec![], vec![], vec![]];
    let mut rng = Rng::new(36, 7, 0, 0);
    let p = &s.params;
    for _ in 0..n {
        let (x, y) = ((rng.next_f32() * p.width as f32) as u32, (rng.next_f32() * p.height as f32) as u32);
        let u = [rng.next_f32(), rng.next_f32()];
        let (o, d) = rlpt::camera::camera_ray(p, x.min(p.width - 1), y.min(p.height - 1), u);
        rays[0].push((o, d, f32::INFINITY, shared::NO_PRIM));
        let Some((t, r)) = closest_hit(s, o, d, f32::INFINITY) else { continue };
        let h = prim_hit(s, r, o, d, t);
        // The shading frame on the side the ray came from.
        let ns = if h.ns.dot(d) > 0.0 { -h.ns } else { h.ns };
        let dir = Frame::from_normal(ns).to_world(cosine_hemisphere([rng.next_f32(), rng.next_f32()])).normalize();
        let bo = offset_origin(h.p, h.n, h.eps, dir);
        rays[1].push((bo, dir, f32::INFINITY, shared::NO_PRIM));
        let (u_sel, u) = (rng.next_f32(), [rng.next_f32(), rng.next_f32()]);
        if s.lights.is_empty() {
            rays[2].push((bo, dir, f32::INFINITY, shared::NO_PRIM));
        } else if let Some(ls) = sample_light(s, h.p, u_sel, u) {
            if ls.le.max_element() > 0.0 && ls.wi.dot(ns) > 0.0 {
                let (so, sd, len) = shadow_ray(h.p, h.n, h.eps, &ls);
                rays[2].push((so, sd, len, ls.skip));
            }
        }
    }
    rays
}

/// Walks `rays` (closest hits for kinds 0 and 1, shadow rays for 2), counted.
fn count(s: &SceneArrays, kind: usize, rays: &[Ray]) -> WalkStats {
    let mut st = WalkStats::default();
    for &(o, d, t, skip) in rays {
        if kind < 2 {
            closest_hit_counted(s, o, d, t, &mut st);
        } else {
            occluded_counted(s, o, d, t, skip, &mut st);
        }
    }
    st
}

/// Nanoseconds per ray of the normal (uncounted) walk on one thread, the least of 5 runs.
fn time(s: &SceneArrays, kind: usize, rays: &[Ray]) -> f64 {
    (0..5)
        .map(|_| {
            let t0 = Instant::now();
            let mut hits = 0usize;
            for &(o, d, t, skip) in rays {
                hits += if kind < 2 { closest_hit(s, o, d, t).is_some() } else { occluded(s, o, d, t, skip) } as usize;
            }
            std::hint::black_box(hits);
            t0.elapsed().as_secs_f64() * 1e9 / rays.len().max(1) as f64
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
#[ignore = "prints per-ray walk counts; run by hand (see the module's comment)"]
fn walk_counts() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("bvh-crates/ lies in the repository");
    let scenes = std::env::var("RLPT_WALK_SCENES").unwrap_or_else(|_| "bunny-door,bmw-m6".into());
    let n = std::env::var("RLPT_WALK_RAYS").map_or(200_000, |v| v.parse().expect("RLPT_WALK_RAYS: a count"));
    for name in scenes.split(',') {
        let scene = Scene::load(root.join("scenes").join(format!("{name}.toml"))).expect("the scene loads");
        let prepared = PreparedScene::new(&scene, &RenderOptions::from_scene(&scene)).expect("valid options");
        assert!(!prepared.bvh_nodes.is_empty(), "{name} walks no BVH");
        eprintln!("\n{name}: {} nodes, {} references; per ray:", prepared.bvh_nodes.len(), prepared.prim_refs.len());
        eprintln!("| rays | count | nodes | boxes | entered | zero ties | leaves | triangles | quads | spheres | pushes | nodes after hit | CPU ns |");
        eprintln!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        let rays = render_rays(&prepared, n);
        for (k, name) in ["camera", "bounce", "shadow"].iter().enumerate() {
            let st = count(&prepared, k, &rays[k]);
            let ns = time(&prepared, k, &rays[k]);
            let r = st.rays.max(1) as f64;
            let f = |v: u64| v as f64 / r;
            eprintln!(
                "| {name} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {ns:.0} |",
                st.rays,
                f(st.nodes),
                f(st.boxes),
                f(st.entered),
                f(st.zero_ties),
                f(st.leaves),
                f(st.triangles),
                f(st.quads),
                f(st.spheres),
                f(st.pushes),
                f(st.nodes_after_hit)
            );
        }
    }
}
