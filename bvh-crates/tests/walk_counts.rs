//! What the BVH walk does per ray on a scene's render rays (issue 36: why the
//! 4-wide walk slowed bunny-door): nodes read, boxes tested and entered, leaves
//! and primitives tested (by kind), stack pushes, counted by
//! `rlpt::math::bvh::closest_hit_counted` and `occluded_counted` (the normal walk
//! counts nothing). Ignored (it prints a table):
//! `RLPT_WALK_SCENES=bunny-door,bmw-m6 cargo test -p rlpt-bvh-crates --test walk_counts -- --ignored --nocapture`
//! (scenes/NAME.toml; `RLPT_WALK_RAYS` camera rays, 200000 by default).
//! docs/meshes.md, "Bunny-door under the 4-wide walk", gives the figures.

use rlpt::layout::SceneArrays;
use rlpt::math::bvh::{closest_hit_counted, occluded_counted, WalkStats};
use rlpt::math::geometry::{offset_origin, prim_hit, sample_light, shadow_ray};
use rlpt::math::rng::Rng;
use rlpt::math::sampling::cosine_hemisphere;
use rlpt::math::Frame;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;
use rlpt::shared;
use std::path::Path;

/// Per kind of ray: camera (closest hit), diffuse bounce from the camera ray's hit
/// (closest hit), next-event shadow ray from that hit (any hit; to a sampled light
/// point where the scene has lights, else to the sky along the bounce).
fn count(s: &SceneArrays, n: usize) -> [WalkStats; 3] {
    let mut st = [WalkStats::default(); 3];
    let mut rng = Rng::new(36, 7, 0, 0);
    let p = &s.params;
    for _ in 0..n {
        let (x, y) = ((rng.next_f32() * p.width as f32) as u32, (rng.next_f32() * p.height as f32) as u32);
        let (o, d) =
            rlpt::camera::camera_ray(p, x.min(p.width - 1), y.min(p.height - 1), [rng.next_f32(), rng.next_f32()]);
        let Some((t, r)) = closest_hit_counted(s, o, d, f32::INFINITY, &mut st[0]) else { continue };
        let h = prim_hit(s, r, o, d, t);
        // The shading frame on the side the ray came from.
        let ns = if h.ns.dot(d) > 0.0 { -h.ns } else { h.ns };
        let dir = Frame::from_normal(ns).to_world(cosine_hemisphere([rng.next_f32(), rng.next_f32()])).normalize();
        let bo = offset_origin(h.p, h.n, h.eps, dir);
        closest_hit_counted(s, bo, dir, f32::INFINITY, &mut st[1]);
        let (u_sel, u) = (rng.next_f32(), [rng.next_f32(), rng.next_f32()]);
        if s.lights.is_empty() {
            occluded_counted(s, bo, dir, f32::INFINITY, shared::NO_PRIM, &mut st[2]);
        } else if let Some(ls) = sample_light(s, h.p, u_sel, u) {
            if ls.le.max_element() > 0.0 && ls.wi.dot(ns) > 0.0 {
                let (so, sd, len) = shadow_ray(h.p, h.n, h.eps, &ls);
                occluded_counted(s, so, sd, len, ls.skip, &mut st[2]);
            }
        }
    }
    st
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
        eprintln!("| rays | count | nodes | boxes | entered | zero ties | leaves | triangles | quads | spheres | pushes | nodes after hit |");
        eprintln!("|---|---|---|---|---|---|---|---|---|---|---|---|");
        for (kind, st) in ["camera", "bounce", "shadow"].iter().zip(count(&prepared, n)) {
            let r = st.rays.max(1) as f64;
            let f = |v: u64| v as f64 / r;
            eprintln!(
                "| {kind} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
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
