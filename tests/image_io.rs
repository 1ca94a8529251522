//! Image files: EXR round-trips exactly, PNG within one 8-bit step of sRGB,
//! and every failure names the path.

mod common;

use common::cli::fresh_dir;
use std::path::Path;

use rlpt::image::{srgb_decode, srgb_encode, Image};

/// Deterministic pseudo-random numbers in [0, 1).
fn uniform(state: &mut u64) -> f32 {
    *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*state >> 40) as f32) / (1u64 << 24) as f32
}

fn test_image(width: u32, height: u32, lo: f32, hi: f32) -> Image {
    let mut state = 12345;
    let mut image = Image::new(width, height);
    for p in &mut image.pixels {
        for c in p.iter_mut() {
            *c = lo + (hi - lo) * uniform(&mut state);
        }
    }
    image
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

#[test]
fn new_is_black_and_get_is_row_major() {
    let mut image = Image::new(3, 2);
    assert_eq!(image.pixels.len(), 6);
    assert!(image.pixels.iter().all(|p| *p == [0.0; 3]));
    image.pixels[3 + 2] = [1.0, 2.0, 3.0];
    assert_eq!(image.get(2, 1), [1.0, 2.0, 3.0]);
    assert_eq!(image.get(0, 0), [0.0; 3]);
}

#[test]
#[should_panic]
fn get_outside_panics() {
    Image::new(3, 2).get(3, 0);
}

#[test]
fn exr_round_trip_is_exact() {
    let dir = fresh_dir("exr_round_trip");
    let mut image = test_image(37, 23, -2.0, 1000.0);
    // Awkward values: zero, negative zero, subnormal, tiny, huge, max.
    image.pixels[0] = [0.0, -0.0, f32::MIN_POSITIVE / 8.0];
    image.pixels[1] = [1e-30, 65504.5, f32::MAX];
    image.pixels[2] = [f32::EPSILON, 1.0 + f32::EPSILON, -1e20];
    let path = dir.join("round.exr");
    image.save(&path).unwrap();
    let back = Image::load(&path).unwrap();
    assert_eq!((back.width, back.height), (37, 23));
    for (i, (a, b)) in image.pixels.iter().zip(&back.pixels).enumerate() {
        for c in 0..3 {
            assert_eq!(a[c].to_bits(), b[c].to_bits(), "pixel {i} channel {c}: {a:?} vs {b:?}");
        }
    }
    assert_eq!(files_in(&dir), ["round.exr"], "a temporary file was left behind");
}

#[test]
fn exr_extension_is_case_insensitive() {
    let dir = fresh_dir("exr_upper");
    let image = test_image(4, 4, 0.0, 5.0);
    let path = dir.join("UPPER.EXR");
    image.save(&path).unwrap();
    assert_eq!(Image::load(&path).unwrap(), image);
}

#[test]
fn png_round_trip_within_one_step() {
    let dir = fresh_dir("png_round_trip");
    let mut image = test_image(41, 19, -0.5, 1.5);
    image.pixels[0] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    image.pixels[1] = [0.0, 1.0, 0.0031308];
    let path = dir.join("round.png");
    image.save(&path).unwrap();
    let back = Image::load(&path).unwrap();
    assert_eq!((back.width, back.height), (41, 19));
    for (i, (a, b)) in image.pixels.iter().zip(&back.pixels).enumerate() {
        for c in 0..3 {
            let clamped = if a[c].is_nan() { 0.0 } else { a[c].clamp(0.0, 1.0) };
            let want = srgb_encode(clamped);
            let got = srgb_encode(b[c]);
            assert!(
                (want - got).abs() <= 1.0 / 255.0 + 1e-6,
                "pixel {i} channel {c}: wrote {} (sRGB {want}), read back sRGB {got}",
                a[c]
            );
        }
    }
    // NaN -> 0, +inf -> 1, -inf -> 0, exactly.
    assert_eq!(back.pixels[0], [0.0, 1.0, 0.0]);
    assert_eq!(back.pixels[1][0], 0.0);
    assert_eq!(back.pixels[1][1], 1.0);
    assert_eq!(files_in(&dir), ["round.png"], "a temporary file was left behind");
}

#[test]
fn png_stores_rounded_srgb_bytes() {
    // Linear 0.5 is sRGB 0.7353569, i.e. byte 187.5 -> 188; 0.2140 is sRGB ~0.5 -> 128.
    let dir = fresh_dir("png_bytes");
    let mut image = Image::new(2, 1);
    image.pixels[0] = [0.5, 0.0, 1.0];
    image.pixels[1] = [srgb_decode(128.0 / 255.0), 2.0, -1.0];
    let path = dir.join("bytes.png");
    image.save(&path).unwrap();
    let back = Image::load(&path).unwrap();
    let bytes: Vec<[u8; 3]> = back.pixels.iter().map(|p| p.map(|c| (srgb_encode(c) * 255.0).round() as u8)).collect();
    assert_eq!(bytes, [[188, 0, 255], [128, 255, 0]]);
}

#[test]
fn saving_overwrites() {
    let dir = fresh_dir("overwrite");
    let path = dir.join("twice.exr");
    test_image(8, 8, 0.0, 1.0).save(&path).unwrap();
    let second = test_image(3, 5, 2.0, 3.0);
    second.save(&path).unwrap();
    assert_eq!(Image::load(&path).unwrap(), second);
    assert_eq!(files_in(&dir), ["twice.exr"]);
}

#[test]
fn srgb_known_values() {
    assert_eq!(srgb_encode(0.0), 0.0);
    assert_eq!(srgb_decode(0.0), 0.0);
    assert!((srgb_encode(1.0) - 1.0).abs() < 1e-7);
    assert!((srgb_decode(1.0) - 1.0).abs() < 1e-7);
    assert!((srgb_encode(0.0031308) - 0.04045).abs() < 1e-5);
    assert!((srgb_decode(0.04045) - 0.0031308).abs() < 1e-6);
    assert!((srgb_encode(0.5) - 0.7353569).abs() < 1e-6);
    assert!((srgb_decode(0.7353569) - 0.5).abs() < 1e-6);
    // The linear segment.
    assert!((srgb_encode(0.001) - 0.01292).abs() < 1e-8);
    assert!((srgb_decode(0.01292) - 0.001).abs() < 1e-8);
    // Mid-grey: sRGB 0.5 is linear 0.2140411.
    assert!((srgb_decode(0.5) - 0.2140411).abs() < 1e-6);
}

#[test]
fn srgb_encode_and_decode_are_inverse() {
    for i in 0..=10_000 {
        let x = i as f32 / 10_000.0;
        let round = srgb_decode(srgb_encode(x));
        assert!((round - x).abs() <= 1e-6, "decode(encode({x})) = {round}");
        let round = srgb_encode(srgb_decode(x));
        assert!((round - x).abs() <= 1e-6, "encode(decode({x})) = {round}");
    }
    // Monotonic.
    let mut previous = -1.0;
    for i in 0..=1000 {
        let e = srgb_encode(i as f32 / 1000.0);
        assert!(e > previous);
        previous = e;
    }
}

#[test]
fn bad_extension_is_an_error() {
    let dir = fresh_dir("bad_extension");
    let image = Image::new(2, 2);
    for name in ["picture.jpg", "picture", "picture.png.txt"] {
        let path = dir.join(name);
        let message = format!("{:#}", image.save(&path).unwrap_err());
        assert!(message.contains(&path.display().to_string()), "{message}");
        assert!(message.contains(".png") && message.contains(".exr"), "{message}");
        assert!(!path.exists());
    }
    assert!(files_in(&dir).is_empty());
}

#[test]
fn missing_directory_is_an_error() {
    let dir = fresh_dir("missing_dir");
    let path = dir.join("no").join("such").join("out.exr");
    let message = format!("{:#}", Image::new(2, 2).save(&path).unwrap_err());
    assert!(message.contains(&path.display().to_string()), "{message}");
    assert!(message.contains("does not exist"), "{message}");
    assert!(!dir.join("no").exists(), "the directory must not be created");
}

#[test]
fn wrong_pixel_count_is_an_error() {
    let dir = fresh_dir("pixel_count");
    let mut image = Image::new(4, 4);
    image.pixels.pop();
    let path = dir.join("short.exr");
    let message = format!("{:#}", image.save(&path).unwrap_err());
    assert!(message.contains("short.exr") && message.contains("16 pixels"), "{message}");
    assert!(files_in(&dir).is_empty());
}

#[test]
fn loading_a_missing_file_names_it() {
    let dir = fresh_dir("missing_file");
    for name in ["nothing.exr", "nothing.png"] {
        let path = dir.join(name);
        let message = format!("{:#}", Image::load(&path).unwrap_err());
        assert!(message.contains(&path.display().to_string()), "{message}");
    }
}

#[test]
fn loading_garbage_names_the_file() {
    let dir = fresh_dir("garbage");
    let path = dir.join("garbage.exr");
    std::fs::write(&path, b"this is not an image").unwrap();
    let message = format!("{:#}", Image::load(&path).unwrap_err());
    assert!(message.contains(&path.display().to_string()), "{message}");
}

#[test]
fn loading_rgba_exr_drops_alpha() {
    let dir = fresh_dir("rgba");
    let path = dir.join("rgba.exr");
    let data: Vec<f32> = vec![0.25, 0.5, 2.0, 0.1, 7.0, 8.0, 9.0, 1.0];
    image::Rgba32FImage::from_raw(2, 1, data).unwrap().save_with_format(&path, image::ImageFormat::OpenExr).unwrap();
    let back = Image::load(&path).unwrap();
    assert_eq!((back.width, back.height), (2, 1));
    assert_eq!(back.pixels, [[0.25, 0.5, 2.0], [7.0, 8.0, 9.0]]);
}
