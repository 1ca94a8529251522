//! pbrt files rlpt refuses: each refusal names the file, line and column and
//! what was expected (or, for a missing file, its path as written and as
//! resolved), and nothing is rendered.

mod common;
mod pbrt_support;

use common::cli::fresh_dir;
use common::files::write;
use pbrt_support::{refuse, TRIANGLE};
use rlpt::scene::Scene;

#[test]
fn syntax_errors_name_line_and_column() {
    let e = refuse("unterminated", "WorldBegin\n  Shape \"sphere\n", false);
    assert_eq!(e, "DIR/scene.pbrt:2:9: unterminated string: expected a closing `\"` on the same line");
    let e = refuse("number", "WorldBegin\nTranslate 1 2x 3\n", false);
    assert_eq!(e, "DIR/scene.pbrt:2:13: expected a finite number, found `2x`");
    let e = refuse("bracket", "WorldBegin\nShape \"sphere\" \"float radius\" [ 1\n", false);
    assert_eq!(
        e,
        "DIR/scene.pbrt:2:31: expected `]` to close the values of parameter \"float radius\", found the end of the file"
    );
    let e = refuse("count", "LookAt 0 0 0  0 0 1  0 1\nWorldBegin\n", false);
    assert_eq!(e, "DIR/scene.pbrt:2:1: LookAt takes 9 numbers; expected number 9 of them, found `WorldBegin`");
    let e = refuse("eof", "WorldBegin\nTranslate 1 2", false);
    assert_eq!(e, "DIR/scene.pbrt:2:1: Translate takes 3 numbers; found the end of the file after 2");
    let e = refuse("paramtype", "WorldBegin\nShape \"sphere\" \"float radius\" \"big\"\n", false);
    assert_eq!(e, "DIR/scene.pbrt:2:31: parameter \"float radius\" must hold numbers only");
    let e = refuse("decl", "WorldBegin\nShape \"sphere\" \"radius\" 1\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:2:16: expected a parameter declaration \"type name\""), "{e}");
}

#[test]
fn unknown_directives_shapes_lights_and_materials_are_refused() {
    let e = refuse("directive", "WorldBegin\n\nShap \"sphere\"\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:3:1: unknown directive `Shap`;"), "{e}");
    let e = refuse("shape", "WorldBegin\n  Shape \"teapot\"\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:2:3: unknown shape \"teapot\"; rlpt reads plymesh"), "{e}");
    let e = refuse("light", "WorldBegin\nLightSource \"laser\"\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:2:1: unknown light \"laser\""), "{e}");
    let e = refuse("material", "WorldBegin\nMaterial \"velvet\"\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:2:1: unknown material type \"velvet\""), "{e}");
    let e = refuse("named", "WorldBegin\nNamedMaterial \"gold\"\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:2:1: NamedMaterial \"gold\": no material of that name"), "{e}");
    let e = refuse("spectrum", "WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"metal-Xx-eta\"\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:2:22: parameter \"spectrum eta\" names spectrum \"metal-Xx-eta\""), "{e}");
}

#[test]
fn structure_errors() {
    let e = refuse("end", "WorldBegin\nAttributeEnd\n", false);
    assert_eq!(e, "DIR/scene.pbrt:2:1: AttributeEnd without a matching Begin");
    let e = refuse("mismatch", "WorldBegin\nAttributeBegin\nTransformEnd\n", false);
    assert_eq!(e, "DIR/scene.pbrt:3:1: TransformEnd closes the AttributeBegin of line 2");
    let e = refuse("early", "Shape \"sphere\"\nWorldBegin\n", false);
    assert_eq!(e, "DIR/scene.pbrt:1:1: Shape is allowed only after WorldBegin");
    let e = refuse("noworld", "Camera \"perspective\"\n", false);
    assert_eq!(e, "DIR/scene.pbrt: no WorldBegin: the file describes no world to render");
    let e = refuse(
        "index",
        "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 3]\n",
        false,
    );
    assert!(
        e.starts_with("DIR/scene.pbrt:2:76: Shape \"trianglemesh\": index 3 (number 3 of \"indices\") is out of range"),
        "{e}"
    );
    let e = refuse("lookat", "LookAt 0 0 0  0 1 0  0 1 0\nWorldBegin\n", false);
    assert!(e.starts_with("DIR/scene.pbrt:1:1: LookAt: "), "{e}");
    let e = refuse("empty", "WorldBegin\n", false);
    assert!(e.contains("no shape rlpt renders"), "{e}");
}

