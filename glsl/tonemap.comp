#version 460
// The viewer's display pass: the accumulation's mean radiance, clamped to [0,1]
// and sRGB-encoded exactly as `rlpt render` writes a PNG (src/image.rs
// `to_srgb8`), packed as RGBA8 (R in the low byte) for a copy into an
// R8G8B8A8 image. Where an inset is shown (the learned Q distribution of one
// voxel, drawn on the host), its pixels replace the image's.
#include "common.glsl"

layout(local_size_x = TONEMAP_GROUP_X, local_size_y = TONEMAP_GROUP_Y) in;

struct AccumPixel {
    vec4 sum;
    vec4 m2_frame_mean;
};
layout(std430, set = 0, binding = 0) readonly buffer Accum { AccumPixel accum[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Display { uint display[]; };
layout(std430, set = 0, binding = 2) readonly buffer Inset { uint inset[]; };

// frames: frames in the accumulation (64 samples per pixel each); the inset
// covers [inset_x, inset_x + inset_w) x [inset_y, inset_y + inset_h), none when inset_w == 0.
layout(push_constant) uniform Push {
    uint width;
    uint height;
    uint frames;
    uint inset_x;
    uint inset_y;
    uint inset_w;
    uint inset_h;
} push;

float srgb_encode(float l) {
    return l <= 0.0031308 ? 12.92 * l : 1.055 * pow(l, 1.0 / 2.4) - 0.055;
}

uint to_srgb8(float linear) {
    // NaN -> 0, like the PNG writer.
    float c = isnan(linear) ? 0.0 : clamp(linear, 0.0, 1.0);
    return uint(clamp(floor(srgb_encode(c) * 255.0 + 0.5), 0.0, 255.0));
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= push.width || p.y >= push.height) {
        return;
    }
    uint i = p.y * push.width + p.x;
    uint ix = p.x - push.inset_x;
    uint iy = p.y - push.inset_y;
    if (push.inset_w > 0u && p.x >= push.inset_x && p.y >= push.inset_y && ix < push.inset_w && iy < push.inset_h) {
        display[i] = inset[iy * push.inset_w + ix];
        return;
    }
    float n = float(max(push.frames, 1u)) * float(SAMPLES_PER_FRAME);
    vec3 mean = accum[i].sum.xyz / n;
    display[i] = to_srgb8(mean.r) | (to_srgb8(mean.g) << 8) | (to_srgb8(mean.b) << 16) | (255u << 24);
}
