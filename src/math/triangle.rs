//! Watertight ray/triangle intersection after Woop, Benthin and Wald,
//! "Watertight Ray/Triangle Intersection" (JCGT 2(1), 2013); `glsl/bvh.glsl`
//! `intersect_triangle` is the twin, operation for operation.
//!
//! The ray is moved to the origin, its axes permuted so that its largest
//! component is z, and the triangle sheared so that the ray becomes the z axis.
//! Whether the ray meets the triangle is then the sign of three 2D edge
//! functions of the sheared vertices. A vertex's sheared coordinates depend on
//! the vertex and the ray alone, and an edge's function is the same product
//! difference (negated) in the two triangles that share it, so a ray that
//! crosses a mesh finds at least one of them: no cracks along edges or at
//! vertices. Where an edge function rounds to exactly 0 it is recomputed
//! exactly (f64 here, the products' rounding errors on the GPU), so that a ray
//! next to an edge is never put on its wrong side.

use super::Vec3;

/// A ray set up for [`TriangleRay::intersect`]: the permutation and shear of
/// the paper, computed once per ray (the BVH walk tests many triangles).
#[derive(Clone, Copy, Debug)]
pub struct TriangleRay {
    /// The axis of the direction's largest component (`kz`); `kx`, `ky` follow it cyclically.
    kz: usize,
    /// The origin, permuted to (kx, ky, kz).
    o: Vec3,
    /// The shear: d[kx] / d[kz], d[ky] / d[kz] and 1 / d[kz].
    sx: f32,
    sy: f32,
    sz: f32,
}

/// `v` with its axes in the order (kx, ky, kz), kx = kz + 1 and ky = kz + 2 (mod 3).
fn permute(v: Vec3, kz: usize) -> Vec3 {
    match kz {
        0 => Vec3::new(v.y, v.z, v.x),
        1 => Vec3::new(v.z, v.x, v.y),
        _ => v,
    }
}

/// `a.x b.y - a.y b.x`, exact in sign where it rounds to 0 in f32: the products
/// of two f32 are exact in f64, so their difference is rounded once.
/// (`glsl/bvh.glsl` gets the same number from the products' rounding errors.)
fn edge_function(a: Vec3, b: Vec3) -> f32 {
    let e = a.x * b.y - a.y * b.x;
    if e != 0.0 {
        return e;
    }
    (a.x as f64 * b.y as f64 - a.y as f64 * b.x as f64) as f32
}

impl TriangleRay {
    /// The ray from `o` along `d` (any length but 0). The paper swaps kx and ky
    /// where `d[kz] < 0` to keep the winding's sign; the test here is two-sided,
    /// so it does not.
    pub fn new(o: Vec3, d: Vec3) -> TriangleRay {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let dp = permute(d, kz);
        TriangleRay { kz, o: permute(o, kz), sx: dp.x / dp.z, sy: dp.y / dp.z, sz: 1.0 / dp.z }
    }

    /// The distance along the ray to the triangle (v0, v1, v2), hit from either
    /// side, if it lies in (0, t_max), in units of the ray's direction.
    pub fn intersect(&self, v0: Vec3, v1: Vec3, v2: Vec3, t_max: f32) -> Option<f32> {
        let a = permute(v0, self.kz) - self.o;
        let b = permute(v1, self.kz) - self.o;
        let c = permute(v2, self.kz) - self.o;
        // The sheared vertices (x, y); z is scaled below, once the ray is known to hit.
        let shear = |p: Vec3| Vec3::new(p.x - self.sx * p.z, p.y - self.sy * p.z, p.z);
        let (a, b, c) = (shear(a), shear(b), shear(c));
        let u = edge_function(c, b);
        let v = edge_function(a, c);
        let w = edge_function(b, a);
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None; // the ray lies in the triangle's plane, or the triangle has no area
        }
        let t = (u * (self.sz * a.z) + v * (self.sz * b.z) + w * (self.sz * c.z)) / det;
        (t > 0.0 && t < t_max).then_some(t)
    }
}

/// The distance along the ray from `o` along `d` to the triangle (v0, v1, v2),
/// from either side, if it lies in (0, t_max) ([`TriangleRay`]).
/// `glsl/bvh.glsl` `intersect_triangle`.
pub fn intersect_triangle(v0: Vec3, v1: Vec3, v2: Vec3, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
    TriangleRay::new(o, d).intersect(v0, v1, v2, t_max)
}

/// Whether the segment from `o` to `o + t_max d` meets the triangle (a shadow ray's test).
pub fn triangle_blocks(v0: Vec3, v1: Vec3, v2: Vec3, o: Vec3, d: Vec3, t_max: f32) -> bool {
    intersect_triangle(v0, v1, v2, o, d, t_max).is_some()
}

