//! The `#[repr(C)]` mirrors of the structs in `glsl/common.glsl` (std430 layout;
//! sizes asserted here, field offsets checked on the device by
//! `tests/gpu_probes.rs` `struct_layout_matches_the_rust_mirrors`), the limits
//! every layer checks against, and [`SceneArrays`], the scene flattened into the
//! arrays both renderers trace. It imports nothing of rlpt but the constants of
//! `common.glsl` (`crate::shared`): every other module may build on it.

use crate::shared;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

pub(crate) fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    pub albedo_roughness: [f32; 4],
    pub emission_ior: [f32; 4],
    /// xyz: a conductor's eta, the real part of its complex index per channel.
    pub eta: [f32; 4],
    /// xyz: a conductor's k, the imaginary part.
    pub k: [f32; 4],
    pub kind: u32,
    pub two_sided: u32,
    /// `shared::NO_TEXTURE`, or 1 + the index in [`SceneArrays::textures`] of the
    /// texture whose RGB multiplies the albedo.
    pub albedo_texture: u32,
    /// `shared::NO_TEXTURE`, or 1 + the index of the texture whose red channel
    /// times `albedo_roughness[3]` is the roughness.
    pub roughness_texture: u32,
}

/// A texture's place in [`SceneArrays::texels`] and its UV transform
/// (`glsl/common.glsl` `TextureHeader`; `crate::math::texture` reads it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuTexture {
    /// The first word of its texels; rows from the image's top.
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    /// `shared::TEXEL_*`.
    pub format: u32,
    /// st = uv * (x, y) + (z, w).
    pub transform: [f32; 4],
}

/// A sphere's texture-coordinate frame (`SphereUv`, `crate::scene::SphereUv`):
/// xyz the rows of its world-to-object matrix; w phi_max, theta_min, theta_max.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuSphereUv {
    pub x: [f32; 4],
    pub y: [f32; 4],
    pub z: [f32; 4],
}

/// The UVs of a triangle's vertices (`TriangleUvs`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuTriangleUvs {
    pub uv: [[f32; 2]; 3],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuSphere {
    pub center_radius: [f32; 4],
    /// xyz: the anchor, the point of the sphere nearest the world origin; w: the radius again.
    pub anchor_radius: [f32; 4],
    /// xyz: the unit outward normal at the anchor (the centre is anchor - radius * axis);
    /// w: 1 for a compact sphere ([`GpuSphere::compact`]), else 0.
    pub axis: [f32; 4],
    pub material: u32,
    pub light: u32,
    pub pad: [u32; 2],
}

impl GpuSphere {
    /// A sphere with its intersection frame: the anchor and axis are worked out in
    /// f64 from the f32 centre and radius, so that they describe the same surface
    /// to within f32 rounding near the anchor (see `math::geometry::intersect_sphere`).
    pub fn new(center: Vec3, radius: f32, material: u32, light: u32) -> GpuSphere {
        let c = center.as_dvec3();
        let len = c.length();
        // The centre at the origin: any point of the sphere is as near as any other.
        let axis = if len > 0.0 { -c / len } else { glam::DVec3::Z };
        let anchor = (c + radius as f64 * axis).as_vec3();
        let axis = axis.as_vec3();
        let compact = 4.0 * radius * radius <= center.dot(center);
        GpuSphere {
            center_radius: v4(center, radius),
            anchor_radius: v4(anchor, radius),
            axis: v4(axis, if compact { 1.0 } else { 0.0 }),
            material,
            light,
            pad: [0; 2],
        }
    }

