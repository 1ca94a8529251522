#version 460
// One frame of progressive path tracing: 64 samples of each pixel, one path
// per invocation. Workgroup (8, 8, Z): x,y are the samples of one pixel, z the
// pixels; the group covers Z pixels of a row (SPEC_PIXELS_PER_GROUP).
// src/cpu/path.rs (`trace_path`, stage for stage) and src/cpu/mod.rs (`render`)
// are the same algorithm on the CPU.
#extension GL_KHR_shader_subgroup_arithmetic : require
// Kernels that may sum a race's frame variance (add_frame_variance): the guided
// ones and the unguided one a race traces (build.rs `pathtrace_racing`).
#if defined(RLPT_GUIDING) || defined(RLPT_FRAME_VARIANCE)
#define RLPT_WEIGHS_FRAMES
#extension GL_EXT_shader_atomic_float : require
#endif
// Compiled for the render at hand: the specialization constants of common.glsl
// (guide.glsl takes the table's shape from them instead of params where this is set).
#define RLPT_SPECIALIZED
#include "common.glsl"
#include "bsdf.glsl"
#include "geometry.glsl"
#include "camera.glsl"
#include "reduce.glsl"
#include "film.glsl"
// params.flags and params.max_bounces, fixed for the pipeline (the renderer
// builds a new one when they change). FLAGS before guide.glsl, which reads it.
layout(constant_id = SPEC_FLAGS) const uint FLAGS = 0u;
#ifdef RLPT_GUIDING
#include "guide.glsl"
#include "product.glsl"
#endif

layout(constant_id = SPEC_MAX_BOUNCES) const uint MAX_BOUNCES = 0u;
layout(constant_id = SPEC_RECORDING) const bool RECORDING = false;
// src/guide/mod.rs `guided_vertices`: guided sampling at vertices of depth below it.
layout(constant_id = SPEC_GUIDE_VERTICES) const uint GUIDE_VERTICES = 0u;
// src/guide/mod.rs `record_vertices`: the rays that leave vertices of depth below
// it record their targets.
layout(constant_id = SPEC_RECORD_VERTICES) const uint RECORD_VERTICES = 0u;
// The paths' random numbers: Owen-scrambled Sobol or independent (sampler.glsl).
const bool SAMPLER_SOBOL = (FLAGS & FLAG_SOBOL) != 0u;
#include "sampler.glsl"

// The group's pixels, gl_WorkGroupSize.z, are a specialization constant: 4 for
// the guided kernels, 2 for the unguided one (common.glsl).
layout(local_size_x = SAMPLES_X, local_size_y = SAMPLES_Y, local_size_z_id = SPEC_PIXELS_PER_GROUP) in;

struct AccumPixel {
    vec4 sum;
    vec4 m2_frame_mean;  // Welford: squared deviations of the per-frame means
};
layout(std430, set = 0, binding = BINDING_ACCUM) buffer Accum { AccumPixel accum[]; };
// The sums' Kahan compensation per pixel (xyz): `accumulate`.
layout(std430, set = 0, binding = BINDING_ACCUM_CARRY) buffer AccumCarry { vec4 accum_carry[]; };

layout(std430, set = 0, binding = BINDING_COUNTERS) buffer Counters { uint counters[]; };
#ifdef RLPT_WEIGHS_FRAMES
// The same buffer's words as floats: add_frame_variance's slots.
layout(std430, set = 0, binding = BINDING_COUNTERS) buffer FrameVarianceSlots { float frame_variance_slots[]; };
#endif
#include "counters.glsl"

// frame: frames traced so far (the recording schedule, learned roulette's wait);
// accum_frames: frames in the accumulation buffer (restarts keep learning going);
// ablate: ABLATE_* bits, parts of guiding left out (profiling only, else 0);
// rows: the pixel rows this dispatch traces (ROWS_* | phase << 8 | stride << 16);
// learned_frames: frames left out of the image whose radiance the pixels' sum.w
// keeps for learned roulette's estimate (guide::GuideConfig::learning_frames):
// where accum_frames is 0, the frames the buffer still holds, which the first
// accumulation replaces or folds in (fold_learned);
// table_frames: frames the table learned from before this render (a loaded field);
// rng_frame: the frame index of the random numbers: frame, plus a part's offset on
// the image's frames (src/math/sampler.rs `rng_frame`), so that parts draw disjoint samples;
// fold_learned: 1 where the first image frame takes the learning frames' mean in as
// one frame of the image (src/film.rs `accumulate`), 0 where it writes over them;
// samples: the frame's samples per pixel, SAMPLES_PER_FRAME but in a last frame
// cut short at a time limit (its lanes from `samples` on trace nothing);
// weight: a whole frame's weight, 1 but in a timed race (src/film.rs `FrameWeight`);
// accum_weight: the accumulation's frames' total weight before this one, in whole
// frames (float(accum_frames) where every frame weighed 1).
layout(push_constant) uniform Push {
    uint frame; uint accum_frames; uint ablate; uint rows; uint learned_frames; uint table_frames; uint rng_frame;
    uint fold_learned; uint samples; float weight; float accum_weight;
} push;

