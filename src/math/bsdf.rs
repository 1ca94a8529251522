//! BSDFs in the style of pbrt-v4: `bsdf_eval(wo, wi)`, `bsdf_pdf(wo, wi)`,
//! `bsdf_sample(wo, uc, u)`; random numbers are passed in, never drawn inside.
//! `glsl/bsdf.glsl` holds the same functions.
//!
//! Directions are in the local shading frame, +z the normal. Reflecting
//! materials (diffuse, specular, glossy, conductor, coated) are two-sided: the
//! caller flips the normal to `wo`'s side, so `wo.z >= 0`. For the dielectrics
//! (smooth and rough) the frame's +z is the surface's outward (front) normal and
//! `wo` may lie on either side ([`Bsdf::transmits`]).

use super::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use super::Vec3;
use crate::layout::GpuMaterial;
use crate::scene::MaterialKind;
use crate::shared;
use std::f32::consts::PI;

/// What a BSDF needs of a material.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    pub kind: MaterialKind,
    pub albedo: Vec3,
    /// GGX alpha = roughness^2.
    pub alpha: f32,
    pub ior: f32,
    /// A conductor's complex index of refraction eta + i k, per channel.
    pub eta: Vec3,
    pub k: Vec3,
    /// The coated material's base: 0 for the Lambertian one of `albedo`, else
    /// the GGX alpha of a conductor base of index `eta` + i `k` (tinted by
    /// `albedo`; [`coated_conductor_base`]). Unused by the other kinds.
    pub base_alpha: f32,
}

/// A sampled direction. `weight` is f * |cos| / pdf; for delta lobes `pdf` is
/// the discrete probability of the chosen lobe.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub weight: Vec3,
    pub pdf: f32,
    pub delta: bool,
}

impl Bsdf {
    /// A BSDF of `kind` with no conductor index (eta 1, k 0).
    pub fn new(kind: MaterialKind, albedo: Vec3, alpha: f32, ior: f32) -> Bsdf {
        Bsdf { kind, albedo, alpha, ior, eta: Vec3::ONE, k: Vec3::ZERO, base_alpha: 0.0 }
    }

    /// A conductor of complex index `eta` + i `k` and GGX `alpha` (0: a mirror).
    pub fn conductor(eta: Vec3, k: Vec3, alpha: f32) -> Bsdf {
        Bsdf { kind: MaterialKind::Conductor, albedo: Vec3::ONE, alpha, ior: 1.0, eta, k, base_alpha: 0.0 }
    }

    /// A coated conductor: a dielectric coat of GGX `alpha` (0: smooth) and index
    /// `ior` over a conductor of index `eta` + i `k` (as in air) and GGX `base_alpha` > 0.
    pub fn coated_conductor(alpha: f32, ior: f32, eta: Vec3, k: Vec3, base_alpha: f32) -> Bsdf {
        Bsdf { kind: MaterialKind::Coated, albedo: Vec3::ONE, alpha, ior, eta, k, base_alpha }
    }

    /// True for a coated material over a conductor base rather than a Lambertian one.
    pub fn has_conductor_base(&self) -> bool {
        self.kind == MaterialKind::Coated && self.base_alpha > 0.0
    }

    /// True if the BSDF is a Dirac delta (no direction can be evaluated or light-sampled).
    /// A coated material with a smooth coat (alpha 0) is not: its coat is a delta
    /// lobe that `bsdf_sample` chooses with a discrete probability, its base is not.
    pub fn is_delta(&self) -> bool {
        match self.kind {
            MaterialKind::Specular | MaterialKind::Dielectric => true,
            MaterialKind::Conductor => self.alpha == 0.0,
            _ => false,
        }
    }

    /// True for the dielectrics, whose frame keeps the surface's front normal
    /// (`wo` on either side); the other materials are shaded from `wo`'s side.
    pub fn transmits(&self) -> bool {
        matches!(self.kind, MaterialKind::Dielectric | MaterialKind::RoughDielectric)
    }
}

