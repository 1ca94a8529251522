// The GPU/host interface: constants, bindings and structs shared with Rust.
// build.rs turns every `#define NAME <integer>` below into a Rust constant
// (`rlpt::shared::NAME`); the Rust mirrors of the structs live in
// src/prepared.rs and a probe kernel checks their layout (tests/gpu_probes.rs
// `struct_layout_matches_the_rust_mirrors`).
#ifndef RLPT_COMMON_GLSL
#define RLPT_COMMON_GLSL

// Workgroup: x,y index the 64 samples of one pixel, z the pixels of the group.
#define SAMPLES_X 8
#define SAMPLES_Y 8
#define SAMPLES_PER_FRAME 64
// Pixels per workgroup, local_size_z, the specialization constant
// SPEC_PIXELS_PER_GROUP (src/render `pixels_per_group`): PIXELS_PER_GROUP for the
// recording guided kernel of scenes with mirror, glass or glossy materials,
// PIXELS_PER_GROUP_SMALL for every other kernel. Smaller groups free an SM's
// slots sooner after their longest path, but the recording kernel with glass and
// GGX code was slower with them (docs/ARCHITECTURE.md).
#define PIXELS_PER_GROUP 4
#define PIXELS_PER_GROUP_SMALL 2
// Largest subgroup size the reduction handles with shuffles alone; smaller
// subgroups combine their partial sums through shared memory.
#define MAX_REDUCE_LANES 64

// Material kinds (src/scene/mod.rs MaterialKind has the same values).
#define MAT_DIFFUSE 0
#define MAT_SPECULAR 1
#define MAT_GLOSSY 2
#define MAT_DIELECTRIC 3
#define MAT_EMISSIVE 4
// GGX conductor with the complex Fresnel of eta + i k (a mirror at roughness 0).
#define MAT_CONDUCTOR 5
// GGX dielectric, reflection and transmission (the smooth one is MAT_DIELECTRIC).
#define MAT_ROUGH_DIELECTRIC 6
// A GGX dielectric coat over a Lambertian base (src/math/bsdf.rs `coated_eval_pdf`),
// or over a GGX conductor: Material.k.w its roughness (0 for the Lambertian base),
// eta and k its index; a roughness texture then scales the base's roughness.
// A coat of roughness 0 is smooth (a delta lobe).
#define MAT_COATED 7
// A mix of two materials (pbrt's `mix`), resolved at each hit to one of them
// (pathtrace.comp `resolve_mix`): Material.albedo_roughness.x its amount, the
// chance of the second (times its albedo texture's red where it has one), k.xy
// the two materials' indices (as floats, exact below 2^24). A mix may name mixes,
// at most MIX_MAX_DEPTH levels in all. Its emission is the surface's own.
#define MAT_MIX 8
#define MIX_MAX_DEPTH 4

