//! Delta lights (distant, point, spot; docs/correctness.md "Delta lights"): a
//! diffuse plane lit by one, rendered with one bounce on the GPU and the CPU,
//! against the analytic radiance rho/pi E (E = I cos / r^2, L cos, pbrt-v4's
//! spot falloff) averaged over each pixel; GPU and CPU agreement with an area
//! light beside them, guided too; the pbrt import; bad input.

mod common;
mod pbrt_support;

use common::*;
use glam::Vec3;
use pbrt_support::{close, load, refuse, TRIANGLE};
use rlpt::film::Film;
use rlpt::prepared::PreparedScene;
use rlpt::scene::{DeltaLight, Scene};

const ALBEDO: f32 = 0.5;

/// A large diffuse floor at y = 0 seen from straight above, one bounce, no area light.
fn floor_scene(vfov: f32) -> Scene {
    let text = format!(
        "[camera]\nposition = [0, 2, 0]\ndirection = [0, -1, 0]\nup = [0, 0, -1]\nvfov = {vfov}\n\
         [render]\nmax_bounces = 1\n\
         [[material]]\nname = \"floor\"\ntype = \"diffuse\"\nalbedo = [{ALBEDO}, {ALBEDO}, {ALBEDO}]\n\
         [[quad]]\norigin = [-20, 0, 20]\nedge_u = [40, 0, 0]\nedge_v = [0, 0, -40]\nmaterial = \"floor\"\n"
    );
    Scene::parse(&text, "floor").unwrap_or_else(|e| panic!("{e}"))
}

