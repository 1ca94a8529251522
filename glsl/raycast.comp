#version 460
// The traversal alone (`rlpt bench --rays`, src/render/raycast.rs): one ray per
// pixel through the renderer's own intersect_scene and occluded, specialized as
// pathtrace.comp is. push.mode: RAYCAST_CAMERA traces the camera rays and keeps
// each hit (point, normal, offset); RAYCAST_BOUNCE traces a cosine-distributed
// ray from each kept hit (a diffuse bounce); RAYCAST_SHADOW asks whether that
// same ray escapes the scene (an any-hit ray, as towards a sky or a light).
#define RLPT_SPECIALIZED
#include "common.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "geometry.glsl"
#include "camera.glsl"
#extension GL_KHR_shader_subgroup_arithmetic : require

layout(local_size_x = RAYCAST_GROUP) in;
// Per pixel: the hit point and its offset bound (w), and the front normal (w: 1 for a hit).
layout(std430, set = 0, binding = BINDING_RAYCAST_HITS) buffer Hits { vec4 hits[]; };
// [0]: the rays that hit (camera, bounce) or were blocked (shadow).
layout(std430, set = 0, binding = BINDING_RAYCAST_COUNT) buffer Count { uint hit_count[]; };
layout(push_constant) uniform Push { uint mode; uint seed; } push;

void main() {
    uint pixel = gl_GlobalInvocationID.x;
    if (pixel >= params.width * params.height) return;
    bool hit_something = false;
    if (push.mode == RAYCAST_CAMERA) {
        vec3 o, d;
        camera_ray(pixel % params.width, pixel / params.width, vec2(0.5), o, d);
        Hit h;
        hit_something = intersect_scene(o, d, 1.0 / 0.0, h);
        vec3 n = dot(h.n, d) < 0.0 ? h.n : -h.n;
        hits[2u * pixel] = vec4(h.p, h.eps);
        hits[2u * pixel + 1u] = vec4(n, hit_something ? 1.0 : 0.0);
    } else {
        vec4 pe = hits[2u * pixel];
        vec4 nh = hits[2u * pixel + 1u];
        if (nh.w == 0.0) return;
        uint rng = rng_init(push.seed, pixel, 0u, 0u);
        vec3 d = to_world(make_frame(nh.xyz), cosine_hemisphere(rng_next_2d(rng)));
        vec3 o = offset_origin(pe.xyz, nh.xyz, pe.w, d);
        if (push.mode == RAYCAST_BOUNCE) {
            Hit h;
            hit_something = intersect_scene(o, d, 1.0 / 0.0, h);
        } else {
            hit_something = occluded(o, d, 1.0 / 0.0, NO_PRIM);
        }
    }
    uint n = subgroupAdd(hit_something ? 1u : 0u);
    if (subgroupElect()) atomicAdd(hit_count[0], n);
}
