//! pbrt's delta lights, `LightSource "distant" | "point" | "spot"`, as
//! [`DeltaLight`]s: positions and directions through the light's transform and
//! the bake, `L`/`I` times `scale`, pbrt-v4's `power` and `illuminance`
//! normalisations (docs/pbrt.md).

use glam::{DVec3, Vec3};

use super::lexer::Loc;
use super::params::Params;
use super::Importer;
use crate::scene::{DeltaLight, SceneError};

/// Luminance of linear sRGB (Rec. 709 weights): what pbrt-v4 normalises `power`
/// and `illuminance` by (its `SpectrumToPhotometric`).
fn luminance(c: Vec3) -> f64 {
    0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
}

impl Importer {
    /// A point parameter (`point3`/`point`) of three finite numbers, or `default`.
    fn light_point(p: &Params, name: &str, default: DVec3, what: &str) -> Result<DVec3, SceneError> {
        let Some(q) = p.get(name, &["point3", "point"]) else { return Ok(default) };
        let v = q.numbers_n(3)?;
        let v = DVec3::new(v[0], v[1], v[2]);
        if !v.is_finite() {
            return Err(q.loc.error(format!("{what}: \"{name}\" must be finite")));
        }
        Ok(v)
    }

    /// `LightSource "distant" | "point" | "spot"`: a [`DeltaLight`] in rlpt's space.
    pub(super) fn delta_light(&mut self, ty: &str, p: &Params, loc: &Loc) -> Result<(), SceneError> {
        let what = format!("LightSource \"{ty}\"");
        let m = self.bake * self.state.ctm;
        let (colour_name, power_name) = if ty == "distant" { ("L", "illuminance") } else { ("I", "power") };
        let mut r = self.reader(p, loc, what.clone());
        let colour = r.colour(colour_name, Vec3::ONE)?;
        let scale = r.colour("scale", Vec3::ONE)?;
        let from = Self::light_point(p, "from", DVec3::ZERO, &what)?;
        let to = Self::light_point(p, "to", DVec3::Z, &what)?;
        let power = p.float(power_name)?;
        let mut value = colour * scale;
        let bad = |m: String| Err(loc.error(format!("{what}: {m}")));
        if !(value.min_element() >= 0.0 && value.max_element() <= 1e12) {
            return bad(format!("{colour_name} times scale is {value}; each channel must be from 0 to 1e12"));
        }
        // Cone cosines (full intensity, edge); 1 and -1 outside spots.
        let (mut cos_start, mut cos_end) = (1.0f64, -1.0f64);
        if ty == "spot" {
            let cone = p.float_or("coneangle", 30.0)?;
            let delta = p.float_or("conedeltaangle", 5.0)?;
            if !(cone > 0.0 && cone <= 180.0) {
                return bad(format!("coneangle {cone} must be above 0 and at most 180 degrees"));
            }
            if !(delta >= 0.0 && delta <= cone) {
                return bad(format!("conedeltaangle {delta} must be from 0 to coneangle ({cone}) degrees"));
            }
            cos_end = cone.to_radians().cos();
            cos_start = (cone - delta).to_radians().cos();
        }
        // pbrt-v4: `power` (point, spot) and `illuminance` (distant) set the
        // luminous power / illuminance, dividing out the colour's luminance.
        if let Some(target) = power {
            let lum = luminance(value);
            if !(target >= 0.0 && target.is_finite() && lum > 0.0) {
                return bad(format!("{power_name} {target} needs a finite value >= 0 and a colour of luminance > 0"));
            }
            let k = match ty {
                "point" => 4.0 * std::f64::consts::PI,
                "spot" => 2.0 * std::f64::consts::PI * (1.0 - 0.5 * (cos_start + cos_end)),
                _ => 1.0,
            };
            value *= (target / (k * lum)) as f32;
        }
        let light = if ty == "distant" {
            let w = m.transform_vector3(from - to);
            if !(w.length() > 0.0) {
                return bad("\"from\" and \"to\" coincide: no direction".into());
            }
            DeltaLight::Distant { to_light: w.normalize().as_vec3(), radiance: value }
        } else {
            let position = m.transform_point3(from).as_vec3();
            if ty == "point" {
                DeltaLight::Point { position, intensity: value }
            } else {
                let axis = m.transform_vector3(to - from);
                if !(axis.length() > 0.0) {
                    return bad("\"from\" and \"to\" coincide: no axis".into());
                }
                DeltaLight::Spot {
                    position,
                    axis: axis.normalize().as_vec3(),
                    intensity: value,
                    cos_start: cos_start as f32,
                    cos_end: cos_end as f32,
                }
            }
        };
        self.out.delta_lights.push(light);
        let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
        if !unused.is_empty() {
            self.notes.approximated(loc, format!("{what}: ignored {}", unused.join(", ")))?;
        }
        Ok(())
    }
}