// Light kinds and the "not a light" marker.
#define LIGHT_SPHERE 0
#define LIGHT_QUAD 1
#define LIGHT_TRIANGLE 2
// The image environment (src/math/envmap.rs): one light, the last of lights[],
// whose index is 0; a kernel without it has none of its code (SCENE_KINDS).
#define LIGHT_ENV 3
// Delta lights (delta.glsl, src/math/delta.rs): a direction with a radiance, a
// point, a point in a cone; Light.index into delta_lights[]. A BSDF-sampled ray
// never meets one, so only next-event estimation reaches them, weight 1.
#define LIGHT_DISTANT 4
#define LIGHT_POINT 5
#define LIGHT_SPOT 6
#define NO_LIGHT 4294967295
// A face of the room (src/layout.rs `Room`) that no quad covers.
#define NO_QUAD 4294967295
// A primitive reference (the BVH's leaves, prim_refs[]; src/math/bvh.rs):
// its kind in the top two bits, its index in spheres, quads or triangles below.
#define PRIM_TRIANGLE 0
#define PRIM_SPHERE 1
#define PRIM_QUAD 2
#define PRIM_KIND_SHIFT 30
#define PRIM_INDEX_MASK 1073741823
// The shadow test's "skip no primitive" as a reference (no kind has it).
#define NO_PRIM 4294967295
// Triangle.normals of a flat triangle: it has no shading normals.
#define NO_NORMALS 4294967295
// BvhNode child words: bit 31 set for a leaf, whose first reference in
// prim_refs is the rest and whose count is the child's count word; BVH_EMPTY for
// an unused slot; else the index of an interior node. The walk pushes up to
// three children per node: its stack holds BVH_STACK entries, at least 3 per
// level of the deepest tree the builder makes (src/math/bvh/build.rs MAX_DEPTH).
#define BVH_LEAF 2147483648
#define BVH_EMPTY 4294967295
#define BVH_STACK 168
// RenderParams.scene_kinds: bit (1 << MAT_*) for each material kind of the scene,
// bit (1 << (SCENE_KIND_LIGHT_SHIFT + LIGHT_*)) for each kind of light, and bit
// (1 << SCENE_KIND_GUIDED_GLOSSY) where a glossy material's lobe is wide enough
// to take guided directions (src/guide/sampler.rs `glossy_share`).
#define SCENE_KIND_LIGHT_SHIFT 8
#define SCENE_KIND_GUIDED_GLOSSY 15
// Bit (1 << SCENE_KIND_PROCEDURAL) where a material reads a procedural texture,
// (1 << SCENE_KIND_REFLECTANCE_CONDUCTOR) where a conductor's index comes from a
// reflectance texture (Material.eta.w 1): kernels without them skip that code.
#define SCENE_KIND_PROCEDURAL 16
#define SCENE_KIND_REFLECTANCE_CONDUCTOR 17
// Bit (1 << SCENE_KIND_MIX) where a material is a mix (MAT_MIX, which has no bit
// of its own kind): kernels without one have no `resolve_mix` code.
#define SCENE_KIND_MIX 18
// Bit (1 << SCENE_KIND_COATED_CONDUCTOR) where a coated material has a conductor
// base, (1 << SCENE_KIND_SMOOTH_COAT) where one has a smooth coat (roughness 0):
// kernels without them have none of that code.
#define SCENE_KIND_COATED_CONDUCTOR 19
#define SCENE_KIND_SMOOTH_COAT 20

// RenderParams.flags bits.
#define FLAG_NEE 1
#define FLAG_RUSSIAN_ROULETTE 2
// MIS heuristic: power (beta = 2) when set, balance otherwise.
#define FLAG_POWER_HEURISTIC 4
// Each cell learns its guided fraction (src/guide/fraction.rs `FractionState`).
#define FLAG_LEARN_FRACTION 8
// The ray into a path's last vertex is traced in full only where its line meets
// a light: the environment is black, so nothing else could add to the image
// (src/prepared/analysis.rs `last_ray_to_lights`: set where, besides, every light has a
// specialized slot and the scene has no roulette).
#define FLAG_LAST_RAY_TO_LIGHTS 16
// The frame counters are kept: the paths that carried nothing (one sum per
// subgroup after the paths) with FLAG_COUNTERS, which `render --stats` sets; the
// rays traced and the rays the subgroups' longest paths set (counted inside the
// path loop) with FLAG_COUNT_RAYS too, which `rlpt bench` sets. Without them the
// kernel has none of their code (src/options.rs `Counters`).
#define FLAG_COUNTERS 32
#define FLAG_COUNT_RAYS 64
// Q-learning targets count the emission a ray meets with its MIS weight and add
// the light sample's estimate at the vertex it meets, where NEE is on
// (src/guide/mod.rs `QTargets::Mis`); without the bit, the emission in full.
#define FLAG_MIS_TARGETS 128
// The paths' random numbers are Owen-scrambled Sobol points (sampler.glsl);
// without the bit, independent PCG hashes.
#define FLAG_SOBOL 256
// Each frame sums its pixels' relative variance into COUNTER_FRAME_VARIANCE's
// slots (pathtrace.comp `add_frame_variance`), for the guided renders' choice
// between guided and unguided frames (src/guide/race.rs).
#define FLAG_FRAME_VARIANCE 512
// The guiding grid's cells subdivide where paths record many targets
// (src/guide/tree.rs, guide.glsl `cell_index`, learn.comp `refine`).
#define FLAG_ADAPTIVE_GRID 1024
// Guided directions at glossy vertices are drawn from the product of Q and the
// lobe (product.glsl, src/guide/product.rs); set only where a material's lobe
// takes it and `--glossy-product on`.
#define FLAG_GLOSSY_PRODUCT 2048