/// f(wo, wi), without the cosine, and the solid-angle density with which
/// `bsdf_sample` picks `wi`: both zero for delta BSDFs. One function, so that the
/// glossy lobe's half vector, distribution and masking are computed once where a
/// vertex needs both (light samples and guided directions); on the GPU the code
/// of one call site instead of two.
pub fn bsdf_eval_pdf(b: &Bsdf, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    match b.kind {
        MaterialKind::Diffuse if wo.z > 0.0 && wi.z > 0.0 => (b.albedo / PI, cosine_hemisphere_pdf(wi.z)),
        MaterialKind::Glossy if wo.z > 0.0 && wi.z > 0.0 => {
            let GgxTerms { d, g1, g2, .. } = ggx_terms(wo, wi, b.alpha);
            (b.albedo * (d * g2 / (4.0 * wo.z * wi.z)), g1 * d / (4.0 * wo.z))
        }
        MaterialKind::Conductor if wo.z > 0.0 && wi.z > 0.0 && b.alpha > 0.0 => {
            let GgxTerms { h, d, g1, g2 } = ggx_terms(wo, wi, b.alpha);
            let f = fresnel_complex3(wo.dot(h), b.eta, b.k);
            (b.albedo * f * (d * g2 / (4.0 * wo.z * wi.z)), g1 * d / (4.0 * wo.z))
        }
        MaterialKind::RoughDielectric => rough_dielectric_eval_pdf(b, wo, wi),
        MaterialKind::Coated if wo.z > 0.0 && wi.z > 0.0 => coated_eval_pdf(b, wo, wi),
        _ => (Vec3::ZERO, 0.0),
    }
}

/// The rough dielectric (pbrt-v4's `DielectricBxDF`, after Walter et al. 2007):
/// GGX reflection and transmission through the generalized half vector, each lobe
/// chosen by the Fresnel reflectance of the microfacet; transmitted radiance
/// scaled by 1/etap^2 as the smooth dielectric's. `glsl/bsdf.glsl` has the twin.
fn rough_dielectric_eval_pdf(b: &Bsdf, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    let (co, ci) = (wo.z, wi.z);
    if co == 0.0 || ci == 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    let reflect = co * ci > 0.0;
    let etap = if reflect {
        1.0
    } else if co > 0.0 {
        b.ior
    } else {
        1.0 / b.ior
    };
    let wm = wi * etap + wo;
    if wm.length_squared() == 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    let mut wm = wm.normalize();
    if wm.z < 0.0 {
        wm = -wm;
    }
    let (dot_i, dot_o) = (wm.dot(wi), wm.dot(wo));
    // Microfacets seen from behind by either direction carry nothing.
    if dot_i * ci < 0.0 || dot_o * co < 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    let fr = fresnel_dielectric(dot_o, b.ior);
    let d = ggx_d(wm, b.alpha);
    let g2 = ggx_g2(co, ci, b.alpha);
    // The visible-normal density of wm seen from wo: G1(wo) D(wm) |wo.wm| / |cos_o|.
    let vis = ggx_g1(co, b.alpha) * d * dot_o.abs() / co.abs();
    if reflect {
        let f = d * g2 * fr / (4.0 * ci * co).abs();
        (b.albedo * f, vis / (4.0 * dot_o.abs()) * fr)
    } else {
        let denom = (dot_i + dot_o / etap) * (dot_i + dot_o / etap);
        if denom == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let f = d * (1.0 - fr) * g2 * (dot_i * dot_o / (ci * co * denom)).abs() / (etap * etap);
        (b.albedo * f, vis * dot_i.abs() / denom * (1.0 - fr))
    }
}

/// The chance that the coated BSDF samples its coat rather than its base, from
/// `wo` alone: the coat's Fresnel reflectance against the light the base returns,
/// kept within [0.1, 0.9] so that both lobes are always sampled.
fn coated_coat_chance(b: &Bsdf, cos_o: f32) -> f32 {
    let fo = fresnel_dielectric(cos_o, b.ior);
    let base = (1.0 - fo) * (b.albedo.x + b.albedo.y + b.albedo.z) / 3.0;
    (fo / (fo + base).max(1e-12)).clamp(0.1, 0.9)
}

