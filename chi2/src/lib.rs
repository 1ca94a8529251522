//! Chi-square goodness-of-fit test for direction samplers.
//!
//! A sampler draws `N` directions on the unit sphere (some draws may fail:
//! absorbed, below the horizon, ...; those are `None`), and a `pdf` function
//! claims to give the solid-angle density of those draws.  The test checks the
//! claim the way pbrt-v4 (`src/pbrt/bsdfs_test.cpp`, `Chi2Test`) and Mitsuba 3
//! (`mitsuba/python/chi2.py`, `ChiSquareTest`) do:
//!
//! 1. The sphere is cut into `theta_bins x phi_bins` cells of equal extent in
//!    `theta = acos(z)` and `phi = atan2(y, x)` (`z` is the normal axis), and
//!    the samples are counted per cell (the *observed* frequencies).
//! 2. The pdf is integrated numerically over every cell and multiplied by `N`
//!    (the *expected* frequencies).  The failed draws form one more cell with
//!    expected frequency `N * (1 - integral of the pdf)`, used when that is at
//!    least `min_expected` (as Mitsuba does).
//! 3. Cells are sorted by expected frequency and the smallest are pooled until
//!    each pooled cell expects at least `min_expected` samples (the chi-square
//!    approximation needs that).  The statistic is
//!    `sum (observed - expected)^2 / expected` over the `k` resulting cells,
//!    with `k - 1` degrees of freedom (nothing is fitted), and the p-value is
//!    the chi-square upper tail [`gamma_q`]`(dof / 2, statistic / 2)`.
//!
//! Two gross errors are reported in [`Chi2Outcome::message`] and make the test
//! fail whatever the p-value: samples in a cell where the pdf integrates to
//! zero, and a pdf whose integral differs from the fraction of successful
//! samples by more than 5 binomial standard deviations (the sampler and the pdf
//! disagree on the probability that a draw succeeds).  Non-finite or negative
//! pdf values and samples that are not finite unit vectors are reported too.
//!
//! # Integration
//!
//! With a million samples a bin that expects 10^5 of them has a noise of 0.3%,
//! so the expected frequencies must be much more accurate than that, also for
//! very peaked lobes (GGX with alpha = 1e-4, whose peak is 1e-4 radians wide).
//! The integrand is `pdf(dir(theta, phi)) * sin(theta)` over `(theta, phi)`.
//! Each bin starts as an `integration_resolution^2` grid of cells, each with a
//! 5x5-node Simpson rule whose difference from the 3x3 rule on the same cell
//! is a (conservative) error estimate.  The bin is then refined *globally
//! adaptively* (as QUADPACK / `cubature` do): the cell with the largest error
//! is split, in `theta`, in `phi` or both, whichever the partial rules say
//! resolves the error, until the bin's summed error is below 1% of its Poisson
//! noise and below 1e-7 of its mass (at most `MAX_SPLITS` splits per bin).
//!
//! A peak narrower than the node spacing can hide from every node, so a cell
//! that holds clearly more samples than its estimate allows is split first,
//! towards where its samples are (the samples only steer where the quadrature
//! refines; a converged integral does not depend on them).  A lobe that
//! neither the nodes nor the samples see is not found, but then it carries
//! no observable mass.  Nodes on a bin's boundary are moved 1e-7 of the bin
//! size inside it, so that a pdf that jumps on a bin edge (the horizon of a
//! hemispherical pdf with an even `theta_bins`) is integrated on the right
//! side of the jump.  A bin whose integral did not converge is reported.
//!
//! On two cores a test of 10^6 samples takes ~0.1-0.3 s for a cheap pdf
//! (a few 10^5 to 10^6 pdf evaluations).

use rayon::prelude::*;
use std::f64::consts::PI;
use std::fmt;

/// Outcome of a goodness-of-fit test.
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    pub statistic: f64,
    pub degrees_of_freedom: usize,
    pub p_value: f64,
    /// Integral of the pdf over the sphere (numerical); should be ~ the fraction of successful samples.
    pub pdf_integral: f64,
    /// Fraction of samples that succeeded.
    pub success_fraction: f64,
    /// Human-readable explanation when the test fails (or is inconclusive), empty when fine.
    pub message: String,
}

impl Chi2Outcome {
    /// True when the null hypothesis ("the samples follow the pdf") is not
    /// rejected at level `significance` and nothing else went wrong
    /// (`message` is empty).  With several tests, pass [`sidak`]`(alpha, n)`.
    pub fn passed(&self, significance: f64) -> bool {
        self.p_value >= significance && self.message.is_empty()
    }
}

impl fmt::Display for Chi2Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "chi2 = {:.4} with {} dof, p = {:.4e}, pdf integral = {:.8}, success fraction = {:.8}",
            self.statistic, self.degrees_of_freedom, self.p_value, self.pdf_integral, self.success_fraction
        )?;
        if !self.message.is_empty() {
            write!(f, "\n{}", self.message)?;
        }
        Ok(())
    }
}

/// Sidak-corrected significance for one of `num_tests` independent tests, so
/// that the probability of at least one false failure is `significance`:
/// `1 - (1 - significance)^(1 / num_tests)`.
pub fn sidak(significance: f64, num_tests: usize) -> f64 {
    let n = num_tests.max(1) as f64;
    // -expm1(ln(1 - s) / n), accurate for small significances.
    -((-significance).ln_1p() / n).exp_m1()
}

/// Options of [`chi2_sphere`].
#[derive(Clone, Debug)]
pub struct Chi2Options {
    /// Bins in `theta` over `[0, pi]` (keep it even so that the horizon is a bin edge).
    pub theta_bins: usize,
    /// Bins in `phi` over `[0, 2 pi)`.
    pub phi_bins: usize,
    /// Cells expecting fewer samples than this are pooled.
    pub min_expected: f64,
    /// Each bin starts as `integration_resolution^2` quadrature cells (5x5
    /// Simpson nodes each), refined adaptively from there.
    pub integration_resolution: usize,
}

impl Default for Chi2Options {
    /// 10 x 20 bins (pbrt-v4's `bsdfs_test` uses the same; bins of 18 degrees
    /// square keep ~5000 samples per bin at 10^6 samples, so a 5% density error
    /// in one bin is a 3.5 sigma effect), the usual `min_expected` of 5, and an
    /// 8x8 starting grid per bin (nodes every 1.1 degrees: most lobes are seen
    /// by the nodes, the rest is found through the samples).
    fn default() -> Self {
        Chi2Options { theta_bins: 10, phi_bins: 20, min_expected: 5.0, integration_resolution: 8 }
    }
}