// The samplers' dimension layout (sampler.glsl, docs/sampling.md): the camera's
// jitter takes dimensions 0 and 1; the vertex of depth d takes SAMPLER_BOUNCE_DIMS
// from SAMPLER_BOUNCE_BASE + d * SAMPLER_BOUNCE_DIMS, slot SAMPLE_* of them, used
// or not, so that a dimension means the same in every path. A 2D sample at
// dimension k takes k and k + 1.
#define SAMPLE_CAMERA 0
#define SAMPLER_BOUNCE_BASE 4
#define SAMPLER_BOUNCE_DIMS 8
// The light sample's point (2D) and light choice, and the roulette that decides
// whether the path goes on to this vertex.
#define SAMPLE_LIGHT 0
#define SAMPLE_LIGHT_SELECT 2
#define SAMPLE_ROULETTE 3
// The continuation: direction (2D), lobe or guided bin, guided-or-BSDF choice.
#define SAMPLE_DIRECTION 4
#define SAMPLE_LOBE 6
#define SAMPLE_MIX 7

// Profiling (`rlpt bench --ablate`): parts of guiding left out of a frame.
#define ABLATE_RECORD 1
#define ABLATE_GUIDED_SAMPLING 2

// Descriptor bindings of set 0 (pathtrace.comp).
#define BINDING_PARAMS 0
#define BINDING_MATERIALS 1
#define BINDING_SPHERES 2
#define BINDING_QUADS 3
#define BINDING_LIGHTS 4
#define BINDING_ACCUM 5
// Per pixel the Kahan compensation of the accumulation's sum (pathtrace.comp
// `accumulate`, `kahan_add`), kept on the device alone.
#define BINDING_ACCUM_CARRY 28
// Learned guiding (pathtrace.comp): the table, the targets' sums since it last learned, the sampling rows (alias tables).
#define BINDING_Q 6
#define BINDING_FRAME_SUMS 7
#define BINDING_FRAME_COUNTS 8
#define BINDING_SAMPLER 9
// Per-frame counters (pathtrace.comp): [0] paths that carried zero radiance, [1] path segments.
#define BINDING_COUNTERS 10
// The first primitives of the scene, as the hit tests read them (geometry.glsl):
// a uniform buffer of CONST_SPHERES spheres and CONST_QUADS quads.
#define BINDING_SCENE_CONSTANTS 11
// Learned guiding (pathtrace.comp): the guided fraction of each sampling row,
// 0 where the row is unlearned (src/guide/table.rs `QTable::fractions`).
#define BINDING_FRACTIONS 12
// Learned guiding: per sampling row, 1 once a recording path's guided vertex
// has read it (src/guide/table.rs `QTable::rows_read`); learn.comp rebuilds those alone.
#define BINDING_ROWS_READ 13
// Triangle meshes and the BVH (geometry.glsl, bvh.glsl): the triangles, the
// shading normals of the smooth ones, the nodes, and the leaves' primitive refs.
#define BINDING_TRIANGLES 14
#define BINDING_TRIANGLE_NORMALS 15
#define BINDING_BVH_NODES 16
#define BINDING_PRIM_REFS 17
#define CONST_SPHERES 64
#define CONST_QUADS 64
// Specialization constants of pathtrace.comp (their constant_id): what a render
// fixes from start to end, so that the driver compiles the kernel for it (loops
// of known length, arithmetic by known numbers, switched-off features left out).
// src/render/pipelines.rs `specialization` sets them.
#define SPEC_NUM_SPHERES 0
#define SPEC_NUM_QUADS 1
#define SPEC_GUIDE_ROWS 2
#define SPEC_GUIDE_COLS 3
#define SPEC_GUIDE_RES_X 4
#define SPEC_GUIDE_RES_Y 5
#define SPEC_GUIDE_RES_Z 6
#define SPEC_FLAGS 7
#define SPEC_MAX_BOUNCES 8
// 1: the guided kernel records its paths' Q-learning targets; 0: it has no
// recording code at all, and a frame's rows that do not record go to it: code
// present in a kernel costs time even where it never runs (docs/guiding.md).
#define SPEC_RECORDING 9
#define SPEC_GUIDE_VERTICES 10
#define SPEC_RECORD_VERTICES 11
#define SPEC_OCCLUDING_QUADS 12
// params.scene_kinds: the kernel leaves out the code of the material and light
// kinds the scene lacks (src/prepared/analysis.rs `scene_kinds`).
#define SPEC_SCENE_KINDS 13
// params.num_lights: a scene with one light skips choosing one (geometry.glsl).
#define SPEC_NUM_LIGHTS 14
// The workgroup's pixels (local_size_z): PIXELS_PER_GROUP or PIXELS_PER_GROUP_SMALL.
#define SPEC_PIXELS_PER_GROUP 15
// The hit-test data of the first SPEC_QUADS quads and SPEC_SPHERES spheres, one
// float per constant (geometry.glsl; src/prepared/mod.rs `geometry_specialization`):
// quad i from SPEC_QUAD_BASE + SPEC_QUAD_FLOATS * i (normal and plane offset,
// origin, dual_u, dual_v), sphere i from SPEC_SPHERE_BASE + SPEC_SPHERE_FLOATS * i
// (centre, anchor and radius, axis). The driver sees the numbers: the zeros of an
// axis-aligned quad's normal and edges take their arithmetic with them.
#define SPEC_QUAD_BASE 16
#define SPEC_QUAD_FLOATS 13
#define SPEC_QUADS 16
#define SPEC_SPHERE_BASE 224
#define SPEC_SPHERE_FLOATS 10
#define SPEC_SPHERES 16
// Bit i: the sphere in slot i is compact (src/layout.rs `GpuSphere::compact`).
// The host works it out, as the driver did not fold the same comparison of the
// slot's float constants: the branch on it stayed, with both sides' code.
#define SPEC_COMPACT_SPHERES 384
// Bit i: the quad (sphere) in slot i is a light, whose test `meets_light` runs
// (geometry.glsl; src/prepared/mod.rs `geometry_specialization`).
#define SPEC_LIGHT_QUADS 385
#define SPEC_LIGHT_SPHERES 386
// The room (geometry.glsl `room_hit`; src/layout.rs `Room`): how many of
// its faces have a quad (the scene's last quads, which the closest-hit walk
// leaves to room_hit), its box (6 floats: min, then max), and per face
// 2 * axis + side the index of its quad, NO_QUAD where the face is open; and
// whether a ray may meet a wall from outside (the camera's may: `Room::entering`).
#define SPEC_ROOM_QUADS 387
#define SPEC_ROOM_BOUNDS 388
#define SPEC_ROOM_FACES 394
#define SPEC_ROOM_ENTERING 400
// 1: every ray walks the BVH over all primitives (scenes with triangles, or
// many spheres and quads: src/prepared `uses_bvh`); 0: the specialized walk.
#define SPEC_BVH 401
// 1: some triangle has shading normals (Triangle.normals != NO_NORMALS).
#define SPEC_SMOOTH 402
// 1: some material has a texture: hits carry UVs and materials read textures
// (texture.glsl); 0: the kernel has none of that code.
#define SPEC_TEXTURES 403
#define NUM_SPEC_CONSTANTS 404
// Frame counters (pathtrace.comp): the paths without radiance (one word, at most
// 64 per pixel); the rays traced and the subgroups' rays below (64-bit pairs, low
// word first: glsl/counters.glsl).
#define COUNTER_ZERO_PATHS 0
#define COUNTER_SEGMENTS 1
// Over the subgroups that trace paths: the rays of the subgroup's longest path
// times its lanes' pixels' share of the subgroup (lanes / min(subgroup size, 64));
// times min(subgroup size, 64) on the host, the rays the subgroups would trace if
// every lane's path were as long as its subgroup's longest (src/render/mod.rs).
#define COUNTER_SUBGROUP_SEGMENTS 3
// FRAME_VARIANCE_SLOTS float sums of the pixels' relative variance (each pixel's
// term clamped to 65535), added by atomics that return nothing, so that no pixel
// waits on one: the pixels spread over the slots so that few atomics meet on one
// word, and the slots FRAME_VARIANCE_STRIDE words apart, one to a 128-byte line,
// so that their atomics do not queue on a few lines of the cache.
#define COUNTER_FRAME_VARIANCE 5
#define FRAME_VARIANCE_SLOTS 64
#define FRAME_VARIANCE_STRIDE 32
#define FRAME_VARIANCE_MAX 65535.0
#define NUM_COUNTERS 2053
// learn.comp: invocations per workgroup of the fold (phase 0), and of the rows'
// rebuild (phase 1), whose group builds one row at a time in shared memory
// (src/render/learning.rs `rebuild_shared_bytes`).
#define LEARN_FOLD_GROUP 16
#define LEARN_ROW_GROUP 64
// learn.comp's dispatches: at most this many groups (every Vulkan device's
// maxComputeWorkGroupCount[0] is at least this), each invocation stepping
// through the work a dispatch apart.
#define LEARN_MAX_GROUPS 65535
// learn.comp's specialization constants (their constant_id): its invocations
// per workgroup and the words of its shared arrays (a row's bins).
#define SPEC_LEARN_GROUP 0
#define SPEC_LEARN_STAGE_WORDS 1
// Guiding: sampling distributions per cell, one per class of surface orientation
// (src/guide/bins.rs `normal_class`).
#define NORMAL_CLASSES 6
// Learned Russian roulette (src/guide/roulette.rs `survival_probability`): a path
// survives with probability RR_WINDOW * (expected contribution) / (pixel
// estimate), at least RR_MIN_PERCENT / 100 and at most 1.
#define RR_WINDOW 4
#define RR_MIN_PERCENT 25
// Glossy lobes whose share of the guided fraction (4 alpha^2) is below
// 1 / GLOSSY_SHARE_MIN_INV take none (src/guide/sampler.rs `glossy_share`).
#define GLOSSY_SHARE_MIN_INV 16
// The product with a glossy lobe (src/guide/product.rs): a window of at most
// PRODUCT_MAX_BINS bins within PRODUCT_RADIUS_PER_ALPHA * alpha radians of the
// lobe's centre, for lobes of alpha at least PRODUCT_MIN_ALPHA whose cap fits
// in PRODUCT_WINDOW_BINS bins.
#define PRODUCT_MAX_BINS 64
#define PRODUCT_WINDOW_BINS 48
#define PRODUCT_RADIUS_PER_ALPHA 4.0
#define PRODUCT_MIN_ALPHA 0.01
// Learned roulette starts once the table has learned from this many frames (and
// the pixel has an estimate); plain throughput roulette before
// (src/guide/roulette.rs `roulette_estimate`): a table of one frame is too noisy, and
// roulette by it makes fireflies (docs/guiding.md, "Learned Russian roulette").
#define LEARNED_RR_FRAMES 4
// Learned guided fraction (src/guide/fraction.rs `FractionState`): each cell's
// fraction is sigmoid(theta), theta moved by Adam (step FRACTION_RATE, decay
// rates FRACTION_BETA1, FRACTION_BETA2) down the gradient of the KL divergence
// between the normalised integrand and the mixture, and kept within
// [FRACTION_MIN, 1 - FRACTION_MIN].
#define FRACTION_RATE 0.1
#define FRACTION_BETA1 0.9
#define FRACTION_BETA2 0.999
#define FRACTION_MIN 0.1
// A cell uses its table as far as it has earned it: its rows' fraction is the
// learned one times n / (n + FRACTION_EVIDENCE_PER_BIN * bins), n the targets
// its entries have taken (src/guide/fraction.rs `evidence_weight`).
#define FRACTION_EVIDENCE_PER_BIN 16
// Adaptive directions (src/guide/sampler.rs `pooled_q`): a bin's sampling weight
// takes the Q of the smallest block of 1, 2x2 or 4x4 bins around it whose
// entries have taken BIN_POOL_TARGETS targets a bin, the largest where none has.
#define BIN_POOL_TARGETS 16
// The adaptive grid (src/guide/tree.rs): per cell a CellNode (first child, 0 for
// a leaf; depth; the targets its entries had taken at the last rebuild of its
// rows, as float bits; unused), then one word: the cells in use. A leaf splits
// into 8 children when those targets reach SPLIT_TARGETS_PER_BIN * bins and its
// depth is below GUIDE_TREE_DEPTH, while the table has room for them.
#define BINDING_GUIDE_TREE 26
#define GUIDE_TREE_DEPTH 3
#define SPLIT_TARGETS_PER_BIN 128
// learn.comp's refine phase: one workgroup of this many invocations.
#define REFINE_GROUP 64
// Which paths hand their Q-learning targets to the table (src/guide/record.rs
// `RecordSchedule`): in the first RECORD_FIRST_FRAMES frames all of them, or one row
// in a first stride over large images, then all of them in the first frame of each
// cycle of a stride's frames and none in its others. The stride starts at
// RECORD_ROW_STRIDE and doubles, up to RECORD_MAX_STRIDE, as the table fills.
#define RECORD_FIRST_FRAMES 8
#define RECORD_ROW_STRIDE 8
#define RECORD_MAX_STRIDE 32
// Which pixel rows a dispatch of pathtrace.comp traces (push constant `rows`:
// mode | phase << 8 | stride << 16; src/render/dispatch.rs `frame_dispatches`): all
// of them; those y with y % stride == phase (workgroup row g traces
// y = g * stride + phase); or all the others.
#define ROWS_ALL 0
#define ROWS_PHASE 1
#define ROWS_NOT_PHASE 2
// raycast.comp (`rlpt bench --rays`): invocations per group, its modes, and
// its two buffers' bindings (after the scene's).
#define RAYCAST_GROUP 64
#define RAYCAST_CAMERA 0
#define RAYCAST_BOUNCE 1
#define RAYCAST_SHADOW 2
#define BINDING_RAYCAST_HITS 18
#define BINDING_RAYCAST_COUNT 19
// The image environment (envmap.glsl `env_sample`, `env_lookup`): per texel
// vec4(scaled rgb, density over the image's unit square); the cdfs over rows,
// then per row over its texels. Empty for the uniform sky.
#define BINDING_ENV_TEXELS 20
#define BINDING_ENV_CDF 21
// Image textures (texture.glsl; src/math/texture.rs; docs/ARCHITECTURE.md,
// "Textures"): per texture a TextureHeader; every texture's texels in one array
// of words; per triangle its vertices' UVs (TriangleUvs); per sphere its UV
// frame (SphereUv). Empty in a scene without textures, whose kernel has no
// texture code (SPEC_TEXTURES).
#define BINDING_TEXTURES 22
#define BINDING_TEXELS 23
#define BINDING_TRIANGLE_UVS 24
#define BINDING_SPHERE_UVS 25
// The delta lights (DeltaLight; delta.glsl), indexed by Light.index; empty in a
// scene without them.
#define BINDING_DELTA_LIGHTS 27
// TextureHeader.format: one word per texel, RGBA 8 bits each (red the low
// byte), linear or sRGB-encoded (decoded on lookup); or two words per texel,
// RGBA as four halves (packHalf2x16 of rg, then of ba), linear.
#define TEXEL_RGBA8 0
#define TEXEL_RGBA8_SRGB 1
#define TEXEL_RGBA16F 2
// TextureHeader.format of a procedural colour texture (texture.glsl
// `colour_texture`; src/scene/procedural.rs): its operands at texels[offset]:
// three operand headers (1 + index, or NO_TEXTURE), then their three constant
// colours (float bits); a checkerboard's st transform in `transform`.
#define TEXTURE_CHECKER 3
#define TEXTURE_SCALE 4
#define TEXTURE_MIX 5
// Material.albedo_texture and roughness_texture: 0 for none, else 1 + the
// index of its TextureHeader. A roughness from a texture is kept within
// [TEXTURE_MIN_ROUGHNESS, 1]: the smallest roughness GGX is tested at
// (src/scene/mesh/mod.rs `SPECULAR_BELOW_ROUGHNESS`).
#define NO_TEXTURE 0
#define TEXTURE_MIN_ROUGHNESS 0.05
// tonemap.comp (the viewer's display pass): 16x16 pixels per workgroup.
#define TONEMAP_GROUP_X 16
#define TONEMAP_GROUP_Y 16
#define NO_KEY 4294967295
// Guided sampling rows are alias tables (src/guide/sampler.rs `AliasBin`): a column's
// 16-bit threshold over ALIAS_THRESHOLD_ONE is the chance it keeps its own bin;
// UNLEARNED in a row's columns marks a row with nothing to sample.
#define ALIAS_THRESHOLD_ONE 65535
#define UNLEARNED 4294967295

