//! Learned guiding after Dahm & Keller, "Learning Light Transport the
//! Reinforced Way" (2017): the geometry of the Q-table, its learning and the
//! guided sampler.
//!
//! - **States** are the cells of a voxel [`Grid`] over the scene.
//! - **Actions** are [`Bins`] of directions over the whole sphere, equal in solid
//!   angle: rows uniform in cos(theta), columns uniform in phi (world space).
//! - **Q(cell, bin)** estimates the radiance arriving at the cell from the bin's
//!   directions (mean over RGB).
//! - **Learning**: when a path leaves x through bin a, reaches y and continues from
//!   y in the direction w it sampled there (weight f |cos| / pdf), Q(x, a) moves
//!   towards `Le(y -> x) + (f |cos| / pdf)(w) Q(y, bin(w))`, with learning rate
//!   1 / (1 + visits), so Q is the running mean of its targets. This target is the
//!   one-sample Monte Carlo estimate of Dahm & Keller's expected-SARSA target
//!   `Le(y) + integral Q(y, bin(w)) f(y; w -> x) |cos w| dw`: its expectation is
//!   that integral (over each bin, not only at its centre), so the running means
//!   converge to the same values while each update costs O(1) instead of one BSDF
//!   evaluation per bin. Delta vertices pass through the bin of the direction they
//!   chose. A frame's targets are summed per entry and folded in between frames
//!   ([`QTable::learn`]): the same running mean, taken in batches.
//! - **Sampling** at a non-delta vertex is a one-sample mixture: with probability
//!   `fraction` a bin is drawn from the cell's CDF for the vertex's orientation
//!   class (the signed axis nearest its shading normal, [`normal_class`]), in
//!   proportion to `(Q + floor * Qbar) cos(axis, bin)` (rebuilt after each frame;
//!   binary search), and a direction uniformly inside it; otherwise the BSDF is
//!   sampled. The mixture pdf weights the path and the MIS with light sampling, so
//!   the image stays unbiased, and no direction where the BSDF is non-zero gets pdf
//!   zero. Cells that have learned nothing use BSDF sampling alone. The cosine is
//!   that of the class axis, exact on axis-aligned walls; the BSDF's own lobe is
//!   left to the BSDF half of the mixture.
//! - **Russian roulette** with guiding keeps a path in proportion to its expected
//!   contribution, from the learned Q, relative to the pixel's estimate
//!   ([`crate::cpu::survival_probability`]).
//!
//! `glsl/guide.glsl` and `glsl/learn.comp` are the GPU twins.

use crate::math::geometry::intersect;
use crate::math::rng::Rng;
use crate::math::{Frame, Vec3};
use crate::prepared::PreparedScene;
use crate::scene::GuidingSettings;
use std::f32::consts::PI;

/// Which guiding, if any.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuidingMode {
    /// Plain path tracing.
    Off,
    /// 2 x 4 bins: exactly the eight octants of the seed.
    Octant,
    /// Finer bins over the sphere (default 8 x 16 = 128).
    Sphere,
}

impl GuidingMode {
    pub fn name(self) -> &'static str {
        match self {
            GuidingMode::Off => "off",
            GuidingMode::Octant => "octant",
            GuidingMode::Sphere => "sphere",
        }
    }
}

/// Equal-area direction bins: `rows` bands uniform in cos(theta) (z from +1 down
/// to -1) times `cols` sectors uniform in phi.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bins {
    pub rows: u32,
    pub cols: u32,
}

impl Bins {
    pub const OCTANT: Bins = Bins { rows: 2, cols: 4 };
    pub const SPHERE_DEFAULT: Bins = Bins { rows: 8, cols: 16 };

    pub fn count(&self) -> u32 {
        self.rows * self.cols
    }

    /// Solid angle of every bin.
    pub fn solid_angle(&self) -> f32 {
        4.0 * PI / self.count() as f32
    }

