//! What the BVH tests share (tests/bvh.rs, tests/bvh_gpu.rs,
//! bvh-crates/tests/bvh_crates.rs): a test-only PLY reader, the bunny and a mixed
//! scene prepared as the renderers prepare them, scenes of bare triangles, random
//! rays in bundles, the brute-force reference, and a closed icosphere
//! (tests/mesh_render.rs too).
#![allow(dead_code)]

use rlpt::layout::{prim_kind_index, prim_ref, GpuTriangle, SceneArrays};
use rlpt::math::bvh::{self, PrimBox};
use rlpt::math::geometry::{intersect_quad, intersect_sphere, sphere_blocks};
use rlpt::math::rng::Rng;
use rlpt::math::triangle::intersect_triangle;
use rlpt::math::Vec3;
use rlpt::options::RenderOptions;
use rlpt::prepared::PreparedScene;
use rlpt::scene::{Mesh, Quad, Scene, Sphere};
use rlpt::shared;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

/// The repository's root: rlpt's, or its parent's for bvh-crates/, which reads this module too.
fn repo_root() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    if env!("CARGO_PKG_NAME") == "rlpt-bvh-crates" {
        dir.parent().expect("bvh-crates/ lies in the repository").to_path_buf()
    } else {
        dir.to_path_buf()
    }
}

/// The shared assets (issue 36): other people's data, never committed here.
pub fn asset(rel: &str) -> PathBuf {
    repo_root().join("../shared/assets").join(rel)
}

/// A PLY file's vertex positions and its faces as triangles (polygons fanned).
pub struct Ply {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

fn scalar_size(ty: &str) -> usize {
    match ty {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        _ => panic!("PLY type {ty} unknown to the test reader"),
    }
}

fn read_scalar(ty: &str, b: &[u8]) -> f64 {
    match ty {
        "char" | "int8" => b[0] as i8 as f64,
        "uchar" | "uint8" => b[0] as f64,
        "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
        "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
        "int" | "int32" => i32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "uint" | "uint32" => u32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "float" | "float32" => f32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        _ => f64::from_le_bytes(b[..8].try_into().unwrap()),
    }
}

/// Reads an ASCII or binary little-endian PLY of a vertex element (x, y, z among
/// its scalar properties) and a face element (one list property), in that order.
/// A missing file fails the test with a sentence naming it.
pub fn read_ply(path: &Path) -> Ply {
    let file = std::fs::File::open(path).unwrap_or_else(|e| {
        panic!("{} cannot be read ({e}): the BVH tests need the shared assets of issue 36 there", path.display())
    });
    let mut r = std::io::BufReader::new(file);
    let (mut binary, mut elements) = (false, Vec::<(String, usize, Vec<Vec<String>>)>::new());
    loop {
        let mut line = String::new();
        assert!(r.read_line(&mut line).unwrap() > 0, "{}: no end_header", path.display());
        let w: Vec<String> = line.split_whitespace().map(str::to_owned).collect();
        match w.first().map(String::as_str) {
            Some("format") => binary = w[1] == "binary_little_endian",
            Some("element") => elements.push((w[1].clone(), w[2].parse().unwrap(), vec![])),
            Some("property") => elements.last_mut().unwrap().2.push(w[1..].to_vec()),
            Some("end_header") => break,
            _ => {}
        }
    }
    let mut text = String::new();
    if !binary {
        r.read_to_string(&mut text).unwrap();
    }
    let mut tokens = text.split_ascii_whitespace();
    let mut bytes = Vec::new();
    if binary {
        r.read_to_end(&mut bytes).unwrap();
    }
    let mut at = 0;
    let mut next = |ty: &str| -> f64 {
        if binary {
            let n = scalar_size(ty);
            at += n;
            read_scalar(ty, &bytes[at - n..at])
        } else {
            tokens.next().expect("PLY data ends early").parse().unwrap()
        }
    };
    let mut ply = Ply { positions: vec![], triangles: vec![] };
    for (name, count, props) in &elements {
        for _ in 0..*count {
            let mut p = [0.0f32; 3];
            for prop in props {
                if prop[0] == "list" {
                    let n = next(&prop[1]) as usize;
                    let idx: Vec<u32> = (0..n).map(|_| next(&prop[2]) as u32).collect();
                    if name == "face" {
                        for k in 1..n.saturating_sub(1) {
                            ply.triangles.push([idx[0], idx[k], idx[k + 1]]);
                        }
                    }
                } else {
                    let v = next(&prop[0]);
                    match (name.as_str(), prop[1].as_str()) {
                        ("vertex", "x") => p[0] = v as f32,
                        ("vertex", "y") => p[1] = v as f32,
                        ("vertex", "z") => p[2] = v as f32,
                        _ => {}
                    }
                }
            }
            if name == "vertex" {
                ply.positions.push(Vec3::from(p));
            }
        }
    }
    ply
}

/// A PLY's triangles as their three vertices each.
pub fn ply_triangles(ply: &Ply) -> Vec<[Vec3; 3]> {
    ply.triangles.iter().map(|t| t.map(|i| ply.positions[i as usize])).collect()
}

/// The BMW M6's 114 meshes (`bmw_m6_pbrt/geometry/*.ply`, in name order) as
/// one list of triangles, and how many files they came from.
pub fn bmw_triangles() -> (Vec<[Vec3; 3]>, usize) {
    let mut files: Vec<_> = std::fs::read_dir(asset("bmw_m6_pbrt/geometry"))
        .expect("the BMW's meshes in ../shared/assets/bmw_m6_pbrt/geometry")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ply"))
        .collect();
    files.sort();
    let tris = files.iter().flat_map(|f| ply_triangles(&read_ply(f))).collect();
    (tris, files.len())
}

/// A scene of one grey material under a sky (the open furnace, its ball taken out).
fn base_scene() -> Scene {
    let text = std::fs::read_to_string(repo_root().join("scenes/furnace-open.toml")).unwrap();
    let mut scene = Scene::parse(&text, "furnace-open.toml").unwrap();
    scene.spheres.clear();
    scene
}

fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    Mesh {
        source: PathBuf::from("test mesh"),
        positions,
        normals: None,
        uvs: None,
        materials: vec![0; triangles.len()],
        triangles,
    }
}

