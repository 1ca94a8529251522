#version 460
// Between frames, with guiding, after the frames that src/guide/record.rs
// `RecordSchedule::learns_after` names (src/guide/table.rs `QTable::learn`):
// phase 0, one invocation per entry: folds the Q-learning targets recorded since
// the last fold into the table, Q <- Q + w (S / c - Q) with w = batch_rate(n, c)
// (learning rate 1 / i^omega for the i-th target; the running mean at omega = 1),
// and clears the sums;
// phase 1, one workgroup per (cell, normal class): rebuilds that sampling row
// where a recording path has read it (`QTable::rows_read`),
// an alias table over bins in proportion to (Q + floor * Qbar) cos
// (`build_sampling_rows`, `build_alias_row`: the same steps in the same order).
// Where cells learn their guided fractions (push.learn_fraction), phase 0's
// first `cells` invocations also take one Adam step on their cell's fraction
// from the gradients summed after the table's entries (`FractionState::step`),
// and phase 1 writes each row's fraction (`QTable::learn`).
// Phase 2, where the grid is adaptive, between the two (one group): the leaves
// that have learned enough split (`refine`, src/guide/tree.rs `QTable::refine`).
#include "common.glsl"
#include "sampling.glsl"

// src/render/mod.rs `GpuRenderer::new`: the fold runs LEARN_FOLD_GROUP invocations
// per group with no shared array; the rebuild LEARN_ROW_GROUP per group, one row
// each group, staged in shared arrays of a row's bins (STAGE_WORDS).
layout(local_size_x_id = SPEC_LEARN_GROUP) in;
layout(constant_id = SPEC_LEARN_GROUP) const uint GROUP = LEARN_FOLD_GROUP;
layout(constant_id = SPEC_LEARN_STAGE_WORDS) const uint STAGE_WORDS = 1u;
layout(std430, set = 0, binding = 0) buffer QTable { float q_table[]; };
layout(std430, set = 0, binding = 1) buffer Visits { uint visits[]; };
layout(std430, set = 0, binding = 2) buffer FrameSums { float frame_sums[]; };
layout(std430, set = 0, binding = 3) buffer FrameCounts { uint frame_counts[]; };
// Per bin: (threshold << 16 | alias, density bits); src/guide/sampler.rs `AliasBin`.
layout(std430, set = 0, binding = 4) buffer Sampler { uvec2 sampler_table[]; };
// Per sampling row: its guided fraction, 0 where unlearned (`QTable::fractions`).
layout(std430, set = 0, binding = 5) buffer Fractions { float row_fractions[]; };
// Per cell: theta, Adam's m and v, steps (`FractionState`).
layout(std430, set = 0, binding = 6) buffer FractionStates { vec4 fraction_states[]; };
// Per sampling row: 1 once a recording path read it (`QTable::rows_read`).
layout(std430, set = 0, binding = 7) buffer RowsRead { uint rows_read[]; };
// Per cell (first child, depth, targets bits, unused), then the cells in use
// (src/guide/tree.rs `CellNode`).
layout(std430, set = 0, binding = 8) buffer CellTree { uvec4 cell_tree[]; };
layout(push_constant) uniform Push {
    uint phase;
    uint entries;
    uint bins;
    float floor_factor;
    uint rows;
    uint cols;
    uint cells;
    float start_fraction;  // fixed, or each cell's start where learn_fraction
    uint learn_fraction;
    float rate_exponent;  // omega of Q's learning rate 1 / i^omega
    uint adaptive;        // the grid's cells split (FLAG_ADAPTIVE_GRID)
    uint pool_largest;    // adaptive directions' largest block (1: none; pooled_q)
} push;

// src/guide/table.rs `batch_rate`: the weight with which c targets move an entry
// that has taken n towards their mean.
float batch_rate(float n, float k) {
    if (n <= 0.0) return 1.0;
    float omega = push.rate_exponent;
    if (omega >= 1.0) return k / (n + k);
    float a = 1.0 - omega;
    float x = k / n;
    float growth = x < 1e-3 ? a * x * (1.0 + 0.5 * (a - 1.0) * x) : pow(1.0 + x, a) - 1.0;
    float s = pow(n, a) / a * growth;
    return s < 1e-3 ? s * (1.0 - 0.5 * s) : 1.0 - exp(-s);
}

// src/guide/fraction.rs `logit`.
float logit(float p) { return log(p / (1.0 - p)); }

// src/guide/fraction.rs `FractionState::fraction`.
float cell_fraction(vec4 s) {
    float l = logit(push.start_fraction) + s.x;
    return clamp(1.0 / (1.0 + exp(-l)), FRACTION_MIN, 1.0 - FRACTION_MIN);
}

