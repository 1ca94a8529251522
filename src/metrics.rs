//! Error metrics between an image and a reference, as rendering papers report them.

use crate::image::Image;

/// Errors of `image` against `reference`, averaged over pixels and channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    /// Relative mean squared error: mean of (x - r)^2 / (r^2 + 0.01).
    pub rel_mse: f64,
    /// Root mean squared error.
    pub rmse: f64,
    /// Mean absolute percentage error: mean of |x - r| / (|r| + 0.01).
    pub mape: f64,
    /// Where the reference comes with its own variance ([`Reference::with_variance`]):
    /// mean of ((x - r)^2 - v) / (r^2 + 0.01), the relMSE against the true image
    /// rather than against the reference ([`rel_mse_debiased`]).
    pub rel_mse_debiased: Option<f64>,
}

/// Compares two images of the same size. `Err` names the sizes when they
/// differ, and the first pixel that is NaN or infinite in either image (every
/// metric would be NaN or infinite, which reads like a measurement).
pub fn compare(image: &Image, reference: &Image) -> Result<Errors, String> {
    errors(image, reference, None, false)
}

/// The relMSE of an image against the true image, estimated from a reference
/// `r` that is itself a Monte Carlo estimate with per-pixel variance `v`: the
/// mean of `((x - r)^2 - v) / (r^2 + 0.01)`.
///
/// Against a reference rendered independently of the image, E[(x - r)^2] is
/// (x - t)^2 + Var(r), t the true value: a reference's own noise adds the mean
/// of v / (r^2 + 0.01) to every relMSE measured against it, whatever the image.
/// A reference of four times an unguided render's samples adds a quarter of that
/// render's relMSE to each figure, and no image, however good, measures below
/// that floor. Subtracting an unbiased estimate of v (the spread of the
/// reference's frames, `rlpt render --variance`) takes the floor out, so that
/// ratios between renders read as ratios of their own errors. Each pixel's
/// term can be negative (v is itself an estimate); the mean is what estimates
/// the error. The denominator keeps the reference's r: its noise there is a
/// second-order effect, the same as in the plain relMSE.
pub fn rel_mse_debiased(x: f64, r: f64, v: f64) -> f64 {
    let d = x - r;
    (d * d - v) / (r * r + 0.01)
}

/// A reference image whose every pixel was found finite once, when it was made,
/// for measuring many images against it (`rlpt render --stats` measures about 24
/// frames per decade) without scanning it again each time; with its per-pixel
/// variance where one was given ([`Reference::with_variance`]).
#[derive(Clone, Debug)]
pub struct Reference {
    image: Image,
    variance: Option<Image>,
}

impl Reference {
    /// `Err` names the first pixel that is NaN or infinite.
    pub fn new(image: Image) -> Result<Reference, String> {
        check_finite("reference", &image)?;
        Ok(Reference { image, variance: None })
    }

    /// The reference with the variance of each of its pixels' estimates (an
    /// image of the same size: `Film::variance_of_mean`, written by `rlpt render
    /// --variance`), so that [`Reference::compare`] also gives
    /// [`Errors::rel_mse_debiased`]. `Err` names a size that differs, and the
    /// first pixel whose variance is NaN, infinite or negative.
    pub fn with_variance(self, variance: Image) -> Result<Reference, String> {
        if (variance.width, variance.height) != (self.image.width, self.image.height) {
            return Err(format!(
                "the variance image is {}x{} but the reference is {}x{}",
                variance.width, variance.height, self.image.width, self.image.height
            ));
        }
        check_variance("variance image", &variance)?;
        Ok(Reference { variance: Some(variance), ..self })
    }

    pub fn image(&self) -> &Image {
        &self.image
    }

    /// The variance of each pixel of the reference, where one was given.
    pub fn variance(&self) -> Option<&Image> {
        self.variance.as_ref()
    }

    /// [`compare`] against the reference, which is not scanned again; with
    /// [`Errors::rel_mse_debiased`] where the reference has its variance.
    pub fn compare(&self, image: &Image) -> Result<Errors, String> {
        errors(image, &self.image, self.variance.as_ref(), true)
    }
}