    /// Whether the sphere is no larger than half its centre's distance from the
    /// world origin (2r <= |C|), so that its hit tests work from the centre
    /// instead of the anchor ([`crate::math::geometry::intersect_sphere_compact`]
    /// and [`crate::math::geometry::sphere_blocks`] say why that is precise
    /// enough); set by [`GpuSphere::new`], in `axis[3]`.
    pub fn compact(&self) -> bool {
        self.axis[3] != 0.0
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuQuad {
    pub origin: [f32; 4],
    /// xyz: the edge; w: the scale of the quad's points for hit offsets
    /// ([`crate::math::geometry::quad_points_scale`]).
    pub edge_u: [f32; 4],
    pub edge_v: [f32; 4],
    pub normal: [f32; 4],
    pub dual_u: [f32; 4],
    pub dual_v: [f32; 4],
    pub material: u32,
    pub light: u32,
    pub pad: [u32; 2],
}

/// A triangle in world space (`glsl/common.glsl` `Triangle`); its front side is
/// the side of `(v1 - v0) x (v2 - v0)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub material: u32,
    pub v1: [f32; 3],
    /// Index into the lights, or `shared::NO_LIGHT`.
    pub light: u32,
    pub v2: [f32; 3],
    /// Index into [`SceneArrays::triangle_normals`], or `shared::NO_NORMALS` (flat).
    pub normals: u32,
}

impl GpuTriangle {
    pub fn vertices(&self) -> [Vec3; 3] {
        [Vec3::from(self.v0), Vec3::from(self.v1), Vec3::from(self.v2)]
    }
}

/// The unit shading normals at a smooth triangle's vertices (`TriangleNormals`; w unused).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuTriangleNormals {
    pub n: [[f32; 4]; 3],
}

/// One node of the 4-wide BVH: its four children's boxes as structures of arrays
/// (slot k's box is `lo_x[k]..hi_x[k]` and so on: one read tests all four), and
/// their words (`glsl/common.glsl` `BvhNode`; `crate::math::bvh` builds and walks
/// it). A child word with `shared::BVH_LEAF` set is a leaf of `count` refs from
/// `child & !BVH_LEAF` in [`SceneArrays::prim_refs`]; `shared::BVH_EMPTY` is an
/// unused slot, whose box is inverted (lo +inf, hi -inf: no ray enters it); any
/// other word is the index of a node (count 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuBvhNode {
    pub lo_x: [f32; 4],
    pub lo_y: [f32; 4],
    pub lo_z: [f32; 4],
    pub hi_x: [f32; 4],
    pub hi_y: [f32; 4],
    pub hi_z: [f32; 4],
    pub child: [u32; 4],
    pub count: [u32; 4],
}

impl Default for GpuBvhNode {
    /// A node of four empty slots.
    fn default() -> GpuBvhNode {
        let (lo, hi) = ([f32::INFINITY; 4], [f32::NEG_INFINITY; 4]);
        GpuBvhNode {
            lo_x: lo,
            lo_y: lo,
            lo_z: lo,
            hi_x: hi,
            hi_y: hi,
            hi_z: hi,
            child: [shared::BVH_EMPTY; 4],
            count: [0; 4],
        }
    }
}

impl GpuBvhNode {
    /// Slot `k`'s box (inverted where the slot is empty).
    pub fn slot_box(&self, k: usize) -> ([f32; 3], [f32; 3]) {
        ([self.lo_x[k], self.lo_y[k], self.lo_z[k]], [self.hi_x[k], self.hi_y[k], self.hi_z[k]])
    }

    /// Sets slot `k`'s box.
    pub fn set_box(&mut self, k: usize, lo: [f32; 3], hi: [f32; 3]) {
        (self.lo_x[k], self.lo_y[k], self.lo_z[k]) = (lo[0], lo[1], lo[2]);
        (self.hi_x[k], self.hi_y[k], self.hi_z[k]) = (hi[0], hi[1], hi[2]);
    }

    /// The box around the four slots' boxes (empty slots add nothing).
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut b = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for k in 0..4 {
            let (lo, hi) = self.slot_box(k);
            for a in 0..3 {
                b.0[a] = b.0[a].min(lo[a]);
                b.1[a] = b.1[a].max(hi[a]);
            }
        }
        b
    }
}

/// A primitive reference as the BVH's leaves hold it: kind (`shared::PRIM_*`) in
/// the top two bits, the index in its array below.
/// `glsl/geometry.glsl` `PRIM_REF`.
pub fn prim_ref(kind: u32, index: u32) -> u32 {
    debug_assert!(index <= shared::PRIM_INDEX_MASK);
    (kind << shared::PRIM_KIND_SHIFT) | index
}

