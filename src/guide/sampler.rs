//! Sampling a direction from a cell's table: the alias rows, the guided density,
//! the one-sample mixture with the BSDF and the share glossy lobes take;
//! `glsl/guide.glsl` is the GPU twin.

use super::*;

/// Bytes of a table's sampling rows, the largest of its buffers: an [`AliasBin`]
/// per bin of each of the [`NORMAL_CLASSES`] rows of `cells` cells.
pub fn sampling_rows_bytes(cells: u32, bins: Bins) -> u64 {
    cells as u64 * NORMAL_CLASSES as u64 * bins.count() as u64 * std::mem::size_of::<AliasBin>() as u64
}

/// One bin of a guided sampling row: its column of the row's alias table
/// (Walker's alias method, built by Vose's algorithm) and its density.
///
/// Drawing a bin takes one load (and a second where the column passes to its
/// alias); evaluating the density of a direction takes one. `glsl/guide.glsl`
/// reads the same 8 bytes as a `uvec2`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AliasBin {
    /// `threshold << 16 | alias`: column `i` keeps bin `i` when its uniform
    /// number is below `threshold / 65535`, else gives `alias`. [`UNLEARNED`] in
    /// every bin of a row that has nothing to sample.
    pub column: u32,
    /// Solid-angle density of guided sampling in this bin: exactly the probability
    /// the alias table gives the bin (thresholds as stored), over the bin's solid angle.
    pub pdf: f32,
}

/// The column of every bin of a row with nothing to sample (no alias index
/// reaches 65535: rows have at most 1024 bins). `glsl/common.glsl`.
pub const UNLEARNED: u32 = shared::UNLEARNED;

/// Scale of the 16-bit thresholds. `glsl/common.glsl` `ALIAS_THRESHOLD_ONE`.
const THRESHOLD_ONE: u32 = shared::ALIAS_THRESHOLD_ONE;

/// Draws a direction from a sampling row ([`build_alias_row`]): the column
/// from `uc`, the bin by comparing the remainder with the column's threshold,
/// then a direction uniformly inside the bin with `u`. Its density is
/// [`guided_pdf`], a function of the direction alone, which is what the mixture
/// with BSDF sampling needs for either choice. `glsl/guide.glsl` `guided_direction`.
pub fn guided_direction(bins: &Bins, row: &[AliasBin], uc: f32, u: [f32; 2]) -> Vec3 {
    guided_direction_bin(bins, row, uc, u).0
}

/// [`guided_direction`] and the bin it drew the direction in, whose density is
/// the direction's ([`bin_pdf`]); the renderers read it instead of finding the
/// direction's bin again.
pub fn guided_direction_bin(bins: &Bins, row: &[AliasBin], uc: f32, u: [f32; 2]) -> (Vec3, u32) {
    let n = row.len();
    let x = uc * n as f32;
    let i = (x as usize).min(n - 1);
    let rest = x - i as f32;
    let column = row[i].column;
    let b = if rest * (THRESHOLD_ONE as f32) < (column >> 16) as f32 { i } else { (column & 0xffff) as usize } as u32;
    (bins.sample(b, u), b)
}

/// Solid-angle density of [`guided_direction`] for direction `dir`.
pub fn guided_pdf(bins: &Bins, row: &[AliasBin], dir: Vec3) -> f32 {
    bin_pdf(row, bins.index(dir))
}

/// Solid-angle density of [`guided_direction`] in bin `b` of the row.
pub fn bin_pdf(row: &[AliasBin], b: u32) -> f32 {
    row[b as usize].pdf
}

/// True when a sampling row holds a distribution (its cell has learned something).
pub fn learned(row: &[AliasBin]) -> bool {
    row.first().is_some_and(|e| e.column != UNLEARNED)
}