struct Material {
    vec4 albedo_roughness;   // xyz albedo, w GGX roughness
    vec4 emission_ior;       // xyz emitted radiance, w index of refraction
    vec4 eta;                // xyz a conductor's eta (real part of its index); w 1 for a reflectance conductor
    vec4 k;                  // xyz a conductor's k (imaginary part); xy a mix's two materials; w a coated one's conductor base roughness (0: Lambertian)
    uint kind;               // MAT_*
    uint two_sided;          // emission leaves both sides
    uint albedo_texture;     // NO_TEXTURE, or 1 + the texture whose RGB multiplies the albedo
    uint roughness_texture;  // NO_TEXTURE, or 1 + the texture whose red times w is the roughness
};

struct Sphere {
    vec4 center_radius;      // xyz center, w radius
    vec4 anchor_radius;      // xyz the point nearest the world origin, w radius
    vec4 axis;               // xyz unit outward normal at the anchor; w 1 if compact, else 0
    uint material;
    uint light;              // index into lights, or NO_LIGHT
    uint pad0;
    uint pad1;
};

struct Quad {
    vec4 origin;             // xyz origin, w area
    vec4 edge_u;             // xyz edge_u, w the scale of its points for hit offsets
    vec4 edge_v;             // xyz edge_v
    vec4 normal;             // xyz unit normal (edge_u x edge_v), w plane offset dot(normal, origin)
    vec4 dual_u;             // xyz: dot(p - origin, dual_u) = s
    vec4 dual_v;             // xyz: dot(p - origin, dual_v) = t
    uint material;
    uint light;              // index into lights, or NO_LIGHT
    uint pad0;
    uint pad1;
};

