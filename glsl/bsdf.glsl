// BSDFs: src/math/bsdf.rs, same functions and conventions (local frame, +z normal).
#ifndef RLPT_BSDF_GLSL
#define RLPT_BSDF_GLSL
#include "common.glsl"
#include "sampling.glsl"

struct Bsdf {
    uint kind;
    vec3 albedo;
    float alpha;
    float ior;
    vec3 eta;      // a conductor's complex index eta + i k
    vec3 k;
    float base_alpha;  // a coated material's conductor base's GGX alpha; 0: its Lambertian base
};

struct BsdfSample {
    vec3 wi;
    vec3 weight;   // f |cos| / pdf
    float pdf;
    bool delta;
    bool ok;
};

// b.kind == kind, known false when the kernel is specialized to a scene without
// that kind: the BSDFs' code is compiled for the scene's kinds alone.
bool is_kind(Bsdf b, uint kind) { return scene_has_material(kind) && b.kind == kind; }

bool bsdf_is_delta(Bsdf b) {
    return is_kind(b, MAT_SPECULAR) || is_kind(b, MAT_DIELECTRIC) || (is_kind(b, MAT_CONDUCTOR) && b.alpha == 0.0);
}

// src/math/bsdf.rs `Bsdf::transmits`: the dielectrics keep the surface's front
// normal; the other materials are shaded from wo's side.
// src/math/bsdf.rs `Bsdf::has_conductor_base`: a coated material over a conductor
// (known false in kernels of scenes without one).
bool has_conductor_base(Bsdf b) { return SCENE_COATED_CONDUCTOR && is_kind(b, MAT_COATED) && b.base_alpha > 0.0; }

bool bsdf_transmits(Bsdf b) { return is_kind(b, MAT_DIELECTRIC) || is_kind(b, MAT_ROUGH_DIELECTRIC); }

// GGX D(h) of a unit half vector, from its components: alpha^2 / (pi (sin^2 + alpha^2 cos^2)^2).
// Not from cos alone: 1 - cos^2 (1 - alpha^2) cancels in f32 where alpha is small (1.3 %
// too much albedo at roughness 0.05; see ggx_d in src/math/bsdf.rs).
float ggx_d(vec3 h, float alpha) {
    if (h.z <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float d = h.x * h.x + h.y * h.y + a2 * h.z * h.z;
    return a2 / (PI * d * d);
}
float ggx_lambda(float cos_theta, float alpha) {
    float c2 = cos_theta * cos_theta;
    if (c2 <= 0.0) return 1.0 / 0.0;
    float tan2 = max((1.0 - c2) / c2, 0.0);
    return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}
float ggx_g1(float cos_theta, float alpha) { return 1.0 / (1.0 + ggx_lambda(cos_theta, alpha)); }
float ggx_g2(float cos_o, float cos_i, float alpha) {
    return 1.0 / (1.0 + ggx_lambda(cos_o, alpha) + ggx_lambda(cos_i, alpha));
}

vec3 ggx_sample_vndf(vec3 wo, float alpha, vec2 u) {
    vec3 vh = normalize(vec3(alpha * wo.x, alpha * wo.y, wo.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0 ? vec3(-vh.y, vh.x, 0.0) / sqrt(lensq) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float s = 0.5 * (1.0 + vh.z);
    float p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * r * sin(phi);
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(1e-6, nh.z)));
}

// src/math/bsdf.rs `ggx_terms`: the GGX reflection lobe's half vector, D, and
// G1(wo) and G2(wo, wi) sharing Lambda(wo) (glossy, conductor and the coat).
void ggx_terms(vec3 wo, vec3 wi, float alpha, out vec3 h, out float d, out float g1, out float g2) {
    h = normalize(wo + wi);
    d = ggx_d(h, alpha);
    float lambda_o = ggx_lambda(wo.z, alpha);
    g1 = 1.0 / (1.0 + lambda_o);
    g2 = 1.0 / (1.0 + lambda_o + ggx_lambda(wi.z, alpha));
}

// src/math/bsdf.rs `ggx_reflection_sample`: a GGX reflection sampled from the
// visible normals, its half vector, density and G2 / G1(wo); false below the
// surface (the caller checks the density).
bool ggx_reflection_sample(vec3 wo, float alpha, vec2 u, out vec3 wi, out vec3 h, out float pdf, out float masking) {
    h = ggx_sample_vndf(wo, alpha, u);
    wi = 2.0 * dot(wo, h) * h - wo;
    pdf = 0.0;
    masking = 0.0;
    if (wi.z <= 0.0) return false;
    pdf = ggx_g1(wo.z, alpha) * ggx_d(h, alpha) / (4.0 * wo.z);
    masking = ggx_g2(wo.z, wi.z, alpha) / ggx_g1(wo.z, alpha);
    return true;
}

float fresnel_dielectric(float cos_i, float eta) {
    cos_i = clamp(cos_i, -1.0, 1.0);
    if (cos_i < 0.0) { eta = 1.0 / eta; cos_i = -cos_i; }
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) return 1.0;
    float cos_t = sqrt(max(0.0, 1.0 - sin2_t));
    float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (r_parl * r_parl + r_perp * r_perp);
}

