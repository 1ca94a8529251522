//! docs/cluster.md's Slurm scripts, run as written on a one-node Slurm cluster
//! that the test starts and stops (`scripts/cluster/one-node-slurm.sh`).

mod common;

use common::cli::rlpt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The scripts docs/cluster.md shows are those in scripts/cluster, word for word.
#[test]
fn the_docs_show_the_scripts() {
    let doc = std::fs::read_to_string(Path::new(ROOT).join("docs/cluster.md")).unwrap();
    for script in ["submit.sh", "part.sbatch", "merge.sbatch"] {
        let text = std::fs::read_to_string(Path::new(ROOT).join("scripts/cluster").join(script)).unwrap();
        assert!(doc.contains(&text), "docs/cluster.md does not show scripts/cluster/{script} as it is");
    }
}

/// Stops the cluster however the test ends.
struct Cluster(PathBuf);

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ =
            Command::new(Path::new(ROOT).join("scripts/cluster/one-node-slurm.sh")).arg("stop").arg(&self.0).status();
    }
}

fn ok(o: Output, what: &str) -> String {
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{what} failed:\n{out}\n{err}");
    out.into_owned()
}

/// submit.sh renders 3 parts by a job array and merges them by a dependent job;
/// the merged image agrees with an unsplit render of another seed within noise.
#[test]
#[ignore = "needs root and Debian's slurm-wlm and munge installed (it starts munged, slurmctld and slurmd): \
            run by hand with `cargo test --test cluster -- --ignored`"]
fn a_slurm_job_array_renders_the_parts_and_merges_them() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("rlpt-slurm-test");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let cluster = Cluster(dir.join("slurm"));
    let o = Command::new(Path::new(ROOT).join("scripts/cluster/one-node-slurm.sh"))
        .arg("start")
        .arg(&cluster.0)
        .output()
        .unwrap();
    ok(o, "starting the one-node Slurm");
    let conf = cluster.0.join("slurm.conf");

    let out = dir.join("merged.exr");
    let size = ["--device", "cpu", "--width", "32", "--height", "24"];
    let o = Command::new(Path::new(ROOT).join("scripts/cluster/submit.sh"))
        .current_dir(ROOT)
        .env("SLURM_CONF", &conf)
        .env("RLPT", env!("CARGO_BIN_EXE_rlpt"))
        .args(["scenes/cornell-box.toml", "3", "640"])
        .arg(&out)
        .args(size)
        .output()
        .unwrap();
    println!("{}", ok(o, "submit.sh"));

    // Every job ends: the parts, then the merge.
    let start = Instant::now();
    loop {
        let o = Command::new("squeue").env("SLURM_CONF", &conf).args(["-h", "-o", "%i %j %T"]).output().unwrap();
        let queue = ok(o, "squeue");
        if queue.trim().is_empty() {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(300), "jobs still queued after 300 s:\n{queue}");
        std::thread::sleep(Duration::from_millis(500));
    }
    let parts = dir.join("merged.parts");
    let log = |name: &str| std::fs::read_to_string(parts.join(name)).unwrap_or_else(|e| format!("({name}: {e})"));
    for k in 0..3 {
        println!("part-{k}.log: {}", log(&format!("part-{k}.log")).trim());
    }
    let merge_log = log("merge.log");
    println!("merge.log: {}", merge_log.trim());
    assert!(merge_log.contains("merged 3 part(s) of 3: 32x24, 640 spp"), "the merge job: {merge_log}");

    let (unsplit, variance) = (dir.join("unsplit.exr"), dir.join("unsplit-variance.exr"));
    let o = rlpt()
        .args(["render", "scenes/cornell-box.toml", "--spp", "640", "--seed", "1"])
        .args(size)
        .arg("-o")
        .arg(&unsplit)
        .arg("--variance")
        .arg(&variance)
        .output()
        .unwrap();
    ok(o, "the unsplit render");
    // Two independent renders of 640 spp: each mean within 5 standard deviations.
    let o = rlpt()
        .arg("compare")
        .arg(&out)
        .arg(&unsplit)
        .arg("--reference-variance")
        .arg(&variance)
        .arg("--image-variance")
        .arg(dir.join("merged.variance.exr"))
        .args(["--max-z", "5"])
        .output()
        .unwrap();
    println!("{}", ok(o, "comparing the merged image with the unsplit render"));
}
