//! Ray intersection, surface offsets and light sampling on a [`SceneArrays`];
//! `glsl/geometry.glsl` is the same code.

use super::{texture, Vec3};
use crate::layout::{prim_kind_index, prim_ref, GpuQuad, GpuSphere, GpuTriangle, RenderParams, Room, SceneArrays};
use crate::shared;
use glam::Vec2;
use std::f32::consts::PI;

/// A surface hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub p: Vec3,
    /// Unit geometric normal on the front side (outward for spheres, edge_u x edge_v
    /// for quads, (v1 - v0) x (v2 - v0) for triangles).
    pub n: Vec3,
    /// Unit shading normal, on the side of `n`: interpolated on smooth triangles, else `n`.
    pub ns: Vec3,
    /// Bound on the position error of `p`: origins of new rays move this far off the surface.
    pub eps: f32,
    pub material: u32,
    pub light: u32,
    /// Texture coordinates (`crate::math::texture`), where the scene has textures; else zero.
    pub uv: Vec2,
}

fn xyz(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

fn max_abs(v: Vec3) -> f32 {
    v.abs().max_element()
}

/// Position error bound of a hit at `p` on a primitive whose defining numbers
/// are as large as `scale` (sphere: |center| + radius; quad: |origin| + edges).
/// f32 rounds to 2^-24 relative; the factors leave a margin over the few
/// roundings of each intersection routine.
pub fn hit_epsilon(p: Vec3, scale: f32) -> f32 {
    1e-5 * (1.0 + max_abs(p)) + 2.5e-7 * scale
}

/// Where a line passes a sphere: f = o - C, b = -(f.d) (the distance along the
/// line to its nearest approach to the centre) and l^2 = |f + b d|^2 (the
/// square of that approach); `None` where the line misses, l^2 > r^2. Every
/// sphere test starts here, and most stop.
struct Approach {
    f: Vec3,
    b: f32,
    l2: f32,
}

fn approach(s: &GpuSphere, o: Vec3, d: Vec3) -> Option<Approach> {
    let r = s.center_radius[3];
    let f = o - xyz(s.center_radius);
    let b = -f.dot(d);
    let l2 = (f + b * d).length_squared();
    (l2 <= r * r).then_some(Approach { f, b, l2 })
}

/// Ray-sphere intersection that stays accurate in f32 for any radius, smallpt's
/// 1e5 walls included. It follows Haines et al., "Precision Improvements for
/// Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7): near-tangent
/// discriminants come from the perpendicular distance to the centre, and the
/// roots from the stable quadratic formula. `d` must be unit length.
///
/// One step more than the chapter, for c = |o - C|^2 - r^2, the power of the
/// origin: computed as (|o - C| - r)(|o - C| + r), it carries the rounding error
/// of |o - C|, half an ulp of r (0.004 at r = 1e5), which put smallpt's ceiling
/// 0.012 units too close on average and hid the rim of its lamp. The sphere
/// also has an anchor A, its point nearest the world origin, and the unit
/// normal n there (C = A - r n, see [`GpuSphere::new`]); with g = o - A,
///
/// ```text
/// c = g.g + 2 r (g.n)
/// ```
///
/// subtracts nothing of the size of r or r^2, and its error is a few ulps of
/// |o| + |A|, the sizes of the scene around the ray. With the origin inside
/// (c < 0) the discriminant is then b^2 - c, a sum of two positive numbers.
///
/// A compact sphere ([`GpuSphere::compact`]) takes [`intersect_sphere_compact`]
/// instead.
///
/// Misses, most tests, are rejected first by the chapter's perpendicular-distance
/// discriminant, from f = o - C with the f32 centre: b = -(f.d) and
/// l = |f + b d|. f carries an error of an ulp of |C| (of r, for spheres far
/// larger than the scene), which moves b and l by as much: nothing against the
/// roots' own sizes there, and where the ray grazes the sphere, a shift of the
/// silhouette by an ulp of the centre. The anchor is read only by rays that
/// pass, so a miss costs the centre's arithmetic alone, and no square root: it
/// compares l^2 with r^2, and l itself is taken for the discriminant
/// (r - l)(r + l) of the rays that pass (clamped at 0 where rounding puts l
/// just past r; tangent, then). Most tests miss, so this spares most tests a
/// square root (docs/ARCHITECTURE.md, "Sphere intersection").
pub fn intersect_sphere(s: &GpuSphere, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
    if s.compact() {
        return intersect_sphere_compact(s, o, d, t_max);
    }
    let r = s.anchor_radius[3];
    let Approach { b, l2, .. } = approach(s, o, d)?;
    let l = l2.sqrt();
    let mut disc = ((r - l) * (r + l)).max(0.0);
    let g = o - xyz(s.anchor_radius);
    let c = g.dot(g) + 2.0 * r * g.dot(xyz(s.axis));
    if c < 0.0 {
        disc = b * b - c;
    }
    let q = b + disc.sqrt().copysign(b);
    if q == 0.0 {
        return None;
    }
    let (t0, t1) = {
        let a = c / q;
        if a < q {
            (a, q)
        } else {
            (q, a)
        }
    };
    if t0 > 0.0 && t0 < t_max {
        Some(t0)
    } else if t1 > 0.0 && t1 < t_max {
        Some(t1)
    } else {
        None
    }
}

/// [`intersect_sphere`] for a compact sphere ([`GpuSphere::compact`]: 2r <= |C|,
/// every sphere of the seed's scenes and smallpt's balls): the textbook roots
/// b -+ sqrt(r^2 - l^2) from the centre, f = o - C, b = -(f.d), l = |f + b d|,
/// with neither the anchor's power of the origin nor a division.
///
/// What the chapter's care buys elsewhere is not needed at this size. The roots
/// carry an error of a few ulps of |f| + r (most where b - sqrt(..) cancels,
/// with the origin near the surface), the order of the rounding of the hit
/// point o + t d itself, which every test has. What remains is f's own error,
/// an ulp of |C| from the f32 centre: against the hit's offset ([`hit_epsilon`],
/// at least 1e-5 |p|, with |p| >= |C| / 2 near a compact sphere) under a
/// hundredth, where on smallpt's walls (r = 1e5 beside a room of size 100) it
/// would be 0.004 and more than the offset, hence the anchor there. In
/// exchange, a ray that passes costs one
/// square root and no division instead of two and one.
pub fn intersect_sphere_compact(s: &GpuSphere, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
    let r = s.center_radius[3];
    let Approach { b, l2, .. } = approach(s, o, d)?;
    let root = (r * r - l2).sqrt();
    [b - root, b + root].into_iter().find(|&t| t > 0.0 && t < t_max)
}

/// Whether the segment from `o` to `o + t_max d` (`d` unit length) meets the
/// sphere: the shadow rays' test, which needs no root, only whether one lies in
/// (0, t_max). Misses are rejected as in [`intersect_sphere`]. For the rest, the
/// segment's ends are classed inside or outside by the sign of their power: ends
/// on opposite sides cross the surface once, two ends inside never (a ball is
/// convex), and two outside twice if the line's nearest approach to the centre,
/// at b = -(f.d), lies between them (the line passes inside, from the miss test).
/// No square root and no division: shadow rays are half the rays, and scenes of
/// many balls pay for every root they take.
///
/// The powers come from the centre, |p - C|^2 - r^2, on a compact sphere
/// ([`GpuSphere::compact`]: no larger than half its centre's distance from the
/// world origin, 2r <= |C|): their error there, an ulp of |C| + r in distance,
/// is a small part of the offset
/// ([`offset_origin`]) that keeps an end off a surface, which grows with |p|, and
/// the points near such a sphere are at least |C| / 2 from the origin. On larger
/// spheres (smallpt's walls, r = 1e5 next to a room of size 100, which the centre's
/// arithmetic would misplace by 0.004) they come from the anchor, as the power of
/// the origin does in [`intersect_sphere`].
pub fn sphere_blocks(s: &GpuSphere, o: Vec3, d: Vec3, t_max: f32) -> bool {
    let r = s.anchor_radius[3];
    let Some(Approach { f, b, .. }) = approach(s, o, d) else { return false };
    let (in_o, in_e) = if s.compact() {
        let e = f + t_max * d;
        (f.dot(f) < r * r, e.dot(e) < r * r)
    } else {
        let axis = xyz(s.axis);
        let g = o - xyz(s.anchor_radius);
        let ge = g + t_max * d;
        (g.dot(g) + 2.0 * r * g.dot(axis) < 0.0, ge.dot(ge) + 2.0 * r * ge.dot(axis) < 0.0)
    };
    if in_o != in_e {
        return true;
    }
    !in_o && b > 0.0 && b < t_max
}

pub fn intersect_quad(q: &GpuQuad, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
    let n = xyz(q.normal);
    let denom = n.dot(d);
    if denom.abs() < 1e-12 {
        return None;
    }
    let t = (q.normal[3] - n.dot(o)) / denom;
    if !(t > 0.0 && t < t_max) {
        return None;
    }
    let rel = o + t * d - xyz(q.origin);
    let s = rel.dot(xyz(q.dual_u));
    let tt = rel.dot(xyz(q.dual_v));
    if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&tt) {
        Some(t)
    } else {
        None
    }
}