/// A bin is integrated until its summed error estimate, in expected samples,
/// is below `REL_TOL * sqrt(expected)` (1% of its Poisson noise) ...
const REL_TOL: f64 = 0.01;
/// ... and below `MASS_TOL * expected` (so that the pdf integral is accurate), ...
const MASS_TOL: f64 = 1e-7;
/// ... or below this many expected samples.
const ABS_TOL: f64 = 1e-3;
/// Quadrature cells are split at most this many times below the starting grid
/// (an 18-degree bin / 8 / 2^24 is 2e-9 radians).
const MAX_DEPTH: u32 = 24;
/// At most this many cell splits per bin (pathological pdfs, wrong samplers).
const MAX_SPLITS: usize = 5000;
/// Quadrature nodes stay this fraction of the bin size inside the bin.
const EDGE_NUDGE: f64 = 1e-7;
/// A bin whose pdf mass is below this (expected count below `1e-12 * N`)
/// counts as a zero-pdf bin: samples there fail the test.
const ZERO_MASS: f64 = 1e-12;
/// Samples whose length differs from 1 by more than this are reported.
const UNIT_TOLERANCE: f64 = 1e-3;
/// At most this many zero-pdf bins are listed in the message.
const MAX_LISTED_BINS: usize = 5;

/// Chi-square test of `samples` against the solid-angle density `pdf`.
///
/// Bins `samples` (unit vectors, `[x, y, z]`, `z` is the "up"/normal axis:
/// `theta = acos(z)`, `phi = atan2(y, x)` in `[0, 2 pi)`) and compares counts
/// with expected counts from integrating `pdf` over each `(theta, phi)` bin.
/// `None` is a failed sample: it counts toward `N` but not to any bin; the
/// failures form one more cell expecting `N * (1 - pdf_integral)` samples,
/// included when that is at least `min_expected`.  See the module
/// documentation for the method and its references.
pub fn chi2_sphere(
    samples: &[Option<[f64; 3]>],
    pdf: impl Fn([f64; 3]) -> f64 + Sync,
    opts: &Chi2Options,
) -> Chi2Outcome {
    let theta_bins = opts.theta_bins.max(1);
    let phi_bins = opts.phi_bins.max(1);
    let resolution = opts.integration_resolution.max(1);
    let d_theta = PI / theta_bins as f64;
    let d_phi = 2.0 * PI / phi_bins as f64;
    let n = samples.len();
    let n_f = n as f64;
    let mut messages: Vec<String> = Vec::new();

    // --- Observed frequencies -------------------------------------------------
    let mut bins: Vec<Vec<(f64, f64)>> = vec![Vec::new(); theta_bins * phi_bins];
    let mut first_in_bin: Vec<Option<[f64; 3]>> = vec![None; theta_bins * phi_bins];
    let mut failures = 0usize;
    let mut bad_samples = 0usize;
    let mut first_bad_sample: Option<(usize, [f64; 3])> = None;
    for (index, sample) in samples.iter().enumerate() {
        let Some(d) = *sample else {
            failures += 1;
            continue;
        };
        let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let usable = length.is_finite() && length > 0.0;
        if !usable || (length - 1.0).abs() > UNIT_TOLERANCE {
            bad_samples += 1;
            first_bad_sample.get_or_insert((index, d));
            if !usable {
                continue;
            }
        }
        let (theta, phi) = spherical(d);
        let i = ((theta / d_theta) as usize).min(theta_bins - 1);
        let j = ((phi / d_phi) as usize).min(phi_bins - 1);
        bins[i * phi_bins + j].push((theta, phi));
        first_in_bin[i * phi_bins + j].get_or_insert(d);
    }
    if n == 0 {
        messages.push("no samples".to_string());
    }
    if let Some((index, d)) = first_bad_sample {
        messages.push(format!(
            "{bad_samples} sample(s) are not finite unit vectors (e.g. sample #{index} = {})",
            fmt_dir(d)
        ));
    }

    // --- Expected frequencies (parallel over bins) ------------------------------
    let results: Vec<BinResult> = bins
        .into_par_iter()
        .enumerate()
        .map(|(b, mut points)| {
            let theta0 = (b / phi_bins) as f64 * d_theta;
            let phi0 = (b % phi_bins) as f64 * d_phi;
            let mut integrator = Integrator {
                pdf: &pdf,
                n: n_f.max(1.0),
                theta_range: (0.0, PI),
                phi_range: (0.0, 2.0 * PI),
                bad_value: None,
            };
            let observed = points.len();
            let (mass, error) = integrator.bin((theta0, d_theta), (phi0, d_phi), resolution, &mut points);
            BinResult { observed, mass, error, bad_value: integrator.bad_value }
        })
        .collect();

    if let Some((d, v)) = results.iter().find_map(|r| r.bad_value) {
        messages.push(format!("pdf returned {v} (must be finite and >= 0) at direction {}", fmt_dir(d)));
    }

    if let Some((b, r)) =
        results.iter().enumerate().find(|(_, r)| r.error > 0.25 * (n_f * r.mass).max(0.0).sqrt() + 0.5)
    {
        messages.push(format!(
            "numerical integration of the pdf did not converge in {}: estimated error {:.3} of {:.3} expected samples; the test is unreliable",
            bin_name(b, phi_bins, d_theta, d_phi),
            r.error,
            n_f * r.mass
        ));
    }

    let pdf_integral: f64 = results.iter().map(|r| r.mass).sum();
    let integration_error: f64 = results.iter().map(|r| r.error).sum();
    let successes = n - failures;
    let success_fraction = if n > 0 { successes as f64 / n_f } else { 0.0 };

    // --- Cells, zero-pdf hits -------------------------------------------------
    let zero_count = ZERO_MASS * n_f;
    let mut cells: Vec<(f64, f64)> = Vec::with_capacity(results.len() + 1);
    let mut zero_hits: Vec<usize> = Vec::new();
    for (b, r) in results.iter().enumerate() {
        let expected = n_f * r.mass;
        if expected <= zero_count {
            if r.observed > 0 {
                zero_hits.push(b);
            }
        } else {
            cells.push((r.observed as f64, expected));
        }
    }
    if !zero_hits.is_empty() {
        let total: usize = zero_hits.iter().map(|&b| results[b].observed).sum();
        let mut text = format!("{total} sample(s) landed where the pdf is zero, in {} bin(s):", zero_hits.len());
        for &b in zero_hits.iter().take(MAX_LISTED_BINS) {
            text += &format!(
                "\n  {}: {} sample(s), pdf integral {:.3e}, e.g. direction {}",
                bin_name(b, phi_bins, d_theta, d_phi),
                results[b].observed,
                results[b].mass,
                fmt_dir(first_in_bin[b].unwrap_or([f64::NAN; 3])),
            );
        }
        if zero_hits.len() > MAX_LISTED_BINS {
            text += &format!("\n  ... and {} more bin(s)", zero_hits.len() - MAX_LISTED_BINS);
        }
        messages.push(text);
    }
    let expected_failures = (n_f * (1.0 - pdf_integral)).max(0.0);
    if expected_failures >= opts.min_expected && expected_failures > zero_count {
        cells.push((failures as f64, expected_failures));
    }

    // --- Success probability: pdf integral vs. fraction of successes ----------
    if n > 0 {
        let p = pdf_integral.clamp(0.0, 1.0);
        let sigma = ((p * (1.0 - p)).max(1.0 / n_f) / n_f).sqrt();
        let difference = pdf_integral - success_fraction;
        if difference.abs() > 5.0 * sigma + integration_error / n_f {
            messages.push(format!(
                "the pdf integrates to {pdf_integral:.6} over the sphere but {success_fraction:.6} of the samples succeeded \
                 (difference {difference:.3e} = {:.1} sigma): pdf and sampler disagree on the probability that a sample succeeds",
                difference / sigma
            ));
        }
    }

    // --- Statistic ------------------------------------------------------------
    let pooled = pool_cells(cells, opts.min_expected);
    let statistic: f64 = pooled.iter().map(|&(observed, expected)| (observed - expected).powi(2) / expected).sum();
    let degrees_of_freedom = pooled.len().saturating_sub(1);
    let p_value = if degrees_of_freedom == 0 {
        if n > 0 {
            messages.push(format!(
                "inconclusive: the expected samples fill only {} cell(s) of at least {} samples; use finer bins or more samples",
                pooled.len(),
                opts.min_expected
            ));
        }
        1.0
    } else {
        gamma_q(0.5 * degrees_of_freedom as f64, 0.5 * statistic)
    };

    Chi2Outcome { statistic, degrees_of_freedom, p_value, pdf_integral, success_fraction, message: messages.join("\n") }
}

