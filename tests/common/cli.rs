//! Running the `rlpt` binary as a user does, for the command-line tests
//! (`tests/cli_*.rs`).

use std::process::{Command, Output};

/// `rlpt` with the Khronos validation layer on (synchronization validation included)
/// for every GPU it touches; run it with [`Checked::checked_output`].
pub fn rlpt() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rlpt"));
    c.current_dir(env!("CARGO_MANIFEST_DIR")).env("RLPT_VALIDATION", "1");
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        c.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    c
}

/// How every test here runs `rlpt`: the run fails the test if the validation layer
/// said anything, whatever the exit status the test expects.
pub trait Checked {
    fn checked_output(&mut self) -> Output;
}

impl Checked for Command {
    fn checked_output(&mut self) -> Output {
        let o = self.output().expect("rlpt runs");
        assert_no_validation_messages(&String::from_utf8_lossy(&o.stderr));
        assert_no_validation_messages(&String::from_utf8_lossy(&o.stdout));
        o
    }
}

/// rlpt prints each message the layer sends it as "vulkan validation (...)", and ends
/// with "the Vulkan validation layer reported N problem(s)" and a failure status when
/// any was counted, those at a context's destruction included; where no messenger of
/// rlpt's is registered the layer prints its own "Validation Error" / "Validation Warning".
pub fn assert_no_validation_messages(output: &str) {
    for sign in ["vulkan validation", "validation layer reported", "Validation Error", "Validation Warning"] {
        assert!(!output.contains(sign), "the validation layer spoke:\n{output}");
    }
}

/// This test binary's own directory of files, under Cargo's `target/tmp`: emptied
/// at its first use in each run, so runs neither accumulate files nor see old ones.
fn own_dir() -> &'static std::path::Path {
    static DIR: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(env!("CARGO_CRATE_NAME"));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

/// A file `name` in this test binary's own directory of files.
pub fn tmp(name: &str) -> std::path::PathBuf {
    own_dir().join(name)
}

/// A fresh, empty directory `name` for one test's files.
pub fn fresh_dir(name: &str) -> std::path::PathBuf {
    let dir = own_dir().join(format!("dir-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `rlpt ARGS` and returns (success, stderr).
pub fn run(args: &[&str]) -> (bool, String) {
    let o = rlpt().args(args).checked_output();
    (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
}
