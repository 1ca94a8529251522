//! `rlpt info`: what a scene holds once loaded and prepared, without rendering it.

use crate::*;
use rlpt::layout::{GpuBvhNode, SceneArrays};
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::shared;

/// The depth of the BVH: nodes on its longest path, and one for the leaves below.
fn bvh_depth(nodes: &[GpuBvhNode]) -> u32 {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 1u32)];
    while let Some((i, depth)) = stack.pop() {
        deepest = deepest.max(depth + 1);
        for &child in &nodes[i].child {
            if child & shared::BVH_LEAF == 0 {
                stack.push((child as usize, depth + 1));
            }
        }
    }
    deepest
}

fn megabytes(bytes: u64) -> String {
    format!("{:.1} MB", bytes as f64 / (1 << 20) as f64)
}

/// The box around every primitive, from the boxes the BVH is built from.
fn bounds(s: &SceneArrays) -> Option<(glam::Vec3, glam::Vec3)> {
    let boxes = rlpt::prepared::prim_boxes(&s.spheres, &s.quads, &s.triangles);
    let lo = boxes.iter().fold(glam::Vec3::INFINITY, |a, b| a.min(b.lo));
    let hi = boxes.iter().fold(glam::Vec3::NEG_INFINITY, |a, b| a.max(b.hi));
    (!boxes.is_empty()).then_some((lo, hi))
}

