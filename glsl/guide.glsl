// Learned guiding on the GPU: src/guide/mod.rs, same functions.
// Needs scene.glsl (params); declares the guiding buffers.
#ifndef RLPT_GUIDE_GLSL
#define RLPT_GUIDE_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_EXT_shader_atomic_float : require
#ifdef RLPT_PARTITIONED
#extension GL_NV_shader_subgroup_partitioned : require
#endif
#include "scene.glsl"
#include "sampling.glsl"

layout(std430, set = 0, binding = BINDING_Q) readonly buffer QTable { float q_table[]; };
layout(std430, set = 0, binding = BINDING_FRAME_SUMS) buffer FrameSums { float frame_sums[]; };
layout(std430, set = 0, binding = BINDING_FRAME_COUNTS) buffer FrameCounts { uint frame_counts[]; };
// Per bin of each sampling row: (threshold << 16 | alias, density bits); src/guide/sampler.rs `AliasBin`.
layout(std430, set = 0, binding = BINDING_SAMPLER) readonly buffer Sampler { uvec2 sampler_table[]; };
// Per sampling row: its guided fraction (the cell's times its evidence weight), 0 where
// it is unlearned; src/guide/table.rs `QTable::fractions`.
layout(std430, set = 0, binding = BINDING_FRACTIONS) readonly buffer Fractions { float row_fractions[]; };
layout(std430, set = 0, binding = BINDING_ROWS_READ) buffer RowsRead { uint rows_read[]; };
// Per cell (first child, depth, targets, unused), then the cells in use;
// src/guide/tree.rs `CellNode`.
layout(std430, set = 0, binding = BINDING_GUIDE_TREE) readonly buffer GuideTree { uvec4 cell_tree[]; };

#ifdef RLPT_SPECIALIZED
// The table's shape as specialization constants: bin and cell arithmetic by
// known numbers.
layout(constant_id = SPEC_GUIDE_ROWS) const uint GUIDE_ROWS = 1u;
layout(constant_id = SPEC_GUIDE_COLS) const uint GUIDE_COLS = 1u;
layout(constant_id = SPEC_GUIDE_RES_X) const uint GUIDE_RES_X = 1u;
layout(constant_id = SPEC_GUIDE_RES_Y) const uint GUIDE_RES_Y = 1u;
layout(constant_id = SPEC_GUIDE_RES_Z) const uint GUIDE_RES_Z = 1u;
const uint GUIDE_BINS = GUIDE_ROWS * GUIDE_COLS;
// The includer declares FLAGS, the specialized params.flags.
const bool GUIDE_ADAPTIVE = (FLAGS & FLAG_ADAPTIVE_GRID) != 0u;
// An adaptive grid's table holds more cells than the grid: params.guide_cells.
#define GUIDE_ENTRIES (GUIDE_ADAPTIVE ? params.guide_cells * GUIDE_BINS : GUIDE_RES_X * GUIDE_RES_Y * GUIDE_RES_Z * GUIDE_BINS)
#else
#define GUIDE_ADAPTIVE ((params.flags & FLAG_ADAPTIVE_GRID) != 0u)
#define GUIDE_ROWS params.guide_rows
#define GUIDE_COLS params.guide_cols
#define GUIDE_RES_X params.guide_res_x
#define GUIDE_RES_Y params.guide_res_y
#define GUIDE_RES_Z params.guide_res_z
#define GUIDE_BINS params.guide_bins
#define GUIDE_ENTRIES (params.guide_cells * params.guide_bins)
#endif

// src/guide/bins.rs `Bins::column`: the sector of atan2(y, x) in [0, 2 pi), found
// without the arctangent where the columns are a multiple of 4: (x, y) turned
// back by whole quarter turns into the first quadrant, the sector within it
// counted by the sides of its inner edges. With the table's shape specialized
// the edges' sines and cosines are constants.
uint bin_column(float x, float y) {
    uint cols = GUIDE_COLS;
    if (cols % 4u != 0u) {
        float phi = atan(y, x);
        if (phi < 0.0) phi += 2.0 * PI;
        return min(uint(phi * (0.5 / PI) * float(cols)), cols - 1u);
    }
    uint per_quadrant = cols / 4u;
    uint q;
    float u, v;
    if (y >= 0.0) {
        if (x > 0.0) { q = 0u; u = x; v = y; } else { q = 1u; u = y; v = -x; }
    } else {
        if (x > 0.0) { q = 3u; u = -y; v = x; } else { q = 2u; u = -x; v = -y; }
    }
    if (u <= 0.0) return v > 0.0 ? (q + 1u) * per_quadrant : 0u;
    float step = 0.5 * PI / float(per_quadrant);
    uint inside = 0u;
    for (uint j = 1u; j < per_quadrant; ++j) {
        float t = float(j) * step;
        if (v * cos(t) - u * sin(t) >= 0.0) inside += 1u;
    }
    return q * per_quadrant + inside;
}

