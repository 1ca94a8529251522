//! Every kind of refusal of the scene loader: each message must name the file,
//! point at the offending key or value (`line:column`, 1-based) and say what
//! was expected. The scenes are assembled from the fixed pieces of
//! `tests/common/scene_pieces.rs`, so that the bad line's number is known by
//! construction.
//!
//! This file: values out of range or not finite, material names, camera
//! geometry, quads and the `[guiding]` table; the file's form, in
//! `scene_errors_syntax.rs`.

mod common;

use common::scene_pieces::*;
use rlpt::scene::Scene;

// ---------------------------------------------------------------------------
// Values out of range.

#[test]
fn vfov_zero() {
    expect(&camera_with_vfov("0"), "4:8", &["key `vfov` must be", "0 < vfov < 180", "found 0"]);
}

#[test]
fn vfov_180() {
    expect(&camera_with_vfov("180.0"), "4:8", &["0 < vfov < 180", "found 180.0"]);
}

#[test]
fn vfov_negative() {
    expect(&camera_with_vfov("-10"), "4:8", &["0 < vfov < 180", "found -10"]);
}

#[test]
fn near_negative() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = 45\nnear = -1.0\n");
    expect(&text, "5:8", &["key `near` must be a number from 0 to 1e12", "found -1.0"]);
}

#[test]
fn near_beyond_the_scene_scale() {
    // It clipped every ray: a black image without a word.
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = 45\nnear = 1e30\n");
    expect(&text, "5:8", &["key `near` must be a number from 0 to 1e12", "found 1e30"]);
}

#[test]
fn position_beyond_the_scene_scale() {
    let text = with_camera("[camera]\nposition = [0, 2e12, 5]\nlook_at = [0, 0, 0]\n");
    expect(&text, "2:16", &["key `position` must have every component within +-1e12", "found 2e12 (component 2)"]);
}

fn sphere_with_radius(radius: &str) -> String {
    with_geometry(&format!("[[sphere]]\ncenter = [0, 0, 0]\nradius = {radius}\nmaterial = \"white\"\n"))
}

#[test]
fn radius_zero() {
    expect(&sphere_with_radius("0"), "11:10", &["[[sphere]] #1: key `radius` must be a number > 0", "found 0"]);
}

#[test]
fn radius_negative() {
    expect(&sphere_with_radius("-2.5"), "11:10", &["key `radius` must be a number > 0", "found -2.5"]);
}

fn glossy_with_roughness(roughness: &str) -> String {
    with_material(&format!(
        "[[material]]\nname = \"white\"\ntype = \"glossy\"\nalbedo = [0.5, 0.5, 0.5]\nroughness = {roughness}\n"
    ))
}

#[test]
fn roughness_zero() {
    expect(
        &glossy_with_roughness("0.0"),
        "9:13",
        &["[[material]] \"white\": key `roughness` must be a number in (0, 1]", "found 0.0"],
    );
}

#[test]
fn roughness_above_one() {
    expect(&glossy_with_roughness("1.5"), "9:13", &["key `roughness` must be a number in (0, 1]", "found 1.5"]);
}

#[test]
fn roughness_one_is_accepted() {
    let text = glossy_with_roughness("1");
    let scene = Scene::parse(&text, "good.toml").unwrap();
    assert_eq!(scene.materials[0].roughness, 1.0);
}

#[test]
fn ior_below_one() {
    let text = with_material("[[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 0.9\n");
    let text = text.replace("\"white\"", "\"glass\"");
    expect(&text, "8:7", &["[[material]] \"glass\": key `ior` must be a number >= 1", "found 0.9"]);
}

fn diffuse_with_albedo(albedo: &str) -> String {
    with_material(&format!("[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = {albedo}\n"))
}

#[test]
fn albedo_above_one() {
    expect(
        &diffuse_with_albedo("[0.5, 1.2, 0.5]"),
        "8:16",
        &["key `albedo` must have every component in [0, 1]", "found 1.2 (component 2)"],
    );
}

#[test]
fn albedo_negative() {
    expect(
        &diffuse_with_albedo("[-0.1, 0.5, 0.5]"),
        "8:11",
        &["key `albedo` must have every component in [0, 1]", "found -0.1 (component 1)"],
    );
}

