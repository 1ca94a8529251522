//! pbrt import (`docs/pbrt.md`): each construct in a small scene of the test's
//! own, read into the `Scene` the renderers draw. Without a `Camera`, pbrt's
//! camera space is its world, and rlpt's space is that mirrored in x.

mod common;
mod pbrt_support;

use common::cli::fresh_dir;
use common::files::write;
use glam::{DMat4, DVec3, Vec3};
use pbrt_support::{close, load, note, TRIANGLE};
use rlpt::scene::{MaterialKind, Scene};
use std::f64::consts::{FRAC_PI_2, PI};

/// rlpt's space of a pbrt world point, for a scene without a Camera.
fn baked(p: DVec3) -> Vec3 {
    Vec3::new(-p.x as f32, p.y as f32, p.z as f32)
}

/// The geometric front of the first triangle of the first mesh.
fn front(scene: &Scene) -> Vec3 {
    let m = &scene.meshes[0];
    let [a, b, c] = m.triangles[0].map(|i| m.positions[i as usize]);
    (b - a).cross(c - a).normalize()
}

#[test]
fn film_camera_sampler_and_integrator() {
    let s = load(
        "film",
        &format!(
            "Film \"rgb\" \"integer xresolution\" 200 \"integer yresolution\" [100] \"string filename\" \"x.exr\"\n\
             Sampler \"halton\" \"integer pixelsamples\" 32\nIntegrator \"volpath\" \"integer maxdepth\" [ 7 ]\n\
             PixelFilter \"gaussian\"\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n{TRIANGLE}"
        ),
    );
    assert_eq!((s.render.width, s.render.height, s.render.spp, s.render.max_bounces), (200, 100, 32, 7));
    // Landscape: pbrt's fov spans the shorter side, the vertical one.
    assert!((s.camera.vfov_deg - 40.0).abs() < 1e-5);
    note(&s, "Film \"rgb\": resolution taken");
    note(&s, "ignored \"string filename\"");
    note(&s, "Sampler \"halton\"");
    note(&s, "PixelFilter \"gaussian\"");
    // Portrait: the fov is horizontal, rlpt's vfov the wider angle.
    let s = load(
        "portrait",
        &format!("Film \"rgb\" \"integer xresolution\" 100 \"integer yresolution\" 200\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n{TRIANGLE}"),
    );
    let expected = 2.0 * ((20f64.to_radians().tan() * 2.0).atan().to_degrees());
    assert!((s.camera.vfov_deg as f64 - expected).abs() < 1e-4, "{} vs {expected}", s.camera.vfov_deg);
}

#[test]
fn look_at_bakes_the_world_into_pbrt_camera_space_mirrored() {
    // Eye at z = 5 looking at the origin: pbrt's camera x is cross(up, dir) = -x
    // of the world, so the sphere at world +x is on the left of pbrt's image.
    let s = load(
        "lookat",
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\nWorldBegin\n\
         Translate 1 0 0\nShape \"sphere\" \"float radius\" 0.5\n",
    );
    let c = s.spheres[0].center;
    assert!(close(c, Vec3::new(1.0, 0.0, 5.0)), "{c}");
    assert!((s.spheres[0].radius - 0.5).abs() < 1e-6);
    // rlpt's camera: image x grows along forward x up.
    let right = s.camera.forward.cross(s.camera.up);
    assert!(c.dot(right) / c.dot(s.camera.forward) < 0.0, "the sphere must be left of centre");
}