// src/guide/fraction.rs `evidence_weight`: the share of its fraction a cell
// whose entries took n targets uses.
float evidence_weight(float n) {
    return n / (n + float(FRACTION_EVIDENCE_PER_BIN) * float(push.bins));
}

// src/guide/fraction.rs `FractionState::step`.
vec4 fraction_step(vec4 s, float gradient) {
    if (isnan(gradient) || isinf(gradient)) return s;
    s.w += 1.0;
    s.y = FRACTION_BETA1 * s.y + (1.0 - FRACTION_BETA1) * gradient;
    s.z = FRACTION_BETA2 * s.z + (1.0 - FRACTION_BETA2) * gradient * gradient;
    float m_hat = s.y / (1.0 - pow(FRACTION_BETA1, s.w));
    float v_hat = s.z / (1.0 - pow(FRACTION_BETA2, s.w));
    if (v_hat > 0.0) s.x -= FRACTION_RATE * m_hat / sqrt(v_hat);
    float bound = log((1.0 - FRACTION_MIN) / FRACTION_MIN);
    float start_logit = logit(push.start_fraction);
    s.x = clamp(s.x, -bound - start_logit, bound - start_logit);
    return s;
}

// src/guide/bins.rs `Bins::center` and `bin_cosine` for the axis of `class_`.
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

// A row is built where loads cost little: Vose's loop is sequential, and built
// in the table by one invocation its chains of dependent loads from L2 were
// slow. A group stages its row in shared memory (a row of Bins::MAX_COUNT bins
// fits the 16 KB every device has) and builds it together: the loops over bins
// in parallel, the sums and Vose's loop by its first invocation, in the order
// of the CPU twin (docs/guiding.md, "Learning").
shared uvec2 staged[STAGE_WORDS];
// Each bin's probability in units of 1 / ALIAS_THRESHOLD_ONE, summed by atomics.
shared uint staged_units[STAGE_WORDS];
shared float staged_total;

float weight_at(uint b) { return uintBitsToFloat(staged[b].y); }
void set_weight(uint b, float w) { staged[b].y = floatBitsToUint(w); }

// First column at or after `from` not yet set whose scaled weight is small
// (below 1) or large; n where there is none. src/guide/sampler.rs `build_alias_row`.
uint open_column(uint from, uint n, bool small) {
    for (uint i = from; i < n; ++i) {
        uvec2 e = staged[i];
        if (e.x == uint(UNLEARNED) && (uintBitsToFloat(e.y) < 1.0) == small) return i;
    }
    return n;
}

// Vose's pairing over the scaled weights (mean 1) in the density slots: each
// small column takes its threshold and the large bin that fills it
// (src/guide/sampler.rs `build_alias_row`); columns left unset stay UNLEARNED.
void alias_pairs(uint n) {
    uint next = open_column(0u, n, true);
    uint s = next;
    uint l = open_column(0u, n, false);
    while (s < n && l < n) {
        float p = weight_at(s);
        uint threshold = min(uint(ceil(p * float(ALIAS_THRESHOLD_ONE))), uint(ALIAS_THRESHOLD_ONE));
        staged[s].x = (threshold << 16u) | l;
        float rest = (weight_at(l) + p) - 1.0;
        set_weight(l, rest);
        if (rest < 1.0) {
            s = l;
            l = open_column(l + 1u, n, false);
        } else {
            next = open_column(next + 1u, n, true);
            s = next;
        }
    }
}

// A bin's density from its probability in units (src/guide/sampler.rs
// `alias_densities`): units / ALIAS_THRESHOLD_ONE / n over the bin's 4 pi / n.
float units_density(uint units) { return float(units) / float(ALIAS_THRESHOLD_ONE) * (1.0 / (4.0 * PI)); }

// Phase 0 for entry i: fold its targets into Q; for i < cells where cells learn
// their fractions, one Adam step on cell i's fraction too.
void fold(uint i) {
    if (push.learn_fraction != 0u && i < push.cells) {
        uint k = push.entries + i;
        uint c = frame_counts[k];
        if (c != 0u) {
            fraction_states[i] = fraction_step(fraction_states[i], frame_sums[k] / float(c));
            frame_sums[k] = 0.0;
            frame_counts[k] = 0u;
        }
    }
    if (i >= push.entries) return;
    uint c = frame_counts[i];
    if (c == 0u) return;
    float w = batch_rate(float(visits[i]), float(c));
    q_table[i] += w * (frame_sums[i] / float(c) - q_table[i]);
    visits[i] += c;
    frame_sums[i] = 0.0;
    frame_counts[i] = 0u;
}