/// Scale of a point computed from a sphere's centre and radius (sampled light points).
fn sphere_scale(cr: [f32; 4]) -> f32 {
    max_abs(xyz(cr)) + cr[3]
}

/// Scale of a hit found by [`intersect_sphere`], whose error grows with the
/// origin (covered by `hit_epsilon`'s own term in |p|) and the anchor, not the radius.
fn sphere_hit_scale(s: &GpuSphere) -> f32 {
    max_abs(xyz(s.anchor_radius))
}

fn quad_scale(q: &GpuQuad) -> f32 {
    q.edge_u[3]
}

/// The scale of the points of a quad (origin, edges), for [`hit_epsilon`]:
/// computed once, when the scene is prepared, and kept in `GpuQuad::edge_u[3]`.
pub fn quad_points_scale(origin: Vec3, edge_u: Vec3, edge_v: Vec3) -> f32 {
    max_abs(origin) + max_abs(edge_u) + max_abs(edge_v)
}

impl Room {
    /// Whether the camera's rays may start outside the box beyond a face that
    /// has a quad, and so meet that wall from outside. Every other ray starts on a
    /// surface inside the box, or leaves it for good: the primitives all lie
    /// inside it, so a ray that starts outside (off a wall it left outward) has
    /// nothing to come back to. seed-exp1 to exp3 look in through their open face,
    /// and door's camera stands inside its room: none of them needs the entering
    /// face. The camera's rays start `near` from its position, and a margin of
    /// rounding is counted in.
    pub fn camera_may_enter(&self, p: &RenderParams) -> bool {
        let c = p.cam_position_near;
        let reach = c[3].max(0.0);
        (0..6).any(|f| {
            let a = f / 2;
            let margin = 1e-5 * (1.0 + self.min[a].abs().max(self.max[a].abs()));
            let beyond =
                if f % 2 == 1 { c[a] + reach >= self.max[a] - margin } else { c[a] - reach <= self.min[a] + margin };
            self.faces[f] != shared::NO_QUAD && beyond
        })
    }