fn check_finite(which: &str, img: &Image) -> Result<(), String> {
    match img.first_non_finite() {
        Some((x, y)) => {
            Err(format!("the {which} has a NaN or infinite value at pixel ({x}, {y}) (column, row from the top left)"))
        }
        None => Ok(()),
    }
}

/// A variance image's values are finite and at least 0: `Err` names the first
/// pixel that is not.
fn check_variance(which: &str, img: &Image) -> Result<(), String> {
    check_finite(which, img)?;
    let width = img.width.max(1) as usize;
    match img.pixels.iter().position(|p| p.iter().any(|&c| c < 0.0)) {
        Some(i) => Err(format!(
            "the {which} has a negative value at pixel ({}, {}) (column, row from the top left): a variance is at \
             least 0",
            i % width,
            i / width
        )),
        None => Ok(()),
    }
}

/// The metrics, after the sizes and the pixels are checked (the reference's
/// only where `reference_checked` is false; a variance comes checked).
fn errors(
    image: &Image,
    reference: &Image,
    variance: Option<&Image>,
    reference_checked: bool,
) -> Result<Errors, String> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(format!(
            "image is {}x{} but the reference is {}x{}",
            image.width, image.height, reference.width, reference.height
        ));
    }
    check_finite("image", image)?;
    if !reference_checked {
        check_finite("reference", reference)?;
    }
    let (mut rel, mut se, mut ape, mut debiased) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (i, (a, b)) in image.pixels.iter().zip(&reference.pixels).enumerate() {
        for c in 0..3 {
            let (x, r) = (a[c] as f64, b[c] as f64);
            let d = x - r;
            rel += d * d / (r * r + 0.01);
            se += d * d;
            ape += d.abs() / (r.abs() + 0.01);
            if let Some(v) = variance {
                debiased += rel_mse_debiased(x, r, v.pixels[i][c] as f64);
            }
        }
    }
    let n = (image.pixels.len() * 3).max(1) as f64;
    Ok(Errors {
        rel_mse: rel / n,
        rmse: (se / n).sqrt(),
        mape: ape / n,
        rel_mse_debiased: variance.map(|_| debiased / n),
    })
}

/// The difference of two renders' means over one part of the image in one
/// channel, and its z-score from the renders' per-pixel variances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeanDiff {
    /// The part: columns `x0..x1`, rows `y0..y1` from the top left.
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
    pub channel: usize,
    pub mean_a: f64,
    pub mean_b: f64,
    /// (mean_a - mean_b) / sqrt(var_a + var_b), each mean's variance the sum of
    /// its pixels' variances over the count squared (pixels are independent).
    pub z: f64,
}

impl MeanDiff {
    /// (mean_a - mean_b) / mean_b, 0 where both are 0.
    pub fn relative(&self) -> f64 {
        if self.mean_b == 0.0 {
            if self.mean_a == 0.0 {
                0.0
            } else {
                f64::INFINITY
            }
        } else {
            (self.mean_a - self.mean_b) / self.mean_b
        }
    }
}

/// How two independent renders of one scene agree ([`agreement`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Agreement {
    /// The whole image, per channel (R, G, B).
    pub global: [MeanDiff; 3],
    /// A 4x4 grid of regions, per channel: 48 differences.
    pub regions: Vec<MeanDiff>,
    /// Per pixel and channel, z = (a - b) / sqrt(va + vb) over the values whose
    /// variances are not both 0: their count, the mean of z^2 (near 1 where the
    /// variances are calibrated), and the Kolmogorov-Smirnov distance of their
    /// distribution from the standard normal.
    pub pixels: usize,
    pub pixel_mean_z2: f64,
    pub pixel_ks: f64,
}

impl Agreement {
    /// The difference with the largest |z|, the global ones and the regions'.
    pub fn worst(&self) -> &MeanDiff {
        self.global.iter().chain(&self.regions).max_by(|a, b| a.z.abs().total_cmp(&b.z.abs())).expect("three globals")
    }
}

