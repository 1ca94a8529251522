//! The image environment of a scene (`[environment] file`, and pbrt's
//! `LightSource "infinite"` with a `filename`): an equirectangular EXR or HDR
//! image read into linear RGB. The convention and the sampling are
//! `crate::math::envmap`'s.

use std::path::{Path, PathBuf};

/// An equirectangular environment map: row 0 is straight up (+y), the image
/// centre is -z, columns run towards +x (`crate::math::envmap`).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    /// The file as resolved, for messages and `rlpt info`.
    pub file: PathBuf,
    pub width: u32,
    pub height: u32,
    /// Linear RGB per texel, rows from the top, times the scene's `scale`.
    pub texels: Vec<[f32; 3]>,
    /// The rotation from world directions to the map's frame: `[environment]
    /// rotate` turns the map about +y, pbrt's light transform any way.
    pub to_map: glam::Mat3,
}

impl EnvironmentMap {
    /// Reads `written` (as the scene wrote it), resolved against `base`, the map
    /// turned by `rotate_deg` about +y (right-handed: the image centre, -z, turns
    /// towards -x); the error is one sentence naming the file.
    pub fn read(written: &str, base: &Path, scale: f32, rotate_deg: f32) -> Result<EnvironmentMap, String> {
        let path = base.join(written);
        let shown = if path.as_os_str() == written {
            format!("\"{written}\"")
        } else {
            format!("\"{written}\" (resolved to {})", path.display())
        };
        if !path.is_file() {
            return Err(format!("the environment image {shown} does not exist"));
        }
        let image = image::open(&path).map_err(|e| format!("the environment image {shown} cannot be read: {e}"))?;
        // Integer images hold sRGB-encoded colour, float ones linear (as pbrt reads them).
        let srgb = !matches!(image, image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_));
        let decode = |c: f32| if srgb { crate::scene::texture::srgb_to_linear(c) } else { c };
        let rgb = image.to_rgb32f();
        let (width, height) = rgb.dimensions();
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for (x, y, p) in rgb.enumerate_pixels() {
            if let Some(c) = p.0.iter().find(|c| !(c.is_finite() && **c >= 0.0)) {
                return Err(format!(
                    "the environment image {shown} has texel ({x}, {y}) of value {c}: texels must be finite and not negative"
                ));
            }
            texels.push(p.0.map(|c| decode(c) * scale));
        }
        if texels.iter().flatten().any(|c| !c.is_finite()) {
            return Err(format!("the environment image {shown} times scale {scale} overflows a 32-bit float"));
        }
        let to_map = glam::Mat3::from_rotation_y(-rotate_deg.to_radians());
        Ok(EnvironmentMap { file: path, width, height, texels, to_map })
    }

    /// The mean radiance over the sphere (rows weighted by their solid angle).
    pub fn mean(&self) -> glam::Vec3 {
        let (mut sum, mut total) = (glam::DVec3::ZERO, 0.0f64);
        for (i, t) in self.texels.iter().enumerate() {
            let y = i / self.width as usize;
            let w = (std::f64::consts::PI * (y as f64 + 0.5) / self.height as f64).sin();
            sum += w * glam::DVec3::new(t[0] as f64, t[1] as f64, t[2] as f64);
            total += w;
        }
        (sum / total.max(f64::MIN_POSITIVE)).as_vec3()
    }
}
