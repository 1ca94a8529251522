//! Helpers of the pbrt import tests: scenes written into a directory of the
//! test's own (`common::cli::fresh_dir`, `common::files::write`), loaded or
//! refused. The including test declares `mod common`.
#![allow(dead_code)]

use super::common::cli::fresh_dir;
use super::common::files::write;
use rlpt::scene::Scene;

/// A triangle shape for scenes that need some geometry.
pub const TRIANGLE: &str = "Shape \"trianglemesh\" \"point3 P\" [0 0 5  1 0 5  0 1 5] \"integer indices\" [0 1 2]\n";

/// Loads `text` as `scene.pbrt` in a directory of its own.
pub fn load(test: &str, text: &str) -> Scene {
    let d = fresh_dir(test);
    let p = write(&d, "scene.pbrt", text);
    Scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// The refusal of `text`, with the scene path replaced by `scene.pbrt`.
pub fn refuse(test: &str, text: &str, strict: bool) -> String {
    let d = fresh_dir(test);
    let p = write(&d, "scene.pbrt", text);
    match Scene::load_with(&p, strict) {
        Ok(_) => panic!("{test}: the scene loaded; expected a refusal"),
        Err(e) => e.to_string().replace(&d.display().to_string(), "DIR"),
    }
}

/// The note that contains `needle`, or a panic listing them all.
pub fn note<'a>(scene: &'a Scene, needle: &str) -> &'a str {
    scene
        .notes
        .iter()
        .find(|n| n.contains(needle))
        .unwrap_or_else(|| panic!("no note containing {needle:?}; notes: {:#?}", scene.notes))
}

pub fn close(a: glam::Vec3, b: glam::Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}