/// A magnifying glass for lobes narrower than a bin: a bijection of the sphere that
/// spreads the neighbourhood of `center` over most of it, so that [`chi2_sphere`]'s
/// bins of 18 degrees resolve a lobe a fraction of a degree wide (GGX at roughness
/// 0.05) instead of pooling it into one. The sphere is projected stereographically
/// from the point opposite `center`, the plane scaled by `k`, and projected back
/// (a conformal map: a circle of angle theta around `center` goes to one of angle
/// 2 atan(k tan(theta / 2))). Samples go through [`Zoom::sample`], and the density
/// of the zoomed samples is [`Zoom::pdf`]: the original pdf at the preimage times
/// the map's area ratio, d omega / d omega' = (1 + P'^2)^2 / (k^2 (1 + P'^2 / k^2)^2)
/// for the zoomed point's projection P'. Failed samples (`None`) stay failed, so
/// the test of the success probability is unchanged.
#[derive(Clone, Copy, Debug)]
pub struct Zoom {
    /// Orthonormal frame `[t, b, n]`, `n` = the centre.
    frame: [[f64; 3]; 3],
    k: f64,
}

impl Zoom {
    /// Zoom by `k` (> 0; above 1 magnifies) around the unit vector `center`.
    pub fn new(center: [f64; 3], k: f64) -> Zoom {
        let n = normalized(center);
        let a = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let t = normalized(cross(a, n));
        let b = cross(n, t);
        Zoom { frame: [t, b, n], k }
    }

    /// Where the direction `d` goes.
    pub fn sample(&self, d: [f64; 3]) -> [f64; 3] {
        self.map(d, self.k)
    }

    /// The density of zoomed samples at the zoomed direction `d`, from `pdf`, the
    /// density of the samples before the zoom.
    pub fn pdf(&self, pdf: impl Fn([f64; 3]) -> f64, d: [f64; 3]) -> f64 {
        let l = self.local(d);
        let p2 = (l[0] * l[0] + l[1] * l[1]) / ((1.0 + l[2]) * (1.0 + l[2]));
        if !p2.is_finite() {
            return 0.0; // the point opposite the centre: measure zero
        }
        let k2 = self.k * self.k;
        let ratio = (1.0 + p2) * (1.0 + p2) / (k2 * (1.0 + p2 / k2) * (1.0 + p2 / k2));
        pdf(self.map(d, 1.0 / self.k)) * ratio
    }

    fn local(&self, d: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| dot(self.frame[i], d))
    }

    /// Scales the stereographic projection of `d` about the centre by `k`.
    fn map(&self, d: [f64; 3], k: f64) -> [f64; 3] {
        let l = self.local(d);
        let (px, py) = (k * l[0] / (1.0 + l[2]), k * l[1] / (1.0 + l[2]));
        let p2 = px * px + py * py;
        let m = if p2.is_finite() {
            [2.0 * px / (1.0 + p2), 2.0 * py / (1.0 + p2), (1.0 - p2) / (1.0 + p2)]
        } else {
            [0.0, 0.0, -1.0]
        };
        let f = &self.frame;
        std::array::from_fn(|i| f[0][i] * m[0] + f[1][i] * m[1] + f[2][i] * m[2])
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalized(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// `(theta, phi)` of a nonzero vector, `theta` in `[0, pi]`, `phi` in `[0, 2 pi)`.
fn spherical(d: [f64; 3]) -> (f64, f64) {
    let theta = d[0].hypot(d[1]).atan2(d[2]);
    let mut phi = d[1].atan2(d[0]);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    if phi >= 2.0 * PI {
        phi = 0.0;
    }
    (theta, phi)
}

fn bin_name(b: usize, phi_bins: usize, d_theta: f64, d_phi: f64) -> String {
    let (i, j) = ((b / phi_bins) as f64, (b % phi_bins) as f64);
    format!(
        "bin theta [{:.1}, {:.1}] deg x phi [{:.1}, {:.1}] deg",
        (i * d_theta).to_degrees(),
        ((i + 1.0) * d_theta).to_degrees(),
        (j * d_phi).to_degrees(),
        ((j + 1.0) * d_phi).to_degrees()
    )
}

fn fmt_dir(d: [f64; 3]) -> String {
    format!("[{:.6}, {:.6}, {:.6}]", d[0], d[1], d[2])
}

/// Pools `(observed, expected)` cells Mitsuba-style: sorted by expected
/// frequency, the smallest are merged until the merged cell expects at least
/// `min_expected`; a remainder that never gets there joins the last cell.
fn pool_cells(mut cells: Vec<(f64, f64)>, min_expected: f64) -> Vec<(f64, f64)> {
    cells.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut pooled: Vec<(f64, f64)> = Vec::with_capacity(cells.len());
    let (mut observed, mut expected) = (0.0, 0.0);
    let mut pending = false;
    for (o, e) in cells {
        observed += o;
        expected += e;
        pending = true;
        if expected >= min_expected {
            pooled.push((observed, expected));
            (observed, expected, pending) = (0.0, 0.0, false);
        }
    }
    if pending {
        match pooled.last_mut() {
            Some(last) => {
                last.0 += observed;
                last.1 += expected;
            }
            None => pooled.push((observed, expected)),
        }
    }
    pooled
}

struct BinResult {
    observed: usize,
    /// Integral of the pdf over the bin.
    mass: f64,
    /// Estimated absolute error of `mass`, in expected samples.
    error: f64,
    bad_value: Option<([f64; 3], f64)>,
}

/// 3x3 Simpson rule on a unit square.
fn simpson(v: &[[f64; 3]; 3]) -> f64 {
    const W: [f64; 3] = [1.0, 4.0, 1.0];
    let mut sum = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            sum += W[i] * W[j] * v[i][j];
        }
    }
    sum / 36.0
}

/// The 3x3 sub-grid of a 5x5 node grid on rows `r` and columns `c`.
fn sub_grid(v: &[[f64; 5]; 5], r: [usize; 3], c: [usize; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| v[r[i]][c[j]]))
}

const LOW: [usize; 3] = [0, 1, 2];
const HIGH: [usize; 3] = [2, 3, 4];
const ALL: [usize; 3] = [0, 2, 4];