#[test]
fn transforms_attributes_and_coordinate_systems() {
    let tri = "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] \"integer indices\" [0 1 2]\n";
    let s = load(
        "transforms",
        &format!(
            "WorldBegin\nAttributeBegin\nTranslate 1 2 3\n{tri}CoordinateSystem \"moved\"\nAttributeEnd\n\
             TransformBegin\nScale 2 2 2\n{tri}TransformEnd\n{tri}\
             AttributeBegin\nRotate 90 0 0 1\n{tri}AttributeEnd\n\
             AttributeBegin\nTransform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1]\nConcatTransform [2 0 0 0 0 2 0 0 0 0 2 0 0 0 0 1]\n{tri}AttributeEnd\n\
             AttributeBegin\nCoordSysTransform \"moved\"\n{tri}AttributeEnd\n"
        ),
    );
    let ms = DMat4::from_scale(DVec3::splat(2.0));
    let cases = [
        DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0)),
        ms,
        DMat4::IDENTITY,
        DMat4::from_rotation_z(90f64.to_radians()),
        DMat4::from_translation(DVec3::new(5.0, 6.0, 7.0)) * ms,
        DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0)),
    ];
    assert_eq!(s.meshes.len(), cases.len());
    for (k, (m, want)) in s.meshes.iter().zip(cases).enumerate() {
        let mut got: Vec<[i64; 3]> =
            m.positions.iter().map(|p| (p.as_dvec3() * 1e4).round().as_i64vec3().to_array()).collect();
        let mut expected: Vec<[i64; 3]> = [DVec3::ZERO, DVec3::X, DVec3::Y]
            .iter()
            .map(|&p| (baked(want.transform_point3(p)).as_dvec3() * 1e4).round().as_i64vec3().to_array())
            .collect();
        got.sort();
        expected.sort();
        assert_eq!(got, expected, "shape {k}");
    }
}

#[test]
fn include_and_import_read_files_relative_to_the_scene() {
    let d = fresh_dir("include");
    write(&d, "parts/geo.pbrt", TRIANGLE);
    write(&d, "parts/more.pbrt", "Translate 0 0 1\nInclude \"parts/geo.pbrt\"\n");
    let p = write(&d, "scene.pbrt", "WorldBegin\nInclude \"parts/geo.pbrt\"\nImport \"parts/more.pbrt\"\n");
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.meshes.len(), 2);
    assert!((s.meshes[1].positions[0].z - s.meshes[0].positions[0].z - 1.0).abs() < 1e-6);
}

/// The scene material of the first mesh of a scene with `material` (a
/// Material or MakeNamedMaterial/NamedMaterial block) before one triangle.
fn material_of(test: &str, material: &str) -> (Scene, rlpt::scene::Material) {
    let s = load(test, &format!("WorldBegin\n{material}\n{TRIANGLE}"));
    let m = s.materials[s.meshes[0].materials[0] as usize].clone();
    (s, m)
}

fn fresnel(eta: Vec3, k: Vec3) -> Vec3 {
    ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k)
}

