//! The direction bins of guiding's table (equal-area rows and columns over the
//! sphere) and the six orientation classes of a sampling row; `glsl/guide.glsl`
//! is the GPU twin (`bin_index`, `bin_direction`, `normal_class`).

use super::*;

/// Equal-area direction bins: `rows` bands uniform in cos(theta) (z from +1 down
/// to -1) times `cols` sectors uniform in phi.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bins {
    pub rows: u32,
    pub cols: u32,
}

impl Bins {
    pub const OCTANT: Bins = Bins { rows: 2, cols: 4 };
    /// `--guiding sphere`'s bins in scenes without Russian roulette ([`default_bins`]).
    pub const SPHERE_DEFAULT: Bins = Bins { rows: 8, cols: 16 };
    /// `--guiding sphere`'s bins in scenes with Russian roulette ([`default_bins`]).
    pub const SPHERE_ROULETTE_DEFAULT: Bins = Bins { rows: 20, cols: 40 };

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
        row * self.cols + self.column(d.x, d.y)
    }

    /// The column of the azimuth phi = atan2(y, x) in [0, 2 pi): the sector
    /// `floor(phi cols / 2 pi)`. Where `cols` is a multiple of 4 (the octant's 4,
    /// the defaults 16 and 40), without the arctangent: (x, y) is turned back by whole
    /// quarter turns into the first quadrant, (u, v) with u, v >= 0, and the
    /// sector within it counted by the sides of its `cols / 4 - 1` inner edges
    /// (v cos t - u sin t >= 0 from edge angle t on). The same function up to
    /// rounding at the edges (where either bin's density will do); on the GPU
    /// the arctangent was most of the bin lookup that a guided vertex, and with
    /// learned roulette every vertex, pays. `glsl/guide.glsl` `bin_column`.
    pub fn column(&self, x: f32, y: f32) -> u32 {
        if !self.cols.is_multiple_of(4) {
            let mut phi = y.atan2(x);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            return ((phi * (0.5 / PI) * self.cols as f32) as u32).min(self.cols - 1);
        }
        let per_quadrant = self.cols / 4;
        // The quadrant q and (x, y) turned back by q quarter turns; the boundary
        // rays go with the quadrant they start (phi = 0, pi / 2, pi, 3 pi / 2).
        let (q, u, v) = match (y >= 0.0, x > 0.0) {
            (true, true) => (0, x, y),
            (true, false) => (1, y, -x),
            (false, false) => (2, -x, -y),
            (false, true) => (3, -y, x),
        };
        // u = 0 (v > 0): phi is the next quadrant's first edge. Only q = 1 and
        // 2 reach it (phi = pi and 3 pi / 2); the poles (0, 0) take column 0.
        if u <= 0.0 {
            return if v > 0.0 { (q + 1) * per_quadrant } else { 0 };
        }
        let inside = with_quadrant_edges(per_quadrant, |edges| {
            edges.iter().filter(|&&(s, c)| v * c - u * s >= 0.0).count() as u32
        });
        q * per_quadrant + inside
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
        Bins::check(rows, cols).map_err(|e| format!("`{s}`: {e}"))?;
        Ok(Bins { rows, cols })
    }

    /// Most bins a table may have. Finer tables learn too slowly to pay
    /// (docs/guiding.md, "The table"), and the bound keeps a row's 16-bit alias
    /// indices far from the marker [`UNLEARNED`].
    pub const MAX_COUNT: u64 = 1024;

    /// Whether `rows` x `cols` bins are a table the renderers can build: at least
    /// one of each, at most [`Bins::MAX_COUNT`] in all. The message says what was
    /// expected.
    pub fn check(rows: u32, cols: u32) -> Result<(), String> {
        if rows == 0 || cols == 0 || rows as u64 * cols as u64 > Bins::MAX_COUNT {
            return Err(format!("rows and columns must be at least 1, and at most {} bins in all", Bins::MAX_COUNT));
        }
        Ok(())
    }
}

