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
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(format!(
            "image is {}x{} but the reference is {}x{}",
            image.width, image.height, reference.width, reference.height
        ));
    }
    for (which, img) in [("image", image), ("reference", reference)] {
        if let Some((x, y)) = img.first_non_finite() {
            return Err(format!(
                "the {which} has a NaN or infinite value at pixel ({x}, {y}) (column, row from the top left)"
            ));
        }
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
