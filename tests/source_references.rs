//! Twins name each other: a comment that says where an item lives ("src/guide/
//! sampler.rs `lobe_share`", "`glsl/bvh.glsl` `bvh_walk`", "learn.comp
//! `fold`") must name a file that exists and defines that item. Checked over the
//! comments of `src/`, `glsl/` and `tests/`.

use std::path::{Path, PathBuf};

/// A reference found in a comment: where, the file it names and the item.
#[derive(Debug, PartialEq)]
struct Reference {
    line: usize,
    path: String,
    name: String,
}

fn is_path_char(c: u8) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, b'_' | b'/' | b'.' | b'-')
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// The comments of a source file, line by line (1-based): the length of the
/// line's own comment, and that comment followed by the next line's where it goes
/// on there, so that a reference wrapped across two lines is still one.
fn comments(src: &str) -> Vec<(usize, usize, String)> {
    let text: Vec<Option<&str>> =
        src.lines().map(|l| l.find("//").map(|i| l[i..].trim_start_matches(['/', '!']).trim())).collect();
    let mut out = Vec::new();
    for (i, c) in text.iter().enumerate() {
        if let Some(c) = c {
            let next = text.get(i + 1).copied().flatten().unwrap_or("");
            out.push((i + 1, c.len(), format!("{c} {next}")));
        }
    }
    out
}

/// The references that start in the first `own` bytes of a comment: a file path
/// (`src/`, `glsl/` or `tests/`, or a bare `NAME.glsl` / `NAME.comp` of `glsl/`),
/// maybe in backquotes, then the item in backquotes, maybe in parentheses.
fn references_in(line: usize, own: usize, text: &str) -> Vec<Reference> {
    let s = text.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < own {
        if !is_path_char(s[i]) || (i > 0 && is_path_char(s[i - 1])) {
            i += 1;
            continue;
        }
        let end = (i..s.len()).find(|&j| !is_path_char(s[j])).unwrap_or(s.len());
        let word = text[i..end].trim_end_matches('.');
        i = end;
        let bare_glsl = !word.contains('/') && (word.ends_with(".glsl") || word.ends_with(".comp"));
        let rooted = ["src/", "glsl/", "tests/"].iter().any(|r| word.starts_with(r))
            && [".rs", ".glsl", ".comp"].iter().any(|e| word.ends_with(e));
        if !(bare_glsl || rooted) {
            continue;
        }
        let mut rest = text[i..].trim_start_matches('`');
        rest = rest.strip_prefix("'s").unwrap_or(rest);
        rest = rest.trim_start_matches([',', ':']).trim_start();
        rest = rest.strip_prefix('(').unwrap_or(rest);
        let Some(quoted) = rest.strip_prefix('`') else { continue };
        let Some(close) = quoted.find('`') else { continue };
        let name = quoted[..close].trim_end_matches("()");
        let well_formed = name.bytes().next().is_some_and(|c| c.is_ascii_alphabetic() || c == b'_')
            && name.bytes().all(|c| is_ident(c) || c == b':');
        if well_formed && !name.starts_with("crate::") {
            let path = if bare_glsl { format!("glsl/{word}") } else { word.to_string() };
            found.push(Reference { line, path, name: name.to_string() });
        }
    }
    found
}

/// Whether `word` stands in `line` as a whole word at byte `at`.
fn word_at(line: &str, at: usize, word: &str) -> bool {
    let b = line.as_bytes();
    line[at..].starts_with(word)
        && (at == 0 || !is_ident(b[at - 1]))
        && b.get(at + word.len()).is_none_or(|&c| !is_ident(c))
}

fn word_positions<'a>(line: &'a str, word: &'a str) -> impl Iterator<Item = usize> + 'a {
    line.match_indices(word).map(|(at, _)| at).filter(move |&at| word_at(line, at, word))
}

/// Whether a Rust file defines `name`: an item (`fn`, `struct`, `const`...), a
/// field or an enum variant.
fn rust_defines(src: &str, name: &str) -> bool {
    const ITEMS: [&str; 9] = ["fn", "struct", "enum", "trait", "const", "static", "type", "mod", "macro_rules!"];
    src.lines().any(|l| {
        let code = l.split("//").next().unwrap_or("");
        let before = |at: usize| code[..at].trim_end();
        if word_positions(code, name).any(|at| ITEMS.iter().any(|k| before(at).ends_with(k))) {
            return true;
        }
        let t = code.trim_start();
        let t = t.strip_prefix("pub(crate) ").or_else(|| t.strip_prefix("pub ")).unwrap_or(t);
        t.starts_with(name) && {
            let after = t[name.len()..].trim_start();
            word_at(t, 0, name)
                && (after.starts_with(':') && !after.starts_with("::") || after.starts_with([',', '(', '{']))
        }
    })
}

