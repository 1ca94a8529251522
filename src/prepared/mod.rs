//! The scene flattened into the arrays both renderers trace
//! ([`crate::layout::SceneArrays`]) for the render options
//! ([`crate::options::RenderOptions`]), and the analysis that orders them
//! (`analysis.rs`: which quads shadow rays test, the room's walls, the kernel's
//! material and light kinds). The GPU renderer uploads them; the CPU renderer
//! reads the same values, so precomputed normals, light probabilities and camera
//! vectors agree exactly.

use crate::guide::{self, Bins, FieldError, Grid, GuideConfig, GuideField, GuidingMode};
use crate::layout::{v4, GpuLight, GpuMaterial, GpuQuad, GpuSphere, GpuTexture, RenderParams, Room, SceneArrays};
use crate::math::bvh;
use crate::math::sampler::SamplerKind;
use crate::math::Vec3;
use crate::options::{Counters, OptionError, RenderOptions};
use crate::scene::Scene;
use crate::shared;

mod analysis;
mod meshes;
mod textures;
pub use analysis::*;
use meshes::mesh_triangles;
pub use meshes::{prim_boxes, uses_bvh, BVH_MIN_ANALYTIC};

/// The image environment's share of light choices where the scene has other lights.
pub const ENV_LIGHT_SHARE: f32 = 0.5;

/// The scene ready to upload or trace: its arrays ([`SceneArrays`], which it
/// derefs to, as the geometry reads them) and the guiding configuration.
#[derive(Clone, Debug)]
pub struct PreparedScene {
    pub arrays: SceneArrays,
    /// Guiding geometry, when guiding is on.
    pub guide: Option<GuideConfig>,
    /// The learned field guiding starts from (`--guide-in`), else a blank table.
    pub guide_start: Option<std::sync::Arc<GuideField>>,
}

impl std::ops::Deref for PreparedScene {
    type Target = SceneArrays;
    fn deref(&self) -> &SceneArrays {
        &self.arrays
    }
}

impl std::ops::DerefMut for PreparedScene {
    fn deref_mut(&mut self) -> &mut SceneArrays {
        &mut self.arrays
    }
}

impl RenderParams {
    /// Points the camera fields at `cam` (the aspect ratio is the image's: set
    /// `width` and `height` first).
    pub fn set_camera(&mut self, cam: &crate::scene::Camera) {
        let right = cam.forward.cross(cam.up).normalize();
        let up = right.cross(cam.forward).normalize();
        let tan_half = (cam.vfov_deg.to_radians() * 0.5).tan();
        self.cam_position_near = v4(cam.position, cam.near);
        self.cam_forward_tan = v4(cam.forward, tan_half);
        self.cam_right_aspect = v4(right, self.width as f32 / self.height as f32);
        self.cam_up = v4(up, 0.0);
    }
}

/// Where specialization constant `id` (from `SPEC_QUAD_BASE` on) lies in
/// [`PreparedScene::geometry_specialization`]'s vector.
pub fn geometry_index(id: u32) -> usize {
    (id - shared::SPEC_QUAD_BASE) as usize
}

impl PreparedScene {
    /// Frames that teach the table before the image starts (`GuideConfig::learning_frames`; 0 without guiding).
    pub fn learning_frames(&self) -> u32 {
        self.guide.as_ref().map_or(0, |g| g.learning_frames)
    }

    /// The uniform buffer of `glsl/geometry.glsl` (`SceneConstantsBlock`): the
    /// first `CONST_SPHERES` spheres (center_radius, anchor_radius, axis) and the first
    /// `CONST_QUADS` quads (normal, origin, dual_u, dual_v), the data their hit
    /// tests read, zero-filled past the scene's own.
    pub fn scene_constants(&self) -> Vec<[f32; 4]> {
        let ns = shared::CONST_SPHERES as usize;
        let nq = shared::CONST_QUADS as usize;
        let mut out = vec![[0.0; 4]; 3 * ns + 4 * nq];
        for (i, s) in self.spheres.iter().take(ns).enumerate() {
            out[3 * i..3 * i + 3].copy_from_slice(&[s.center_radius, s.anchor_radius, s.axis]);
        }
        for (i, q) in self.quads.iter().take(nq).enumerate() {
            let k = 3 * ns + 4 * i;
            out[k..k + 4].copy_from_slice(&[q.normal, q.origin, q.dual_u, q.dual_v]);
        }
        out
    }

