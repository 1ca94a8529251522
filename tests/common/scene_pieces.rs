//! The pieces the scene-error tests (`tests/scene_errors_*.rs`) assemble bad
//! scenes from, so that the bad line's number is known by construction:
//! - `with_camera(c)`: `c` starts on line 1;
//! - `with_render(r)`: `r` starts on line 1 (also used for `[environment]` and `[guiding]`);
//! - `with_material(m)`: the camera takes lines 1-4, `m` starts on line 5;
//! - `with_geometry(g)`: camera lines 1-4, material lines 5-8, `g` starts on line 9.

use rlpt::scene::Scene;

pub const CAMERA: &str = "\
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
vfov = 45
";

pub const MATERIAL: &str = "\
[[material]]
name = \"white\"
type = \"diffuse\"
albedo = [0.5, 0.5, 0.5]
";

pub const SPHERE: &str = "\
[[sphere]]
center = [0, 0, 0]
radius = 1
material = \"white\"
";

pub fn with_camera(camera: &str) -> String {
    format!("{camera}{MATERIAL}{SPHERE}")
}

pub fn with_render(render: &str) -> String {
    format!("{render}{CAMERA}{MATERIAL}{SPHERE}")
}

pub fn with_material(material: &str) -> String {
    format!("{CAMERA}{material}{SPHERE}")
}

pub fn with_geometry(geometry: &str) -> String {
    format!("{CAMERA}{MATERIAL}{geometry}")
}

/// Parses `text` as `bad.toml`, which must be refused; returns the message.
pub fn refuse(text: &str) -> String {
    match Scene::parse(text, "bad.toml") {
        Ok(scene) => panic!("scene accepted, expected a refusal:\n{text}\n{scene:?}"),
        Err(e) => e.to_string(),
    }
}

/// The message must start with `bad.toml:{at}: ` (or `bad.toml: ` when `at` is
/// empty) and contain every phrase.
#[track_caller]
pub fn expect(text: &str, at: &str, phrases: &[&str]) {
    let message = refuse(text);
    let prefix = if at.is_empty() { "bad.toml: ".to_string() } else { format!("bad.toml:{at}: ") };
    assert!(message.starts_with(&prefix), "message {message:?} does not start with {prefix:?}; scene:\n{text}");
    for phrase in phrases {
        assert!(message.contains(phrase), "message {message:?} lacks {phrase:?}; scene:\n{text}");
    }
}

pub fn camera_with_vfov(vfov: &str) -> String {
    with_camera(&format!("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = {vfov}\n"))
}
