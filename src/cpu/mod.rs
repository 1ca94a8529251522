//! The CPU renderer: the same camera, BSDFs, next-event estimation, MIS and
//! random numbers as `glsl/pathtrace.comp`, on all cores (rayon). It is the
//! reference the GPU renderer is tested against.

use crate::film::Film;
use crate::math::bsdf::{bsdf_eval, bsdf_pdf, bsdf_sample, Bsdf};
use crate::math::geometry::{emitted, intersect, light_pdf, occluded, offset_origin, sample_light};
use crate::math::rng::Rng;
use crate::math::sampling::mis_weight;
use crate::math::{max_component, Frame, Vec3};
use crate::prepared::{PreparedScene, RenderParams};
use crate::scene::MaterialKind;
use crate::shared;
use rayon::prelude::*;

fn xyz(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

/// The primary ray through pixel (x, y) jittered by `u`; `glsl/pathtrace.comp` `camera_ray`.
pub fn camera_ray(p: &RenderParams, x: u32, y: u32, u: [f32; 2]) -> (Vec3, Vec3) {
    let tan = p.cam_forward_tan[3];
    let aspect = p.cam_right_aspect[3];
    let sx = (2.0 * (x as f32 + u[0]) / p.width as f32 - 1.0) * tan * aspect;
    let sy = (1.0 - 2.0 * (y as f32 + u[1]) / p.height as f32) * tan;
    let d = (xyz(p.cam_forward_tan) + sx * xyz(p.cam_right_aspect) + sy * xyz(p.cam_up)).normalize();
    (xyz(p.cam_position_near) + p.cam_position_near[3] * d, d)
}

fn material_bsdf(scene: &PreparedScene, mat: u32) -> Bsdf {
    let m = &scene.materials[mat as usize];
    let kind = match m.kind {
        shared::MAT_DIFFUSE => MaterialKind::Diffuse,
        shared::MAT_SPECULAR => MaterialKind::Specular,
        shared::MAT_GLOSSY => MaterialKind::Glossy,
        shared::MAT_DIELECTRIC => MaterialKind::Dielectric,
        _ => MaterialKind::Emissive,
    };
    let r = m.albedo_roughness[3];
    Bsdf { kind, albedo: xyz(m.albedo_roughness), alpha: r * r, ior: m.emission_ior[3] }
}

/// Traces one path from the camera ray (o, d) and returns the radiance it carries.
pub fn trace_path(scene: &PreparedScene, mut o: Vec3, mut d: Vec3, rng: &mut Rng) -> Vec3 {
    let p = &scene.params;
    let nee = p.flags & shared::FLAG_NEE != 0 && p.num_lights > 0;
    let power = p.flags & shared::FLAG_POWER_HEURISTIC != 0;
    let rr = p.flags & shared::FLAG_RUSSIAN_ROULETTE != 0;
    let mut radiance = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    // Density of the direction that led to the current vertex, and whether it was a delta choice.
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut prev_p = o;
    let mut depth = 0u32;
    loop {
        let Some(hit) = intersect(scene, o, d, f32::INFINITY) else {
            radiance += beta * xyz(p.environment);
            break;
        };
        let wo = -d;
        let le = emitted(scene, hit.material, hit.n, wo);
        if le.max_element() > 0.0 {
            let w = if !nee || prev_delta || hit.light == shared::NO_LIGHT {
                1.0
            } else {
                mis_weight(prev_pdf, light_pdf(scene, hit.light, prev_p, d), power)
            };
            radiance += beta * le * w;
        }
        let bsdf = material_bsdf(scene, hit.material);
        if bsdf.kind == MaterialKind::Emissive || depth >= p.max_bounces {
            break;
        }
        // Reflecting materials are two-sided: shade with the normal on wo's side.
        let n = if bsdf.kind == MaterialKind::Dielectric || hit.n.dot(wo) >= 0.0 { hit.n } else { -hit.n };
        let frame = Frame::from_normal(n);
        let wo_local = frame.to_local(wo);

        if nee && !bsdf.is_delta() {
            let u_sel = rng.next_f32();
            let u_light = rng.next_2d();
            if let Some(ls) = sample_light(scene, hit.p, u_sel, u_light) {
                let wi_local = frame.to_local(ls.wi);
                let f = bsdf_eval(&bsdf, wo_local, wi_local);
                if ls.le.max_element() > 0.0 && f.max_element() > 0.0 {
                    let origin = offset_origin(hit.p, hit.n, hit.eps, ls.wi);
                    let target = offset_origin(ls.p, ls.n, ls.eps, -ls.wi);
                    let seg = target - origin;
                    let len = seg.length();
                    if !occluded(scene, origin, seg / len, len) {
                        let w = mis_weight(ls.pdf, bsdf_pdf(&bsdf, wo_local, wi_local), power);
                        radiance += beta * f * wi_local.z.abs() * ls.le * (w / ls.pdf);
                    }
                }
            }
        } else if nee {
            // Keep the random-number sequence aligned with the GPU kernel.
            rng.next_f32();
            rng.next_2d();
        }

        let uc = rng.next_f32();
        let u = rng.next_2d();
        let Some(s) = bsdf_sample(&bsdf, wo_local, uc, u) else { break };
        beta *= s.weight;
        let wi = frame.to_world(s.wi).normalize();
        prev_pdf = s.pdf;
        prev_delta = s.delta;
        prev_p = hit.p;
        o = offset_origin(hit.p, hit.n, hit.eps, wi);
        d = wi;
        depth += 1;
        if rr && depth >= p.rr_depth {
            let q = max_component(beta).min(0.95);
            if rng.next_f32() >= q {
                break;
            }
            beta /= q;
        }
        if beta.max_element() <= 0.0 {
            break;
        }
    }
    radiance
}

/// Renders `frames` more frames of 64 samples per pixel into `film`, calling
/// `on_frame` after each.
pub fn render(scene: &PreparedScene, film: &mut Film, frames: u32, mut on_frame: impl FnMut(&Film)) {
    let p = scene.params;
    assert_eq!((film.width, film.height), (p.width, p.height), "film size matches the render size");
    for _ in 0..frames {
        let frame = film.frames;
        film.pixels.par_chunks_mut(p.width as usize).enumerate().for_each(|(y, row)| {
            for (x, acc) in row.iter_mut().enumerate() {
                let pixel = y as u32 * p.width + x as u32;
                let mut sum = Vec3::ZERO;
                for sample in 0..shared::SAMPLES_PER_FRAME {
                    let mut rng = Rng::new(p.seed, pixel, frame, sample);
                    let u = rng.next_2d();
                    let (o, d) = camera_ray(&p, x as u32, y as u32, u);
                    let l = trace_path(scene, o, d, &mut rng);
                    // A NaN or infinite sample would poison the pixel forever; it is dropped (and is a bug).
                    if l.is_finite() {
                        sum += l;
                    }
                }
                crate::film::accumulate(acc, frame, sum.to_array());
            }
        });
        film.frames += 1;
        on_frame(film);
    }
}
