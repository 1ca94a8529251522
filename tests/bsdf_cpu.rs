//! Sampling tests of the Rust BSDFs and light sampler: chi-square of every
//! continuous `sample`/`pdf` pair, and exact checks of the delta lobes.

use rlpt::math::bsdf::{bsdf_eval, bsdf_pdf, bsdf_sample, fresnel_dielectric, Bsdf};
use rlpt::math::rng::Rng;
use rlpt::math::Vec3;
use rlpt::scene::MaterialKind;
use rlpt_chi2::{chi2_sphere, sidak, Chi2Options, Zoom};

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

fn continuous_cases() -> Vec<(Bsdf, Vec3)> {
    let glossy = |r: f32| Bsdf::new(MaterialKind::Glossy, Vec3::new(0.9, 0.6, 0.5), r * r, 1.0);
    let diffuse = Bsdf::new(MaterialKind::Diffuse, Vec3::new(0.7, 0.5, 0.3), 1.0, 1.0);
    vec![
        (diffuse, dir(0.0, 0.0)),
        (diffuse, dir(60.0, 30.0)),
        (glossy(0.05), dir(0.0, 0.0)),
        (glossy(0.05), dir(35.0, 120.0)),
        (glossy(0.05), dir(80.0, 250.0)),
        (glossy(0.08), dir(60.0, 10.0)),
        (glossy(0.2), dir(20.0, 10.0)),
        (glossy(0.3), dir(75.0, 200.0)),
        (glossy(0.5), dir(45.0, 90.0)),
        (glossy(0.8), dir(5.0, 0.0)),
        (glossy(1.0), dir(85.0, 300.0)),
    ]
    .into_iter()
    .chain(new_material_cases())
    .collect()
}

/// pbrt's gold and copper (their RGB eta and k) at the sRGB primaries.
const GOLD: ([f32; 3], [f32; 3]) = ([0.143119, 0.374957, 1.44248], [3.98316, 2.38572, 1.60322]);
const COPPER: ([f32; 3], [f32; 3]) = ([0.200438, 0.924033, 1.10221], [3.91295, 2.45285, 2.14219]);

fn conductor(metal: ([f32; 3], [f32; 3]), roughness: f32) -> Bsdf {
    Bsdf::conductor(Vec3::from(metal.0), Vec3::from(metal.1), roughness * roughness)
}

fn rough_glass(roughness: f32, ior: f32) -> Bsdf {
    Bsdf::new(MaterialKind::RoughDielectric, Vec3::ONE, roughness * roughness, ior)
}

fn coated(roughness: f32, ior: f32) -> Bsdf {
    Bsdf::new(MaterialKind::Coated, Vec3::new(0.6, 0.3, 0.2), roughness * roughness, ior)
}

/// The conductor, the rough dielectric (wo outside: from inside its transmitted
/// radiance is scaled up by ior^2, which `reflectance_never_exceeds_albedo` would
/// count) and the coated material.
fn new_material_cases() -> Vec<(Bsdf, Vec3)> {
    vec![
        (conductor(GOLD, 0.05), dir(30.0, 10.0)),
        (conductor(GOLD, 0.3), dir(0.0, 0.0)),
        (conductor(GOLD, 0.3), dir(45.0, 70.0)),
        (conductor(COPPER, 0.6), dir(80.0, 200.0)),
        (conductor(COPPER, 1.0), dir(20.0, 300.0)),
        (rough_glass(0.3, 1.5), dir(30.0, 40.0)),
        (rough_glass(0.6, 1.5), dir(70.0, 100.0)),
        (rough_glass(0.15, 1.33), dir(0.0, 0.0)),
        (coated(0.2, 1.5), dir(10.0, 0.0)),
        (coated(0.2, 1.5), dir(70.0, 120.0)),
        (coated(0.6, 2.0), dir(45.0, 250.0)),
        // A smooth coat (its mirror lobe a delta: outside the chi-square, checked by
        // `smooth_coat_reflects_by_its_fresnel`) and coated conductors.
        (coated(0.0, 1.5), dir(30.0, 60.0)),
        (coated_conductor(0.0, 1.5, AL, 0.47), dir(20.0, 30.0)),
        (coated_conductor(0.0, 1.5, GOLD, 0.2), dir(65.0, 100.0)),
        (coated_conductor(0.3, 1.5, COPPER, 0.6), dir(40.0, 200.0)),
        (coated_conductor(0.5, 2.0, GOLD, 0.15), dir(80.0, 300.0)),
    ]
}