// src/render/dispatch.rs `pixel_row`: the pixel row of workgroup row `g`.
uint pixel_row(uint g) {
    uint mode = push.rows & 0xffu;
    uint phase = (push.rows >> 8u) & 0xffu;
    uint stride = push.rows >> 16u;
    if (mode == uint(ROWS_PHASE)) return g * stride + phase;
    if (mode == uint(ROWS_NOT_PHASE)) return (g / (stride - 1u)) * stride + (phase + 1u + g % (stride - 1u)) % stride;
    return g;
}

// src/film.rs `accumulate_samples`, the frame's push.samples summed in `sum`. The
// first frame of an accumulation writes over what the buffer holds; after the
// learning frames, it either takes their mean in as the image's first frame
// (fold_learned) or keeps their mean3 sum in sum.w (src/guide/roulette.rs
// `roulette_estimate` reads it). A frame of k samples weighs k / 64 of a whole
// one, times push.weight; the sum holds each frame's sum times its push.weight.
void accumulate(uint pixel, vec3 sum) {
    float per_frame = float(SAMPLES_PER_FRAME);
    float before = push.accum_weight;
    vec3 weighted = sum * push.weight;
    if (push.accum_frames == 0u && push.learned_frames > 0u && push.fold_learned != 0u) {
        accum[pixel].sum = vec4(accum[pixel].sum.xyz / float(push.learned_frames), 0.0);
        accum[pixel].m2_frame_mean = vec4(0.0);
        accum_carry[pixel] = vec4(0.0);
        before = 1.0;
    } else if (push.accum_frames == 0u) {
        float learned = 0.0;
        if (push.learned_frames > 0u) learned = mean3(accum[pixel].sum.xyz);
        accum[pixel].sum = vec4(weighted, learned);
        accum[pixel].m2_frame_mean = vec4(0.0);
        accum_carry[pixel] = vec4(0.0);
        return;
    }
    float w = push.weight * float(push.samples) / per_frame;
    vec3 total = accum[pixel].sum.xyz;
    vec3 mean_old = total / (per_frame * before);
    vec3 m = sum / float(push.samples);
    vec3 delta = m - mean_old;
    vec3 mean_new = mean_old + delta * w / (before + w);
    // Compensated: after a million frames a frame's sum is a millionth of the
    // pixel's, and added plainly its low bits would be lost.
    vec3 carry = accum_carry[pixel].xyz;
    kahan_add(total, carry, weighted);
    accum[pixel].sum.xyz = total;
    accum_carry[pixel].xyz = carry;
    accum[pixel].m2_frame_mean.xyz += w * delta * (m - mean_new);
}

#ifdef RLPT_WEIGHS_FRAMES
// src/film.rs `frame_variance_term`: the squared deviation of the frame's mean of
// the pixel (mean3) from the pixel's mean before the frame, over that mean's
// square plus relMSE's 0.01, at most FRAME_VARIANCE_MAX: the frame mean's
// relative variance, whatever its samples share (stratified pixel positions).
float frame_variance_term(float frame_mean, float mean_before) {
    float d = frame_mean - mean_before;
    return min(d * d / (mean_before * mean_before + 0.01), FRAME_VARIANCE_MAX);
}

// Adds the pixel's frame_variance_term to its slot (src/render/mod.rs reads the
// slots). The pixel's mean before the frame is the accumulation's, the learning
// frames' where the image has none yet, and this frame's on the first frame
// (as src/cpu/mod.rs `pixel_mean_before`).
void add_frame_variance(uint pixel, float sum) {
    float n = push.accum_frames > 0u ? push.accum_weight : float(push.learned_frames);
    float per_frame = float(SAMPLES_PER_FRAME);
    float before = n > 0.0 ? mean3(accum[pixel].sum.xyz) / (per_frame * n) : sum / per_frame;
    uint slot = uint(COUNTER_FRAME_VARIANCE) + uint(FRAME_VARIANCE_STRIDE) * (pixel % uint(FRAME_VARIANCE_SLOTS));
    atomicAdd(frame_variance_slots[slot], frame_variance_term(sum / per_frame, before));
}
#endif

