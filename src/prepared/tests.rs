//! Tests of scene preparation: the arrays, the lights, the analysis and the
//! guiding configuration a scene and its options give.

use super::*;
use crate::guide::guided_vertices;
use crate::layout::{MAX_BOUNCES, MAX_IMAGE_SIDE, MAX_SPP};

/// Each option out of range is refused, by name, by the check and by
/// `PreparedScene::new`; the edges of each range are accepted.
#[test]
fn options_out_of_range_are_refused_by_name() {
    let s = scene("door");
    let good = RenderOptions { guiding: GuidingMode::Sphere, ..RenderOptions::from_scene(&s) };
    assert_eq!(good.check(), Ok(()));
    assert!(PreparedScene::new(&s, &good).is_ok());
    // The edges that are allowed.
    for ok in [
        RenderOptions { width: 1, height: MAX_IMAGE_SIDE, max_bounces: MAX_BOUNCES, spp: MAX_SPP, ..good.clone() },
        RenderOptions {
            bins: Some(Bins { rows: 32, cols: 32 }),
            guided_fraction: 0.0,
            guide_floor: 0.0,
            ..good.clone()
        },
        RenderOptions { learning_rate_exponent: 0.500001, guided_vertices: Some(1), ..good.clone() },
    ] {
        assert_eq!(ok.check(), Ok(()), "{ok:?}");
    }
    let cases: Vec<(RenderOptions, &str)> = vec![
        (RenderOptions { width: 0, ..good.clone() }, "width"),
        (RenderOptions { height: MAX_IMAGE_SIDE + 1, ..good.clone() }, "height"),
        (RenderOptions { spp: 0, ..good.clone() }, "spp"),
        (RenderOptions { spp: MAX_SPP + 1, ..good.clone() }, "spp"),
        (RenderOptions { max_bounces: MAX_BOUNCES + 1, ..good.clone() }, "max_bounces"),
        (RenderOptions { bins: Some(Bins { rows: 0, cols: 16 }), ..good.clone() }, "bins"),
        (RenderOptions { bins: Some(Bins { rows: 65536, cols: 65536 }), ..good.clone() }, "bins"),
        (RenderOptions { guided_fraction: 1.0, ..good.clone() }, "guided_fraction"),
        (RenderOptions { guided_fraction: f32::NAN, ..good.clone() }, "guided_fraction"),
        (RenderOptions { guided_fraction: -0.25, learn_fraction: true, ..good.clone() }, "guided_fraction"),
        (RenderOptions { guide_floor: -1.0, ..good.clone() }, "guide_floor"),
        (RenderOptions { guide_floor: f32::INFINITY, ..good.clone() }, "guide_floor"),
        (RenderOptions { guide_floor: 1e5, ..good.clone() }, "guide_floor"),
        (RenderOptions { learning_rate_exponent: 0.5, ..good.clone() }, "learning_rate_exponent"),
        (RenderOptions { learning_rate_exponent: 1.01, ..good.clone() }, "learning_rate_exponent"),
        (RenderOptions { learning_rate_exponent: f32::NAN, ..good.clone() }, "learning_rate_exponent"),
        (RenderOptions { guided_vertices: Some(0), ..good.clone() }, "guided_vertices"),
    ];
    for (opts, option) in cases {
        let e = opts.check().expect_err(option);
        assert_eq!(e.option, option, "{e}");
        let text = e.to_string();
        assert!(text.starts_with(&format!("render option `{option}` is ")), "{text}");
        assert_eq!(PreparedScene::new(&s, &opts).err(), Some(e));
    }
}

/// Without Russian roulette the default follows the NEE flag of the params,
/// also when it is switched after the scene was prepared; an explicit count
/// stays.
#[test]
fn guided_vertices_default_to_two_with_nee_and_all_without() {
    assert_eq!(crate::layout::DEFAULT_GUIDED_VERTICES_NEE, 2);
    let mut p = RenderParams { flags: shared::FLAG_NEE, ..Default::default() };
    assert_eq!(guided_vertices(&p), 2);
    p.set_nee(false);
    assert_eq!(guided_vertices(&p), u32::MAX);
    p.guide_vertices = 3;
    assert_eq!(guided_vertices(&p), 3);
    p.set_nee(true);
    assert_eq!(guided_vertices(&p), 3);
}

