#version 460
// Test kernel: reads element 1 of each scene array and the render parameters
// field by field, in GLSL declaration order, so tests/gpu_probes.rs
// `struct_layout_matches_the_rust_mirrors` can check that the Rust mirrors in
// src/prepared.rs have the same layout.
#include "scene.glsl"

layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 5) writeonly buffer Out { uint words[]; };

uint n = 0u;
void put(uint v) { words[n++] = v; }
void putf(float v) { put(floatBitsToUint(v)); }
void put4(vec4 v) { putf(v.x); putf(v.y); putf(v.z); putf(v.w); }

void main() {
    Material m = materials[1];
    put4(m.albedo_roughness); put4(m.emission_ior); put4(m.eta); put4(m.k); put(m.kind); put(m.two_sided); put(m.albedo_texture); put(m.roughness_texture);
    Sphere s = spheres[1];
    put4(s.center_radius); put4(s.anchor_radius); put4(s.axis); put(s.material); put(s.light);
    Quad q = quads[1];
    put4(q.origin); put4(q.edge_u); put4(q.edge_v); put4(q.normal); put4(q.dual_u); put4(q.dual_v);
    put(q.material); put(q.light);
    Light l = lights[1];
    put(l.kind); put(l.index); putf(l.pmf); putf(l.cdf);
    put4(params.cam_position_near); put4(params.cam_forward_tan); put4(params.cam_right_aspect);
    put4(params.cam_up); put4(params.environment);
    put(params.width); put(params.height); put(params.max_bounces); put(params.rr_depth);
    put(params.num_spheres); put(params.num_quads); put(params.num_lights); put(params.flags); put(params.seed);
    put(params.guide_bins); put(params.guide_rows); put(params.guide_cols);
    put4(params.guide_min); put4(params.guide_inv_cell);
    put(params.guide_res_x); put(params.guide_res_y); put(params.guide_res_z); put(params.guide_cells);
    putf(params.guide_floor); put(params.guide_vertices); put(params.occluding_quads); put(params.scene_kinds);
    put(params.num_triangles); put(params.bvh_nodes); put(params.env_width); put(params.env_height);
    put4(params.env_frame[0]); put4(params.env_frame[1]); put4(params.env_frame[2]);
    Triangle t = triangles[1];
    putf(t.v0.x); putf(t.v0.y); putf(t.v0.z); put(t.material);
    putf(t.v1.x); putf(t.v1.y); putf(t.v1.z); put(t.light);
    putf(t.v2.x); putf(t.v2.y); putf(t.v2.z); put(t.normals);
    TriangleNormals tn = triangle_normals[1];
    put4(tn.n0); put4(tn.n1); put4(tn.n2);
    BvhNode b = bvh_nodes[1];
    put4(b.lo_x); put4(b.lo_y); put4(b.lo_z); put4(b.hi_x); put4(b.hi_y); put4(b.hi_z);
    put(b.child.x); put(b.child.y); put(b.child.z); put(b.child.w);
    put(b.count.x); put(b.count.y); put(b.count.z); put(b.count.w);
}
