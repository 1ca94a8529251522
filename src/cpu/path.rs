//! One path on the CPU, in the named stages of `glsl/pathtrace.comp`'s path loop:
//! `environment_met` or `emission_met` where a ray ends or arrives, `guide_vertex`
//! and `mixture_fraction` (guiding's lookups), `light_sample` (next-event
//! estimation), `choose_direction` (BSDF or guided), `record_vertex_target` and
//! `record_end` (Q-learning targets), `roulette`. Each stage has its GLSL twin of
//! the same name in `glsl/pathtrace.comp`, a function or, for `guide_vertex`,
//! `mixture_fraction`, `light_sample`, `choose_direction` and `roulette`, a block
//! of the loop under a comment that names it (as functions they made guided
//! frames longer: docs/kernel-speed.md); the arithmetic and its order match.

use super::{material_bsdf, resolve_mix, xyz, Guide};
use crate::guide::{self, Recorder};
use crate::math::bsdf::{bsdf_eval_pdf, bsdf_sample, Bsdf};
use crate::math::envmap;
use crate::math::geometry::{
    emitted, intersect, light_pdf, meets_light, occluded, offset_origin, sample_light, shadow_ray, Hit,
};
use crate::math::sampler::{bounce_dim, PathSampler};
use crate::math::sampling::mis_weight;
use crate::math::{max_component, mean3, Frame, Vec3};
use crate::prepared::PreparedScene;
use crate::scene::MaterialKind;
use crate::shared;

/// What the path's settings say, fixed for the whole path.
struct PathSettings {
    nee: bool,
    power: bool,
    rr: bool,
    /// Targets that count the emission met as the image weighs it and the light
    /// sample at the vertex met (`guide::QTargets::Mis`), where the path records.
    mis_targets: bool,
    /// Whether the path records its cells' fraction gradients.
    learn_fraction: bool,
    guided_vertices: u32,
    record_vertices: u32,
    bins_per_cell: u32,
    /// Glossy vertices draw guided directions from the product with their lobe
    /// (`shared::FLAG_GLOSSY_PRODUCT`, [`guide::product_applies`]).
    product: bool,
}

/// The path so far: what it carries, and how the ray being traced left its last vertex.
struct PathState {
    radiance: Vec3,
    beta: Vec3,
    /// Density of the direction that led to the current vertex, and whether it was a delta choice.
    prev_pdf: f32,
    prev_delta: bool,
    prev_p: Vec3,
    /// Q-table entry of the ray being traced (none for camera rays).
    prev_key: u32,
    /// The fraction-gradient factor of that ray (`guide::fraction_gradient_factor`),
    /// 0 where its vertex did not mix or the path does not learn fractions.
    prev_factor: f32,
}

impl PathState {
    /// Whether the ray that arrives at a vertex of `depth` has a target to record
    /// (where the path records): it left a vertex of depth below `record_vertices`.
    fn records_target(&self, s: &PathSettings, depth: u32) -> bool {
        depth <= s.record_vertices && self.prev_key != shared::NO_KEY
    }
}

/// One vertex as the stages after the hit read it: its shading and guiding.
struct Vertex<'a> {
    hit: Hit,
    bsdf: Bsdf,
    /// The geometric normal on the side the vertex shades, and the shading normal.
    n: Vec3,
    ns: Vec3,
    frame: Frame,
    wo_local: Vec3,
    /// The cell's first entry in the table, its sampling row and guided fraction.
    cell_key: u32,
    sampler: &'a [guide::AliasBin],
    row_fraction: f32,
    /// The probability of guided sampling here ([`mixture_fraction`]).
    g_frac: f32,
    /// Where guided directions come from the product with the lobe: the vertex as
    /// it reads it and its window's sums ([`glossy_product`]).
    product: Option<(guide::ProductVertex<'a>, guide::Product)>,
}