// The sums of row i over its bins' Q and cosine (staged in the column and
// density slots), the weights (Q + floor * Qbar) cos written to the density
// slots and the columns marked unset; the row's fraction and, where the grid is
// adaptive, its cell's targets written. Returns the weights' total.
// Sequential, in the CPU twin's order (`build_sampling_rows`).
float row_weights(uint i) {
    uint cell = i / NORMAL_CLASSES;
    uint qrow = cell * push.bins;
    float qc = 0.0;
    float c = 0.0;
    float targets = 0.0;
    for (uint b = 0u; b < push.bins; ++b) {
        float q = uintBitsToFloat(staged[b].x);
        float w = uintBitsToFloat(staged[b].y);
        targets += float(visits[qrow + b]);
        qc += q * w;
        c += w;
    }
    // Each of the cell's rows read writes the same sum (QTable::learn's order).
    if (push.adaptive != 0u) cell_tree[cell].z = floatBitsToUint(targets);
    float q_floor = c > 0.0 ? push.floor_factor * qc / c : 0.0;
    float total = 0.0;
    for (uint b = 0u; b < push.bins; ++b) {
        float w = (uintBitsToFloat(staged[b].x) + q_floor) * uintBitsToFloat(staged[b].y);
        staged[b] = uvec2(uint(UNLEARNED), floatBitsToUint(w));
        total += w;
    }
    float g = push.learn_fraction != 0u ? cell_fraction(fraction_states[cell]) : push.start_fraction;
    row_fractions[i] = total > 0.0 ? g * evidence_weight(targets) : 0.0;
    return total;
}

// src/guide/sampler.rs `pooled_q`: the Q that bin b of the cell whose entries
// start at qrow weighs its density by: the visit-weighted mean of the smallest
// block of 1, 2x2 or 4x4 bins around it (up to push.pool_largest, the sizes
// dividing the rows and columns) whose entries took BIN_POOL_TARGETS targets a
// bin, of the largest where none did. `precise`: the sums as the CPU's.
float pooled_q(uint qrow, uint b) {
    uint row = b / push.cols;
    uint col = b % push.cols;
    for (uint s = 1u; s <= push.pool_largest; s *= 2u) {
        uint r0 = row / s * s;
        uint c0 = col / s * s;
        uint n = 0u;
        for (uint r = r0; r < r0 + s; ++r) {
            for (uint c = c0; c < c0 + s; ++c) {
                // Saturating, as the CPU's.
                uint v = visits[qrow + r * push.cols + c];
                n = n > 0xffffffffu - v ? 0xffffffffu : n + v;
            }
        }
        if (n < uint(BIN_POOL_TARGETS) * s * s && s != push.pool_largest) continue;
        if (s == 1u) return q_table[qrow + b];
        precise float nq = 0.0;
        for (uint r = r0; r < r0 + s; ++r) {
            for (uint c = c0; c < c0 + s; ++c) {
                uint e = qrow + r * push.cols + c;
                precise float t = float(visits[e]) * q_table[e];
                nq += t;
            }
        }
        return n > 0u ? nq / float(n) : 0.0;
    }
    return q_table[qrow + b];
}

// Phase 1 for sampling row i, of cell i / NORMAL_CLASSES, by the whole group:
// rebuild it where a recording path has read it (else it stays unlearned, its
// fraction 0), as src/guide/sampler.rs `build_sampling_rows` and `build_alias_row`.
void build_row(uint i) {
    if (rows_read[i] == 0u) return;  // the same for the whole group
    uint lid = gl_LocalInvocationID.x;
    uint n = push.bins;
    uint class_ = i % NORMAL_CLASSES;
    uint qrow = (i / NORMAL_CLASSES) * n;
    uint row = i * n;
    // Each bin's Q, read from the table once, and cosine, in its column and density slots.
    for (uint b = lid; b < n; b += GROUP) {
        float q = push.pool_largest > 1u ? pooled_q(qrow, b) : q_table[qrow + b];
        staged[b] = uvec2(floatBitsToUint(q), floatBitsToUint(bin_cosine(b, class_)));
    }
    barrier();
    if (lid == 0u) staged_total = row_weights(i);
    barrier();
    float total = staged_total;
    if (!(total > 0.0)) {
        for (uint b = lid; b < n; b += GROUP) sampler_table[row + b] = uvec2(uint(UNLEARNED), 0u);
        barrier();
        return;
    }
    float scale = float(n) / total;
    for (uint b = lid; b < n; b += GROUP) set_weight(b, weight_at(b) * scale);
    barrier();
    if (lid == 0u) alias_pairs(n);
    barrier();
    // What is left is full (up to rounding): each such column keeps its own bin.
    // Then each bin's probability: its threshold, plus what each column aliased
    // to it leaves.
    for (uint b = lid; b < n; b += GROUP) {
        uint c = staged[b].x;
        c = c == uint(UNLEARNED) ? (uint(ALIAS_THRESHOLD_ONE) << 16u) | b : c;
        staged[b].x = c;
        staged_units[b] = c >> 16u;
    }
    barrier();
    for (uint b = lid; b < n; b += GROUP) {
        uint c = staged[b].x;
        uint a = c & 0xffffu;
        if (a != b) atomicAdd(staged_units[a], uint(ALIAS_THRESHOLD_ONE) - (c >> 16u));
    }
    barrier();
    for (uint b = lid; b < n; b += GROUP) {
        sampler_table[row + b] = uvec2(staged[b].x, floatBitsToUint(units_density(staged_units[b])));
    }
    barrier();
}