pub(crate) fn info(path: &Path, strict: bool) -> Result<()> {
    let start = std::time::Instant::now();
    let scene = Scene::load_with(path, strict)?;
    let loaded = start.elapsed();
    let start = std::time::Instant::now();
    let opts = RenderOptions::from_scene(&scene);
    let prepared = PreparedScene::new(&scene, &opts)?;
    let prepare_time = start.elapsed();
    let v = |p: glam::Vec3| format!("[{}, {}, {}]", p.x, p.y, p.z);
    println!("{}", path.display());
    println!(
        "  image {}x{}, {} spp, {} bounces; loaded in {:.3} s, prepared (BVH built) in {:.3} s",
        scene.render.width,
        scene.render.height,
        scene.render.spp,
        scene.render.max_bounces,
        loaded.as_secs_f64(),
        prepare_time.as_secs_f64()
    );
    println!("  {} spheres, {} quads, {} meshes", scene.spheres.len(), scene.quads.len(), scene.meshes.len());
    for m in &scene.meshes {
        println!(
            "    {}: {} triangles, {} vertices, {}",
            m.source.display(),
            m.triangles.len(),
            m.positions.len(),
            if m.normals.is_some() { "smooth" } else { "flat" }
        );
    }
    println!("  materials:");
    for (i, m) in scene.materials.iter().enumerate() {
        let a = m.albedo;
        let e = m.emission;
        use rlpt::scene::MaterialKind as K;
        let mut line = match m.mix {
            Some([x, y]) => {
                let name = |j: u32| format!("[{j}] {}", scene.materials[j as usize].name);
                let by = match (&m.albedo_texture, &m.albedo_procedural) {
                    (Some(t), _) => format!(" times texture {}", t.path.display()),
                    (None, Some(p)) => format!(" times the {}", p.describe()),
                    _ => String::new(),
                };
                format!("    [{i}] {}: Mix of {} and {}, the second with chance {}{by}", m.name, name(x), name(y), a.x)
            }
            None => format!("    [{i}] {}: {:?}, albedo {}", m.name, m.kind, v(a)),
        };
        if matches!(m.kind, K::Glossy | K::Conductor | K::RoughDielectric | K::Coated) {
            line += &format!(", roughness {}", m.roughness);
        }
        if matches!(m.kind, K::Dielectric | K::RoughDielectric | K::Coated) {
            line += &format!(", ior {}", m.ior);
        }
        if let Some(r) = m.base_roughness {
            line += &format!(", over a conductor of roughness {r}");
        }
        if m.reflectance_conductor {
            line += ", eta 1 and k per hit from its reflectance (the albedo)";
        } else if m.kind == K::Conductor || m.base_roughness.is_some() {
            line += &format!(", eta {}, k {}", v(m.eta), v(m.k));
        }
        if m.emits() {
            line += &format!(", emission {}{}", v(e), if m.two_sided { " (two-sided)" } else { "" });
        }
        if let Some(t) = m.albedo_texture.as_ref().filter(|_| m.mix.is_none()) {
            line += &format!(", albedo times texture {}", t.path.display());
        }
        if let Some(p) = m.albedo_procedural.as_ref().filter(|_| m.mix.is_none()) {
            line += &format!(", albedo times the {}", p.describe());
        }
        if let Some(t) = &m.roughness_texture {
            line += &format!(", roughness times texture {}", t.path.display());
        }
        println!("{line}");
    }
    if !scene.textures.is_empty() {
        let bytes: usize = scene.textures.iter().map(|t| 4 * t.texels.len()).sum();
        println!("  textures: {}, {:.1} MB of texels", scene.textures.len(), bytes as f64 / 1e6);
        for line in rlpt::scene::texture::describe(&scene.textures) {
            println!("    {line}");
        }
    }
    for m in &scene.material_mappings {
        println!("  mapped {m}");
    }
    for note in &scene.notes {
        println!("  note: {note}");
    }
    let count = |k: u32| prepared.lights.iter().filter(|l| l.kind == k).count();
    // The image environment, where there is one, in place of the uniform sky's radiance.
    let environment = match &scene.environment_map {
        Some(m) => format!("image {} ({} x {}, mean radiance {})", m.file.display(), m.width, m.height, v(m.mean())),
        None => v(scene.environment),
    };
    println!(
        "  lights: {} ({} spheres, {} quads, {} triangles, {} distant, {} point, {} spot{}); environment {}",
        prepared.lights.len(),
        count(shared::LIGHT_SPHERE),
        count(shared::LIGHT_QUAD),
        count(shared::LIGHT_TRIANGLE),
        count(shared::LIGHT_DISTANT),
        count(shared::LIGHT_POINT),
        count(shared::LIGHT_SPOT),
        if count(shared::LIGHT_ENV) > 0 { ", the image environment" } else { "" },
        environment
    );
    for l in &scene.delta_lights {
        println!("    {l:?}");
    }
    if let Some((lo, hi)) = bounds(&prepared) {
        println!("  bounds {} to {}", v(lo), v(hi));
    }
    // The grid guiding learns on at the scene's size (docs/guiding.md, "The table").
    let roulette = opts.russian_roulette_depth.is_some();
    let bins = rlpt::guide::default_bins(roulette);
    let grid = rlpt::guide::Grid::for_render(&prepared, &scene.guiding, roulette, bins);
    println!(
        "  guide grid (--guiding sphere, default bins): {}x{}x{} cells, {}, over {} to {}",
        grid.res[0],
        grid.res[1],
        grid.res[2],
        scene.guiding.grid.unwrap_or_default().name(),
        v(grid.min),
        v(grid.max)
    );
    if prepared.bvh_nodes.is_empty() {
        println!("  no BVH: the kernel walks the {} primitives itself", scene.spheres.len() + scene.quads.len());
    } else {
        println!(
            "  BVH: {} nodes (4-wide), depth {}, {} primitive refs",
            prepared.bvh_nodes.len(),
            bvh_depth(&prepared.bvh_nodes),
            prepared.prim_refs.len()
        );
    }
    let geometry = rlpt::render::scene_geometry_bytes(&prepared);
    let small = [
        std::mem::size_of_val(prepared.materials.as_slice()),
        std::mem::size_of_val(prepared.spheres.as_slice()),
        std::mem::size_of_val(prepared.quads.as_slice()),
        std::mem::size_of_val(prepared.lights.as_slice()),
    ]
    .iter()
    .sum::<usize>() as u64;
    let accum = scene.render.width as u64 * scene.render.height as u64 * 32;
    println!(
        "  device memory: {} scene geometry (triangles, normals, BVH), {} other scene data, {} image",
        megabytes(geometry),
        megabytes(small),
        megabytes(accum)
    );
    Ok(())
}