/// A direction leaving a vertex: BSDF x cos / density (`weight`), the density,
/// whether it was a delta choice, its bin, and its fraction-gradient factor.
#[derive(Clone, Copy)]
struct Direction {
    wi: Vec3,
    weight: Vec3,
    pdf: f32,
    delta: bool,
    bin: u32,
    factor: f32,
}

/// Traces one path from the camera ray (o, d) and returns the radiance it
/// carries and the number of rays it traced. With guiding and a `learn`
/// (the path records), every ray that leaves a vertex of depth below
/// [`guide::record_vertices`] and reaches a surface or escapes hands its
/// Q-learning target to `learn`, and where cells learn their fractions and the
/// vertex mixed, the gradient sample of its cell's fraction.
/// `glsl/pathtrace.comp` `trace_path`.
pub fn trace_path(
    scene: &PreparedScene,
    guide: Option<Guide>,
    mut o: Vec3,
    mut d: Vec3,
    rng: &mut PathSampler,
    pixel_estimate: f32,
    mut learn: Option<&mut dyn Recorder>,
) -> (Vec3, u32) {
    let record = learn.is_some();
    let p = &scene.params;
    let s = PathSettings {
        nee: p.flags & shared::FLAG_NEE != 0 && p.num_lights > 0,
        power: p.flags & shared::FLAG_POWER_HEURISTIC != 0,
        rr: p.flags & shared::FLAG_RUSSIAN_ROULETTE != 0,
        mis_targets: record && p.flags & shared::FLAG_MIS_TARGETS != 0,
        learn_fraction: record && guide.is_some_and(|g| g.cfg.learn_fraction),
        guided_vertices: guide::guided_vertices(p),
        record_vertices: guide::record_vertices(p),
        bins_per_cell: guide.map_or(1, |g| g.cfg.bins.count()),
        product: guide.is_some() && p.flags & shared::FLAG_GLOSSY_PRODUCT != 0,
    };
    let mut path = PathState {
        radiance: Vec3::ZERO,
        beta: Vec3::ONE,
        prev_pdf: 0.0,
        prev_delta: true,
        prev_p: o,
        prev_key: shared::NO_KEY,
        prev_factor: 0.0,
    };
    let mut depth = 0u32;
    let mut segments = 0u32;
    // The ray into the last vertex adds only the emission it meets; where the
    // environment is black and its line meets no light, it adds nothing, and the
    // closest-hit walk is skipped (unless the path records that vertex's target).
    let last_ray_to_lights =
        p.flags & shared::FLAG_LAST_RAY_TO_LIGHTS != 0 && !(record && s.record_vertices >= p.max_bounces);
    loop {
        segments += 1;
        if last_ray_to_lights && depth >= p.max_bounces && !meets_light(scene, o, d) {
            break;
        }
        let Some(hit) = intersect(scene, o, d, f32::INFINITY) else {
            let (env, w) = environment_met(scene, &s, &path, d);
            if let Some(learn) = learn.as_mut().filter(|_| path.records_target(&s, depth)) {
                let target = if s.mis_targets { mean3(env) * w } else { mean3(env) };
                record_end(&mut **learn, &s, &path, target, mean3(env) * w);
            }
            path.radiance += path.beta * env * w;
            break;
        };
        let wo = -d;
        let (le, le_counted) = emission_met(scene, &s, &mut path, &hit, wo, d);
        // What the target of the ray that arrived here counts of that emission.
        let le_target = if s.mis_targets { le_counted } else { mean3(le) };
        // A mix resolves here to the material every stage below shades with.
        let mat = if p.scene_kinds & 1 << shared::SCENE_KIND_MIX != 0 {
            resolve_mix(scene, hit.material, hit.p, wo, hit.uv)
        } else {
            hit.material
        };
        let bsdf = material_bsdf(scene, mat, hit.uv);
        // Reflecting materials are two-sided: shade with the normal on wo's side.
        let n = if bsdf.transmits() || hit.n.dot(wo) >= 0.0 { hit.n } else { -hit.n };
        let ns = shading_side(n, hit, wo);
        let frame = Frame::from_normal(ns);
        let wo_local = frame.to_local(wo);
        let (cell_key, sampler, row_fraction) = guide_vertex(guide, &s, &hit, n, depth, &mut learn);
        if bsdf.kind == MaterialKind::Emissive {
            // Reflects nothing: the target is the emission alone.
            if let Some(learn) = learn.as_mut().filter(|_| path.records_target(&s, depth)) {
                record_end(&mut **learn, &s, &path, le_target, le_counted);
            }
            break;
        }
        let mut g_frac = mixture_fraction(guide, &s, depth, &bsdf, row_fraction);
        let product = glossy_product(guide, &s, &bsdf, frame, wo_local, cell_key, &mut g_frac);
        let v = Vertex { hit, bsdf, n, ns, frame, wo_local, cell_key, sampler, row_fraction, g_frac, product };
        let last = depth >= p.max_bounces;

        let u_sel = rng.sample_1d(bounce_dim(depth, shared::SAMPLE_LIGHT_SELECT));
        let u_light = rng.sample_2d(bounce_dim(depth, shared::SAMPLE_LIGHT));
        // The light sample's estimate here, without the path's throughput: the
        // part of the target of the ray that arrived here that light sampling
        // found (`mis_targets`).
        let mut nee_here = 0.0f32;
        if s.nee && !last && !v.bsdf.is_delta() {
            nee_here = light_sample(scene, guide, &s, &v, (u_sel, u_light), &mut path, &mut segments);
        }

        // The continuation: sampled even at the last bounce when the path records,
        // since the Q-learning target of the previous vertex is estimated from it.
        let wants_target = record && path.records_target(&s, depth);
        if last && !wants_target {
            break;
        }
        let u_mix = rng.sample_1d(bounce_dim(depth, shared::SAMPLE_MIX));
        let uc = rng.sample_1d(bounce_dim(depth, shared::SAMPLE_LOBE));
        let u = rng.sample_2d(bounce_dim(depth, shared::SAMPLE_DIRECTION));
        let sampled = choose_direction(guide, &s, &v, u_mix, uc, u);
        if let (Some(g), Some(learn)) = (guide, learn.as_mut().filter(|_| wants_target)) {
            let reflected = match sampled {
                Some(dir) => mean3(dir.weight) * g.q[(v.cell_key + dir.bin) as usize],
                None => 0.0,
            };
            record_vertex_target(&mut **learn, &s, &path, reflected, (le_target, le_counted), nee_here);
        }
        if last {
            break;
        }
        let Some(dir) = sampled else { break };
        path.beta *= dir.weight;
        path.prev_pdf = dir.pdf;
        path.prev_delta = dir.delta;
        path.prev_p = v.hit.p;
        if guide.is_some() {
            path.prev_key = v.cell_key + dir.bin;
            path.prev_factor = dir.factor;
        }
        o = offset_origin(v.hit.p, v.hit.n, v.hit.eps, dir.wi);
        d = dir.wi;
        depth += 1;
        if s.rr && depth >= p.rr_depth && !roulette(guide, &mut path, pixel_estimate, rng, depth) {
            break;
        }
        if path.beta.max_element() <= 0.0 {
            break;
        }
    }
    (path.radiance, segments)
}

