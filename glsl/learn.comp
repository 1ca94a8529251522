#version 460
// Between frames, with guiding (src/guide/mod.rs `QTable::learn`):
// phase 0, one invocation per entry: folds the frame's Q-learning targets into
// the running means, Q <- (Q n + S) / (n + c), i.e. learning rate 1 / (1 + visits)
// for each target, and clears the frame's sums;
// phase 1, one invocation per cell: rebuilds the cell's sampling CDF over bins in
// proportion to Q + floor * mean(Q) (`build_cdf`).
#include "common.glsl"

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
} push;

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
    uint row = i * push.bins;
    if (row >= push.entries) return;
    float sum = 0.0;
    for (uint b = 0u; b < push.bins; ++b) sum += q_table[row + b];
    float q_floor = push.floor_factor * sum / float(push.bins);
    float total = sum + q_floor * float(push.bins);
    if (!(total > 0.0)) {
        for (uint b = 0u; b < push.bins; ++b) cdf_table[row + b] = 0.0;
        return;
    }
    float acc = 0.0;
    for (uint b = 0u; b < push.bins; ++b) {
        acc += q_table[row + b] + q_floor;
        cdf_table[row + b] = acc / total;
    }
    cdf_table[row + push.bins - 1u] = 1.0;
}
