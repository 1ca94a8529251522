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

bool bsdf_is_delta(Bsdf b) { return is_kind(b, MAT_SPECULAR) || is_kind(b, MAT_DIELECTRIC); }

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

// src/math/bsdf.rs `bsdf_eval_pdf`: f(wo, wi) without the cosine, and in `pdf`
// the density with which bsdf_sample picks wi; the glossy lobe's half vector,
// distribution and masking computed once for both.
vec3 bsdf_eval_pdf(Bsdf b, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    if (is_kind(b, MAT_DIFFUSE)) {
        pdf = cosine_hemisphere_pdf(wi.z);
        return b.albedo / PI;
    }
    if (is_kind(b, MAT_GLOSSY)) {
        vec3 h = normalize(wo + wi);
        float d = ggx_d(h, b.alpha);
        float lambda_o = ggx_lambda(wo.z, b.alpha);
        float g1 = 1.0 / (1.0 + lambda_o);
        float g2 = 1.0 / (1.0 + lambda_o + ggx_lambda(wi.z, b.alpha));
        pdf = g1 * d / (4.0 * wo.z);
        return b.albedo * (d * g2 / (4.0 * wo.z * wi.z));
    }
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
        vec3 h = ggx_sample_vndf(wo, b.alpha, u);
        s.wi = 2.0 * dot(wo, h) * h - wo;
        if (s.wi.z <= 0.0) return s;
        s.pdf = ggx_g1(wo.z, b.alpha) * ggx_d(h, b.alpha) / (4.0 * wo.z);
        s.weight = b.albedo * (ggx_g2(wo.z, s.wi.z, b.alpha) / ggx_g1(wo.z, b.alpha));
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
    }
    return s;
}

#endif
