//! The voxel grid over the scene whose cells are guiding's states, and the probe
//! of the scene that bounds it; `glsl/guide.glsl` `cell_index` is the GPU twin.

use super::*;
use crate::scene::GridKind;

/// The storage buffer size every Vulkan device allows (the least
/// `maxStorageBufferRange` the specification permits).
pub const PORTABLE_BUFFER_BYTES: u64 = 1 << 27;

/// The voxel grid whose cells are the states.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub min: Vec3,
    pub max: Vec3,
    pub res: [u32; 3],
    /// Cells the table holds: [`cells`](Self::cells) for a uniform grid; where
    /// more, the grid is adaptive and its cells split into 8 as paths teach them,
    /// until the table is full (`tree.rs`).
    pub capacity: u32,
}

impl Grid {
    /// The grid's own cells (the tree's roots where it is adaptive).
    pub fn cells(&self) -> u32 {
        self.res[0] * self.res[1] * self.res[2]
    }

    /// Whether cells split ([`QTable::refine`]).
    pub fn adaptive(&self) -> bool {
        self.capacity > self.cells()
    }

    /// The adaptive grid that takes the memory of this uniform one: half its
    /// cells along each axis (rounded up), the same cells in the table.
    pub fn adaptive_of(self) -> Grid {
        let res = self.res.map(|n| n.div_ceil(2));
        Grid { res, ..self }
    }

    /// Cells per unit length along each axis.
    pub fn inv_cell_size(&self) -> Vec3 {
        Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32) / (self.max - self.min)
    }

    /// The grid's cell containing `p`; points outside the box use the nearest
    /// cell. Where the grid is adaptive, [`cell_in_tree`] goes on down the tree.
    pub fn cell(&self, p: Vec3) -> u32 {
        cell_in_tree(self, &[], p)
    }

    /// The grid a render of `bins` guides on: the `[guiding]` table where it says
    /// so; otherwise the box around the points that camera rays and their first
    /// diffuse bounce reach on paths that meet light ([`guide_bounds`]; so huge
    /// wall spheres do not stretch it), and [`default_grid_cells`] along its
    /// longest axis, proportionally fewer along the others, fewer still where the
    /// sampling rows would pass [`PORTABLE_BUFFER_BYTES`], which every Vulkan
    /// device lets a storage buffer hold (no fewer than 16: more bins than that
    /// fits are the user's choice, and the device's own limit decides).
    pub fn for_render(scene: &SceneArrays, settings: &GuidingSettings, roulette: bool, bins: Bins) -> Grid {
        // The probe behind the box runs once; only the cells vary below.
        let (min, max) = match (settings.bounds_min, settings.bounds_max) {
            (Some(a), Some(b)) => (a, b),
            _ => guide_bounds(scene),
        };
        let pixels = scene.params.width as u64 * scene.params.height as u64;
        let mut longest = default_grid_cells(roulette, pixels);
        loop {
            let grid = Grid::over(min, max, settings, longest);
            let rows = sampling_rows_bytes(grid.capacity, bins);
            if settings.resolution.is_some() || rows <= PORTABLE_BUFFER_BYTES || longest <= 16 {
                return grid;
            }
            longest -= 1;
        }
    }

    /// The grid over the box from `min` to `max`: the `[guiding]` resolution where
    /// it gives one, else `longest` cells along the box's longest axis and
    /// proportionally fewer along the others; adaptive where the settings say so.
    fn over(min: Vec3, max: Vec3, settings: &GuidingSettings, longest: u32) -> Grid {
        let res = settings.resolution.unwrap_or_else(|| {
            let e = max - min;
            let size = e.max_element();
            let n = |x: f32| ((longest as f32 * x / size).round() as u32).clamp(1, longest);
            [n(e.x), n(e.y), n(e.z)]
        });
        let grid = Grid { min, max, res, capacity: res[0] * res[1] * res[2] };
        match settings.grid.unwrap_or_default() {
            GridKind::Uniform => grid,
            GridKind::Adaptive => grid.adaptive_of(),
        }
    }
}

/// A warning for stderr where the scene's own `[guiding]` box does not overlap
/// [`probe_bounds`], the box of what the camera sees: every point of the scene
/// then falls in the grid's edge cells (points outside the box use the nearest
/// cell), and the table learns one blur of the whole scene. None where the box
/// is chosen automatically, or guiding is off.
pub fn grid_warning(scene: &SceneArrays, cfg: Option<&GuideConfig>, settings: &GuidingSettings) -> Option<String> {
    let cfg = cfg?;
    settings.bounds_min?;
    let (lo, hi) = probe_bounds(scene);
    let (min, max) = (cfg.grid.min, cfg.grid.max);
    let overlaps = (0..3).all(|a| min[a] < hi[a] && max[a] > lo[a]);
    (!overlaps).then(|| {
        let v = |p: Vec3| format!("[{}, {}, {}]", p.x, p.y, p.z);
        format!(
            "the [guiding] box from {} to {} does not overlap what the camera sees (about {} to {}): every \
             point falls in one of its edge cells, and guiding learns little",
            v(min),
            v(max),
            v(lo),
            v(hi)
        )
    })
}

