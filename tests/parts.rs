//! Split renders (`render --part K/N`, `rlpt merge`): parts are disjoint and
//! complete (merged, they are the unsplit render to rounding), their files carry
//! what merge checks, and merge refuses parts that do not belong together.

mod common;

use common::cli::{rlpt, tmp, Checked};
use common::scene;
use rlpt::cpu::CpuRenderer;
use rlpt::film::Film;
use rlpt::guide::scene_hash;
use rlpt::image::Image;
use rlpt::parts::{merge, settings_hash, Part, PartImage, PartInfo};
use rlpt::prepared::PreparedScene;
use std::path::{Path, PathBuf};

fn prepared(width: u32, height: u32, seed: u32) -> PreparedScene {
    let s = scene("cornell-box.toml");
    let mut o = rlpt::options::RenderOptions::from_scene(&s);
    (o.width, o.height, o.seed) = (width, height, seed);
    PreparedScene::new(&s, &o).expect("valid options")
}

/// `frames` frames on the CPU from random-number frame `offset` on.
fn render(p: &PreparedScene, offset: u32, frames: u32) -> Film {
    let mut r = CpuRenderer::new(p);
    r.set_frame_offset(offset);
    for _ in 0..frames {
        r.render_frame();
    }
    r.film().clone()
}

/// Part `part` of a render of `total` frames, as `render --part` makes it; with
/// `shift` off, every part draws the random numbers of frames 0.. (as parts would
/// without the frame offset).
fn part(p: &PreparedScene, part: Part, total: u32, shift: bool) -> PartImage {
    let range = part.frames(total);
    let film = render(p, if shift { range.start } else { 0 }, range.len() as u32);
    PartImage {
        info: PartInfo {
            part,
            scene_hash: scene_hash(p),
            settings_hash: settings_hash(&p.params),
            seed: p.params.seed,
            total_frames: total,
            first_frame: range.start,
            frames: film.frames,
            spp: film.samples_per_pixel(),
            guiding: "off".into(),
            guide_in: None,
        },
        mean: film.mean(),
        variance: film.variance_of_mean(),
    }
}

fn named(parts: Vec<PartImage>) -> Vec<(PathBuf, PartImage)> {
    parts.into_iter().map(|p| (PathBuf::from(format!("part-{}.exr", p.info.part.index)), p)).collect()
}

/// The largest difference of two images relative to the larger value (at least 1e-3).
fn max_relative_difference(a: &Image, b: &Image) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / p[c].abs().max(q[c].abs()).max(1e-3)))
        .fold(0.0, f32::max)
}

#[test]
fn part_specs_are_checked() {
    assert_eq!(Part::parse("0/1"), Ok(Part { index: 0, count: 1 }));
    assert_eq!(Part::parse("2/3"), Ok(Part { index: 2, count: 3 }));
    for (bad, says) in [
        ("3/3", "numbered 0 to 2"),
        ("7/3", "numbered 0 to 2"),
        ("0/0", "into 0 parts"),
        ("a/3", "not a part"),
        ("1", "not a part"),
        ("1/2/3", "not a part"),
        ("-1/3", "not a part"),
        ("/3", "not a part"),
        ("", "not a part"),
    ] {
        let e = Part::parse(bad).expect_err(bad);
        assert!(e.contains(says) && e.contains(&format!("`{bad}`")), "{bad}: {e}");
    }
}

/// All N parts of a render merged are the unsplit render of the same seed, to
/// float summation order: the parts' frames tile the unsplit render's, each
/// drawing the random numbers it draws there. Without the frame offset every part
/// would draw frame 0's numbers, and the merge would be another image.
#[test]
fn merged_parts_are_the_unsplit_render() {
    let p = prepared(24, 18, 5);
    let total = 7;
    let unsplit = render(&p, 0, total);
    for count in [1, 2, 3] {
        let parts: Vec<PartImage> = (0..count).map(|index| part(&p, Part { index, count }, total, true)).collect();
        let merged = merge(&named(parts), false).expect("the parts belong together");
        assert_eq!(merged.spp, unsplit.samples_per_pixel());
        let d = max_relative_difference(&merged.mean, &unsplit.mean());
        assert!(d < 2e-6, "{count} parts against the unsplit render: relative difference {d}");
    }
    let unshifted: Vec<PartImage> = (0..3).map(|index| part(&p, Part { index, count: 3 }, total, false)).collect();
    let merged = merge(&named(unshifted), false).expect("merge does not see random numbers");
    let d = max_relative_difference(&merged.mean, &unsplit.mean());
    assert!(d > 1e-2, "parts that draw the same numbers merged to the unsplit render: {d}");
}