/// With Russian roulette the default is every vertex, NEE on or off; an
/// explicit count stays.
#[test]
fn guided_vertices_default_to_all_with_roulette() {
    let mut p = RenderParams { flags: shared::FLAG_RUSSIAN_ROULETTE | shared::FLAG_NEE, ..Default::default() };
    assert_eq!(guided_vertices(&p), u32::MAX);
    p.set_nee(false);
    assert_eq!(guided_vertices(&p), u32::MAX);
    p.guide_vertices = 2;
    assert_eq!(guided_vertices(&p), 2);
    p.set_nee(true);
    assert_eq!(guided_vertices(&p), 2);
}

/// Prepared from the scenes' own settings: door.toml and smallpt.toml (with
/// roulette) guide every vertex, seed-exp1 (without) the first two with NEE and
/// every vertex without; an explicit count wins.
#[test]
fn prepared_scenes_guide_the_vertices_of_their_roulette() {
    for (name, roulette, nee_default) in
        [("door", true, u32::MAX), ("smallpt", true, u32::MAX), ("seed-exp1", false, 2)]
    {
        let s = scene(name);
        assert_eq!(s.render.russian_roulette_depth.is_some(), roulette, "{name}");
        for (nee, want) in [(true, nee_default), (false, u32::MAX)] {
            let o = RenderOptions { guiding: GuidingMode::Sphere, nee, ..RenderOptions::from_scene(&s) };
            let p = PreparedScene::new(&s, &o).expect("valid options");
            assert_eq!(p.params.flags & shared::FLAG_RUSSIAN_ROULETTE != 0, roulette, "{name}");
            assert_eq!(guided_vertices(&p.params), want, "{name}, NEE {nee}");
            let o = RenderOptions { guided_vertices: Some(3), ..o };
            let p = PreparedScene::new(&s, &o).expect("valid options");
            assert_eq!(guided_vertices(&p.params), 3, "{name}, NEE {nee}, explicit");
        }
    }
}

/// `--guiding sphere` without bins takes 20x40 in scenes with Russian roulette
/// and 8x16 without; bins given win; octant stays 2x4, and no guiding has none.
#[test]
fn sphere_bins_default_to_the_scenes_roulette() {
    assert_eq!(guide::default_bins(true), Bins { rows: 20, cols: 40 });
    assert_eq!(guide::default_bins(false), Bins { rows: 8, cols: 16 });
    let given = Bins { rows: 16, cols: 32 };
    for (name, default) in [
        ("door", Bins { rows: 20, cols: 40 }),
        ("smallpt", Bins { rows: 20, cols: 40 }),
        ("seed-exp1", Bins { rows: 8, cols: 16 }),
    ] {
        let s = scene(name);
        let bins_of = |guiding: GuidingMode, bins: Option<Bins>| {
            let o = RenderOptions { guiding, bins, ..RenderOptions::from_scene(&s) };
            assert_eq!(o.check(), Ok(()));
            let p = PreparedScene::new(&s, &o).expect("valid options");
            let b = p.guide.map(|g| g.bins);
            if let Some(b) = b {
                let got = (p.params.guide_bins, p.params.guide_rows, p.params.guide_cols);
                assert_eq!(got, (b.count(), b.rows, b.cols), "{name}: the params carry the bins");
            }
            b
        };
        assert_eq!(RenderOptions::from_scene(&s).bins, None, "{name}");
        assert_eq!(bins_of(GuidingMode::Sphere, None), Some(default), "{name}");
        assert_eq!(bins_of(GuidingMode::Sphere, Some(given)), Some(given), "{name}");
        assert_eq!(bins_of(GuidingMode::Octant, None), Some(Bins { rows: 2, cols: 4 }), "{name}");
        assert_eq!(bins_of(GuidingMode::Octant, Some(given)), Some(Bins { rows: 2, cols: 4 }), "{name}");
        assert_eq!(bins_of(GuidingMode::Off, None), None, "{name}");
    }
}