/// A ray that escapes: the uniform sky, or the image environment, a light whose
/// emission is weighed against light sampling as the other lights' is. Returns
/// the environment's radiance and its MIS weight. `glsl/pathtrace.comp` `environment_met`.
fn environment_met(scene: &PreparedScene, s: &PathSettings, path: &PathState, d: Vec3) -> (Vec3, f32) {
    let p = &scene.params;
    if p.env_width > 0 {
        let (le, pdf_env) = envmap::env_lookup(scene, d);
        let pmf = scene.lights[p.num_lights as usize - 1].pmf;
        (le, if s.nee && !path.prev_delta { mis_weight(path.prev_pdf, pdf_env * pmf, s.power) } else { 1.0 })
    } else {
        (xyz(p.environment), 1.0)
    }
}

/// The emission met at a hit, added to the path's radiance MIS-weighted against
/// light sampling. Returns the emission and the emission as the image counts it
/// here (mean3, weighted), which the fraction's gradient weighs, and with
/// `mis_targets` the target too. `glsl/pathtrace.comp` `emission_met`.
fn emission_met(
    scene: &PreparedScene,
    s: &PathSettings,
    path: &mut PathState,
    hit: &Hit,
    wo: Vec3,
    d: Vec3,
) -> (Vec3, f32) {
    let le = emitted(scene, hit.material, hit.n, wo);
    let mut le_counted = 0.0f32;
    if le.max_element() > 0.0 {
        let w = if !s.nee || path.prev_delta || hit.light == shared::NO_LIGHT {
            1.0
        } else {
            mis_weight(path.prev_pdf, light_pdf(scene, hit.light, path.prev_p, d), s.power)
        };
        path.radiance += path.beta * le * w;
        le_counted = mean3(le) * w;
    }
    (le, le_counted)
}