    /// The bin of a unit direction; `glsl/guide.glsl` `bin_index`.
    pub fn index(&self, d: Vec3) -> u32 {
        let row = (((1.0 - d.z) * 0.5 * self.rows as f32) as u32).min(self.rows - 1);
        let mut phi = d.y.atan2(d.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let col = ((phi * (0.5 / PI) * self.cols as f32) as u32).min(self.cols - 1);
        row * self.cols + col
    }

    /// A direction uniformly distributed in bin `b`; `glsl/guide.glsl` `bin_sample`.
    pub fn sample(&self, b: u32, u: [f32; 2]) -> Vec3 {
        let (row, col) = (b / self.cols, b % self.cols);
        let z = 1.0 - 2.0 * (row as f32 + u[0]) / self.rows as f32;
        let phi = 2.0 * PI * (col as f32 + u[1]) / self.cols as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// The direction at the centre of bin `b` (where the sampling weights are evaluated).
    pub fn center(&self, b: u32) -> Vec3 {
        self.sample(b, [0.5, 0.5])
    }

    /// Parses `ROWSxCOLS`, e.g. `8x16`.
    pub fn parse(s: &str) -> Result<Bins, String> {
        let (r, c) = s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}`: expected ROWSxCOLS, e.g. 8x16"))?;
        let rows: u32 = r.trim().parse().map_err(|_| format!("`{s}`: rows `{r}` is not a positive integer"))?;
        let cols: u32 = c.trim().parse().map_err(|_| format!("`{s}`: columns `{c}` is not a positive integer"))?;
        if rows == 0 || cols == 0 || rows * cols > 1024 {
            return Err(format!("`{s}`: rows and columns must be at least 1, and at most 1024 bins in all"));
        }
        Ok(Bins { rows, cols })
    }
}

/// The voxel grid whose cells are the states.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub min: Vec3,
    pub max: Vec3,
    pub res: [u32; 3],
}

impl Grid {
    pub fn cells(&self) -> u32 {
        self.res[0] * self.res[1] * self.res[2]
    }

    /// Cells per unit length along each axis.
    pub fn inv_cell_size(&self) -> Vec3 {
        Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32) / (self.max - self.min)
    }

    /// The cell containing `p`; points outside the box use the nearest cell.
    /// `glsl/guide.glsl` `cell_index`.
    pub fn cell(&self, p: Vec3) -> u32 {
        let g = (p - self.min) * self.inv_cell_size();
        let clampi = |v: f32, n: u32| (v.max(0.0) as u32).min(n - 1);
        let (x, y, z) = (clampi(g.x, self.res[0]), clampi(g.y, self.res[1]), clampi(g.z, self.res[2]));
        (z * self.res[1] + y) * self.res[0] + x
    }

    /// The grid of a scene: the `[guiding]` table where it says so; otherwise the
    /// box around the points that camera rays and their first diffuse bounce reach
    /// (so huge wall spheres do not stretch it), and 16 cells along its longest axis.
    pub fn for_scene(scene: &PreparedScene, settings: &GuidingSettings) -> Grid {
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
        Grid { min, max, res }
    }
}

/// The bounding box of the camera and of the surface points seen from it
/// directly and after one bounce, enlarged by 1% of its diagonal.
pub fn probe_bounds(scene: &PreparedScene) -> (Vec3, Vec3) {
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
            let (o, d) = crate::cpu::camera_ray(&probe, x, y, rng.next_2d());
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

/// Everything the guided sampler needs besides the table itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideConfig {
    pub mode: GuidingMode,
    pub bins: Bins,
    pub grid: Grid,
    /// Probability of guided sampling at a non-delta vertex.
    pub fraction: f32,
    /// Exploration floor: bins are sampled in proportion to `(Q + floor * mean Q of
    /// the cell) f |cos|`, so directions not yet learned keep some guided probability.
    pub floor: f32,
}

impl GuideConfig {
    pub fn entries(&self) -> usize {
        (self.grid.cells() * self.bins.count()) as usize
    }
}

/// Mean of the three channels: the scalar Q learns.
pub fn mean3(v: Vec3) -> f32 {
    (v.x + v.y + v.z) * (1.0 / 3.0)
}

/// Draws a direction from a cell's CDF row (`cdf[b]` = probability of bins 0..=b;
/// all zero where the cell has learned nothing): the bin by binary search with
/// `uc`, the direction uniformly inside it with `u`. `glsl/guide.glsl` `guided_sample`.
pub fn guided_sample(bins: &Bins, cdf: &[f32], uc: f32, u: [f32; 2]) -> Vec3 {
    // First bin whose cumulative probability exceeds uc (bins of zero width are never chosen).
    let (mut lo, mut hi) = (0usize, cdf.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if uc < cdf[mid] {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    bins.sample(lo as u32, u)
}

/// Solid-angle density of [`guided_sample`] for direction `dir`.
pub fn guided_pdf(bins: &Bins, cdf: &[f32], dir: Vec3) -> f32 {
    let b = bins.index(dir) as usize;
    let below = if b == 0 { 0.0 } else { cdf[b - 1] };
    (cdf[b] - below) / bins.solid_angle()
}

/// True when a cell's CDF row holds a distribution (it has learned something).
pub fn learned(cdf: &[f32]) -> bool {
    cdf.last().is_some_and(|&c| c > 0.0)
}

/// Guided sampling distributions per cell: one for each class of surface
/// orientation, so that the cosine at the vertex can weight the bins. A vertex's
/// class is the signed axis its shading normal is closest to ([`normal_class`]);
/// the class's distribution weights each bin by the cosine between that axis and
/// the bin's centre. The class is a function of the vertex alone, so the sampled
/// directions and the pdf evaluated for MIS always come from the same distribution.
pub const NORMAL_CLASSES: u32 = crate::shared::NORMAL_CLASSES;

/// The class of a unit normal: `2 * axis + (component < 0)` for the axis of its
/// largest component (ties go to the lower axis). `glsl/guide.glsl` `normal_class`.
pub fn normal_class(n: Vec3) -> u32 {
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + (n[axis as usize] < 0.0) as u32
}

/// The unit axis of a normal class.
pub fn class_axis(class: u32) -> Vec3 {
    let mut v = [0.0f32; 3];
    v[(class / 2) as usize] = if class.is_multiple_of(2) { 1.0 } else { -1.0 };
    Vec3::from_array(v)
}

/// The cosine weight of bin `b` for a class axis: the cosine at the bin's centre,
/// zero where it is below 1e-6 (so rounding cannot split a bin whose centre lies on
/// the horizon between CPU and GPU). `glsl/learn.comp` `bin_cosine`. Bins of a
/// `ROWSxCOLS` grid with even rows and columns divisible by four lie wholly on one
/// side of every axis plane.
pub fn bin_cosine(bins: &Bins, b: u32, axis: Vec3) -> f32 {
    let c = bins.center(b).dot(axis);
    if c > 1e-6 {
        c
    } else {
        0.0
    }
}

/// The cosine weights of every bin for every normal class ([`bin_cosine`]), class
/// after class: they depend on the bins alone, so [`build_cdf`] takes them
/// computed once rather than once per cell.
pub fn class_cosines(bins: &Bins) -> Vec<f32> {
    (0..NORMAL_CLASSES)
        .flat_map(|class| (0..bins.count()).map(move |b| bin_cosine(bins, b, class_axis(class))))
        .collect()
}

/// Index of the first entry of the CDF row for `cell` and normal `class` in a
/// table of `bins` bins per row. `glsl/guide.glsl` `cdf_row`.
pub fn cdf_row(cell: u32, class: u32, bins: u32) -> usize {
    ((cell * NORMAL_CLASSES + class) * bins) as usize
}

/// Builds a cell's sampling CDFs, one row of `q.len()` entries per normal class,
/// from its Q row and the bins' [`class_cosines`]: bin b of class c in proportion
/// to `(Q_b + floor * Qbar_c) cos_c(b)` where `Qbar_c` is the cosine-weighted mean
/// of Q over the class's hemisphere, so a share `floor / (1 + floor)` of the guided
/// probability is spread like the cosine and directions not yet learned keep some.
/// A class row is all zero where it has nothing to sample (no Q above its
/// horizon). `glsl/learn.comp` is the same.
pub fn build_cdf(cosines: &[f32], q: &[f32], floor: f32, cdf: &mut [f32]) {
    let n = q.len();
    for (cos, row) in cosines.chunks(n).zip(cdf.chunks_mut(n)) {
        let qc: f32 = q.iter().zip(cos).map(|(v, w)| v * w).sum();
        let c: f32 = cos.iter().sum();
        let q_floor = if c > 0.0 { floor * qc / c } else { 0.0 };
        let total = qc + q_floor * c;
        if !(total > 0.0) {
            row.fill(0.0);
            continue;
        }
        let mut acc = 0.0;
        let mut last = 0;
        for (b, ((r, &v), &w)) in row.iter_mut().zip(q).zip(cos).enumerate() {
            acc += (v + q_floor) * w;
            *r = acc / total;
            if w > 0.0 && v + q_floor > 0.0 {
                last = b;
            }
        }
        // Exactly 1 from the last bin with any weight on, whatever the rounding: every
        // uc in [0, 1) finds a bin, and bins of zero weight are never chosen.
        row[last..].fill(1.0);
    }
}

/// The learned table on the host (the CPU renderer's, and the GPU's when read back).
#[derive(Clone, Debug)]
pub struct QTable {
    /// Q per (cell, bin), cell-major.
    pub q: Vec<f32>,
    /// Targets folded into each entry so far.
    pub visits: Vec<u32>,
    /// Sampling CDFs, [`NORMAL_CLASSES`] rows per cell (see [`build_cdf`]).
    pub cdf: Vec<f32>,
}

/// One frame's targets, summed per entry.
#[derive(Clone, Debug)]
pub struct FrameSums {
    pub sums: Vec<f32>,
    pub counts: Vec<u32>,
}

impl FrameSums {
    pub fn new(entries: usize) -> FrameSums {
        FrameSums { sums: vec![0.0; entries], counts: vec![0; entries] }
    }
    pub fn add(&mut self, key: u32, target: f32) {
        self.sums[key as usize] += target;
        self.counts[key as usize] += 1;
    }
    pub fn merge(mut self, other: FrameSums) -> FrameSums {
        for (a, b) in self.sums.iter_mut().zip(other.sums) {
            *a += b;
        }
        for (a, b) in self.counts.iter_mut().zip(other.counts) {
            *a += b;
        }
        self
    }
}

impl QTable {
    pub fn new(entries: usize) -> QTable {
        QTable { q: vec![0.0; entries], visits: vec![0; entries], cdf: vec![0.0; entries * NORMAL_CLASSES as usize] }
    }

    /// Folds a frame's targets into the running means, Q <- (Q n + S) / (n + c)
    /// (the learning rate 1/(1 + visits) applied to each target in turn), then
    /// rebuilds the sampling CDFs. `glsl/learn.comp` is the same.
    pub fn learn(&mut self, cfg: &GuideConfig, frame: &FrameSums) {
        for i in 0..self.q.len() {
            let c = frame.counts[i];
            if c > 0 {
                let n = self.visits[i] as f32;
                self.q[i] = (self.q[i] * n + frame.sums[i]) / (n + c as f32);
                self.visits[i] += c;
            }
        }
        let n = cfg.bins.count() as usize;
        let cosines = class_cosines(&cfg.bins);
        for (q, cdf) in self.q.chunks(n).zip(self.cdf.chunks_mut(n * NORMAL_CLASSES as usize)) {
            build_cdf(&cosines, q, cfg.floor, cdf);
        }
    }
}
