// The product with a glossy lobe on the GPU: src/guide/product.rs, same
// functions and arithmetic. Needs guide.glsl (bins, Q) and bsdf.glsl (GGX).
#ifndef RLPT_PRODUCT_GLSL
#define RLPT_PRODUCT_GLSL
#include "bsdf.glsl"
#include "guide.glsl"

// src/guide/product.rs `LobeWindow`: rows r0..r1 around the lobe's centre (cos
// theta zm, azimuth phi_m), the cap's radius as its cosine.
struct LobeWindow {
    float zm;
    float phi_m;
    float cos_r;
    uint r0;
    uint r1;
};

// src/guide/product.rs `Product`: a glossy vertex's window and sums.
struct Product {
    LobeWindow window;
    float floor_q;
    float sum_w;
    uint qrow;  // the cell's first entry in q_table (the CPU's ProductVertex::q)
};

// src/guide/product.rs `product_applies`: GGX reflection lobes from
// PRODUCT_MIN_ALPHA up to the cosine lobe's width whose window's cap fits in
// PRODUCT_WINDOW_BINS bins.
bool product_applies(Bsdf b) {
    float r = PRODUCT_RADIUS_PER_ALPHA * b.alpha;
    return (is_kind(b, MAT_GLOSSY) || is_kind(b, MAT_CONDUCTOR)) && b.alpha >= PRODUCT_MIN_ALPHA &&
           4.0 * b.alpha * b.alpha < 1.0 && PI * r * r <= float(PRODUCT_WINDOW_BINS) * (4.0 * PI / float(GUIDE_BINS));
}

// src/guide/product.rs `window_columns`: the window's first column in a bin row
// and how many (modulo the columns).
uvec2 window_columns(LobeWindow w, uint row) {
    uint cols = GUIDE_COLS;
    float top = 1.0 - 2.0 * float(row) / float(GUIDE_ROWS);
    float bottom = 1.0 - 2.0 * float(row + 1u) / float(GUIDE_ROWS);
    float z = clamp(w.zm, bottom, top);
    float den = sqrt(max(1.0 - z * z, 0.0)) * sqrt(max(1.0 - w.zm * w.zm, 0.0));
    float per_radian = float(cols) * (0.5 / PI);
    uint n = cols;
    int c0 = 0;
    if (den > 1e-6) {
        float cos_d = (w.cos_r - z * w.zm) / den;
        if (cos_d > -1.0) {
            float d = acos(min(cos_d, 1.0));
            int first = int(floor((w.phi_m - d) * per_radian));
            int last = int(floor((w.phi_m + d) * per_radian));
            if (uint(last - first + 1) < cols) {
                n = uint(last - first + 1);
                c0 = first;
            }
        }
    }
    if (n > uint(PRODUCT_MAX_BINS)) {
        n = uint(PRODUCT_MAX_BINS);
        c0 = int(floor(w.phi_m * per_radian)) - int(n / 2u);
    }
    // c0 >= -cols here; GLSL's % of a negative number is undefined.
    return uvec2(uint(c0 + 2 * int(cols)) % cols, n);
}

// The bin row of cos(theta) z (bin_index's).
uint window_row(float z) { return min(uint((1.0 - z) * 0.5 * float(GUIDE_ROWS)), GUIDE_ROWS - 1u); }

// src/guide/product.rs `lobe_window`: the bins within PRODUCT_RADIUS_PER_ALPHA
// alpha of the centre m, rows added above and below while PRODUCT_MAX_BINS hold them.
LobeWindow lobe_window(vec3 m, float alpha) {
    LobeWindow w;
    w.zm = clamp(m.z, -1.0, 1.0);
    float theta_m = acos(w.zm);
    float r = min(PRODUCT_RADIUS_PER_ALPHA * alpha, PI);
    w.phi_m = atan(m.y, m.x);
    if (w.phi_m < 0.0) w.phi_m += 2.0 * PI;
    w.cos_r = cos(r);
    uint r_hi = window_row(cos(max(theta_m - r, 0.0)));
    uint r_lo = window_row(cos(min(theta_m + r, PI)));
    uint rm = window_row(w.zm);
    w.r0 = rm;
    w.r1 = rm;
    uint total = window_columns(w, rm).y;
    bool up = rm > r_hi;
    bool down = rm < r_lo;
    while (up || down) {
        if (up) {
            uint n = window_columns(w, w.r0 - 1u).y;
            up = total + n <= uint(PRODUCT_MAX_BINS);
            if (up) {
                total += n;
                w.r0 -= 1u;
                up = w.r0 > r_hi;
            }
        }
        if (down) {
            uint n = window_columns(w, w.r1 + 1u).y;
            down = total + n <= uint(PRODUCT_MAX_BINS);
            if (down) {
                total += n;
                w.r1 += 1u;
                down = w.r1 < r_lo;
            }
        }
    }
    return w;
}

