//! Image textures on the CPU: the UVs of a hit and the bilinear lookup of a
//! texture's texels, each the twin of the function of the same name in
//! `glsl/texture.glsl`. The conventions are `docs/SCENE_FORMAT.md`'s
//! ("Textures"): repeat wrap, v up (row 0 of the image at v = 1), texel
//! centres at half-integers.

use glam::{Vec2, Vec4};

use crate::layout::{GpuMaterial, GpuQuad, GpuTexture, SceneArrays};
use crate::math::bsdf::Bsdf;
use crate::math::Vec3;
use crate::scene::texture::srgb_to_linear;
use crate::shared;

fn xyz(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

/// Linear RGBA of texel (x, y) of `t` (`texel`).
pub fn texel(texels: &[u32], t: &GpuTexture, x: u32, y: u32) -> Vec4 {
    let i = (y * t.width + x) as usize;
    if t.format == shared::TEXEL_RGBA16F {
        let base = t.offset as usize + 2 * i;
        let h = |w: u32, k: u32| half::f16::from_bits((w >> (16 * k)) as u16).to_f32();
        let (a, b) = (texels[base], texels[base + 1]);
        return Vec4::new(h(a, 0), h(a, 1), h(b, 0), h(b, 1));
    }
    let bytes = texels[t.offset as usize + i].to_le_bytes();
    let c = Vec4::from_array(bytes.map(|b| b as f32 / 255.0));
    if t.format == shared::TEXEL_RGBA8_SRGB {
        Vec4::new(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z), c.w)
    } else {
        c
    }
}

/// GLSL's `mix`.
fn mix(a: Vec4, b: Vec4, t: f32) -> Vec4 {
    a * (1.0 - t) + b * t
}

/// A coordinate's place in [0, 1) under repeat wrap; 0 where it is not finite.
fn wrap(s: f32) -> f32 {
    let f = s - s.floor();
    if f < 1.0 {
        f
    } else {
        0.0
    }
}

/// The texel row or column below `x` (in texel units, centres at half-integers)
/// and the one after it, wrapped to [0, n).
fn neighbours(x: f32, n: u32) -> (u32, u32, f32) {
    let x0 = x.floor();
    let i0 = if x0 < 0.0 { n - 1 } else { (x0 as u32).min(n - 1) };
    let i1 = if i0 + 1 == n { 0 } else { i0 + 1 };
    (i0, i1, x - x0)
}

/// The bilinearly filtered linear RGBA of texture `index` at `uv` (`texture_lookup`):
/// its UV transform, repeat wrap, v up (image row 0 at the top).
pub fn texture_lookup(scene: &SceneArrays, index: u32, uv: Vec2) -> Vec4 {
    let t = &scene.textures[index as usize];
    let s = wrap(uv.x * t.transform[0] + t.transform[2]);
    let v = wrap(uv.y * t.transform[1] + t.transform[3]);
    let (x0, x1, fx) = neighbours(s * t.width as f32 - 0.5, t.width);
    let (y0, y1, fy) = neighbours((1.0 - v) * t.height as f32 - 0.5, t.height);
    let tx = |x, y| texel(&scene.texels, t, x, y);
    mix(mix(tx(x0, y0), tx(x1, y0), fx), mix(tx(x0, y1), tx(x1, y1), fx), fy)
}

/// Operand `which` of the procedural texture whose operands start at
/// `texels[at]` (`procedural_operand`): its constant times its image at `uv`.
pub fn procedural_operand(scene: &SceneArrays, at: u32, which: u32, uv: Vec2) -> Vec3 {
    let tex = scene.texels[(at + which) as usize];
    let c = (at + 3 + 3 * which) as usize;
    let value = Vec3::from_array([0, 1, 2].map(|k| f32::from_bits(scene.texels[c + k])));
    if tex == shared::NO_TEXTURE {
        value
    } else {
        value * texture_lookup(scene, tex - 1, uv).truncate()
    }
}

/// Whether floor(s) + floor(t) is odd (`checker_odd`): pbrt's 2D
/// checkerboard, unfiltered, reads its second operand there; false where not finite.
pub fn checker_odd(st: Vec2) -> bool {
    let f = st.x.floor() + st.y.floor();
    f - 2.0 * (f * 0.5).floor() == 1.0
}