/// The coated material, an approximation of a layer: a GGX dielectric coat's
/// reflection plus a base seen through it, weighed by (1 - F(cos_o)) (1 - F(cos_i)),
/// F the coat's Fresnel reflectance: a Lambertian base of albedo / pi, or a GGX
/// conductor ([`coated_conductor_base`]). A smooth coat (alpha 0) is a delta
/// lobe that only `bsdf_sample` returns. It ignores refraction of the base's
/// light by the coat (directions are not bent), the Lambertian base's
/// reflections between coat and base, and absorption; docs/SCENE_FORMAT.md
/// says so. `glsl/bsdf.glsl` has the twin.
pub fn coated_eval_pdf(b: &Bsdf, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    let p = coated_coat_chance(b, wo.z);
    let (fo, fi) = (fresnel_dielectric(wo.z, b.ior), fresnel_dielectric(wi.z, b.ior));
    let (mut coat, mut pdf) = (0.0, 0.0);
    if b.alpha > 0.0 {
        let GgxTerms { h, d, g1, g2 } = ggx_terms(wo, wi, b.alpha);
        coat = fresnel_dielectric(wo.dot(h), b.ior) * d * g2 / (4.0 * wo.z * wi.z);
        pdf = p * g1 * d / (4.0 * wo.z);
    }
    let through = (1.0 - fo) * (1.0 - fi);
    if b.base_alpha > 0.0 {
        let (base, base_pdf) = coated_conductor_base(b, wo, wi, fo, fi);
        return (Vec3::splat(coat) + base * through, pdf + (1.0 - p) * base_pdf);
    }
    (Vec3::splat(coat) + b.albedo * (through / PI), pdf + (1.0 - p) * cosine_hemisphere_pdf(wi.z))
}

/// The coated conductor's base, without the coat's transmission, and its
/// sampling density (GGX visible normals of `base_alpha`): pbrt-v4's
/// `CoatedConductorMaterial` divides the conductor's index by the coat's, and
/// light meets it at the refracted angle, so its Fresnel is taken at the cosine
/// of wo.h refracted into the coat; the light that bounces between base and coat
/// adds the factor 1 / (1 - Fc min(F(cos_o), F(cos_i))), exact for a smooth coat
/// over a smooth conductor (its directions are not bent: docs/SCENE_FORMAT.md).
/// `glsl/bsdf.glsl` has the twin.
pub fn coated_conductor_base(b: &Bsdf, wo: Vec3, wi: Vec3, fo: f32, fi: f32) -> (Vec3, f32) {
    let GgxTerms { h, d, g1, g2 } = ggx_terms(wo, wi, b.base_alpha);
    let c = wo.dot(h);
    let cos_t = (1.0 - (1.0 - c * c) / (b.ior * b.ior)).max(0.0).sqrt();
    let fc = fresnel_complex3(cos_t, b.eta / b.ior, b.k / b.ior);
    let bounces = Vec3::ONE - fc * fo.min(fi);
    (b.albedo * fc / bounces * (d * g2 / (4.0 * wo.z * wi.z)), g1 * d / (4.0 * wo.z))
}

/// f(wo, wi), without the cosine. Zero for delta BSDFs.
pub fn bsdf_eval(b: &Bsdf, wo: Vec3, wi: Vec3) -> Vec3 {
    bsdf_eval_pdf(b, wo, wi).0
}

/// Solid-angle density with which `bsdf_sample` picks `wi`. Zero for delta BSDFs.
pub fn bsdf_pdf(b: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
    bsdf_eval_pdf(b, wo, wi).1
}

