//! Helpers of the pbrt import tests: scenes written into a directory of the
//! test's own, loaded or refused.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use rlpt::scene::Scene;

/// A fresh directory for one test.
pub fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rlpt-pbrt-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, text).unwrap();
    p
}

/// A triangle shape for scenes that need some geometry.
pub const TRIANGLE: &str = "Shape \"trianglemesh\" \"point3 P\" [0 0 5  1 0 5  0 1 5] \"integer indices\" [0 1 2]\n";

/// Loads `text` as `scene.pbrt` in a directory of its own.
pub fn load(test: &str, text: &str) -> Scene {
    let d = dir(test);
    let p = write(&d, "scene.pbrt", text);
    Scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// The refusal of `text`, with the scene path replaced by `scene.pbrt`.
pub fn refuse(test: &str, text: &str, strict: bool) -> String {
    let d = dir(test);
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