    /// The first of the room's quads that the ray from `o` along `d` meets at a
    /// distance in (0, t_max), and its index in [`SceneArrays::quads`]. From
    /// outside the box, the face it enters by, where that face has a quad and
    /// `entering` is set; else the face it leaves by. The distances are the
    /// quads' own (plane offset minus origin, over the direction's component),
    /// as [`intersect_quad`] computes them.
    pub fn hit(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
        if self.quads == 0 {
            return None;
        }
        let t_lo = (self.min - o) / d;
        let t_hi = (self.max - o) / d;
        let (near, far) = (t_lo.min(t_hi), t_lo.max(t_hi));
        let (t_enter, t_exit) = (near.max_element(), far.min_element());
        if !(t_enter <= t_exit) {
            return None;
        }
        // The axis whose planes give `t`, and the quad of the face there.
        let face = |t: f32, ts: Vec3, entering: bool| {
            let a = if ts.x == t {
                0
            } else if ts.y == t {
                1
            } else {
                2
            };
            let at_max = if entering { d[a] < 0.0 } else { d[a] > 0.0 };
            self.faces[2 * a + at_max as usize]
        };
        if self.entering {
            let q = face(t_enter, near, true);
            if t_enter > 0.0 && q != shared::NO_QUAD {
                return (t_enter < t_max).then_some((t_enter, q));
            }
        }
        let q = face(t_exit, far, false);
        (q != shared::NO_QUAD && t_exit > 0.0 && t_exit < t_max).then_some((t_exit, q))
    }
}