/// Moves the elements satisfying `pred` to the front; returns their number.
fn partition<T>(items: &mut [T], pred: impl Fn(&T) -> bool) -> usize {
    let mut k = 0;
    for i in 0..items.len() {
        if pred(&items[i]) {
            items.swap(i, k);
            k += 1;
        }
    }
    k
}

/// How to split a cell whose samples the quadrature has not found: along the
/// direction(s) in which the samples are unevenly spread (a lobe at the pole
/// is uniform in phi, and splitting it in phi too would multiply cells).
fn split_towards_samples(points: &[(f64, f64)], t_mid: f64, p_mid: f64) -> Split {
    let count = points.len().max(1) as f64;
    let low_theta = points.iter().filter(|p| p.0 < t_mid).count() as f64;
    let low_phi = points.iter().filter(|p| p.1 < p_mid).count() as f64;
    let theta_imbalance = (low_theta / count - 0.5).abs();
    let phi_imbalance = (low_phi / count - 0.5).abs();
    if phi_imbalance < 0.5 * theta_imbalance {
        Split::Theta
    } else if theta_imbalance < 0.5 * phi_imbalance {
        Split::Phi
    } else {
        Split::Both
    }
}

/// How a quadrature cell is best split.
#[derive(Clone, Copy)]
enum Split {
    Theta,
    Phi,
    Both,
}

/// A quadrature cell `[t0, t0 + h] x [p0, p0 + w]` with its 5x5 Simpson nodes.
struct Cell {
    t0: f64,
    h: f64,
    p0: f64,
    w: f64,
    nodes: [[f64; 5]; 5],
    /// Its samples: `points[start..end]` of the bin.
    start: usize,
    end: usize,
    depth: u32,
    /// Integral estimate (Richardson-extrapolated Simpson).
    mass: f64,
    /// Conservative error estimate: |5x5 rule - 3x3 rule|.
    error: f64,
    split: Split,
    /// Holds clearly more samples than its estimate allows: a peak between the nodes.
    unexplained: bool,
}

/// Heap entry: cells with unexplained samples first, then by error.
struct Queued {
    unexplained: bool,
    error: f64,
    index: usize,
}

impl PartialEq for Queued {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Queued {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.unexplained.cmp(&other.unexplained).then(self.error.total_cmp(&other.error))
    }
}

/// Globally adaptive 2-D Simpson quadrature of `pdf(dir(theta, phi)) * sin(theta)`
/// over one bin.
struct Integrator<'a, F> {
    pdf: &'a F,
    /// Number of samples: tolerances are in expected samples.
    n: f64,
    /// Bin bounds; nodes are kept `EDGE_NUDGE` of the bin size inside them.
    theta_range: (f64, f64),
    phi_range: (f64, f64),
    /// First non-finite or negative pdf value met, with its direction.
    bad_value: Option<([f64; 3], f64)>,
}