/// The RGB of texture `index` at `uv` (`colour_texture`): an image's bilinear
/// lookup, or a procedural texture's (`shared::TEXTURE_CHECKER`, ...;
/// `crate::scene::procedural`), at most 1.
pub fn colour_texture(scene: &SceneArrays, index: u32, uv: Vec2) -> Vec3 {
    let t = &scene.textures[index as usize];
    if t.format < shared::TEXTURE_CHECKER {
        return texture_lookup(scene, index, uv).truncate();
    }
    let at = t.offset;
    let c = if t.format == shared::TEXTURE_CHECKER {
        let st = uv * Vec2::new(t.transform[0], t.transform[1]) + Vec2::new(t.transform[2], t.transform[3]);
        procedural_operand(scene, at, checker_odd(st) as u32, uv)
    } else {
        let (a, b) = (procedural_operand(scene, at, 0, uv), procedural_operand(scene, at, 1, uv));
        let amount = if t.format == shared::TEXTURE_MIX { procedural_operand(scene, at, 2, uv).x } else { 0.0 };
        if t.format == shared::TEXTURE_SCALE {
            a * b
        } else {
            a * (1.0 - amount) + b * amount
        }
    };
    c.min(Vec3::ONE)
}

/// The barycentric weights of `p` in the triangle `v` (by projection onto its
/// plane), clamped into the triangle (`triangle_barycentrics`).
pub fn triangle_barycentrics(v: [Vec3; 3], p: Vec3) -> Vec3 {
    let (e1, e2, ep) = (v[1] - v[0], v[2] - v[0], p - v[0]);
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (ep.dot(e1), ep.dot(e2));
    let denom = d00 * d11 - d01 * d01;
    let b1 = ((d11 * d20 - d01 * d21) / denom).clamp(0.0, 1.0);
    let b2 = ((d00 * d21 - d01 * d20) / denom).clamp(0.0, 1.0 - b1);
    Vec3::new(1.0 - b1 - b2, b1, b2)
}

/// The UV of sphere `i`'s point of outward unit normal `n` (`sphere_uv`), by
/// its frame (`crate::scene::SphereUv`): u = phi / phi_max, v = (theta -
/// theta_min) / (theta_max - theta_min), the angles in its object space.
pub fn sphere_uv(scene: &SceneArrays, i: usize, n: Vec3) -> Vec2 {
    let f = &scene.sphere_uvs[i];
    let o = Vec3::new(xyz(f.x).dot(n), xyz(f.y).dot(n), xyz(f.z).dot(n)).normalize();
    let mut phi = o.y.atan2(o.x);
    if phi < 0.0 {
        phi += 2.0 * std::f32::consts::PI;
    }
    let theta = o.z.clamp(-1.0, 1.0).acos();
    Vec2::new(phi / f.x[3], (theta - f.y[3]) / (f.z[3] - f.y[3]))
}

/// The UV of `p` on a quad (`quad_uv`): its (s, t), p = origin + s edge_u + t edge_v.
pub fn quad_uv(q: &GpuQuad, p: Vec3) -> Vec2 {
    let rel = p - xyz(q.origin);
    Vec2::new(rel.dot(xyz(q.dual_u)), rel.dot(xyz(q.dual_v)))
}

/// The UV of `p` on triangle `i` (`triangle_uv`): its vertices' UVs by the
/// barycentrics of p; (0, 0) where the scene holds no UVs.
pub fn triangle_uv(scene: &SceneArrays, i: usize, p: Vec3) -> Vec2 {
    let Some(uvs) = scene.triangle_uvs.get(i) else { return Vec2::ZERO };
    let b = triangle_barycentrics(scene.triangles[i].vertices(), p);
    let [a, c, d] = uvs.uv.map(Vec2::from);
    b.x * a + b.y * c + b.z * d
}

/// The material's textures applied to its BSDF at `uv` (`apply_textures` in
/// `glsl/pathtrace.comp`'s `material_bsdf`): the albedo times the colour
/// texture's RGB, the roughness its own times the roughness texture's red,
/// within [`shared::TEXTURE_MIN_ROUGHNESS`], 1] (a coated conductor's base's);
/// a reflectance conductor's
/// (`eta[3]` 1) textured albedo its reflectance (eta 1, k `conductor_k`).
pub fn apply_textures(scene: &SceneArrays, m: &GpuMaterial, uv: Vec2, b: &mut Bsdf) {
    if m.albedo_texture != shared::NO_TEXTURE {
        b.albedo *= colour_texture(scene, m.albedo_texture - 1, uv);
    }
    if m.roughness_texture != shared::NO_TEXTURE {
        // A coated conductor's texture is its base's roughness (`k[3]`), not its coat's.
        let base = b.has_conductor_base();
        let r =
            if base { m.k[3] } else { m.albedo_roughness[3] } * texture_lookup(scene, m.roughness_texture - 1, uv).x;
        let r = r.clamp(shared::TEXTURE_MIN_ROUGHNESS, 1.0);
        if base {
            b.base_alpha = r * r;
        } else {
            b.alpha = r * r;
        }
    }
    if m.eta[3] != 0.0 {
        (b.eta, b.k, b.albedo) = (Vec3::ONE, crate::scene::conductor_k(b.albedo), Vec3::ONE);
    }
}