    /// The hit-test data of the first `SPEC_QUADS` quads and `SPEC_SPHERES`
    /// spheres as pathtrace.comp's specialization constants (glsl/geometry.glsl),
    /// f32 bit patterns in constant_id order from `SPEC_QUAD_BASE`: per quad its
    /// normal, origin, dual_u and dual_v (13 floats), per sphere its centre, its
    /// anchor and radius and its axis (10); zeros past the scene's own. Last,
    /// `SPEC_COMPACT_SPHERES`, an integer: bit i for a compact sphere i
    /// ([`GpuSphere::compact`]); then `SPEC_LIGHT_QUADS` and `SPEC_LIGHT_SPHERES`,
    /// bit i for a light in slot i.
    pub fn geometry_specialization(&self) -> Vec<u32> {
        let quad_floats = shared::SPEC_QUAD_FLOATS as usize;
        let sphere_floats = shared::SPEC_SPHERE_FLOATS as usize;
        let mut out = vec![0u32; geometry_index(shared::NUM_SPEC_CONSTANTS)];
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
        for (i, q) in self.quads.iter().take(shared::SPEC_QUADS as usize).enumerate() {
            let floats = [&q.normal[..], &q.origin[..3], &q.dual_u[..3], &q.dual_v[..3]].concat();
            out[quad_floats * i..quad_floats * (i + 1)].copy_from_slice(&bits(&floats));
        }
        let spheres = geometry_index(shared::SPEC_SPHERE_BASE);
        for (i, s) in self.spheres.iter().take(shared::SPEC_SPHERES as usize).enumerate() {
            let floats = [&s.center_radius[..3], &s.anchor_radius[..], &s.axis[..3]].concat();
            let k = spheres + sphere_floats * i;
            out[k..k + sphere_floats].copy_from_slice(&bits(&floats));
        }
        let at = geometry_index;
        for (i, s) in self.spheres.iter().take(shared::SPEC_SPHERES as usize).enumerate() {
            out[at(shared::SPEC_COMPACT_SPHERES)] |= (s.compact() as u32) << i;
            out[at(shared::SPEC_LIGHT_SPHERES)] |= ((s.light != shared::NO_LIGHT) as u32) << i;
        }
        for (i, q) in self.quads.iter().take(shared::SPEC_QUADS as usize).enumerate() {
            out[at(shared::SPEC_LIGHT_QUADS)] |= ((q.light != shared::NO_LIGHT) as u32) << i;
        }
        let r = &self.room;
        out[at(shared::SPEC_ROOM_QUADS)] = r.quads;
        let bounds = at(shared::SPEC_ROOM_BOUNDS);
        out[bounds..bounds + 6].copy_from_slice(&bits(&[r.min.to_array(), r.max.to_array()].concat()));
        let faces = at(shared::SPEC_ROOM_FACES);
        out[faces..faces + 6].copy_from_slice(&r.faces);
        out[at(shared::SPEC_ROOM_ENTERING)] = r.entering as u32;
        out[at(shared::SPEC_BVH)] = !self.bvh_nodes.is_empty() as u32;
        out[at(shared::SPEC_SMOOTH)] = !self.triangle_normals.is_empty() as u32;
        out[at(shared::SPEC_TEXTURES)] = !self.textures.is_empty() as u32;
        out
    }