// A triangle in world space, front side counter-clockwise (v1 - v0) x (v2 - v0).
struct Triangle {
    vec3 v0;
    uint material;
    vec3 v1;
    uint light;              // index into lights, or NO_LIGHT
    vec3 v2;
    uint normals;            // index into triangle_normals, or NO_NORMALS (flat)
};

// The unit shading normals at a smooth triangle's vertices (xyz; w unused).
struct TriangleNormals {
    vec4 n0;
    vec4 n1;
    vec4 n2;
};

// A node of the 4-wide BVH (src/layout.rs `GpuBvhNode`): its four children's
// boxes as vec4s of each coordinate, so that one read tests all four, and their
// words. child: BVH_LEAF | first ref for a leaf (count refs), BVH_EMPTY for an
// unused slot (its box inverted: no ray enters it), else a node index (count 0).
struct BvhNode {
    vec4 lo_x;
    vec4 lo_y;
    vec4 lo_z;
    vec4 hi_x;
    vec4 hi_y;
    vec4 hi_z;
    uvec4 child;
    uvec4 count;
};

// A texture's texels in texels[] from `offset` (words), rows from the top of
// the image, and the texture's UV transform: st = uv * transform.xy + transform.zw.
struct TextureHeader {
    uint offset;
    uint width;
    uint height;
    uint format;             // TEXEL_*
    vec4 transform;
};