/// pbrt's aluminium (RGB eta and k), the BMW's wheel rims under their coat.
const AL: ([f32; 3], [f32; 3]) = ([1.65746, 0.880369, 0.521229], [9.22387, 6.26952, 4.837]);

fn coated_conductor(roughness: f32, ior: f32, metal: ([f32; 3], [f32; 3]), base_roughness: f32) -> Bsdf {
    let (eta, k) = (Vec3::from(metal.0), Vec3::from(metal.1));
    Bsdf::coated_conductor(roughness * roughness, ior, eta, k, base_roughness * base_roughness)
}

/// The rough dielectric seen from inside, where transmission leaves the denser side.
fn rough_glass_inside_cases() -> Vec<(Bsdf, Vec3)> {
    let inside = |theta: f32, phi: f32| {
        let d = dir(theta, phi);
        Vec3::new(d.x, d.y, -d.z)
    };
    vec![
        (rough_glass(0.3, 1.5), inside(20.0, 30.0)),
        (rough_glass(0.3, 1.5), inside(60.0, 200.0)),
        (rough_glass(0.7, 1.5), inside(40.0, 90.0)),
    ]
}

#[test]
fn continuous_bsdfs_sample_their_pdf() {
    let cases: Vec<_> = continuous_cases().into_iter().chain(rough_glass_inside_cases()).collect();
    let zoomed = cases.iter().filter(|(b, wo)| narrow_lobe_zoom(b, *wo).is_some()).count();
    let significance = sidak(0.01, cases.len() + zoomed);
    for (i, (b, wo)) in cases.iter().enumerate() {
        let mut rng = Rng::new(1, i as u32, 0, 0);
        let samples: Vec<Option<[f64; 3]>> = (0..1_000_000)
            .map(|_| {
                let uc = rng.next_f32();
                let u = rng.next_2d();
                // A delta lobe (a smooth coat's) has no density: outside the bins.
                bsdf_sample(b, *wo, uc, u).filter(|s| !s.delta).map(|s| [s.wi.x as f64, s.wi.y as f64, s.wi.z as f64])
            })
            .collect();
        let (b2, w) = (*b, *wo);
        let pdf = move |d: [f64; 3]| bsdf_pdf(&b2, w, Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)) as f64;
        let r = chi2_sphere(&samples, pdf, &Chi2Options::default());
        assert!(r.passed(significance), "{b:?} wo={wo:?}: {r:?}");
        if let Some(zoom) = narrow_lobe_zoom(b, *wo) {
            let zoomed: Vec<_> = samples.iter().map(|s| s.map(|d| zoom.sample(d))).collect();
            let r = chi2_sphere(&zoomed, |d| zoom.pdf(pdf, d), &Chi2Options::default());
            assert!(r.passed(significance), "{b:?} wo={wo:?}, zoomed into the lobe: {r:?}");
            assert!(r.degrees_of_freedom >= 100, "the zoom resolves the lobe: {r}");
        }
    }
}

/// For a glossy lobe narrower than the chi-square's 18-degree bins (alpha < 0.01,
/// roughness below 0.1), a [`Zoom`] into it around the mirror direction: k = 0.5 /
/// alpha spreads the lobe's core (some 2 alpha radians wide) over tens of degrees.
/// The plain bins test its tails; the zoomed ones its core.
fn narrow_lobe_zoom(b: &Bsdf, wo: Vec3) -> Option<Zoom> {
    (matches!(b.kind, MaterialKind::Glossy | MaterialKind::Conductor) && b.alpha < 0.01)
        .then(|| Zoom::new([-wo.x as f64, -wo.y as f64, wo.z as f64], 0.5 / b.alpha as f64))
}