fn scene(name: &str) -> Scene {
    Scene::load(format!("{}/scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// Each specialization constant of the geometry carries its own number: the
/// float at constant_id SPEC_QUAD_BASE + 13 i + k is float k of quad i's
/// normal, origin, dual_u, dual_v; from SPEC_SPHERE_BASE + 10 i, sphere i's
/// centre, anchor, radius and axis; slots past the scene's primitives are zero;
/// last, the mask of compact spheres.
#[test]
fn geometry_specialization_holds_each_primitive_in_its_slot() {
    let s = scene("seed-exp3");
    let p = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).expect("valid options");
    let c = p.geometry_specialization();
    assert_eq!(c.len() as u32, shared::NUM_SPEC_CONSTANTS - shared::SPEC_QUAD_BASE);
    let at = |id: u32| f32::from_bits(c[geometry_index(id)]);
    assert!(p.quads.len() >= 6 && p.spheres.len() >= 9);
    for (i, q) in p.quads.iter().enumerate() {
        let base = shared::SPEC_QUAD_BASE + shared::SPEC_QUAD_FLOATS * i as u32;
        let want = [q.normal[0], q.normal[1], q.normal[2], q.normal[3], q.origin[0], q.origin[1], q.origin[2]];
        for (k, w) in want.iter().enumerate() {
            assert_eq!(at(base + k as u32), *w, "quad {i}, float {k}");
        }
        for k in 0..3 {
            assert_eq!(at(base + 7 + k as u32), q.dual_u[k], "quad {i}, dual_u[{k}]");
            assert_eq!(at(base + 10 + k as u32), q.dual_v[k], "quad {i}, dual_v[{k}]");
        }
    }
    for (i, sp) in p.spheres.iter().enumerate() {
        let base = shared::SPEC_SPHERE_BASE + shared::SPEC_SPHERE_FLOATS * i as u32;
        for k in 0..3 {
            assert_eq!(at(base + k as u32), sp.center_radius[k], "sphere {i}, center[{k}]");
            assert_eq!(at(base + 7 + k as u32), sp.axis[k], "sphere {i}, axis[{k}]");
        }
        for k in 0..4 {
            assert_eq!(at(base + 3 + k as u32), sp.anchor_radius[k], "sphere {i}, anchor_radius[{k}]");
        }
    }
    let used_quads = shared::SPEC_QUAD_BASE + shared::SPEC_QUAD_FLOATS * p.quads.len() as u32;
    let used_spheres = shared::SPEC_SPHERE_BASE + shared::SPEC_SPHERE_FLOATS * p.spheres.len() as u32;
    for id in (used_quads..shared::SPEC_SPHERE_BASE).chain(used_spheres..shared::SPEC_COMPACT_SPHERES) {
        assert_eq!(c[geometry_index(id)], 0, "unused constant {id}");
    }
    // Every sphere of seed-exp3 is compact; of smallpt's, the balls (radius 16.5) are,
    // not the walls (1e5, centres 1e5 + 80 or less from the origin) nor the lamp (600 at 687).
    let mask = |p: &PreparedScene| p.geometry_specialization()[geometry_index(shared::SPEC_COMPACT_SPHERES)];
    assert_eq!(mask(&p), (1u32 << p.spheres.len()) - 1);
    let smallpt = scene("smallpt");
    let sp = PreparedScene::new(&smallpt, &RenderOptions::from_scene(&smallpt)).expect("valid options");
    let want = sp.spheres.iter().enumerate().fold(0, |m, (i, s)| m | ((s.center_radius[3] < 100.0) as u32) << i);
    assert_eq!(mask(&sp), want);
    assert!(want != 0 && want != (1u32 << sp.spheres.len()) - 1, "smallpt has both kinds: {want:b}");
    // The lights' slots: seed-exp3's lamp quad (moved to the front as the one
    // quad that can block a shadow ray) and its warm globe, its last sphere.
    let slots = |p: &PreparedScene, id: u32| p.geometry_specialization()[geometry_index(id)];
    assert_eq!(slots(&p, shared::SPEC_LIGHT_QUADS), 1);
    assert_eq!(slots(&p, shared::SPEC_LIGHT_SPHERES), 1 << (p.spheres.len() - 1));
    for (i, q) in p.quads.iter().enumerate() {
        assert_eq!(slots(&p, shared::SPEC_LIGHT_QUADS) >> i & 1 == 1, q.light != shared::NO_LIGHT, "quad {i}");
    }
    assert_eq!(slots(&sp, shared::SPEC_LIGHT_QUADS), 0);
    let lamps = sp.spheres.iter().enumerate().fold(0, |m, (i, s)| m | ((s.light != shared::NO_LIGHT) as u32) << i);
    assert_eq!(slots(&sp, shared::SPEC_LIGHT_SPHERES), lamps);
    assert_eq!(lamps.count_ones(), 1, "smallpt has one lamp");
}

/// The ray into the last vertex is traced in full only where it meets a light
/// in scenes with a black environment, every light in a specialized slot and
/// no roulette: the seed's three and the closed furnace; not door (roulette),
/// smallpt (roulette) nor the open furnace (its environment glows); nor a
/// scene whose lamp is the 17th quad.
#[test]
fn the_last_ray_looks_for_lights_where_nothing_else_could_add() {
    let flag = |s: &Scene| {
        let p = PreparedScene::new(s, &RenderOptions::from_scene(s)).expect("valid options");
        p.params.flags & shared::FLAG_LAST_RAY_TO_LIGHTS != 0
    };
    for name in ["seed-exp1", "seed-exp2", "seed-exp3", "furnace-closed"] {
        assert!(flag(&scene(name)), "{name}");
    }
    for name in ["door", "smallpt", "furnace-open"] {
        assert!(!flag(&scene(name)), "{name}");
    }
    // Without roulette door would take it.
    let door = scene("door");
    let mut opts = RenderOptions::from_scene(&door);
    opts.russian_roulette_depth = None;
    let p = PreparedScene::new(&door, &opts).expect("valid options");
    assert!(p.params.flags & shared::FLAG_LAST_RAY_TO_LIGHTS != 0);
    // 16 panels that can block shadow rays, then the lamp: slot 16 is past the
    // specialized ones. With one panel fewer the lamp is in slot 15.
    let text = |panels: u32| {
        let mut t = String::from(
            "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\nvfov = 40\n\
             [[material]]\nname = \"m\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [1, 1, 1]\n",
        );
        for i in 0..panels {
            t += &format!(
                "[[quad]]\norigin = [{x}, 0, 0]\nedge_u = [0.1, 0, 0]\nedge_v = [0, 1, 0]\nmaterial = \"m\"\n",
                x = i as f32 * 0.2 - 1.6
            );
        }
        t + "[[quad]]\norigin = [-1, 2, -1]\nedge_u = [2, 0, 0]\nedge_v = [0, 0, 2]\nmaterial = \"lamp\"\n"
    };
    let many = Scene::parse(&text(16), "t.toml").unwrap();
    let p = PreparedScene::new(&many, &RenderOptions::from_scene(&many)).expect("valid options");
    assert_eq!(p.lights[0].index, 16);
    assert!(!flag(&many));
    assert!(flag(&Scene::parse(&text(15), "t.toml").unwrap()));
}

/// Each quad carries the scale of its points (for hit offsets) in edge_u.w,
/// worked out when the scene is prepared: max |origin| + max |edge_u| +
/// max |edge_v|, which the hit and light-sampling code of both renderers read.
#[test]
fn quads_carry_the_scale_of_their_points() {
    let mut seen = 0;
    for name in ["door", "seed-exp1", "seed-exp3"] {
        let s = scene(name);
        let p = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).expect("valid options");
        for q in &p.quads {
            let m = |v: [f32; 4]| v[..3].iter().fold(0.0f32, |a, x| a.max(x.abs()));
            let want = m(q.origin) + m(q.edge_u) + m(q.edge_v);
            assert!(
                want > 0.0 && q.edge_u[3] == want,
                "{name}: quad at {:?}: {} against {want}",
                q.origin,
                q.edge_u[3]
            );
            seen += 1;
        }
    }
    assert!(seen >= 20, "{seen} quads");
}

/// Every material of the scene file sets its kind's bit, every light its
/// kind's; the seed's diffuse box and door have diffuse, emissive and quad
/// lights only, seed-exp3 everything.
#[test]
fn scene_kinds_name_the_materials_and_lights_of_the_scene() {
    let kinds = |name: &str| {
        let s = scene(name);
        PreparedScene::new(&s, &RenderOptions::from_scene(&s)).expect("valid options").params.scene_kinds
    };
    let mat = |k: u32| 1u32 << k;
    let light = |k: u32| 1u32 << (shared::SCENE_KIND_LIGHT_SHIFT + k);
    let quad_lit = mat(shared::MAT_DIFFUSE) | mat(shared::MAT_EMISSIVE) | light(shared::LIGHT_QUAD);
    assert_eq!(kinds("seed-exp1"), quad_lit);
    assert_eq!(kinds("door"), quad_lit);
    let all_materials = (0..=shared::MAT_EMISSIVE).fold(0, |k, m| k | mat(m));
    // Their glossy balls (roughness 0.3 and 0.08) are too narrow to take guided directions.
    assert_eq!(kinds("seed-exp2"), all_materials | light(shared::LIGHT_QUAD));
    assert_eq!(kinds("seed-exp3"), all_materials | light(shared::LIGHT_QUAD) | light(shared::LIGHT_SPHERE));
    assert_eq!(kinds("smallpt"), all_materials & !mat(shared::MAT_GLOSSY) | light(shared::LIGHT_SPHERE));
    // No lights at all (the furnace lights the ball from the environment).
    assert_eq!(kinds("furnace-open"), mat(shared::MAT_DIFFUSE));
    // A copper of roughness 0.36 (4 alpha^2 = 0.067, at least 1/16) takes guided
    // directions; 0.35 (0.060) does not.
    let copper = |roughness: &str| {
        let path = format!("{}/scenes/seed-exp2.toml", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(path).unwrap();
        assert!(text.contains("roughness = 0.3\n"));
        let s =
            Scene::parse(&text.replace("roughness = 0.3\n", &format!("roughness = {roughness}\n")), "edited").unwrap();
        PreparedScene::new(&s, &RenderOptions::from_scene(&s)).expect("valid options").params.scene_kinds
    };
    let guided_glossy = 1u32 << shared::SCENE_KIND_GUIDED_GLOSSY;
    assert_eq!(copper("0.36"), kinds("seed-exp2") | guided_glossy);
    assert_eq!(copper("0.35"), kinds("seed-exp2"));
}

/// door.toml: the partition's three pieces (both rooms lie on both sides of
/// their plane) can block a shadow ray, in their scene order; the six walls of
/// the rooms cannot, nor the lamp, the scene's one light, on which every
/// shadow ray ends: they come last, in scene order. In the prepared scene the
/// walls, which are the room's (`room_walls`), follow the lamp. The lamp's
/// light follows its quad.
#[test]
fn shadow_rays_test_the_quads_inside_the_scene_first() {
    let s = scene("door");
    let (order, n) = occluding_order(&s);
    assert_eq!(n, 3);
    assert_eq!(order, vec![6, 7, 8, 0, 1, 2, 3, 4, 5, 9]);
    let p = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).expect("valid options");
    assert_eq!(p.params.occluding_quads, 3);
    for (j, &i) in [6, 7, 8, 9, 0, 1, 2, 3, 4, 5].iter().enumerate() {
        assert_eq!(p.quads[j].origin[..3], s.quads[i].origin.to_array());
    }
    assert_eq!(p.lights.len(), 1);
    assert_eq!(p.lights[0].index, 3);
    assert_eq!(p.quads[3].light, 0);
    // The seed's boxes: the lamp alone could (the ceiling is above it, the
    // rest below), and it is the one light of seed-exp1 and exp2; seed-exp3
    // has a second, a sphere, whose shadow rays the lamp can block.
    for name in ["seed-exp1", "seed-exp2"] {
        assert_eq!(occluding_order(&scene(name)), ((0..6).collect(), 0), "{name}");
    }
    let (order, n) = occluding_order(&scene("seed-exp3"));
    assert_eq!((n, order[0]), (1, 5));
    // smallpt has no quads; the furnaces' spheres bound nothing.
    assert_eq!(occluding_order(&scene("smallpt")), (vec![], 0));
}

/// A lamp panel inside the scene (a floor below it, a blocker crossing its
/// plane) goes last where it is the one light, and stays among the occluders
/// where a second lamp's shadow rays could meet it.
#[test]
fn the_one_quad_light_cannot_block_its_own_shadow_rays() {
    let text = |lamps: u32| {
        let mut t = String::from(
            "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\nvfov = 40\n\
             [[material]]\nname = \"m\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [1, 1, 1]\n\
             [[quad]]\norigin = [-5, 0, -5]\nedge_u = [0, 0, 10]\nedge_v = [10, 0, 0]\nmaterial = \"m\"\n\
             [[quad]]\norigin = [-1, 0.5, 0]\nedge_u = [2, 0, 0]\nedge_v = [0, 2, 0]\nmaterial = \"m\"\n",
        );
        for i in 0..lamps {
            t += &format!(
                "[[quad]]\norigin = [{x}, 1, -1]\nedge_u = [1, 0, 0]\nedge_v = [0, 0, 2]\nmaterial = \"lamp\"\n",
                x = 2.0 * i as f32 - 1.5
            );
        }
        Scene::parse(&t, "t.toml").unwrap()
    };
    // The floor bounds the scene; the blocker (z = 0) crosses the lamps' plane (y = 1).
    assert_eq!(occluding_order(&text(1)), (vec![1, 0, 2], 1));
    assert_eq!(occluding_order(&text(2)), (vec![1, 2, 3, 0], 3));
}

/// Touching the plane counts as inside it; crossing it by more than rounding
/// (here by 0.001) keeps the quad among the occluders, for spheres and quads alike.
#[test]
fn a_quad_bounds_the_scene_only_if_nothing_crosses_its_plane() {
    let text = |sphere_y: f32, panel_y: f32| {
        format!(
            "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\nvfov = 40\n\
             [[material]]\nname = \"m\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [[quad]]\norigin = [-5, 0, -5]\nedge_u = [0, 0, 10]\nedge_v = [10, 0, 0]\nmaterial = \"m\"\n\
             [[quad]]\norigin = [-1, {panel_y}, -1]\nedge_u = [2, 1, 0]\nedge_v = [0, 0, 2]\nmaterial = \"m\"\n\
             [[sphere]]\ncenter = [2, {sphere_y}, 0]\nradius = 1\nmaterial = \"m\"\n"
        )
    };
    let order = |sy: f32, py: f32| occluding_order(&Scene::parse(&text(sy, py), "t.toml").unwrap());
    // The floor (y = 0) bounds the scene: the ball rests on it, the tilted panel
    // starts on it. The panel's own plane has the floor on both sides.
    assert_eq!(order(1.0, 0.0), (vec![1, 0], 1));
    // The ball sinks into the floor by a little: the floor could block.
    assert_eq!(order(0.999, 0.0), (vec![0, 1], 2));
    // The panel dips below the floor.
    assert_eq!(order(1.0, -0.001), (vec![0, 1], 2));
}

/// The room of the shipped scenes: seed-exp2's five walls (its front is
/// open), door's six (its partition and lamp are not walls), none in
/// smallpt (spheres only); the walls go last, after the other quads, each
/// face naming the quad that covers it.
#[test]
fn rooms_are_found_where_quads_cover_the_faces_of_the_box() {
    let prep = |name: &str| {
        let s = scene(name);
        (PreparedScene::new(&s, &RenderOptions::from_scene(&s)).unwrap(), s)
    };
    let (p, s) = prep("seed-exp2");
    assert_eq!((p.room.min, p.room.max), (Vec3::ZERO, Vec3::new(100.0, 80.0, 160.0)));
    assert_eq!(p.room.quads, 5);
    // min x: left wall; max x: right; min y: floor; max y: ceiling; min z: back.
    let want = [Some(3), Some(4), Some(0), Some(1), Some(2), None];
    for (face, w) in want.iter().enumerate() {
        let q = p.room.faces[face];
        match w {
            None => assert_eq!(q, shared::NO_QUAD, "face {face} is open"),
            Some(i) => {
                assert!(q >= 1, "face {face}: the walls come after the lamp");
                let (a, b) = (&p.quads[q as usize], &s.quads[*i]);
                assert_eq!(a.origin[..3], b.origin.to_array(), "face {face}");
            }
        }
    }
    let (p, _) = prep("door");
    assert_eq!((p.room.quads, p.quads.len()), (6, 10));
    assert!(p.room.faces.iter().all(|q| (4..10).contains(q)), "{:?}", p.room.faces);
    assert_eq!(p.params.occluding_quads, 3, "the partition still blocks shadow rays");
    assert_eq!(prep("smallpt").0.room, Room::NONE);
    // A wall short of its face is no wall of the room: door's floor cut at
    // x = 8.5 leaves the floor to the walk (and the box is still 9 long:
    // the ceiling spans it).
    let mut s = scene("door");
    s.quads[0].edge_v = Vec3::new(8.5, 0.0, 0.0);
    let p = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).unwrap();
    assert_eq!((p.room.quads, p.room.faces[2]), (5, shared::NO_QUAD));
}