/// A point uniform by area on the triangle (v0, v1, v2) from `u` (the square
/// root warp, pbrt's `SampleUniformTriangle`), its unit geometric normal and the
/// triangle's area. `glsl/geometry.glsl` `sample_triangle`.
pub fn sample_triangle(v0: Vec3, v1: Vec3, v2: Vec3, u: [f32; 2]) -> (Vec3, Vec3, f32) {
    let su = u[0].sqrt();
    let (b0, b1) = (1.0 - su, u[1] * su);
    let p = b0 * v0 + b1 * v1 + (1.0 - b0 - b1) * v2;
    let c = (v1 - v0).cross(v2 - v0);
    let len = c.length();
    (p, c / len, 0.5 * len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::Rng;

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn hits_from_both_sides_at_the_plane_distance() {
        let (a, b, c) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
        let t = intersect_triangle(a, b, c, v(0.25, 0.25, 2.0), v(0.0, 0.0, -1.0), 10.0).unwrap();
        assert_eq!(t, 2.0);
        let t = intersect_triangle(a, b, c, v(0.25, 0.25, -3.0), v(0.0, 0.0, 1.0), 10.0).unwrap();
        assert_eq!(t, 3.0);
        // A direction of length 2 halves t.
        let t = intersect_triangle(a, b, c, v(0.25, 0.25, -3.0), v(0.0, 0.0, 2.0), 10.0).unwrap();
        assert_eq!(t, 1.5);
    }

    #[test]
    fn misses_outside_behind_beyond_and_in_plane() {
        let (a, b, c) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
        let down = v(0.0, 0.0, -1.0);
        assert_eq!(intersect_triangle(a, b, c, v(0.6, 0.6, 1.0), down, 10.0), None, "outside the hypotenuse");
        assert_eq!(intersect_triangle(a, b, c, v(-0.1, 0.2, 1.0), down, 10.0), None, "outside an edge");
        assert_eq!(intersect_triangle(a, b, c, v(0.2, 0.2, -1.0), down, 10.0), None, "behind the origin");
        assert_eq!(intersect_triangle(a, b, c, v(0.2, 0.2, 1.0), down, 1.0), None, "t_max is exclusive");
        assert_eq!(intersect_triangle(a, b, c, v(0.2, 0.2, 1.0), down, 0.999), None, "beyond t_max");
        assert_eq!(intersect_triangle(a, b, c, v(-1.0, 0.2, 0.0), v(1.0, 0.0, 0.0), 10.0), None, "in the plane");
        assert_eq!(intersect_triangle(a, b, a, v(0.0, 0.0, 1.0), down, 10.0), None, "no area");
    }

    #[test]
    fn edges_and_vertices_hit_and_both_triangles_of_a_shared_edge_agree() {
        // Two triangles of a square sharing the diagonal (0,0)-(1,1), the second
        // wound the other way round: a ray through the diagonal hits both.
        let (p00, p10, p11, p01) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(0.0, 1.0, 0.0));
        let down = v(0.0, 0.0, -1.0);
        for x in [0.0, 0.25, 0.5, 1.0] {
            let o = v(x, x, 1.0);
            assert!(intersect_triangle(p00, p10, p11, o, down, 10.0).is_some(), "diagonal at {x}, lower");
            assert!(intersect_triangle(p00, p11, p01, o, down, 10.0).is_some(), "diagonal at {x}, upper");
        }
        // An outer edge and a vertex, exactly.
        assert!(intersect_triangle(p00, p10, p11, v(0.5, 0.0, 1.0), down, 10.0).is_some());
        assert!(intersect_triangle(p00, p10, p11, v(1.0, 0.0, 1.0), down, 10.0).is_some());
    }

    #[test]
    fn edge_function_is_exact_where_f32_cancels() {
        // 3 * f32(1/3) rounds to 1 in f32, but is 1 + 2^-25 exactly.
        let (a, b) = (v(3.0, 1.0, 0.0), v(1.0, 1.0 / 3.0, 0.0));
        assert_eq!(a.x * b.y - a.y * b.x, 0.0, "f32 cancels");
        assert_eq!(edge_function(a, b), 2f32.powi(-25));
        assert_eq!(edge_function(b, a), -(2f32.powi(-25)), "the shared edge's other side");
    }

    #[test]
    fn agrees_with_a_plane_and_barycentric_test_in_f64() {
        let mut rng = Rng::new(11, 0, 0, 0);
        let mut r = || rng.next_f32() * 2.0 - 1.0;
        let (mut hits, mut checked) = (0, 0);
        for _ in 0..20_000 {
            let (a, b, c) = (v(r(), r(), r()), v(r(), r(), r()), v(r(), r(), r()));
            let o = v(r(), r(), r()) * 2.0;
            // Towards a point of the triangle's plane in and around it.
            let (b1, b2) = (r() * 0.8 + 0.3, r() * 0.8 + 0.3);
            let d = (a + b1 * (b - a) + b2 * (c - a) - o) * (1.0 + r());
            let got = intersect_triangle(a, b, c, o, d, 100.0);
            // Reference in f64: Moller-Trumbore.
            let (a, b, c, o, d) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3(), o.as_dvec3(), d.as_dvec3());
            let (e1, e2) = (b - a, c - a);
            let p = d.cross(e2);
            let det = e1.dot(p);
            let s = o - a;
            let bu = s.dot(p) / det;
            let q = s.cross(e1);
            let bv = d.dot(q) / det;
            let t = e2.dot(q) / det;
            // Leave out rays within rounding of an edge or the plane.
            let margin = 1e-4;
            if det.abs() < 1e-3 || [bu, bv, 1.0 - bu - bv].iter().any(|x| x.abs() < margin) || t.abs() < margin {
                continue;
            }
            checked += 1;
            let want = bu > 0.0 && bv > 0.0 && bu + bv < 1.0 && t > 0.0 && t < 100.0;
            assert_eq!(got.is_some(), want, "triangle {a} {b} {c}, ray {o} {d}");
            if let Some(g) = got {
                hits += 1;
                assert!((g as f64 - t).abs() <= 1e-4 * t.max(1.0), "t {g} vs {t}");
            }
        }
        assert!(checked > 15_000 && hits > 3000, "{checked} checked, {hits} hits");
    }
}
