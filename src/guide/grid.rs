//! The voxel grid over the scene whose cells are guiding's states, and the probe
//! of the scene that bounds it; `glsl/guide.glsl` `cell_index` is the GPU twin.

use super::*;
use crate::scene::GridKind;

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

    /// The grid of a scene: the `[guiding]` table where it says so; otherwise the
    /// box around the points that camera rays and their first diffuse bounce reach
    /// (so huge wall spheres do not stretch it), and 16 cells along its longest axis.
    pub fn for_scene(scene: &SceneArrays, settings: &GuidingSettings) -> Grid {
        let (min, max) = match (settings.bounds_min, settings.bounds_max) {
            (Some(a), Some(b)) => (a, b),
            _ => probe_bounds(scene),
        };
        let res = settings.resolution.unwrap_or_else(|| {
            let e = max - min;
            let longest = e.max_element();
            let n = |x: f32| ((16.0 * x / longest).round() as u32).clamp(1, 16);
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
    let p = &scene.params;
    let eye = Vec3::new(p.cam_position_near[0], p.cam_position_near[1], p.cam_position_near[2]);
    let (mut lo, mut hi) = (eye, eye);
    let n = 64u32;
    let mut rng = Rng::new(0x5eed, 0, 0, 0);
    let mut probe = p.to_owned();
    probe.width = n;
    probe.height = n;
    for y in 0..n {
        for x in 0..n {
            let (o, d) = crate::camera::camera_ray(&probe, x, y, rng.next_2d());
            let Some(h) = intersect(scene, o, d, f32::INFINITY) else { continue };
            lo = lo.min(h.p);
            hi = hi.max(h.p);
            let nrm = if h.n.dot(d) < 0.0 { h.n } else { -h.n };
            let dir = Frame::from_normal(nrm).to_world(crate::math::sampling::cosine_hemisphere(rng.next_2d()));
            let o2 = crate::math::geometry::offset_origin(h.p, h.n, h.eps, dir);
            if let Some(h2) = intersect(scene, o2, dir, f32::INFINITY) {
                lo = lo.min(h2.p);
                hi = hi.max(h2.p);
            }
        }
    }
    let margin = 0.01 * (hi - lo).length().max(1e-3);
    (lo - Vec3::splat(margin), hi + Vec3::splat(margin))
}
