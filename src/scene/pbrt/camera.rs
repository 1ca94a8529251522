//! Camera and render settings: `Camera`, `Film`, `Sampler`, `Integrator` and
//! the rest before `WorldBegin`, and the bake of the world into the space rlpt
//! renders in.

use glam::{DMat4, DVec3};

use super::lexer::Loc;
use super::params::Params;
use super::Importer;
use crate::scene::SceneError;

impl Importer {
    /// `WorldBegin`: fixes the camera. The world is baked into pbrt's camera
    /// space mirrored in x, where rlpt's camera sits at the origin looking
    /// along +z with +y up: rlpt's right (forward x up) is -x there, which is
    /// pbrt's +x, so the picture is pbrt's, handedness included.
    pub(super) fn world_begin(&mut self, loc: &Loc) -> Result<(), SceneError> {
        if self.in_world {
            return Err(loc.error("a second WorldBegin"));
        }
        if let Some((_, push, opened)) = self.stack.last() {
            return Err(loc.error(format!("WorldBegin inside the {push:?}Begin of line {}", opened.line)));
        }
        let camera_from_world = match &self.camera {
            Some((m, _, _)) => *m,
            None => {
                self.notes.setting(loc, "no Camera: pbrt's default, perspective with fov 90 at the origin".into());
                self.camera = Some((self.state.ctm, 90.0, loc.clone()));
                self.state.ctm
            }
        };
        self.bake = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0)) * camera_from_world;
        self.in_world = true;
        self.state.ctm = DMat4::IDENTITY;
        self.coordinate_systems.insert("world".into(), DMat4::IDENTITY);
        Ok(())
    }

    /// Camera, Sampler, Film, PixelFilter, Integrator: what rlpt takes, and a
    /// note naming what it leaves to its own options.
    pub(super) fn option(&mut self, directive: &str, ty: &str, p: &Params, loc: &Loc) -> Result<(), SceneError> {
        let max_side = crate::layout::MAX_IMAGE_SIDE as i64;
        match directive {
            "Camera" => {
                let inverse = self.state.ctm.inverse();
                self.coordinate_systems.insert("camera".into(), inverse);
                if ty != "perspective" {
                    self.notes.approximated(
                        loc,
                        format!("Camera \"{ty}\" rendered as a perspective camera (rlpt has a pinhole only)"),
                    )?;
                }
                let fov = p.float_or("fov", 90.0)?;
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(loc.error(format!("Camera: \"float fov\" must be in (0, 180) degrees, found {fov}")));
                }
                self.camera = Some((self.state.ctm, fov, loc.clone()));
                let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
                if !unused.is_empty() {
                    self.notes.approximated(
                        loc,
                        format!("Camera parameters {} ignored (rlpt has a pinhole camera)", unused.join(", ")),
                    )?;
                }
                return Ok(());
            }
            "Film" => {
                for (key, slot) in [("xresolution", 0), ("yresolution", 1)] {
                    if let Some(n) = p.integer(key)? {
                        if !(1..=max_side).contains(&n) {
                            return Err(
                                loc.error(format!("Film: \"integer {key}\" must be from 1 to {max_side}, found {n}"))
                            );
                        }
                        if slot == 0 {
                            self.render.width = n as u32
                        } else {
                            self.render.height = n as u32
                        }
                    }
                }
            }
            "Sampler" => {
                if let Some(n) = p.integer("pixelsamples")? {
                    let max = crate::layout::MAX_SPP as i64;
                    self.render.spp = n.clamp(1, max) as u32;
                    if n > max {
                        self.notes.setting(loc, format!("\"integer pixelsamples\" {n} capped at rlpt's {max}"));
                    }
                }
            }
            "Integrator" | "SurfaceIntegrator" => {
                if let Some(n) = p.integer("maxdepth")? {
                    let max = crate::layout::MAX_BOUNCES as i64;
                    self.render.max_bounces = n.clamp(0, max) as u32;
                    if n > max {
                        self.notes.setting(loc, format!("\"integer maxdepth\" {n} capped at rlpt's {max} bounces"));
                    }
                }
            }
            _ => {}
        }
        let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
        let kept = match directive {
            "Film" => "resolution taken",
            "Sampler" => "pixelsamples taken as spp",
            "Integrator" | "SurfaceIntegrator" => "maxdepth taken as max_bounces",
            _ => "nothing taken",
        };
        let rest = if unused.is_empty() { String::new() } else { format!("; ignored {}", unused.join(", ")) };
        self.notes
            .setting(loc, format!("{directive} \"{ty}\": {kept}, rlpt's own {} used{rest}", directive.to_lowercase()));
        Ok(())
    }
}

/// pbrt's LookAt: camera-from-world for eye, target, up (9 numbers); its
/// camera x is cross(up, dir), so its camera space is left-handed.
pub(super) fn look_at(v: &[f64]) -> Option<DMat4> {
    let pos = DVec3::new(v[0], v[1], v[2]);
    let dir = (DVec3::new(v[3], v[4], v[5]) - pos).normalize_or_zero();
    let up = DVec3::new(v[6], v[7], v[8]).normalize_or_zero();
    let right = up.cross(dir);
    if dir == DVec3::ZERO || right.length() < 1e-9 {
        return None;
    }
    let right = right.normalize();
    let new_up = dir.cross(right);
    let world_from_camera = DMat4::from_cols(right.extend(0.0), new_up.extend(0.0), dir.extend(0.0), pos.extend(1.0));
    Some(world_from_camera.inverse())
}