#[test]
fn sample_weight_is_f_cos_over_pdf() {
    for (i, (b, wo)) in continuous_cases().iter().chain(&rough_glass_inside_cases()).enumerate() {
        let mut rng = Rng::new(2, i as u32, 0, 0);
        for _ in 0..10_000 {
            let Some(s) = bsdf_sample(b, *wo, rng.next_f32(), rng.next_2d()).filter(|s| !s.delta) else { continue };
            let f = bsdf_eval(b, *wo, s.wi);
            let pdf = bsdf_pdf(b, *wo, s.wi);
            assert!((pdf - s.pdf).abs() <= 1e-3 * pdf.max(1e-3), "{b:?}: pdf {} vs sampled {}", pdf, s.pdf);
            let expect = f * s.wi.z.abs() / pdf;
            assert!(
                (expect - s.weight).abs().max_element() <= 2e-3 * expect.max_element().max(1.0),
                "{b:?}: weight {:?} vs {:?}",
                s.weight,
                expect
            );
        }
    }
}

#[test]
fn reflectance_never_exceeds_albedo() {
    // Energy: the directional albedo (mean of the sample weights) is at most the albedo.
    // For the rough dielectric that is wo outside, where transmission scales radiance down.
    for (i, (b, wo)) in continuous_cases().iter().enumerate() {
        let mut rng = Rng::new(3, i as u32, 0, 0);
        let n = 200_000;
        let mut sum = glam::DVec3::ZERO;
        for _ in 0..n {
            if let Some(s) = bsdf_sample(b, *wo, rng.next_f32(), rng.next_2d()) {
                sum += s.weight.as_dvec3();
            }
        }
        let albedo = sum / n as f64;
        // The coated material's clear coat reflects on top of its base's albedo: its bound is 1
        // (`coated_albedo_stays_at_most_one`).
        let bound = if b.kind == MaterialKind::Coated { 1.0 } else { b.albedo.x as f64 };
        assert!(albedo.x <= bound * 1.005, "{b:?} wo={wo:?}: directional albedo {albedo:?}");
        if b.kind == MaterialKind::Diffuse {
            assert!(
                (albedo - b.albedo.as_dvec3()).abs().max_element() < 1e-9,
                "Lambertian importance sampling is exact: {albedo:?}"
            );
        }
    }
}

#[test]
fn mirror_reflects_exactly() {
    let b = Bsdf::new(MaterialKind::Specular, Vec3::splat(0.8), 1.0, 1.0);
    let wo = dir(40.0, 70.0);
    let s = bsdf_sample(&b, wo, 0.3, [0.2, 0.9]).unwrap();
    assert!(s.delta);
    assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
    assert_eq!(s.weight, Vec3::splat(0.8));
    assert_eq!(bsdf_eval(&b, wo, s.wi), Vec3::ZERO, "delta lobes cannot be evaluated");
    assert_eq!(bsdf_pdf(&b, wo, s.wi), 0.0);
}

