//! What the scene's geometry allows the renderers to skip or specialize: the
//! quads shadow rays need not test, the room one slab test finds, the material
//! and light kinds the kernel is compiled for, and whether the last ray may look
//! for lights alone.

use super::*;

/// The kinds of material and light the scene has, as `RenderParams.scene_kinds`
/// bits: `1 << kind` for each material kind (`MAT_*`, every material of the scene
/// file, used or not) and `1 << (SCENE_KIND_LIGHT_SHIFT + kind)` for each light
/// kind (`LIGHT_*`). pathtrace.comp is specialized to them (`SPEC_SCENE_KINDS`)
/// and compiles the BSDFs and light samplers of these kinds alone: a kind with no
/// material or light in the scene is never asked for, so its code only took room.
/// Likewise `1 << SCENE_KIND_GUIDED_GLOSSY` where a glossy material is wide enough
/// to take guided directions ([`crate::guide::glossy_guided`]): without one the
/// guided kernel evaluates the mixture of diffuse vertices alone. And
/// `SCENE_KIND_PROCEDURAL` where a texture is procedural, and
/// `SCENE_KIND_REFLECTANCE_CONDUCTOR` where a conductor reads its index from
/// its reflectance texture, `SCENE_KIND_MIX` where a material is a mix,
/// `SCENE_KIND_COATED_CONDUCTOR` where a coated material has a conductor base and
/// `SCENE_KIND_SMOOTH_COAT` where one has a smooth coat: kernels without them
/// leave that code out.
pub fn scene_kinds(materials: &[GpuMaterial], lights: &[GpuLight], textures: &[GpuTexture]) -> u32 {
    let m = materials.iter().fold(0, |k, m| {
        let guided_glossy = if crate::guide::glossy_guided(m) { 1 << shared::SCENE_KIND_GUIDED_GLOSSY } else { 0 };
        let reflectance = if m.eta[3] != 0.0 { 1 << shared::SCENE_KIND_REFLECTANCE_CONDUCTOR } else { 0 };
        let kind = if m.kind == shared::MAT_MIX { 1 << shared::SCENE_KIND_MIX } else { 1 << m.kind };
        let coated = |bit: u32, yes: bool| if m.kind == shared::MAT_COATED && yes { 1 << bit } else { 0 };
        let coats = coated(shared::SCENE_KIND_COATED_CONDUCTOR, m.k[3] > 0.0)
            | coated(shared::SCENE_KIND_SMOOTH_COAT, m.albedo_roughness[3] == 0.0);
        k | kind | guided_glossy | reflectance | coats
    });
    let procedural = textures.iter().any(|t| t.format >= shared::TEXTURE_CHECKER);
    let m = if procedural { m | 1 << shared::SCENE_KIND_PROCEDURAL } else { m };
    lights.iter().fold(m, |k, l| k | 1 << (shared::SCENE_KIND_LIGHT_SHIFT + l.kind))
}

/// Whether the ray into a path's last vertex needs tracing only where its line
/// meets a light (`shared::FLAG_LAST_RAY_TO_LIGHTS`): at the last vertex a path
/// adds the emission it finds there and nothing more, and where the environment is
/// black only the lights emit, so a ray whose line meets none of them adds nothing
/// and the closest-hit walk over every primitive can be skipped
/// (`math::geometry::meets_light`; the image is the same). On the GPU the lights'
/// tests are written out per specialized slot, so every light must lie in one
/// (the first `SPEC_SPHERES` spheres and `SPEC_QUADS` quads, in the order of
/// [`SceneArrays::quads`]). A scene with no light has nothing to find.
/// Not with Russian `roulette`: with it few paths reach the last vertex, and the
/// test is code the kernel carries for little (door's frames were longer with it).
pub fn last_ray_to_lights(environment: Vec3, lights: &[GpuLight], roulette: bool) -> bool {
    let in_slot = |l: &GpuLight| match l.kind {
        shared::LIGHT_SPHERE => l.index < shared::SPEC_SPHERES,
        shared::LIGHT_QUAD => l.index < shared::SPEC_QUADS,
        _ => false,
    };
    !roulette && environment == Vec3::ZERO && lights.iter().all(in_slot)
}

