//! The light sampler's directions follow its pdf (chi-square over the sphere of
//! directions seen from a shading point), for spheres seen from outside and from
//! inside, for quads, and for the choice among several lights.

use rlpt::math::geometry::{intersect, light_pdf, sample_light};
use rlpt::math::rng::Rng;
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;
use rlpt_chi2::{chi2_sphere, sidak, Chi2Options};

const SCENE: &str = r#"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
vfov = 40
[[material]]
name = "lamp"
type = "emissive"
emission = [4, 4, 4]
[[material]]
name = "glow"
type = "diffuse"
albedo = [0.5, 0.5, 0.5]
emission = [1, 2, 3]
two_sided = true
[[sphere]]
center = [0, 0, 0]
radius = 0.5
material = "lamp"
[[sphere]]
center = [3, 1, -1]
radius = 1.5
material = "lamp"
[[quad]]
origin = [-2, 2, -2]
edge_u = [4, 0, 0]
edge_v = [0, 0, 3]
material = "glow"
"#;

/// Shading points: outside every light, and inside the large sphere.
#[test]
fn light_directions_follow_light_pdf() {
    let scene = Scene::parse(SCENE, "lights.toml").unwrap();
    let prepared = PreparedScene::new(&scene, &RenderOptions::from_scene(&scene)).expect("valid options");
    let points = [Vec3::new(0.3, -1.2, 1.0), Vec3::new(3.2, 1.3, -0.8)];
    let significance = sidak(0.01, points.len());
    for (k, p) in points.iter().enumerate() {
        let mut rng = Rng::new(9, k as u32, 0, 0);
        let samples: Vec<Option<[f64; 3]>> = (0..1_000_000)
            .map(|_| {
                let u_sel = rng.next_f32();
                let u = rng.next_2d();
                sample_light(&prepared, *p, u_sel, u).map(|s| [s.wi.x as f64, s.wi.y as f64, s.wi.z as f64])
            })
            .collect();
        // The density of a direction sums over the lights that direction reaches (lights may overlap in
        // direction); light_pdf gives each one's share. Occlusion does not matter to the sampler.
        // One single-primitive scene per light, to find where a direction meets that light alone.
        let singles: Vec<PreparedScene> = prepared
            .lights
            .iter()
            .map(|l| {
                let mut only = prepared.clone();
                only.spheres.clear();
                only.quads.clear();
                if l.kind == rlpt::shared::LIGHT_SPHERE {
                    only.spheres.push(prepared.spheres[l.index as usize]);
                } else {
                    only.quads.push(prepared.quads[l.index as usize]);
                }
                only
            })
            .collect();
        let prep = prepared.clone();
        let pp = *p;
        // The density of a direction is the sum over the lights it reaches of each light's
        // share; occlusion does not matter to the sampler.
        let pdf = move |d: [f64; 3]| {
            let w = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32);
            singles
                .iter()
                .enumerate()
                .filter_map(|(li, only)| {
                    intersect(only, pp, w, f32::INFINITY).map(|_| light_pdf(&prep, li as u32, pp, w) as f64)
                })
                .sum::<f64>()
        };
        let r = chi2_sphere(&samples, pdf, &Chi2Options::default());
        assert!(r.passed(significance), "shading point {p:?}: {r:?}");
    }
}