#[test]
fn fresnel_has_known_values() {
    // Normal incidence: ((n-1)/(n+1))^2 = 0.04 for n = 1.5.
    assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
    assert!((fresnel_dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6);
    // Grazing: total reflection.
    assert!((fresnel_dielectric(1e-6, 1.5) - 1.0).abs() < 1e-3);
    // Inside glass beyond the critical angle asin(1/1.5) = 41.8 degrees: total internal reflection.
    assert_eq!(fresnel_dielectric(-(45f32.to_radians().cos()), 1.5), 1.0);
    // Brewster's angle atan(1.5): the parallel part vanishes, R = r_perp^2 / 2.
    let tb = 1.5f32.atan();
    let (ci, ct) = (tb.cos(), (std::f32::consts::FRAC_PI_2 - tb).cos());
    let r_perp = (ci - 1.5 * ct) / (ci + 1.5 * ct);
    assert!((fresnel_dielectric(ci, 1.5) - 0.5 * r_perp * r_perp).abs() < 1e-5);
}

#[test]
fn dielectric_chooses_lobes_by_fresnel_and_obeys_snell() {
    let b = Bsdf::new(MaterialKind::Dielectric, Vec3::ONE, 1.0, 1.5);
    for (theta, outside) in [(30.0f32, true), (70.0, true), (20.0, false), (60.0, false)] {
        let mut wo = dir(theta, 25.0);
        if !outside {
            wo.z = -wo.z;
        }
        let f = fresnel_dielectric(wo.z, 1.5);
        let n = 200_000;
        let mut rng = Rng::new(4, theta as u32, 0, 0);
        let mut reflected = 0;
        for _ in 0..n {
            let s = bsdf_sample(&b, wo, rng.next_f32(), rng.next_2d()).expect("a smooth dielectric never absorbs");
            assert!(s.delta);
            if s.wi.z * wo.z > 0.0 {
                reflected += 1;
                assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-5);
            } else {
                // Snell: eta_i sin_i = eta_t sin_t, and the refracted ray lies in the plane of incidence.
                let (eta_i, eta_t) = if outside { (1.0, 1.5) } else { (1.5, 1.0) };
                let sin_i = (1.0 - wo.z * wo.z).sqrt();
                let sin_t = (1.0 - s.wi.z * s.wi.z).sqrt();
                assert!((eta_i * sin_i - eta_t * sin_t).abs() < 1e-4);
                assert!((s.wi.x * wo.y - s.wi.y * wo.x).abs() < 1e-5);
                assert!(
                    (s.weight - Vec3::splat((eta_i / eta_t) * (eta_i / eta_t))).length() < 1e-5,
                    "radiance scaling 1/eta^2"
                );
            }
        }
        // Binomial: reflected fraction within 5 sigma of F.
        let p = reflected as f64 / n as f64;
        let sigma = (f as f64 * (1.0 - f as f64) / n as f64).sqrt().max(1e-9);
        assert!((p - f as f64).abs() < 5.0 * sigma + 1e-12, "theta {theta}: reflected {p} vs Fresnel {f}");
    }
}

/// `bsdf_eval_pdf` shares the glossy lobe's terms between f and the density: both
/// equal the textbook forms (Walter et al. 2007; Heitz 2018's visible-normal
/// density), f = D G2 / (4 cos_o cos_i) and pdf = G1(wo) D / (4 cos_o), written
/// here with the separate masking functions; zero below either horizon.
#[test]
fn eval_pdf_is_the_microfacet_brdf_and_its_sampling_density() {
    use rlpt::math::bsdf::{bsdf_eval_pdf, ggx_d, ggx_g1, ggx_g2};
    let mut rng = Rng::new(3, 0, 0, 0);
    let cases =
        continuous_cases().into_iter().filter(|(b, _)| matches!(b.kind, MaterialKind::Diffuse | MaterialKind::Glossy));
    for (b, wo) in cases {
        for _ in 0..1000 {
            let u = rng.next_2d();
            let wi = dir(u[0] * 100.0, u[1] * 360.0);
            let (f, pdf) = bsdf_eval_pdf(&b, wo, wi);
            let (want_f, want_pdf) = if wi.z <= 0.0 {
                (Vec3::ZERO, 0.0)
            } else if b.kind == MaterialKind::Diffuse {
                (b.albedo / std::f32::consts::PI, wi.z / std::f32::consts::PI)
            } else {
                let h = (wo + wi).normalize();
                let d = ggx_d(h, b.alpha);
                (
                    b.albedo * (d * ggx_g2(wo.z, wi.z, b.alpha) / (4.0 * wo.z * wi.z)),
                    ggx_g1(wo.z, b.alpha) * d / (4.0 * wo.z),
                )
            };
            let close = |a: f32, w: f32| (a - w).abs() <= 1e-5 * w.abs().max(1e-3);
            assert!(
                (0..3).all(|c| close(f[c], want_f[c])) && close(pdf, want_pdf),
                "{:?} wo {wo} wi {wi}: f {f} pdf {pdf}, want {want_f} {want_pdf}",
                b.kind
            );
            assert_eq!((bsdf_eval(&b, wo, wi), bsdf_pdf(&b, wo, wi)), (f, pdf));
        }
    }
}