/// Samples an incident direction; `uc` chooses between lobes (dielectric), `u` the direction.
/// `None` when the sample carries nothing (below the horizon, absorbed, emissive).
pub fn bsdf_sample(b: &Bsdf, wo: Vec3, uc: f32, u: [f32; 2]) -> Option<BsdfSample> {
    match b.kind {
        MaterialKind::Diffuse => {
            if wo.z <= 0.0 {
                return None;
            }
            let wi = cosine_hemisphere(u);
            let pdf = cosine_hemisphere_pdf(wi.z);
            if pdf <= 0.0 {
                return None;
            }
            Some(BsdfSample { wi, weight: b.albedo, pdf, delta: false })
        }
        MaterialKind::Specular => {
            if wo.z <= 0.0 {
                return None;
            }
            Some(BsdfSample { wi: Vec3::new(-wo.x, -wo.y, wo.z), weight: b.albedo, pdf: 1.0, delta: true })
        }
        MaterialKind::Glossy => {
            if wo.z <= 0.0 {
                return None;
            }
            let (wi, _, pdf, masking) = ggx_reflection_sample(wo, b.alpha, u)?;
            Some(BsdfSample { wi, weight: b.albedo * masking, pdf, delta: false })
        }
        MaterialKind::Dielectric => {
            let f = fresnel_dielectric(wo.z, b.ior);
            if uc < f {
                return Some(BsdfSample { wi: Vec3::new(-wo.x, -wo.y, wo.z), weight: b.albedo, pdf: f, delta: true });
            }
            // Relative index across the interface, and the normal on wo's side.
            let (etap, n) = if wo.z > 0.0 { (b.ior, Vec3::Z) } else { (1.0 / b.ior, -Vec3::Z) };
            let wi = refract(wo, n, etap)?;
            // Radiance is compressed by 1/etap^2 when it crosses into the denser medium (pbrt-v4 9.5.2).
            Some(BsdfSample { wi, weight: b.albedo / (etap * etap), pdf: 1.0 - f, delta: true })
        }
        MaterialKind::Conductor => {
            if wo.z <= 0.0 {
                return None;
            }
            if b.alpha == 0.0 {
                let f = fresnel_complex3(wo.z, b.eta, b.k);
                return Some(BsdfSample {
                    wi: Vec3::new(-wo.x, -wo.y, wo.z),
                    weight: b.albedo * f,
                    pdf: 1.0,
                    delta: true,
                });
            }
            let (wi, h, pdf, masking) = ggx_reflection_sample(wo, b.alpha, u)?;
            let f = fresnel_complex3(wo.dot(h), b.eta, b.k);
            Some(BsdfSample { wi, weight: b.albedo * f * masking, pdf, delta: false })
        }
        MaterialKind::RoughDielectric => {
            if wo.z == 0.0 {
                return None;
            }
            // A normal visible from wo (wo turned to the upper side, as its density assumes),
            // then reflection or refraction by its Fresnel reflectance.
            let wm = ggx_sample_vndf(if wo.z < 0.0 { -wo } else { wo }, b.alpha, u);
            let fr = fresnel_dielectric(wo.dot(wm), b.ior);
            let wi = if uc < fr {
                let wi = reflect(wo, wm);
                if wi.z * wo.z <= 0.0 {
                    return None;
                }
                wi
            } else {
                let (etap, n) = if wo.dot(wm) > 0.0 { (b.ior, wm) } else { (1.0 / b.ior, -wm) };
                let wi = refract(wo, n, etap)?;
                if wi.z * wo.z >= 0.0 {
                    return None;
                }
                wi
            };
            let (f, pdf) = rough_dielectric_eval_pdf(b, wo, wi);
            if !(pdf > 0.0) {
                return None;
            }
            Some(BsdfSample { wi, weight: f * (wi.z.abs() / pdf), pdf, delta: false })
        }
        MaterialKind::Coated => {
            if wo.z <= 0.0 {
                return None;
            }
            let p = coated_coat_chance(b, wo.z);
            let wi = if uc < p {
                if b.alpha == 0.0 {
                    // The smooth coat's mirror lobe, chosen with chance p.
                    let f = fresnel_dielectric(wo.z, b.ior);
                    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                    return Some(BsdfSample { wi, weight: Vec3::splat(f / p), pdf: p, delta: true });
                }
                reflect(wo, ggx_sample_vndf(wo, b.alpha, u))
            } else if b.base_alpha > 0.0 {
                reflect(wo, ggx_sample_vndf(wo, b.base_alpha, u))
            } else {
                cosine_hemisphere(u)
            };
            if wi.z <= 0.0 {
                return None;
            }
            let (f, pdf) = coated_eval_pdf(b, wo, wi);
            if !(pdf > 0.0) {
                return None;
            }
            Some(BsdfSample { wi, weight: f * (wi.z / pdf), pdf, delta: false })
        }
        MaterialKind::Emissive | MaterialKind::Mix => None,
    }
}