/// Nearest hit along the unit direction `d` closer than `t_max`: the spheres,
/// the room's walls ([`Room::hit`]), then the other quads.
pub fn intersect(scene: &SceneArrays, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
    if !scene.bvh_nodes.is_empty() {
        let (t, r) = super::bvh::closest_hit(scene, o, d, t_max)?;
        return Some(prim_hit(scene, r, o, d, t));
    }
    let mut best = t_max;
    let mut found: Option<(bool, usize)> = None;
    for (i, s) in scene.spheres.iter().enumerate() {
        if let Some(t) = intersect_sphere(s, o, d, best) {
            best = t;
            found = Some((true, i));
        }
    }
    if let Some((t, i)) = scene.room.hit(o, d, best) {
        best = t;
        found = Some((false, i as usize));
    }
    let walked = scene.quads.len() - scene.room.quads as usize;
    for (i, q) in scene.quads[..walked].iter().enumerate() {
        if let Some(t) = intersect_quad(q, o, d, best) {
            best = t;
            found = Some((false, i));
        }
    }
    let (is_sphere, i) = found?;
    let kind = if is_sphere { shared::PRIM_SPHERE } else { shared::PRIM_QUAD };
    Some(prim_hit(scene, prim_ref(kind, i as u32), o, d, best))
}

/// The hit at distance `t` along the ray on primitive `r` (a [`prim_ref`]);
/// `glsl/geometry.glsl` `prim_hit` is its twin.
pub fn prim_hit(scene: &SceneArrays, r: u32, o: Vec3, d: Vec3, t: f32) -> Hit {
    let p = o + t * d;
    let (kind, i) = prim_kind_index(r);
    let i = i as usize;
    // Texture coordinates only where some material reads them.
    let textures = !scene.textures.is_empty();
    let uv = |f: &dyn Fn() -> Vec2| if textures { f() } else { Vec2::ZERO };
    match kind {
        shared::PRIM_SPHERE => {
            let s = &scene.spheres[i];
            let n = ((p - xyz(s.center_radius)) / s.center_radius[3]).normalize();
            let eps = hit_epsilon(p, sphere_hit_scale(s));
            Hit {
                t,
                p,
                n,
                ns: n,
                eps,
                material: s.material,
                light: s.light,
                uv: uv(&|| texture::sphere_uv(scene, i, n)),
            }
        }
        shared::PRIM_QUAD => {
            let q = &scene.quads[i];
            let n = xyz(q.normal);
            let eps = hit_epsilon(p, quad_scale(q));
            Hit { t, p, n, ns: n, eps, material: q.material, light: q.light, uv: uv(&|| texture::quad_uv(q, p)) }
        }
        _ => {
            let tri = &scene.triangles[i];
            let [v0, v1, v2] = tri.vertices();
            let n = (v1 - v0).cross(v2 - v0).normalize();
            let ns = if tri.normals == shared::NO_NORMALS {
                n
            } else {
                shading_normal(&scene.triangle_normals[tri.normals as usize].n, [v0, v1, v2], p, n)
            };
            let eps = hit_epsilon(p, triangle_scale(tri));
            let uv = uv(&|| texture::triangle_uv(scene, i, p));
            Hit { t, p, n, ns, eps, material: tri.material, light: tri.light, uv }
        }
    }
}

/// The scale of a triangle's points for hit offsets: its largest coordinate.
pub fn triangle_scale(tri: &GpuTriangle) -> f32 {
    let [a, b, c] = tri.vertices();
    max_abs(a).max(max_abs(b)).max(max_abs(c))
}

/// The shading normal at `p` on a smooth triangle: its vertex normals
/// interpolated by the barycentrics of `p`, turned to the side of the geometric
/// normal `n` (the winding decides which side is the front; a file's normals
/// may disagree). `glsl/geometry.glsl` `shading_normal`.
pub fn shading_normal(normals: &[[f32; 4]; 3], v: [Vec3; 3], p: Vec3, n: Vec3) -> Vec3 {
    let b = texture::triangle_barycentrics(v, p);
    let ns = (b.x * xyz(normals[0]) + b.y * xyz(normals[1]) + b.z * xyz(normals[2])).normalize();
    if !ns.is_finite() {
        n
    } else if ns.dot(n) < 0.0 {
        -ns
    } else {
        ns
    }
}