/// The glossy lobe's directional albedo, the integral of f cos over the hemisphere,
/// computed two ways that share nothing but `bsdf_eval`: by quadrature, and as the
/// mean weight of `bsdf_sample` (f cos / pdf). Single-scattering GGX loses energy
/// (more at high roughness and grazing angles), so the albedo is below 1; the two
/// must agree. The quadrature runs over half vectors h, d omega_i = 4 (wo . h) d omega_h,
/// with theta_h mapped from s in [0, 1) by tan theta_h = alpha tan(pi s / 2) (written
/// here in f64): the lobe's core, 0.3 degrees wide at roughness 0.05, fills the first
/// half of s, its tails the rest, and the midpoint rule in (s, phi) resolves both. Its
/// error is estimated as the difference from the same rule at half the resolution,
/// the sampled mean's from its spread; 5 sigma plus that error is the tolerance.
#[test]
fn glossy_albedo_sampled_matches_its_integral() {
    use rayon::prelude::*;
    use std::f64::consts::PI;
    let glossy = |r: f32| Bsdf::new(MaterialKind::Glossy, Vec3::ONE, r * r, 1.0);
    let integral = |b: &Bsdf, wo: Vec3, n: usize| -> f64 {
        let alpha = b.alpha as f64;
        let wo64 = wo.as_dvec3();
        let sum: f64 = (0..n)
            .into_par_iter()
            .map(|i| {
                let t = (0.5 * PI * (i as f64 + 0.5) / n as f64).tan();
                let theta_h = (alpha * t).atan();
                let dtheta_ds = alpha * 0.5 * PI * (1.0 + t * t) / (1.0 + alpha * alpha * t * t);
                let (sin_h, cos_h) = theta_h.sin_cos();
                let mut row = 0.0f64;
                for j in 0..n {
                    let phi = 2.0 * PI * (j as f64 + 0.5) / n as f64;
                    let h = glam::DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
                    let oh = wo64.dot(h);
                    let wi = 2.0 * oh * h - wo64;
                    if oh <= 0.0 || wi.z <= 0.0 {
                        continue;
                    }
                    let f = bsdf_eval(b, wo, wi.as_vec3()).x as f64;
                    row += f * wi.z * 4.0 * oh * sin_h * dtheta_ds;
                }
                row
            })
            .sum();
        sum * 2.0 * PI / (n * n) as f64
    };
    let mut failures = Vec::new();
    for (i, r) in [0.05f32, 0.08, 0.2, 0.5, 1.0].into_iter().enumerate() {
        let b = glossy(r);
        for (k, theta) in [0.0f32, 30.0, 60.0, 80.0, 88.0].into_iter().enumerate() {
            let wo = dir(theta, 40.0);
            let (fine, coarse) = (integral(&b, wo, 2048), integral(&b, wo, 1024));
            let quadrature_error = (fine - coarse).abs();
            let mut rng = Rng::new(5, i as u32, k as u32, 0);
            let n = 400_000;
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                if let Some(x) = bsdf_sample(&b, wo, rng.next_f32(), rng.next_2d()) {
                    let w = x.weight.x as f64;
                    s += w;
                    s2 += w * w;
                }
            }
            let mean = s / n as f64;
            let sd = ((s2 / n as f64 - mean * mean).max(0.0) / (n - 1) as f64).sqrt();
            if (fine - mean).abs() > 5.0 * sd + quadrature_error {
                failures.push(format!(
                    "roughness {r}, wo at {theta} degrees: integral {fine:.6} (error {quadrature_error:.1e}), \
                     sampled {mean:.6} +- {sd:.1e}"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "sampled and integrated albedos differ:\n{}", failures.join("\n"));
}

/// pbrt-v4's `FrComplex` by its known values: at normal incidence
/// ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2); with k = 0 the dielectric's
/// reflectance at every angle; 1 at grazing; within [0, 1]; and for gold the red
/// channel reflects more than the blue short of grazing.
#[test]
fn conductor_fresnel_has_known_values() {
    use rlpt::math::bsdf::{fresnel_complex, fresnel_complex3};
    for (eta, k) in [(0.2f32, 3.9f32), (1.65, 9.2), (0.14, 3.98), (2.5, 0.0)] {
        let f0 = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
        assert!((fresnel_complex(1.0, eta, k) - f0).abs() < 1e-5, "eta {eta} k {k}: {}", fresnel_complex(1.0, eta, k));
        assert!((fresnel_complex(1e-7, eta, k) - 1.0).abs() < 1e-3, "eta {eta} k {k}: grazing");
    }
    for i in 0..=90 {
        let c = (i as f32).to_radians().cos();
        for eta in [1.2f32, 1.5, 2.4] {
            let (a, b) = (fresnel_complex(c, eta, 0.0), fresnel_dielectric(c, eta));
            assert!((a - b).abs() < 1e-5, "eta {eta} at {i} degrees: complex {a}, dielectric {b}");
        }
        let gold = fresnel_complex3(c, Vec3::from(GOLD.0), Vec3::from(GOLD.1));
        assert!(gold.max_element() <= 1.0 && gold.min_element() >= 0.0, "{i} degrees: {gold}");
        assert!(i > 85 || gold.x > gold.z, "{i} degrees: gold reflects red more than blue: {gold}");
    }
}

/// The rough conductor is the glossy lobe of its alpha times the complex Fresnel
/// at the sampled microfacet: with the same random numbers both sample the same
/// direction, and the weights differ by F(wo . h) exactly (the glossy lobe's
/// albedo is checked against quadrature in `glossy_albedo_sampled_matches_its_integral`).
#[test]
fn rough_conductor_is_the_glossy_lobe_times_fresnel() {
    use rlpt::math::bsdf::fresnel_complex3;
    for r in [0.1f32, 0.4, 0.8] {
        let c = conductor(GOLD, r);
        let g = Bsdf::new(MaterialKind::Glossy, Vec3::ONE, r * r, 1.0);
        for theta in [0.0f32, 45.0, 85.0] {
            let wo = dir(theta, 20.0);
            let mut rng = Rng::new(8, (r * 10.0) as u32, theta as u32, 0);
            for _ in 0..20_000 {
                let (uc, u) = (rng.next_f32(), rng.next_2d());
                let (sc, sg) = (bsdf_sample(&c, wo, uc, u), bsdf_sample(&g, wo, uc, u));
                assert_eq!(sc.is_some(), sg.is_some());
                let (Some(sc), Some(sg)) = (sc, sg) else { continue };
                assert_eq!((sc.wi, sc.pdf), (sg.wi, sg.pdf));
                let f = fresnel_complex3(wo.dot((wo + sc.wi).normalize()), c.eta, c.k);
                let want = f * sg.weight;
                assert!((sc.weight - want).abs().max_element() <= 1e-4 * want.max_element(), "{sc:?} vs {want}");
                let (fc, fg) = (bsdf_eval(&c, wo, sc.wi), bsdf_eval(&g, wo, sc.wi));
                assert!((fc - f * fg).abs().max_element() <= 1e-4 * fc.max_element(), "f {fc} vs {}", f * fg);
            }
        }
    }
}

/// The smooth conductor: a mirror whose weight is the complex Fresnel at wo.
#[test]
fn smooth_conductor_is_a_mirror_with_fresnel() {
    use rlpt::math::bsdf::fresnel_complex3;
    let b = conductor(GOLD, 0.0);
    assert!(b.is_delta());
    let wo = dir(50.0, 30.0);
    let s = bsdf_sample(&b, wo, 0.7, [0.3, 0.1]).unwrap();
    assert!(s.delta && (s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
    assert_eq!(s.weight, fresnel_complex3(wo.z, Vec3::from(GOLD.0), Vec3::from(GOLD.1)));
    assert_eq!(bsdf_eval(&b, wo, s.wi), Vec3::ZERO, "delta lobes cannot be evaluated");
}

/// Energy of the rough dielectric, albedo 1, from both sides: reflected plus
/// transmitted energy (the transmitted weight times etap^2, undoing the radiance
/// scaling) is at most 1 and, at small roughness where single scattering loses
/// little, near 1; the reflected share there is the smooth interface's Fresnel.
#[test]
fn rough_dielectric_keeps_energy_and_tends_to_the_smooth_one() {
    for (r, wo) in [(0.05f32, dir(30.0, 10.0)), (0.05, dir(70.0, 80.0)), (0.05, -dir(20.0, 0.0)), (0.5, dir(40.0, 0.0))]
    {
        let b = rough_glass(r, 1.5);
        let mut rng = Rng::new(9, (r * 100.0) as u32, (wo.z * 100.0).abs() as u32, 0);
        let n = 400_000;
        let (mut energy, mut reflected, mut reflected_energy) = (0.0f64, 0usize, 0.0f64);
        for _ in 0..n {
            let Some(s) = bsdf_sample(&b, wo, rng.next_f32(), rng.next_2d()) else { continue };
            let w = s.weight.x as f64;
            if s.wi.z * wo.z > 0.0 {
                reflected += 1;
                reflected_energy += w;
                energy += w;
            } else {
                let etap = if wo.z > 0.0 { 1.5f64 } else { 1.0 / 1.5 };
                energy += w * etap * etap;
            }
        }
        let (energy, share) = (energy / n as f64, reflected as f64 / n as f64);
        assert!(energy <= 1.0 + 2e-3, "roughness {r} wo {wo}: energy {energy}");
        if r < 0.1 {
            let f = fresnel_dielectric(wo.z, 1.5) as f64;
            assert!(energy > 0.97, "roughness {r} wo {wo}: energy {energy} (reflected {reflected_energy})");
            assert!((share - f).abs() < 0.01 + 0.05 * f, "roughness {r} wo {wo}: reflected share {share}, Fresnel {f}");
        }
    }
}

/// The coated approximation keeps energy: with a white base its directional
/// albedo stays at most 1 over directions, roughnesses and coat indices.
#[test]
fn coated_albedo_stays_at_most_one() {
    for r in [0.05f32, 0.3, 1.0] {
        for ior in [1.2f32, 1.5, 2.5] {
            let b = Bsdf::new(MaterialKind::Coated, Vec3::ONE, r * r, ior);
            for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
                let wo = dir(theta, 15.0);
                let mut rng = Rng::new(10, (r * 100.0) as u32, (ior * 10.0) as u32, theta as u32);
                let n = 200_000;
                let (mut s1, mut s2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    if let Some(s) = bsdf_sample(&b, wo, rng.next_f32(), rng.next_2d()) {
                        let w = s.weight.x as f64;
                        s1 += w;
                        s2 += w * w;
                    }
                }
                let mean = s1 / n as f64;
                let sd = ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(mean <= 1.0 + 3.0 * sd, "roughness {r} ior {ior} at {theta}: albedo {mean} +- {sd}");
                if theta <= 60.0 {
                    assert!(mean > 0.5, "roughness {r} ior {ior} at {theta}: a white base under a clear coat returns most light: {mean}");
                }
            }
        }
    }
}

/// A smooth coat's mirror lobe: chosen with the discrete chance its sample's pdf
/// names, weighted so that its expected reflectance is the coat's Fresnel
/// reflectance F(cos_o), exactly in the mirror direction; and not a delta BSDF,
/// whose base light sampling still reaches.
#[test]
fn smooth_coat_reflects_by_its_fresnel() {
    for (b, wo) in [
        (coated(0.0, 1.5), dir(30.0, 60.0)),
        (coated(0.0, 2.0), dir(80.0, 10.0)),
        (coated_conductor(0.0, 1.5, AL, 0.47), dir(20.0, 30.0)),
        (coated_conductor(0.0, 1.3, GOLD, 0.2), dir(65.0, 100.0)),
    ] {
        assert!(!b.is_delta(), "{b:?}");
        let mut rng = Rng::new(11, (b.ior * 10.0) as u32, (wo.z * 100.0) as u32, 0);
        let n = 200_000;
        let (mut chosen, mut reflected, mut chance) = (0usize, 0.0f64, 0.0f32);
        for _ in 0..n {
            let Some(s) = bsdf_sample(&b, wo, rng.next_f32(), rng.next_2d()) else { continue };
            if s.delta {
                assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6, "{b:?}: {s:?}");
                assert!(s.weight.x == s.weight.y && s.weight.y == s.weight.z, "the coat is untinted: {s:?}");
                chosen += 1;
                reflected += s.weight.x as f64;
                chance = s.pdf;
            }
        }
        let share = chosen as f64 / n as f64;
        let sd = (chance as f64 * (1.0 - chance as f64) / n as f64).sqrt();
        assert!((share - chance as f64).abs() < 4.0 * sd, "{b:?}: mirror lobe chosen {share}, its pdf {chance}");
        let f = fresnel_dielectric(wo.z, b.ior) as f64;
        assert!(
            (reflected / n as f64 - f).abs() < 0.02 * f + 4.0 * sd,
            "{b:?}: coat reflects {} of F {f}",
            reflected / n as f64
        );
    }
}

/// pbrt-v4's directional albedo of a smooth coat (index `ior`) over a smooth
/// conductor (eta, k in air) with no medium between them (thickness 0): light
/// enters with 1 - F, meets the conductor at the refracted angle (its index
/// divided by the coat's, as pbrt-v4's CoatedConductorMaterial), and bounces
/// between the two: F + (1 - F)^2 Rc / (1 - F Rc), per channel.
fn pbrt_smooth_coated_conductor_albedo(cos_o: f32, ior: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let f = fresnel_dielectric(cos_o, ior);
    let cos_t = (1.0 - (1.0 - cos_o * cos_o) / (ior * ior)).sqrt();
    let rc = rlpt::math::bsdf::fresnel_complex3(cos_t, eta / ior, k / ior);
    Vec3::splat(f) + (1.0 - f) * (1.0 - f) * rc / (Vec3::ONE - f * rc)
}

/// The coated conductor's furnace: its directional albedo stays at most 1 for a
/// conductor that reflects everything (k 200: Rc above 0.9999) over coat and base
/// roughnesses, indices and directions; and where pbrt-v4's layer has a closed
/// form (a smooth coat over a nearly smooth conductor, roughness 0.05) the two
/// agree per channel within 1 %, for gold and aluminium.
#[test]
fn coated_conductor_albedo_is_bounded_and_matches_pbrt() {
    let albedo = |b: &Bsdf, wo: Vec3, seed: u32| {
        let mut rng = Rng::new(12, seed, (b.alpha * 1000.0) as u32, (wo.z * 1000.0) as u32);
        let n = 200_000;
        let (mut s1, mut s2) = (glam::DVec3::ZERO, 0.0f64);
        for _ in 0..n {
            if let Some(s) = bsdf_sample(b, wo, rng.next_f32(), rng.next_2d()) {
                s1 += s.weight.as_dvec3();
                s2 += (s.weight.x as f64).powi(2);
            }
        }
        let mean = s1 / n as f64;
        (mean, ((s2 / n as f64 - mean.x * mean.x).max(0.0) / n as f64).sqrt())
    };
    let white = ([1.0f32; 3], [200.0f32; 3]);
    for (i, (coat, base)) in [(0.0f32, 0.05f32), (0.0, 0.5), (0.3, 0.1), (0.3, 1.0), (1.0, 0.3)].into_iter().enumerate()
    {
        for ior in [1.3f32, 1.5, 2.5] {
            for theta in [0.0f32, 40.0, 70.0, 85.0] {
                let b = coated_conductor(coat, ior, white, base);
                let (a, sd) = albedo(&b, dir(theta, 20.0), i as u32);
                assert!(a.x <= 1.0 + 3.0 * sd, "coat {coat} base {base} ior {ior} at {theta}: albedo {a} +- {sd}");
                if theta <= 40.0 && coat == 0.0 {
                    assert!(
                        a.x > 0.8,
                        "coat {coat} base {base} ior {ior} at {theta}: a white conductor returns most light: {a}"
                    );
                }
            }
        }
    }
    for metal in [GOLD, AL] {
        for theta in [0.0f32, 30.0, 60.0, 75.0] {
            let wo = dir(theta, 50.0);
            let b = coated_conductor(0.0, 1.5, metal, 0.05);
            let (a, sd) = albedo(&b, wo, 99);
            let pbrt = pbrt_smooth_coated_conductor_albedo(wo.z, 1.5, Vec3::from(metal.0), Vec3::from(metal.1));
            let err = (a - pbrt.as_dvec3()).abs();
            assert!(
                err.max_element() < 0.01 * pbrt.max_element() as f64 + 4.0 * sd,
                "{metal:?} at {theta}: albedo {a}, pbrt-v4's {pbrt}"
            );
        }
    }
}