// A sphere's UV frame (texture.glsl `sphere_uv`; src/scene/mod.rs `SphereUv`):
// xyz the rows of its world-to-object matrix; w phi_max, theta_min, theta_max.
struct SphereUv {
    vec4 x;
    vec4 y;
    vec4 z;
};

// The UVs of a triangle's three vertices (texture.glsl `triangle_uv`).
struct TriangleUvs {
    vec2 uv0;
    vec2 uv1;
    vec2 uv2;
};

struct Light {
    uint kind;               // LIGHT_*
    uint index;              // into spheres, quads, triangles or delta_lights
    float pmf;               // probability of choosing this light
    float cdf;               // sum of pmf up to and including this light
};

// src/layout.rs `GpuDeltaLight`: a distant, point or spot light (delta.glsl).
struct DeltaLight {
    vec4 position_cos_start; // xyz: the point, or the unit direction towards a distant light; w: a spot's cos of its full-intensity cone
    vec4 intensity_cos_end;  // xyz: intensity I (point, spot) or radiance L (distant); w: a spot's cos of its cone's edge
    vec4 axis;               // xyz: a spot's unit axis (the way it shines)
};

struct RenderParams {
    vec4 cam_position_near;  // xyz eye, w near distance
    vec4 cam_forward_tan;    // xyz unit forward, w tan(vfov / 2)
    vec4 cam_right_aspect;   // xyz unit right, w width / height
    vec4 cam_up;             // xyz unit up (orthogonal to forward)
    vec4 environment;        // xyz uniform sky radiance
    uint width;
    uint height;
    uint max_bounces;
    uint rr_depth;           // Russian roulette after this many bounces (FLAG_RUSSIAN_ROULETTE)
    uint num_spheres;
    uint num_quads;
    uint num_lights;
    uint flags;              // FLAG_*
    uint seed;
    uint guide_bins;         // rows * cols; 0 = guiding off
    uint guide_rows;
    uint guide_cols;
    vec4 guide_min;          // xyz grid minimum, w guided fraction (fixed, or the cells' start; the kernel reads row_fractions)
    vec4 guide_inv_cell;     // xyz cells per unit length, w solid angle of a bin
    uint guide_res_x;
    uint guide_res_y;
    uint guide_res_z;
    uint guide_cells;
    float guide_floor;       // exploration floor of the guided distribution
    uint guide_vertices;     // guided sampling at a path's first this many vertices
    uint occluding_quads;    // shadow rays test the first this many quads (src/prepared/analysis.rs `occluding_order`)
    uint scene_kinds;        // SCENE_KIND_* bits: the material and light kinds the scene has
    uint num_triangles;
    uint bvh_nodes;          // nodes of the BVH; 0 where the kernel walks the primitives itself
    uint env_width;          // the image environment's texels across and down; 0 for the uniform sky
    uint env_height;
    vec4 env_frame[3];       // rows of the rotation from world directions to the image environment's frame
};