#[test]
fn materials_map_onto_rlpt_kinds() {
    let (s, m) = material_of("diffuse", "MakeNamedMaterial \"wall\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.2 0.3 0.4]\nNamedMaterial \"wall\"");
    assert_eq!((m.kind, m.albedo), (MaterialKind::Diffuse, Vec3::new(0.2, 0.3, 0.4)));
    assert!(s.material_mappings.iter().any(|l| l.starts_with("wall: diffuse -> diffuse")), "{:?}", s.material_mappings);

    // Conductor: eta and k as given (named spectra through pbrt's RGB table); v4
    // remaps roughness r to alpha sqrt(r), and rlpt's roughness is sqrt(alpha).
    let (eta, k) = (Vec3::new(0.2, 0.9, 1.1), Vec3::new(3.9, 2.4, 2.1));
    let (s, m) = material_of(
        "conductor",
        "Material \"conductor\" \"rgb eta\" [0.2 0.9 1.1] \"rgb k\" [3.9 2.4 2.1] \"float roughness\" 0.0625",
    );
    assert_eq!((m.kind, m.eta, m.k), (MaterialKind::Conductor, eta, k));
    assert!((m.roughness - 0.5).abs() < 1e-6, "{}", m.roughness);
    assert!(s.material_mappings.iter().any(|l| l.contains("conductor -> conductor")));
    let (_, m) =
        material_of("unremapped", "Material \"conductor\" \"float roughness\" 0.01 \"bool remaproughness\" false");
    assert!((m.roughness - 0.1).abs() < 1e-6, "{m:?}");
    assert_eq!(
        (m.eta, m.k),
        (Vec3::new(0.200438, 0.924033, 1.10221), Vec3::new(3.91295, 2.45285, 2.14219)),
        "copper by default"
    );
    // Smooth (alpha below pbrt-v4's 1e-3): a mirror, roughness 0.
    let (_, m) =
        material_of("smooth", "Material \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\"");
    assert_eq!((m.kind, m.roughness), (MaterialKind::Conductor, 0.0));
    assert_eq!((m.eta, m.k), (Vec3::new(0.143119, 0.374957, 1.44248), Vec3::new(3.98316, 2.38572, 1.60322)));
    // reflectance instead of eta and k: as pbrt-v4, eta 1 and k = 2 sqrt(r) / sqrt(1 - r),
    // whose normal-incidence reflectance is r.
    let (_, m) = material_of("reflectance", "Material \"conductor\" \"rgb reflectance\" [0.9 0.5 0.1]");
    assert!(close(fresnel(m.eta, m.k), Vec3::new(0.9, 0.5, 0.1)), "{m:?}");
    // pbrt-v3 metal with u/v roughness, not remapped.
    let (_, m) = material_of(
        "metal",
        "Material \"metal\" \"float uroughness\" 0.25 \"float vroughness\" 0.25 \"bool remaproughness\" \"false\"",
    );
    assert!((m.kind, (m.roughness - 0.5).abs() < 1e-6) == (MaterialKind::Conductor, true), "{m:?}");

    // Rough dielectric: alpha sqrt(0.1) (v4 remapping), rlpt roughness its root.
    let (s, m) = material_of("dielectric", "Material \"dielectric\" \"float eta\" 1.33 \"float roughness\" 0.1");
    assert_eq!((m.kind, m.ior), (MaterialKind::RoughDielectric, 1.33));
    assert!((m.roughness - 0.1f32.sqrt().sqrt()).abs() < 1e-6, "{m:?}");
    assert!(
        s.material_mappings.iter().any(|l| l.contains("dielectric -> roughdielectric")),
        "{:?}",
        s.material_mappings
    );
    assert!(!s.notes.iter().any(|n| n.contains("rough")), "{:#?}", s.notes);
    let (s, m) = material_of("glass", "Material \"glass\" \"float index\" 1.7");
    assert_eq!((m.kind, m.ior), (MaterialKind::Dielectric, 1.7));
    // pbrt-v3 glass at roughness 0 is smooth although its remapping of 0 is not.
    assert!(!s.notes.iter().any(|n| n.contains("rough")), "{:#?}", s.notes);
    let (_, m) = material_of("mirror", "Material \"mirror\" \"rgb Kr\" [0.5 0.6 0.7]");
    assert_eq!((m.kind, m.albedo), (MaterialKind::Specular, Vec3::new(0.5, 0.6, 0.7)));
    let (s, m) = material_of("interface", "Material \"interface\"");
    assert_eq!((m.kind, m.ior), (MaterialKind::Dielectric, 1.0));
    note(&s, "no surface");
}

