//! Every kind of refusal of the scene loader: each message must name the file,
//! point at the offending key or value (`line:column`, 1-based) and say what
//! was expected. The scenes are assembled from the fixed pieces of
//! `tests/common/scene_pieces.rs`, so that the bad line's number is known by
//! construction.
//!
//! This file: TOML syntax, unknown and missing keys and tables, wrong types,
//! whole-scene checks, positions and files; the values, in `scene_errors_values.rs`.

mod common;

use common::scene_pieces::*;
use rlpt::scene::{Scene, SceneError};

#[test]
fn the_base_pieces_are_valid() {
    for text in [with_camera(CAMERA), with_render("[render]\n"), with_material(MATERIAL), with_geometry(SPHERE)] {
        Scene::parse(&text, "good.toml").unwrap();
    }
}

// ---------------------------------------------------------------------------
// TOML syntax.

#[test]
fn toml_syntax_error() {
    let text = with_camera("[camera]\nposition = [0, 0, 5\nlook_at = [0, 0, 0]\nvfov = 45\n");
    expect(&text, "3:1", &["not valid TOML", "comma"]);
    assert!(matches!(Scene::parse(&text, "bad.toml"), Err(SceneError::Syntax { line: 3, column: 1, .. })));
}

#[test]
fn toml_unquoted_string() {
    let text = with_material("[[material]]\nname = white\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n");
    expect(&text, "6:8", &["not valid TOML", "quoted"]);
}

#[test]
fn toml_duplicate_key() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = 45\nvfov = 50\n");
    expect(&text, "5:1", &["not valid TOML", "duplicate key"]);
}

// ---------------------------------------------------------------------------
// Unknown keys and tables.

#[test]
fn unknown_key_in_camera() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 45\n");
    expect(
        &text,
        "4:1",
        &["[camera]: unknown key `fov`", "expected one of position, look_at, direction, up, vfov, near"],
    );
}

#[test]
fn unknown_key_in_render() {
    let text = with_render("[render]\nwidth = 64\nsamples = 16\n");
    expect(&text, "3:1", &["[render]: unknown key `samples`", "expected one of width, height, spp"]);
}

#[test]
fn unknown_key_in_environment() {
    let text = with_render("[environment]\ncolor = [1, 1, 1]\n");
    expect(&text, "2:1", &["[environment]: unknown key `color`", "expected one of radiance"]);
}

#[test]
fn unknown_key_in_material() {
    let text =
        with_material("[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\ncolour = 1\n");
    expect(
        &text,
        "9:1",
        &["[[material]] \"white\": unknown key `colour`", "expected one of name, type, albedo, emission, two_sided"],
    );
}

#[test]
fn roughness_is_unknown_for_diffuse() {
    let text = with_material(
        "[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\nroughness = 0.5\n",
    );
    expect(&text, "9:1", &["unknown key `roughness` for a material of type \"diffuse\""]);
}

#[test]
fn ior_is_unknown_for_glossy() {
    let text = with_material(
        "[[material]]\nname = \"white\"\ntype = \"glossy\"\nalbedo = [0.5, 0.5, 0.5]\nroughness = 0.5\nior = 1.5\n",
    );
    expect(
        &text,
        "10:1",
        &[
            "unknown key `ior` for a material of type \"glossy\"",
            "expected one of name, type, albedo, roughness, emission, two_sided",
        ],
    );
}

#[test]
fn albedo_is_unknown_for_emissive() {
    let text = with_material(
        "[[material]]\nname = \"white\"\ntype = \"emissive\"\nalbedo = [0.5, 0.5, 0.5]\nemission = [1, 1, 1]\n",
    );
    expect(
        &text,
        "8:1",
        &[
            "unknown key `albedo` for a material of type \"emissive\"",
            "expected one of name, type, emission, two_sided",
        ],
    );
}

#[test]
fn roughness_is_unknown_for_specular() {
    let text = with_material(
        "[[material]]\nname = \"white\"\ntype = \"specular\"\nalbedo = [0.5, 0.5, 0.5]\nroughness = 0.1\n",
    );
    expect(&text, "9:1", &["unknown key `roughness` for a material of type \"specular\""]);
}

#[test]
fn dielectric_roughness_out_of_range() {
    let text = with_material("[[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5\nroughness = 1.5\n");
    expect(
        &text,
        "9:13",
        &["[[material]] \"glass\": key `roughness` must be a number in [0, 1] (0: smooth), found 1.5"],
    );
}