/// True if anything blocks the segment from `o` along unit `d` up to `t_max`,
/// both ends on the scene's surfaces (a shadow ray), leaving out the primitive
/// `skip` (a [`prim_ref`]: the light the segment ends on, see [`LightSample::end`];
/// `shared::NO_PRIM` for none). Without a BVH the quads that bound the scene
/// cannot block, and are not tested (`crate::prepared::occluding_order`).
/// `glsl/geometry.glsl` `occluded`.
pub fn occluded(scene: &SceneArrays, o: Vec3, d: Vec3, t_max: f32, skip: u32) -> bool {
    if !scene.bvh_nodes.is_empty() {
        return super::bvh::occluded(scene, o, d, t_max, skip);
    }
    // `skip` compared whole with each primitive's reference, as the GLSL does.
    let quads = &scene.quads[..scene.params.occluding_quads as usize];
    let sphere = |i: usize| prim_ref(shared::PRIM_SPHERE, i as u32);
    let quad = |i: usize| prim_ref(shared::PRIM_QUAD, i as u32);
    scene.spheres.iter().enumerate().any(|(i, s)| skip != sphere(i) && sphere_blocks(s, o, d, t_max))
        || quads.iter().enumerate().any(|(i, q)| skip != quad(i) && intersect_quad(q, o, d, t_max).is_some())
}

/// Whether the line of the ray from `o` along `d` meets a light at t > 0, by the
/// lights' own hit tests and whatever lies in front of them: where it meets none,
/// in a scene whose environment is black, the ray can add nothing to a path that
/// ends where it lands (`crate::prepared::last_ray_to_lights`).
/// `glsl/geometry.glsl` `meets_light`.
pub fn meets_light(scene: &SceneArrays, o: Vec3, d: Vec3) -> bool {
    scene.lights.iter().any(|l| match l.kind {
        shared::LIGHT_SPHERE => intersect_sphere(&scene.spheres[l.index as usize], o, d, f32::INFINITY).is_some(),
        shared::LIGHT_QUAD => intersect_quad(&scene.quads[l.index as usize], o, d, f32::INFINITY).is_some(),
        _ => {
            let [a, b, c] = scene.triangles[l.index as usize].vertices();
            super::triangle::intersect_triangle(a, b, c, o, d, f32::INFINITY).is_some()
        }
    })
}

