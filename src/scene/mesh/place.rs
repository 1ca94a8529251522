//! A mesh file placed in the world by its `[[mesh]]` table: positions by the
//! transform, shading normals by its inverse transpose (or computed), and the
//! triangles that a transform flattens to zero area in f32 skipped.

use glam::{DMat3, DMat4, DVec3, Vec3};

use super::MeshFile;

/// The `[[mesh]]` transform of `scale`, `rotate` and `translate`: scale, then
/// rotate about x, then y, then z (degrees, right-handed), then translate,
/// for column vectors (p' = M p).
pub fn compose_transform(scale: DVec3, rotate_degrees: DVec3, translate: DVec3) -> DMat4 {
    DMat4::from_translation(translate)
        * DMat4::from_rotation_z(rotate_degrees.z.to_radians())
        * DMat4::from_rotation_y(rotate_degrees.y.to_radians())
        * DMat4::from_rotation_x(rotate_degrees.x.to_radians())
        * DMat4::from_scale(scale)
}

/// A mesh file in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Placed {
    pub positions: Vec<Vec3>,
    /// Unit shading normals per vertex, where asked to be smooth.
    pub normals: Option<Vec<Vec3>>,
    /// A transform that mirrors (negative determinant) reverses each
    /// triangle's order, so that its front side stays the outside.
    pub triangles: Vec<[u32; 3]>,
    /// Per kept triangle, its index among the file's triangles.
    pub file_triangles: Vec<u32>,
    /// The file's triangles of zero area in world space (f32), skipped.
    pub skipped_degenerate: usize,
}

/// Why a placed mesh is refused.
#[derive(Clone, Debug, PartialEq)]
pub enum PlaceError {
    /// A vertex not finite, or beyond +-`limit` on some axis, after the transform.
    OutOfRange { vertex: usize, position: DVec3 },
    /// Every triangle has zero area after the transform.
    AllDegenerate { triangles: usize },
}

/// Places `file` by `matrix` (affine, invertible); every position must land
/// within +-`limit`. With `smooth`, the file's normals (by the inverse
/// transpose, renormalised) or, where it has none or one is zero, the
/// area-weighted average of the normals of the triangles around the vertex.
pub fn place(file: &MeshFile, matrix: &DMat4, smooth: bool, limit: f64) -> Result<Placed, PlaceError> {
    let mut world = Vec::with_capacity(file.positions.len());
    for (vertex, p) in file.positions.iter().enumerate() {
        let w = matrix.transform_point3(p.as_dvec3());
        if !w.is_finite() || w.abs().max_element() > limit {
            return Err(PlaceError::OutOfRange { vertex, position: w });
        }
        world.push(w);
    }
    let positions: Vec<Vec3> = world.iter().map(|w| w.as_vec3()).collect();
    let linear = DMat3::from_mat4(*matrix);
    let mirrored = linear.determinant() < 0.0;

    let mut triangles = Vec::with_capacity(file.triangles.len());
    let mut file_triangles = Vec::with_capacity(file.triangles.len());
    for (k, &[a, b, c]) in file.triangles.iter().enumerate() {
        let t = if mirrored { [a, c, b] } else { [a, b, c] };
        let [pa, pb, pc] = t.map(|i| positions[i as usize]);
        if (pb - pa).cross(pc - pa) == Vec3::ZERO {
            continue;
        }
        triangles.push(t);
        file_triangles.push(k as u32);
    }
    if triangles.is_empty() {
        return Err(PlaceError::AllDegenerate { triangles: file.triangles.len() });
    }
    let skipped_degenerate = file.triangles.len() - triangles.len();
    let normals = smooth.then(|| shading_normals(file, &world, &triangles, &linear));
    Ok(Placed { positions, normals, triangles, file_triangles, skipped_degenerate })
}