// src/guide/product.rs `window_contains`.
bool window_contains(LobeWindow w, uint b) {
    uint row = b / GUIDE_COLS;
    uint col = b % GUIDE_COLS;
    if (row < w.r0 || row > w.r1) return false;
    uvec2 c = window_columns(w, row);
    return (col + GUIDE_COLS - c.x) % GUIDE_COLS < c.y;
}

// src/guide/product.rs `glossy_lobe`: D(h) G2(wo, wi) in the shading frame, 0 below it.
float glossy_lobe(vec3 wo, vec3 wi, float alpha) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
    return ggx_d(normalize(wo + wi), alpha) * ggx_g2(wo.z, wi.z, alpha);
}

// The lobe at the centre of bin b (src/guide/product.rs `ProductVertex::lobe`).
float product_lobe(mat3 frame, vec3 wo, float alpha, uint b) {
    return glossy_lobe(wo, to_local(frame, bin_sample(b, vec2(0.5))), alpha);
}

// src/guide/product.rs `product_sums`: the window of the vertex's lobe (wo in its
// shading frame) and the sums of its bins' weights (Q_b + floor_q) lobe(c_b),
// floor_q = `exploration` times the lobe-weighted mean Q; Q from qrow, the cell's first entry.
Product product_sums(mat3 frame, vec3 wo, float alpha, uint qrow, float exploration) {
    Product p;
    p.qrow = qrow;
    p.window = lobe_window(to_world(frame, vec3(-wo.x, -wo.y, wo.z)), alpha);
    float sum_ql = 0.0;
    float sum_l = 0.0;
    for (uint row = p.window.r0; row <= p.window.r1; ++row) {
        uvec2 c = window_columns(p.window, row);
        for (uint k = 0u; k < c.y; ++k) {
            uint b = row * GUIDE_COLS + (c.x + k) % GUIDE_COLS;
            float l = product_lobe(frame, wo, alpha, b);
            sum_l += l;
            sum_ql += q_table[qrow + b] * l;
        }
    }
    p.floor_q = sum_l > 0.0 ? exploration * sum_ql / sum_l : 0.0;
    p.sum_w = sum_ql > 0.0 ? sum_ql + p.floor_q * sum_l : 0.0;
    return p;
}

float product_weight(mat3 frame, vec3 wo, float alpha, Product p, uint b) {
    return (q_table[p.qrow + b] + p.floor_q) * product_lobe(frame, wo, alpha, b);
}

// src/guide/product.rs `product_bin`: the bin whose cumulative weight first
// exceeds uc times the sum (the last of positive weight where rounding leaves none).
uint product_bin(mat3 frame, vec3 wo, float alpha, Product p, float uc) {
    float target = uc * p.sum_w;
    float acc = 0.0;
    uint last = 0u;
    for (uint row = p.window.r0; row <= p.window.r1; ++row) {
        uvec2 c = window_columns(p.window, row);
        for (uint k = 0u; k < c.y; ++k) {
            uint b = row * GUIDE_COLS + (c.x + k) % GUIDE_COLS;
            float w = product_weight(frame, wo, alpha, p, b);
            acc += w;
            if (w > 0.0) {
                last = b;
                if (target < acc) return b;
            }
        }
    }
    return last;
}

// src/guide/product.rs `product_pdf`: w_b / (sum_w * solid angle) inside the window, 0 outside.
float product_pdf(mat3 frame, vec3 wo, float alpha, Product p, uint b) {
    if (!(p.sum_w > 0.0) || !window_contains(p.window, b)) return 0.0;
    return product_weight(frame, wo, alpha, p, b) / (p.sum_w * (4.0 * PI / float(GUIDE_BINS)));
}

#endif