/// Whether a GLSL file defines `name`: a function, variable, constant, field,
/// struct, block or macro (a name after a type word, followed by `(`, `;`, `=`,
/// `[` or `,`).
fn glsl_defines(src: &str, name: &str) -> bool {
    src.lines().any(|l| {
        let code = l.split("//").next().unwrap_or("");
        word_positions(code, name).any(|at| {
            let before = code[..at].trim_end();
            let after = code[at + name.len()..].trim_start();
            let word_before = before.rsplit(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ']')).next();
            ["#define", "struct", "uniform", "buffer"].iter().any(|k| before.ends_with(k))
                || (word_before.is_some_and(|w| !w.is_empty() && !["return", "else", "case"].contains(&w))
                    && after.starts_with(['(', ';', '=', '[', ',']))
        })
    })
}

/// Whether the file `path` (under `root`) defines `name`; for `Type::item`, the
/// item, and the type stands in the file (its impl).
fn defines(root: &Path, path: &str, name: &str) -> Result<(), String> {
    let src = std::fs::read_to_string(root.join(path)).map_err(|_| format!("{path} does not exist"))?;
    let (outer, item) = name.rsplit_once("::").map_or((None, name), |(o, i)| (Some(o), i));
    let item_defined = if path.ends_with(".rs") { rust_defines(&src, item) } else { glsl_defines(&src, item) };
    let outer_named =
        outer.is_none_or(|o| o.split("::").all(|w| src.lines().any(|l| word_positions(l, w).next().is_some())));
    if item_defined && outer_named {
        Ok(())
    } else {
        Err(format!("{path} does not define `{name}`"))
    }
}

fn source_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("directory readable") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            source_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs" || e == "glsl" || e == "comp") {
            out.push(path);
        }
    }
}

/// Every reference in the comments under `root`'s `dirs` that names a missing
/// file or an item its file does not define, as "file:line: ...".
fn stale_references(root: &Path, dirs: &[&str]) -> Vec<String> {
    let mut files = Vec::new();
    for d in dirs {
        source_files(&root.join(d), &mut files);
    }
    files.sort();
    let mut problems = Vec::new();
    for file in files {
        // This file's fixtures are string literals that hold such comments.
        if file.ends_with("tests/source_references.rs") {
            continue;
        }
        let src = std::fs::read_to_string(&file).expect("source readable");
        let shown = file.strip_prefix(root).expect("under the root").display().to_string();
        for (line, own, text) in comments(&src) {
            for r in references_in(line, own, &text) {
                if let Err(e) = defines(root, &r.path, &r.name) {
                    problems.push(format!("{shown}:{}: {e}", r.line));
                }
            }
        }
    }
    problems
}

#[test]
fn comments_name_files_that_define_what_they_name() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let problems = stale_references(root, &["src", "glsl", "tests"]);
    assert!(problems.is_empty(), "references to a file that lacks the item:\n{}", problems.join("\n"));
}

/// The reader finds references in their forms, wrapped lines included, and none
/// that are not (a path without an item, a `crate::` path).
#[test]
fn the_reader_finds_references_in_their_forms() {
    let src = "// src/guide/sampler.rs `lobe_share`: x\n\
               // twin of `glsl/bvh.glsl` (`bvh_walk`), and of learn.comp `fold()`, and\n\
               // src/math/bvh.rs's\n\
               // `Bvh::depth`; docs/x.md `no` src/cpu/mod.rs alone; common.glsl (`crate::shared`)\n\
               let x = 1; // glsl/rng.glsl `rng_next`\n";
    let refs: Vec<_> =
        comments(src).into_iter().flat_map(|(line, own, text)| references_in(line, own, &text)).collect();
    let got: Vec<_> = refs.iter().map(|r| (r.line, r.path.as_str(), r.name.as_str())).collect();
    assert_eq!(
        got,
        [
            (1, "src/guide/sampler.rs", "lobe_share"),
            (2, "glsl/bvh.glsl", "bvh_walk"),
            (2, "glsl/learn.comp", "fold"),
            (3, "src/math/bvh.rs", "Bvh::depth"),
            (5, "glsl/rng.glsl", "rng_next"),
        ]
    );
}

/// A stale reference is reported with its file and line: a missing file, an item
/// the file does not define (though it mentions it), a method of another type.
#[test]
fn a_stale_reference_is_reported() {
    let root = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("rlpt-references");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("src")).unwrap();
    std::fs::create_dir_all(root.join("glsl")).unwrap();
    std::fs::write(
        root.join("src/a.rs"),
        "/// Mentions `helper` (glsl/b.glsl `shade`).\npub struct A {\n    pub field: u32,\n}\nimpl A {\n    \
         pub fn go(&self) {}\n}\nenum E {\n    One,\n}\n",
    )
    .unwrap();
    std::fs::write(
        root.join("glsl/b.glsl"),
        "// src/a.rs `A::go`, src/a.rs `field`, src/a.rs `One`, src/a.rs `helper`,\n\
         // src/gone.rs `x`, src/a.rs `B::go`\nfloat shade(vec3 n) { return helper(n); }\n",
    )
    .unwrap();
    let problems = stale_references(&root, &["src", "glsl"]);
    std::fs::remove_dir_all(&root).unwrap();
    assert_eq!(
        problems,
        [
            "glsl/b.glsl:1: src/a.rs does not define `helper`",
            "glsl/b.glsl:2: src/gone.rs does not exist",
            "glsl/b.glsl:2: src/a.rs does not define `B::go`",
        ]
    );
}