/// The share of the guided fraction that a vertex with BSDF `b` takes, in
/// [0, 1]: 1 on diffuse surfaces, the width of the lobe relative to the cosine
/// lobe's on glossy ones. The sampling rows are Q times the cosine, the product
/// with a diffuse BSDF; a glossy BSDF's lobe is not in them, and the narrower the
/// lobe the more guided directions miss it and carry little, while each BSDF
/// direction's weight grows by up to 1 / (1 - fraction) (its mixture density is
/// (1 - fraction) times the BSDF's plus the guided density): twice the variance
/// at the default 0.5 for no gain. The width is measured by the peak density of
/// the sampled directions, 1 / pi for the cosine lobe and 1 / (4 pi alpha^2) for
/// GGX reflection (D(n) / 4 at normal incidence), so the share is min(1, 4 alpha^2):
/// 0.25 at roughness 0.5, 1 from roughness 0.71 up; below 1/16 (roughness 0.354)
/// none ([`glossy_share`]), so seed-exp2's and exp3's copper (roughness 0.3, 4
/// alpha^2 = 0.032) and seed-exp3's gold (0.08, 0.00016) take none
/// (docs/guiding.md, "Glossy lobes"). The share is a function of the vertex alone
/// and the mixture density uses it wherever it is evaluated, so the estimate
/// stays unbiased.
/// `glsl/pathtrace.comp` `lobe_share`.
/// A conductor shares as a glossy lobe of its alpha. A rough dielectric takes no
/// guided directions: its lobes lie on both sides of the surface and the guiding
/// table's bins of one cell serve both sides' light alike. The coated material
/// takes them as diffuse (share 1): its base is Lambertian and its coat lobe is
/// still sampled by the BSDF's part of the mixture; over a conductor base it
/// shares as the base's GGX lobe.
pub fn lobe_share(b: &crate::math::bsdf::Bsdf) -> f32 {
    match b.kind {
        crate::scene::MaterialKind::Glossy | crate::scene::MaterialKind::Conductor => glossy_share(b.alpha),
        crate::scene::MaterialKind::RoughDielectric => 0.0,
        crate::scene::MaterialKind::Coated if b.has_conductor_base() => glossy_share(b.base_alpha),
        _ => 1.0,
    }
}

/// The share of the guided fraction at a glossy vertex of GGX width `alpha`:
/// 4 alpha^2, at most 1, and 0 below 1 / `GLOSSY_SHARE_MIN_INV` (1/16, roughness
/// below 0.354). Below it at most 1 direction in 32 would come from the table at
/// the default fraction, too few to find light the lobe misses, while the kernel
/// pays for such vertices with a second copy of the GGX evaluation, where the
/// mixture's density is computed: the host sets `SCENE_KIND_GUIDED_GLOSSY` only for
/// scenes with a glossy material at or above the bound ([`glossy_guided`]), and
/// without it the kernel leaves that copy out. Seed-exp2's copper (roughness 0.3)
/// and seed-exp3's gold (0.08) are below it. `glsl/pathtrace.comp` `glossy_share`
/// is the same arithmetic.
pub fn glossy_share(alpha: f32) -> f32 {
    let s = 4.0 * alpha * alpha;
    if s * (shared::GLOSSY_SHARE_MIN_INV as f32) < 1.0 {
        0.0
    } else {
        s.min(1.0)
    }
}

/// Whether a material takes guided directions as a glossy lobe ([`glossy_share`]
/// above zero), from its kernel record.
pub fn glossy_guided(m: &GpuMaterial) -> bool {
    let b = m.bsdf();
    b.kind == crate::scene::MaterialKind::Glossy && glossy_share(b.alpha) > 0.0
}

/// Fills one sampling row from non-negative bin weights (`row[b].pdf` holds the
/// weights on entry): Vose's alias-table construction, in place and in index
/// order so that `glsl/learn.comp` makes the same table. Each bin's density is
/// then read back from the table itself, so sampling and density agree exactly
/// whatever the rounding. A row whose weights sum to zero is marked [`UNLEARNED`].
pub fn build_alias_row(row: &mut [AliasBin]) {
    let n = row.len();
    let total: f32 = row.iter().map(|e| e.pdf).sum();
    if !(total > 0.0) {
        row.fill(AliasBin { column: UNLEARNED, pdf: 0.0 });
        return;
    }
    // Scaled weights (mean 1) in `pdf`; `column` UNLEARNED marks a column not yet set.
    let scale = n as f32 / total;
    for e in row.iter_mut() {
        e.pdf *= scale;
        e.column = UNLEARNED;
    }
    let open = |row: &[AliasBin], from: usize, small: bool| {
        (from..n).find(|&i| row[i].column == UNLEARNED && (row[i].pdf < 1.0) == small).unwrap_or(n)
    };
    // `s`: the small column being set; `next`: the scan for the small columns
    // of the start; `l`: the large bin that gives its excess to the small ones.
    let mut next = open(row, 0, true);
    let mut s = next;
    let mut l = open(row, 0, false);
    while s < n && l < n {
        let p = row[s].pdf;
        // Rounded up, so that a bin of any weight keeps some probability.
        let threshold = ((p * THRESHOLD_ONE as f32).ceil() as u32).min(THRESHOLD_ONE);
        row[s].column = threshold << 16 | l as u32;
        row[l].pdf = (row[l].pdf + p) - 1.0;
        if row[l].pdf < 1.0 {
            // The large bin has become small: its column is the next one to set.
            s = l;
            l = open(row, l + 1, false);
        } else {
            next = open(row, next + 1, true);
            s = next;
        }
    }
    // What is left is full (up to rounding): each such column keeps its own bin.
    for (i, e) in row.iter_mut().enumerate() {
        if e.column == UNLEARNED {
            e.column = THRESHOLD_ONE << 16 | i as u32;
        }
    }
    alias_densities(row);
}

