//! Procedural colour textures: pbrt's `checkerboard` (2D, uv mapping), `scale`
//! and `mix` over two operands, each a constant colour or a constant times an
//! image. The renderers evaluate them per hit (`crate::math::texture`
//! `colour_texture`, `glsl/texture.glsl`); their images are decoded as the
//! materials' own ([`super::texture::load_textures`]).

use glam::Vec3;

use super::texture::{find, TextureImage, TextureRef};

/// How a [`Procedural`] combines its operands.
#[derive(Clone, Debug, PartialEq)]
pub enum Combine {
    /// `a` where floor(s) + floor(t) is even, `b` where odd, with (s, t) =
    /// (u, v) * xy + zw (pbrt's uv mapping); unfiltered.
    Checker([f32; 4]),
    /// `a * b`.
    Scale,
    /// `(1 - amount) a + amount b`, amount the red of `amount`.
    Mix,
}

/// An operand: `value` times the image's RGB at the hit, or `value` alone.
#[derive(Clone, Debug, PartialEq)]
pub struct Operand {
    pub value: Vec3,
    pub image: Option<TextureRef>,
}

impl Operand {
    pub fn constant(value: Vec3) -> Operand {
        Operand { value, image: None }
    }

    /// Its mean over the image (the value where it has none).
    pub fn mean(&self, textures: &[TextureImage]) -> Vec3 {
        match &self.image {
            None => self.value,
            Some(r) => self.value * textures[find(textures, r).expect("operand images are decoded")].mean,
        }
    }
}

/// A procedural colour texture (multiplying a material's albedo as an image does).
#[derive(Clone, Debug, PartialEq)]
pub struct Procedural {
    pub combine: Combine,
    pub a: Operand,
    pub b: Operand,
    /// The mix's amount (red channel); unused otherwise.
    pub amount: Operand,
}

impl Procedural {
    /// Its images, each an operand's.
    pub fn images(&self) -> impl Iterator<Item = &TextureRef> {
        [&self.a, &self.b, &self.amount].into_iter().filter_map(|o| o.image.as_ref())
    }

    /// Its mean colour over the plane (a checker's two squares equally; a
    /// product or mix of images as the product or mix of their means, which
    /// is exact where either is constant), for surfaces without UVs.
    pub fn mean(&self, textures: &[TextureImage]) -> Vec3 {
        let (a, b) = (self.a.mean(textures), self.b.mean(textures));
        match self.combine {
            Combine::Checker(_) => 0.5 * (a + b),
            Combine::Scale => a * b,
            Combine::Mix => {
                let t = self.amount.mean(textures).x;
                a * (1.0 - t) + b * t
            }
        }
    }

    /// For `rlpt info` and mapping lines: `checkerboard of [..] and dir/a.png`.
    pub fn describe(&self) -> String {
        let op = |o: &Operand| match &o.image {
            None => format!("[{}, {}, {}]", o.value.x, o.value.y, o.value.z),
            Some(r) if o.value == Vec3::ONE => r.path.display().to_string(),
            Some(r) => format!("{} times [{}, {}, {}]", r.path.display(), o.value.x, o.value.y, o.value.z),
        };
        match self.combine {
            Combine::Checker(t) => format!(
                "checkerboard (st = uv * ({}, {}) + ({}, {})) of {} and {}",
                t[0],
                t[1],
                t[2],
                t[3],
                op(&self.a),
                op(&self.b)
            ),
            Combine::Scale => format!("product of {} and {}", op(&self.a), op(&self.b)),
            Combine::Mix => format!("mix of {} and {} by {}", op(&self.a), op(&self.b), op(&self.amount)),
        }
    }
}
