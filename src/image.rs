//! Linear HDR RGB images and their files: `.exr` (linear 32-bit float RGB, lossless)
//! and `.png` (8-bit sRGB, for viewing).
//!
//! Saving writes a temporary file next to the target and renames it over the
//! target, so an interrupted save never leaves a truncated image behind.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::{bail, Context};
use image::codecs::openexr::OpenExrEncoder;
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder, ImageFormat, ImageReader};

/// Linear RGB image, row-major from the top-left, f32 per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// `width * height` pixels, row by row from the top-left.
    pub pixels: Vec<[f32; 3]>,
}

/// The file formats [`Image::save`] and [`Image::load`] know: by extension
/// when saving, by content when loading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// 8-bit sRGB, clamped to [0, 1]: for viewing, not for measuring.
    Png,
    /// 32-bit float linear RGB.
    Exr,
}

impl Format {
    /// The format as error messages name it.
    pub fn describe(self) -> &'static str {
        match self {
            Format::Png => "a PNG (8-bit sRGB, clamped to 1)",
            Format::Exr => "an EXR (linear float)",
        }
    }
}

const SUPPORTED: &str = ".png (8-bit sRGB) and .exr (32-bit float linear)";

fn format_of(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "png" => Some(Format::Png),
        "exr" => Some(Format::Exr),
        _ => None,
    }
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, pixels: vec![[0.0; 3]; width as usize * height as usize] }
    }

    /// The pixel at column `x`, row `y` (row 0 at the top).
    ///
    /// # Panics
    /// If `(x, y)` lies outside the image.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside a {}x{} image", self.width, self.height);
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Saves by extension: .png (clamped to [0, 1], sRGB-encoded (the exact
    /// piecewise sRGB curve), 8-bit RGB; NaN is written as 0) or .exr (linear
    /// 32-bit float RGB). Other extensions: an error naming the path and the
    /// supported extensions. The parent directory must exist (it is not created).
    pub fn save(&self, path: &Path) -> anyhow::Result<()> {
        let Some(format) = format_of(path) else {
            bail!("cannot save image {}: unsupported file extension; supported: {SUPPORTED}", path.display());
        };
        let expected = self.width as usize * self.height as usize;
        if self.width == 0 || self.height == 0 || self.pixels.len() != expected {
            bail!(
                "cannot save image {}: a {}x{} image needs {} pixels (and neither side may be 0), it has {}",
                path.display(),
                self.width,
                self.height,
                expected,
                self.pixels.len()
            );
        }
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if !parent.is_dir() {
            bail!("cannot save image {}: the directory {} does not exist", path.display(), parent.display());
        }

        let temp = temp_path(&parent, path);
        let result = self.write_to(&temp, format).and_then(|()| {
            std::fs::rename(&temp, path)
                .with_context(|| format!("renaming the temporary file {} over it failed", temp.display()))
        });
        if result.is_err() {
            let _ = std::fs::remove_file(&temp);
        }
        result.with_context(|| format!("cannot save image {}", path.display()))
    }

    fn write_to(&self, temp: &Path, format: Format) -> anyhow::Result<()> {
        let file = File::create(temp).with_context(|| format!("cannot create temporary file {}", temp.display()))?;
        let mut writer = BufWriter::new(file);
        match format {
            Format::Png => {
                let bytes: Vec<u8> = self.pixels.iter().flat_map(|p| p.map(to_srgb8)).collect();
                PngEncoder::new(&mut writer).write_image(&bytes, self.width, self.height, ExtendedColorType::Rgb8)?;
            }
            Format::Exr => {
                OpenExrEncoder::new(&mut writer).write_image(
                    bytemuck::cast_slice(&self.pixels),
                    self.width,
                    self.height,
                    ExtendedColorType::Rgb32F,
                )?;
            }
        }
        let file = writer
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("cannot write temporary file {}", temp.display()))?;
        file.sync_all().with_context(|| format!("cannot write temporary file {}", temp.display()))?;
        Ok(())
    }

    /// Loads an .exr written by [`save`](Self::save) (or any RGB/RGBA float EXR;
    /// alpha is dropped) into linear RGB; a .png is decoded from sRGB to linear.
    /// Errors name the path.
    pub fn load(path: &Path) -> anyhow::Result<Image> {
        Ok(Image::load_format(path)?.0)
    }

    /// [`load`](Self::load), and the format the file's content turned out to be.
    pub fn load_format(path: &Path) -> anyhow::Result<(Image, Format)> {
        let load = || -> anyhow::Result<(Image, Format)> {
            let file = File::open(path)?;
            let mut reader = ImageReader::new(BufReader::new(file)).with_guessed_format()?;
            reader.no_limits();
            let format = match reader.format() {
                Some(ImageFormat::OpenExr) => Format::Exr,
                Some(ImageFormat::Png) => Format::Png,
                Some(other) => bail!("unsupported image format {other:?}; supported: {SUPPORTED}"),
                None => bail!("not a recognised image file; supported: {SUPPORTED}"),
            };
            // The decoder's own message, once: its error repeats its source in
            // its text, which an error chain would print twice.
            let decoded = reader.decode().map_err(|e| {
                let what = match format {
                    Format::Exr => "an EXR that rlpt can read (it needs float R, G and B channels; truncated?)",
                    Format::Png => "a PNG that rlpt can read (truncated?)",
                };
                anyhow::anyhow!("not {what}: {e}")
            })?;
            let (width, height) = (decoded.width(), decoded.height());
            let rgb = decoded.into_rgb32f();
            let pixels = match format {
                Format::Exr => rgb.pixels().map(|p| p.0).collect(),
                Format::Png => rgb.pixels().map(|p| p.0.map(srgb_decode)).collect(),
            };
            Ok((Image { width, height, pixels }, format))
        };
        load().with_context(|| format!("cannot load image {}", path.display()))
    }

    /// The first pixel `(x, y)`, row by row, with a NaN or infinite channel.
    pub fn first_non_finite(&self) -> Option<(u32, u32)> {
        let i = self.pixels.iter().position(|p| p.iter().any(|c| !c.is_finite()))?;
        Some((i as u32 % self.width, i as u32 / self.width))
    }
}

/// A unique temporary name in `dir` for writing `target`.
fn temp_path(dir: &Path, target: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let stem = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    dir.join(format!(".{stem}.{}-{n}.tmp", std::process::id()))
}

/// Clamped to [0,1] (NaN -> 0), sRGB-encoded, rounded to 8 bits.
fn to_srgb8(linear: f32) -> u8 {
    let clamped = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    (srgb_encode(clamped) * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

/// The sRGB transfer function (IEC 61966-2-1): linear [0, 1] -> encoded [0, 1].
/// Values outside [0, 1] follow the same formula (negative values map to
/// `12.92 * linear`).
pub fn srgb_encode(linear: f32) -> f32 {
    let l = f64::from(linear);
    let e = if l <= 0.0031308 { 12.92 * l } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    e as f32
}

/// The inverse of [`srgb_encode`]: encoded [0, 1] -> linear [0, 1].
pub fn srgb_decode(encoded: f32) -> f32 {
    let e = f64::from(encoded);
    let l = if e <= 0.04045 { e / 12.92 } else { ((e + 0.055) / 1.055).powf(2.4) };
    l as f32
}
