// Scene buffers of set 0, shared by the kernels that trace rays.
#ifndef RLPT_SCENE_GLSL
#define RLPT_SCENE_GLSL
#include "common.glsl"

layout(std140, set = 0, binding = BINDING_PARAMS) uniform ParamsBlock { RenderParams params; };
layout(std430, set = 0, binding = BINDING_MATERIALS) readonly buffer Materials { Material materials[]; };
layout(std430, set = 0, binding = BINDING_SPHERES) readonly buffer Spheres { Sphere spheres[]; };
layout(std430, set = 0, binding = BINDING_QUADS) readonly buffer Quads { Quad quads[]; };
layout(std430, set = 0, binding = BINDING_LIGHTS) readonly buffer Lights { Light lights[]; };
layout(std430, set = 0, binding = BINDING_TRIANGLES) readonly buffer Triangles { Triangle triangles[]; };
layout(std430, set = 0, binding = BINDING_TRIANGLE_NORMALS) readonly buffer TriangleNormalsBuf { TriangleNormals triangle_normals[]; };
layout(std430, set = 0, binding = BINDING_BVH_NODES) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, set = 0, binding = BINDING_PRIM_REFS) readonly buffer PrimRefs { uint prim_refs[]; };
layout(std430, set = 0, binding = BINDING_ENV_TEXELS) readonly buffer EnvTexels { vec4 env_texels[]; };
layout(std430, set = 0, binding = BINDING_ENV_CDF) readonly buffer EnvCdf { float env_cdf[]; };
layout(std430, set = 0, binding = BINDING_DELTA_LIGHTS) readonly buffer DeltaLights { DeltaLight delta_lights[]; };

#endif
