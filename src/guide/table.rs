//! The Q-table and its learning: targets folded into running means and the
//! sampling rows rebuilt (`QTable::learn`, the twin of `glsl/learn.comp`).

use super::*;
use rayon::prelude::*;

/// The learned table on the host (the CPU renderer's, and the GPU's when read back).
#[derive(Clone, Debug)]
pub struct QTable {
    /// Q per (cell, bin), cell-major.
    pub q: Vec<f32>,
    /// Targets folded into each entry so far.
    pub visits: Vec<u32>,
    /// Sampling rows, [`NORMAL_CLASSES`] per cell (see [`build_sampling_rows`]).
    pub rows: Vec<AliasBin>,
    /// The guided fraction of each sampling row: its cell's times the cell's
    /// [`evidence_weight`], 0 where the row is [`UNLEARNED`] (so one load tells a
    /// vertex both).
    pub fractions: Vec<f32>,
    /// Per cell, the state of its learned fraction.
    pub fraction_states: Vec<FractionState>,
    /// Per sampling row, whether a guided vertex of a recording path has read it
    /// (set for good): only those rows are rebuilt when the table learns, the
    /// others stay [`UNLEARNED`] with fraction 0 (BSDF sampling alone). Most rows
    /// are never read: a cell's six orientation classes exist for whichever
    /// surfaces it holds, and the rebuild, a sequential loop per row, would do
    /// several times the work it needs (docs/guiding.md, "Learning"). A row that a
    /// path which does not record reads first samples the BSDF alone until a
    /// recording path reads it too, which every row's paths do in turn
    /// ([`RecordSchedule`]). `glsl/pathtrace.comp` marks them, `glsl/learn.comp`
    /// reads the marks.
    pub rows_read: Vec<bool>,
    /// Per cell of the table, its place in the adaptive grid's tree (all leaves
    /// of depth 0 in a uniform grid): `tree.rs`.
    pub nodes: Vec<CellNode>,
    /// Cells in use: the grid's, and the children split off so far.
    pub used_cells: u32,
}

/// The weight with which `k` targets, folded in at once, move an entry that has
/// already taken `n` towards their mean: `Q <- Q + w (S / k - Q)`.
///
/// Taken one by one, the i-th target of an entry has learning rate `1 / i^omega`,
/// and the k steps leave `prod (1 - 1 / i^omega)` (i = n+1 .. n+k) of the old
/// value; that product is taken as `exp(-sum 1 / i^omega)` with the sum as its
/// integral from n to n + k, `F(n + k) - F(n)`, `F(x) = x^(1-omega) / (1 - omega)`
/// (`ln x` at omega = 1). Batches then compose (a batch of k1 and one of k2 with
/// the same mean move Q as one of k1 + k2 does), and at omega = 1 the product is
/// exact: `w = k / (n + k)`, the running mean. An entry's first batch sets it to
/// the batch's mean (w = 1: the first step's rate is 1). Written so that a fold
/// into an entry of millions of targets keeps its precision in f32.
/// `glsl/learn.comp` `batch_rate` is the same.
pub fn batch_rate(n: f32, k: f32, omega: f32) -> f32 {
    if n <= 0.0 {
        return 1.0;
    }
    if omega >= 1.0 {
        return k / (n + k);
    }
    let a = 1.0 - omega;
    // (1 + x)^a - 1, by its series where x is small.
    let x = k / n;
    let growth = if x < 1e-3 { a * x * (1.0 + 0.5 * (a - 1.0) * x) } else { (1.0 + x).powf(a) - 1.0 };
    let s = n.powf(a) / a * growth;
    // 1 - exp(-s), likewise.
    if s < 1e-3 {
        s * (1.0 - 0.5 * s)
    } else {
        1.0 - (-s).exp()
    }
}