// src/guide/tree.rs `QTable::split_cell`: the 8 children of `cell` from `first` on
// start from its Q, an eighth of its visits and targets, its fraction's state and
// its rows read; its own rows are no longer read.
void split_cell(uint cell, uint first) {
    uvec4 parent = cell_tree[cell];
    cell_tree[cell].x = first;
    uint n = push.bins;
    for (uint child = first; child < first + 8u; ++child) {
        cell_tree[child] = uvec4(0u, parent.y + 1u, floatBitsToUint(uintBitsToFloat(parent.z) * 0.125), 0u);
        for (uint b = 0u; b < n; ++b) {
            q_table[child * n + b] = q_table[cell * n + b];
            visits[child * n + b] = visits[cell * n + b] / 8u;
        }
        fraction_states[child] = fraction_states[cell];
        for (uint c = 0u; c < NORMAL_CLASSES; ++c) rows_read[child * NORMAL_CLASSES + c] = rows_read[cell * NORMAL_CLASSES + c];
    }
    for (uint c = 0u; c < NORMAL_CLASSES; ++c) rows_read[cell * NORMAL_CLASSES + c] = 0u;
}

// Phase 2, one group of REFINE_GROUP: src/guide/tree.rs `QTable::refine`. The
// cells in use at the start are taken REFINE_GROUP at a time; those that split
// take 8 cells each in cell order (an exclusive scan of the group), as many as
// fit the table.
shared uint refine_scan[REFINE_GROUP];
void refine() {
    uint lid = gl_LocalInvocationID.x;
    uint capacity = push.cells;
    uint used = cell_tree[capacity].x;
    uint end = used;
    float threshold = float(SPLIT_TARGETS_PER_BIN * push.bins);
    for (uint start = 0u; start < end; start += REFINE_GROUP) {
        uint cell = start + lid;
        bool splits = false;
        if (cell < end) {
            uvec4 node = cell_tree[cell];
            splits = node.x == 0u && node.y < GUIDE_TREE_DEPTH && uintBitsToFloat(node.z) >= threshold;
        }
        refine_scan[lid] = splits ? 1u : 0u;
        barrier();
        for (uint offset = 1u; offset < REFINE_GROUP; offset *= 2u) {
            uint v = lid >= offset ? refine_scan[lid - offset] : 0u;
            barrier();
            refine_scan[lid] += v;
            barrier();
        }
        uint total = refine_scan[REFINE_GROUP - 1u];
        uint first = used + 8u * (refine_scan[lid] - (splits ? 1u : 0u));
        if (splits && first + 8u <= capacity) split_cell(cell, first);
        used += 8u * min(total, (capacity - used) / 8u);
        barrier();
    }
    if (lid == 0u) cell_tree[capacity].x = used;
}

// Dispatches are capped at LEARN_MAX_GROUPS, which every device takes, so an
// invocation steps through the work a whole dispatch apart.
void main() {
    uint stride = gl_NumWorkGroups.x * GROUP;
    if (push.phase == 0u) {
        // Every cell is an entry's index too (cells <= entries).
        for (uint i = gl_GlobalInvocationID.x; i < push.entries; i += stride) fold(i);
    } else if (push.phase == 2u) {
        refine();
    } else {
        uint n = push.cells * NORMAL_CLASSES;
        for (uint i = gl_WorkGroupID.x; i < n; i += gl_NumWorkGroups.x) build_row(i);
    }
}