// src/cpu/mod.rs `material_bsdf`: the material's BSDF at a hit of texture
// coordinates uv, its textures applied (src/math/texture.rs `apply_textures`)
// where the scene has any.
Bsdf material_bsdf(uint mat, vec2 uv) {
    Material m = materials[mat];
    Bsdf b;
    b.kind = m.kind;
    b.albedo = m.albedo_roughness.xyz;
    b.alpha = m.albedo_roughness.w * m.albedo_roughness.w;
    b.ior = m.emission_ior.w;
    // Read only where the kernel may meet a conductor: other scenes skip the loads.
    bool conductors = scene_has_material(MAT_CONDUCTOR) || SCENE_COATED_CONDUCTOR;
    b.eta = conductors ? m.eta.xyz : vec3(1.0);
    b.k = conductors ? m.k.xyz : vec3(0.0);
    // A coated material's conductor base: its roughness in k.w (0: Lambertian).
    b.base_alpha = SCENE_COATED_CONDUCTOR && m.kind == MAT_COATED ? m.k.w * m.k.w : 0.0;
    if (SCENE_TEXTURES) {
        if (m.albedo_texture != NO_TEXTURE) b.albedo *= colour_texture(m.albedo_texture - 1u, uv);
        if (m.roughness_texture != NO_TEXTURE) {
            // A coated conductor's texture is its base's roughness, not its coat's.
            bool base = has_conductor_base(b);
            float r = clamp((base ? m.k.w : m.albedo_roughness.w) * texture_lookup(m.roughness_texture - 1u, uv).r, TEXTURE_MIN_ROUGHNESS, 1.0);
            if (base) b.base_alpha = r * r; else b.alpha = r * r;
        }
        // A reflectance conductor: its textured albedo is pbrt-v4's reflectance r.
        if ((SCENE_KINDS & (1u << SCENE_KIND_REFLECTANCE_CONDUCTOR)) != 0u && m.eta.w != 0.0) {
            b.eta = vec3(1.0);
            b.k = conductor_k(b.albedo);
            b.albedo = vec3(1.0);
        }
    }
    return b;
}

// src/cpu/mod.rs `resolve_mix`: the material a hit on `mat` shades with: `mat`
// itself, or where it is a mix one of its two materials, the second with chance
// its amount by mix_hash of the hit, level by level (at most MIX_MAX_DEPTH).
uint resolve_mix(uint mat, vec3 p, vec3 wo, vec2 uv) {
    for (uint level = 0u; level < uint(MIX_MAX_DEPTH); ++level) {
        Material m = materials[mat];
        if (m.kind != MAT_MIX) break;
        float amount = m.albedo_roughness.x;
        if (SCENE_TEXTURES && m.albedo_texture != NO_TEXTURE) amount *= colour_texture(m.albedo_texture - 1u, uv).x;
        mat = mix_hash(p, wo, mat) < amount ? uint(m.k.y) : uint(m.k.x);
    }
    return mat;
}

// src/cpu/path.rs `shading_side`: the shading normal on the side of n, or n
// where wo lies on one side of it and the other of the surface.
vec3 shading_side(vec3 n, Hit hit, vec3 wo) {
    vec3 ns = n == hit.n ? hit.ns : -hit.ns;
    return dot(ns, wo) * dot(n, wo) < 0.0 ? n : ns;
}

// src/cpu/path.rs `sides_agree`: w on the same side of the surface as of the
// shading normal (always without smooth triangles).
bool sides_agree(vec3 n, vec3 ns, vec3 w) {
    return !SCENE_SMOOTH || !(dot(w, n) * dot(w, ns) < 0.0);
}


#ifdef RLPT_GUIDING
// src/guide/roulette.rs `survival_probability`.
float survival_probability(float expected, float pixel_estimate) {
    return clamp(float(RR_WINDOW) * expected / pixel_estimate, float(RR_MIN_PERCENT) / 100.0, 1.0);
}

// The scene has glossy materials, and none wide enough to take guided directions
// (src/guide/sampler.rs `glossy_share`, `SCENE_KIND_GUIDED_GLOSSY`).
const bool GLOSSY_UNGUIDED = (SCENE_KINDS & ((1u << MAT_GLOSSY) | (1u << SCENE_KIND_GUIDED_GLOSSY))) == (1u << MAT_GLOSSY);

// src/guide/sampler.rs `glossy_share`; 0 throughout where GLOSSY_UNGUIDED.
float glossy_share(float alpha) {
    float s = 4.0 * alpha * alpha;
    return GLOSSY_UNGUIDED || s * float(GLOSSY_SHARE_MIN_INV) < 1.0 ? 0.0 : min(s, 1.0);
}

// src/guide/sampler.rs `lobe_share`: a conductor's lobe shares as a glossy one
// of its alpha (not through glossy_share, which GLOSSY_UNGUIDED zeroes).
float conductor_share(float alpha) {
    float s = 4.0 * alpha * alpha;
    return s * float(GLOSSY_SHARE_MIN_INV) < 1.0 ? 0.0 : min(s, 1.0);
}

// src/guide/sampler.rs `lobe_share`: the share of the guided fraction at a vertex,
// less than 1 on glossy lobes narrower than the cosine lobe, 0 on the narrowest
// and on every glossy lobe of a scene whose kinds say none takes any.
float lobe_share(Bsdf b) {
    if (scene_has_material(MAT_GLOSSY) && b.kind == MAT_GLOSSY) return glossy_share(b.alpha);
    if (scene_has_material(MAT_CONDUCTOR) && b.kind == MAT_CONDUCTOR) return conductor_share(b.alpha);
    if (is_kind(b, MAT_ROUGH_DIELECTRIC)) return 0.0;
    if (has_conductor_base(b)) return conductor_share(b.base_alpha);
    return 1.0;
}
// src/cpu/path.rs `record_to`: the target of the ray that left through `key`,
// and where `factor` is not 0 its cell's fraction-gradient sample,
// -factor * counted, summed after the table's entries (src/guide/record.rs `FrameSums`);
// nothing where the target is not finite (it would poison its entry for good).
void record(uint key, float target, float counted, float factor) {
    if (isnan(target) || isinf(target)) return;
    record_target(key, target);
    if (factor != 0.0) record_target(GUIDE_ENTRIES + key / GUIDE_BINS, -factor * counted);
}
#define GUIDED 1
#else
#define GUIDED 0
#endif