/// The (sin t, cos t) of a quadrant's inner column edges, t = j pi / (2
/// `per_quadrant`) for j = 1 .. `per_quadrant`: [`Bins::column`]'s constants, which
/// the GPU folds at compile time (`GUIDE_COLS` is a specialization constant) and
/// the CPU computes once per column count (up to 32 a quadrant; past it, per call).
fn with_quadrant_edges<R>(per_quadrant: u32, f: impl FnOnce(&[(f32, f32)]) -> R) -> R {
    type Edges = std::sync::OnceLock<Box<[(f32, f32)]>>;
    const CACHED: usize = 33;
    static EDGES: [Edges; CACHED] = [const { Edges::new() }; CACHED];
    let edges = || {
        let step = 0.5 * PI / per_quadrant as f32;
        (1..per_quadrant).map(|j| (j as f32 * step).sin_cos()).collect::<Box<[_]>>()
    };
    match EDGES.get(per_quadrant as usize) {
        Some(cell) => f(cell.get_or_init(edges)),
        None => f(&edges()),
    }
}

/// Guided sampling distributions per cell: one for each class of surface
/// orientation, so that the cosine at the vertex can weight the bins. A vertex's
/// class is the signed axis its shading normal is closest to ([`normal_class`]);
/// the class's distribution weights each bin by the cosine between that axis and
/// the bin's centre. The class is a function of the vertex alone, so the sampled
/// directions and the pdf that weights them always come from the same distribution.
pub const NORMAL_CLASSES: u32 = shared::NORMAL_CLASSES;

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
/// after class: they depend on the bins alone, so [`build_sampling_rows`] takes them
/// computed once rather than once per cell.
pub fn class_cosines(bins: &Bins) -> Vec<f32> {
    (0..NORMAL_CLASSES)
        .flat_map(|class| (0..bins.count()).map(move |b| bin_cosine(bins, b, class_axis(class))))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Bins::column` without the arctangent is `floor(phi cols / 2 pi)`: for
    /// every direction away from a column's edge (by more than rounding), for
    /// column counts that take the quadrant form and for ones that do not; on the
    /// axes, phi = 0, pi / 2, pi and 3 pi / 2 start their columns, -0 as +0; the
    /// poles take a column in range (0 in the quadrant form).
    #[test]
    fn column_is_the_sector_of_the_azimuth() {
        for cols in [4u32, 8, 12, 16, 24, 32, 64, 5, 7] {
            let bins = Bins { rows: 1, cols };
            let mut rng = Rng::new(7, cols, 0, 0);
            let mut checked = 0;
            for _ in 0..100_000 {
                let phi = 2.0 * std::f64::consts::PI * rng.next_f32() as f64;
                let r = 0.05 + rng.next_f32() as f64;
                let (x, y) = ((r * phi.cos()) as f32, (r * phi.sin()) as f32);
                let exact = (y as f64).atan2(x as f64).rem_euclid(2.0 * std::f64::consts::PI);
                let sector = exact * cols as f64 / (2.0 * std::f64::consts::PI);
                if (sector - sector.round()).abs() < 1e-5 {
                    continue;
                }
                assert_eq!(bins.column(x, y), sector.floor() as u32, "cols {cols}, ({x}, {y}), sector {sector}");
                checked += 1;
            }
            assert!(checked > 99_000, "cols {cols}: {checked}");
            let axes = [((1.0, 0.0), 0), ((0.0, 1.0), cols / 4), ((-1.0, 0.0), cols / 2), ((0.0, -1.0), 3 * cols / 4)];
            if cols % 4 == 0 {
                for ((x, y), col) in axes {
                    assert_eq!(bins.column(x, y), col, "cols {cols}, ({x}, {y})");
                }
                assert_eq!(bins.column(1.0, -0.0), 0);
                assert_eq!(bins.column(-1.0, -0.0), cols / 2);
            }
            for (x, y) in [(0.0, 0.0), (-0.0, -0.0), (0.0, -0.0), (-0.0, 0.0)] {
                let col = bins.column(x, y);
                assert!(col < cols && (cols % 4 != 0 || col == 0), "cols {cols}, pole ({x}, {y}): {col}");
            }
        }
    }
}