uint bin_index(vec3 d) {
    uint rows = GUIDE_ROWS;
    uint cols = GUIDE_COLS;
    uint row = min(uint((1.0 - d.z) * 0.5 * float(rows)), rows - 1u);
    return row * cols + bin_column(d.x, d.y);
}

vec3 bin_sample(uint b, vec2 u) {
    uint cols = GUIDE_COLS;
    uint row = b / cols;
    uint col = b % cols;
    float z = 1.0 - 2.0 * (float(row) + u.x) / float(GUIDE_ROWS);
    float phi = 2.0 * PI * (float(col) + u.y) / float(cols);
    float r = sqrt(max(0.0, 1.0 - z * z));
    return vec3(r * cos(phi), r * sin(phi), z);
}

// src/guide/bins.rs `normal_class`: the signed axis closest to a unit normal.
// The component is picked by selects: n[axis] with axis unknown made the
// driver keep n in local memory (16 bytes per invocation, NVIDIA 580).
uint normal_class(vec3 n) {
    vec3 a = abs(n);
    uint axis = (a.x >= a.y && a.x >= a.z) ? 0u : (a.y >= a.z ? 1u : 2u);
    float c = axis == 0u ? n.x : (axis == 1u ? n.y : n.z);
    return 2u * axis + (c < 0.0 ? 1u : 0u);
}

// The first bin of the sampling row for a cell and a normal class.
uint sampler_row(uint cell, uint class_) { return (cell * NORMAL_CLASSES + class_) * GUIDE_BINS; }

// src/guide/tree.rs `cell_in_tree`: the grid's cell holding p, then, where the
// grid is adaptive, down the cell tree by octant, p taken in the cell's unit cube.
uint cell_index(vec3 p) {
    vec3 g = (p - params.guide_min.xyz) * params.guide_inv_cell.xyz;
    uint x = min(uint(max(g.x, 0.0)), GUIDE_RES_X - 1u);
    uint y = min(uint(max(g.y, 0.0)), GUIDE_RES_Y - 1u);
    uint z = min(uint(max(g.z, 0.0)), GUIDE_RES_Z - 1u);
    uint cell = (z * GUIDE_RES_Y + y) * GUIDE_RES_X + x;
    if (GUIDE_ADAPTIVE) {
        vec3 f = clamp(g - vec3(x, y, z), vec3(0.0), vec3(1.0));
        for (uint d = 0u; d < GUIDE_TREE_DEPTH; ++d) {
            uint first = cell_tree[cell].x;
            if (first == 0u) break;
            uvec3 o = uvec3(greaterThanEqual(f, vec3(0.5)));
            cell = first + o.x + 2u * o.y + 4u * o.z;
            f = f * 2.0 - vec3(o);
        }
    }
    return cell;
}

// src/guide/sampler.rs `guided_direction`: the column of the row's alias table
// from uc, the bin by the column's threshold, the direction uniform inside the
// bin (also returned, in `b`). Its density is `guided_pdf`, a function of the
// direction alone: `bin_pdf` of the bin, which the caller has without
// bin_index's arctangent.
vec3 guided_direction(uint row, float uc, vec2 u, out uint b) {
    uint n = GUIDE_BINS;
    float x = uc * float(n);
    uint i = min(uint(x), n - 1u);
    float rest = x - float(i);
    uint column = sampler_table[row + i].x;
    b = rest * float(ALIAS_THRESHOLD_ONE) < float(column >> 16u) ? i : column & 0xffffu;
    return bin_sample(b, u);
}

// The guided density in bin b of a sampling row.
float bin_pdf(uint row, uint b) { return uintBitsToFloat(sampler_table[row + b].y); }

// src/guide/sampler.rs `mixture_pdf`: the one-sample mixture's density, guided
// sampling with probability g_frac, the BSDF otherwise.
float mixture_pdf(float g_frac, float pdf_bsdf, float pdf_guided) { return (1.0 - g_frac) * pdf_bsdf + g_frac * pdf_guided; }

float guided_pdf(uint row, vec3 dir) { return bin_pdf(row, bin_index(dir)); }

// The guided fraction of the sampling row whose first bin is `row`: 0 where
// the row has learned nothing (src/cpu/mod.rs reads QTable::fractions).
float row_fraction(uint row) { return row_fractions[row / GUIDE_BINS]; }

#include "record.glsl"

#endif