#[test]
fn approximated_materials_are_noted_once_with_their_line() {
    for (ty, key) in [("diffusetransmission", "reflectance"), ("uber", "Kd"), ("translucent", "Kd")] {
        let (s, m) = material_of(ty, &format!("\nMaterial \"{ty}\" \"rgb {key}\" [0.1 0.2 0.3]"));
        assert_eq!((m.kind, m.albedo), (MaterialKind::Diffuse, Vec3::new(0.1, 0.2, 0.3)), "{ty}");
        let n = note(&s, &format!("{ty} rendered as diffuse"));
        assert!(n.contains("scene.pbrt:3:"), "{n}");
        assert_eq!(s.notes.iter().filter(|n| n.contains("rendered as")).count(), 1, "{ty}: {:#?}", s.notes);
    }
    // The coated ones: rlpt's coated material, with no note where it takes every
    // parameter given; pbrt-v3's plastic and substrate by their v3 remapping.
    let (s, m) = material_of(
        "coateddiffuse",
        "Material \"coateddiffuse\" \"rgb reflectance\" [0.1 0.2 0.3] \"float roughness\" 0.04 \"float eta\" 1.6",
    );
    assert_eq!((m.kind, m.albedo, m.ior), (MaterialKind::Coated, Vec3::new(0.1, 0.2, 0.3), 1.6));
    assert!((m.roughness - 0.04f32.sqrt().sqrt()).abs() < 1e-6, "{m:?}");
    assert!(!s.notes.iter().any(|n| n.contains("material")), "{:#?}", s.notes);
    // pbrt-v4's coatedconductor: its coat's index and roughness, its conductor's
    // index and roughness (remapped, or not with remaproughness false), or its
    // reflectance (eta 1, k from it); a smooth coat stays smooth, without a note.
    let (s, m) = material_of(
        "coatedconductor",
        "Material \"coatedconductor\" \"float interface.eta\" 1.7 \"float interface.roughness\" 0.09 \
         \"spectrum conductor.eta\" \"metal-Au-eta\" \"spectrum conductor.k\" \"metal-Au-k\" \"float conductor.roughness\" 0.01",
    );
    assert_eq!((m.kind, m.ior, m.eta.x, m.k.x), (MaterialKind::Coated, 1.7, 0.143119, 3.98316));
    assert!((m.roughness - 0.09f32.sqrt().sqrt()).abs() < 1e-6 && m.roughness_texture.is_none(), "{m:?}");
    assert!((m.base_roughness.unwrap() - 0.01f32.sqrt().sqrt()).abs() < 1e-6, "{m:?}");
    assert!(!s.notes.iter().any(|n| n.contains("material")), "{:#?}", s.notes);
    let (s, m) = material_of(
        "coatedconductor",
        "Material \"coatedconductor\" \"rgb reflectance\" [0.9 0.5 0.2] \"float conductor.roughness\" 0.09 \
         \"bool remaproughness\" false",
    );
    assert_eq!((m.kind, m.ior, m.roughness, m.eta), (MaterialKind::Coated, 1.5, 0.0, Vec3::ONE));
    assert!((m.k - rlpt::scene::conductor_k(Vec3::new(0.9, 0.5, 0.2))).abs().max_element() < 1e-6, "{m:?}");
    assert!((m.base_roughness.unwrap() - 0.3).abs() < 1e-6, "alpha 0.09 not remapped: {m:?}");
    assert!(!s.notes.iter().any(|n| n.contains("material")), "{:#?}", s.notes);
    for (ty, key) in [("plastic", "Kd"), ("substrate", "Kd")] {
        let (s, m) =
            material_of(ty, &format!("\nMaterial \"{ty}\" \"rgb {key}\" [0.1 0.2 0.3] \"rgb Ks\" [0.4 0.4 0.4]"));
        assert_eq!((m.kind, m.albedo, m.ior), (MaterialKind::Coated, Vec3::new(0.1, 0.2, 0.3), 1.5), "{ty}");
        // pbrt-v3's default roughness 0.1, remapped by its polynomial.
        let x = 0.1f64.ln();
        let alpha = 1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x.powi(3) + 0.000640711 * x.powi(4);
        assert!((m.roughness as f64 - alpha.sqrt()).abs() < 1e-5, "{ty}: {m:?}");
        let n = note(&s, "Ks [0.4, 0.4, 0.4] dropped");
        assert!(n.contains("scene.pbrt:3:"), "{n}");
    }
    // mix: two diffuse materials blend by amount (the second's share).
    let (s, m) = material_of(
        "mix",
        "MakeNamedMaterial \"a\" \"string type\" \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
         MakeNamedMaterial \"b\" \"string type\" \"diffuse\" \"rgb reflectance\" [1 1 1]\n\
         MakeNamedMaterial \"m\" \"string type\" \"mix\" \"float amount\" 0.25 \"string materials\" [\"a\" \"b\"]\nNamedMaterial \"m\"",
    );
    assert!(close(m.albedo, Vec3::splat(0.25)), "{}", m.albedo);
    // The same in expectation as pbrt-v4's choice per hit: no note.
    assert!(!s.notes.iter().any(|n| n.contains("(mix)")), "{:#?}", s.notes);
    assert!(s.material_mappings.iter().any(|m| m.contains("mix -> diffuse (albedos of \"a\" and \"b\" blended")));
    // A parameter nothing reads is named.
    let (s, _) = material_of("unused", "Material \"diffuse\" \"float frobnicate\" 3");
    note(&s, "ignored \"float frobnicate\"");
}

