// The pinhole camera's ray through pixel (x, y) at offset u in [0, 1)^2;
// src/camera.rs `camera_ray` is its twin.
#ifndef RLPT_CAMERA_GLSL
#define RLPT_CAMERA_GLSL
#include "scene.glsl"

void camera_ray(uint x, uint y, vec2 u, out vec3 o, out vec3 d) {
    float tan_half = params.cam_forward_tan.w;
    float aspect = params.cam_right_aspect.w;
    float sx = (2.0 * (float(x) + u.x) / float(params.width) - 1.0) * tan_half * aspect;
    float sy = (1.0 - 2.0 * (float(y) + u.y) / float(params.height)) * tan_half;
    d = normalize(params.cam_forward_tan.xyz + sx * params.cam_right_aspect.xyz + sy * params.cam_up.xyz);
    o = params.cam_position_near.xyz + params.cam_position_near.w * d;
}

#endif