impl<F: Fn([f64; 3]) -> f64> Integrator<'_, F> {
    fn integrand(&mut self, theta: f64, phi: f64) -> f64 {
        // A pdf that jumps on a bin edge (a hemisphere's horizon) must be
        // evaluated on the bin's side of the edge.
        let (t_lo, t_hi) = self.theta_range;
        let (p_lo, p_hi) = self.phi_range;
        let t_eps = EDGE_NUDGE * (t_hi - t_lo);
        let p_eps = EDGE_NUDGE * (p_hi - p_lo);
        let theta = theta.clamp(t_lo + t_eps, t_hi - t_eps);
        let phi = phi.clamp(p_lo + p_eps, p_hi - p_eps);
        let (sin_theta, cos_theta) = theta.sin_cos();
        let (sin_phi, cos_phi) = phi.sin_cos();
        let d = [sin_theta * cos_phi, sin_theta * sin_phi, cos_theta];
        let value = (self.pdf)(d);
        if !(value.is_finite() && value >= 0.0) {
            self.bad_value.get_or_insert((d, value));
            return 0.0;
        }
        value * sin_theta
    }

    /// Evaluates the cell whose 3x3 Simpson nodes are `coarse`.
    fn cell(
        &mut self,
        (t0, h): (f64, f64),
        (p0, w): (f64, f64),
        coarse: [[f64; 3]; 3],
        (start, end): (usize, usize),
        depth: u32,
    ) -> Cell {
        let mut nodes = [[0.0; 5]; 5];
        for (a, row) in nodes.iter_mut().enumerate() {
            for (b, value) in row.iter_mut().enumerate() {
                *value = if a % 2 == 0 && b % 2 == 0 {
                    coarse[a / 2][b / 2]
                } else {
                    self.integrand(t0 + 0.25 * h * a as f64, p0 + 0.25 * w * b as f64)
                };
            }
        }
        let area = h * w;
        let coarse_rule = simpson(&coarse) * area;
        let theta_halves = (simpson(&sub_grid(&nodes, LOW, ALL)) + simpson(&sub_grid(&nodes, HIGH, ALL))) * 0.5 * area;
        let phi_halves = (simpson(&sub_grid(&nodes, ALL, LOW)) + simpson(&sub_grid(&nodes, ALL, HIGH))) * 0.5 * area;
        let fine_rule =
            [LOW, HIGH].iter().flat_map(|&r| [LOW, HIGH].map(|c| simpson(&sub_grid(&nodes, r, c)))).sum::<f64>()
                * 0.25
                * area;

        let difference = fine_rule - coarse_rule;
        // Richardson extrapolation (Simpson's error is O(h^4)); it can only go
        // negative on badly resolved cells, keep the plain estimate there.
        let extrapolated = fine_rule + difference / 15.0;
        let mass = if extrapolated >= 0.0 { extrapolated } else { fine_rule };
        let expected = self.n * fine_rule;
        let count = (end - start) as f64;
        let unexplained = count > 1.5 * expected + 5.0 * expected.sqrt() + 10.0;
        // Split only along the direction that resolves the error, when clear.
        let (theta_error, phi_error) = ((theta_halves - coarse_rule).abs(), (phi_halves - coarse_rule).abs());
        let split = if phi_error <= 0.25 * theta_error {
            Split::Theta
        } else if theta_error <= 0.25 * phi_error {
            Split::Phi
        } else {
            Split::Both
        };
        Cell { t0, h, p0, w, nodes, start, end, depth, mass, error: difference.abs(), split, unexplained }
    }

    /// Integral over the bin `[theta0, theta0 + d_theta] x [phi0, phi0 + d_phi]`
    /// holding `points` (`(theta, phi)` of its samples); returns the integral and
    /// its error estimate in expected samples.
    ///
    /// Starts from a `resolution x resolution` grid and keeps splitting the
    /// cell with the largest error (cells with unexplained samples first) until
    /// the summed error is below `REL_TOL * sqrt(expected)` samples.
    fn bin(
        &mut self,
        (theta0, d_theta): (f64, f64),
        (phi0, d_phi): (f64, f64),
        resolution: usize,
        points: &mut [(f64, f64)],
    ) -> (f64, f64) {
        self.theta_range = (theta0, theta0 + d_theta);
        self.phi_range = (phi0, phi0 + d_phi);
        let h = d_theta / resolution as f64;
        let w = d_phi / resolution as f64;
        // Counting sort of the points into the starting grid.
        let cell_of = |p: &(f64, f64)| {
            let i = (((p.0 - theta0) / h) as usize).min(resolution - 1);
            let j = (((p.1 - phi0) / w) as usize).min(resolution - 1);
            i * resolution + j
        };
        let mut start = vec![0usize; resolution * resolution + 1];
        for p in points.iter() {
            start[cell_of(p) + 1] += 1;
        }
        for c in 0..resolution * resolution {
            start[c + 1] += start[c];
        }
        let mut sorted = vec![(0.0, 0.0); points.len()];
        let mut next = start.clone();
        for p in points.iter() {
            let c = cell_of(p);
            sorted[next[c]] = *p;
            next[c] += 1;
        }

        let mut cells: Vec<Cell> = Vec::with_capacity(4 * resolution * resolution);
        for i in 0..resolution {
            for j in 0..resolution {
                let t0 = theta0 + i as f64 * h;
                let p0 = phi0 + j as f64 * w;
                let coarse: [[f64; 3]; 3] = std::array::from_fn(|a| {
                    std::array::from_fn(|b| self.integrand(t0 + 0.5 * h * a as f64, p0 + 0.5 * w * b as f64))
                });
                let c = i * resolution + j;
                cells.push(self.cell((t0, h), (p0, w), coarse, (start[c], start[c + 1]), 0));
            }
        }
        let mut mass: f64 = cells.iter().map(|c| c.mass).sum();
        let mut error: f64 = cells.iter().map(|c| c.error).sum();
        let mut queue: std::collections::BinaryHeap<Queued> = cells
            .iter()
            .enumerate()
            .map(|(index, c)| Queued { unexplained: c.unexplained, error: c.error, index })
            .collect();

        let mut splits = 0;
        while let Some(top) = queue.pop() {
            let expected = self.n * mass.max(0.0);
            let tolerance = (REL_TOL * expected.sqrt()).min(MASS_TOL * expected).max(ABS_TOL) / self.n;
            if (!top.unexplained && error <= tolerance) || splits >= MAX_SPLITS {
                break;
            }
            let cell = &cells[top.index];
            if cell.depth >= MAX_DEPTH {
                continue; // stays as it is (its error still counts)
            }
            splits += 1;
            let (t0, h, p0, w, depth) = (cell.t0, cell.h, cell.p0, cell.w, cell.depth + 1);
            let (nodes, range) = (cell.nodes, (cell.start, cell.end));
            mass -= cell.mass;
            error -= cell.error;
            let points = &mut sorted[range.0..range.1];
            let (t_mid, p_mid) = (t0 + 0.5 * h, p0 + 0.5 * w);
            let split = if cell.unexplained { split_towards_samples(points, t_mid, p_mid) } else { cell.split };
            let mut children: Vec<Cell> = Vec::with_capacity(4);
            match split {
                Split::Theta => {
                    let k = range.0 + partition(points, |p| p.0 < t_mid);
                    children.push(self.cell((t0, 0.5 * h), (p0, w), sub_grid(&nodes, LOW, ALL), (range.0, k), depth));
                    children.push(self.cell(
                        (t_mid, 0.5 * h),
                        (p0, w),
                        sub_grid(&nodes, HIGH, ALL),
                        (k, range.1),
                        depth,
                    ));
                }
                Split::Phi => {
                    let k = range.0 + partition(points, |p| p.1 < p_mid);
                    children.push(self.cell((t0, h), (p0, 0.5 * w), sub_grid(&nodes, ALL, LOW), (range.0, k), depth));
                    children.push(self.cell(
                        (t0, h),
                        (p_mid, 0.5 * w),
                        sub_grid(&nodes, ALL, HIGH),
                        (k, range.1),
                        depth,
                    ));
                }
                Split::Both => {
                    let k = partition(points, |p| p.0 < t_mid);
                    let (low, high) = points.split_at_mut(k);
                    let k_low = range.0 + partition(low, |p| p.1 < p_mid);
                    let k_high = range.0 + k + partition(high, |p| p.1 < p_mid);
                    let k = range.0 + k;
                    let quadrants = [
                        (t0, p0, LOW, LOW, (range.0, k_low)),
                        (t0, p_mid, LOW, HIGH, (k_low, k)),
                        (t_mid, p0, HIGH, LOW, (k, k_high)),
                        (t_mid, p_mid, HIGH, HIGH, (k_high, range.1)),
                    ];
                    for (t, p, r, c, sub_range) in quadrants {
                        children.push(self.cell((t, 0.5 * h), (p, 0.5 * w), sub_grid(&nodes, r, c), sub_range, depth));
                    }
                }
            }
            for child in children {
                mass += child.mass;
                error += child.error;
                queue.push(Queued { unexplained: child.unexplained, error: child.error, index: cells.len() });
                cells.push(child);
            }
            // A split replaces its cell: mark the old entry dead.
            cells[top.index].mass = 0.0;
            cells[top.index].error = 0.0;
        }
        // Sum afresh (the running sums drift); split cells hold zeros.
        let (mass, error) = cells.iter().fold((0.0, 0.0), |(m, e), c| (m + c.mass, e + c.error));
        (mass, self.n * error)
    }
}

// --- Incomplete gamma function -------------------------------------------------

/// Regularised upper incomplete gamma function `Q(a, x) = Gamma(a, x) / Gamma(a)`.
///
/// The chi-square p-value of statistic `s` with `k` degrees of freedom is
/// `gamma_q(k / 2, s / 2)`.  Series for `P = 1 - Q` when `x < a + 1`, Lentz's
/// continued fraction for `Q` otherwise (Numerical Recipes, 6.2), with the
/// prefactor `x^a e^-x / Gamma(a)` computed from Stirling's series so that it
/// stays accurate (~1e-13 relative) for large `a`.  Relative accuracy ~1e-12
/// for `a` in `[0.5, 1e4]`.  `NaN` for `a <= 0` or `NaN` arguments.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if a.is_nan() || x.is_nan() || a <= 0.0 {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x == f64::INFINITY {
        return 0.0;
    }
    if x < a + 1.0 {
        1.0 - gamma_p_series(a, x)
    } else {
        gamma_q_continued_fraction(a, x)
    }
}

const GAMMA_MAX_ITERATIONS: usize = 1_000_000;

/// `ln(x^a e^-x / Gamma(a))`.
fn ln_gamma_prefactor(a: f64, x: f64) -> f64 {
    if a >= 10.0 {
        // a ln x - x - ln Gamma(a), with ln Gamma(a) from Stirling's series:
        // = a (ln(1 + t) - t) + ln(a) / 2 - ln(2 pi) / 2 - stirling_remainder(a),
        // t = (x - a) / a, free of the cancellation between a ln x and ln Gamma(a).
        let t = (x - a) / a;
        a * (t.ln_1p() - t) + 0.5 * a.ln() - 0.5 * (2.0 * PI).ln() - stirling_remainder(a)
    } else {
        a * x.ln() - x - ln_gamma(a)
    }
}

