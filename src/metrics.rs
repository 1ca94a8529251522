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
        check_finite("variance image", &variance)?;
        let width = variance.width.max(1) as usize;
        if let Some(i) = variance.pixels.iter().position(|p| p.iter().any(|&c| c < 0.0)) {
            return Err(format!(
                "the variance image has a negative value at pixel ({}, {}) (column, row from the top left): \
                 a variance is at least 0",
                i % width,
                i / width
            ));
        }
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
}
