// Warps and frames: src/math/sampling.rs and src/math/mod.rs (Frame).
#ifndef RLPT_SAMPLING_GLSL
#define RLPT_SAMPLING_GLSL

const float PI = 3.14159265358979323846;

// Duff et al. 2017; columns t, b, n.
mat3 make_frame(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    vec3 bb = vec3(b, s + n.y * n.y * a, -n.y);
    return mat3(t, bb, n);
}
vec3 to_local(mat3 f, vec3 v) { return vec3(dot(v, f[0]), dot(v, f[1]), dot(v, f[2])); }
vec3 to_world(mat3 f, vec3 v) { return f[0] * v.x + f[1] * v.y + f[2] * v.z; }

vec2 concentric_disk(vec2 u) {
    float a = 2.0 * u.x - 1.0;
    float b = 2.0 * u.y - 1.0;
    if (a == 0.0 && b == 0.0) return vec2(0.0);
    float r, theta;
    if (abs(a) > abs(b)) { r = a; theta = (PI / 4.0) * (b / a); }
    else { r = b; theta = PI / 2.0 - (PI / 4.0) * (a / b); }
    return r * vec2(cos(theta), sin(theta));
}

vec3 cosine_hemisphere(vec2 u) {
    vec2 d = concentric_disk(u);
    return vec3(d, sqrt(max(0.0, 1.0 - dot(d, d))));
}
float cosine_hemisphere_pdf(float cos_theta) { return max(cos_theta, 0.0) / PI; }

vec3 uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

float mis_weight(float pdf_a, float pdf_b, bool power) {
    if (power) {
        float a = pdf_a * pdf_a;
        float b = pdf_b * pdf_b;
        return a + b > 0.0 ? a / (a + b) : 0.0;
    }
    return pdf_a + pdf_b > 0.0 ? pdf_a / (pdf_a + pdf_b) : 0.0;
}

float max_component(vec3 v) { return max(v.x, max(v.y, v.z)); }

// src/math/mod.rs `mean3`: the scalar that Q learns and learned roulette compares.
float mean3(vec3 v) { return (v.x + v.y + v.z) * (1.0 / 3.0); }

#endif
