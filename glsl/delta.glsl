// Delta lights: distant, point and spot (src/math/delta.rs, the CPU twin;
// docs/correctness.md "Delta lights"). Included by geometry.glsl after LightSample.
#ifndef RLPT_DELTA_GLSL
#define RLPT_DELTA_GLSL

// src/math/delta.rs `spot_falloff`: pbrt-v4's smoothstep from the cone's edge
// (cos_end) to its full-intensity cone (cos_start).
float spot_falloff(float cos_theta, float cos_start, float cos_end) {
    if (cos_theta >= cos_start) return 1.0;
    if (cos_theta <= cos_end) return 0.0;
    float t = (cos_theta - cos_end) / (cos_start - cos_end);
    return t * t * (3.0 - 2.0 * t);
}

// src/math/delta.rs `sample_delta_light`: the one direction to the light from p,
// its radiance factor (L, or I falloff / r^2) and the light's pmf as the pdf;
// the shadow ray ends on the point, or leaves the scene towards a distant light.
bool sample_delta_light(Light light, vec3 p, out LightSample ls) {
    DeltaLight dl = delta_lights[light.index];
    ls.skip = NO_PRIM;
    ls.pdf = light.pmf;
    ls.delta = true;
    if (scene_has_light(LIGHT_DISTANT) && light.kind == LIGHT_DISTANT) {
        ls.wi = dl.position_cos_start.xyz;
        ls.dist = 1.0 / 0.0;
        ls.end = ls.wi;
        ls.le = dl.intensity_cos_end.xyz;
        return ls.pdf > 0.0;
    }
    vec3 v = dl.position_cos_start.xyz - p;
    float d2 = dot(v, v);
    if (!(d2 > 0.0)) return false;
    ls.dist = sqrt(d2);
    ls.wi = v / ls.dist;
    ls.end = dl.position_cos_start.xyz;
    ls.le = dl.intensity_cos_end.xyz / d2;
    if (scene_has_light(LIGHT_SPOT) && light.kind == LIGHT_SPOT)
        ls.le *= spot_falloff(dot(-ls.wi, dl.axis.xyz), dl.position_cos_start.w, dl.intensity_cos_end.w);
    return ls.pdf > 0.0;
}

#endif