/// The merged variance of the mean, sum(n_i^2 var_i) / (sum n_i)^2 from each
/// part's own frames, estimates what the unsplit render measures from all its
/// frames: summed over the image they agree within 20%, where a variance summed
/// without the weights would be 16 times off, or weighted by n_i alone 4 times.
/// (Their ratio spreads by some 5 to 10% from seed to seed: a few bright pixels
/// carry most of the variance, each measured from 28 or 31 degrees of freedom.)
#[test]
fn merged_variance_is_the_unsplit_renders() {
    for seed in [9, 10] {
        let p = prepared(16, 16, seed);
        let total = 32;
        let unsplit = render(&p, 0, total).variance_of_mean().expect("32 frames");
        let parts: Vec<PartImage> = (0..4).map(|index| part(&p, Part { index, count: 4 }, total, true)).collect();
        let merged = merge(&named(parts), false).unwrap().variance.expect("every part has a variance");
        let sum = |i: &Image| i.pixels.iter().flatten().map(|&v| v as f64).sum::<f64>();
        let ratio = sum(&merged) / sum(&unsplit);
        assert!((0.8..1.25).contains(&ratio), "seed {seed}: merged / unsplit variance = {ratio}");
    }
}

/// What merge refuses, one sentence each naming the files: parts of another scene,
/// settings, seed, size or split, a part twice, overlapping frames, a part
/// missing (unless --allow-missing, which names it).
#[test]
fn merge_refuses_parts_that_do_not_belong_together() {
    let p = prepared(8, 6, 0);
    let total = 6;
    let good = || named((0..3).map(|index| part(&p, Part { index, count: 3 }, total, true)).collect());
    let refused = |parts: Vec<(PathBuf, PartImage)>| match merge(&parts, false) {
        Ok(_) => panic!("merged parts that do not belong together"),
        Err(e) => e,
    };
    let one = |parts: Vec<(PathBuf, PartImage)>, says: &[&str]| {
        let e = refused(parts);
        assert_eq!(e.len(), 1, "{e:?}");
        for s in says {
            assert!(e[0].contains(s), "`{s}` not in: {}", e[0]);
        }
    };
    assert!(merge(&good(), false).is_ok());

    let mut parts = good();
    parts[1].1.info.scene_hash ^= 1;
    one(parts, &["part-1.exr is a render of another scene than part-0.exr"]);
    let mut parts = good();
    parts[2].1.info.settings_hash ^= 1;
    one(parts, &["part-2.exr was rendered with other settings than part-0.exr"]);
    let mut parts = good();
    parts[2].1.info.seed = 3;
    one(parts, &["part-2.exr has seed 3 but part-0.exr seed 0"]);
    let mut parts = good();
    parts[1].1.mean = Image::new(4, 6);
    one(parts, &["part-1.exr is 4x6 but part-0.exr is 8x6"]);
    let mut parts = good();
    parts[1].1.info.guiding = "sphere".into();
    one(parts, &["part-1.exr was rendered with guiding sphere but part-0.exr with guiding off"]);
    let mut parts = good();
    parts[1].1.info.total_frames = 9;
    one(parts, &["part-1.exr is part 1/3 of a render of 9 frames", "part-0.exr part 0/3 of 6 frames"]);
    let mut parts = good();
    parts[2] = (PathBuf::from("again.exr"), parts[1].1.clone());
    one(parts, &["part-1.exr and again.exr are both part 1/3"]);
    let mut parts = good();
    parts[2].1.info.part = Part { index: 2, count: 3 };
    parts[2].1.info.first_frame = 3;
    one(parts, &["part-1.exr (frames 2..4) and part-2.exr (frames 3..5) overlap"]);

    // Parts that started from different fields are each unbiased: merged, with a note.
    let mut parts = good();
    parts[1].1.info.guide_in = Some(0xfe1d);
    let merged = merge(&parts, false).expect("parts from different fields merge");
    let said = "part-1.exr started from field 000000000000fe1d but part-0.exr learned from nothing";
    assert!(merged.notes.iter().any(|n| n.contains(said)), "{:?}", merged.notes);
    assert!(merge(&good(), false).unwrap().notes.is_empty());

    let mut parts = good();
    parts.remove(1);
    one(parts.clone(), &["part 1 of 3 missing", "--allow-missing"]);
    let merged = merge(&parts, true).expect("--allow-missing merges the parts given");
    assert!(merged.notes.iter().any(|n| n.contains("part 1 of 3 missing")), "{:?}", merged.notes);
    assert_eq!(merged.spp, (parts[0].1.info.frames + parts[1].1.info.frames) as u64 * 64);

    // Two problems, two sentences.
    let mut parts = good();
    parts[1].1.info.seed = 1;
    parts[2].1.info.scene_hash ^= 1;
    assert_eq!(refused(parts).len(), 2);
}