/// The index of the light `u_sel` in [0, 1) picks: the first whose cdf exceeds
/// it (the last where rounding leaves none), by bisection.
/// `glsl/geometry.glsl` `choose_light`.
pub fn choose_light(scene: &SceneArrays, u_sel: f32) -> usize {
    let (mut lo, mut hi) = (0usize, scene.lights.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if u_sel < scene.lights[mid].cdf {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

/// Moves `p` off its surface (normal `n`, error bound `eps`) to the side `w` points to.
pub fn offset_origin(p: Vec3, n: Vec3, eps: f32, w: Vec3) -> Vec3 {
    if n.dot(w) >= 0.0 {
        p + eps * n
    } else {
        p - eps * n
    }
}

/// A point sampled on a light, seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point to the light point.
    pub wi: Vec3,
    pub dist: f32,
    /// Where the shadow ray ends. The light point itself, with the light's own
    /// primitive left out of the test (`skip`), where the light cannot hide its
    /// point from the shading point: a quad, a triangle, and a sphere sampled
    /// by its cone from outside (the point is on the near side). An end moved off
    /// the light instead would let the shadow ray pass every surface that crosses
    /// the light within that distance of the point: smallpt's ceiling cuts its lamp
    /// just below the cap, and an end moved by the hit epsilon brightened the image
    /// measurably (docs/correctness.md). A sphere sampled by area (from inside or next to it) may
    /// pick its far side, which the sphere itself must block: there the end is
    /// moved off the surface towards the shading point and the sphere is tested.
    pub end: Vec3,
    /// The primitive the shadow ray leaves out ([`prim_ref`]), `shared::NO_PRIM` for none.
    pub skip: u32,
    /// Emitted radiance towards the shading point (zero if it sees the back of a one-sided light).
    pub le: Vec3,
    /// Solid-angle density at the shading point, including the choice of the
    /// light; a delta light's pmf alone (`delta`).
    pub pdf: f32,
    /// A delta light's sample ([`super::delta`]): no MIS weight against BSDF sampling.
    pub delta: bool,
}

/// The shadow ray of a light sample from a shading point (`p`, geometric normal
/// `n`, hit epsilon `eps`): origin, unit direction and length, for [`occluded`]
/// with the sample's `skip`. `glsl/geometry.glsl` `shadow_ray`.
pub fn shadow_ray(p: Vec3, n: Vec3, eps: f32, ls: &LightSample) -> (Vec3, Vec3, f32) {
    let origin = offset_origin(p, n, eps, ls.wi);
    // The image environment's samples lie at infinity (`dist`), along `wi`.
    if ls.dist.is_infinite() {
        return (origin, ls.wi, ls.dist);
    }
    let seg = ls.end - origin;
    let len = seg.length();
    (origin, seg / len, len)
}

/// Probability of the sphere-cone sampling scheme covering the light, as
/// `1 - cos(theta_max)`, computed without cancellation for small cones.
fn one_minus_cos_max(sin2_max: f32) -> f32 {
    if sin2_max < 0.000_685_23 {
        // sin^2(1.5 degrees): the series keeps precision for distant lights (pbrt-v4).
        0.5 * sin2_max
    } else {
        1.0 - (1.0 - sin2_max).max(0.0).sqrt()
    }
}

/// Emitted radiance of material `mat` leaving a surface with front normal `n` towards `w`.
pub fn emitted(scene: &SceneArrays, mat: u32, n: Vec3, w: Vec3) -> Vec3 {
    let m = &scene.materials[mat as usize];
    let e = xyz(m.emission_ior);
    if m.two_sided != 0 || n.dot(w) > 0.0 {
        e
    } else {
        Vec3::ZERO
    }
}

/// Chooses a light by power with `u_sel` and samples a point on it with `u`:
/// spheres seen from outside by the cone of directions they subtend, spheres
/// from inside, quads and triangles uniformly by area, the image environment by
/// its map (`crate::math::envmap`), a delta light's one direction ([`super::delta`]).
pub fn sample_light(scene: &SceneArrays, p: Vec3, u_sel: f32, u: [f32; 2]) -> Option<LightSample> {
    let n_lights = scene.lights.len();
    if n_lights == 0 {
        return None;
    }
    let light = &scene.lights[choose_light(scene, u_sel)];
    if light.kind >= shared::LIGHT_DISTANT {
        return super::delta::sample_delta_light(scene, light, p);
    }
    // The image environment: a direction to infinity, nothing skipped.
    if light.kind == shared::LIGHT_ENV {
        let (wi, le, pdf_env) = super::envmap::env_sample(scene, u)?;
        let pdf = pdf_env * light.pmf;
        return (pdf > 0.0 && pdf.is_finite()).then_some(LightSample {
            wi,
            dist: f32::INFINITY,
            end: wi,
            skip: shared::NO_PRIM,
            le,
            pdf,
            delta: false,
        });
    }
    // The shadow ray's end and what it skips (see `LightSample::end`): the point
    // itself and the light's primitive, unless a sphere is sampled by area.
    let (mut skip, mut area_eps) = (shared::NO_PRIM, 0.0f32);
    let (lp, ln, mat, pdf_solid) = if light.kind == shared::LIGHT_SPHERE {
        let s = &scene.spheres[light.index as usize];
        let c = xyz(s.center_radius);
        let r = s.center_radius[3];
        let to_c = c - p;
        let dc2 = to_c.length_squared();
        if dc2 > r * r * 1.0001 {
            // Outside: uniform in the cone (pbrt-v4 Sphere::Sample).
            let dc = dc2.sqrt();
            let sin_max = r / dc;
            let sin2_max = sin_max * sin_max;
            let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
            let omc = one_minus_cos_max(sin2_max);
            let (sin2_t, cos_t) = if sin2_max < 0.000_685_23 {
                let s2 = sin2_max * u[0];
                (s2, (1.0 - s2).sqrt())
            } else {
                let ct = (cos_max - 1.0) * u[0] + 1.0;
                (1.0 - ct * ct, ct)
            };
            let cos_alpha = sin2_t / sin_max + cos_t * (1.0 - sin2_t / sin2_max).max(0.0).sqrt();
            let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
            let phi = 2.0 * PI * u[1];
            let frame = super::Frame::from_normal(to_c / dc);
            let w = Vec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha);
            let n = -frame.to_world(w);
            let lp = c + r * n;
            skip = prim_ref(shared::PRIM_SPHERE, light.index);
            (lp, n, s.material, 1.0 / (2.0 * PI * omc))
        } else {
            // Inside (or on) the sphere: uniform by area.
            let n = super::sampling::uniform_sphere(u);
            let lp = c + r * n;
            let d = lp - p;
            let d2 = d.length_squared();
            let cos_l = n.dot(d).abs() / d2.sqrt();
            if cos_l <= 0.0 {
                return None;
            }
            let area = 4.0 * PI * r * r;
            area_eps = hit_epsilon(lp, sphere_scale(s.center_radius));
            (lp, n, s.material, d2 / (area * cos_l))
        }
    } else if light.kind == shared::LIGHT_QUAD {
        let q = &scene.quads[light.index as usize];
        let lp = xyz(q.origin) + u[0] * xyz(q.edge_u) + u[1] * xyz(q.edge_v);
        let n = xyz(q.normal);
        let d = lp - p;
        let d2 = d.length_squared();
        let cos_l = n.dot(d).abs() / d2.sqrt();
        if cos_l <= 0.0 {
            return None;
        }
        skip = prim_ref(shared::PRIM_QUAD, light.index);
        (lp, n, q.material, d2 / (q.origin[3] * cos_l))
    } else {
        let tri = &scene.triangles[light.index as usize];
        let [v0, v1, v2] = tri.vertices();
        let (lp, n, area) = super::triangle::sample_triangle(v0, v1, v2, u);
        let d = lp - p;
        let d2 = d.length_squared();
        let cos_l = n.dot(d).abs() / d2.sqrt();
        if !(cos_l > 0.0 && area > 0.0) {
            return None;
        }
        skip = prim_ref(shared::PRIM_TRIANGLE, light.index);
        (lp, n, tri.material, d2 / (area * cos_l))
    };
    let d = lp - p;
    let dist = d.length();
    if !(dist > 0.0) {
        return None;
    }
    let wi = d / dist;
    let le = emitted(scene, mat, ln, -wi);
    let pdf = pdf_solid * light.pmf;
    if !(pdf > 0.0 && pdf.is_finite()) {
        return None;
    }
    let end = if area_eps > 0.0 { offset_origin(lp, ln, area_eps, -wi) } else { lp };
    Some(LightSample { wi, dist, end, skip, le, pdf, delta: false })
}

/// The density with which `sample_light`, called at `p`, picks the direction `w`
/// towards light `light` (including the choice of the light): the light-sampling
/// pdf in the MIS weight of a BSDF-sampled ray that hit that light. It is a
/// function of (p, w) alone, like the BSDF pdf it is weighed against, so both
/// strategies see the same pair of densities for the same path; where `w` meets
/// the light is found again analytically from `p` (not from the offset origin
/// the ray was traced from). Zero where `w` misses the light.
pub fn light_pdf(scene: &SceneArrays, light: u32, p: Vec3, w: Vec3) -> f32 {
    let l = &scene.lights[light as usize];
    let pdf_solid = if l.kind == shared::LIGHT_SPHERE {
        let s = &scene.spheres[l.index as usize];
        let c = xyz(s.center_radius);
        let r = s.center_radius[3];
        let f = p - c;
        let dc2 = f.length_squared();
        if dc2 > r * r * 1.0001 {
            let sin2_max = r * r / dc2;
            1.0 / (2.0 * PI * one_minus_cos_max(sin2_max))
        } else {
            // Sampled by area: the point w reaches first. From inside, or from the
            // sphere's own surface (within a hit epsilon of it: grazing rays there
            // would find a near root at p itself), the far root; from a point
            // outside, the near one.
            let b = -f.dot(w);
            let l2 = (f + b * w).length();
            let root = ((r - l2) * (r + l2)).max(0.0).sqrt();
            let outside = dc2.sqrt() - r > hit_epsilon(p, sphere_scale(s.center_radius));
            let t = if outside { b - root } else { b + root };
            if !(t > 0.0) {
                return 0.0;
            }
            let n = (p + t * w - c) / r;
            t * t / (4.0 * PI * r * r * n.dot(w).abs())
        }
    } else if l.kind == shared::LIGHT_QUAD {
        let q = &scene.quads[l.index as usize];
        let n = xyz(q.normal);
        let cos = n.dot(w);
        let t = (q.normal[3] - n.dot(p)) / cos;
        if !(t > 0.0) {
            return 0.0;
        }
        t * t / (q.origin[3] * cos.abs())
    } else {
        let [v0, v1, v2] = scene.triangles[l.index as usize].vertices();
        let c = (v1 - v0).cross(v2 - v0);
        let len = c.length();
        let n = c / len;
        let cos = n.dot(w);
        let t = n.dot(v0 - p) / cos;
        if !(t > 0.0) {
            return 0.0;
        }
        t * t / (0.5 * len * cos.abs())
    };
    pdf_solid * l.pmf
}