// Whether the frame counters are kept (FLAG_COUNTERS: paths without radiance;
// FLAG_COUNT_RAYS: rays too): without them the kernel counts nothing, and their
// code is compiled out. Counting rays inside the path loop costs a frame
// measurably, so `render --stats` counts paths alone.
const bool COUNTERS = (FLAGS & FLAG_COUNTERS) != 0u;
// The host sets FLAG_COUNT_RAYS only beside FLAG_COUNTERS, and the bit is tested
// alone: glslang evaluates `&&` of specialization constants as code in the first
// function that reads it, and COUNT_RAYS is read in the path loop and in main; written
// as COUNTERS && ..., the module was invalid SPIR-V and lavapipe rejected it.
const bool COUNT_RAYS = (FLAGS & FLAG_COUNT_RAYS) != 0u;
// The frame's relative variance is summed (add_frame_variance), by the kernels
// built for it (the host picks them where it sets the flag).
#ifdef RLPT_WEIGHS_FRAMES
const bool FRAME_VARIANCE = (FLAGS & FLAG_FRAME_VARIANCE) != 0u;
#else
const bool FRAME_VARIANCE = false;
#endif
// Where trace_path counts its rays: with the depth in one register where the
// scene has roulette (see `depth_rays`), in `segments` otherwise. DEPTH selects
// on the specialization constant so that kernels without roulette keep the plain
// depth: with the mask there too, their frames were longer.
// Written without `&&` (see COUNT_RAYS): COUNT_RAY is read in the loop's light_sample too.
const bool PACK_RAYS =
    (FLAGS & (FLAG_COUNT_RAYS | FLAG_RUSSIAN_ROULETTE)) == (FLAG_COUNT_RAYS | FLAG_RUSSIAN_ROULETTE);
#define DEPTH (PACK_RAYS ? depth_rays & 0xffffu : depth_rays)
#define COUNT_RAY() if (PACK_RAYS) depth_rays += 0x10000u; else if (COUNT_RAYS) segments += 1u

// Q-learning targets that count the emission met as the image weighs it and
// add the light sample at the vertex met (src/guide/mod.rs `QTargets::Mis`).
const bool MIS_TARGETS = (FLAGS & FLAG_MIS_TARGETS) != 0u;

// The ray into the last vertex is traced in full only where its line meets a
// light (FLAG_LAST_RAY_TO_LIGHTS), unless the kernel records that vertex's target.
// Read in trace_path alone: glslang evaluates this `&&` of specialization
// constants as code where it is first read, and a read from a second function
// would make invalid SPIR-V (see COUNT_RAYS).
const bool LAST_RAY_TO_LIGHTS =
    (FLAGS & FLAG_LAST_RAY_TO_LIGHTS) != 0u && !(RECORDING && RECORD_VERTICES >= MAX_BOUNCES);

#ifdef RLPT_GUIDING
// The path loop's guided stages (src/cpu/path.rs, same names); without guiding
// each compiles to nothing, and trace_path's guiding state stays constant.

// The path records Q-learning targets (the recording kernel, unless profiling
// leaves recording out).
bool path_records() { return RECORDING && (push.ablate & ABLATE_RECORD) == 0u; }
// The path may take guided directions (unless profiling leaves them out).
bool path_guides() { return (push.ablate & ABLATE_GUIDED_SAMPLING) == 0u; }

// Glossy vertices draw their guided directions from the product of Q and the
// lobe (product.glsl): set only where a material's lobe takes it.
const bool GLOSSY_PRODUCT = (FLAGS & FLAG_GLOSSY_PRODUCT) != 0u;

// The vertex's product with its lobe (glossy_product), read by light_sample and
// choose_direction; sum_w 0 where the vertex has none. A private variable rather
// than a parameter, so that the unguided kernel's stages stay as they were.
Product vertex_product;

// src/cpu/path.rs `glossy_product`: the product's window sums at a glossy vertex
// that mixes (vertex_product); where its weights sum to zero the vertex samples
// the BSDF alone (g_frac 0).
void glossy_product(Bsdf bsdf, mat3 frame, vec3 wo_local, uint qrow, inout float g_frac) {
    if (!GLOSSY_PRODUCT) return;
    vertex_product.sum_w = 0.0;
    if (g_frac > 0.0 && product_applies(bsdf)) {
        vertex_product = product_sums(frame, wo_local, bsdf.alpha, qrow, params.guide_floor);
        if (!(vertex_product.sum_w > 0.0)) g_frac = 0.0;
    }
}

