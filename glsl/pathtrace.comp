#version 460
// One frame of progressive path tracing: 64 samples of each pixel, one path
// per invocation. Workgroup (8, 8, PIXELS_PER_GROUP): x,y are the samples of
// one pixel, z the pixels; the group covers PIXELS_PER_GROUP pixels of a row.
// src/cpu/mod.rs (`trace_path`, `render`) is the same algorithm on the CPU.
#include "common.glsl"
#include "rng.glsl"
#include "bsdf.glsl"
#include "geometry.glsl"
#include "reduce.glsl"

layout(local_size_x = SAMPLES_X, local_size_y = SAMPLES_Y, local_size_z = PIXELS_PER_GROUP) in;

struct AccumPixel {
    vec4 sum;
    vec4 m2_frame_mean;  // Welford: squared deviations of the per-frame means
};
layout(std430, set = 0, binding = BINDING_ACCUM) buffer Accum { AccumPixel accum[]; };

// frame: frames accumulated so far (also decorrelates the random numbers).
layout(push_constant) uniform Push { uint frame; } push;

// src/film.rs `accumulate`.
void accumulate(uint pixel, vec3 sum) {
    float per_frame = float(SAMPLES_PER_FRAME);
    vec3 mean_old = push.frame == 0u ? vec3(0.0) : accum[pixel].sum.xyz / (per_frame * float(push.frame));
    vec3 m = sum / per_frame;
    vec3 delta = m - mean_old;
    vec3 mean_new = mean_old + delta / float(push.frame + 1u);
    accum[pixel].sum.xyz += sum;
    accum[pixel].m2_frame_mean.xyz += delta * (m - mean_new);
}

Bsdf material_bsdf(uint mat) {
    Material m = materials[mat];
    Bsdf b;
    b.kind = m.kind;
    b.albedo = m.albedo_roughness.xyz;
    b.alpha = m.albedo_roughness.w * m.albedo_roughness.w;
    b.ior = m.emission_ior.w;
    return b;
}

void camera_ray(uint x, uint y, vec2 u, out vec3 o, out vec3 d) {
    float tan_half = params.cam_forward_tan.w;
    float aspect = params.cam_right_aspect.w;
    float sx = (2.0 * (float(x) + u.x) / float(params.width) - 1.0) * tan_half * aspect;
    float sy = (1.0 - 2.0 * (float(y) + u.y) / float(params.height)) * tan_half;
    d = normalize(params.cam_forward_tan.xyz + sx * params.cam_right_aspect.xyz + sy * params.cam_up.xyz);
    o = params.cam_position_near.xyz + params.cam_position_near.w * d;
}

vec3 trace_path(vec3 o, vec3 d, inout uint rng) {
    bool nee = (params.flags & FLAG_NEE) != 0u && params.num_lights > 0u;
    bool power = (params.flags & FLAG_POWER_HEURISTIC) != 0u;
    bool rr = (params.flags & FLAG_RUSSIAN_ROULETTE) != 0u;
    vec3 radiance = vec3(0.0);
    vec3 beta = vec3(1.0);
    float prev_pdf = 0.0;
    bool prev_delta = true;
    vec3 prev_p = o;
    uint depth = 0u;
    for (;;) {
        Hit hit;
        if (!intersect_scene(o, d, 1.0 / 0.0, hit)) {
            radiance += beta * params.environment.xyz;
            break;
        }
        vec3 wo = -d;
        vec3 le = emitted(hit.material, hit.n, wo);
        if (max_component(le) > 0.0) {
            float w = 1.0;
            if (nee && !prev_delta && hit.light != NO_LIGHT) {
                w = mis_weight(prev_pdf, light_pdf(hit.light, prev_p, d), power);
            }
            radiance += beta * le * w;
        }
        Bsdf bsdf = material_bsdf(hit.material);
        if (bsdf.kind == MAT_EMISSIVE || depth >= params.max_bounces) break;
        vec3 n = (bsdf.kind == MAT_DIELECTRIC || dot(hit.n, wo) >= 0.0) ? hit.n : -hit.n;
        mat3 frame = make_frame(n);
        vec3 wo_local = to_local(frame, wo);

        if (nee) {
            float u_sel = rng_next(rng);
            vec2 u_light = rng_next_2d(rng);
            LightSample ls;
            if (!bsdf_is_delta(bsdf) && sample_light(hit.p, u_sel, u_light, ls)) {
                vec3 wi_local = to_local(frame, ls.wi);
                vec3 f = bsdf_eval(bsdf, wo_local, wi_local);
                if (max_component(ls.le) > 0.0 && max_component(f) > 0.0) {
                    vec3 origin = offset_origin(hit.p, hit.n, hit.eps, ls.wi);
                    vec3 target = offset_origin(ls.p, ls.n, ls.eps, -ls.wi);
                    vec3 seg = target - origin;
                    float len = length(seg);
                    if (!occluded(origin, seg / len, len)) {
                        float w = mis_weight(ls.pdf, bsdf_pdf(bsdf, wo_local, wi_local), power);
                        radiance += beta * f * abs(wi_local.z) * ls.le * (w / ls.pdf);
                    }
                }
            }
        }

        float uc = rng_next(rng);
        vec2 u = rng_next_2d(rng);
        BsdfSample s = bsdf_sample(bsdf, wo_local, uc, u);
        if (!s.ok) break;
        beta *= s.weight;
        vec3 wi = normalize(to_world(frame, s.wi));
        prev_pdf = s.pdf;
        prev_delta = s.delta;
        prev_p = hit.p;
        o = offset_origin(hit.p, hit.n, hit.eps, wi);
        d = wi;
        depth += 1u;
        if (rr && depth >= params.rr_depth) {
            float q = min(max_component(beta), 0.95);
            if (rng_next(rng) >= q) break;
            beta /= q;
        }
        if (max_component(beta) <= 0.0) break;
    }
    return radiance;
}

void main() {
    uint px = gl_WorkGroupID.x * uint(PIXELS_PER_GROUP) + gl_LocalInvocationID.z;
    uint py = gl_WorkGroupID.y;
    uint sample_index = gl_LocalInvocationID.x + uint(SAMPLES_X) * gl_LocalInvocationID.y;
    bool inside = px < params.width && py < params.height;
    uint pixel = py * params.width + px;

    vec3 radiance = vec3(0.0);
    if (inside) {
        uint rng = rng_init(params.seed, pixel, push.frame, sample_index);
        vec2 u = rng_next_2d(rng);
        vec3 o, d;
        camera_ray(px, py, u, o, d);
        radiance = trace_path(o, d, rng);
        // A NaN or infinite sample would poison the pixel for good; it is dropped, as on the CPU.
        if (any(isnan(radiance)) || any(isinf(radiance))) radiance = vec3(0.0);
    }

    // Every invocation takes part in the reduction, inside the image or not.
    vec3 sum = reduce_pixel_sum(radiance);
    if (inside && sample_index == 0u) {
        accumulate(pixel, sum);
    }
}