fn prepare(scene: &Scene) -> PreparedScene {
    let prepared = PreparedScene::new(scene, &RenderOptions::from_scene(scene)).expect("valid options");
    assert!(!prepared.bvh_nodes.is_empty(), "the scene walks a BVH");
    prepared
}

/// The Stanford bunny (69451 triangles), as the renderers prepare it.
pub fn bunny() -> PreparedScene {
    let ply = read_ply(&asset("stanford_bunny/bun_zipper.ply"));
    assert_eq!(ply.triangles.len(), 69451);
    let mut scene = base_scene();
    scene.meshes.push(mesh(ply.positions, ply.triangles));
    prepare(&scene)
}

/// Random triangles (small and large, some sharing vertices), spheres (some far
/// larger than the rest, some tiny) and quads (some axis-aligned), overlapping.
pub fn mixed() -> PreparedScene {
    let mut rng = Rng::new(36, 1, 0, 0);
    let mut r = || rng.next_f32();
    let mut scene = base_scene();
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..400u32 {
        let c = Vec3::new(r(), r(), r()) * 10.0 - 5.0;
        let size = if i % 10 == 0 { 4.0 } else { 0.6 };
        let mut corner = || c + (Vec3::new(r(), r(), r()) - 0.5) * size;
        let (a, b, d) = (corner(), corner(), corner());
        let n = positions.len() as u32;
        positions.extend([a, b, d]);
        triangles.push([n, n + 1, n + 2]);
        if i % 4 == 0 {
            // A neighbour across the edge (b, d): the two share it exactly.
            positions.push(corner());
            triangles.push([n + 2, n + 1, n + 3]);
        }
    }
    scene.meshes.push(mesh(positions, triangles));
    for i in 0..120 {
        let center = Vec3::new(r(), r(), r()) * 10.0 - 5.0;
        let radius = match i % 12 {
            0 => 3.0 + 3.0 * r(),
            1 => 1e-3 * r() + 1e-4,
            _ => 0.05 + 0.5 * r(),
        };
        scene.spheres.push(Sphere { center, radius, material: 0, uv: rlpt::scene::SphereUv::TOML });
    }
    for i in 0..80 {
        let origin = Vec3::new(r(), r(), r()) * 10.0 - 5.0;
        let (edge_u, edge_v) = if i % 3 == 0 {
            let k = i % 9 / 3;
            let (mut u, mut v) = (Vec3::ZERO, Vec3::ZERO);
            u[k] = 0.5 + 2.0 * r();
            v[(k + 1) % 3] = 0.5 + 2.0 * r();
            (u, v)
        } else {
            (Vec3::new(r(), r(), r()) * 2.0 - 1.0, Vec3::new(r(), r(), r()) * 2.0 - 1.0)
        };
        scene.quads.push(Quad { origin, edge_u, edge_v, material: 0 });
    }
    prepare(&scene)
}