    /// The scene's arrays and the render's parameters; an error where an option
    /// is out of range ([`RenderOptions::check`]).
    pub fn new(scene: &Scene, opts: &RenderOptions) -> Result<PreparedScene, OptionError> {
        opts.check()?;
        if !opts.nee && !scene.delta_lights.is_empty() {
            return Err(OptionError {
                option: "nee",
                value: "off".into(),
                expected: format!(
                    "it must be on, as the scene's {} distant, point or spot lights are reached only by next-event estimation",
                    scene.delta_lights.len()
                ),
            });
        }
        let mut materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .map(|m| GpuMaterial {
                albedo_roughness: v4(m.albedo, m.roughness),
                emission_ior: v4(m.emission, m.ior),
                eta: v4(m.eta, if m.reflectance_conductor { 1.0 } else { 0.0 }),
                // A mix's two materials, as floats (exact: Scene's indices are below 2^24).
                k: match m.mix {
                    Some([a, b]) => [a as f32, b as f32, 0.0, 0.0],
                    // A coated material's conductor base's roughness, 0 for the Lambertian base.
                    None => v4(m.k, m.base_roughness.unwrap_or(0.0)),
                },
                kind: m.kind as u32,
                two_sided: m.two_sided as u32,
                albedo_texture: shared::NO_TEXTURE,
                roughness_texture: shared::NO_TEXTURE,
            })
            .collect();
        let (textures, texels) = textures::scene_textures(scene, &mut materials);
        let sphere_uvs = if textures.is_empty() { Vec::new() } else { textures::sphere_uvs(scene) };
        // Lights are chosen in proportion to emitted power: area x mean emission (x2 if two-sided).
        // In f64: a large lamp's power overflows f32 (1e12 radiance over 1e24 of
        // area), and the probabilities are all that leaves here.
        let power = |mat: u32, area: f64| {
            let m = &scene.materials[mat as usize];
            let mean = (m.emission.x as f64 + m.emission.y as f64 + m.emission.z as f64) / 3.0;
            area * mean * if m.two_sided { 2.0 } else { 1.0 }
        };
        let mut lights = Vec::new();
        let mut powers = Vec::new();
        let spheres: Vec<GpuSphere> = scene
            .spheres
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let mut light = shared::NO_LIGHT;
                if scene.material_emits(s.material) {
                    light = lights.len() as u32;
                    lights.push(GpuLight { kind: shared::LIGHT_SPHERE, index: i as u32, pmf: 0.0, cdf: 0.0 });
                    powers.push(power(s.material, 4.0 * std::f64::consts::PI * (s.radius as f64).powi(2)));
                }
                GpuSphere::new(s.center, s.radius, s.material, light)
            })
            .collect();
        let quads: Vec<_> = scene
            .quads
            .iter()
            .enumerate()
            .map(|(i, q)| {
                let n = q.edge_u.cross(q.edge_v);
                let area = n.length();
                let w = n / n.length_squared();
                let normal = n / area;
                let mut light = shared::NO_LIGHT;
                if scene.material_emits(q.material) {
                    light = lights.len() as u32;
                    lights.push(GpuLight { kind: shared::LIGHT_QUAD, index: i as u32, pmf: 0.0, cdf: 0.0 });
                    powers.push(power(q.material, q.edge_u.as_dvec3().cross(q.edge_v.as_dvec3()).length()));
                }
                GpuQuad {
                    origin: v4(q.origin, area),
                    edge_u: v4(q.edge_u, crate::math::geometry::quad_points_scale(q.origin, q.edge_u, q.edge_v)),
                    edge_v: v4(q.edge_v, 0.0),
                    normal: v4(normal, normal.dot(q.origin)),
                    dual_u: v4(q.edge_v.cross(w), 0.0),
                    dual_v: v4(w.cross(q.edge_u), 0.0),
                    material: q.material,
                    light,
                    pad: [0; 2],
                }
            })
            .collect();
        let (triangles, triangle_normals, triangle_uvs) =
            mesh_triangles(scene, &mut lights, &mut powers, &power, !textures.is_empty());
        let delta_lights = delta_lights(scene, &spheres, &quads, &triangles, &mut lights, &mut powers);
        let bvh = uses_bvh(scene);
        // Without a BVH, the quads that can block a shadow ray first, the room's
        // walls last; lights follow their quads. The BVH tests every primitive.
        // A shadow ray to the image environment leaves the scene: every quad may block it.
        // So may one to a delta light, which need lie on no surface (a distant one's leaves too).
        let all_quads = bvh || scene.environment_map.is_some() || !delta_lights.is_empty();
        let (mut order, occluding_quads) = if all_quads {
            ((0..scene.quads.len()).collect(), scene.quads.len() as u32)
        } else {
            occluding_order(scene)
        };
        let walls = if bvh { None } else { room_walls(scene, &order[occluding_quads as usize..]) };
        let mut room = Room::NONE;
        if let Some((min, max, faces)) = walls {
            let is_wall = |i: &usize| faces.contains(&Some(*i));
            let (rest, last): (Vec<usize>, Vec<usize>) = order.iter().partition(|i| !is_wall(i));
            order = [rest, last].concat();
            let at = |i: usize| order.iter().position(|&j| j == i).unwrap() as u32;
            room = Room {
                min,
                max,
                faces: faces.map(|f| f.map_or(shared::NO_QUAD, at)),
                quads: faces.iter().flatten().count() as u32,
                entering: false,
            };
        }
        let quads: Vec<GpuQuad> = order.iter().map(|&i| quads[i]).collect();
        for (j, q) in quads.iter().enumerate() {
            if q.light != shared::NO_LIGHT {
                lights[q.light as usize].index = j as u32;
            }
        }
        let total: f64 = powers.iter().sum();
        let mut cdf = 0.0f64;
        for (l, p) in lights.iter_mut().zip(&powers) {
            let pmf = p / total;
            cdf += pmf;
            l.pmf = pmf as f32;
            l.cdf = cdf as f32;
        }
        // The image environment is the last light (a map of no light is no light):
        // half the choices where there are other lights, else all of them. A
        // fixed share, as its power depends on the scene's extent as much as on
        // the map; the map's own distribution does the rest.
        let env = scene
            .environment_map
            .as_ref()
            .and_then(|m| crate::math::envmap::env_distribution(m.width, m.height, &m.texels).map(|d| (m, d)));
        if env.is_some() {
            let share = if lights.is_empty() { 1.0 } else { ENV_LIGHT_SHARE };
            for l in &mut lights {
                l.pmf *= 1.0 - share;
                l.cdf *= 1.0 - share;
            }
            lights.push(GpuLight { kind: shared::LIGHT_ENV, index: 0, pmf: share, cdf: 1.0 });
        }
        if let Some(last) = lights.last_mut() {
            last.cdf = 1.0;
        }

        let mut flags = 0;
        if opts.nee {
            flags |= shared::FLAG_NEE;
        }
        let roulette = opts.russian_roulette_depth.is_some();
        if roulette {
            flags |= shared::FLAG_RUSSIAN_ROULETTE;
        }
        if opts.power_heuristic {
            flags |= shared::FLAG_POWER_HEURISTIC;
        }
        if opts.learn_fraction && opts.guiding != GuidingMode::Off {
            flags |= shared::FLAG_LEARN_FRACTION;
        }
        if opts.q_targets == guide::QTargets::Mis && opts.guiding != GuidingMode::Off {
            flags |= shared::FLAG_MIS_TARGETS;
        }
        if !bvh && last_ray_to_lights(scene.environment, &lights, roulette) {
            flags |= shared::FLAG_LAST_RAY_TO_LIGHTS;
        }
        if opts.sampler == SamplerKind::Sobol {
            flags |= shared::FLAG_SOBOL;
        }
        let product = opts.glossy_product
            && opts.guiding != GuidingMode::Off
            && materials.iter().any(crate::guide::product_material);
        if product {
            flags |= shared::FLAG_GLOSSY_PRODUCT;
        }
        match opts.counters {
            Counters::Off => {}
            Counters::ZeroPaths => flags |= shared::FLAG_COUNTERS,
            Counters::All => flags |= shared::FLAG_COUNTERS | shared::FLAG_COUNT_RAYS,
        }
        let mut params = RenderParams {
            cam_position_near: [0.0; 4],
            cam_forward_tan: [0.0; 4],
            cam_right_aspect: [0.0; 4],
            cam_up: [0.0; 4],
            environment: v4(scene.environment, 0.0),
            width: opts.width,
            height: opts.height,
            max_bounces: opts.max_bounces,
            rr_depth: opts.russian_roulette_depth.unwrap_or(u32::MAX),
            num_spheres: scene.spheres.len() as u32,
            num_quads: scene.quads.len() as u32,
            num_lights: lights.len() as u32,
            flags,
            seed: opts.seed,
            guide_bins: 0,
            guide_rows: 0,
            guide_cols: 0,
            guide_min: [0.0; 4],
            guide_inv_cell: [0.0; 4],
            guide_res_x: 0,
            guide_res_y: 0,
            guide_res_z: 0,
            guide_cells: 0,
            guide_floor: 0.0,
            guide_vertices: 0,
            occluding_quads,
            // The product's glossy vertices mix: their kernel keeps the mixture's GGX evaluation.
            scene_kinds: scene_kinds(&materials, &lights, &textures)
                | (product as u32) << shared::SCENE_KIND_GUIDED_GLOSSY,
            num_triangles: triangles.len() as u32,
            bvh_nodes: 0,
            env_width: env.as_ref().map_or(0, |(m, _)| m.width),
            env_height: env.as_ref().map_or(0, |(m, _)| m.height),
            env_frame: env.as_ref().map_or([[0.0; 4]; 3], |(m, _)| {
                let r = m.to_map.transpose();
                [v4(r.x_axis, 0.0), v4(r.y_axis, 0.0), v4(r.z_axis, 0.0)]
            }),
        };
        params.set_camera(&scene.camera);
        let (mut bvh_nodes, mut prim_refs) = (Vec::new(), Vec::new());
        if bvh {
            let built = bvh::build(&prim_boxes(&spheres, &quads, &triangles));
            params.bvh_nodes = built.nodes.len() as u32;
            (bvh_nodes, prim_refs) = (built.nodes, built.prim_refs);
        }
        room.entering = room.camera_may_enter(&params);
        let mut prepared = PreparedScene {
            arrays: SceneArrays {
                params,
                materials,
                spheres,
                quads,
                lights,
                triangles,
                triangle_normals,
                bvh_nodes,
                prim_refs,
                room,
                env_texels: env.as_ref().map_or(Vec::new(), |(_, (t, _))| t.clone()),
                env_cdf: env.map_or(Vec::new(), |(_, (_, c))| c),
                textures,
                texels,
                triangle_uvs,
                sphere_uvs,
                delta_lights,
            },
            guide: None,
            guide_start: None,
        };
        let bins = match opts.guiding {
            GuidingMode::Off => None,
            GuidingMode::Octant => Some(Bins::OCTANT),
            GuidingMode::Sphere => Some(opts.bins.unwrap_or(guide::default_bins(roulette))),
        };
        if let Some(bins) = bins {
            let settings =
                crate::scene::GuidingSettings { grid: opts.guide_grid.or(scene.guiding.grid), ..scene.guiding.clone() };
            let grid = Grid::for_render(&prepared, &settings, roulette, bins);
            let cfg = GuideConfig {
                mode: opts.guiding,
                bins,
                grid,
                // A learned fraction starts within the bounds it learns in.
                fraction: if opts.learn_fraction {
                    opts.guided_fraction.clamp(guide::FRACTION_MIN, 1.0 - guide::FRACTION_MIN)
                } else {
                    opts.guided_fraction
                },
                learn_fraction: opts.learn_fraction,
                floor: opts.guide_floor,
                rate_exponent: opts.learning_rate_exponent,
                learning_frames: guide::frames_before_image(
                    opts.learning_frames.unwrap_or(guide::default_learning_frames(roulette)),
                    opts.unguided_frames == guide::UnguidedFrames::Auto,
                ),
                unguided_frames: opts.unguided_frames == guide::UnguidedFrames::Auto,
                learning_period: opts.learning_period,
                adaptive_directions: opts.adaptive_directions,
            };
            let p = &mut prepared.params;
            p.guide_bins = bins.count();
            p.guide_rows = bins.rows;
            p.guide_cols = bins.cols;
            set_grid(p, &cfg);
            p.guide_floor = cfg.floor;
            if cfg.unguided_frames {
                p.flags |= shared::FLAG_FRAME_VARIANCE;
            }
            // 0: the default for whichever NEE and roulette flags the params hold.
            p.guide_vertices = opts.guided_vertices.unwrap_or(0);
            prepared.guide = Some(cfg);
        }
        Ok(prepared)
    }

    /// Starts guiding from `field`, read from `path` (`--guide-in`): its grid takes
    /// the place of the one this render's camera would give, so that a field
    /// learned from one view serves another; its bins must be this render's, and
    /// its scene this one. Learning frames are then 0 unless `opts` asks for some.
    pub fn start_from(
        &mut self,
        field: GuideField,
        path: &std::path::Path,
        opts: &RenderOptions,
    ) -> Result<(), FieldError> {
        let hash = guide::scene_hash(&self.arrays);
        let Some(cfg) = self.guide.as_mut() else {
            return Err(FieldError(format!(
                "--guide-in {} needs guiding on (--guiding sphere or octant)",
                path.display()
            )));
        };
        field.check(path, hash, cfg.bins)?;
        cfg.grid = field.grid;
        cfg.learning_frames = guide::frames_before_image(opts.learning_frames.unwrap_or(0), cfg.unguided_frames);
        let cfg = *cfg;
        set_grid(&mut self.arrays.params, &cfg);
        self.guide_start = Some(std::sync::Arc::new(field));
        Ok(())
    }
}