/// The kind and index of a primitive reference ([`prim_ref`]).
pub fn prim_kind_index(r: u32) -> (u32, u32) {
    (r >> shared::PRIM_KIND_SHIFT, r & shared::PRIM_INDEX_MASK)
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuLight {
    pub kind: u32,
    pub index: u32,
    pub pmf: f32,
    pub cdf: f32,
}

/// A delta light (`glsl/common.glsl` `DeltaLight`; `crate::math::delta`):
/// a distant light's unit direction towards it and radiance, or a point's or
/// a spot's position and intensity, with a spot's axis and cone cosines.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuDeltaLight {
    /// xyz: the point, or the unit direction towards a distant light; w: a spot's cos of its full-intensity cone.
    pub position_cos_start: [f32; 4],
    /// xyz: intensity (point, spot) or radiance (distant); w: a spot's cos of its cone's edge.
    pub intensity_cos_end: [f32; 4],
    /// xyz: a spot's unit axis.
    pub axis: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RenderParams {
    pub cam_position_near: [f32; 4],
    pub cam_forward_tan: [f32; 4],
    pub cam_right_aspect: [f32; 4],
    pub cam_up: [f32; 4],
    pub environment: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub max_bounces: u32,
    pub rr_depth: u32,
    pub num_spheres: u32,
    pub num_quads: u32,
    pub num_lights: u32,
    pub flags: u32,
    pub seed: u32,
    pub guide_bins: u32,
    pub guide_rows: u32,
    pub guide_cols: u32,
    pub guide_min: [f32; 4],
    pub guide_inv_cell: [f32; 4],
    pub guide_res_x: u32,
    pub guide_res_y: u32,
    pub guide_res_z: u32,
    pub guide_cells: u32,
    pub guide_floor: f32,
    /// Vertices of a path that mix guided sampling in: those at depth < this; 0 for
    /// the default of the roulette and NEE flags, read through
    /// [`crate::guide::guided_vertices`], so that switching NEE (`set_nee`, the
    /// viewer's N key) switches the default too (in a scene without roulette).
    pub guide_vertices: u32,
    /// Shadow rays test the first this many quads only: the rest bound the scene
    /// ([`crate::prepared::occluding_order`]) and cannot block a segment between two of its points.
    pub occluding_quads: u32,
    /// The material and light kinds of the scene ([`crate::prepared::scene_kinds`]): the kernel is
    /// specialized to them and leaves out the code of the others.
    pub scene_kinds: u32,
    pub num_triangles: u32,
    /// Nodes of the BVH; 0 where the kernel walks the primitives itself.
    pub bvh_nodes: u32,
    /// The image environment's texels across and down ([`SceneArrays::env_texels`]);
    /// 0 where the environment is the uniform sky.
    pub env_width: u32,
    pub env_height: u32,
    /// The image environment's frame: the rows of the rotation that takes world
    /// directions to the map's own (`crate::math::envmap`); w unused.
    pub env_frame: [[f32; 4]; 3],
}

impl RenderParams {
    /// Next-event estimation on or off.
    pub fn set_nee(&mut self, on: bool) {
        if on {
            self.flags |= shared::FLAG_NEE;
        } else {
            self.flags &= !shared::FLAG_NEE;
        }
    }
}

/// One pixel of the accumulation buffer: the sum of all radiance samples, and
/// Welford's running sum of squared deviations of the per-frame 64-sample means
/// (for variance estimates; it stays accurate in f32 where sum-of-squares minus
/// square-of-sum cancels).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct AccumPixel {
    pub sum: [f32; 4],
    pub m2_frame_mean: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<GpuMaterial>() == 80);