#[test]
fn conductor_needs_eta_and_k_in_range() {
    let text = with_material("[[material]]\nname = \"gold\"\ntype = \"conductor\"\nk = [3, 2, 1]\n");
    expect(&text, "5:1", &["[[material]] \"gold\": missing key `eta` ([r, g, b], components in (0, 100])"]);
    let text =
        with_material("[[material]]\nname = \"gold\"\ntype = \"conductor\"\neta = [0.1, 0, 1.4]\nk = [3, 2, 1]\n");
    expect(
        &text,
        "8:13",
        &["[[material]] \"gold\": key `eta` must have every component in (0, 100], found 0 (component 2)"],
    );
    let text =
        with_material("[[material]]\nname = \"gold\"\ntype = \"conductor\"\neta = [0.1, 0.4, 1.4]\nk = [3, -2, 1]\n");
    expect(
        &text,
        "9:9",
        &["[[material]] \"gold\": key `k` must have every component in [0, 100], found -2 (component 2)"],
    );
    let text = with_material(
        "[[material]]\nname = \"gold\"\ntype = \"conductor\"\neta = [0.1, 0.4, 1.4]\nk = [3, 2, 1]\nroughness = -0.1\n",
    );
    expect(&text, "10:13", &["key `roughness` must be a number in [0, 1] (0: a mirror), found -0.1"]);
}

#[test]
fn coated_needs_a_coat_roughness_and_a_whole_conductor_base() {
    let text = with_material(
        "[[material]]\nname = \"paint\"\ntype = \"coated\"\nalbedo = [0.5, 0.2, 0.1]\nroughness = -0.1\n",
    );
    expect(&text, "9:13", &["[[material]] \"paint\": key `roughness` must be a number in [0, 1] (0: a smooth coat)"]);
    let base = "[[material]]\nname = \"rim\"\ntype = \"coated\"\nroughness = 0\n";
    let text = with_material(&format!("{base}eta = [1.6, 0.9, 0.5]\nk = [9, 6, 5]\n"));
    expect(&text, "5:1", &["[[material]] \"rim\": missing key `base_roughness`"]);
    let text = with_material(&format!("{base}albedo = [0.5, 0.5, 0.5]\nbase_roughness = 0.3\n"));
    expect(&text, "5:1", &["key `base_roughness` needs a conductor base: give its `eta` and `k` too"]);
    let text = with_material(&format!("{base}eta = [1.6, 0.9, 0.5]\nbase_roughness = 0.3\n"));
    expect(&text, "5:1", &["missing key `k`"]);
    let text = with_material(
        "[[material]]\nname = \"paint\"\ntype = \"coated\"\nalbedo = [0.5, 0.2, 0.1]\nroughness = 0.2\nior = 0.8\n",
    );
    expect(&text, "10:7", &["key `ior` must be a number from 1 to 100, found 0.8"]);
}

#[test]
fn unknown_key_in_sphere() {
    let text = with_geometry("[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"white\"\nradious = 2\n");
    expect(&text, "13:1", &["[[sphere]] #1: unknown key `radious`", "expected one of center, radius, material"]);
}

#[test]
fn unknown_key_in_quad() {
    let text = with_geometry(
        "[[quad]]\norigin = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\nedge_w = [0, 0, 1]\nmaterial = \"white\"\n",
    );
    expect(&text, "13:1", &["[[quad]] #1: unknown key `edge_w`", "expected one of origin, edge_u, edge_v, material"]);
}

#[test]
fn unknown_top_level_table() {
    let text = format!("{}[lights]\nintensity = 3\n", with_geometry(SPHERE));
    expect(
        &text,
        "13:2",
        &["unknown table `[lights]`", "[camera]", "[guiding]", "[[material]]", "[[sphere]]", "[[quad]]"],
    );
}

#[test]
fn unknown_top_level_array_of_tables() {
    let text = format!("{}[[light]]\nintensity = 3\n", with_geometry(SPHERE));
    expect(&text, "13:3", &["unknown table `[[light]]`"]);
}

#[test]
fn unknown_top_level_key() {
    let text = format!("version = 2\n{}", with_geometry(SPHERE));
    expect(&text, "1:1", &["unknown top-level key `version`"]);
}

// ---------------------------------------------------------------------------
// Missing tables and keys.

#[test]
fn missing_camera() {
    let text = format!("{MATERIAL}{SPHERE}");
    expect(&text, "", &["missing table [camera]", "vfov"]);
}

#[test]
fn missing_camera_position() {
    let text = with_camera("[camera]\nlook_at = [0, 0, 0]\nvfov = 45\n");
    expect(&text, "1:1", &["[camera]: missing key `position`"]);
}