/// Guiding at a vertex: its cell's first entry in the table, its sampling row
/// and the row's guided fraction (empty and 0 without guiding); a recording path
/// marks the rows its guided vertices read (`QTable::rows_read`).
/// `glsl/pathtrace.comp` writes it inline in the path loop, under its name.
fn guide_vertex<'g>(
    guide: Option<Guide<'g>>,
    s: &PathSettings,
    hit: &Hit,
    n: Vec3,
    depth: u32,
    learn: &mut Option<&mut dyn Recorder>,
) -> (u32, &'g [guide::AliasBin], f32) {
    let Some(g) = guide else { return (0, &[], 0.0) };
    let (cell, bins) = (g.cell(hit.p), g.cfg.bins.count());
    let row = guide::sampler_row(cell, guide::normal_class(n), bins);
    if let Some(learn) = learn.as_mut().filter(|_| depth < s.guided_vertices) {
        learn.row_read(row / bins as usize);
    }
    (cell * bins, &g.rows[row..row + bins as usize], g.fractions[row / bins as usize])
}

/// Probability of guided sampling at a vertex: the row's fraction (0 where
/// nothing is learned) times the lobe's share (less on narrow glossy lobes),
/// the whole fraction where the product with the lobe draws the guided
/// directions; zero at delta vertices and past the guided vertices.
/// `glsl/pathtrace.comp` writes it inline in the path loop, under its name.
fn mixture_fraction(guide: Option<Guide>, s: &PathSettings, depth: u32, bsdf: &Bsdf, row_fraction: f32) -> f32 {
    match guide {
        Some(g) if depth < s.guided_vertices && !bsdf.is_delta() => {
            let product = s.product && guide::product_applies(bsdf, &g.cfg.bins);
            row_fraction * if product { 1.0 } else { guide::lobe_share(bsdf) }
        }
        _ => 0.0,
    }
}

/// The product with the lobe at a glossy vertex that mixes: its window's sums
/// (`guide::product_sums`), or None where the product does not apply; where the
/// window's weights sum to zero the vertex samples the BSDF alone (`g_frac` 0).
/// `glsl/pathtrace.comp` `glossy_product`.
fn glossy_product<'g>(
    guide: Option<Guide<'g>>,
    s: &PathSettings,
    bsdf: &Bsdf,
    frame: Frame,
    wo: Vec3,
    cell_key: u32,
    g_frac: &mut f32,
) -> Option<(guide::ProductVertex<'g>, guide::Product)> {
    let g = guide.filter(|g| s.product && *g_frac > 0.0 && guide::product_applies(bsdf, &g.cfg.bins))?;
    let q = &g.q[cell_key as usize..(cell_key + s.bins_per_cell) as usize];
    let v = guide::ProductVertex { frame, wo, alpha: bsdf.alpha, q };
    let p = guide::product_sums(&g.cfg.bins, &v, g.cfg.floor);
    if !(p.sum_w > 0.0) {
        *g_frac = 0.0;
    }
    Some((v, p))
}

