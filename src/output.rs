//! Checks on a file a command will write, made before any work is done: a render
//! that fails only when it saves its result has wasted the render.

use std::path::Path;

/// Refuses an output path whose name does not end in one of `extensions` (where
/// given, compared without case), whose directory does not exist, or which is a
/// directory itself. The message names `flag` (the option that gave the path, or
/// "output") and the path. The CLI checks its outputs with it, and `rlpt view`
/// its `--screenshot`.
pub fn check_output_path(flag: &str, path: &Path, extensions: Option<&[&str]>) -> Result<(), String> {
    if let Some(exts) = extensions {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if !ext.as_deref().is_some_and(|e| exts.contains(&e)) {
            let list = exts.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(" or ");
            return Err(format!("{flag} {}: the file name must end in {list}", path.display()));
        }
    }
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !parent.is_dir() {
            return Err(format!("{flag} {}: directory {} does not exist", path.display(), parent.display()));
        }
    }
    if path.is_dir() {
        return Err(format!("{flag} {}: is a directory; give a file name", path.display()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_are_refused_by_name_before_any_work() {
        let dir = std::env::temp_dir();
        let ok = dir.join("rlpt-output-check.PNG");
        assert_eq!(check_output_path("-o", &ok, Some(&["png", "exr"])), Ok(()));
        assert_eq!(check_output_path("--stats", &dir.join("s"), None), Ok(()));
        let e = check_output_path("-o", &dir.join("x.jpg"), Some(&["png", "exr"])).unwrap_err();
        assert!(e.starts_with("-o ") && e.ends_with("the file name must end in .png or .exr"), "{e}");
        let e = check_output_path("--json", &dir.join("no-such-dir-rlpt/x.json"), None).unwrap_err();
        assert!(e.contains("directory") && e.ends_with("does not exist"), "{e}");
        let e = check_output_path("--trace", &dir, None).unwrap_err();
        assert!(e.ends_with("is a directory; give a file name"), "{e}");
    }
}