#[test]
fn missing_camera_vfov() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n");
    expect(&text, "1:1", &["[camera]: missing key `vfov` (vertical field of view in degrees, 0 < vfov < 180)"]);
}

#[test]
fn missing_material_name_and_type() {
    let text = with_material("[[material]]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n");
    expect(&text, "5:1", &["[[material]] #1: missing key `name`"]);
    let text = with_material("[[material]]\nname = \"white\"\nalbedo = [0.5, 0.5, 0.5]\n");
    expect(
        &text,
        "5:1",
        &[
            "[[material]] \"white\": missing key `type`",
            "diffuse, specular, glossy, dielectric, conductor, coated, emissive, mix",
        ],
    );
}

#[test]
fn missing_albedo_of_diffuse() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"diffuse\"\n");
    expect(&text, "5:1", &["[[material]] \"white\": missing key `albedo`", "[0, 1]"]);
}

#[test]
fn missing_albedo_of_specular() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"specular\"\n");
    expect(&text, "5:1", &["[[material]] \"white\": missing key `albedo`"]);
}

#[test]
fn missing_albedo_of_glossy() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"glossy\"\nroughness = 0.5\n");
    expect(&text, "5:1", &["[[material]] \"white\": missing key `albedo`"]);
}

#[test]
fn missing_roughness_of_glossy() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"glossy\"\nalbedo = [0.5, 0.5, 0.5]\n");
    expect(&text, "5:1", &["[[material]] \"white\": missing key `roughness`", "(0, 1]"]);
}

#[test]
fn missing_ior_of_dielectric() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"dielectric\"\n");
    expect(&text, "5:1", &["[[material]] \"white\": missing key `ior`", ">= 1"]);
}

#[test]
fn missing_emission_of_emissive() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"emissive\"\n");
    expect(&text, "5:1", &["[[material]] \"white\": missing key `emission`"]);
}

#[test]
fn missing_sphere_radius() {
    let text = with_geometry("[[sphere]]\ncenter = [0, 0, 0]\nmaterial = \"white\"\n");
    expect(&text, "9:1", &["[[sphere]] #1: missing key `radius`", "> 0"]);
}

#[test]
fn missing_sphere_material() {
    let text = with_geometry("[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n");
    expect(&text, "9:1", &["[[sphere]] #1: missing key `material`"]);
}

#[test]
fn missing_quad_edge() {
    let text = with_geometry("[[quad]]\norigin = [0, 0, 0]\nedge_u = [1, 0, 0]\nmaterial = \"white\"\n");
    expect(&text, "9:1", &["[[quad]] #1: missing key `edge_v`"]);
}

#[test]
fn second_sphere_is_numbered() {
    let text = with_geometry(&format!("{SPHERE}[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n"));
    expect(&text, "13:1", &["[[sphere]] #2: missing key `material`"]);
}

// ---------------------------------------------------------------------------
// Wrong types.

#[test]
fn string_for_number() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = \"wide\"\n");
    expect(&text, "4:8", &["[camera]: key `vfov` must be a number", "found string \"wide\""]);
}

#[test]
fn float_for_integer() {
    let text = with_render("[render]\nwidth = 64.5\n");
    expect(&text, "2:9", &["[render]: key `width` must be an integer", "found float 64.5"]);
}

#[test]
fn float_with_zero_fraction_for_integer() {
    let text = with_render("[render]\nspp = 16.0\n");
    expect(&text, "2:7", &["key `spp` must be an integer", "found float 16.0"]);
}

#[test]
fn vector_of_two() {
    let text = with_camera("[camera]\nposition = [0, 5]\nlook_at = [0, 0, 0]\nvfov = 45\n");
    expect(&text, "2:12", &["[camera]: key `position` must be an array of 3 numbers", "found an array of 2 values"]);
}

#[test]
fn vector_of_four() {
    let text = with_geometry("[[sphere]]\ncenter = [0, 0, 0, 1]\nradius = 1\nmaterial = \"white\"\n");
    expect(&text, "10:10", &["key `center` must be an array of 3 numbers", "4 values"]);
}

#[test]
fn number_for_vector() {
    let text = with_geometry("[[sphere]]\ncenter = 0\nradius = 1\nmaterial = \"white\"\n");
    expect(&text, "10:10", &["key `center` must be an array of 3 numbers", "integer 0"]);
}

#[test]
fn string_in_vector() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, \"half\", 0.5]\n");
    expect(&text, "8:16", &["key `albedo` component 2 must be a number", "string \"half\""]);
}