/// Sets each bin's density to the probability the row's alias table gives it,
/// over the bin's solid angle (4 pi / n): `(threshold_b + sum over columns j
/// aliased to b of (1 - threshold_j)) / n / (4 pi / n)`, summed exactly in units
/// of 1 / THRESHOLD_ONE (the GPU's groups add them by atomics, in any order).
/// `glsl/learn.comp` `units_density`.
fn alias_densities(row: &mut [AliasBin]) {
    let mut units: Vec<u32> = row.iter().map(|e| e.column >> 16).collect();
    for (i, e) in row.iter().enumerate() {
        let a = (e.column & 0xffff) as usize;
        if a != i {
            units[a] += THRESHOLD_ONE - (e.column >> 16);
        }
    }
    for (e, u) in row.iter_mut().zip(units) {
        e.pdf = u as f32 / THRESHOLD_ONE as f32 * (1.0 / (4.0 * PI));
    }
}

/// Index of the first bin of the sampling row for `cell` and normal `class` in a
/// table of `bins` bins per row. `glsl/guide.glsl` `sampler_row`.
pub fn sampler_row(cell: u32, class: u32, bins: u32) -> usize {
    ((cell * NORMAL_CLASSES + class) * bins) as usize
}

/// Builds a cell's sampling rows, one of `q.len()` bins per normal class, from its
/// Q row and the bins' [`class_cosines`]: bin b of class c in proportion to
/// `(Q_b + floor * Qbar_c) cos_c(b)` where `Qbar_c` is the cosine-weighted mean
/// of Q over the class's hemisphere, so a share `floor / (1 + floor)` of the guided
/// probability is spread like the cosine and directions not yet learned keep some.
/// A class row is [`UNLEARNED`] where it has nothing to sample (no Q above its
/// horizon). Each row is an alias table ([`build_alias_row`]). `glsl/learn.comp`
/// is the same.
pub fn build_sampling_rows(cosines: &[f32], q: &[f32], floor: f32, rows: &mut [AliasBin]) {
    let n = q.len();
    for (cos, row) in cosines.chunks(n).zip(rows.chunks_mut(n)) {
        build_sampling_row(cos, q, floor, row);
    }
}

/// The block sizes (in bins along each side) that adaptive directions pool a
/// row's bins over, finest first: 1, then 2 and 4 where they divide both the
/// rows and the columns of `bins` (none beyond 1 where 2 does not).
pub fn pool_sizes(bins: &Bins) -> Vec<u32> {
    [1, 2, 4].into_iter().filter(|s| bins.rows.is_multiple_of(*s) && bins.cols.is_multiple_of(*s)).collect()
}

/// Adaptive directions: the Q that bin `b` of a cell's row weighs its sampling
/// density by. The bins' Q are estimated bin by bin, and a bin that has taken
/// few targets holds a noisy one; so each bin takes the visit-weighted mean Q of
/// the smallest block of [`pool_sizes`] around it whose entries have taken
/// `BIN_POOL_TARGETS` targets a bin, or of the largest block where none has. The
/// row refines where paths record many targets (where guided directions go: the
/// peaks of the distribution) and stays coarse where few go. The bins have equal
/// solid angles, so a block's mean Q is its mean radiance. Any weights make the
/// same unbiased estimate: only the density changes. `glsl/learn.comp` `pooled_q`
/// is the same, sum for sum.
pub fn pooled_q(bins: &Bins, sizes: &[u32], q: &[f32], visits: &[u32], b: u32) -> f32 {
    let (row, col) = (b / bins.cols, b % bins.cols);
    let largest = *sizes.last().expect("pool sizes start with 1");
    for &s in sizes {
        let (r0, c0) = (row / s * s, col / s * s);
        let mut n = 0u32;
        for r in r0..r0 + s {
            for c in c0..c0 + s {
                // Saturating: a long render's visits may pass u32 in a block's sum.
                n = n.saturating_add(visits[(r * bins.cols + c) as usize]);
            }
        }
        if n < shared::BIN_POOL_TARGETS * s * s && s != largest {
            continue;
        }
        if s == 1 {
            return q[b as usize];
        }
        let mut nq = 0.0f32;
        for r in r0..r0 + s {
            for c in c0..c0 + s {
                let i = (r * bins.cols + c) as usize;
                nq += visits[i] as f32 * q[i];
            }
        }
        return if n > 0 { nq / n as f32 } else { 0.0 };
    }
    unreachable!("the largest size returns")
}