// src/cpu/path.rs `guided_bin_pdf`: the guided density of bin b, the product's
// where it draws the guided directions, else the sampling row's.
float guided_bin_pdf(mat3 frame, vec3 wo_local, Bsdf bsdf, uint row, uint b) {
    if (GLOSSY_PRODUCT && vertex_product.sum_w > 0.0) return product_pdf(frame, wo_local, bsdf.alpha, vertex_product, b);
    return bin_pdf(row, b);
}

// src/cpu/path.rs `record_end`: keeps the target of the ray that ends the path
// (it escapes or meets an emitter, `le` of MIS weight `w`) for after the loop,
// one call site of record_target fewer inside it. The gradient weighs the
// emission as the image does, and with MIS_TARGETS the target too.
void record_end(bool records, uint key, vec3 le, float w, inout uint end_key, inout float end_target, inout float factor) {
    if (records) {
        end_key = key;
        end_target = MIS_TARGETS ? mean3(le) * w : mean3(le);
        if (!MIS_TARGETS) factor *= w;
    }
}

// src/cpu/path.rs `record_vertex_target`: the target of the ray that arrived at
// this vertex, a one-sample estimate of the expected-SARSA target
// (src/guide/mod.rs). With MIS_TARGETS the target is the light as the image
// counts it from here on, and the fraction's gradient weighs the same.
void record_vertex_target(bool wants_target, bool ok, vec3 weight, uint qrow, uint wi_bin, vec3 le, float w_le,
                          float nee_here, uint key, float factor) {
    if (wants_target) {
        float reflected = ok ? mean3(weight) * q_table[qrow + wi_bin] : 0.0;
        float target = (MIS_TARGETS ? mean3(le) * w_le + nee_here : mean3(le)) + reflected;
        record(key, target, MIS_TARGETS ? target : mean3(le) * w_le + reflected, factor);
    }
}
#else
bool path_records() { return false; }
bool path_guides() { return false; }
void record_end(bool records, uint key, vec3 le, float w, inout uint end_key, inout float end_target, inout float factor) {}
void record_vertex_target(bool wants_target, bool ok, vec3 weight, uint qrow, uint wi_bin, vec3 le, float w_le,
                          float nee_here, uint key, float factor) {}
void record(uint key, float target, float counted, float factor) {}
#endif

// src/cpu/path.rs `environment_met`: a ray that escapes meets the uniform sky,
// or the image environment, a light whose emission is weighed against light
// sampling as the other lights' is (its MIS weight in `w_env`, else 1).
vec3 environment_met(vec3 d, bool nee, bool power, float prev_pdf, bool prev_delta, out float w_env) {
    vec3 le_env = params.environment.xyz;
    w_env = 1.0;
    if (scene_has_light(LIGHT_ENV)) {
        float pdf_env;
        le_env = env_lookup(d, pdf_env);
        if (nee && !prev_delta) w_env = mis_weight(prev_pdf, pdf_env * lights[params.num_lights - 1u].pmf, power);
    }
    return le_env;
}

// src/cpu/path.rs `emission_met`: the emission met at a hit, added to the
// radiance with its MIS weight against light sampling (`w_le`, which the
// fraction's gradient applies too).
vec3 emission_met(Hit hit, vec3 wo, vec3 d, bool nee, bool power, float prev_pdf, bool prev_delta, vec3 prev_p,
                  vec3 beta, inout vec3 radiance, out float w_le) {
    vec3 le = emitted(hit.material, hit.n, wo);
    w_le = 1.0;
    if (max_component(le) > 0.0) {
        if (nee && !prev_delta && hit.light != NO_LIGHT) {
            w_le = mis_weight(prev_pdf, light_pdf(hit.light, prev_p, d), power);
        }
        radiance += beta * le * w_le;
    }
    return le;
}