#[test]
fn missing_files_are_named_as_written_and_as_resolved() {
    let e = refuse("ply", "WorldBegin\n Shape \"plymesh\" \"string filename\" \"geo/missing.ply\"\n", false);
    assert_eq!(
        e,
        "DIR/scene.pbrt:2:2: Shape \"plymesh\": the file \"geo/missing.ply\" does not exist (resolved to DIR/geo/missing.ply)"
    );
    let e = refuse("include", "WorldBegin\nInclude \"parts/geo.pbrt\"\n", false);
    assert!(
        e.starts_with(
            "DIR/scene.pbrt:2:1: cannot read the included file parts/geo.pbrt (resolved to DIR/parts/geo.pbrt):"
        ),
        "{e}"
    );
    // An error inside an included file names that file.
    let d = fresh_dir("inner");
    write(&d, "geo.pbrt", "\n\nShape \"cube\"\n");
    let p = write(&d, "scene.pbrt", format!("WorldBegin\n{TRIANGLE}Include \"geo.pbrt\"\n"));
    let e = Scene::load(&p).unwrap_err().to_string().replace(&d.display().to_string(), "DIR");
    assert!(e.starts_with("DIR/geo.pbrt:3:1: unknown shape \"cube\""), "{e}");
    // A PLY that does not read: the shape's place and the PLY's own error.
    let d = fresh_dir("badply");
    write(&d, "bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\nnot-a-number\n");
    let p = write(&d, "scene.pbrt", "WorldBegin\nShape \"plymesh\" \"string filename\" \"bad.ply\"\n");
    let e = Scene::load(&p).unwrap_err().to_string().replace(&d.display().to_string(), "DIR");
    assert!(e.starts_with("DIR/scene.pbrt:2:1: Shape \"plymesh\": DIR/bad.ply"), "{e}");
}

#[test]
fn cli_info_prints_the_mapping_and_strict_refuses() {
    let d = fresh_dir("cli");
    let p = write(&d, "scene.pbrt", format!("WorldBegin\nMakeNamedMaterial \"paint\" \"string type\" \"coatedconductor\"\nNamedMaterial \"paint\"\n{TRIANGLE}"));
    let run = |strict: bool| {
        let mut c = common::cli::rlpt();
        c.arg("info").arg(&p);
        if strict {
            c.arg("--strict");
        }
        let out = c.output().unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (ok, stdout, stderr) = run(false);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("mapped paint: coatedconductor -> coated (coat eta 1.5, alpha 0 -> a smooth coat"),
        "{stdout}"
    );
    let smooth_base = "material \"paint\": a smooth conductor under the coat (alpha 0)";
    assert!(stdout.contains("note: ") && stdout.contains(&format!("scene.pbrt:2: {smooth_base}")), "{stdout}");
    let (ok, _, stderr) = run(true);
    assert!(!ok && stderr.contains(&format!("scene.pbrt:2:1: {smooth_base}")), "{stderr}");
    assert!(stderr.contains("--strict"), "{stderr}");
}

#[test]
fn cli_render_prints_the_notes_and_strict_renders_nothing() {
    let d = fresh_dir("cli-render");
    let p = write(
        &d,
        "scene.pbrt",
        format!("WorldBegin\nLightSource \"infinite\"\nLightSource \"goniometric\"\n{TRIANGLE}"),
    );
    let out = d.join("out.png");
    let run = |strict: bool| {
        let mut c = common::cli::rlpt();
        c.arg("render")
            .arg(&p)
            .args(["--width", "8", "--height", "8", "--spp", "64", "--device", "cpu", "-o"])
            .arg(&out);
        if strict {
            c.arg("--strict");
        }
        let o = c.output().unwrap();
        (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (ok, stderr) = run(false);
    assert!(
        ok && stderr.contains("note: ") && stderr.contains("scene.pbrt:3: LightSource \"goniometric\" dropped"),
        "{stderr}"
    );
    assert!(out.is_file());
    std::fs::remove_file(&out).unwrap();
    let (ok, stderr) = run(true);
    assert!(!ok && stderr.contains("scene.pbrt:3:1: LightSource \"goniometric\" dropped"), "{stderr}");
    assert!(!out.exists(), "nothing rendered under --strict");
}