/// pbrt-v4's smoothstep falloff, written out here from its definition.
fn pbrt_smoothstep(cos_theta: f32, cos_start: f32, cos_end: f32) -> f32 {
    let t = ((cos_theta - cos_end) / (cos_start - cos_end)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The irradiance the light gives the floor point `p` (normal +y), unshadowed.
fn irradiance(l: &DeltaLight, p: Vec3) -> Vec3 {
    match *l {
        DeltaLight::Distant { to_light, radiance } => radiance * to_light.y.max(0.0),
        DeltaLight::Point { position, intensity } => {
            let v = position - p;
            intensity * (v.y / v.length()).max(0.0) / v.length_squared()
        }
        DeltaLight::Spot { position, axis, intensity, cos_start, cos_end } => {
            let v = position - p;
            let falloff = pbrt_smoothstep((-v.normalize()).dot(axis), cos_start, cos_end);
            intensity * falloff * (v.y / v.length()).max(0.0) / v.length_squared()
        }
    }
}

/// Every pixel of `film` against rho/pi E averaged over the pixel (a 16 x 16
/// grid of camera rays): within 5 standard deviations of the pixel's mean plus
/// 3e-3 relative, what 1024 jittered samples leave of the irradiance's change
/// across a pixel (worst seen 1.4e-3; a uniform field, the distant light's,
/// agrees to 1e-6). Returns the largest relative error.
fn assert_analytic(film: &Film, prepared: &PreparedScene, light: &DeltaLight, what: &str) -> f32 {
    let (mean, var) = (film.mean(), film.variance_of_mean().unwrap());
    let mut worst = 0.0f32;
    for y in 0..film.height {
        for x in 0..film.width {
            let mut want = Vec3::ZERO;
            for j in 0..16 {
                for i in 0..16 {
                    let u = [(i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0];
                    let (o, d) = rlpt::camera::camera_ray(&prepared.params, x, y, u);
                    let p = o + d * (-o.y / d.y);
                    want += irradiance(light, p) * (ALBEDO / std::f32::consts::PI) / 256.0;
                }
            }
            let i = (y * film.width + x) as usize;
            for c in 0..3 {
                let (got, w) = (mean.pixels[i][c], want[c]);
                let tol = 5.0 * var.pixels[i][c].sqrt() + 3e-3 * w + 1e-6;
                assert!((got - w).abs() <= tol, "{what}: pixel ({x}, {y}) channel {c}: {got} vs analytic {w}");
                worst = worst.max((got - w).abs() / w.max(1e-6));
            }
        }
    }
    worst
}

/// Renders the floor lit by `light` alone on both devices against the analytic answer.
fn floor_lit_by(light: DeltaLight, vfov: f32, what: &str) {
    let mut scene = floor_scene(vfov);
    scene.delta_lights.push(light.clone());
    let o = options(&scene, 12, 12, 1024);
    let prepared = PreparedScene::new(&scene, &o).unwrap();
    let ctx = gpu();
    for (device, film) in [("GPU", render_gpu(&ctx, &scene, &o)), ("CPU", render_cpu(&scene, &o))] {
        let worst = assert_analytic(&film, &prepared, &light, &format!("{what} ({device})"));
        eprintln!("{what} ({device}): worst relative error {worst:.2e}");
    }
}

#[test]
fn a_point_light_gives_i_cos_over_r_squared() {
    let light = DeltaLight::Point { position: Vec3::new(0.3, 1.0, 0.2), intensity: Vec3::new(2.0, 1.0, 0.5) };
    floor_lit_by(light, 90.0, "point");
}

#[test]
fn a_distant_light_gives_l_cos() {
    let to_light = Vec3::new(1.0, 2.0, 0.5).normalize();
    floor_lit_by(DeltaLight::Distant { to_light, radiance: Vec3::new(1.5, 1.0, 0.25) }, 60.0, "distant");
}

#[test]
fn a_spot_light_follows_pbrts_cone_and_falloff() {
    // Cone 30 degrees, full intensity within 20: the 90-degree view spans 63
    // degrees from the spot's axis, inside, across and outside the falloff.
    let (start, end) = (20f32.to_radians().cos(), 30f32.to_radians().cos());
    let light = DeltaLight::Spot {
        position: Vec3::new(0.0, 1.0, 0.0),
        axis: Vec3::NEG_Y,
        intensity: Vec3::new(1.0, 2.0, 3.0),
        cos_start: start,
        cos_end: end,
    };
    floor_lit_by(light, 90.0, "spot");
    // The falloff function itself at a few angles, against values worked by hand:
    // midway in cos, t = 0.5 gives 0.5; a quarter, 0.15625.
    let f = rlpt::math::delta::spot_falloff;
    assert_eq!(f(start, start, end), 1.0);
    assert_eq!(f(1.0, start, end), 1.0);
    assert_eq!(f(end, start, end), 0.0);
    assert_eq!(f(0.0, start, end), 0.0);
    assert!((f(0.5 * (start + end), start, end) - 0.5).abs() < 1e-5);
    assert!((f(end + 0.25 * (start - end), start, end) - 0.15625).abs() < 1e-4);
}

#[test]
fn delta_lights_beside_an_area_light_agree_on_gpu_and_cpu_guided_too() {
    let text = "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0.5, 0]\nvfov = 50\n[render]\nmax_bounces = 4\n\
        [[material]]\nname = \"floor\"\ntype = \"diffuse\"\nalbedo = [0.7, 0.6, 0.5]\n\
        [[material]]\nname = \"shiny\"\ntype = \"glossy\"\nalbedo = [0.8, 0.8, 0.8]\nroughness = 0.4\n\
        [[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [4, 4, 4]\n\
        [[quad]]\norigin = [-3, 0, 3]\nedge_u = [6, 0, 0]\nedge_v = [0, 0, -6]\nmaterial = \"floor\"\n\
        [[quad]]\norigin = [-3, 0, -1]\nedge_u = [6, 0, 0]\nedge_v = [0, 3, 0]\nmaterial = \"floor\"\n\
        [[sphere]]\ncenter = [0.3, 0.4, 0]\nradius = 0.4\nmaterial = \"shiny\"\n\
        [[quad]]\norigin = [-1.5, 2, 0.5]\nedge_u = [0, 0, -0.5]\nedge_v = [0.5, 0, 0]\nmaterial = \"lamp\"\n";
    let mut scene = Scene::parse(text, "mixed").unwrap_or_else(|e| panic!("{e}"));
    scene.delta_lights.push(DeltaLight::Point { position: Vec3::new(1.0, 1.5, 1.0), intensity: Vec3::splat(1.5) });
    scene.delta_lights.push(DeltaLight::Spot {
        position: Vec3::new(-0.8, 1.6, 0.8),
        axis: Vec3::new(0.4, -1.0, -0.4).normalize(),
        intensity: Vec3::new(3.0, 2.0, 1.0),
        cos_start: 25f32.to_radians().cos(),
        cos_end: 35f32.to_radians().cos(),
    });
    scene
        .delta_lights
        .push(DeltaLight::Distant { to_light: Vec3::new(-0.3, 1.0, 0.6).normalize(), radiance: Vec3::splat(0.5) });
    let mut o = options(&scene, 16, 12, 256);
    o.q_targets = rlpt::guide::QTargets::Mis;
    let film = gpu_unguided_and_guided_agree_with_cpu(&scene, &mut o, [7, 11], "delta and area lights");
    assert!(film.mean().pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
    // Without next-event estimation nothing reaches a delta light: refused, saying why.
    o.nee = false;
    let Err(e) = PreparedScene::new(&scene, &o).map(|_| ()) else { panic!("--nee off was not refused") };
    let e = e.to_string();
    assert!(e.contains("nee") && e.contains("next-event estimation"), "{e}");
}

#[test]
fn pbrt_delta_lights_import_through_their_transforms() {
    // No Camera: rlpt's space is pbrt's world mirrored in x.
    let s = load(
        "delta",
        &format!(
            "WorldBegin\nAttributeBegin\nTranslate 1 0 0\n\
             LightSource \"point\" \"rgb I\" [1 2 3] \"point3 from\" [0 2 0] \"float scale\" 2\nAttributeEnd\n\
             LightSource \"distant\" \"point3 from\" [1 1 0] \"point3 to\" [0 0 0] \"rgb L\" [1 1 1] \"float illuminance\" 3\n\
             AttributeBegin\nRotate 90 1 0 0\n\
             LightSource \"spot\" \"point3 from\" [0 0 1] \"point3 to\" [0 1 1] \"float coneangle\" 40 \"float conedeltaangle\" 10\n\
             AttributeEnd\nLightSource \"point\" \"float power\" 10\n{TRIANGLE}"
        ),
    );
    assert_eq!(s.delta_lights.len(), 4, "{:?}", s.delta_lights);
    // Its only lights are delta lights: no warning of a black image.
    assert_eq!(rlpt::scene::no_light_warning(&s), None);
    match &s.delta_lights[0] {
        DeltaLight::Point { position, intensity } => {
            assert!(close(*position, Vec3::new(-1.0, 2.0, 0.0)), "{position}");
            assert!(close(*intensity, Vec3::new(2.0, 4.0, 6.0)), "{intensity}");
        }
        l => panic!("{l:?}"),
    }
    match &s.delta_lights[1] {
        DeltaLight::Distant { to_light, radiance } => {
            assert!(close(*to_light, Vec3::new(-1.0, 1.0, 0.0).normalize()), "{to_light}");
            // pbrt-v4's illuminance: L scaled so that its luminance is 3.
            assert!(close(*radiance, Vec3::splat(3.0)), "{radiance}");
        }
        l => panic!("{l:?}"),
    }
    match &s.delta_lights[2] {
        DeltaLight::Spot { position, axis, cos_start, cos_end, .. } => {
            // Rotate 90 about x takes (0, 0, 1) to (0, -1, 0) and +y to +z.
            assert!(close(*position, Vec3::new(0.0, -1.0, 0.0)), "{position}");
            assert!(close(*axis, Vec3::Z), "{axis}");
            assert!(
                (cos_start - 30f32.to_radians().cos()).abs() < 1e-6
                    && (cos_end - 40f32.to_radians().cos()).abs() < 1e-6
            );
        }
        l => panic!("{l:?}"),
    }
    match &s.delta_lights[3] {
        // pbrt-v4's power: 4 pi I of luminance 10.
        DeltaLight::Point { intensity, .. } => {
            assert!(close(*intensity, Vec3::splat(10.0 / (4.0 * std::f32::consts::PI))), "{intensity}")
        }
        l => panic!("{l:?}"),
    }
}

#[test]
fn bad_delta_lights_are_refused_with_file_and_line() {
    let cases = [
        ("LightSource \"spot\" \"float coneangle\" -5", "coneangle -5 must be above 0 and at most 180"),
        ("LightSource \"spot\" \"float coneangle\" 200", "coneangle 200 must be above 0"),
        ("LightSource \"spot\" \"float coneangle\" 20 \"float conedeltaangle\" 30", "conedeltaangle 30 must be from 0"),
        ("LightSource \"distant\" \"point3 from\" [1 1 1] \"point3 to\" [1 1 1]", "coincide"),
        ("LightSource \"point\" \"rgb I\" [1 -1 1]", "must be from 0 to 1e12"),
    ];
    for (line, want) in cases {
        let e = refuse("baddelta", &format!("WorldBegin\n{line}\n{TRIANGLE}"), false);
        assert!(e.starts_with("DIR/scene.pbrt:2:1: LightSource") && e.contains(want), "{line}: {e}");
    }
}