#[test]
fn shapes_trianglemesh_bilinearmesh_sphere_plymesh_and_instances() {
    let d = fresh_dir("shapes");
    write(
        &d,
        "quad.ply",
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n",
    );
    let p = write(
        &d,
        "scene.pbrt",
        "WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0]\n\
         Shape \"plymesh\" \"string filename\" \"quad.ply\"\n\
         ObjectBegin \"thing\"\nShape \"plymesh\" \"string filename\" \"quad.ply\"\nObjectEnd\n\
         AttributeBegin\nTranslate 10 0 0\nObjectInstance \"thing\"\nAttributeEnd\n\
         AttributeBegin\nTranslate 20 0 0\nObjectInstance \"thing\"\nAttributeEnd\n\
         AttributeBegin\nScale 2 2 2\nShape \"sphere\" \"float radius\" 1.5\nAttributeEnd\n\
         AttributeBegin\nScale 1 2 1\nShape \"sphere\"\nAttributeEnd\n",
    );
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.meshes.len(), 4, "bilinear patch, the PLY, and two instances of the object");
    assert_eq!(s.meshes[0].triangles.len(), 2);
    // The bilinear patch's two triangles cover the unit square.
    let area: f32 = s.meshes[0]
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| s.meshes[0].positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    assert!((area - 1.0).abs() < 1e-6, "{area}");
    for (k, dx) in [(2, 10.0), (3, 20.0)] {
        let min_x = s.meshes[k].positions.iter().map(|p| -p.x).fold(f32::INFINITY, f32::min);
        assert!((min_x - dx).abs() < 1e-5, "instance {k}: {min_x}");
    }
    assert_eq!(s.spheres.len(), 2);
    assert!((s.spheres[0].radius - 3.0).abs() < 1e-6);
    note(&s, "non-uniform scale");
}

#[test]
fn one_sided_emission_faces_where_pbrt_emits() {
    // Front by the winding (+z); ReverseOrientation turns it; a mirroring
    // transform keeps it (pbrt flips its normal where handedness swaps); given
    // normals decide it.
    let light = "AreaLightSource \"diffuse\" \"rgb L\" [5 5 5]\n";
    let cases = [
        ("", "", Vec3::Z),
        ("ReverseOrientation\n", "", -Vec3::Z),
        ("Scale -1 1 1\n", "", Vec3::Z),
        ("Scale -1 1 1\nReverseOrientation\n", "", -Vec3::Z),
        ("", "\"normal N\" [0 0 -1 0 0 -1 0 0 -1]", -Vec3::Z),
        ("ReverseOrientation\n", "\"normal N\" [0 0 -1 0 0 -1 0 0 -1]", Vec3::Z),
    ];
    for (k, (state, normals, want)) in cases.into_iter().enumerate() {
        let s = load(
            &format!("emit{k}"),
            &format!(
                "WorldBegin\nAttributeBegin\n{light}{state}Shape \"trianglemesh\" \"point3 P\" [0 0 5  1 0 5  0 1 5] \
                 \"integer indices\" [0 1 2] {normals}\nAttributeEnd\n"
            ),
        );
        let m = &s.materials[s.meshes[0].materials[0] as usize];
        assert!(m.emission == Vec3::splat(5.0) && !m.two_sided, "{m:?}");
        // The x-flip of rlpt's space leaves z alone.
        assert!(close(front(&s), want), "case {k}: front {} expected {want}", front(&s));
    }
    let s = load("twosided", &format!("WorldBegin\nAreaLightSource \"diffuse\" \"blackbody L\" 5500 \"float scale\" 2 \"bool twosided\" true\n{TRIANGLE}"));
    let m = &s.materials[s.meshes[0].materials[0] as usize];
    assert!(m.two_sided && m.emission == Vec3::splat(2.0), "{m:?}");
    note(&s, "blackbody");
}

#[test]
fn lights_environment_and_dropped_goniometric_and_projection_lights() {
    let s = load(
        "infinite",
        &format!(
            "WorldBegin\nLightSource \"infinite\" \"rgb L\" [0.5 0.25 0.125] \"float scale\" 2\n\
             LightSource \"goniometric\"\nLightSource \"projection\"\n{TRIANGLE}"
        ),
    );
    assert_eq!(s.environment, Vec3::new(1.0, 0.5, 0.25));
    for ty in ["goniometric", "projection"] {
        assert!(note(&s, &format!("LightSource \"{ty}\" dropped")).contains("scene.pbrt:"));
    }
    let s = load(
        "envmissing",
        &format!("WorldBegin\nLightSource \"infinite\" \"string filename\" \"sky.exr\"\n{TRIANGLE}"),
    );
    assert_eq!(s.environment, Vec3::ONE);
    note(&s, "\"sky.exr\"");
}

