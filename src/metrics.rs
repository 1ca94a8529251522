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
}

/// Compares two images of the same size. `Err` names the sizes when they
/// differ, and the first pixel that is NaN or infinite in either image (every
/// metric would be NaN or infinite, which reads like a measurement).
pub fn compare(image: &Image, reference: &Image) -> Result<Errors, String> {
    errors(image, reference, false)
}

/// A reference image whose every pixel was found finite once, when it was made,
/// for measuring many images against it (`rlpt render --stats` measures about 24
/// frames per decade) without scanning it again each time.
#[derive(Clone, Debug)]
pub struct Reference(Image);

impl Reference {
    /// `Err` names the first pixel that is NaN or infinite.
    pub fn new(image: Image) -> Result<Reference, String> {
        check_finite("reference", &image)?;
        Ok(Reference(image))
    }

    pub fn image(&self) -> &Image {
        &self.0
    }

    /// [`compare`] against the reference, which is not scanned again.
    pub fn compare(&self, image: &Image) -> Result<Errors, String> {
        errors(image, &self.0, true)
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
/// only where `reference_checked` is false).
fn errors(image: &Image, reference: &Image, reference_checked: bool) -> Result<Errors, String> {
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
    let (mut rel, mut se, mut ape) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (x, r) = (a[c] as f64, b[c] as f64);
            let d = x - r;
            rel += d * d / (r * r + 0.01);
            se += d * d;
            ape += d.abs() / (r.abs() + 0.01);
        }
    }
    let n = (image.pixels.len() * 3).max(1) as f64;
    Ok(Errors { rel_mse: rel / n, rmse: (se / n).sqrt(), mape: ape / n })
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
}
