//! The library's layers (docs/ARCHITECTURE.md, "Modules"): a module imports only
//! from the layers below its own, never from its own layer's other modules nor from
//! above. Checked by reading every `crate::` path of `src/**/*.rs`.

use std::path::{Path, PathBuf};

/// The library's top-level modules, lowest layer first; modules of one layer
/// import nothing of each other. A new module goes where its imports put it.
const LAYERS: &[&[&str]] = &[
    &["shared", "gpu", "image", "output", "stats"],
    &["layout", "plot"],
    &["scene", "parts"],
    &["math"],
    &["film", "metrics"],
    &["camera"],
    &["guide"],
    &["options"],
    &["prepared"],
    &["renderer"],
    &["cpu", "render"],
    &["session", "bench"],
    &["viewer"],
];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

/// A path that names a module of the crate's root: the importing module, the line
/// (1-based) and the module named.
#[derive(Debug, PartialEq)]
struct RootPath {
    line: usize,
    target: String,
}

/// The source with comments and the insides of string literals blanked out (line
/// breaks kept, so lines still count).
fn strip_comments(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let (mut i, mut in_str) = (0, false);
    while i < b.len() {
        if in_str {
            let blank = |c: u8| if c == b'\n' { c } else { b' ' };
            if b[i] == b'\\' && i + 1 < b.len() {
                out.extend([blank(b[i]), blank(b[i + 1])]);
                i += 2;
                continue;
            }
            in_str = b[i] != b'"';
            out.push(if in_str { blank(b[i]) } else { b[i] });
            i += 1;
        } else if b[i] == b'\'' && (b.get(i + 2) == Some(&b'\'') || b.get(i + 1) == Some(&b'\\')) {
            // A character literal ('"', '\n'); a lifetime has no closing quote.
            let end = (i + 2..b.len()).find(|&j| b[j] == b'\'').expect("a closed character literal");
            out.extend_from_slice(&b[i..=end]);
            i = end + 1;
        } else if b[i] == b'"' {
            in_str = true;
            out.push(b'"');
            i += 1;
        } else if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let mut depth = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if b[i] == b'\n' {
                        out.push(b'\n');
                    }
                    i += 1;
                }
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).expect("comments end on character boundaries")
}

fn ident_at(s: &[u8], i: usize) -> &str {
    let end = (i..s.len()).find(|&j| !(s[j].is_ascii_alphanumeric() || s[j] == b'_')).unwrap_or(s.len());
    std::str::from_utf8(&s[i..end]).expect("ASCII identifier")
}

/// Every module of the crate's root that `src` names by a `crate::` path, a
/// `use crate::{a::X, b::Y}` group counting once per item, and by a `super::`
/// chain that climbs out of `module_path` (the file's modules, from the root).
fn root_paths(src: &str, module_path: &[String]) -> Vec<RootPath> {
    let code = strip_comments(src);
    let s = code.as_bytes();
    let line_of = |i: usize| 1 + s[..i].iter().filter(|&&c| c == b'\n').count();
    let is_ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_' || c == b'$';
    let mut found = Vec::new();
    // Brace depth, and the depths at which inline modules (`mod tests {`) opened.
    let (mut depth, mut inline) = (0, Vec::new());
    let mut i = 0;
    while i < s.len() {
        let start_of_word = i == 0 || !is_ident(s[i - 1]) && s[i - 1] != b':';
        let mut after = None;
        match s[i] {
            b'{' => depth += 1,
            b'}' => {
                depth -= 1;
                if inline.last() == Some(&depth) {
                    inline.pop();
                }
            }
            _ => {}
        }
        if start_of_word && s[i..].starts_with(b"mod ") {
            let name = ident_at(s, i + 4);
            let rest = &code[i + 4 + name.len()..];
            if rest.trim_start().starts_with('{') {
                inline.push(depth);
            }
        } else if start_of_word && s[i..].starts_with(b"crate::") {
            after = Some(i + "crate::".len());
        } else if start_of_word && s[i..].starts_with(b"super::") {
            let (mut j, mut ups) = (i, 0);
            while s[j..].starts_with(b"super::") {
                j += "super::".len();
                ups += 1;
            }
            if ups < module_path.len() + inline.len() {
                i = j;
                continue;
            }
            after = Some(j);
        }
        let Some(j) = after else {
            i += 1;
            continue;
        };
        if s[j] == b'{' {
            // One item per comma at the group's first depth.
            let (mut k, mut depth, mut item_start) = (j + 1, 1, true);
            while k < s.len() && depth > 0 {
                match s[k] {
                    b'{' => depth += 1,
                    b'}' => depth -= 1,
                    b',' if depth == 1 => item_start = true,
                    c if item_start && is_ident(c) => {
                        item_start = false;
                        let target = ident_at(s, k);
                        if target != "self" {
                            found.push(RootPath { line: line_of(k), target: target.to_string() });
                        }
                        k += target.len();
                        continue;
                    }
                    _ => {}
                }
                k += 1;
            }
            i = k;
        } else {
            let target = ident_at(s, j);
            found.push(RootPath { line: line_of(j), target: target.to_string() });
            i = j + target.len().max(1);
        }
    }
    found
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ readable") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The modules a file under `src/` belongs to, from the root: `math/bvh.rs` is
/// `[math, bvh]`, `guide/mod.rs` `[guide]`.
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let file = parts.pop().expect("a file name");
    if file != "mod.rs" {
        parts.push(file.trim_end_matches(".rs").to_string());
    }
    parts
}