#[test]
fn number_for_material_name() {
    let text = with_geometry("[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = 3\n");
    expect(&text, "12:12", &["key `material` must be the name of a [[material]]", "integer 3"]);
}

#[test]
fn number_for_bool() {
    let text =
        with_material("[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\ntwo_sided = 1\n");
    expect(&text, "9:13", &["key `two_sided` must be true or false", "integer 1"]);
}

#[test]
fn unknown_material_type() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"metal\"\nalbedo = [0.5, 0.5, 0.5]\n");
    expect(
        &text,
        "7:8",
        &[
            "key `type` must be one of diffuse, specular, glossy, dielectric, conductor, coated, emissive, mix",
            "found \"metal\"",
        ],
    );
}

#[test]
fn empty_material_name() {
    let text = with_material("[[material]]\nname = \"\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n");
    expect(&text, "6:8", &["key `name` must be a non-empty string"]);
}

#[test]
fn camera_written_as_array_of_tables() {
    let text = with_camera("[[camera]]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = 45\n");
    expect(&text, "1:1", &["`camera` must be a single table written [camera]"]);
}

#[test]
fn material_written_as_single_table() {
    let text = with_material("[material]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n");
    expect(&text, "5:1", &["`material` must be an array of tables", "write [[material]], not [material]"]);
}

// ---------------------------------------------------------------------------
// Whole-scene checks.

#[test]
fn no_geometry() {
    let text = format!("{CAMERA}{MATERIAL}");
    expect(&text, "", &["the scene has no geometry", "[[sphere]] or [[quad]]"]);
}

#[test]
fn no_material() {
    let text = format!("{CAMERA}{SPHERE}");
    expect(&text, "", &["the scene defines no material", "[[material]]"]);
}

#[test]
fn empty_file() {
    expect("", "", &["missing table [camera]"]);
}

// ---------------------------------------------------------------------------
// Positions.

#[test]
fn columns_count_characters_not_bytes() {
    // Inline tables are TOML too; the bad value `2` is the 58th character of
    // line 1 but its 60th byte, because of the two-byte letters before it.
    // (A top-level key must come before the first table header.)
    let text = format!("material = [{{ name = \"wéiß\", type = \"diffuse\", albedo = [2, 0, 0] }}]\n{CAMERA}{SPHERE}")
        .replace("material = \"white\"", "material = \"wéiß\"");
    let line1 = text.lines().next().unwrap();
    let column = line1.chars().position(|c| c == '2').unwrap() + 1;
    assert_eq!(column, 58);
    assert_eq!(line1.find('2'), Some(59));
    expect(&text, "1:58", &["[[material]] \"wéiß\": key `albedo`", "in [0, 1]"]);
}

#[test]
fn windows_line_endings() {
    let text = camera_with_vfov("0").replace('\n', "\r\n");
    expect(&text, "4:8", &["0 < vfov < 180"]);
}

// ---------------------------------------------------------------------------
// Files.

#[test]
fn errors_from_files_name_the_path() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("scene_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, camera_with_vfov("200")).unwrap();
    let message = Scene::load(&path).unwrap_err().to_string();
    assert!(message.starts_with(&format!("{}:4:8: ", path.display())), "{message}");
    assert!(message.contains("0 < vfov < 180"), "{message}");
}

#[test]
fn missing_file_names_the_path() {
    let path = std::path::Path::new("scenes/does-not-exist.toml");
    let error = Scene::load(path).unwrap_err();
    assert!(matches!(error, SceneError::Io { .. }));
    let message = error.to_string();
    assert!(message.starts_with("scenes/does-not-exist.toml: cannot read the scene file"), "{message}");
}

#[test]
fn binary_file_says_what_a_scene_is() {
    // An EXR given where the scene goes: the reader's "not valid UTF-8" alone
    // does not tell the user what was expected.
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("scene_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("image.exr");
    std::fs::write(&path, [0x76, 0x2f, 0x31, 0x01, 0xff, 0xfe, 0x00, 0x80]).unwrap();
    let message = Scene::load(&path).unwrap_err().to_string();
    assert!(message.starts_with(&format!("{}: cannot read the scene file", path.display())), "{message}");
    assert!(message.contains("a scene is a TOML text file"), "{message}");
}

#[test]
fn position_accessor() {
    let error = Scene::parse(&camera_with_vfov("0"), "bad.toml").unwrap_err();
    assert_eq!(error.position(), Some((4, 8)));
    let error = Scene::parse(&format!("{CAMERA}{MATERIAL}"), "bad.toml").unwrap_err();
    assert_eq!(error.position(), None);
}
