#version 460
// Test kernel: the product with a glossy lobe (product.glsl) on a Q row from the
// host, whose entries start at 0 of q_table. Input per case: (shading normal,
// alpha), (wo in the shading frame, uc), (a direction, floor). Output per case:
// (sum_w, floor_q, r0 | r1 << 16, the bin product_bin draws), (its product_pdf,
// product_pdf of the direction's bin, window_contains of that bin, the window's
// bins), (the window's zm, phi_m, cos_r, 0).
// tests/guiding_product.rs compares them with src/guide/product.rs.
#extension GL_KHR_shader_subgroup_basic : require
#include "common.glsl"
#include "bsdf.glsl"
#include "product.glsl"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 10) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 11) writeonly buffer Outputs { vec4 outputs[]; };
layout(push_constant) uniform Push { uint count; } push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    vec4 a = inputs[3u * i];
    vec4 b = inputs[3u * i + 1u];
    vec4 c = inputs[3u * i + 2u];
    mat3 frame = make_frame(a.xyz);
    Product p = product_sums(frame, b.xyz, a.w, 0u, c.w);
    uint bin = product_bin(frame, b.xyz, a.w, p, b.w);
    uint test_bin = bin_index(c.xyz);
    uint count = 0u;
    for (uint row = p.window.r0; row <= p.window.r1; ++row) count += window_columns(p.window, row).y;
    outputs[3u * i] = vec4(p.sum_w, p.floor_q, uintBitsToFloat(p.window.r0 | p.window.r1 << 16u), uintBitsToFloat(bin));
    outputs[3u * i + 1u] = vec4(product_pdf(frame, b.xyz, a.w, p, bin), product_pdf(frame, b.xyz, a.w, p, test_bin),
                                window_contains(p.window, test_bin) ? 1.0 : 0.0, float(count));
    outputs[3u * i + 2u] = vec4(p.window.zm, p.window.phi_m, p.window.cos_r, 0.0);
}
