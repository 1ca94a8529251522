//! Files the tests write and read: files in a test's own directory
//! ([`super::cli::fresh_dir`]), the shared assets, and the encodings the mesh
//! and texture tests embed.

use std::path::{Path, PathBuf};

/// Writes `contents` to `dir/name` (making the folders of `name`) and returns the path.
pub fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&path, contents).unwrap();
    path
}

/// `../shared/assets/` beside the repository: other people's data (meshes, pbrt
/// scenes), never committed here (issue 36).
pub fn assets() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets");
    assert!(
        dir.is_dir(),
        "the shared assets are missing: expected the folder {} (the project's shared/assets/, which holds \
         other people's meshes and scenes that the repository does not commit; see issue 36)",
        dir.display()
    );
    dir
}

/// Standard base64 (with padding), for a `data:` uri.
pub fn base64(bytes: &[u8]) -> String {
    const TABLE: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk.iter().enumerate().fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for k in 0..=chunk.len() {
            out.push(TABLE[(n >> (18 - 6 * k) & 63) as usize] as char);
        }
    }
    while !out.len().is_multiple_of(4) {
        out.push('=');
    }
    out
}

/// The linear value of an 8-bit sRGB-encoded texel channel, as the renderers decode it.
pub fn srgb(b: u8) -> f32 {
    rlpt::scene::texture::srgb_to_linear(b as f32 / 255.0)
}

/// An RGBA8 PNG of `w` x `h` texels, rows from the top, encoded.
pub fn png_bytes(w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4]) -> Vec<u8> {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(texel(x, y)));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}