/// The guided density of bin `bin` at a vertex that mixes: the product's where it
/// draws the guided directions, else the sampling row's.
fn guided_bin_pdf(guide: Option<Guide>, v: &Vertex, bin: u32) -> f32 {
    match (guide, &v.product) {
        (Some(g), Some((pv, p))) => guide::product_pdf(&g.cfg.bins, pv, p, bin),
        _ => guide::bin_pdf(v.sampler, bin),
    }
}

/// The bin of a direction, where guiding reads it.
fn bin_of(guide: Option<Guide>, wi: Vec3) -> u32 {
    guide.map_or(0, |g| g.cfg.bins.index(wi))
}

/// Next-event estimation at a vertex: a light sample `u` = (selection, position),
/// its shadow ray (counted in `segments`), its contribution added to the path's
/// radiance. Returns the light sample's estimate without the path's throughput
/// where `mis_targets` (0 otherwise). `glsl/pathtrace.comp` writes it inline in the path loop, under its name.
fn light_sample(
    scene: &PreparedScene,
    guide: Option<Guide>,
    s: &PathSettings,
    v: &Vertex,
    (u_sel, u_light): (f32, [f32; 2]),
    path: &mut PathState,
    segments: &mut u32,
) -> f32 {
    let mut nee_here = 0.0f32;
    if let Some(ls) = sample_light(scene, v.hit.p, u_sel, u_light).filter(|ls| sides_agree(v.n, v.ns, ls.wi)) {
        let wi_local = v.frame.to_local(ls.wi);
        let (f, pb) = bsdf_eval_pdf(&v.bsdf, v.wo_local, wi_local);
        if ls.le.max_element() > 0.0 && f.max_element() > 0.0 {
            let (origin, dir, len) = shadow_ray(v.hit.p, v.hit.n, v.hit.eps, &ls);
            *segments += 1;
            if !occluded(scene, origin, dir, len, ls.skip) {
                // MIS against the mixture's density where the vertex mixes
                // (see `mixture_sample`).
                let pdf = if v.g_frac > 0.0 {
                    guide::mixture_pdf(v.g_frac, pb, guided_bin_pdf(guide, v, bin_of(guide, ls.wi)))
                } else {
                    pb
                };
                // A delta light is reached by no BSDF-sampled ray: weight 1.
                let w = if ls.delta { 1.0 } else { mis_weight(ls.pdf, pdf, s.power) };
                path.radiance += path.beta * f * wi_local.z.abs() * ls.le * (w / ls.pdf);
                if s.mis_targets {
                    nee_here = mean3(f * wi_local.z.abs() * ls.le * (w / ls.pdf));
                }
            }
        }
    }
    nee_here
}

/// The direction leaving a vertex: from the table with probability `g_frac`
/// (`u_mix` below it), else from the BSDF; then, where the two are mixed, one
/// evaluation of the BSDF and the mixture density for either choice (the GPU
/// runs it once for a warp that holds both). A guided direction comes with its
/// bin, a BSDF direction's is found once. None where the BSDF or the density is
/// zero, or the direction would leak through the surface.
/// `glsl/pathtrace.comp` writes it inline in the path loop, under its name.
fn choose_direction(
    guide: Option<Guide>,
    s: &PathSettings,
    v: &Vertex,
    u_mix: f32,
    uc: f32,
    u: [f32; 2],
) -> Option<Direction> {
    let sampled = if u_mix < v.g_frac {
        // A guided direction: its weight and density are those of the mixture.
        let g = guide.expect("g_frac > 0 only with guiding");
        let (wi, bin) = match &v.product {
            Some((pv, p)) => {
                let bin = guide::product_bin(&g.cfg.bins, pv, p, uc);
                (g.cfg.bins.sample(bin, u), bin)
            }
            None => guide::guided_direction_bin(&g.cfg.bins, v.sampler, uc, u),
        };
        mixture_sample(guide, s, v, wi, bin)
    } else {
        match bsdf_sample(&v.bsdf, v.wo_local, uc, u) {
            // A BSDF direction at a vertex that mixes: the same evaluation.
            Some(b) if v.g_frac > 0.0 && !b.delta => {
                let wi = v.frame.to_world(b.wi).normalize();
                mixture_sample(guide, s, v, wi, bin_of(guide, wi))
            }
            Some(b) => {
                let wi = v.frame.to_world(b.wi).normalize();
                // A delta lobe at a vertex that mixes (a smooth coat's): chosen with
                // (1 - g_frac) times the BSDF's chance, which b.weight counts alone.
                let weight = if b.delta && v.g_frac > 0.0 { b.weight / (1.0 - v.g_frac) } else { b.weight };
                Some(Direction { wi, weight, pdf: b.pdf, delta: b.delta, bin: bin_of(guide, wi), factor: 0.0 })
            }
            None => None,
        }
    };
    // A direction on one side of the shading normal and the other of the
    // surface would leak light through it: dropped.
    sampled.filter(|dir| sides_agree(v.n, v.ns, dir.wi))
}