// src/cpu/path.rs `trace_path`, stage for stage. Returns the radiance; counts rays in `segments`.
// `pixel_estimate`: mean3 of the pixel's accumulated mean, 0 where there is none yet.
vec3 trace_path(vec3 o, vec3 d, float pixel_estimate, inout PathSampler rng, inout uint segments) {
    bool nee = (FLAGS & FLAG_NEE) != 0u && params.num_lights > 0u;
    bool power = (FLAGS & FLAG_POWER_HEURISTIC) != 0u;
    bool rr = (FLAGS & FLAG_RUSSIAN_ROULETTE) != 0u;
    vec3 radiance = vec3(0.0);
    vec3 beta = vec3(1.0);
    float prev_pdf = 0.0;
    bool prev_delta = true;
    vec3 prev_p = o;
    uint prev_key = NO_KEY;
    // The vertex's depth (DEPTH) in the low 16 bits; in scenes with roulette, the
    // rays traced in the high ones (COUNT_RAY), added to `segments` at the end
    // (at most 1024 bounces, so at most 2050 rays). One live register fewer
    // brought door's guided kernel to a better occupancy; packed in every kernel,
    // frames without roulette got longer, so those keep the count apart.
    uint depth_rays = 0u;
    // Guiding's state, constant without guiding. The recording kernel traces the
    // rows whose paths record (src/guide/record.rs `records`), the other kernel the
    // rest. A path records the targets of the rays that leave its vertices of
    // depth < RECORD_VERTICES, the ray that arrives at a vertex of depth `DEPTH`
    // having left DEPTH - 1.
    bool learn = path_records();
    bool guide = path_guides();
    // The target of the ray that ends the path (record_end), recorded after the loop.
    uint end_key = NO_KEY;
    float end_target = 0.0;
    // Where cells learn their fractions (recording kernel only): the
    // fraction-gradient factor of the ray being traced, 0 where its vertex did
    // not mix (src/guide/fraction.rs `fraction_gradient_factor`).
    bool learn_fraction = learn && (FLAGS & FLAG_LEARN_FRACTION) != 0u;
    float prev_factor = 0.0;
    for (;;) {
        COUNT_RAY();
        Hit hit;
        // The ray into the last vertex adds only the emission it meets, and in
        // a scene whose environment is black only the lights emit: where its
        // line meets none, the closest-hit walk would find nothing to add.
        if (LAST_RAY_TO_LIGHTS && DEPTH >= MAX_BOUNCES && !meets_light(o, d)) break;
        if (!intersect_scene(o, d, 1.0 / 0.0, hit)) {
            float w_env;
            vec3 le_env = environment_met(d, nee, power, prev_pdf, prev_delta, w_env);
            record_end(learn && DEPTH <= RECORD_VERTICES && prev_key != NO_KEY, prev_key, le_env, w_env, end_key,
                       end_target, prev_factor);
            radiance += beta * (scene_has_light(LIGHT_ENV) ? le_env * w_env : le_env);
            break;
        }
        vec3 wo = -d;
        float w_le;
        vec3 le = emission_met(hit, wo, d, nee, power, prev_pdf, prev_delta, prev_p, beta, radiance, w_le);
        // A mix resolves here to the material every stage below shades with;
        // kernels of scenes without one have no such code (SCENE_MIX).
        uint mat = SCENE_MIX ? resolve_mix(hit.material, hit.p, wo, hit.uv) : hit.material;
        Bsdf bsdf = material_bsdf(mat, hit.uv);
        vec3 n = (bsdf_transmits(bsdf) || dot(hit.n, wo) >= 0.0) ? hit.n : -hit.n;
        vec3 ns = SCENE_SMOOTH ? shading_side(n, hit, wo) : n;
        mat3 frame = make_frame(ns);
        vec3 wo_local = to_local(frame, wo);
        uint qrow, row;
        float fraction;
        // src/cpu/path.rs `guide_vertex`, written inline: the vertex's cell (qrow,
        // its first entry) and sampling row, where something reads them; the row's
        // guided fraction (see the CPU's comment).
#if GUIDED
        {
            qrow = NO_KEY;
            row = 0u;
            if (DEPTH < GUIDE_VERTICES || (learn && DEPTH <= RECORD_VERTICES) || rr) {
                uint gv_cell = cell_index(hit.p);
                qrow = gv_cell * GUIDE_BINS;
                row = sampler_row(gv_cell, normal_class(n));
            }
            fraction = DEPTH < GUIDE_VERTICES ? row_fraction(row) : 0.0;
            if (learn && DEPTH < GUIDE_VERTICES && fraction == 0.0) rows_read[row / GUIDE_BINS] = 1u;
        }
#else
        qrow = NO_KEY;
        row = 0u;
        fraction = 0.0;
#endif
        if (bsdf.kind == MAT_EMISSIVE) {
            record_end(learn && DEPTH <= RECORD_VERTICES && prev_key != NO_KEY, prev_key, le, w_le, end_key,
                       end_target, prev_factor);
            break;
        }
        // src/cpu/path.rs `mixture_fraction`, written inline: the probability of
        // guided sampling at the vertex; 0 at delta vertices and past the guided vertices.
        float g_frac = 0.0;
#if GUIDED
        if (guide && DEPTH < GUIDE_VERTICES && !bsdf_is_delta(bsdf)) {
            g_frac = fraction * (GLOSSY_PRODUCT && product_applies(bsdf) ? 1.0 : lobe_share(bsdf));
        }
        glossy_product(bsdf, frame, wo_local, qrow, g_frac);
#endif
        bool last = DEPTH >= MAX_BOUNCES;

        float u_sel = sample_1d(rng, bounce_dim(DEPTH, SAMPLE_LIGHT_SELECT));
        vec2 u_light = sample_2d(rng, bounce_dim(DEPTH, SAMPLE_LIGHT));
        float nee_here = 0.0;
        if (nee && !last && !bsdf_is_delta(bsdf)) {
            // src/cpu/path.rs `light_sample`, written inline: next-event estimation
            // at the vertex, its shadow ray counted, its contribution added to the
            // radiance, MIS against the mixture's density where the vertex mixes;
            // nee_here the light sample's estimate without the path's throughput
            // (MIS_TARGETS, where the path records; else 0).
            LightSample ls;
            if (sample_light(hit.p, u_sel, u_light, ls) && sides_agree(n, ns, ls.wi)) {
                vec3 ls_wi_local = to_local(frame, ls.wi);
                float ls_pdf_bsdf;
                vec3 ls_f = bsdf_eval_pdf(bsdf, wo_local, ls_wi_local, ls_pdf_bsdf);
                if (max_component(ls.le) > 0.0 && max_component(ls_f) > 0.0) {
                    vec3 ls_origin, ls_dir;
                    float ls_len;
                    shadow_ray(hit.p, hit.n, hit.eps, ls, ls_origin, ls_dir, ls_len);
                    COUNT_RAY();
                    if (!occluded(ls_origin, ls_dir, ls_len, ls.skip)) {
                        float ls_pdf_mix = ls_pdf_bsdf;
#if GUIDED
                        if (g_frac > 0.0) ls_pdf_mix = mixture_pdf(g_frac, ls_pdf_bsdf, guided_bin_pdf(frame, wo_local, bsdf, row, bin_index(ls.wi)));
#endif
                        // A delta light is reached by no BSDF-sampled ray: weight 1.
                        float ls_w = (SCENE_DELTA && ls.delta) ? 1.0 : mis_weight(ls.pdf, ls_pdf_mix, power);
                        radiance += beta * ls_f * abs(ls_wi_local.z) * ls.le * (ls_w / ls.pdf);
                        if (MIS_TARGETS && learn) nee_here = mean3(ls_f * abs(ls_wi_local.z) * ls.le * (ls_w / ls.pdf));
                    }
                }
            }
        }

        // The continuation: sampled at the last bounce too when the path records,
        // since the previous vertex's Q-learning target is estimated from it.
        bool wants_target = learn && DEPTH <= RECORD_VERTICES && prev_key != NO_KEY;
        if (last && !wants_target) break;
        float u_mix = sample_1d(rng, bounce_dim(DEPTH, SAMPLE_MIX));
        float uc = sample_1d(rng, bounce_dim(DEPTH, SAMPLE_LOBE));
        vec2 u = sample_2d(rng, bounce_dim(DEPTH, SAMPLE_DIRECTION));
        vec3 wi, weight;
        float pdf, factor;
        bool delta;
        uint wi_bin;
        // src/cpu/path.rs `choose_direction`, written inline: the direction leaving
        // the vertex, from the table (u_mix below g_frac) or the BSDF; then, where
        // the two are mixed, one evaluation of the BSDF and the mixture density for
        // either choice. A guided direction comes with its bin (`wi_bin`, where qrow
        // is set), a BSDF direction's is found once. `ok`: whether there is a
        // direction; `factor` its fraction-gradient factor, 0 where it did not mix.
        wi = vec3(0.0);
        weight = vec3(0.0);
        pdf = 0.0;
        delta = false;
        bool ok = false;
        wi_bin = 0u;
        factor = 0.0;
#if GUIDED
        if (u_mix < g_frac) {
            if (GLOSSY_PRODUCT && vertex_product.sum_w > 0.0) {
                wi_bin = product_bin(frame, wo_local, bsdf.alpha, vertex_product, uc);
                wi = bin_sample(wi_bin, u);
            } else {
                wi = guided_direction(row, uc, u, wi_bin);
            }
            ok = true;
        } else
#endif
        {
            BsdfSample cd_s = bsdf_sample(bsdf, wo_local, uc, u);
            ok = cd_s.ok;
            if (ok) {
                wi = normalize(to_world(frame, cd_s.wi));
                weight = cd_s.weight;
                pdf = cd_s.pdf;
                delta = cd_s.delta;
            }
        }
#if GUIDED
        // A delta lobe at a vertex that mixes (a smooth coat's): chosen with
        // (1 - g_frac) times the BSDF's chance, which its weight counts alone.
        if (SCENE_SMOOTH_COAT && ok && delta && g_frac > 0.0) weight /= 1.0 - g_frac;
#endif
        // A direction on one side of the shading normal and the other of the
        // surface would leak light through it: dropped.
        if (!sides_agree(n, ns, wi)) ok = false;
#if GUIDED
        if (ok && qrow != NO_KEY && !(u_mix < g_frac)) wi_bin = bin_index(wi);
        // Where GLOSSY_UNGUIDED a vertex that mixes is never glossy (its share is
        // 0), and the last test, always true here then, says so to the compiler.
        if (ok && g_frac > 0.0 && !delta && (!GLOSSY_UNGUIDED || bsdf.kind != MAT_GLOSSY)) {
            vec3 cd_wi_local = to_local(frame, wi);
            float cd_pdf_bsdf;
            vec3 cd_f = bsdf_eval_pdf(bsdf, wo_local, cd_wi_local, cd_pdf_bsdf);
            float cd_pdf_guided = guided_bin_pdf(frame, wo_local, bsdf, row, wi_bin);
            pdf = mixture_pdf(g_frac, cd_pdf_bsdf, cd_pdf_guided);
            ok = pdf > 0.0 && max_component(cd_f) > 0.0;
            weight = ok ? cd_f * (abs(cd_wi_local.z) / pdf) : vec3(0.0);
            // share * g (1 - g) is g_frac (1 - g).
            if (learn_fraction && ok) factor = g_frac * (1.0 - fraction) * (cd_pdf_guided - cd_pdf_bsdf) / pdf * mean3(weight);
        }
#endif
        record_vertex_target(wants_target, ok, weight, qrow, wi_bin, le, w_le, nee_here, prev_key, prev_factor);
        if (last || !ok) break;
        beta *= weight;
        prev_pdf = pdf;
        prev_delta = delta;
        prev_p = hit.p;
        prev_key = qrow == NO_KEY ? NO_KEY : qrow + wi_bin;
        prev_factor = factor;
        o = offset_origin(hit.p, hit.n, hit.eps, wi);
        d = wi;
        depth_rays += 1u;
        // src/cpu/path.rs `roulette`, written here rather than as a function: as
        // one (its sampler passed inout) it made unguided frames longer.
        if (rr && DEPTH >= params.rr_depth) {
            float q = min(max_component(beta), 0.95);
#if GUIDED
            if (pixel_estimate > 0.0 && prev_key != NO_KEY) q = survival_probability(mean3(beta) * q_table[prev_key], pixel_estimate);
#endif
            if (sample_1d(rng, bounce_dim(DEPTH, SAMPLE_ROULETTE)) >= q) break;
            beta /= q;
        }
        if (max_component(beta) <= 0.0) break;
    }
    if (end_key != NO_KEY) record(end_key, end_target, end_target, prev_factor);
    if (PACK_RAYS) segments += depth_rays >> 16u;
    return radiance;
}

