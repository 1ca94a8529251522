//! Pure helpers of the viewer: where the image sits in the window, which pixel
//! the cursor is over, and the false-colour picture of one voxel's learned values.

use crate::guide::Bins;

/// Where a `render` image goes in a `window` so that it fits whole, keeps its
/// aspect ratio and is centred: (x, y, width, height) in window pixels.
pub fn letterbox(render: (u32, u32), window: (u32, u32)) -> (i32, i32, u32, u32) {
    let scale = (window.0 as f64 / render.0 as f64).min(window.1 as f64 / render.1 as f64);
    let w = ((render.0 as f64 * scale).round() as u32).clamp(1, window.0.max(1));
    let h = ((render.1 as f64 * scale).round() as u32).clamp(1, window.1.max(1));
    (((window.0 - w) / 2) as i32, ((window.1 - h) / 2) as i32, w, h)
}

/// The image pixel under window position `pos`, given the image's letterbox `rect`;
/// `None` on the borders.
pub fn window_to_pixel(rect: (i32, i32, u32, u32), render: (u32, u32), pos: (f64, f64)) -> Option<(u32, u32)> {
    let (x, y, w, h) = rect;
    let u = (pos.0 - x as f64) / w as f64;
    let v = (pos.1 - y as f64) / h as f64;
    if !(0.0..1.0).contains(&u) || !(0.0..1.0).contains(&v) {
        return None;
    }
    Some((((u * render.0 as f64) as u32).min(render.0 - 1), ((v * render.1 as f64) as u32).min(render.1 - 1)))
}

/// A `width` x `height` picture of one voxel's values `q` (one per bin of `bins`),
/// as RGBA8 texels (R in the low byte): columns are phi = atan2(y, x) from 0 at the
/// left to 2 pi at the right, rows are cos theta = z from +1 at the top to -1 at the
/// bottom, each bin a block in false colour (`shade`: two decades on a log scale,
/// from black through red and yellow to white at the voxel's largest value), with a
/// grey frame. Equal-area bins make equal blocks.
pub fn inset_texels(q: &[f32], bins: Bins, width: u32, height: u32) -> Vec<u32> {
    assert_eq!(q.len(), bins.count() as usize, "one value per bin");
    let max = q.iter().cloned().filter(|v| v.is_finite()).fold(0.0f32, f32::max);
    let mut out = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            if x == 0 || y == 0 || x + 1 == width || y + 1 == height {
                out.push(pack([128, 128, 128]));
                continue;
            }
            let row = ((y as u64 * bins.rows as u64) / height as u64) as u32;
            let col = ((x as u64 * bins.cols as u64) / width as u64) as u32;
            out.push(pack(heat(shade(q[(row * bins.cols + col) as usize], max))));
        }
    }
    out
}

/// Where `v` lies between 1% of `max` (0) and `max` (1), on a log scale: light
/// through a small opening is often a hundred times brighter than the rest, and a
/// linear scale would show only that. Zero, negative or non-finite values give 0.
pub fn shade(v: f32, max: f32) -> f32 {
    if !(max > 0.0) || !(v > 0.0) || !v.is_finite() {
        return 0.0;
    }
    ((v / max).log10() / 2.0 + 1.0).clamp(0.0, 1.0)
}

/// Black -> red -> yellow -> white for t in [0, 1].
pub fn heat(t: f32) -> [u8; 3] {
    let c = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [c(3.0 * t), c(3.0 * t - 1.0), c(3.0 * t - 2.0)]
}

fn pack([r, g, b]: [u8; 3]) -> u32 {
    r as u32 | (g as u32) << 8 | (b as u32) << 16 | 255 << 24
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letterbox_fits_and_centres() {
        assert_eq!(letterbox((320, 240), (320, 240)), (0, 0, 320, 240));
        assert_eq!(letterbox((320, 240), (640, 240)), (160, 0, 320, 240));
        assert_eq!(letterbox((320, 240), (320, 480)), (0, 120, 320, 240));
        assert_eq!(letterbox((100, 100), (300, 200)), (50, 0, 200, 200));
    }

    #[test]
    fn cursor_maps_to_pixels_and_borders_to_none() {
        let rect = letterbox((100, 50), (200, 200));
        assert_eq!(rect, (0, 50, 200, 100));
        assert_eq!(window_to_pixel(rect, (100, 50), (0.0, 50.0)), Some((0, 0)));
        assert_eq!(window_to_pixel(rect, (100, 50), (199.9, 149.9)), Some((99, 49)));
        assert_eq!(window_to_pixel(rect, (100, 50), (10.0, 20.0)), None);
        assert_eq!(window_to_pixel(rect, (100, 50), (10.0, 150.0)), None);
    }

    #[test]
    fn inset_places_each_bin_in_its_block() {
        let bins = Bins { rows: 2, cols: 4 };
        let mut q = vec![0.0; 8];
        q[6] = 2.0; // row 1 (z < 0), column 2 (phi in [pi, 3pi/2))
        q[1] = 1.0; // row 0, column 1
        let t = inset_texels(&q, bins, 42, 22);
        let at = |x: u32, y: u32| t[(y * 42 + x) as usize];
        assert_eq!(at(0, 0), pack([128, 128, 128]), "frame");
        assert_eq!(at(25, 15), pack(heat(1.0)), "the brightest bin is white");
        assert_eq!(at(15, 5), pack(heat(shade(1.0, 2.0))), "half as bright");
        assert_eq!(at(5, 5), pack(heat(0.0)), "nothing learned is black");
        assert!((shade(1.0, 2.0) - (1.0 - 0.150515)).abs() < 1e-5, "log10(1/2)/2 + 1");
        assert_eq!(shade(0.1, 10.0), 0.0, "a hundredth of the largest is black");
        assert_eq!(shade(1.0, 0.0), 0.0, "an empty voxel is black");
        assert_eq!(heat(1.0), [255, 255, 255]);
        assert_eq!(heat(0.0), [0, 0, 0]);
    }
}