/// An `infinite` light's equirectangular image (pbrt-v3's map: z up in the
/// light's space, u = phi / 2 pi from +x towards +y) renders as an image: the
/// rlpt direction of a texel's centre, through the light's transform and the
/// bake, looks up that texel, for rotations and for a mirroring transform. A
/// transform that is not a rotation and a square (pbrt-v4 equal-area) image fall
/// back to the mean with a note.
#[test]
fn infinite_light_images_render_as_images_turned_by_their_transform() {
    use rlpt::math::envmap::env_lookup;
    use rlpt::options::RenderOptions;
    use rlpt::prepared::PreparedScene;
    let d = fresh_dir("envimage");
    let (w, h) = (16u32, 8u32);
    let bright = (5u32, 2u32);
    let img = image::Rgb32FImage::from_fn(w, h, |x, y| {
        image::Rgb(if (x, y) == bright { [50.0, 40.0, 30.0] } else { [0.1 + 0.01 * x as f32, 0.2, 0.3] })
    });
    img.save(d.join("sky.exr")).unwrap();
    let texel_dir = |x: u32, y: u32| {
        let (phi, theta) = (2.0 * PI * (x as f64 + 0.5) / w as f64, PI * (y as f64 + 0.5) / h as f64);
        DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    };
    for (transform, m) in [
        ("", DMat4::IDENTITY),
        ("Rotate -90 1 0 0\n", DMat4::from_axis_angle(DVec3::X, -FRAC_PI_2)),
        ("Rotate 30 0.3 1 0.2\nScale 2 2 2\n", DMat4::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), PI / 6.0)),
        (
            "Scale -1 1 1\nRotate 50 0 0 1\n",
            DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0)) * DMat4::from_axis_angle(DVec3::Z, 50f64.to_radians()),
        ),
    ] {
        let p = write(
            &d,
            "scene.pbrt",
            format!(
                "WorldBegin\nAttributeBegin\n{transform}LightSource \"infinite\" \"string filename\" \"sky.exr\" \"rgb L\" [2 2 2]\nAttributeEnd\n{TRIANGLE}"
            ),
        );
        let s = Scene::load(&p).unwrap();
        assert!(s.environment_map.is_some() && s.environment == Vec3::ZERO, "{transform:?}: {:?}", s.notes);
        let prepared = PreparedScene::new(&s, &RenderOptions::from_scene(&s)).unwrap();
        for (x, y) in [bright, (bright.0 + 1, bright.1), (bright.0, bright.1 + 1), (12, 6)] {
            let world = m.transform_vector3(texel_dir(x, y));
            let (le, _) = env_lookup(&prepared, baked(world).normalize());
            let want = img.get_pixel(x, y).0.map(|c| 2.0 * c);
            assert!(close(le, Vec3::from(want)), "{transform:?}: texel ({x}, {y}) reads {le}, not {want:?}");
        }
    }
    // Not a rotation; a square image.
    let s = load(
        "envshear",
        &format!(
            "WorldBegin\nScale 1 3 1\nLightSource \"infinite\" \"string filename\" \"{}\"\n{TRIANGLE}",
            d.join("sky.exr").display()
        ),
    );
    assert!(s.environment_map.is_none() && s.environment.max_element() > 0.0);
    note(&s, "not a rotation: a uniform sky of its mean radiance");
    image::Rgb32FImage::from_fn(8, 8, |_, _| image::Rgb([1.0, 1.0, 1.0])).save(d.join("square.exr")).unwrap();
    let s = load(
        "envsquare",
        &format!(
            "WorldBegin\nLightSource \"infinite\" \"string filename\" \"{}\"\n{TRIANGLE}",
            d.join("square.exr").display()
        ),
    );
    assert!(s.environment_map.is_none() && close(s.environment, Vec3::ONE));
    note(&s, "pbrt-v4's equal-area octahedral map, which rlpt does not read");
}

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn image_textures_are_read_and_maps_stand_in_as_their_mean() {
    let d = fresh_dir("texture");
    // A 2x2 8-bit image: its mean is taken after sRGB decoding, as pbrt reads it.
    let px = [[255u8, 0, 0], [0, 255, 0], [0, 0, 255], [128, 128, 128]];
    let img = image::RgbImage::from_fn(2, 2, |x, y| image::Rgb(px[(y * 2 + x) as usize]));
    img.save(d.join("tex.png")).unwrap();
    std::fs::create_dir_all(d.join("jpg")).unwrap();
    img.save(d.join("jpg/other.png")).unwrap();
    let p = write(
        &d,
        "scene.pbrt",
        format!(
            "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"tex.png\"\n\
             Texture \"u\" \"spectrum\" \"imagemap\" \"string filename\" \"tga/other.tga\"\n\
             Material \"diffuse\" \"texture reflectance\" \"t\"\n{TRIANGLE}\
             Material \"diffuse\" \"texture reflectance\" \"u\"\n{TRIANGLE}\
             LightSource \"infinite\" \"string filename\" \"tex.png\"\n"
        ),
    );
    let s = Scene::load(&p).unwrap();
    let mut mean = DVec3::ZERO;
    for c in px {
        mean += DVec3::new(
            srgb_to_linear(c[0] as f64 / 255.0),
            srgb_to_linear(c[1] as f64 / 255.0),
            srgb_to_linear(c[2] as f64 / 255.0),
        ) / 4.0;
    }
    // The reflectance reads the image (its texture has no scale: albedo 1); the
    // triangle has no UVs, so its copy of the material takes the image's mean, noted.
    let m = &s.materials[s.meshes[0].materials[0] as usize];
    assert!(close(m.albedo, mean.as_vec3()), "{} vs {mean}", m.albedo);
    let textured = s.materials.iter().find(|m| m.albedo_texture.is_some()).expect("a textured material");
    assert_eq!(textured.albedo, Vec3::ONE);
    assert!(textured.albedo_texture.as_ref().unwrap().path.ends_with("tex.png"));
    note(&s, "has no texture coordinates");
    // A missing image found under another extension beside it, said so, and read.
    let n = note(&s, "texture image \"tga/other.tga\"");
    assert!(n.contains("is missing") && n.contains("other.png"), "{n}");
    assert!(s.textures.iter().any(|t| t.path.ends_with("jpg/other.png")));
    assert!(close(s.materials[s.meshes[1].materials[0] as usize].albedo, mean.as_vec3()));
    assert!(close(s.environment, mean.as_vec3()));
    note(&s, "uniform sky of its mean radiance");
}