#[test]
fn dielectric_albedo_above_one() {
    let text =
        with_material("[[material]]\nname = \"white\"\ntype = \"dielectric\"\nior = 1.5\nalbedo = [1, 1, 1.01]\n");
    expect(&text, "9:17", &["key `albedo` must have every component in [0, 1]"]);
}

#[test]
fn emission_negative() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"emissive\"\nemission = [1, -1, 1]\n");
    expect(&text, "8:16", &["key `emission` must have every component from 0 to 1e12", "found -1 (component 2)"]);
}

#[test]
fn emission_beyond_f32_sums() {
    // 1e35 fitted an f32, but the lamp's power overflowed and the image came out black.
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"emissive\"\nemission = [1e35, 1, 1]\n");
    expect(&text, "8:13", &["key `emission` must have every component from 0 to 1e12", "found 1e35 (component 1)"]);
}

#[test]
fn emission_negative_on_diffuse() {
    let text = with_material(
        "[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\nemission = [0, 0, -0.5]\n",
    );
    expect(&text, "9:19", &["key `emission` must have every component from 0 to 1e12"]);
}

#[test]
fn environment_radiance_negative() {
    let text = with_render("[environment]\nradiance = [-1, 0, 0]\n");
    expect(&text, "2:13", &["[environment]: key `radiance` must have every component from 0 to 1e12"]);
}

#[test]
fn environment_radiance_beyond_f32_sums() {
    // 3e38 gave an image of infinities.
    let text = with_render("[environment]\nradiance = [3e38, 3e38, 3e38]\n");
    expect(&text, "2:13", &["[environment]: key `radiance` must have every component from 0 to 1e12", "found 3e38"]);
}

#[test]
fn width_zero() {
    expect(
        &with_render("[render]\nwidth = 0\n"),
        "2:9",
        &["[render]: key `width` must be an integer from 1 to 16384", "found 0"],
    );
}

#[test]
fn height_absurd() {
    expect(
        &with_render("[render]\nheight = 16385\n"),
        "2:10",
        &["key `height` must be an integer from 1 to 16384", "found 16385"],
    );
}

#[test]
fn spp_zero() {
    expect(&with_render("[render]\nspp = 0\n"), "2:7", &["key `spp` must be an integer from 1 to 4294967232"]);
}

#[test]
fn spp_beyond_whole_frames() {
    // Rounded up to whole frames of 64, u32::MAX samples overflowed (a panic).
    expect(&with_render("[render]\nspp = 4294967295\n"), "2:7", &["from 1 to 4294967232", "found 4294967295"]);
}

#[test]
fn max_bounces_absurd() {
    expect(
        &with_render("[render]\nmax_bounces = 1025\n"),
        "2:15",
        &["key `max_bounces` must be an integer from 0 to 1024"],
    );
}

#[test]
fn russian_roulette_depth_negative() {
    expect(
        &with_render("[render]\nrussian_roulette_depth = -1\n"),
        "2:26",
        &["key `russian_roulette_depth` must be an integer >= 0", "found -1"],
    );
}

#[test]
fn integer_too_large_for_i64() {
    expect(
        &with_render("[render]\nspp = 99999999999999999999\n"),
        "2:7",
        &["key `spp` must be an integer from 1 to 4294967232", "found 99999999999999999999"],
    );
}

// ---------------------------------------------------------------------------
// Non-finite numbers.

#[test]
fn infinite_vfov() {
    expect(&camera_with_vfov("inf"), "4:8", &["key `vfov` must be a finite number", "found inf"]);
}

#[test]
fn nan_radius() {
    expect(&sphere_with_radius("nan"), "11:10", &["key `radius` must be a finite number", "found nan"]);
}

#[test]
fn negative_infinity_in_vector() {
    let text = with_geometry("[[sphere]]\ncenter = [0, -inf, 0]\nradius = 1\nmaterial = \"white\"\n");
    expect(&text, "10:14", &["key `center` component 2 must be a finite number", "found -inf"]);
}

#[test]
fn nan_in_emission() {
    let text = with_material("[[material]]\nname = \"white\"\ntype = \"emissive\"\nemission = [+nan, 1, 1]\n");
    expect(&text, "8:13", &["key `emission` component 1 must be a finite number", "found +nan"]);
}