/// The layout's triangle of corners `a`, `b`, `c` (material, light and normals 0).
pub fn gpu_triangle([a, b, c]: [Vec3; 3]) -> GpuTriangle {
    GpuTriangle { v0: a.into(), v1: b.into(), v2: c.into(), ..Default::default() }
}

/// `n` random triangles of about `size` around points of [0, 10]^3.
pub fn random_triangles(n: usize, seed: u32, size: f32) -> Vec<GpuTriangle> {
    let mut rng = Rng::new(seed, 0, 0, 0);
    let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    (0..n)
        .map(|_| {
            let c = r3() * 10.0;
            gpu_triangle([c, c + (r3() - 0.5) * size, c + (r3() - 0.5) * size])
        })
        .collect()
}

/// The builder's input for `triangles`: triangle i's reference and box.
pub fn triangle_boxes(triangles: &[GpuTriangle]) -> Vec<PrimBox> {
    triangles.iter().enumerate().map(|(i, t)| PrimBox::triangle(i as u32, t)).collect()
}

/// A scene of `triangles` alone over rlpt's BVH of them.
pub fn triangle_scene(triangles: Vec<GpuTriangle>) -> SceneArrays {
    let built = bvh::build(&triangle_boxes(&triangles));
    SceneArrays { bvh_nodes: built.nodes, prim_refs: built.prim_refs, ..SceneArrays::of_triangles(triangles) }
}

/// The box around the scene: the union of the root's boxes.
pub fn bounds(s: &SceneArrays) -> (Vec3, Vec3) {
    let (lo, hi) = s.bvh_nodes[0].bounds();
    (Vec3::from(lo), Vec3::from(hi))
}

/// A conservative cone: the primitives whose bounding sphere it may meet.
pub struct Bundle {
    pub origin: Vec3,
    pub rays: Vec<Vec3>,
    /// The primitives a ray of the bundle may meet (refs): every other lies outside the cone.
    pub candidates: Vec<u32>,
}

/// A primitive's bounding sphere (centre, radius), generous by a margin.
fn bounding_sphere(s: &SceneArrays, r: u32) -> (glam::DVec3, f64) {
    let (kind, i) = prim_kind_index(r);
    let i = i as usize;
    let (c, rad) = match kind {
        shared::PRIM_TRIANGLE => {
            let v = s.triangles[i].vertices().map(|p| p.as_dvec3());
            let c = (v[0] + v[1] + v[2]) / 3.0;
            (c, v.iter().map(|p| (*p - c).length()).fold(0.0, f64::max))
        }
        shared::PRIM_SPHERE => {
            let cr = s.spheres[i].center_radius;
            (glam::DVec3::new(cr[0] as f64, cr[1] as f64, cr[2] as f64), cr[3] as f64)
        }
        _ => {
            let q = &s.quads[i];
            let v = |a: [f32; 4]| glam::DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
            let (o, u, w) = (v(q.origin), v(q.edge_u), v(q.edge_v));
            (o + 0.5 * (u + w), 0.5 * (u + w).length().max((u - w).length()))
        }
    };
    (c, rad * (1.0 + 1e-4) + 1e-5 * (1.0 + c.abs().max_element()))
}