#[test]
fn strict_refuses_what_would_be_noted() {
    let d = fresh_dir("strict");
    let p = write(&d, "scene.pbrt", format!("WorldBegin\nMaterial \"coatedconductor\"\n{TRIANGLE}"));
    assert!(Scene::load(&p).is_ok());
    let e = Scene::load_with(&p, true).unwrap_err().to_string();
    assert!(
        e.contains("scene.pbrt:2:1: ") && e.contains("a smooth conductor under the coat") && e.contains("--strict"),
        "{e}"
    );
    // A smooth coat is rendered as one: nothing to note.
    let p = write(&d, "smooth.pbrt", format!("WorldBegin\nMaterial \"coateddiffuse\"\n{TRIANGLE}"));
    assert!(Scene::load_with(&p, true).is_ok());
    // Render settings rlpt takes from its own options stay notes.
    let p = write(&d, "ok.pbrt", format!("Sampler \"halton\"\nWorldBegin\n{TRIANGLE}"));
    assert!(Scene::load_with(&p, true).is_ok());
}

#[test]
fn strict_refuses_a_toml_scene_whose_mesh_file_is_noted() {
    let d = fresh_dir("strict-toml");
    write(&d, "m.mtl", "newmtl wood\nKd 0.5 0.5 0.5\nmap_Kd wood.png\n");
    write(&d, "m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl wood\nf 1 2 3\n");
    let p = write(
        &d,
        "scene.toml",
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = 40\n[[mesh]]\nfile = \"m.obj\"\n",
    );
    let s = Scene::load(&p).unwrap();
    let first = s.notes.first().expect("the texture is noted").clone();
    let e = Scene::load_with(&p, true).unwrap_err().to_string();
    assert!(e.contains(&first) && e.contains("--strict"), "{e}");
}

#[test]
fn end_time_transforms_are_ignored_with_a_note() {
    let s = load(
        "activetransform",
        &format!(
            "WorldBegin\nActiveTransform EndTime\nTranslate 100 0 0\nActiveTransform All\nTranslate 0 1 0\n{TRIANGLE}"
        ),
    );
    let min_y = s.meshes[0].positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    let max_x = s.meshes[0].positions.iter().map(|p| p.x.abs()).fold(0.0, f32::max);
    assert!((min_y - 1.0).abs() < 1e-6 && max_x <= 1.0, "{:?}", s.meshes[0].positions);
    assert!(note(&s, "Translate under ActiveTransform EndTime ignored").contains("scene.pbrt:3:"));
}