/// Every import in `src/` (the library: `main.rs` and `cli/` are the binary on
/// top) that names a module of its own layer or above, as "file:line: ...".
fn upward_imports(src_dir: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(src_dir, &mut files);
    files.sort();
    let mut problems = Vec::new();
    for file in files {
        let rel = file.strip_prefix(src_dir).expect("under src/");
        let modules = module_path(rel);
        let module = modules[0].as_str();
        if ["lib", "main", "cli"].contains(&module) {
            continue;
        }
        let shown = Path::new("src").join(rel).display().to_string();
        let Some(own) = layer(module) else {
            problems.push(format!("{shown}: module `{module}` has no layer in tests/source_layers.rs `LAYERS`"));
            continue;
        };
        let src = std::fs::read_to_string(&file).expect("source readable");
        for p in root_paths(&src, &modules) {
            if p.target == module {
                continue;
            }
            match layer(&p.target) {
                Some(l) if l < own => {}
                Some(l) => problems.push(format!(
                    "{shown}:{}: `{module}` (layer {own}) imports `{}` (layer {l}), which is not below it",
                    p.line, p.target
                )),
                None => problems.push(format!(
                    "{shown}:{}: `crate::{}` is not a module of tests/source_layers.rs `LAYERS`",
                    p.line, p.target
                )),
            }
        }
    }
    problems
}

#[test]
fn no_module_imports_from_its_own_layer_or_above() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let problems = upward_imports(&src);
    assert!(problems.is_empty(), "imports against the layers (docs/ARCHITECTURE.md):\n{}", problems.join("\n"));
}

#[test]
fn every_library_module_has_a_layer() {
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs")).unwrap();
    for line in lib.lines() {
        if let Some(name) = line.strip_prefix("pub mod ") {
            let name = name.trim_end_matches(';').trim_end_matches(" {").trim();
            assert!(layer(name).is_some(), "src/lib.rs: module `{name}` has no layer in `LAYERS`");
        }
    }
}

/// The reader finds what the check needs: paths in groups over several lines,
/// nested groups, inline paths, `super::` chains out of the module; and none in
/// comments or strings.
#[test]
fn the_reader_finds_every_root_path() {
    let path = |m: &[&str]| m.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let src = "use crate::{layout::A,\n    camera::{B, C}, self};\n// crate::viewer::X\n\
               /* crate::session */ let x = crate::guide::f(\"crate::cpu\", '\"');\nuse super::super::render::Y;\n";
    let got = root_paths(src, &path(&["math", "sampler"]));
    let want = [(1, "layout"), (2, "camera"), (4, "guide"), (5, "render")];
    let want: Vec<_> = want.iter().map(|&(line, t)| RootPath { line, target: t.to_string() }).collect();
    assert_eq!(got, want);
    // One `super` from `math/sampler.rs` stays in `math`, two from its tests too.
    assert!(root_paths("use super::rng::Rng;", &path(&["math", "sampler"])).is_empty());
    let tests = "fn f() {}\nmod tests {\n    use super::{super::rng::Rng, *};\n}\nuse super::super::film::F;";
    let got = root_paths(tests, &path(&["math", "sampler"]));
    assert_eq!(got, [RootPath { line: 5, target: "film".to_string() }]);
}

/// An upward import is reported with its file and line: a copy of `src/` with
/// one added to `math` fails the check, naming it.
#[test]
fn an_upward_import_is_reported() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("rlpt-layers");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("math")).unwrap();
    std::fs::create_dir_all(dir.join("camera")).unwrap();
    std::fs::write(dir.join("math/mod.rs"), "use crate::layout::X;\n\nuse crate::{scene::S,\n  session::Session};\n")
        .unwrap();
    std::fs::write(dir.join("camera/mod.rs"), "use crate::math::Vec3;\n").unwrap();
    std::fs::write(dir.join("nowhere.rs"), "").unwrap();
    let problems = upward_imports(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(problems.len(), 2, "{problems:#?}");
    assert!(problems[0].starts_with("src/math/mod.rs:4: `math` (layer 3) imports `session`"), "{}", problems[0]);
    assert!(problems[1].contains("src/nowhere.rs: module `nowhere` has no layer"), "{}", problems[1]);
}