#[test]
fn float_overflowing_f64() {
    expect(&sphere_with_radius("1e400"), "11:10", &["key `radius` must be a finite number", "found 1e400"]);
}

#[test]
fn float_overflowing_f32() {
    let text = with_geometry("[[sphere]]\ncenter = [1e39, 0, 0]\nradius = 1\nmaterial = \"white\"\n");
    expect(&text, "10:11", &["key `center` component 1", "32-bit float", "found 1e39"]);
}

#[test]
fn radius_beyond_the_scene_scale() {
    // 5e18 fitted, but an emissive sphere that size rendered the closed furnace at 0.5, not 1.
    expect(&sphere_with_radius("5e18"), "11:10", &["key `radius` must be a number > 0, at most 1e12", "found 5e18"]);
}

#[test]
fn radius_whose_square_underflows_f32() {
    expect(&sphere_with_radius("1e-25"), "11:10", &["key `radius`", "32-bit float", "found 1e-25"]);
}

// ---------------------------------------------------------------------------
// Material names.

#[test]
fn undefined_material() {
    let text = format!(
        "{CAMERA}{MATERIAL}[[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [1, 1, 1]\n\
         {SPHERE}[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"chrome\"\n"
    );
    expect(&text, "20:12", &["[[sphere]] #2: material \"chrome\" is not defined (defined: white, lamp)"]);
}

#[test]
fn undefined_material_in_quad() {
    let text =
        with_geometry("[[quad]]\norigin = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\nmaterial = \"White\"\n");
    expect(&text, "13:12", &["[[quad]] #1: material \"White\" is not defined (defined: white)"]);
}

#[test]
fn duplicate_material_name() {
    let text =
        format!("{CAMERA}{MATERIAL}[[material]]\nname = \"white\"\ntype = \"specular\"\nalbedo = [1, 1, 1]\n{SPHERE}");
    expect(&text, "10:8", &["duplicate material name \"white\"", "already defined on line 6", "must be unique"]);
}

// ---------------------------------------------------------------------------
// Camera geometry.

#[test]
fn both_look_at_and_direction() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\ndirection = [0, 0, -1]\nvfov = 45\n");
    expect(&text, "4:13", &["[camera]: give exactly one of `look_at` and `direction`, not both"]);
}

#[test]
fn neither_look_at_nor_direction() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nvfov = 45\n");
    expect(&text, "1:1", &["[camera]: missing key `look_at` or `direction`", "exactly one"]);
}

#[test]
fn look_at_equal_to_position() {
    let text = with_camera("[camera]\nposition = [1, 2, 3]\nlook_at = [1.0, 2.0, 3.0]\nvfov = 45\n");
    expect(&text, "3:11", &["key `look_at` must differ from `position`"]);
}

#[test]
fn zero_direction() {
    let text = with_camera("[camera]\nposition = [1, 2, 3]\ndirection = [0, 0, 0]\nvfov = 45\n");
    expect(&text, "3:13", &["key `direction` must be a non-zero vector"]);
}

#[test]
fn up_parallel_to_view() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 0, 2]\nvfov = 45\n");
    expect(&text, "4:6", &["is parallel to `up` [0, 0, 2]", "give an `up` that is not parallel to the view direction"]);
}

#[test]
fn default_up_parallel_to_view() {
    let text = with_camera("[camera]\nposition = [0, 5, 0]\ndirection = [0, -3, 0]\nvfov = 45\n");
    expect(&text, "3:13", &["parallel to the default `up` [0, 1, 0]", "give an `up`"]);
}

#[test]
fn zero_up() {
    let text = with_camera("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 0, 0]\nvfov = 45\n");
    expect(&text, "4:6", &["key `up` must be a non-zero vector"]);
}

// ---------------------------------------------------------------------------
// Quads.

#[test]
fn degenerate_quad_parallel_edges() {
    let text = with_geometry(
        "[[quad]]\norigin = [0, 0, 0]\nedge_u = [1, 2, 3]\nedge_v = [-2, -4, -6]\nmaterial = \"white\"\n",
    );
    expect(&text, "12:10", &["[[quad]] #1: the quad is degenerate", "give two non-parallel edges"]);
}