/// Mirror `wo` about `n`.
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Refracts `wo` through the interface with normal `n` on `wo`'s side and
/// relative index `etap` = eta_transmitted / eta_incident; `None` on total internal reflection.
pub fn refract(wo: Vec3, n: Vec3, etap: f32) -> Option<Vec3> {
    let cos_i = wo.dot(n);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (etap * etap);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / etap + (cos_i / etap - cos_t) * n)
}

/// Unpolarised Fresnel reflectance of a smooth dielectric interface; `cos_i` is
/// signed (negative: from inside), `eta` = ior inside / ior outside.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Unpolarised Fresnel reflectance of a conductor of complex index eta + i k
/// (relative to the outside) at `cos_i` in [0, 1]: the exact formula, as
/// pbrt-v4's `FrComplex`, in complex f32 arithmetic.
pub fn fresnel_complex(cos_i: f32, eta: f32, k: f32) -> f32 {
    type C = (f32, f32);
    let mul = |a: C, b: C| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let div = |a: C, b: C| {
        let n = b.0 * b.0 + b.1 * b.1;
        ((a.0 * b.0 + a.1 * b.1) / n, (a.1 * b.0 - a.0 * b.1) / n)
    };
    let norm = |a: C| a.0 * a.0 + a.1 * a.1;
    let c = cos_i.clamp(0.0, 1.0);
    let e: C = (eta, k);
    let sin2_t = div((1.0 - c * c, 0.0), mul(e, e));
    let cos_t = complex_sqrt((1.0 - sin2_t.0, -sin2_t.1));
    let ec = (e.0 * c, e.1 * c);
    let r_parl = div((ec.0 - cos_t.0, ec.1 - cos_t.1), (ec.0 + cos_t.0, ec.1 + cos_t.1));
    let ect = mul(e, cos_t);
    let r_perp = div((c - ect.0, -ect.1), (c + ect.0, ect.1));
    0.5 * (norm(r_parl) + norm(r_perp))
}

/// The principal square root of a complex number (re, im), as pbrt-v4's `pstd::sqrt`.
fn complex_sqrt(z: (f32, f32)) -> (f32, f32) {
    let n = (z.0 * z.0 + z.1 * z.1).sqrt();
    if n == 0.0 {
        return (0.0, 0.0);
    }
    let t1 = (0.5 * (n + z.0.abs())).sqrt();
    let t2 = 0.5 * z.1 / t1;
    if z.0 >= 0.0 {
        (t1, t2)
    } else {
        (t2.abs(), t1.copysign(z.1))
    }
}

/// [`fresnel_complex`] per RGB channel.
pub fn fresnel_complex3(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        fresnel_complex(cos_i, eta.x, k.x),
        fresnel_complex(cos_i, eta.y, k.y),
        fresnel_complex(cos_i, eta.z, k.z),
    )
}

/// GGX (Trowbridge-Reitz) normal distribution D(h) of a unit half vector:
/// alpha^2 / (pi (sin^2 theta_h + alpha^2 cos^2 theta_h)^2), the sine squared taken as
/// h.x^2 + h.y^2. The textbook form by cos theta_h alone, 1 + cos^2 (alpha^2 - 1), cancels
/// in f32 where alpha is small: at roughness 0.05 the glossy lobe's evaluated albedo came
/// out 1.3 % high at normal incidence (tests/bsdf_cpu.rs, `glossy_albedo_sampled_matches_its_integral`).
pub fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let d = h.x * h.x + h.y * h.y + a2 * h.z * h.z;
    a2 / (PI * d * d)
}

/// Smith Lambda for GGX.
pub fn ggx_lambda(cos_theta: f32, alpha: f32) -> f32 {
    let c2 = cos_theta * cos_theta;
    if c2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan2 = ((1.0 - c2) / c2).max(0.0);
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

pub fn ggx_g1(cos_theta: f32, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(cos_theta, alpha))
}