/// Whether two independent renders `a` and `b` of one scene, with the variances of
/// their pixels' estimates (`rlpt render --variance`), agree: the difference of
/// their means over the whole image and over each of 16 regions, per channel, as
/// z-scores, and how the per-pixel z-scores are spread. Two unbiased renderers
/// (or estimators) give |z| of a few at most, whatever the samples; a bias shows
/// as |z| that grows with them. `Err` names sizes that differ and values that are
/// not finite or (variances) negative.
///
/// `floor` is the relative difference the comparison does not resolve: each
/// mean's deviation gets `floor` times the mean added in quadrature. f32
/// arithmetic along a path is not exact, and where an image has almost no noise
/// (the closed furnace) rounding alone is many deviations; 1e-4 claims agreement
/// to a part in ten thousand, 0 to the noise alone.
pub fn agreement(a: &Image, va: &Image, b: &Image, vb: &Image, floor: f64) -> Result<Agreement, String> {
    let (w, h) = (a.width, a.height);
    for (name, img) in [("second image", b), ("first image's variance", va), ("second image's variance", vb)] {
        if (img.width, img.height) != (w, h) {
            return Err(format!("the first image is {w}x{h} but the {name} is {}x{}", img.width, img.height));
        }
    }
    check_finite("first image", a)?;
    check_finite("second image", b)?;
    check_variance("first image's variance", va)?;
    check_variance("second image's variance", vb)?;
    if w == 0 || h == 0 {
        return Err("the images are empty".to_string());
    }
    let diff = |x0: u32, y0: u32, x1: u32, y1: u32, c: usize| {
        let (mut sa, mut sb, mut sva, mut svb) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for y in y0..y1 {
            for x in x0..x1 {
                let i = (y * w + x) as usize;
                sa += a.pixels[i][c] as f64;
                sb += b.pixels[i][c] as f64;
                sva += va.pixels[i][c] as f64;
                svb += vb.pixels[i][c] as f64;
            }
        }
        let n = ((x1 - x0) * (y1 - y0)).max(1) as f64;
        let (mean_a, mean_b) = (sa / n, sb / n);
        let rounding = floor * mean_a.abs().max(mean_b.abs());
        let sd = ((sva + svb) / (n * n) + rounding * rounding).sqrt();
        let z = if sd > 0.0 {
            (mean_a - mean_b) / sd
        } else if mean_a == mean_b {
            0.0
        } else {
            f64::INFINITY.copysign(mean_a - mean_b)
        };
        MeanDiff { x0, y0, x1, y1, channel: c, mean_a, mean_b, z }
    };
    let global = [0, 1, 2].map(|c| diff(0, 0, w, h, c));
    let mut regions = Vec::with_capacity(48);
    for ry in 0..4 {
        for rx in 0..4 {
            let (x0, x1) = (rx * w / 4, (rx + 1) * w / 4);
            let (y0, y1) = (ry * h / 4, (ry + 1) * h / 4);
            if x1 > x0 && y1 > y0 {
                regions.extend((0..3).map(|c| diff(x0, y0, x1, y1, c)));
            }
        }
    }
    let mut zs: Vec<f64> = Vec::with_capacity(a.pixels.len() * 3);
    for i in 0..a.pixels.len() {
        for c in 0..3 {
            let v = va.pixels[i][c] as f64 + vb.pixels[i][c] as f64;
            if v > 0.0 {
                zs.push((a.pixels[i][c] as f64 - b.pixels[i][c] as f64) / v.sqrt());
            }
        }
    }
    let pixels = zs.len();
    let pixel_mean_z2 = if pixels > 0 { zs.iter().map(|z| z * z).sum::<f64>() / pixels as f64 } else { 0.0 };
    zs.sort_by(f64::total_cmp);
    let n = pixels as f64;
    let pixel_ks = zs
        .iter()
        .enumerate()
        .map(|(k, &z)| {
            let f = standard_normal_cdf(z);
            (f - k as f64 / n).abs().max(((k + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max);
    Ok(Agreement { global, regions, pixels, pixel_mean_z2, pixel_ks })
}

/// The standard normal distribution function, to about 1e-7 (the complementary
/// error function of Numerical Recipes' `erfcc`, Chebyshev-fitted).
pub fn standard_normal_cdf(z: f64) -> f64 {
    // Phi(z) = erfc(-z / sqrt 2) / 2.
    let x = -z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let poly = -x * x - 1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    let erfc = t * poly.exp();
    let erfc = if x >= 0.0 { erfc } else { 2.0 - erfc };
    0.5 * erfc
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(pixels: Vec<[f32; 3]>) -> Image {
        Image { width: pixels.len() as u32, height: 1, pixels }
    }

    /// The metrics of a known pair; a checked reference gives the same, refuses a
    /// NaN at its making, and still refuses one in the image measured against it.
    #[test]
    fn a_checked_reference_measures_as_compare_does() {
        let r = image(vec![[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]);
        let x = image(vec![[2.0, 1.0, 1.0], [0.0, 0.0, 0.1]]);
        let e = compare(&x, &r).unwrap();
        // (1 / 1.01 + 0.01 / 0.01) / 6, sqrt((1 + 0.01) / 6), (1 / 1.01 + 0.1 / 0.01) / 6
        assert!((e.rel_mse - (1.0 / 1.01 + 1.0) / 6.0).abs() < 1e-6, "{e:?}");
        assert!((e.rmse - (1.01f64 / 6.0).sqrt()).abs() < 1e-6, "{e:?}");
        assert!((e.mape - (1.0 / 1.01 + 10.0) / 6.0).abs() < 1e-5, "{e:?}");
        let checked = Reference::new(r.clone()).unwrap();
        assert_eq!(checked.compare(&x).unwrap(), e);
        assert_eq!(checked.image().pixels, r.pixels);
        let nan = image(vec![[1.0, 1.0, 1.0], [0.0, f32::NAN, 0.0]]);
        assert!(Reference::new(nan.clone())
            .unwrap_err()
            .contains("reference has a NaN or infinite value at pixel (1, 0)"));
        assert!(compare(&x, &nan).unwrap_err().contains("reference has a NaN"));
        assert!(checked.compare(&nan).unwrap_err().contains("image has a NaN or infinite value at pixel (1, 0)"));
        assert!(checked.compare(&image(vec![[1.0; 3]])).unwrap_err().contains("image is 1x1 but the reference is 2x1"));
    }

    /// With the reference's variance, the debiased relMSE subtracts it pixel by
    /// pixel; without, there is none. A variance of another size, or one with
    /// a NaN or a negative value, is refused by name.
    #[test]
    fn a_reference_with_its_variance_subtracts_it() {
        let r = image(vec![[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]);
        let x = image(vec![[2.0, 1.0, 1.0], [0.0, 0.0, 0.1]]);
        assert_eq!(compare(&x, &r).unwrap().rel_mse_debiased, None);
        let v = image(vec![[0.5, 0.0, 0.0], [0.0, 0.0, 0.004]]);
        let with = Reference::new(r.clone()).unwrap().with_variance(v.clone()).unwrap();
        let e = with.compare(&x).unwrap();
        assert_eq!(e.rel_mse, compare(&x, &r).unwrap().rel_mse);
        // ((1 - 0.5) / 1.01 + (0.01 - 0.004) / 0.01) / 6
        let want = (0.5 / 1.01 + 0.6) / 6.0;
        assert!((e.rel_mse_debiased.unwrap() - want).abs() < 1e-6, "{e:?}");
        assert_eq!(with.variance().unwrap().pixels, v.pixels);
        let refuse = |v: Image| Reference::new(r.clone()).unwrap().with_variance(v).unwrap_err();
        assert!(refuse(image(vec![[0.0; 3]])).contains("variance image is 1x1 but the reference is 2x1"));
        assert!(refuse(image(vec![[0.0; 3], [0.0, f32::NAN, 0.0]]))
            .contains("variance image has a NaN or infinite value at pixel (1, 0)"));
        assert!(refuse(image(vec![[0.0; 3], [0.0, 0.0, -1e-9]])).contains("negative value at pixel (1, 0)"));
    }

    /// The point of it: an image and a reference that are each the truth plus
    /// independent noise. Against the reference the relMSE is the image's own
    /// plus the reference's; less the reference's variance it is the image's
    /// alone, within 5 standard errors of the mean over 30000 pixels. The noise
    /// is small against the pixels' denominators, as a reference's is: the
    /// reference's noise then matters in the numerator, where it adds its
    /// variance, and not in the denominator (with a reference noise of a fifth
    /// of sqrt(0.01) the two correlate, and this estimate fell 27 % short).
    #[test]
    fn the_debiased_relmse_is_the_error_against_the_truth() {
        let mut rng = crate::math::rng::Rng::new(11, 0, 0, 0);
        let mut gauss = || {
            let (u, w) = (rng.next_f32().max(1e-7) as f64, rng.next_f32() as f64);
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * w).cos()
        };
        let n = 30000;
        let (sx, sr) = (0.001f64, 0.002f64);
        let (mut truth, mut x, mut r) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            let t = 0.04 * (i as f64 / n as f64);
            truth.push([t as f32; 3]);
            x.push([0, 1, 2].map(|_| (t + sx * gauss()) as f32));
            r.push([0, 1, 2].map(|_| (t + sr * gauss()) as f32));
        }
        let (truth, x, r) = (image(truth), image(x), image(r));
        let v = image(vec![[(sr * sr) as f32; 3]; n]);
        let e = Reference::new(r.clone()).unwrap().with_variance(v.clone()).unwrap().compare(&x).unwrap();
        let against_truth = compare(&x, &truth).unwrap().rel_mse;
        // Per-pixel terms of the difference, for its standard error.
        let terms: Vec<f64> = (0..n)
            .map(|i| {
                (0..3)
                    .map(|c| {
                        let (xi, ri, ti) = (x.pixels[i][c] as f64, r.pixels[i][c] as f64, truth.pixels[i][c] as f64);
                        rel_mse_debiased(xi, ri, v.pixels[i][c] as f64) - (xi - ti).powi(2) / (ti * ti + 0.01)
                    })
                    .sum::<f64>()
                    / 3.0
            })
            .collect();
        let mean = terms.iter().sum::<f64>() / n as f64;
        let sd = (terms.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        let se = sd / (n as f64).sqrt();
        let debiased = e.rel_mse_debiased.unwrap();
        assert!((debiased - against_truth).abs() < 5.0 * se, "{debiased} against {against_truth} (se {se})");
        // The plain relMSE carries the reference's share, about 4 times the image's own here.
        assert!(e.rel_mse > 4.0 * against_truth, "{} against {against_truth}", e.rel_mse);
    }

    /// Two images with known means: the global and regional z-scores follow from
    /// the variances, the worst is found, and mismatched inputs are refused.
    #[test]
    fn agreement_measures_differences_in_units_of_their_noise() {
        let (w, h) = (8u32, 4u32);
        let n = (w * h) as usize;
        let a = Image { width: w, height: h, pixels: vec![[1.0, 2.0, 3.0]; n] };
        let mut b = a.clone();
        // The top-left region (2x1 pixels) is 0.1 darker in green in b.
        for x in 0..2 {
            b.pixels[x][1] -= 0.1;
        }
        let va = Image { width: w, height: h, pixels: vec![[0.01; 3]; n] };
        let ag = agreement(&a, &va, &b, &va, 0.0).unwrap();
        assert_eq!(ag.global[0].z, 0.0);
        // Global green: mean difference 0.2 / 32, sd sqrt(2 * 0.01 * 32) / 32.
        let want = (0.2 / 32.0) / ((2.0 * 0.01 * 32.0f64).sqrt() / 32.0);
        assert!((ag.global[1].z - want).abs() < 1e-4, "{:?}", ag.global[1]);
        // The region: difference 0.1, sd sqrt(2 * 0.01 * 2) / 2.
        let worst = ag.worst();
        assert_eq!((worst.x0, worst.y0, worst.x1, worst.y1, worst.channel), (0, 0, 2, 1, 1));
        assert!((worst.z - 0.1 / ((0.04f64).sqrt() / 2.0)).abs() < 1e-4, "{worst:?}");
        assert!((worst.relative() - 0.1 / 1.9).abs() < 1e-6);
        assert_eq!(ag.regions.len(), 48);
        assert_eq!(ag.pixels, 3 * n);
        let small = Image { width: 1, height: 1, pixels: vec![[0.0; 3]] };
        assert!(agreement(&a, &va, &small, &va, 0.0).unwrap_err().contains("second image is 1x1"));
        let mut neg = va.clone();
        neg.pixels[9][2] = -1.0;
        assert!(agreement(&a, &va, &b, &neg, 0.0)
            .unwrap_err()
            .contains("second image's variance has a negative value at pixel (1, 1)"));
    }

    /// Samples of two estimates of the same values with their true variances:
    /// per-pixel z-scores are standard normal (mean z^2 near 1, a small KS
    /// distance), and no region differs by more than a few sigma. Shifted by a
    /// tenth of a pixel's sigma everywhere, the global z-scores see it.
    #[test]
    fn agreement_of_unbiased_estimates_is_standard_normal_and_sees_a_small_bias() {
        let mut rng = crate::math::rng::Rng::new(5, 0, 0, 0);
        let mut gauss = || {
            let (u, w) = (rng.next_f32().max(1e-7) as f64, rng.next_f32() as f64);
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * w).cos()
        };
        let (w, h) = (200u32, 100u32);
        let n = (w * h) as usize;
        let sd = 0.05f64;
        let var = Image { width: w, height: h, pixels: vec![[(sd * sd) as f32; 3]; n] };
        let noisy = |g: &mut dyn FnMut() -> f64, shift: f64| Image {
            width: w,
            height: h,
            pixels: (0..n)
                .map(|i| [0, 1, 2].map(|c| (1.0 + 0.1 * c as f64 + (i % 7) as f64 * 0.01 + shift + sd * g()) as f32))
                .collect(),
        };
        let a = noisy(&mut gauss, 0.0);
        let b = noisy(&mut gauss, 0.0);
        let ag = agreement(&a, &var, &b, &var, 0.0).unwrap();
        assert!((ag.pixel_mean_z2 - 1.0).abs() < 0.03, "{}", ag.pixel_mean_z2);
        // KS at n = 60000: 1.95 / sqrt(n) is the 0.1 % critical distance.
        assert!(ag.pixel_ks < 1.95 / (ag.pixels as f64).sqrt(), "{}", ag.pixel_ks);
        assert!(ag.worst().z.abs() < 4.5, "{:?}", ag.worst());
        let c = noisy(&mut gauss, 0.1 * sd);
        let shifted = agreement(&c, &var, &b, &var, 0.0).unwrap();
        // Expected z: 0.1 sd / (sd sqrt(2 / n)) = 10.
        assert!(shifted.global.iter().all(|d| d.z > 6.0), "{:?}", shifted.global);
    }

    /// The floor adds its share of the mean to each deviation: a difference of
    /// 1e-5 with no noise is infinitely many deviations without it, a tenth of one
    /// with a floor of 1e-4.
    #[test]
    fn the_floor_bounds_what_rounding_can_differ_by() {
        let a = Image { width: 4, height: 4, pixels: vec![[1.0; 3]; 16] };
        let b = Image { width: 4, height: 4, pixels: vec![[1.00001; 3]; 16] };
        let zero = Image { width: 4, height: 4, pixels: vec![[0.0; 3]; 16] };
        assert!(agreement(&a, &zero, &b, &zero, 0.0).unwrap().global[0].z.is_infinite());
        let z = agreement(&a, &zero, &b, &zero, 1e-4).unwrap().global[0].z;
        assert!((z + 0.1).abs() < 1e-3, "{z}");
    }

    #[test]
    fn the_normal_distribution_function_matches_known_values() {
        for (z, p) in [(0.0, 0.5), (1.0, 0.8413447461), (-1.96, 0.0249978952), (3.0, 0.9986501020)] {
            assert!((standard_normal_cdf(z) - p).abs() < 2e-7, "{z}: {}", standard_normal_cdf(z));
        }
    }
}