/// The walk with the room finds what the walk over every quad finds: the
/// same distance and surface for rays from inside the box, from outside it
/// with the entering face tested, and, without it, from where seed-exp2's
/// camera stands (in front of its open face); but where a hit lies on an
/// edge of the box, where either wall is right.
#[test]
fn the_room_test_finds_what_the_quads_own_tests_find() {
    use crate::math::geometry::intersect;
    use crate::math::rng::Rng;
    use crate::math::sampling::uniform_sphere;
    for name in ["seed-exp2", "door", "seed-exp1"] {
        let s = scene(name);
        let with = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).unwrap();
        assert!(with.room.quads > 0, "{name}");
        assert!(!with.room.entering, "{name}: the camera looks in through an open face, or stands inside");
        let mut without = with.clone();
        without.room = Room::NONE;
        let mut entering = with.clone();
        entering.room.entering = true;
        let (lo, hi) = (with.room.min, with.room.max);
        let size = (hi - lo).max_element();
        let cam = Vec3::from_slice(&with.params.cam_position_near[..3]);
        let mut rng = Rng::new(7, 0, 0, 0);
        let (mut checked, mut walls) = (0, 0);
        for k in 0..30000 {
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            // A third of the origins inside the box, a third in a box three
            // times as large (entering face tested), a third near the camera.
            let (o, room) = match k % 3 {
                0 => (lo + u * (hi - lo), &with),
                1 => (lo - (hi - lo) + u * 3.0 * (hi - lo), &entering),
                _ => (cam + (u - 0.5) * 1e-2 * size, &with),
            };
            let d = uniform_sphere([rng.next_f32(), rng.next_f32()]);
            let (a, b) = (intersect(room, o, d, f32::INFINITY), intersect(&without, o, d, f32::INFINITY));
            let on_edge = |p: Vec3| {
                let near = |x: f32, l: f32, h: f32| (x - l).abs() < 1e-4 * size || (x - h).abs() < 1e-4 * size;
                (0..3).filter(|&a| near(p[a], lo[a], hi[a])).count() >= 2
            };
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) if on_edge(b.p) => assert!((a.t - b.t).abs() <= 1e-4 * b.t, "{name}: {o} {d}"),
                (Some(a), Some(b)) => {
                    assert!((a.t - b.t).abs() <= 1e-6 * b.t, "{name}: {o} {d}: t {} against {}", a.t, b.t);
                    assert_eq!((a.material, a.light, a.n), (b.material, b.light, b.n), "{name}: {o} {d}");
                    checked += 1;
                    walls += with.room.faces.iter().any(|&q| {
                        q != shared::NO_QUAD
                            && with.quads[q as usize].material == a.material
                            && with.quads[q as usize].normal[..3] == a.n.to_array()
                    }) as u32;
                }
                (a, b) => panic!("{name}: {o} {d}: {a:?} with the room, {b:?} without"),
            }
        }
        assert!(checked > 5000 && walls > 2000, "{name}: {checked} hits, {walls} on walls");
    }
    // A camera moved outside, beyond a wall, may meet walls from outside.
    let s = scene("door");
    let mut p = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).unwrap();
    assert!(!p.room.camera_may_enter(&p.params));
    p.params.cam_position_near[0] = -1.0;
    assert!(p.room.camera_may_enter(&p.params));
    let s = scene("seed-exp2");
    let mut p = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).unwrap();
    p.params.cam_position_near[1] = 90.0;
    assert!(p.room.camera_may_enter(&p.params), "above the ceiling");
    p.params.cam_position_near[1] = 40.0;
    p.params.cam_position_near[3] = 30.0;
    assert!(!p.room.camera_may_enter(&p.params), "in front of the open face, rays starting 30 from it");
    p.params.cam_position_near[3] = 45.0;
    assert!(p.room.camera_may_enter(&p.params), "rays starting 45 from it may start above the ceiling");
}