void main() {
    uint px = gl_WorkGroupID.x * gl_WorkGroupSize.z + gl_LocalInvocationID.z;
    uint py = pixel_row(gl_WorkGroupID.y);
    uint lane = gl_LocalInvocationID.x + uint(SAMPLES_X) * gl_LocalInvocationID.y;
    bool inside = px < params.width && py < params.height;
    uint pixel = py * params.width + px;
    // A frame cut short traces push.samples of the pixel's 64 sample indices
    // in its first lanes (whole subgroups idle), from one drawn per pixel and frame.
    bool whole = push.samples == uint(SAMPLES_PER_FRAME);
    uint sample_index = whole ? lane : pass_sample(params.seed, pixel, push.rng_frame, lane);
    bool traced = inside && lane < push.samples;

    vec3 radiance = vec3(0.0);
    uint segments = 0u;
    uint zero = 0u;
    if (traced) {
        PathSampler rng = sampler_init(params.seed, pixel, push.rng_frame, sample_index);
        // Stratified over the pixel: independent sample (x, y) of the 8 x 8 takes
        // its own sub-square, jittered (src/math/sampler.rs `sample_pixel`).
        vec2 u = sample_pixel(rng, uvec2(sample_index % uint(SAMPLES_X), sample_index / uint(SAMPLES_X)));
        vec3 o, d;
        camera_ray(px, py, u, o, d);
        float estimate = 0.0;
#if GUIDED
        // src/guide/roulette.rs `roulette_estimate`: the image's frames and the learning
        // frames' (sum.w); where accum_frames is 0, the buffer still holds the latter.
        if (push.accum_frames + push.learned_frames > 0u && push.frame + push.table_frames >= uint(LEARNED_RR_FRAMES)) {
            vec4 s = accum[pixel].sum;
            float learned = push.accum_frames > 0u ? s.w : 0.0;
            float frames = (push.accum_frames > 0u ? push.accum_weight : 0.0) + float(push.learned_frames);
            estimate = (mean3(s.xyz) + learned) / (float(SAMPLES_PER_FRAME) * frames);
        }
#endif
        radiance = trace_path(o, d, estimate, rng, segments);
        if (!(max_component(radiance) > 0.0)) zero = 1u;
        // A NaN or infinite sample would poison the pixel for good; it is dropped, as on the CPU.
        if (any(isnan(radiance)) || any(isinf(radiance))) radiance = vec3(0.0);
    }
    // Frame counters: one atomic per subgroup and counter, where they are kept.
    if (COUNTERS) {
        uint zero_sum = subgroupAdd(zero);
        if (subgroupElect()) atomicAdd(counters[COUNTER_ZERO_PATHS], zero_sum);
    }
    if (COUNT_RAYS) {
        uint segment_sum = subgroupAdd(segments);
        // The subgroup runs the loop until its longest path ends: its lanes'
        // share of that, for the lane utilization `rlpt bench` prints.
        uint longest = subgroupMax(segments);
        uint pixels_share = subgroupAdd(inside ? 1u : 0u) / min(gl_SubgroupSize, 64u);
        if (subgroupElect()) {
            counter_add64(COUNTER_SEGMENTS, segment_sum);
            counter_add64(COUNTER_SUBGROUP_SEGMENTS, longest * pixels_share);
        }
    }

    // Every invocation takes part in the reduction, inside the image or not.
    vec3 sum = reduce_pixel_sum(radiance);
#ifdef RLPT_WEIGHS_FRAMES
    // A frame cut short ends the render: the race does not weigh it.
    if (FRAME_VARIANCE && inside && lane == 0u && whole) add_frame_variance(pixel, mean3(sum));
#endif
    if (inside && lane == 0u) {
        accumulate(pixel, sum);
    }
}