/// Unit world-space normals per vertex: the file's by the inverse transpose,
/// else the area-weighted average around the vertex, else the normal of its
/// first triangle; +z for a vertex no triangle uses.
fn shading_normals(file: &MeshFile, world: &[DVec3], triangles: &[[u32; 3]], linear: &DMat3) -> Vec<Vec3> {
    let n = world.len();
    let mut sum = vec![DVec3::ZERO; n];
    let mut first = vec![DVec3::ZERO; n];
    for &[a, b, c] in triangles {
        let (pa, pb, pc) = (world[a as usize], world[b as usize], world[c as usize]);
        // Twice the area times the unit normal: the area weights.
        let cross = (pb - pa).cross(pc - pa);
        for i in [a, b, c] {
            sum[i as usize] += cross;
            if first[i as usize] == DVec3::ZERO {
                first[i as usize] = cross;
            }
        }
    }
    let normal_matrix = linear.inverse().transpose();
    let unit = |v: DVec3| {
        let u = v.normalize_or_zero();
        (u != DVec3::ZERO && u.is_finite()).then_some(u)
    };
    (0..n)
        .map(|i| {
            let from_file = file.normals.as_ref().and_then(|normals| unit(normal_matrix * normals[i].as_dvec3()));
            let u = from_file.or_else(|| unit(sum[i])).or_else(|| unit(first[i])).unwrap_or(DVec3::Z);
            u.as_vec3().normalize()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, normals: Option<Vec<Vec3>>) -> MeshFile {
        MeshFile {
            positions,
            normals,
            uvs: None,
            triangles,
            triangle_materials: Vec::new(),
            materials: Vec::new(),
            notes: Vec::new(),
            skipped_degenerate: 0,
        }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-6
    }

    #[test]
    fn scale_then_rotate_x_y_z_then_translate() {
        let m = compose_transform(DVec3::new(2.0, 1.0, 1.0), DVec3::new(0.0, 90.0, 0.0), DVec3::new(0.0, 0.0, 5.0));
        // x scaled to 2, turned 90 degrees about y (x -> -z), moved by +5 in z.
        let p = m.transform_point3(DVec3::X);
        assert!((p - DVec3::new(0.0, 0.0, 3.0)).length() < 1e-12, "{p}");
        // The x rotation comes before the z rotation: y -> z (about x) -> z (about z).
        let m = compose_transform(DVec3::ONE, DVec3::new(90.0, 0.0, 90.0), DVec3::ZERO);
        let p = m.transform_point3(DVec3::Y);
        assert!((p - DVec3::Z).length() < 1e-12, "{p}");
    }

    #[test]
    fn normals_by_the_inverse_transpose() {
        // A triangle in the plane x + y = 1, its normal (1, 1, 0)/sqrt(2).
        let f =
            file(vec![Vec3::X, Vec3::Y, Vec3::X + Vec3::Z], vec![[0, 1, 2]], Some(vec![Vec3::new(1.0, 1.0, 0.0); 3]));
        let m = compose_transform(DVec3::new(2.0, 1.0, 1.0), DVec3::ZERO, DVec3::ZERO);
        let placed = place(&f, &m, true, 1e12).unwrap();
        // Stretched by 2 in x: the plane is x/2 + y = 1, normal (1, 2, 0)/sqrt(5),
        // not the transformed (2, 1, 0).
        let expected = Vec3::new(1.0, 2.0, 0.0).normalize();
        for n in placed.normals.unwrap() {
            assert!(close(n, expected), "{n} vs {expected}");
        }
        // Without `smooth`, none.
        assert_eq!(place(&f, &m, false, 1e12).unwrap().normals, None);
    }

    #[test]
    fn computed_normals_are_area_weighted_and_unit() {
        // Two triangles at a vertex: a large one facing +z, a small one facing +x.
        let f =
            file(vec![Vec3::ZERO, Vec3::X * 10.0, Vec3::Y * 10.0, Vec3::Y, Vec3::Z], vec![[0, 1, 2], [0, 3, 4]], None);
        let placed = place(&f, &DMat4::IDENTITY, true, 1e12).unwrap();
        let n = placed.normals.unwrap();
        assert!(close(n[0], Vec3::new(1.0, 0.0, 100.0).normalize()), "{}", n[0]);
        assert!(close(n[1], Vec3::Z) && close(n[3], Vec3::X));
    }

    #[test]
    fn a_mirror_keeps_the_front_side() {
        let f = file(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]], None);
        let m = compose_transform(DVec3::new(-1.0, 1.0, 1.0), DVec3::ZERO, DVec3::ZERO);
        let placed = place(&f, &m, true, 1e12).unwrap();
        assert_eq!(placed.triangles, vec![[0, 2, 1]]);
        let [a, b, c] = placed.triangles[0].map(|i| placed.positions[i as usize]);
        assert!(close((b - a).cross(c - a).normalize(), Vec3::Z));
        assert!(close(placed.normals.unwrap()[0], Vec3::Z));
    }

    #[test]
    fn refusals() {
        let f = file(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]], None);
        let far = DMat4::from_translation(DVec3::new(0.0, 2e12, 0.0));
        assert_eq!(
            place(&f, &far, false, 1e12),
            Err(PlaceError::OutOfRange { vertex: 0, position: DVec3::new(0.0, 2e12, 0.0) })
        );
        // A scale that leaves the area 0 in f32: every triangle skipped.
        let tiny = DMat4::from_scale(DVec3::splat(1e-30));
        assert_eq!(place(&f, &tiny, false, 1e12), Err(PlaceError::AllDegenerate { triangles: 1 }));
    }
}