/// The order of the scene's quads in [`SceneArrays::quads`], and how many of
/// them come first as the ones a shadow ray must test.
///
/// A quad whose plane has every primitive of the scene in one closed half-space
/// (walls, floor and ceiling of a room; a ground plane) cannot block a shadow
/// ray: both ends of the segment lie on the scene's surfaces (the origin moved
/// off its surface to the side the segment leaves by), so in that half-space, and
/// a half-space is convex, so the segment never crosses the plane. Only rounding could make it
/// appear to, at points within the hit epsilon of the plane, which the offset
/// exists to keep away. Such quads go last and shadow rays skip them; the others
/// keep their order in front. Touching the plane counts as inside, and so does
/// crossing it by less than a tenth of the hit epsilon there
/// (`math::geometry::hit_epsilon`, 1e-5 (1 + |p|)): scene files give coordinates
/// in decimal, whose f32 values make a wall's edge stick out of the ceiling by
/// 6e-8 (door.toml), and a segment can then cross the plane only at an end that
/// lies within that distance of it, inside the band where the answer is rounding.
///
/// In a scene whose one light is a quad, every shadow ray ends on that quad, which
/// the shadow test skips as the light a segment ends on
/// (`math::geometry::LightSample::end`), so the lamp goes last too.
pub fn occluding_order(scene: &Scene) -> (Vec<usize>, u32) {
    let d = |v: Vec3| v.as_dvec3();
    let bounds_scene = |q: &crate::scene::Quad| {
        let n = d(q.edge_u).cross(d(q.edge_v)).normalize();
        let w = n.dot(d(q.origin));
        let (mut below, mut above) = (false, false);
        // `dist`: signed distance from the plane of a point of the scene whose
        // largest coordinate is `scale`.
        let mut side = |dist: f64, scale: f64| {
            let touching = 1e-6 * (1.0 + scale);
            below |= dist < -touching;
            above |= dist > touching;
        };
        for p in &scene.quads {
            let (o, u, v) = (d(p.origin), d(p.edge_u), d(p.edge_v));
            for c in [o, o + u, o + v, o + u + v] {
                side(n.dot(c) - w, c.abs().max_element());
            }
        }
        for s in &scene.spheres {
            let (c, r) = (d(s.center), s.radius as f64);
            let scale = c.abs().max_element() + r;
            side(n.dot(c) - w - r, scale);
            side(n.dot(c) - w + r, scale);
        }
        !(below && above)
    };
    let mut bounding: Vec<bool> = scene.quads.iter().map(bounds_scene).collect();
    let lamp_quads: Vec<usize> =
        (0..scene.quads.len()).filter(|&i| scene.material_emits(scene.quads[i].material)).collect();
    if let [lamp] = lamp_quads[..] {
        if !scene.spheres.iter().any(|s| scene.material_emits(s.material)) {
            bounding[lamp] = true;
        }
    }
    let mut order: Vec<usize> = (0..scene.quads.len()).filter(|&i| !bounding[i]).collect();
    let occluding = order.len() as u32;
    order.extend((0..scene.quads.len()).filter(|&i| bounding[i]));
    (order, occluding)
}

/// The room of a scene ([`Room`]): the box around every primitive (quads'
/// corners, spheres' extents), and for each of its six faces the first of
/// `candidates` (indices into the scene's quads; the quads that bound the scene,
/// [`occluding_order`]) that lies in that face along two axes and covers it
/// whole, as the box's own numbers say, or None. None where no face has one, or
/// the box is flat or not finite (smallpt's huge spheres: no quads).
pub fn room_walls(scene: &Scene, candidates: &[usize]) -> Option<(Vec3, Vec3, [Option<usize>; 6])> {
    let corners = |q: &crate::scene::Quad| {
        let (o, u, v) = (q.origin, q.edge_u, q.edge_v);
        [o, o + u, o + v, o + u + v]
    };
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for q in &scene.quads {
        for c in corners(q) {
            (min, max) = (min.min(c), max.max(c));
        }
    }
    for s in &scene.spheres {
        (min, max) = (min.min(s.center - s.radius), max.max(s.center + s.radius));
    }
    if !(min.is_finite() && max.is_finite() && (max - min).cmpgt(Vec3::ZERO).all()) {
        return None;
    }
    // The one axis an edge runs along, None for an edge askew.
    let axis = |e: Vec3| {
        let along: Vec<usize> = (0..3).filter(|&a| e[a] != 0.0).collect();
        (along.len() == 1).then(|| along[0])
    };
    let mut faces = [None; 6];
    for &i in candidates {
        let q = &scene.quads[i];
        let (Some(a_u), Some(a_v)) = (axis(q.edge_u), axis(q.edge_v)) else { continue };
        if a_u == a_v {
            continue;
        }
        let a = 3 - a_u - a_v;
        let c = corners(q);
        let lo = c.iter().fold(Vec3::splat(f32::INFINITY), |m, &p| m.min(p));
        let hi = c.iter().fold(Vec3::splat(f32::NEG_INFINITY), |m, &p| m.max(p));
        let covers = [a_u, a_v].iter().all(|&b| lo[b] == min[b] && hi[b] == max[b]);
        let side = if lo[a] == min[a] {
            0
        } else if lo[a] == max[a] {
            1
        } else {
            continue;
        };
        if covers && faces[2 * a + side].is_none() {
            faces[2 * a + side] = Some(i);
        }
    }
    faces.iter().any(Option::is_some).then_some((min, max, faces))
}