/// The bounding box of the camera and of the surface points seen from it
/// directly and after one bounce, enlarged by 1% of its diagonal.
pub fn probe_bounds(scene: &SceneArrays) -> (Vec3, Vec3) {
    probe(scene).seen
}

/// The box the grid covers by default: [`probe_bounds`] less the camera and the
/// points of probe paths that meet no light, where at least 1/64 of the paths
/// meet some. Points
/// that no light reaches need no guiding, and can lie far out: smallpt framed
/// wider than 4:3 starts its edge rays behind the side walls, in an unlit gap
/// that reaches hundreds of units out, and the grid over it gave the room a few
/// cells (docs/guiding.md, "Small images").
pub fn guide_bounds(scene: &SceneArrays) -> (Vec3, Vec3) {
    let p = probe(scene);
    if p.lit_paths * 64 >= p.paths {
        p.lit
    } else {
        p.seen
    }
}

/// What [`probe`] found: the boxes of all the points and of those of paths that
/// met light, and how many paths there were and met light.
struct Probe {
    seen: (Vec3, Vec3),
    lit: (Vec3, Vec3),
    paths: u32,
    lit_paths: u32,
}

/// Traces 64x64 camera rays and one cosine-distributed bounce from each hit. A
/// path meets light where its bounce escapes into a sky that is not black, or
/// at one of its two hits ([`meets_light_at`]). The tests for light draw from
/// their own stream, so the points are those of the camera rays and bounces alone.
fn probe(scene: &SceneArrays) -> Probe {
    let p = &scene.params;
    let eye = Vec3::new(p.cam_position_near[0], p.cam_position_near[1], p.cam_position_near[2]);
    let (mut lo, mut hi) = (eye, eye);
    // The eye is no vertex: a camera outside the room (smallpt's) would stretch the box.
    let (mut lit_lo, mut lit_hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let sky = p.env_width > 0 || Vec3::new(p.environment[0], p.environment[1], p.environment[2]).max_element() > 0.0;
    let n = 64u32;
    let mut rng = Rng::new(0x5eed, 0, 0, 0);
    let mut light_rng = Rng::new(0x5eed, 1, 0, 0);
    let mut lit_paths = 0;
    let mut probe = p.to_owned();
    probe.width = n;
    probe.height = n;
    for y in 0..n {
        for x in 0..n {
            let (o, d) = crate::camera::camera_ray(&probe, x, y, rng.next_2d());
            let Some(h) = intersect(scene, o, d, f32::INFINITY) else { continue };
            let mut lit = meets_light_at(scene, &h, d, sky, &mut light_rng);
            let nrm = if h.n.dot(d) < 0.0 { h.n } else { -h.n };
            let dir = Frame::from_normal(nrm).to_world(crate::math::sampling::cosine_hemisphere(rng.next_2d()));
            let o2 = crate::math::geometry::offset_origin(h.p, h.n, h.eps, dir);
            let h2 = intersect(scene, o2, dir, f32::INFINITY);
            lit |= match &h2 {
                Some(h2) => meets_light_at(scene, h2, dir, sky, &mut light_rng),
                None => sky,
            };
            let points = [Some(h.p), h2.map(|h2| h2.p)];
            for q in points.into_iter().flatten() {
                lo = lo.min(q);
                hi = hi.max(q);
                if lit {
                    lit_lo = lit_lo.min(q);
                    lit_hi = lit_hi.max(q);
                }
            }
            lit_paths += lit as u32;
        }
    }
    let grow = |(lo, hi): (Vec3, Vec3)| {
        let margin = 0.01 * (hi - lo).length().max(1e-3);
        (lo - Vec3::splat(margin), hi + Vec3::splat(margin))
    };
    Probe { seen: grow((lo, hi)), lit: grow((lit_lo, lit_hi)), paths: n * n, lit_paths }
}

/// Whether the ray along `d` that reached `h` met light there: an emitter facing
/// it, or one of two light samples from `h` on the ray's side of the surface
/// that nothing blocks (a lamp above a ceiling lights its top, not the room), or
/// where the `sky` is not black, one of two cosine-distributed rays that escape.
fn meets_light_at(scene: &SceneArrays, h: &crate::math::geometry::Hit, d: Vec3, sky: bool, rng: &mut Rng) -> bool {
    use crate::math::geometry::{emitted, occluded, offset_origin, sample_light, shadow_ray};
    if emitted(scene, h.material, h.n, -d).max_element() > 0.0 {
        return true;
    }
    let side = if h.n.dot(d) < 0.0 { h.n } else { -h.n };
    let escapes = |u: [f32; 2]| {
        let w = Frame::from_normal(side).to_world(crate::math::sampling::cosine_hemisphere(u));
        intersect(scene, offset_origin(h.p, h.n, h.eps, w), w, f32::INFINITY).is_none()
    };
    if sky && (0..2).any(|_| escapes(rng.next_2d())) {
        return true;
    }
    (0..2).any(|_| {
        let u_sel = rng.next_f32();
        let Some(ls) = sample_light(scene, h.p, u_sel, rng.next_2d()) else { return false };
        if !(ls.le.max_element() > 0.0) || ls.wi.dot(h.n) * d.dot(h.n) >= 0.0 {
            return false;
        }
        let (o, dir, len) = shadow_ray(h.p, h.n, h.eps, &ls);
        !occluded(scene, o, dir, len, ls.skip)
    })
}