/// The params' copy of the guiding grid and the start fraction.
fn set_grid(p: &mut RenderParams, cfg: &GuideConfig) {
    p.guide_min = v4(cfg.grid.min, cfg.fraction);
    p.guide_inv_cell = v4(cfg.grid.inv_cell_size(), cfg.bins.solid_angle());
    [p.guide_res_x, p.guide_res_y, p.guide_res_z] = cfg.grid.res;
    p.guide_cells = cfg.cells();
    if cfg.grid.adaptive() {
        p.flags |= shared::FLAG_ADAPTIVE_GRID;
    } else {
        p.flags &= !shared::FLAG_ADAPTIVE_GRID;
    }
}

#[cfg(test)]
mod tests;

/// The scene's delta lights for `delta_lights[]`, each appended to `lights` with
/// its power (`crate::math::delta::delta_power`; a distant light's from the
/// bounding sphere of the primitives' box).
fn delta_lights(
    scene: &Scene,
    spheres: &[GpuSphere],
    quads: &[GpuQuad],
    triangles: &[crate::layout::GpuTriangle],
    lights: &mut Vec<GpuLight>,
    powers: &mut Vec<f64>,
) -> Vec<crate::layout::GpuDeltaLight> {
    if scene.delta_lights.is_empty() {
        return Vec::new();
    }
    let boxes = meshes::prim_boxes(spheres, quads, triangles);
    let lo = boxes.iter().fold(glam::DVec3::INFINITY, |a, b| a.min(b.lo.as_dvec3()));
    let hi = boxes.iter().fold(glam::DVec3::NEG_INFINITY, |a, b| a.max(b.hi.as_dvec3()));
    let radius = if boxes.is_empty() { 0.0 } else { 0.5 * (hi - lo).length() };
    let mut out = Vec::new();
    for l in &scene.delta_lights {
        let (kind, gpu) = crate::math::delta::gpu_delta_light(l);
        lights.push(GpuLight { kind, index: out.len() as u32, pmf: 0.0, cdf: 0.0 });
        powers.push(crate::math::delta::delta_power(l, radius));
        out.push(gpu);
    }
    out
}
