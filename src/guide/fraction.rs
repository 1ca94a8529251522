//! The learned guided fraction of each cell (after Müller's learned
//! BSDF-sampling fraction): its state and gradient; `glsl/learn.comp` and
//! `glsl/pathtrace.comp` are the GPU twins.

use super::*;

/// A cell's learned guided fraction: `sigmoid(theta)`, within [`FRACTION_MIN`,
/// 1 - `FRACTION_MIN`], `theta` moved by Adam (Kingma & Ba 2015) down the
/// gradient of the Kullback-Leibler divergence between the product of BSDF,
/// cosine and incident radiance, normalised, and the mixture density
/// `q = (1 - g) p_bsdf + g p_guided` (g the fraction times the lobe's share),
/// as in Müller, "Practical Path Guiding in Production" (SIGGRAPH 2019 course
/// notes, learning the BSDF-sampling fraction). For a direction sampled from q
/// with `F / q` its contribution (the weight `f |cos| / q` times the ray's
/// Q-learning target, the one-step estimate of the radiance it brings), the
/// gradient's sample is `-(F / q) (p_guided - p_bsdf) / q * share * g (1 - g)`;
/// a cell's samples since the table last learned are averaged and take one Adam
/// step ([`QTable::learn`]). The divergence is scale-free per cell: its gradient
/// up to the cell's total radiance, which Adam's normalisation cancels.
/// `glsl/learn.comp` is the same.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct FractionState {
    /// The fraction's logit, relative to the starting fraction's.
    pub theta: f32,
    /// Adam's first and second moments of the gradient.
    pub m: f32,
    pub v: f32,
    /// Adam steps taken (bias correction), as a float for the GPU's layout.
    pub steps: f32,
}

/// Smallest learned fraction, and 1 minus the largest. `glsl/common.glsl`.
pub const FRACTION_MIN: f32 = shared::FRACTION_MIN;

/// The share of its learned fraction that a cell's rows use: `n / (n + k bins)`
/// for a cell whose entries have taken `n` targets, k =
/// `FRACTION_EVIDENCE_PER_BIN`. A table that has seen few paths is noisy, and
/// guided directions drawn from it weigh up to 1 / (1 - fraction) times a BSDF
/// direction at each vertex: a cell starts from BSDF sampling and hands over to
/// its table as the evidence grows (docs/guiding.md, "Evidence").
/// `glsl/learn.comp` `evidence_weight` is the same.
pub fn evidence_weight(targets: f32, bins: u32) -> f32 {
    let k = shared::FRACTION_EVIDENCE_PER_BIN as f32 * bins as f32;
    targets / (targets + k)
}

/// ln(p / (1 - p)), for p in (0, 1).
fn logit(p: f32) -> f32 {
    (p / (1.0 - p)).ln()
}

impl FractionState {
    /// The fraction for starting value `start` (in (0, 1)).
    pub fn fraction(&self, start: f32) -> f32 {
        let l = logit(start) + self.theta;
        (1.0 / (1.0 + (-l).exp())).clamp(FRACTION_MIN, 1.0 - FRACTION_MIN)
    }

    /// One Adam step on the mean gradient `gradient`, `theta` kept where the
    /// fraction stays within its bounds. A gradient that is not finite (a sum
    /// that overflowed) is skipped: Adam's moments would keep it for good.
    pub fn step(&mut self, gradient: f32, start: f32) {
        use shared::{FRACTION_BETA1, FRACTION_BETA2, FRACTION_RATE};
        if !gradient.is_finite() {
            return;
        }
        self.steps += 1.0;
        self.m = FRACTION_BETA1 * self.m + (1.0 - FRACTION_BETA1) * gradient;
        self.v = FRACTION_BETA2 * self.v + (1.0 - FRACTION_BETA2) * gradient * gradient;
        let m_hat = self.m / (1.0 - FRACTION_BETA1.powf(self.steps));
        let v_hat = self.v / (1.0 - FRACTION_BETA2.powf(self.steps));
        if v_hat > 0.0 {
            self.theta -= FRACTION_RATE * m_hat / v_hat.sqrt();
        }
        let bound = ((1.0 - FRACTION_MIN) / FRACTION_MIN).ln();
        let start_logit = logit(start);
        self.theta = self.theta.clamp(-bound - start_logit, bound - start_logit);
    }
}