/// `n` bundles of `per` rays: each from a random origin in the scene's box grown
/// by a fifth on every side, in a cone of half-angle `angle` about a random axis
/// (one bundle in eight about a coordinate axis, its first ray along that axis
/// exactly: directions with zero components), with the primitives the cone may
/// meet.
pub fn bundles(s: &SceneArrays, n: usize, per: usize, angle: f64, seed: u32) -> Vec<Bundle> {
    let (lo, hi) = bounds(s);
    let (lo, hi) = (lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo));
    let all = all_prims(s);
    let spheres: Vec<_> = all.iter().map(|&r| bounding_sphere(s, r)).collect();
    use rayon::prelude::*;
    (0..n)
        .into_par_iter()
        .map(|b| {
            let mut rng = Rng::new(seed, b as u32, 0, 0);
            let origin = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let axis = if b % 8 == 0 {
                let mut a = Vec3::ZERO;
                a[b / 8 % 3] = if b % 16 == 0 { 1.0 } else { -1.0 };
                a
            } else {
                rlpt::math::sampling::uniform_sphere(rng.next_2d())
            };
            let frame = rlpt::math::Frame::from_normal(axis);
            let rays = (0..per)
                .map(|k| {
                    if k == 0 {
                        return axis;
                    }
                    // Within 0.9 of the angle, uniformly over the cap's disc.
                    let (u1, u2) = (rng.next_f32(), rng.next_f32());
                    let rad = (angle as f32 * 0.9) * u1.sqrt();
                    let phi = 2.0 * std::f32::consts::PI * u2;
                    frame.to_world(Vec3::new(rad.sin() * phi.cos(), rad.sin() * phi.sin(), rad.cos())).normalize()
                })
                .collect();
            let (o, a) = (origin.as_dvec3(), axis.as_dvec3());
            let candidates = all
                .iter()
                .zip(&spheres)
                .filter(|(_, (c, rad))| {
                    let w = *c - o;
                    let dist = w.length();
                    dist <= *rad || {
                        let phi = (w.dot(a) / dist).clamp(-1.0, 1.0).acos();
                        phi <= angle + (rad / dist).asin() + 1e-6
                    }
                })
                .map(|(&r, _)| r)
                .collect();
            Bundle { origin, rays, candidates }
        })
        .collect()
}

/// The distance to primitive `r` in (0, t_max), by its own test.
pub fn prim_t(s: &SceneArrays, r: u32, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
    let (kind, i) = prim_kind_index(r);
    let i = i as usize;
    match kind {
        shared::PRIM_TRIANGLE => {
            let [a, b, c] = s.triangles[i].vertices();
            intersect_triangle(a, b, c, o, d, t_max)
        }
        shared::PRIM_SPHERE => intersect_sphere(&s.spheres[i], o, d, t_max),
        _ => intersect_quad(&s.quads[i], o, d, t_max),
    }
}

/// The nearest of `prims` in (0, t_max), the first of equals.
pub fn brute_closest(s: &SceneArrays, prims: &[u32], o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
    let mut best = None;
    let mut t_best = t_max;
    for &r in prims {
        if let Some(t) = prim_t(s, r, o, d, t_best) {
            t_best = t;
            best = Some((t, r));
        }
    }
    best
}

/// Whether one of `prims` but `skip` blocks (0, t_max): spheres by `sphere_blocks`.
pub fn brute_occluded(s: &SceneArrays, prims: &[u32], o: Vec3, d: Vec3, t_max: f32, skip: u32) -> bool {
    prims.iter().any(|&r| {
        r != skip && {
            let (kind, i) = prim_kind_index(r);
            if kind == shared::PRIM_SPHERE {
                sphere_blocks(&s.spheres[i as usize], o, d, t_max)
            } else {
                prim_t(s, r, o, d, t_max).is_some()
            }
        }
    })
}

/// Every primitive's reference.
pub fn all_prims(s: &SceneArrays) -> Vec<u32> {
    (0..s.triangles.len() as u32)
        .map(|i| prim_ref(shared::PRIM_TRIANGLE, i))
        .chain((0..s.spheres.len() as u32).map(|i| prim_ref(shared::PRIM_SPHERE, i)))
        .chain((0..s.quads.len() as u32).map(|i| prim_ref(shared::PRIM_QUAD, i)))
        .collect()
}

/// A closed icosphere of `level` subdivisions, radius 1 about the origin.
pub fn icosphere(level: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|p| Vec3::from(p).normalize())
    .to_vec();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for [a, b, c] in f {
            let mut m = |i: u32, j: u32| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    v.push(((v[i as usize] + v[j as usize]) / 2.0).normalize());
                    v.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f)
}
