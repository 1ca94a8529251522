#version 460
// Between frames, with guiding (src/guide/mod.rs `QTable::learn`):
// phase 0, one invocation per entry: folds the frame's Q-learning targets into
// the running means, Q <- (Q n + S) / (n + c), i.e. learning rate 1 / (1 + visits)
// for each target, and clears the frame's sums;
// phase 1, one invocation per (cell, normal class): rebuilds that sampling CDF,
// bins in proportion to (Q + floor * Qbar) cos (`build_cdf`).
#include "common.glsl"
#include "sampling.glsl"

layout(local_size_x = LEARN_GROUP) in;
layout(std430, set = 0, binding = 0) buffer QTable { float q_table[]; };
layout(std430, set = 0, binding = 1) buffer Visits { uint visits[]; };
layout(std430, set = 0, binding = 2) buffer FrameSums { float frame_sums[]; };
layout(std430, set = 0, binding = 3) buffer FrameCounts { uint frame_counts[]; };
layout(std430, set = 0, binding = 4) buffer Cdf { float cdf_table[]; };
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
    float total = qc + q_floor * c;
    if (!(total > 0.0)) {
        for (uint b = 0u; b < push.bins; ++b) cdf_table[row + b] = 0.0;
        return;
    }
    float acc = 0.0;
    uint last = 0u;
    for (uint b = 0u; b < push.bins; ++b) {
        float w = bin_cosine(b, class_);
        float q = q_table[qrow + b];
        acc += (q + q_floor) * w;
        cdf_table[row + b] = acc / total;
        if (w > 0.0 && q + q_floor > 0.0) last = b;
    }
    for (uint b = last; b < push.bins; ++b) cdf_table[row + b] = 1.0;
}