/// `ln Gamma(a) - ((a - 1/2) ln a - a + ln(2 pi) / 2)` for `a >= 10`.
fn stirling_remainder(a: f64) -> f64 {
    let r = 1.0 / a;
    let r2 = r * r;
    r * (1.0 / 12.0
        + r2 * (-1.0 / 360.0
            + r2 * (1.0 / 1260.0
                + r2 * (-1.0 / 1680.0 + r2 * (1.0 / 1188.0 + r2 * (-691.0 / 360360.0 + r2 * (1.0 / 156.0)))))))
}

/// `ln Gamma(a)` for `a > 0`: Stirling's series after shifting `a` to `>= 10`.
fn ln_gamma(a: f64) -> f64 {
    let mut shifted = a;
    let mut product = 1.0;
    while shifted < 10.0 {
        product *= shifted;
        shifted += 1.0;
    }
    (shifted - 0.5) * shifted.ln() - shifted + 0.5 * (2.0 * PI).ln() + stirling_remainder(shifted) - product.ln()
}

/// `P(a, x)` by its power series (converges quickly for `x < a + 1`).
fn gamma_p_series(a: f64, x: f64) -> f64 {
    let mut denominator = a;
    let mut term = 1.0 / a;
    let mut sum = term;
    for _ in 0..GAMMA_MAX_ITERATIONS {
        denominator += 1.0;
        term *= x / denominator;
        sum += term;
        if term < sum * 1e-17 {
            break;
        }
    }
    sum * ln_gamma_prefactor(a, x).exp()
}