/// The gradient factor of a direction sampled at a vertex that mixes:
/// `share * g (1 - g) (p_guided - p_bsdf) / q` times the mean of its weight `f
/// |cos| / q`, for the row's fraction `g` and the lobe's share, whose product
/// `g_frac` is the mixture's guided probability. The recorder multiplies it by
/// minus the ray's Q-learning target ([`FractionState`]). `glsl/pathtrace.comp`
/// is the same arithmetic.
pub fn fraction_gradient_factor(g_frac: f32, g: f32, p_guided: f32, p_bsdf: f32, q: f32, mean_weight: f32) -> f32 {
    g_frac * (1.0 - g) * (p_guided - p_bsdf) / q * mean_weight
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fresh_state_gives_the_starting_fraction() {
        for start in [0.1f32, 0.25, 0.5, 0.75, 0.9] {
            let g = FractionState::default().fraction(start);
            assert!((g - start).abs() < 1e-6, "start {start}: {g}");
        }
    }

    /// Adam's first step is the rate itself (bias-corrected m / sqrt(v) is the
    /// gradient's sign); steady gradients drive the fraction to the bound on
    /// their side and no further; the gradient is that of the divergence, so a
    /// negative one raises the fraction.
    #[test]
    fn adam_steps_move_the_fraction_against_the_gradient_within_bounds() {
        for (gradient, sign) in [(-3.0e-4f32, 1.0f32), (2.5e3, -1.0)] {
            let mut s = FractionState::default();
            s.step(gradient, 0.5);
            assert!((s.theta - sign * shared::FRACTION_RATE).abs() < 1e-6, "{s:?}");
            assert_eq!(s.steps, 1.0);
            let mut last = s.fraction(0.5);
            for _ in 0..200 {
                s.step(gradient, 0.5);
                let g = s.fraction(0.5);
                assert!(sign * (g - last) >= 0.0, "the fraction moved the wrong way: {last} -> {g}");
                last = g;
            }
            let bound = if sign > 0.0 { 1.0 - FRACTION_MIN } else { FRACTION_MIN };
            assert!((last - bound).abs() < 1e-5, "after 201 steps {last}, bound {bound}");
            // Turning back starts as soon as the momentum turns (7 steps of the
            // opposite gradient): theta was held at the bound, not past it.
            let before = s.fraction(0.5);
            for _ in 0..15 {
                s.step(-gradient, 0.5);
            }
            assert!(sign * (s.fraction(0.5) - before) < -0.01, "{before} -> {}", s.fraction(0.5));
        }
    }

    /// No targets, no share; half at k targets per bin; nearly all with many more.
    #[test]
    fn the_evidence_weight_grows_from_zero_to_one_with_the_targets_per_bin() {
        let k = shared::FRACTION_EVIDENCE_PER_BIN as f32;
        for bins in [8u32, 128, 800] {
            assert_eq!(evidence_weight(0.0, bins), 0.0);
            assert!((evidence_weight(k * bins as f32, bins) - 0.5).abs() < 1e-6);
            assert!(evidence_weight(1000.0 * k * bins as f32, bins) > 0.998);
            let mut last = 0.0;
            for t in [1.0f32, 10.0, 1e3, 1e5, 1e7] {
                let w = evidence_weight(t, bins);
                assert!(w > last && w < 1.0, "{t} targets over {bins} bins: {w} after {last}");
                last = w;
            }
        }
    }

    #[test]
    fn a_gradient_that_is_not_finite_leaves_the_state_as_it_was() {
        let mut s = FractionState::default();
        s.step(-1.0, 0.5);
        let before = s;
        for g in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            s.step(g, 0.5);
            assert_eq!(s, before, "gradient {g}");
        }
    }

    #[test]
    fn the_gradient_factor_favours_the_density_that_is_larger_where_light_is() {
        // A direction the guided density likes more than the BSDF: a positive
        // factor, so that a positive target gives a negative gradient sample,
        // which raises the fraction.
        assert!(fraction_gradient_factor(0.5, 0.5, 2.0, 0.3, 1.15, 0.8) > 0.0);
        assert!(fraction_gradient_factor(0.5, 0.5, 0.1, 0.3, 0.2, 0.8) < 0.0);
        // A narrow glossy lobe's share scales it; fractions at the bounds keep some.
        let full = fraction_gradient_factor(0.5, 0.5, 2.0, 0.3, 1.15, 0.8);
        let shared = fraction_gradient_factor(0.125, 0.5, 2.0, 0.3, 1.15, 0.8);
        assert!((shared / full - 0.25).abs() < 1e-6);
    }
}