// Complex arithmetic on vec2 (re, im) for the conductor's Fresnel.
vec2 c_mul(vec2 a, vec2 b) { return vec2(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
vec2 c_div(vec2 a, vec2 b) {
    float n = b.x * b.x + b.y * b.y;
    return vec2(a.x * b.x + a.y * b.y, a.y * b.x - a.x * b.y) / n;
}
// src/math/bsdf.rs `complex_sqrt`: the principal square root.
vec2 c_sqrt(vec2 z) {
    float n = sqrt(z.x * z.x + z.y * z.y);
    if (n == 0.0) return vec2(0.0);
    float t1 = sqrt(0.5 * (n + abs(z.x)));
    float t2 = 0.5 * z.y / t1;
    return z.x >= 0.0 ? vec2(t1, t2) : vec2(abs(t2), z.y < 0.0 ? -t1 : t1);
}
// src/math/bsdf.rs `fresnel_complex`: a conductor's exact unpolarised reflectance.
float fresnel_complex(float cos_i, float eta, float k) {
    float c = clamp(cos_i, 0.0, 1.0);
    vec2 e = vec2(eta, k);
    vec2 sin2_t = c_div(vec2(1.0 - c * c, 0.0), c_mul(e, e));
    vec2 cos_t = c_sqrt(vec2(1.0 - sin2_t.x, -sin2_t.y));
    vec2 r_parl = c_div(e * c - cos_t, e * c + cos_t);
    vec2 ect = c_mul(e, cos_t);
    vec2 r_perp = c_div(vec2(c, 0.0) - ect, vec2(c, 0.0) + ect);
    return 0.5 * (dot(r_parl, r_parl) + dot(r_perp, r_perp));
}
vec3 fresnel_complex3(float cos_i, vec3 eta, vec3 k) {
    return vec3(fresnel_complex(cos_i, eta.x, k.x), fresnel_complex(cos_i, eta.y, k.y), fresnel_complex(cos_i, eta.z, k.z));
}

// src/scene/mod.rs `conductor_k`: pbrt-v4's k of a conductor of eta 1 whose
// normal-incidence reflectance is r.
vec3 conductor_k(vec3 r) {
    r = clamp(r, vec3(0.0), vec3(0.9999));
    return 2.0 * sqrt(r) / sqrt(vec3(1.0) - r);
}

// src/math/bsdf.rs `rough_dielectric_eval_pdf`: GGX reflection and transmission
// (Walter et al. 2007, as pbrt-v4), transmitted radiance scaled by 1/etap^2.
vec3 rough_dielectric_eval_pdf(Bsdf b, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    float co = wo.z;
    float ci = wi.z;
    if (co == 0.0 || ci == 0.0) return vec3(0.0);
    bool refl = co * ci > 0.0;
    float etap = refl ? 1.0 : (co > 0.0 ? b.ior : 1.0 / b.ior);
    vec3 wm = wi * etap + wo;
    if (dot(wm, wm) == 0.0) return vec3(0.0);
    wm = normalize(wm);
    if (wm.z < 0.0) wm = -wm;
    float dot_i = dot(wm, wi);
    float dot_o = dot(wm, wo);
    if (dot_i * ci < 0.0 || dot_o * co < 0.0) return vec3(0.0);
    float fr = fresnel_dielectric(dot_o, b.ior);
    float d = ggx_d(wm, b.alpha);
    float g2 = ggx_g2(co, ci, b.alpha);
    float vis = ggx_g1(co, b.alpha) * d * abs(dot_o) / abs(co);
    if (refl) {
        pdf = vis / (4.0 * abs(dot_o)) * fr;
        return b.albedo * (d * g2 * fr / abs(4.0 * ci * co));
    }
    float s = dot_i + dot_o / etap;
    float denom = s * s;
    if (denom == 0.0) return vec3(0.0);
    pdf = vis * abs(dot_i) / denom * (1.0 - fr);
    return b.albedo * (d * (1.0 - fr) * g2 * abs(dot_i * dot_o / (ci * co * denom)) / (etap * etap));
}

// src/math/bsdf.rs `coated_coat_chance`.
float coated_coat_chance(Bsdf b, float cos_o) {
    float fo = fresnel_dielectric(cos_o, b.ior);
    float base = (1.0 - fo) * (b.albedo.x + b.albedo.y + b.albedo.z) / 3.0;
    return clamp(fo / max(fo + base, 1e-12), 0.1, 0.9);
}

// src/math/bsdf.rs `coated_conductor_base`: the conductor base under the coat
// (index divided by the coat's, Fresnel at the refracted angle, the bounces
// between base and coat), without the coat's transmission; its density in pdf.
vec3 coated_conductor_base(Bsdf b, vec3 wo, vec3 wi, float fo, float fi, out float pdf) {
    vec3 h;
    float d, g1, g2;
    ggx_terms(wo, wi, b.base_alpha, h, d, g1, g2);
    float c = dot(wo, h);
    float cos_t = sqrt(max(0.0, 1.0 - (1.0 - c * c) / (b.ior * b.ior)));
    vec3 fc = fresnel_complex3(cos_t, b.eta / b.ior, b.k / b.ior);
    vec3 bounces = vec3(1.0) - fc * min(fo, fi);
    pdf = g1 * d / (4.0 * wo.z);
    return b.albedo * fc / bounces * (d * g2 / (4.0 * wo.z * wi.z));
}

// src/math/bsdf.rs `coated_eval_pdf`: a GGX dielectric coat's reflection (none
// here where it is smooth) plus a Lambertian or conductor base seen through it
// (an approximation; docs/SCENE_FORMAT.md).
vec3 coated_eval_pdf(Bsdf b, vec3 wo, vec3 wi, out float pdf) {
    float p = coated_coat_chance(b, wo.z);
    float fo = fresnel_dielectric(wo.z, b.ior);
    float fi = fresnel_dielectric(wi.z, b.ior);
    float coat = 0.0;
    pdf = 0.0;
    if (!SCENE_SMOOTH_COAT || b.alpha > 0.0) {
        vec3 h;
        float d, g1, g2;
        ggx_terms(wo, wi, b.alpha, h, d, g1, g2);
        coat = fresnel_dielectric(dot(wo, h), b.ior) * d * g2 / (4.0 * wo.z * wi.z);
        pdf = p * g1 * d / (4.0 * wo.z);
    }
    float through = (1.0 - fo) * (1.0 - fi);
    if (has_conductor_base(b)) {
        float base_pdf;
        vec3 base = coated_conductor_base(b, wo, wi, fo, fi, base_pdf);
        pdf += (1.0 - p) * base_pdf;
        return vec3(coat) + base * through;
    }
    pdf += (1.0 - p) * cosine_hemisphere_pdf(wi.z);
    return vec3(coat) + b.albedo * (through / PI);
}

// src/math/bsdf.rs `bsdf_eval_pdf`: f(wo, wi) without the cosine, and in `pdf`
// the density with which bsdf_sample picks wi; the glossy lobe's half vector,
// distribution and masking computed once for both.
vec3 bsdf_eval_pdf(Bsdf b, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (is_kind(b, MAT_ROUGH_DIELECTRIC)) return rough_dielectric_eval_pdf(b, wo, wi, pdf);
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    if (is_kind(b, MAT_DIFFUSE)) {
        pdf = cosine_hemisphere_pdf(wi.z);
        return b.albedo / PI;
    }
    if (is_kind(b, MAT_GLOSSY)) {
        vec3 h;
        float d, g1, g2;
        ggx_terms(wo, wi, b.alpha, h, d, g1, g2);
        pdf = g1 * d / (4.0 * wo.z);
        return b.albedo * (d * g2 / (4.0 * wo.z * wi.z));
    }
    if (is_kind(b, MAT_CONDUCTOR) && b.alpha > 0.0) {
        vec3 h;
        float d, g1, g2;
        ggx_terms(wo, wi, b.alpha, h, d, g1, g2);
        pdf = g1 * d / (4.0 * wo.z);
        return b.albedo * fresnel_complex3(dot(wo, h), b.eta, b.k) * (d * g2 / (4.0 * wo.z * wi.z));
    }
    if (is_kind(b, MAT_COATED)) return coated_eval_pdf(b, wo, wi, pdf);
    return vec3(0.0);
}

vec3 bsdf_eval(Bsdf b, vec3 wo, vec3 wi) {
    float pdf;
    return bsdf_eval_pdf(b, wo, wi, pdf);
}

float bsdf_pdf(Bsdf b, vec3 wo, vec3 wi) {
    float pdf;
    bsdf_eval_pdf(b, wo, wi, pdf);
    return pdf;
}

BsdfSample bsdf_sample(Bsdf b, vec3 wo, float uc, vec2 u) {
    BsdfSample s;
    s.wi = vec3(0.0);
    s.weight = vec3(0.0);
    s.pdf = 0.0;
    s.delta = false;
    s.ok = false;
    if (is_kind(b, MAT_DIFFUSE)) {
        if (wo.z <= 0.0) return s;
        s.wi = cosine_hemisphere(u);
        s.pdf = cosine_hemisphere_pdf(s.wi.z);
        s.weight = b.albedo;
        s.ok = s.pdf > 0.0;
    } else if (is_kind(b, MAT_SPECULAR)) {
        if (wo.z <= 0.0) return s;
        s.wi = vec3(-wo.x, -wo.y, wo.z);
        s.weight = b.albedo;
        s.pdf = 1.0;
        s.delta = true;
        s.ok = true;
    } else if (is_kind(b, MAT_GLOSSY)) {
        if (wo.z <= 0.0) return s;
        vec3 h;
        float masking;
        if (!ggx_reflection_sample(wo, b.alpha, u, s.wi, h, s.pdf, masking)) return s;
        s.weight = b.albedo * masking;
        s.ok = s.pdf > 0.0;
    } else if (is_kind(b, MAT_DIELECTRIC)) {
        float f = fresnel_dielectric(wo.z, b.ior);
        s.delta = true;
        if (uc < f) {
            s.wi = vec3(-wo.x, -wo.y, wo.z);
            s.weight = b.albedo;
            s.pdf = f;
            s.ok = true;
            return s;
        }
        float etap = wo.z > 0.0 ? b.ior : 1.0 / b.ior;
        vec3 n = wo.z > 0.0 ? vec3(0.0, 0.0, 1.0) : vec3(0.0, 0.0, -1.0);
        float cos_i = dot(wo, n);
        float sin2_t = max(0.0, 1.0 - cos_i * cos_i) / (etap * etap);
        if (sin2_t >= 1.0) return s;
        float cos_t = sqrt(1.0 - sin2_t);
        s.wi = -wo / etap + (cos_i / etap - cos_t) * n;
        s.weight = b.albedo / (etap * etap);
        s.pdf = 1.0 - f;
        s.ok = true;
    } else if (is_kind(b, MAT_CONDUCTOR)) {
        if (wo.z <= 0.0) return s;
        if (b.alpha == 0.0) {
            s.wi = vec3(-wo.x, -wo.y, wo.z);
            s.weight = b.albedo * fresnel_complex3(wo.z, b.eta, b.k);
            s.pdf = 1.0;
            s.delta = true;
            s.ok = true;
            return s;
        }
        vec3 h;
        float masking;
        if (!ggx_reflection_sample(wo, b.alpha, u, s.wi, h, s.pdf, masking)) return s;
        s.weight = b.albedo * fresnel_complex3(dot(wo, h), b.eta, b.k) * masking;
        s.ok = s.pdf > 0.0;
    } else if (is_kind(b, MAT_ROUGH_DIELECTRIC)) {
        if (wo.z == 0.0) return s;
        vec3 wm = ggx_sample_vndf(wo.z < 0.0 ? -wo : wo, b.alpha, u);
        float fr = fresnel_dielectric(dot(wo, wm), b.ior);
        if (uc < fr) {
            s.wi = 2.0 * dot(wo, wm) * wm - wo;
            if (s.wi.z * wo.z <= 0.0) return s;
        } else {
            bool outside = dot(wo, wm) > 0.0;
            float etap = outside ? b.ior : 1.0 / b.ior;
            vec3 n = outside ? wm : -wm;
            float cos_i = dot(wo, n);
            float sin2_t = max(0.0, 1.0 - cos_i * cos_i) / (etap * etap);
            if (sin2_t >= 1.0) return s;
            float cos_t = sqrt(1.0 - sin2_t);
            s.wi = -wo / etap + (cos_i / etap - cos_t) * n;
            if (s.wi.z * wo.z >= 0.0) return s;
        }
        float pdf;
        vec3 f = rough_dielectric_eval_pdf(b, wo, s.wi, pdf);
        s.pdf = pdf;
        s.ok = pdf > 0.0;
        s.weight = s.ok ? f * (abs(s.wi.z) / pdf) : vec3(0.0);
    } else if (is_kind(b, MAT_COATED)) {
        if (wo.z <= 0.0) return s;
        float p = coated_coat_chance(b, wo.z);
        if (uc < p) {
            if (SCENE_SMOOTH_COAT && b.alpha == 0.0) {
                // The smooth coat's mirror lobe, chosen with chance p.
                s.wi = vec3(-wo.x, -wo.y, wo.z);
                s.weight = vec3(fresnel_dielectric(wo.z, b.ior) / p);
                s.pdf = p;
                s.delta = true;
                s.ok = true;
                return s;
            }
            vec3 h = ggx_sample_vndf(wo, b.alpha, u);
            s.wi = 2.0 * dot(wo, h) * h - wo;
        } else if (has_conductor_base(b)) {
            vec3 h = ggx_sample_vndf(wo, b.base_alpha, u);
            s.wi = 2.0 * dot(wo, h) * h - wo;
        } else {
            s.wi = cosine_hemisphere(u);
        }
        if (s.wi.z <= 0.0) return s;
        float pdf;
        vec3 f = coated_eval_pdf(b, wo, s.wi, pdf);
        s.pdf = pdf;
        s.ok = pdf > 0.0;
        s.weight = s.ok ? f * (s.wi.z / pdf) : vec3(0.0);
    }
    return s;
}

#endif