const _: () = assert!(std::mem::size_of::<GpuSphere>() == 64);
const _: () = assert!(std::mem::size_of::<GpuQuad>() == 112);
const _: () = assert!(std::mem::size_of::<GpuLight>() == 16);
const _: () = assert!(std::mem::size_of::<GpuDeltaLight>() == 48);
const _: () = assert!(std::mem::size_of::<GpuTriangle>() == 48);
const _: () = assert!(std::mem::size_of::<GpuTriangleNormals>() == 48);
const _: () = assert!(std::mem::size_of::<GpuBvhNode>() == 128);
const _: () = assert!(std::mem::size_of::<RenderParams>() == 256);
const _: () = assert!(std::mem::size_of::<AccumPixel>() == 32);
const _: () = assert!(std::mem::size_of::<GpuTexture>() == 32);
const _: () = assert!(std::mem::size_of::<GpuTriangleUvs>() == 24);
const _: () = assert!(std::mem::size_of::<GpuSphereUv>() == 48);
// The specialization constants' layout (glsl/common.glsl): the quads' slots
// follow the scalar constants, the spheres' follow the quads', and nothing after.
const _: () =
    assert!(shared::SPEC_SPHERE_BASE == shared::SPEC_QUAD_BASE + shared::SPEC_QUADS * shared::SPEC_QUAD_FLOATS);
const _: () = assert!(
    shared::SPEC_COMPACT_SPHERES == shared::SPEC_SPHERE_BASE + shared::SPEC_SPHERES * shared::SPEC_SPHERE_FLOATS
);
const _: () = assert!(shared::SPEC_LIGHT_QUADS == shared::SPEC_COMPACT_SPHERES + 1);
const _: () = assert!(shared::SPEC_LIGHT_SPHERES == shared::SPEC_LIGHT_QUADS + 1);
const _: () = assert!(shared::SPEC_ROOM_QUADS == shared::SPEC_LIGHT_SPHERES + 1);
const _: () = assert!(shared::SPEC_ROOM_BOUNDS == shared::SPEC_ROOM_QUADS + 1);
const _: () = assert!(shared::SPEC_ROOM_FACES == shared::SPEC_ROOM_BOUNDS + 6);
const _: () = assert!(shared::SPEC_ROOM_ENTERING == shared::SPEC_ROOM_FACES + 6);
const _: () = assert!(shared::SPEC_BVH == shared::SPEC_ROOM_ENTERING + 1);
const _: () = assert!(shared::SPEC_SMOOTH == shared::SPEC_BVH + 1);
const _: () = assert!(shared::SPEC_TEXTURES == shared::SPEC_SMOOTH + 1);
const _: () = assert!(shared::NUM_SPEC_CONSTANTS == shared::SPEC_TEXTURES + 1);
// geometry.glsl writes its slots out for 16 of each (FOR_SPEC_SLOTS).
const _: () = assert!(shared::SPEC_QUADS == 16 && shared::SPEC_SPHERES == 16);

/// Guided sampling's default reach with NEE in a scene without Russian roulette:
/// a path's first two vertices. There, deeper vertices gained little per sample,
/// while their table lookups and the recording of their targets cost time
/// (docs/guiding.md, "Defaults"). Without NEE only guided sampling aims at the
/// lights, at every vertex: then every vertex is
/// guided. So is every vertex where Russian roulette is on (door.toml), whatever
/// NEE says: there every vertex records targets and looks up its cell for learned
/// roulette anyway, and guiding them all paid at equal time
/// ([`crate::guide::guided_vertices`]).
pub const DEFAULT_GUIDED_VERTICES_NEE: u32 = 2;

/// Largest image width or height, in pixels, a scene or an option may ask for.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Largest samples per pixel a render may ask for: the most whole frames of
/// `SAMPLES_PER_FRAME` whose samples a u32 counts (renders round `spp` up to whole
/// frames; u32::MAX itself would round past it).
pub const MAX_SPP: u32 = u32::MAX / shared::SAMPLES_PER_FRAME * shared::SAMPLES_PER_FRAME;
/// Largest `max_bounces`: a path's ray count shares a 32-bit register with its
/// depth in kernels with roulette (`glsl/pathtrace.comp` `depth_rays`), 16 bits
/// each, and a path of 1024 bounces traces at most 2050 rays.
pub const MAX_BOUNCES: u32 = 1024;