/// Height-correlated Smith masking-shadowing.
pub fn ggx_g2(cos_o: f32, cos_i: f32, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(cos_o, alpha) + ggx_lambda(cos_i, alpha))
}

/// Samples a microfacet normal from the distribution of normals visible from
/// `wo` (Heitz 2018, "Sampling the GGX Distribution of Visible Normals").
/// The GGX reflection lobe's terms for `wo` and `wi` (glossy, conductor and the
/// coat share them): the half vector, D, and G1(wo) and G2(wo, wi) sharing
/// Lambda(wo). `glsl/bsdf.glsl` `ggx_terms` is its twin.
pub struct GgxTerms {
    pub h: Vec3,
    pub d: f32,
    pub g1: f32,
    pub g2: f32,
}

pub fn ggx_terms(wo: Vec3, wi: Vec3, alpha: f32) -> GgxTerms {
    let h = (wo + wi).normalize();
    let d = ggx_d(h, alpha);
    let lambda_o = ggx_lambda(wo.z, alpha);
    let g1 = 1.0 / (1.0 + lambda_o);
    let g2 = 1.0 / (1.0 + lambda_o + ggx_lambda(wi.z, alpha));
    GgxTerms { h, d, g1, g2 }
}

/// A GGX reflection sampled from the visible normals (glossy and conductor lobes):
/// (wi, the half vector, the density, and G2 / G1(wo), which f cos / pdf is times
/// the lobe's colour and Fresnel); None below the surface or at density 0.
/// `glsl/bsdf.glsl` `ggx_reflection_sample` is its twin.
pub fn ggx_reflection_sample(wo: Vec3, alpha: f32, u: [f32; 2]) -> Option<(Vec3, Vec3, f32, f32)> {
    let h = ggx_sample_vndf(wo, alpha, u);
    let wi = reflect(wo, h);
    if wi.z <= 0.0 {
        return None;
    }
    let pdf = ggx_g1(wo.z, alpha) * ggx_d(h, alpha) / (4.0 * wo.z);
    if !(pdf > 0.0) {
        return None;
    }
    Some((wi, h, pdf, ggx_g2(wo.z, wi.z, alpha) / ggx_g1(wo.z, alpha)))
}

pub fn ggx_sample_vndf(wo: Vec3, alpha: f32, u: [f32; 2]) -> Vec3 {
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { Vec3::X };
    let t2 = vh.cross(t1);
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-6)).normalize()
}

impl GpuMaterial {
    /// The BSDF of this record, as `material_bsdf` in `glsl/pathtrace.comp` reads
    /// it: the roughness in `albedo_roughness.w`, alpha its square; a coated
    /// material's conductor base's in `k[3]` (0: a Lambertian base).
    pub fn bsdf(&self) -> Bsdf {
        let kind = match self.kind {
            shared::MAT_DIFFUSE => MaterialKind::Diffuse,
            shared::MAT_SPECULAR => MaterialKind::Specular,
            shared::MAT_GLOSSY => MaterialKind::Glossy,
            shared::MAT_DIELECTRIC => MaterialKind::Dielectric,
            shared::MAT_CONDUCTOR => MaterialKind::Conductor,
            shared::MAT_ROUGH_DIELECTRIC => MaterialKind::RoughDielectric,
            shared::MAT_COATED => MaterialKind::Coated,
            shared::MAT_MIX => MaterialKind::Mix,
            _ => MaterialKind::Emissive,
        };
        let [r, g, b, roughness] = self.albedo_roughness;
        let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        // A coated material's conductor base: its roughness in k.w (0: Lambertian).
        let base = self.k[3];
        Bsdf {
            kind,
            albedo: Vec3::new(r, g, b),
            alpha: roughness * roughness,
            ior: self.emission_ior[3],
            eta: v(self.eta),
            k: v(self.k),
            base_alpha: if kind == MaterialKind::Coated && base > 0.0 { base * base } else { 0.0 },
        }
    }
}