// The material and light kinds (SCENE_KIND_* bits) the including kernel is
// compiled for: all of them, unless it is specialized to a scene
// (pathtrace.comp), when the code of kinds the scene lacks is left out.
#ifdef RLPT_SPECIALIZED
layout(constant_id = SPEC_SCENE_KINDS) const uint SCENE_KINDS = 0xffffffffu;
#else
const uint SCENE_KINDS = 0xffffffffu;
#endif
// Whether the scene may have a material of kind MAT_*.
bool scene_has_material(uint kind) { return (SCENE_KINDS & (1u << kind)) != 0u; }
// Whether the scene may have a light of kind LIGHT_*.
bool scene_has_light(uint kind) { return (SCENE_KINDS & (1u << (uint(SCENE_KIND_LIGHT_SHIFT) + kind))) != 0u; }
// Whether the scene may have a mix (MAT_MIX), whose hits resolve to one of its materials.
const bool SCENE_MIX = (SCENE_KINDS & (1u << SCENE_KIND_MIX)) != 0u;
// Whether the scene may have a coated material over a conductor, or with a smooth coat.
// Whether the scene has a delta light (LIGHT_DISTANT, LIGHT_POINT or LIGHT_SPOT).
const bool SCENE_DELTA = (SCENE_KINDS & (7u << (uint(SCENE_KIND_LIGHT_SHIFT) + uint(LIGHT_DISTANT)))) != 0u;
const bool SCENE_COATED_CONDUCTOR = (SCENE_KINDS & (1u << SCENE_KIND_COATED_CONDUCTOR)) != 0u;
const bool SCENE_SMOOTH_COAT = (SCENE_KINDS & (1u << SCENE_KIND_SMOOTH_COAT)) != 0u;

#endif