impl QTable {
    pub fn new(cfg: &GuideConfig) -> QTable {
        let entries = cfg.entries();
        let rows = cfg.sampling_rows();
        QTable {
            q: vec![0.0; entries],
            visits: vec![0; entries],
            rows: vec![AliasBin { column: UNLEARNED, pdf: 0.0 }; entries * NORMAL_CLASSES as usize],
            fractions: vec![0.0; rows],
            fraction_states: vec![FractionState::default(); cfg.cells() as usize],
            rows_read: vec![false; rows],
            nodes: vec![CellNode::default(); cfg.cells() as usize],
            used_cells: cfg.grid.cells(),
        }
    }

    /// Folds the targets recorded since the last call into the table,
    /// Q <- Q + w (S / c - Q) with w = [`batch_rate`]`(n, c, omega)` (n the
    /// entry's visits, c its new targets, S their sum), takes an Adam step on each cell's fraction where it
    /// learns them and has gradients, then rebuilds the sampling rows and their
    /// fractions; after the frames that [`RecordSchedule::learns_after`] names.
    /// `glsl/learn.comp` is the same.
    pub fn learn(&mut self, cfg: &GuideConfig, targets: &FrameSums) {
        for i in 0..self.q.len() {
            let c = targets.counts[i];
            if c > 0 {
                let w = batch_rate(self.visits[i] as f32, c as f32, cfg.rate_exponent);
                self.q[i] += w * (targets.sums[i] / c as f32 - self.q[i]);
                self.visits[i] += c;
            }
        }
        if cfg.learn_fraction {
            for (cell, state) in self.fraction_states.iter_mut().enumerate() {
                let c = targets.gradient_counts[cell];
                if c > 0 {
                    state.step(targets.gradients[cell] / c as f32, cfg.fraction);
                }
            }
        }
        for (read, &now) in self.rows_read.iter_mut().zip(&targets.rows_read) {
            *read |= now;
        }
        self.refine(cfg);
        let adaptive = cfg.grid.adaptive();
        let n = cfg.bins.count() as usize;
        let cosines = class_cosines(&cfg.bins);
        let classes = NORMAL_CLASSES as usize;
        let (q, visits, rows_read, states) = (&self.q, &self.visits, &self.rows_read, &self.fraction_states);
        let pool = if cfg.adaptive_directions { pool_sizes(&cfg.bins) } else { vec![1] };
        // Each cell's rows on their own: in parallel, the same rows as one by one.
        // The zip below pairs a cell's rows, fractions and node: one each per cell.
        debug_assert_eq!(self.nodes.len() * n * classes, self.rows.len());
        self.rows
            .par_chunks_mut(n * classes)
            .zip(self.fractions.par_chunks_mut(classes))
            .zip(self.nodes.par_iter_mut())
            .enumerate()
            .for_each(|(cell, ((rows, fractions), node))| {
                let read = &rows_read[cell * classes..(cell + 1) * classes];
                if !read.iter().any(|&r| r) {
                    return;
                }
                let g = if cfg.learn_fraction { states[cell].fraction(cfg.fraction) } else { cfg.fraction };
                let targets: f32 = visits[cell * n..(cell + 1) * n].iter().map(|&v| v as f32).sum();
                if adaptive {
                    node.targets = targets;
                }
                let g = g * evidence_weight(targets, n as u32);
                let q = &q[cell * n..(cell + 1) * n];
                let pooled: Vec<f32>;
                let q = if pool.len() > 1 {
                    let v = &visits[cell * n..(cell + 1) * n];
                    pooled = (0..n as u32).map(|b| pooled_q(&cfg.bins, &pool, q, v, b)).collect();
                    &pooled[..]
                } else {
                    q
                };
                for (class, (row, cos)) in rows.chunks_mut(n).zip(cosines.chunks(n)).enumerate() {
                    if read[class] {
                        build_sampling_row(cos, q, cfg.floor, row);
                        fractions[class] = if learned(row) { g } else { 0.0 };
                    }
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At omega = 1 a batch's weight is the running mean's, k / (n + k); an
    /// entry's first batch sets it; a single target's weight lies between the
    /// rates 1/(n+1)^omega and 1/n^omega that the integral brackets, also where
    /// n is in the millions (the series keep f32's precision there).
    #[test]
    fn batch_rate_is_the_running_mean_at_one_and_a_polynomial_rate_below() {
        for n in [1u32, 2, 7, 100, 4095, 1 << 20, 10_000_000] {
            for k in [1u32, 3, 64, 5000] {
                let w = batch_rate(n as f32, k as f32, 1.0);
                assert_eq!(w, k as f32 / (n + k) as f32, "n {n}, k {k}");
            }
            for omega in [0.6f32, 0.75, 0.9] {
                let (n, w) = (n as f64, batch_rate(n as f32, 1.0, omega) as f64);
                let (lo, hi) = (1.0 - (-(n + 1.0).powf(-omega as f64)).exp(), n.powf(-omega as f64));
                assert!(
                    w >= lo * (1.0 - 1e-4) && w <= hi * (1.0 + 1e-4),
                    "n {n}, omega {omega}: {w} not in [{lo}, {hi}]"
                );
            }
        }
        for omega in [0.6f32, 0.75, 1.0] {
            assert_eq!(batch_rate(0.0, 1.0, omega), 1.0);
            assert_eq!(batch_rate(0.0, 300.0, omega), 1.0);
        }
    }

    /// Folding targets in one batch or in two moves Q the same way (the rates
    /// compose), where the two batches have the same mean.
    #[test]
    fn batches_compose() {
        for omega in [0.6f32, 0.75, 1.0] {
            for (n, k1, k2) in [(1.0f32, 1.0f32, 1.0f32), (10.0, 5.0, 20.0), (1000.0, 900.0, 3.0), (2.0e6, 64.0, 64.0)]
            {
                let (q0, t) = (0.25f64, 3.0f64);
                let w1 = batch_rate(n, k1, omega) as f64;
                let w2 = batch_rate(n + k1, k2, omega) as f64;
                let two = (q0 + w1 * (t - q0)) + w2 * (t - (q0 + w1 * (t - q0)));
                let one = q0 + batch_rate(n, k1 + k2, omega) as f64 * (t - q0);
                assert!((two - one).abs() <= 1e-5 * t, "omega {omega}, n {n}, {k1} + {k2}: {two} against {one}");
            }
        }
    }

    /// What the rate is for: an entry whose first targets were too low (bootstrapped
    /// from a table that knew little) and whose later ones are right. Both rates
    /// converge to the right value; the polynomial one gets there sooner. And with
    /// noisy targets of a fixed mean it still converges to that mean.
    #[test]
    fn a_polynomial_rate_forgets_early_targets_sooner_and_converges_to_the_mean() {
        let run = |omega: f32, noisy: bool| {
            let (mut q, mut n) = (0.0f32, 0.0f32);
            let mut rng = Rng::new(3, 0, 0, 0);
            let mut at = Vec::new();
            for batch in 0..2000 {
                let k = 64.0;
                let sum: f32 = (0..64)
                    .map(|_| {
                        let mean = if noisy || batch >= 20 { 1.0 } else { 0.2 };
                        if noisy {
                            mean * 2.0 * rng.next_f32()
                        } else {
                            mean
                        }
                    })
                    .sum();
                q += batch_rate(n, k, omega) * (sum / k - q);
                n += k;
                if [99, 1999].contains(&batch) {
                    at.push(q);
                }
            }
            at
        };
        let (linear, polynomial) = (run(1.0, false), run(0.75, false));
        // After 100 batches the running mean still holds a fifth of the early error.
        assert!((linear[0] - 0.84).abs() < 1e-3, "{linear:?}");
        assert!(1.0 - polynomial[0] < 0.5 * (1.0 - linear[0]), "{polynomial:?} against {linear:?}");
        assert!(1.0 - polynomial[1] < 1e-3 && 1.0 - linear[1] < 0.01, "{polynomial:?} {linear:?}");
        for omega in [0.75, 1.0] {
            let q = run(omega, true)[1];
            assert!((q - 1.0).abs() < 0.01, "omega {omega}: noisy targets of mean 1 gave {q}");
        }
    }
}