/// A part's file holds its header, image and variance exactly, and is an EXR that
/// other readers open (the image in R, G, B).
#[test]
fn a_part_file_round_trips() {
    let p = prepared(10, 7, 2);
    let written = part(&p, Part { index: 1, count: 2 }, 4, true);
    let path = tmp("round-trip.exr");
    written.save(&path).unwrap();
    let read = PartImage::load(&path).unwrap();
    assert_eq!(read.info, written.info);
    assert_eq!(read.mean, written.mean);
    assert_eq!(read.variance, written.variance);
    assert_eq!(Image::load(&path).unwrap(), written.mean);
    // A plain EXR is not a part; a damaged file is named.
    let plain = tmp("plain.exr");
    written.mean.save(&plain).unwrap();
    let e = PartImage::load(&plain).unwrap_err();
    assert!(e.starts_with(&format!("{} is not a part of a split render", plain.display())), "{e}");
    let cut = tmp("cut.exr");
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = PartImage::load(&cut).unwrap_err();
    assert!(e.starts_with(&format!("{} is not an EXR that rlpt can read", cut.display())), "{e}");
}

/// Runs rlpt with `args`; its stdout on success, else its stderr.
fn run(args: &[&str]) -> Result<String, String> {
    let o = rlpt().args(args).checked_output();
    let (out, err) = (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(!err.contains("validation"), "the validation layer spoke:\n{err}");
    if o.status.success() {
        Ok(out)
    } else {
        Err(err)
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Through the command line, on either device: `render --part` for each part and
/// `merge` give the unsplit render to rounding (the GPU's random numbers are
/// offset as the CPU's are).
#[test]
fn render_parts_and_merge_give_the_unsplit_render() {
    for device in ["cpu", "gpu"] {
        let base = ["render", "scenes/cornell-box.toml", "--width", "20", "--height", "14", "--spp", "320"];
        let full = tmp(&format!("full-{device}.exr"));
        run(&[&base[..], &["--device", device, "-o", s(&full)]].concat()).unwrap();
        let mut parts = Vec::new();
        for k in 0..3 {
            let path = tmp(&format!("part-{device}-{k}.exr"));
            let spec = format!("{k}/3");
            let out = run(&[&base[..], &["--device", device, "--part", &spec, "-o", s(&path)]].concat()).unwrap();
            assert!(out.contains(&format!("(part {k}/3: frames")), "{out}");
            parts.push(path);
        }
        let merged = tmp(&format!("merged-{device}.exr"));
        let args: Vec<&str> =
            ["merge"].into_iter().chain(parts.iter().map(|p| s(p))).chain(["-o", s(&merged)]).collect();
        let out = run(&args).unwrap();
        assert!(out.contains("merged 3 part(s) of 3: 20x14, 320 spp"), "{out}");
        let d = max_relative_difference(&Image::load(&merged).unwrap(), &Image::load(&full).unwrap());
        assert!(d < 2e-6, "{device}: merged parts against the unsplit render: {d}");
    }
}

/// The command line refuses a bad part, a part that is not an EXR or has no frame,
/// and merge's bad input, each in a sentence naming the file, writing nothing.
#[test]
fn the_command_line_refuses_bad_parts() {
    let render = |part: &str, out: &Path, spp: &str| {
        run(&[
            "render",
            "scenes/cornell-box.toml",
            "--device",
            "cpu",
            "--width",
            "8",
            "--height",
            "6",
            "--spp",
            spp,
            "--part",
            part,
            "-o",
            s(out),
        ])
    };
    let out = tmp("bad-part.exr");
    for (part, says) in [("2/2", "numbered 0 to 1"), ("0/0", "into 0 parts"), ("x", "not a part")] {
        let e = render(part, &out, "128").unwrap_err();
        assert!(e.contains(says), "{part}: {e}");
    }
    let e = render("0/2", &tmp("part.png"), "128").unwrap_err();
    assert!(e.contains("part.png is not .exr"), "{e}");
    let e = render("0/3", &out, "128").unwrap_err();
    assert!(e.contains("cannot be split into 3 parts") && e.contains("at least 192 samples per pixel"), "{e}");
    assert!(!out.exists());

    let (a, b) = (tmp("cli-a.exr"), tmp("cli-b.exr"));
    render("0/2", &a, "128").unwrap();
    render("1/2", &b, "128").unwrap();
    let merged = tmp("cli-merged.png");
    let e = run(&["merge", s(&a), "-o", s(&merged)]).unwrap_err();
    assert!(e.contains("part 1 of 2 missing"), "{e}");
    assert!(!merged.exists());
    let plain = tmp("cli-plain.exr");
    Image::new(8, 6).save(&plain).unwrap();
    let e = run(&["merge", s(&a), s(&plain), "-o", s(&merged)]).unwrap_err();
    assert!(e.contains(&format!("{} is not a part of a split render", plain.display())), "{e}");
    let e = run(&["merge", s(&a), s(&b), "-o", s(&a)]).unwrap_err();
    assert!(e.contains("one would overwrite the other"), "{e}");
    assert!(PartImage::load(&a).is_ok(), "a part was overwritten");
    let out = run(&["merge", s(&a), s(&b), "-o", s(&merged)]).unwrap();
    assert!(out.contains("merged 2 part(s) of 2") && merged.exists(), "{out}");
}

/// Guided parts that start from one saved field (`--guide-in`), merged, agree
/// within noise with an unguided render of another seed: each part is unbiased
/// whatever its table, and merge says nothing of guiding but that the parts share it.
#[test]
fn guided_parts_from_one_field_merge_to_the_image() {
    let base = ["scenes/cornell-box.toml", "--device", "cpu", "--width", "24", "--height", "18"];
    let field = tmp("field.bin");
    let preview = tmp("preview.png");
    let learn = ["render", "--guiding", "sphere", "--spp", "128", "--guide-out", s(&field), "-o", s(&preview)];
    run(&[&learn[..], &base[..]].concat()).unwrap();
    let mut parts = Vec::new();
    for k in 0..2 {
        let path = tmp(&format!("guided-{k}.exr"));
        let spec = format!("{k}/2");
        let part = ["render", "--guiding", "sphere", "--guide-in", s(&field), "--spp", "512", "--part", &spec];
        run(&[&part[..], &base[..], &["-o", s(&path)]].concat()).unwrap();
        let info = PartImage::load(&path).unwrap().info;
        assert_eq!(info.guiding, "sphere");
        assert_eq!(info.guide_in, Some(rlpt::parts::field_hash(&std::fs::read(&field).unwrap())));
        parts.push(path);
    }
    let (merged, merged_var) = (tmp("guided-merged.exr"), tmp("guided-merged-var.exr"));
    run(&["merge", s(&parts[0]), s(&parts[1]), "-o", s(&merged), "--variance", s(&merged_var)]).unwrap();
    let (plain, plain_var) = (tmp("plain-unsplit.exr"), tmp("plain-unsplit-var.exr"));
    let render = ["render", "--seed", "1", "--spp", "512", "-o", s(&plain), "--variance", s(&plain_var)];
    run(&[&render[..], &base[..]].concat()).unwrap();
    let compare = [
        "compare",
        s(&merged),
        s(&plain),
        "--reference-variance",
        s(&plain_var),
        "--image-variance",
        s(&merged_var),
        "--max-z",
        "5",
    ];
    run(&compare).unwrap();
}

/// Parts that `--time` cuts short on the CPU, their last frame at the time
/// limit: each header's spp is the count of the samples its image holds (the
/// same part traced here, its last frame cut after those samples, is its image
/// to float summation order, the variance too), the summary and `--stats` say
/// it, and merge weights the parts by it.
#[test]
fn parts_cut_short_by_time_hold_their_samples_exactly() {
    let (w, h, seed) = (12, 9, 4);
    // As the command line prepares it: --stats counts the paths that carry nothing.
    let sc = scene("cornell-box.toml");
    let mut o = rlpt::options::RenderOptions::from_scene(&sc);
    (o.width, o.height, o.seed, o.counters) = (w, h, seed, rlpt::options::Counters::ZeroPaths);
    let p = PreparedScene::new(&sc, &o).expect("valid options");
    let mut paths = Vec::new();
    for k in 0..2 {
        let (path, stats) = (tmp(&format!("timed-part-{k}.exr")), tmp(&format!("timed-part-{k}.json")));
        let spec = format!("{k}/2");
        let size = [w.to_string(), h.to_string(), seed.to_string()];
        let out = run(&[
            "render",
            "scenes/cornell-box.toml",
            "--device",
            "cpu",
            "--width",
            &size[0],
            "--height",
            &size[1],
            "--seed",
            &size[2],
            "--spp",
            "64000",
            "--time",
            "0.3",
            "--part",
            &spec,
            "-o",
            s(&path),
            "--stats",
            s(&stats),
        ])
        .unwrap();
        let part = PartImage::load(&path).unwrap();
        let info = &part.info;
        assert_eq!((info.scene_hash, info.settings_hash), (scene_hash(&p), settings_hash(&p.params)));
        assert!(info.frames >= 2 && info.frames < 500, "{out}");
        assert!(out.contains(&format!(", {} spp (part {spec}", info.spp)), "{out}");
        let stats = rlpt::stats::RenderStats::load(&stats).unwrap();
        assert_eq!(stats.frames.last().map(|f| f.spp as u64), Some(info.spp));
        let mut r = CpuRenderer::new(&p);
        r.set_frame_offset(info.first_frame);
        for _ in 0..info.spp / 64 {
            r.render_frame();
        }
        if !info.spp.is_multiple_of(64) {
            r.render_frame_samples((info.spp % 64) as u32);
        }
        let film = r.film();
        assert_eq!((film.frames, film.samples_per_pixel()), (info.frames, info.spp));
        let d = max_relative_difference(&part.mean, &film.mean());
        assert!(d < 1e-5, "part {k} ({} spp) against its samples traced here: {d}", info.spp);
        let d = max_relative_difference(part.variance.as_ref().unwrap(), &film.variance_of_mean().unwrap());
        assert!(d < 1e-3, "part {k}'s variance against its samples': {d}");
        paths.push((path, info.spp));
    }
    let merged = tmp("timed-merged.exr");
    let out = run(&["merge", s(&paths[0].0), s(&paths[1].0), "-o", s(&merged)]).unwrap();
    assert!(out.contains(&format!("{w}x{h}, {} spp", paths[0].1 + paths[1].1)), "{out}");
}
