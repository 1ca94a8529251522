//! The mean colour of an image (what a texture stands in as where a parameter
//! takes no image), and a stand-in for a missing one.

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

const EXTENSIONS: &[&str] = &["exr", "png", "jpg", "jpeg", "tga", "hdr"];

/// The mean linear RGB of the image at `path`. `srgb`: decode from sRGB
/// (`None`: 8-bit images are sRGB, float ones linear, as pbrt's default).
/// `latlong`: an equirectangular map (width twice the height), rows weighted
/// by solid angle; any other shape is pbrt-v4's equal-area map, a plain mean.
/// The error says why it did not read.
pub(super) fn mean(path: &Path, srgb: Option<bool>, latlong: bool) -> Result<Vec3, String> {
    if !path.is_file() {
        return Err("does not exist".into());
    }
    let image = image::open(path).map_err(|e| format!("cannot be read ({e})"))?;
    let eight_bit = !matches!(image, image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_));
    let decode = srgb.unwrap_or(eight_bit);
    let rgb = image.to_rgb32f();
    let (w, h) = rgb.dimensions();
    let weighted = latlong && w == 2 * h;
    let to_linear = |c: f32| if decode { crate::scene::texture::srgb_to_linear(c) } else { c };
    let (mut sum, mut total) = (DVec3::ZERO, 0.0f64);
    for (_, y, p) in rgb.enumerate_pixels() {
        let weight = if weighted { (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin() } else { 1.0 };
        sum += weight * DVec3::new(to_linear(p[0]) as f64, to_linear(p[1]) as f64, to_linear(p[2]) as f64);
        total += weight;
    }
    let mean = (sum / total.max(f64::MIN_POSITIVE)).as_vec3();
    if !mean.is_finite() || mean.min_element() < 0.0 {
        return Err(format!("has a mean {mean} that is not a finite non-negative colour"));
    }
    Ok(mean)
}

/// Whether the image at `path` has 8 bits per channel (read as sRGB by the
/// renderers); None where its header does not read.
pub(super) fn eight_bit(path: &Path) -> Option<bool> {
    use image::ImageDecoder;
    let decoder = image::ImageReader::open(path).ok()?.with_guessed_format().ok()?.into_decoder().ok()?;
    Some(decoder.color_type().bytes_per_pixel() == decoder.color_type().channel_count())
}

/// A file of the same name with another image extension, in the missing
/// file's directory or a directory beside it (scenes shipped with their
/// textures converted, such as TGA to JPEG).
pub(super) fn substitute(path: &Path) -> Option<PathBuf> {
    let stem = path.file_stem()?;
    let dir = path.parent()?;
    let mut dirs = vec![dir.to_path_buf()];
    if let Some(Ok(entries)) = dir.parent().map(std::fs::read_dir) {
        let mut siblings: Vec<PathBuf> =
            entries.flatten().map(|e| e.path()).filter(|p| p.is_dir() && p != dir).collect();
        siblings.sort();
        dirs.extend(siblings);
    }
    for d in dirs {
        for ext in EXTENSIONS {
            let candidate = d.join(format!("{}.{ext}", stem.to_string_lossy()));
            if candidate != path && candidate.is_file() {
                return Some(candidate);
            }
        }
    }
    None
}