#[test]
fn degenerate_quad_zero_edge() {
    let text =
        with_geometry("[[quad]]\norigin = [0, 0, 0]\nedge_u = [0, 0, 0]\nedge_v = [0, 1, 0]\nmaterial = \"white\"\n");
    expect(&text, "11:10", &["key `edge_u` must be a non-zero vector"]);
}

// ---------------------------------------------------------------------------
// The `[guiding]` table (an rlpt extension): `with_render(g)` puts it on line 1.

#[test]
fn guiding_pieces_are_valid() {
    for guiding in [
        "[guiding]\n",
        "[guiding]\nresolution = [8, 8, 8]\n",
        "[guiding]\nbounds_min = [0, 0, 0]\nbounds_max = [1, 1, 1]\n",
        "[guiding]\nbounds_min = [0, 0, 0]\nbounds_max = [1, 1, 1]\nresolution = [64, 64, 64]\n",
        "[guiding]\ngrid = \"uniform\"\n",
        "[guiding]\ngrid = \"adaptive\"\nresolution = [8, 8, 8]\n",
    ] {
        Scene::parse(&with_render(guiding), "good.toml").unwrap();
    }
}

#[test]
fn unknown_key_in_guiding() {
    let text = with_render("[guiding]\nresolution = [8, 8, 8]\ncells = 512\n");
    expect(
        &text,
        "3:1",
        &["[guiding]: unknown key `cells`", "expected one of bounds_min, bounds_max, resolution, grid"],
    );
}

#[test]
fn guiding_grid_kind_is_uniform_or_adaptive() {
    let text = with_render("[guiding]\ngrid = \"octree\"\n");
    expect(&text, "2:8", &["[guiding]: key `grid` must be \"uniform\" or \"adaptive\", found \"octree\""]);
    let text = with_render("[guiding]\ngrid = 2\n");
    expect(&text, "2:8", &["[guiding]: key `grid` must be \"uniform\" or \"adaptive\", found"]);
}

#[test]
fn guiding_written_as_array_of_tables() {
    let text = with_render("[[guiding]]\nresolution = [8, 8, 8]\n");
    expect(&text, "1:1", &["`guiding` must be a single table written [guiding]"]);
}

#[test]
fn guiding_bounds_min_without_bounds_max() {
    let text = with_render("[guiding]\nbounds_min = [0, 0, 0]\n");
    expect(
        &text,
        "2:14",
        &["[guiding]: missing key `bounds_max`", "`bounds_min` is given without it", "give both", "or neither"],
    );
}

#[test]
fn guiding_bounds_max_without_bounds_min() {
    let text = with_render("[guiding]\nresolution = [4, 4, 4]\nbounds_max = [1, 1, 1]\n");
    expect(&text, "3:14", &["[guiding]: missing key `bounds_min`", "`bounds_max` is given without it"]);
}

#[test]
fn guiding_lone_bound_is_checked_first() {
    // A malformed lone bound is reported as malformed, not as lonely.
    let text = with_render("[guiding]\nbounds_min = [0, 0]\n");
    expect(&text, "2:14", &["key `bounds_min` must be an array of 3 numbers", "found an array of 2 values"]);
}

#[test]
fn guiding_bounds_max_equal_to_min_on_an_axis() {
    let text = with_render("[guiding]\nbounds_min = [0, 2, 0]\nbounds_max = [1, 2.0, 1]\n");
    expect(
        &text,
        "3:18",
        &[
            "[guiding]: key `bounds_max` must be greater than `bounds_min` on every axis",
            "found 2.0 <= 2 on the y axis",
        ],
    );
}

#[test]
fn guiding_bounds_max_below_min_on_an_axis() {
    let text = with_render("[guiding]\nbounds_min = [0, 0, 5]\nbounds_max = [1, 1, -1]\n");
    expect(&text, "3:21", &["must be greater than `bounds_min` on every axis", "found -1 <= 5 on the z axis"]);
    // The x axis is reported first when several are wrong.
    let text = with_render("[guiding]\nbounds_max = [0, 0, 0]\nbounds_min = [1, 1, 1]\n");
    expect(&text, "2:15", &["found 0 <= 1 on the x axis"]);
}