/// One class's row of [`build_sampling_rows`], from that class's bin cosines `cos`.
pub fn build_sampling_row(cos: &[f32], q: &[f32], floor: f32, row: &mut [AliasBin]) {
    let qc: f32 = q.iter().zip(cos).map(|(v, w)| v * w).sum();
    let c: f32 = cos.iter().sum();
    let q_floor = if c > 0.0 { floor * qc / c } else { 0.0 };
    for ((e, &v), &w) in row.iter_mut().zip(q).zip(cos) {
        e.pdf = (v + q_floor) * w;
    }
    build_alias_row(row);
}

/// The density of the one-sample mixture at a vertex that mixes: guided sampling
/// with probability `g_frac`, the BSDF otherwise. It weights the path and the MIS
/// with light sampling alike (`crate::cpu` `light_sample`, `mixture_sample`); `glsl/guide.glsl`
/// `mixture_pdf` is the same arithmetic.
pub fn mixture_pdf(g_frac: f32, p_bsdf: f32, p_guided: f32) -> f32 {
    (1.0 - g_frac) * p_bsdf + g_frac * p_guided
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bin keeps its own Q where it has taken `BIN_POOL_TARGETS` targets; else
    /// it takes the visit-weighted mean of its 2x2 block where that block has
    /// taken as many a bin, else of its 4x4 block, whatever that has taken.
    #[test]
    fn a_bin_takes_the_q_of_the_smallest_block_that_has_learned_enough() {
        let bins = Bins { rows: 4, cols: 8 };
        assert_eq!(pool_sizes(&bins), [1, 2, 4]);
        assert_eq!(pool_sizes(&Bins { rows: 6, cols: 10 }), [1, 2]);
        assert_eq!(pool_sizes(&Bins { rows: 9, cols: 13 }), [1]);
        let k = shared::BIN_POOL_TARGETS;
        let n = bins.count() as usize;
        let (mut q, mut v) = (vec![0.0f32; n], vec![0u32; n]);
        let at = |r: u32, c: u32| (r * bins.cols + c) as usize;
        // Bin (0, 0) has learned enough; its 2x2 block as a whole too.
        (q[at(0, 0)], v[at(0, 0)]) = (8.0, k);
        (q[at(0, 1)], v[at(0, 1)]) = (2.0, 3 * k);
        (q[at(1, 0)], v[at(1, 0)]) = (4.0, 0);
        (q[at(1, 1)], v[at(1, 1)]) = (1.0, 1);
        let sizes = pool_sizes(&bins);
        let pooled = |q: &[f32], v: &[u32], b: usize| pooled_q(&bins, &sizes, q, v, b as u32);
        assert_eq!(pooled(&q, &v, at(0, 0)), 8.0);
        assert_eq!(pooled(&q, &v, at(0, 1)), 2.0);
        let block = (8.0 * k as f32 + 2.0 * 3.0 * k as f32 + 1.0) / (4 * k + 1) as f32;
        assert_eq!(pooled(&q, &v, at(1, 0)), block);
        assert_eq!(pooled(&q, &v, at(1, 1)), block);
        // The next 2x2 block has taken too few, all in one bin: that bin keeps its
        // Q, the others take the 4x4 block's mean.
        (q[at(0, 2)], v[at(0, 2)]) = (100.0, 4 * k - 1);
        assert_eq!(pooled(&q, &v, at(0, 2)), 100.0);
        let wide = (8.0 * k as f32 + 2.0 * 3.0 * k as f32 + 1.0 + 100.0 * (4 * k - 1) as f32) / (8 * k) as f32;
        for (r, c) in [(0, 3), (1, 3), (3, 3)] {
            assert_eq!(pooled(&q, &v, at(r, c)), wide, "({r}, {c})");
        }
        // A 4x4 block that has taken nothing stays at zero.
        assert_eq!(pooled(&q, &v, at(2, 5)), 0.0);
        // Without blocks each bin keeps its Q.
        assert_eq!(pooled_q(&bins, &[1], &q, &v, at(1, 0) as u32), 4.0);
        // A block's visits past u32 saturate rather than wrap (or panic).
        v[at(3, 0)] = u32::MAX - 1;
        (q[at(3, 1)], v[at(3, 1)]) = (5.0, 2);
        for (r, c) in [(2, 1), (3, 1)] {
            assert_eq!(pooled(&q, &v, at(r, c)), 5.0 * 2.0 / u32::MAX as f32, "({r}, {c})");
        }
    }
}