/// A direction of the mixture at a vertex that mixes (`g_frac` > 0), whichever
/// sampler chose it, or None where the BSDF or the density is zero.
///
/// The MIS weights between light sampling and the mixture use the mixture's
/// density, the one the direction was drawn from: at the light sample too,
/// which costs it the guided density of its bin. The BSDF's density in their
/// place is unbiased too and cheaper, but hands the light guided directions
/// find to light sampling, which loses badly where light sampling finds a lamp
/// worse (docs/guiding.md, "The mixture").
fn mixture_sample(guide: Option<Guide>, s: &PathSettings, v: &Vertex, wi: Vec3, bin: u32) -> Option<Direction> {
    let wi_local = v.frame.to_local(wi);
    let (f, pb) = bsdf_eval_pdf(&v.bsdf, v.wo_local, wi_local);
    let pg = guided_bin_pdf(guide, v, bin);
    let pdf = guide::mixture_pdf(v.g_frac, pb, pg);
    (pdf > 0.0 && f.max_element() > 0.0).then(|| {
        let weight = f * (wi_local.z.abs() / pdf);
        let factor = if s.learn_fraction {
            guide::fraction_gradient_factor(v.g_frac, v.row_fraction, pg, pb, pdf, mean3(weight))
        } else {
            0.0
        };
        Direction { wi, weight, pdf, delta: false, bin, factor }
    })
}

/// Records the target of the ray that arrived at a vertex: a one-sample estimate
/// of the expected-SARSA target (see src/guide/mod.rs), the emission met `le` =
/// (as the target counts it, as the image counts it) plus `nee_here` plus the
/// `reflected` estimate of the continuation. With `mis_targets` the target is
/// the light as the image counts it from here on, and the fraction's gradient
/// weighs the same (`nee_here` is 0 without it). `glsl/pathtrace.comp` `record_vertex_target`.
fn record_vertex_target(
    learn: &mut dyn Recorder,
    s: &PathSettings,
    path: &PathState,
    reflected: f32,
    (le_target, le_counted): (f32, f32),
    nee_here: f32,
) {
    let target = le_target + nee_here + reflected;
    let counted = if s.mis_targets { target } else { le_counted + reflected };
    record_to(learn, path.prev_key, target, counted, path.prev_factor, s.bins_per_cell);
}

/// Records the target of the ray that ended the path, escaping or meeting an
/// emitter: the emission alone (`counted` as the image weighs it). The GPU keeps
/// it for after the loop. `glsl/pathtrace.comp` `record_end`.
fn record_end(learn: &mut dyn Recorder, s: &PathSettings, path: &PathState, target: f32, counted: f32) {
    record_to(learn, path.prev_key, target, counted, path.prev_factor, s.bins_per_cell);
}