#[test]
fn guiding_bounds_equal_in_f32() {
    // Different in f64, the same 32-bit float: the grid would have no extent.
    let text = with_render("[guiding]\nbounds_min = [0, 0, 1]\nbounds_max = [1, 1, 1.00000001]\n");
    expect(
        &text,
        "3:21",
        &[
            "must be greater than `bounds_min` on every axis",
            "found 1.00000001 <= 1 (equal as 32-bit floats) on the z axis",
        ],
    );
}

#[test]
fn guiding_box_beyond_the_scene_scale() {
    let text = with_render("[guiding]\nbounds_min = [-3e38, 0, 0]\nbounds_max = [3e38, 1, 1]\n");
    expect(&text, "2:15", &["[guiding]: key `bounds_min` must have every component within +-1e12", "found -3e38"]);
}

#[test]
fn guiding_non_finite_bound() {
    let text = with_render("[guiding]\nbounds_min = [0, nan, 0]\nbounds_max = [1, 1, 1]\n");
    expect(&text, "2:18", &["[guiding]: key `bounds_min` component 2 must be a finite number", "found nan"]);
    let text = with_render("[guiding]\nbounds_min = [0, 0, 0]\nbounds_max = [1, 1, +inf]\n");
    expect(&text, "3:21", &["key `bounds_max` component 3 must be a finite number", "found +inf"]);
    let text = with_render("[guiding]\nbounds_min = [-1e39, 0, 0]\nbounds_max = [1, 1, 1]\n");
    expect(&text, "2:15", &["key `bounds_min` component 1", "32-bit float", "found -1e39"]);
}

#[test]
fn guiding_bound_of_wrong_type() {
    let text = with_render("[guiding]\nbounds_min = \"origin\"\nbounds_max = [1, 1, 1]\n");
    expect(&text, "2:14", &["key `bounds_min` must be an array of 3 numbers", "found string \"origin\""]);
}

#[test]
fn guiding_resolution_of_two() {
    let text = with_render("[guiding]\nresolution = [8, 8]\n");
    expect(
        &text,
        "2:14",
        &["[guiding]: key `resolution` must be an array of 3 integers [nx, ny, nz]", "found an array of 2 values"],
    );
}

#[test]
fn guiding_resolution_of_four() {
    let text = with_render("[guiding]\nresolution = [8, 8, 8, 8]\n");
    expect(&text, "2:14", &["key `resolution` must be an array of 3 integers", "found an array of 4 values"]);
}

#[test]
fn guiding_resolution_scalar() {
    let text = with_render("[guiding]\nresolution = 16\n");
    expect(&text, "2:14", &["key `resolution` must be an array of 3 integers", "found integer 16"]);
}

#[test]
fn guiding_resolution_zero() {
    let text = with_render("[guiding]\nresolution = [8, 0, 8]\n");
    expect(&text, "2:18", &["[guiding]: key `resolution` component 2 must be an integer from 1 to 256", "found 0"]);
}

#[test]
fn guiding_resolution_negative() {
    let text = with_render("[guiding]\nresolution = [-4, 8, 8]\n");
    expect(&text, "2:15", &["key `resolution` component 1 must be an integer from 1 to 256", "found -4"]);
}

#[test]
fn guiding_resolution_257() {
    let text = with_render("[guiding]\nresolution = [257, 1, 1]\n");
    expect(&text, "2:15", &["key `resolution` component 1 must be an integer from 1 to 256", "found 257"]);
}

#[test]
fn guiding_resolution_float() {
    let text = with_render("[guiding]\nresolution = [16, 16, 16.0]\n");
    expect(&text, "2:23", &["key `resolution` component 3 must be an integer from 1 to 256", "found float 16.0"]);
}

#[test]
fn guiding_resolution_string() {
    let text = with_render("[guiding]\nresolution = [16, \"16\", 16]\n");
    expect(&text, "2:19", &["key `resolution` component 2 must be an integer", "found string \"16\""]);
}

#[test]
fn guiding_resolution_product_too_large() {
    let text = with_render("[guiding]\nresolution = [64, 64, 65]\n");
    expect(
        &text,
        "2:14",
        &["[guiding]: key `resolution` must have at most 262144 cells in all", "found 64 x 64 x 65 = 266240"],
    );
    let text = with_render("[guiding]\nresolution = [256, 256, 256]\n");
    expect(&text, "2:14", &["at most 262144 cells", "found 256 x 256 x 256 = 16777216"]);
}