/// `Q(a, x)` by its continued fraction, modified Lentz (converges for `x > a + 1`).
fn gamma_q_continued_fraction(a: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / TINY;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..GAMMA_MAX_ITERATIONS {
        let i = i as f64;
        let an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < TINY {
            d = TINY;
        }
        c = b + an / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    (ln_gamma_prefactor(a, x).exp() * h).clamp(0.0, 1.0)
}

#[cfg(test)]
#[allow(clippy::excessive_precision)] // reference values quoted as mpmath printed them
mod tests {
    use super::*;

    /// splitmix64: small, deterministic, good enough for these tests.
    struct Rng(u64);

    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }

        /// Uniform in [0, 1).
        fn uniform(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
        }
    }

    const N: usize = 1_000_000;
    const ALPHA: f64 = 0.01;

    fn draw(seed: u64, mut sampler: impl FnMut(&mut Rng) -> Option<[f64; 3]>) -> Vec<Option<[f64; 3]>> {
        let mut rng = Rng(seed);
        (0..N).map(|_| sampler(&mut rng)).collect()
    }

    fn dir(theta: f64, phi: f64) -> [f64; 3] {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        [st * cp, st * sp, ct]
    }

    fn uniform_sphere(rng: &mut Rng) -> [f64; 3] {
        let z = 1.0 - 2.0 * rng.uniform();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * rng.uniform();
        [r * phi.cos(), r * phi.sin(), z]
    }

    fn cosine_hemisphere(rng: &mut Rng) -> [f64; 3] {
        let u = rng.uniform();
        let r = u.sqrt();
        let phi = 2.0 * PI * rng.uniform();
        [r * phi.cos(), r * phi.sin(), (1.0 - u).sqrt()]
    }

    fn cosine_pdf(d: [f64; 3]) -> f64 {
        d[2].max(0.0) / PI
    }

    /// GGX normal distribution times cos(theta_h): pdf of `ggx_sample`.
    fn ggx_pdf(alpha: f64, d: [f64; 3]) -> f64 {
        if d[2] <= 0.0 {
            return 0.0;
        }
        let a2 = alpha * alpha;
        // (n.h)^2 (a^2 - 1) + 1 = z^2 a^2 + (x^2 + y^2) for a unit vector.
        let denominator = d[2] * d[2] * a2 + d[0] * d[0] + d[1] * d[1];
        a2 / (PI * denominator * denominator) * d[2]
    }

    fn ggx_sample(alpha: f64, rng: &mut Rng) -> [f64; 3] {
        let u = rng.uniform();
        let theta = (alpha * (u / (1.0 - u)).sqrt()).atan();
        dir(theta, 2.0 * PI * rng.uniform())
    }

    /// Orthonormal frame `[t, b, n]` around `n = dir(theta, phi)`.
    fn frame(theta: f64, phi: f64) -> [[f64; 3]; 3] {
        let n = dir(theta, phi);
        let t = dir(theta + 0.5 * PI, phi);
        let b = [n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]];
        [t, b, n]
    }

    fn to_world(f: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| f[0][k] * v[0] + f[1][k] * v[1] + f[2][k] * v[2])
    }

    fn to_local(f: &[[f64; 3]; 3], w: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| f[k][0] * w[0] + f[k][1] * w[1] + f[k][2] * w[2])
    }

    fn assert_rel(actual: f64, expected: f64, tolerance: f64) {
        let rel = ((actual - expected) / expected).abs();
        assert!(rel <= tolerance, "{actual:e} vs {expected:e}: relative error {rel:e}");
    }

    #[test]
    fn chi2_gamma_q_closed_forms() {
        for x in [1e-6, 0.01, 0.5, 1.0, 2.0, 5.0, 20.0, 100.0, 600.0] {
            assert_rel(gamma_q(1.0, x), (-x).exp(), 1e-12);
            // Q(2, x) = (1 + x) e^-x.
            assert_rel(gamma_q(2.0, x), (1.0 + x) * (-x).exp(), 1e-12);
        }
        // Q(1/2, x) = erfc(sqrt x): erfc(0.5), erfc(1), erfc(2), erfc(3).
        assert_rel(gamma_q(0.5, 0.25), 0.479_500_122_186_953_46, 1e-12);
        assert_rel(gamma_q(0.5, 1.0), 0.157_299_207_050_285_13, 1e-12);
        assert_rel(gamma_q(0.5, 4.0), 0.004_677_734_981_047_265_8, 1e-12);
        assert_rel(gamma_q(0.5, 9.0), 2.209_049_699_858_544_1e-5, 1e-12);
        assert_eq!(gamma_q(3.0, 0.0), 1.0);
        assert_eq!(gamma_q(3.0, f64::INFINITY), 0.0);
        assert!(gamma_q(0.0, 1.0).is_nan());
    }

    #[test]
    fn chi2_gamma_q_reference_values() {
        // (a, x, Q) from mpmath.gammainc(a, x, inf, regularized=True), 40 digits.
        let table = [
            (0.5, 30.0, 9.485_737_571_073_848_388_5e-15),
            (0.5, 1e-8, 0.999_887_162_083_666_575_13),
            (1.5, 2.0, 0.261_464_129_949_110_622_2),
            (2.5, 0.1, 0.999_113_861_211_187_557_39),
            (3.0, 1e-3, 0.999_999_999_833_458_283_35),
            (5.0, 20.0, 1.694_474_393_006_738_390_4e-5),
            (50.0, 40.0, 0.929_664_933_340_605_045_56),
            (50.0, 70.0, 0.005_140_502_458_505_893_899_5),
            (100.0, 100.0, 0.486_701_201_720_851_335_14),
            (500.0, 480.0, 0.813_718_026_809_675_399_34),
            (1000.0, 1100.0, 0.001_059_323_253_929_977_348_9),
            (1000.0, 1300.0, 1.873_615_571_578_555_124_2e-18),
            (5000.0, 5000.0, 0.498_119_365_966_182_644_65),
            (10000.0, 9800.0, 0.977_792_456_186_030_306_14),
            (10000.0, 10500.0, 4.275_872_455_059_669_269_2e-7),
            (10000.0, 11000.0, 1.692_853_149_646_932_757_7e-22),
        ];
        for (a, x, q) in table {
            let rel = ((gamma_q(a, x) - q) / q).abs();
            assert!(rel < 1e-10, "Q({a}, {x}) = {:e}, expected {q:e} (rel {rel:e})", gamma_q(a, x));
        }
        // Chi-square tables: p-values of 0.05.
        assert!((gamma_q(0.5, 3.84 / 2.0) - 0.050_043_521_248_705_1).abs() < 1e-12);
        assert!((gamma_q(5.0, 18.307 / 2.0) - 0.050_000_589_091_398_1).abs() < 1e-12);
        assert!((gamma_q(100.0, 233.99 / 2.0) - 0.050_019_837_650_025).abs() < 1e-12);
    }

    #[test]
    fn chi2_sidak_and_pooling() {
        assert!((sidak(0.01, 1) - 0.01).abs() < 1e-15);
        assert!((sidak(0.05, 10) - 0.005_116_196_891_823_3).abs() < 1e-12);
        // 1 - (1 - s)^n recovers s.
        assert!((1.0 - (1.0 - sidak(0.01, 7)).powi(7) - 0.01).abs() < 1e-12);

        // Sorted by expected count 1, 2, 3, 4, 10: 1 + 2 + 3 reaches 5, then 4 + 10.
        let pooled = pool_cells(vec![(10.0, 10.0), (2.0, 2.0), (1.0, 1.0), (4.0, 4.0), (3.0, 3.0)], 5.0);
        assert_eq!(pooled, vec![(6.0, 6.0), (14.0, 14.0)]);
        // Large cells stay alone; observed counts follow their cells.
        let pooled = pool_cells(vec![(7.0, 8.0), (1.0, 1.0), (0.0, 0.5), (9.0, 9.0)], 5.0);
        assert_eq!(pooled, vec![(8.0, 9.5), (9.0, 9.0)]);
        // A remainder below min_expected joins the last pooled cell.
        let pooled = pool_cells(vec![(2.0, 3.0), (4.0, 3.0), (1.0, 3.0)], 5.0);
        assert_eq!(pooled, vec![(7.0, 9.0)]);
        // Everything together below min_expected: one cell.
        let pooled = pool_cells(vec![(2.0, 1.0), (0.0, 2.0)], 5.0);
        assert_eq!(pooled, vec![(2.0, 3.0)]);
    }

    #[test]
    fn chi2_uniform_sphere_passes() {
        let samples = draw(1, |rng| Some(uniform_sphere(rng)));
        let outcome = chi2_sphere(&samples, |_| 0.25 / PI, &Chi2Options::default());
        assert!(outcome.passed(ALPHA), "{outcome}");
        assert_eq!(outcome.degrees_of_freedom, 199);
        assert!((outcome.pdf_integral - 1.0).abs() < 1e-9, "{outcome}");
    }

    #[test]
    fn chi2_cosine_hemisphere_passes() {
        let samples = draw(2, |rng| Some(cosine_hemisphere(rng)));
        let outcome = chi2_sphere(&samples, cosine_pdf, &Chi2Options::default());
        assert!(outcome.passed(ALPHA), "{outcome}");
        assert!((outcome.pdf_integral - 1.0).abs() < 1e-9, "{outcome}");
        // Odd theta_bins: the horizon (where the pdf has a kink) cuts through bins.
        let options = Chi2Options { theta_bins: 9, ..Default::default() };
        let outcome = chi2_sphere(&samples, cosine_pdf, &options);
        assert!(outcome.passed(ALPHA), "{outcome}");
        assert!((outcome.pdf_integral - 1.0).abs() < 1e-7, "{outcome}");
    }

    #[test]
    fn chi2_cosine_against_uniform_hemisphere_fails() {
        let samples = draw(3, |rng| Some(cosine_hemisphere(rng)));
        let uniform_hemisphere = |d: [f64; 3]| if d[2] > 0.0 { 0.5 / PI } else { 0.0 };
        let outcome = chi2_sphere(&samples, uniform_hemisphere, &Chi2Options::default());
        assert!(!outcome.passed(ALPHA), "{outcome}");
        assert!(outcome.p_value < 1e-100, "{outcome}");
        // The shapes differ but both integrate to one.
        assert!(outcome.message.is_empty(), "{outcome}");
    }

    #[test]
    fn chi2_failed_samples() {
        let samples = draw(4, |rng| {
            let absorbed = rng.uniform() < 0.1;
            let d = uniform_sphere(rng);
            (!absorbed).then_some(d)
        });
        let scaled = chi2_sphere(&samples, |_| 0.9 * 0.25 / PI, &Chi2Options::default());
        assert!(scaled.passed(ALPHA), "{scaled}");
        assert!((scaled.success_fraction - 0.9).abs() < 0.002);
        // Failure cell included: 200 bins + 1 cell - 1.
        assert_eq!(scaled.degrees_of_freedom, 200);

        let unscaled = chi2_sphere(&samples, |_| 0.25 / PI, &Chi2Options::default());
        assert!(!unscaled.passed(ALPHA), "{unscaled}");
        assert!(unscaled.message.contains("disagree on the probability"), "{unscaled}");
    }

    fn check_ggx(alpha: f64, seed: u64) {
        let samples = draw(seed, |rng| Some(ggx_sample(alpha, rng)));
        let outcome = chi2_sphere(&samples, |d| ggx_pdf(alpha, d), &Chi2Options::default());
        assert!(outcome.passed(ALPHA), "alpha {alpha}: {outcome}");
        assert!((outcome.pdf_integral - 1.0).abs() < 1e-6, "alpha {alpha}: {outcome}");
    }

    #[test]
    fn chi2_ggx_alpha_0_05_passes() {
        check_ggx(0.05, 5);
    }

    #[test]
    fn chi2_ggx_alpha_1e_4_passes() {
        check_ggx(1e-4, 6);
    }

    #[test]
    fn chi2_ggx_alpha_0_09_passes() {
        check_ggx(0.09, 17);
    }

    /// A GGX lobe tilted to `(theta, phi)`: peaks between quadrature nodes.
    fn check_tilted_ggx(alpha: f64, theta: f64, phi: f64, seed: u64) -> Chi2Outcome {
        let f = frame(theta, phi);
        let samples = draw(seed, |rng| Some(to_world(&f, ggx_sample(alpha, rng))));
        chi2_sphere(&samples, |w| ggx_pdf(alpha, to_local(&f, w)), &Chi2Options::default())
    }

    #[test]
    fn chi2_tilted_ggx_peaks_pass() {
        // Peak on a bin corner (on quadrature nodes): four bins share the lobe.
        let outcome = check_tilted_ggx(1e-3, 0.3 * PI, 0.5 * PI, 8);
        assert!(outcome.passed(ALPHA), "{outcome}");
        assert!(outcome.degrees_of_freedom >= 3, "{outcome}");
        // Peak 2 alpha off a theta edge, off the nodes in phi: two bins, and the
        // lobe is far narrower than the node spacing (found through the samples).
        let outcome = check_tilted_ggx(1e-4, 0.3 * PI + 2e-4, 1.234, 9);
        assert!(outcome.passed(ALPHA), "{outcome}");
        assert!(outcome.degrees_of_freedom >= 1, "{outcome}");
        assert!((outcome.pdf_integral - 1.0).abs() < 1e-6, "{outcome}");
    }

    /// Calibration (slow, run by hand with `cargo test --lib chi2 -- --ignored
    /// --nocapture`): for correct samplers the p-values must be uniform on
    /// [0, 1]; prints the Kolmogorov-Smirnov distance of 30 p-values per case.
    #[test]
    #[ignore]
    fn chi2_p_values_are_uniform_for_correct_samplers() {
        let seeds = 30u64;
        let critical = 1.36 / (seeds as f64).sqrt(); // KS, 5%
        let check = |name: &str, f: &dyn Fn(u64) -> Chi2Outcome| {
            let start = std::time::Instant::now();
            let mut p: Vec<f64> = (0..seeds)
                .map(|s| {
                    let outcome = f(1000 + s);
                    assert!(outcome.message.is_empty(), "{name}: {outcome}");
                    outcome.p_value
                })
                .collect();
            p.sort_by(f64::total_cmp);
            let ks = (0..p.len())
                .map(|i| (p[i] - i as f64 / p.len() as f64).max((i + 1) as f64 / p.len() as f64 - p[i]))
                .fold(0.0, f64::max);
            eprintln!(
                "{name}: KS distance {ks:.3} (5% critical {critical:.3}), min p {:.2e}, {:.2} s/test",
                p[0],
                start.elapsed().as_secs_f64() / seeds as f64
            );
            assert!(ks < critical, "{name}: p-values not uniform: {p:?}");
        };
        let options = Chi2Options::default();
        check("uniform sphere", &|s| chi2_sphere(&draw(s, |r| Some(uniform_sphere(r))), |_| 0.25 / PI, &options));
        check("cosine", &|s| chi2_sphere(&draw(s, |r| Some(cosine_hemisphere(r))), cosine_pdf, &options));
        check("10% failures", &|s| {
            let samples = draw(s, |r| {
                let absorbed = r.uniform() < 0.1;
                let d = uniform_sphere(r);
                (!absorbed).then_some(d)
            });
            chi2_sphere(&samples, |_| 0.9 * 0.25 / PI, &options)
        });
        for alpha in [1e-4, 1e-3, 0.05, 0.09, 0.3] {
            check(&format!("GGX alpha {alpha}"), &|s| {
                chi2_sphere(&draw(s, |r| Some(ggx_sample(alpha, r))), |d| ggx_pdf(alpha, d), &options)
            });
        }
        check("tilted GGX 1e-3 on a corner", &|s| check_tilted_ggx(1e-3, 0.3 * PI, 0.5 * PI, s));
        check("tilted GGX 1e-4 by an edge", &|s| check_tilted_ggx(1e-4, 0.3 * PI + 2e-4, 1.234, s));
        check("tilted GGX 0.2", &|s| check_tilted_ggx(0.2, 1.1, 4.0, s));
    }

    /// The zoom resolves a lobe far narrower than a bin: GGX alpha 1e-3 tilted, with
    /// hundreds of degrees of freedom; and there a width 3 % off fails, which the
    /// plain bins cannot see. The zoom is a bijection: a zoomed uniform sphere
    /// follows the zoomed uniform density.
    #[test]
    fn chi2_zoom_resolves_narrow_lobes() {
        let f = frame(1.0, 2.0);
        let center = f[2];
        let alpha = 1e-3;
        let samples = draw(12, |rng| Some(to_world(&f, ggx_sample(alpha, rng))));
        let zoom = Zoom::new(center, 0.5 / alpha);
        let zoomed: Vec<_> = samples.iter().map(|s| s.map(|d| zoom.sample(d))).collect();
        let options = Chi2Options::default();
        let right = chi2_sphere(&zoomed, |d| zoom.pdf(|w| ggx_pdf(alpha, to_local(&f, w)), d), &options);
        assert!(right.passed(ALPHA), "{right}");
        assert!(right.degrees_of_freedom > 100, "{right}");
        let wrong = |d| zoom.pdf(|w| ggx_pdf(1.03 * alpha, to_local(&f, w)), d);
        let outcome = chi2_sphere(&zoomed, wrong, &options);
        assert!(!outcome.passed(ALPHA), "a 3% wider lobe is seen: {outcome}");
        let plain = chi2_sphere(&samples, |w| ggx_pdf(1.03 * alpha, to_local(&f, w)), &options);
        assert!(!plain.message.is_empty() || plain.p_value > ALPHA, "without the zoom it is not: {plain}");

        let uniform = draw(13, |rng| Some(zoom.sample(uniform_sphere(rng))));
        let outcome = chi2_sphere(&uniform, |d| zoom.pdf(|_| 0.25 / PI, d), &options);
        assert!(outcome.passed(ALPHA), "{outcome}");
        assert!((outcome.pdf_integral - 1.0).abs() < 1e-6, "{outcome}");
    }

    #[test]
    fn chi2_lobe_inside_one_bin_is_inconclusive() {
        let f = frame(1.0, 2.0);
        let mut rng = Rng(10);
        let samples: Vec<_> = (0..10_000).map(|_| Some(to_world(&f, ggx_sample(1e-3, &mut rng)))).collect();
        let outcome = chi2_sphere(&samples, |w| ggx_pdf(1e-3, to_local(&f, w)), &Chi2Options::default());
        assert_eq!(outcome.degrees_of_freedom, 0);
        assert!(!outcome.passed(ALPHA));
        assert!(outcome.message.contains("inconclusive"), "{outcome}");
    }

    #[test]
    fn chi2_samples_where_pdf_is_zero_fail() {
        // 1% of the cosine samples mirrored below the horizon, where the pdf is 0.
        let samples = draw(11, |rng| {
            let mirror = rng.uniform() < 0.01;
            let d = cosine_hemisphere(rng);
            Some(if mirror { [d[0], d[1], -d[2]] } else { d })
        });
        let outcome = chi2_sphere(&samples, cosine_pdf, &Chi2Options::default());
        assert!(!outcome.passed(ALPHA), "{outcome}");
        assert!(outcome.message.contains("landed where the pdf is zero"), "{outcome}");
        assert!(outcome.message.contains("bin theta [90.0, 108.0] deg"), "{outcome}");
    }

    #[test]
    fn chi2_bad_pdf_and_samples_are_reported() {
        let samples = vec![Some([0.0, 0.0, 1.0]), Some([f64::NAN, 0.0, 0.0]), Some([0.0, 2.0, 0.0]), None];
        let outcome = chi2_sphere(&samples, |d| if d[2] > 0.9 { -1.0 } else { 0.25 / PI }, &Chi2Options::default());
        assert!(outcome.message.contains("not finite unit vectors"), "{outcome}");
        assert!(outcome.message.contains("pdf returned -1"), "{outcome}");
        assert!(!outcome.passed(0.0));
    }
}
