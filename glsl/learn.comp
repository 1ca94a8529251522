#version 460
// Between frames, with guiding (src/guide/mod.rs `QTable::learn`):
// phase 0, one invocation per entry: folds the frame's Q-learning targets into
// the running means, Q <- (Q n + S) / (n + c), i.e. learning rate 1 / (1 + visits)
// for each target, and clears the frame's sums;
// phase 1, one invocation per (cell, normal class): rebuilds that sampling row,
// an alias table over bins in proportion to (Q + floor * Qbar) cos
// (`build_sampling_rows`, `build_alias_row`: the same steps in the same order).
#include "common.glsl"
#include "sampling.glsl"

layout(local_size_x = LEARN_GROUP) in;
layout(std430, set = 0, binding = 0) buffer QTable { float q_table[]; };
layout(std430, set = 0, binding = 1) buffer Visits { uint visits[]; };
layout(std430, set = 0, binding = 2) buffer FrameSums { float frame_sums[]; };
layout(std430, set = 0, binding = 3) buffer FrameCounts { uint frame_counts[]; };
// Per bin: (threshold << 16 | alias, density bits); src/guide/mod.rs `AliasBin`.
layout(std430, set = 0, binding = 4) buffer Sampler { uvec2 sampler_table[]; };
layout(push_constant) uniform Push {
    uint phase;
    uint entries;
    uint bins;
    float floor_factor;
    uint rows;
    uint cols;
} push;

// src/guide/mod.rs `Bins::center` and `bin_cosine` for the axis of `class_`.
float bin_cosine(uint b, uint class_) {
    uint row = b / push.cols;
    uint col = b % push.cols;
    float z = 1.0 - 2.0 * (float(row) + 0.5) / float(push.rows);
    float phi = 2.0 * PI * (float(col) + 0.5) / float(push.cols);
    float r = sqrt(max(0.0, 1.0 - z * z));
    vec3 c = vec3(r * cos(phi), r * sin(phi), z);
    float s = c[class_ / 2u];
    s = (class_ % 2u == 0u) ? s : -s;
    return s > 1e-6 ? s : 0.0;
}

const uint UNLEARNED = 0xffffffffu;

float weight_at(uint i) { return uintBitsToFloat(sampler_table[i].y); }

// First column at or after `from` not yet set whose scaled weight is small
// (below 1) or large; n where there is none. src/guide/mod.rs `build_alias_row`.
uint open_column(uint row, uint from, uint n, bool small) {
    for (uint i = from; i < n; ++i) {
        uvec2 e = sampler_table[row + i];
        if (e.x == UNLEARNED && (uintBitsToFloat(e.y) < 1.0) == small) return i;
    }
    return n;
}

// Vose's construction in place over the weights in the density slots, then
// each bin's density read back from the table (src/guide/mod.rs `build_alias_row`).
void build_alias_row(uint row, uint n, float total) {
    float scale = float(n) / total;
    for (uint b = 0u; b < n; ++b) sampler_table[row + b].y = floatBitsToUint(weight_at(row + b) * scale);
    uint next = open_column(row, 0u, n, true);
    uint s = next;
    uint l = open_column(row, 0u, n, false);
    while (s < n && l < n) {
        float p = weight_at(row + s);
        uint threshold = min(uint(ceil(p * 65535.0)), 65535u);
        sampler_table[row + s].x = (threshold << 16u) | l;
        float rest = (weight_at(row + l) + p) - 1.0;
        sampler_table[row + l].y = floatBitsToUint(rest);
        if (rest < 1.0) {
            s = l;
            l = open_column(row, l + 1u, n, false);
        } else {
            next = open_column(row, next + 1u, n, true);
            s = next;
        }
    }
    for (uint b = 0u; b < n; ++b) {
        if (sampler_table[row + b].x == UNLEARNED) sampler_table[row + b].x = (65535u << 16u) | b;
    }
    // Densities: the probability of each bin under the table, over 4 pi / n.
    for (uint b = 0u; b < n; ++b) {
        sampler_table[row + b].y = floatBitsToUint(float(sampler_table[row + b].x >> 16u) / 65535.0);
    }
    for (uint b = 0u; b < n; ++b) {
        uint c = sampler_table[row + b].x;
        uint a = c & 0xffffu;
        if (a != b) {
            float t = float(c >> 16u) / 65535.0;
            sampler_table[row + a].y = floatBitsToUint(weight_at(row + a) + (1.0 - t));
        }
    }
    for (uint b = 0u; b < n; ++b) {
        sampler_table[row + b].y = floatBitsToUint(weight_at(row + b) * (1.0 / (4.0 * PI)));
    }
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (push.phase == 0u) {
        if (i >= push.entries) return;
        uint c = frame_counts[i];
        if (c == 0u) return;
        float n = float(visits[i]);
        q_table[i] = (q_table[i] * n + frame_sums[i]) / (n + float(c));
        visits[i] += c;
        frame_sums[i] = 0.0;
        frame_counts[i] = 0u;
        return;
    }
    uint cell = i / NORMAL_CLASSES;
    uint class_ = i % NORMAL_CLASSES;
    uint qrow = cell * push.bins;
    if (qrow >= push.entries) return;
    uint row = i * push.bins;
    float qc = 0.0;
    float c = 0.0;
    for (uint b = 0u; b < push.bins; ++b) {
        float w = bin_cosine(b, class_);
        qc += q_table[qrow + b] * w;
        c += w;
    }
    float q_floor = c > 0.0 ? push.floor_factor * qc / c : 0.0;
    // The weights, in the density slots while the table is built.
    float total = 0.0;
    for (uint b = 0u; b < push.bins; ++b) {
        float w = (q_table[qrow + b] + q_floor) * bin_cosine(b, class_);
        sampler_table[row + b] = uvec2(UNLEARNED, floatBitsToUint(w));
        total += w;
    }
    if (!(total > 0.0)) {
        for (uint b = 0u; b < push.bins; ++b) sampler_table[row + b] = uvec2(UNLEARNED, 0u);
        return;
    }
    build_alias_row(row, push.bins, total);
}