/// The box whose faces are walls of the scene (`crate::prepared::room_walls`
/// finds it; its tests are in `crate::math::geometry`): the box around every primitive, and the quads that lie in its
/// faces and cover them whole. A ray meets such a quad exactly where it
/// crosses that face of the box, and a line crosses a box's surface at most
/// twice, entering and leaving, so one slab test per ray finds which of them it
/// meets first (`Room::hit`) in place of a hit test per quad: the five walls of
/// the seed's rooms, the six of door's. `glsl/geometry.glsl` `room_hit` is the
/// same test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Room {
    pub min: Vec3,
    pub max: Vec3,
    /// Per face `2 * axis + side` (side 1 the face at `max`): the index in
    /// [`SceneArrays::quads`] of the quad that covers it, `shared::NO_QUAD`
    /// where the face is open.
    pub faces: [u32; 6],
    /// How many faces have a quad. Those quads are the last of
    /// [`SceneArrays::quads`], and the closest-hit walk leaves them to `Room::hit`.
    pub quads: u32,
    /// Whether a ray may meet a wall from outside the box (`Room::camera_may_enter`):
    /// where not, the test leaves out the face a ray enters by.
    pub entering: bool,
}

impl Room {
    /// No room: every quad has its own hit test.
    pub const NONE: Room =
        Room { min: Vec3::ZERO, max: Vec3::ZERO, faces: [shared::NO_QUAD; 6], quads: 0, entering: false };
}

/// The scene as the renderers trace it: what the GPU's buffers hold (parameters,
/// materials, spheres, quads, lights) and the room its kernel is specialized to.
/// `crate::prepared::PreparedScene` makes it (and derefs to it); the geometry of
/// `crate::math::geometry` reads it.
#[derive(Clone, Debug)]
pub struct SceneArrays {
    pub params: RenderParams,
    pub materials: Vec<GpuMaterial>,
    pub spheres: Vec<GpuSphere>,
    pub quads: Vec<GpuQuad>,
    pub lights: Vec<GpuLight>,
    /// The triangles of every mesh, in world space.
    pub triangles: Vec<GpuTriangle>,
    /// The shading normals of the smooth triangles.
    pub triangle_normals: Vec<GpuTriangleNormals>,
    /// The BVH over every primitive ([`GpuBvhNode`], root first); empty where the
    /// renderers walk the spheres and quads themselves.
    pub bvh_nodes: Vec<GpuBvhNode>,
    /// The BVH leaves' primitive references ([`prim_ref`]).
    pub prim_refs: Vec<u32>,
    /// The walls found by one slab test (`crate::prepared::room_walls`);
    /// [`Room::NONE`] where there are none.
    pub room: Room,
    /// The image environment (`crate::math::envmap`): per texel its scaled RGB and
    /// its density over the image's unit square; empty for the uniform sky.
    pub env_texels: Vec<[f32; 4]>,
    /// The environment's sampling cdfs: over rows, then per row over its texels.
    pub env_cdf: Vec<f32>,
    /// The image textures' headers ([`GpuTexture`]); empty where no material has one.
    pub textures: Vec<GpuTexture>,
    /// Every texture's texels, one after another (`shared::TEXEL_*`).
    pub texels: Vec<u32>,
    /// Per triangle its vertices' UVs, where the scene has textures; else empty.
    pub triangle_uvs: Vec<GpuTriangleUvs>,
    /// Per sphere its UV frame, where the scene has textures; else empty.
    pub sphere_uvs: Vec<GpuSphereUv>,
    /// The delta lights, indexed by their [`GpuLight::index`]; empty where there are none.
    pub delta_lights: Vec<GpuDeltaLight>,
}

impl SceneArrays {
    /// Arrays holding `triangles` alone: no tree (the caller puts one in),
    /// materials, lights or room. Tests and the builder comparison start from it.
    pub fn of_triangles(triangles: Vec<GpuTriangle>) -> SceneArrays {
        SceneArrays {
            params: RenderParams::default(),
            materials: vec![],
            spheres: vec![],
            quads: vec![],
            lights: vec![],
            triangles,
            triangle_normals: vec![],
            bvh_nodes: vec![],
            prim_refs: vec![],
            room: Room::NONE,
            env_texels: vec![],
            env_cdf: vec![],
            textures: vec![],
            texels: vec![],
            triangle_uvs: vec![],
            sphere_uvs: vec![],
            delta_lights: vec![],
        }
    }
}