/// Russian roulette after a bounce: whether the path goes on (its throughput
/// then divided by the survival probability). With guiding and a pixel estimate,
/// the probability is learned: the radiance the table expects along the ray
/// about to be traced, times the throughput, against the pixel's.
/// `glsl/pathtrace.comp` writes it inline in `trace_path`'s loop ("src/cpu/path.rs
/// `roulette`"): as a function it made the unguided kernel slower.
fn roulette(
    guide: Option<Guide>,
    path: &mut PathState,
    pixel_estimate: f32,
    rng: &mut PathSampler,
    depth: u32,
) -> bool {
    let q = match guide {
        Some(g) if pixel_estimate > 0.0 => {
            guide::survival_probability(mean3(path.beta) * g.q[path.prev_key as usize], pixel_estimate)
        }
        _ => max_component(path.beta).min(0.95),
    };
    if rng.sample_1d(bounce_dim(depth, shared::SAMPLE_ROULETTE)) >= q {
        return false;
    }
    path.beta /= q;
    true
}

/// The hit's shading normal on the side of `n` (the geometric normal as the
/// vertex shades with it); `n` itself where `wo` lies on one side of the shading
/// normal and the other of the surface, where the shading frame cannot describe
/// the vertex. `glsl/pathtrace.comp` `shading_side`.
pub fn shading_side(n: Vec3, hit: Hit, wo: Vec3) -> Vec3 {
    let ns = if n == hit.n { hit.ns } else { -hit.ns };
    if ns.dot(wo) * n.dot(wo) < 0.0 {
        n
    } else {
        ns
    }
}

/// Whether `w` lies on the same side of the geometric normal `n` as of the
/// shading normal `ns`: always where the two are one. `glsl/pathtrace.comp` `sides_agree`.
pub fn sides_agree(n: Vec3, ns: Vec3, w: Vec3) -> bool {
    !(w.dot(n) * w.dot(ns) < 0.0)
}

/// Hands the target of the ray that left through `key` to `r`, and where `factor`
/// is not 0 the fraction-gradient sample of the ray's cell, `-factor * counted`
/// (`guide::FractionState`): `counted` is the target with the emission the ray
/// met weighted as the image weighs it (MIS against light sampling), since the
/// fraction should serve what BSDF and guided sampling contribute, and with NEE
/// most direct light is light sampling's. A target that is not finite (a
/// direction whose density underflowed, say) is dropped with its gradient, as
/// non-finite samples are dropped from the image: summed in, it would make its
/// entry NaN or infinite for good. `glsl/pathtrace.comp` `record`.
pub(super) fn record_to(r: &mut dyn Recorder, key: u32, target: f32, counted: f32, factor: f32, bins: u32) {
    if !target.is_finite() {
        return;
    }
    r.target(key, target);
    if factor != 0.0 {
        r.fraction_gradient(key / bins, -factor * counted);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guide::Recorder;

    /// What `record_to` hands on.
    #[derive(Default)]
    struct Seen {
        targets: Vec<(u32, f32)>,
        gradients: Vec<(u32, f32)>,
    }

    impl Recorder for Seen {
        fn target(&mut self, key: u32, target: f32) {
            self.targets.push((key, target));
        }
        fn fraction_gradient(&mut self, cell: u32, gradient: f32) {
            self.gradients.push((cell, gradient));
        }
        fn row_read(&mut self, _: usize) {}
    }

    /// A finite target goes to its key and, where the vertex mixed, the gradient
    /// sample to its cell; a target that is not finite goes nowhere, gradient included.
    #[test]
    fn targets_that_are_not_finite_are_dropped() {
        let mut seen = Seen::default();
        record_to(&mut seen, 130, 2.0, 1.5, 0.25, 128);
        assert_eq!(seen.targets, [(130, 2.0)]);
        assert_eq!(seen.gradients, [(1, -0.375)]);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut seen = Seen::default();
            record_to(&mut seen, 130, bad, bad, 0.25, 128);
            assert!(seen.targets.is_empty() && seen.gradients.is_empty(), "{bad}");
        }
    }
}
