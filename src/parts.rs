//! Renders split across machines: `rlpt render --part K/N` traces the K-th of N
//! disjoint ranges of a render's frames into an EXR whose header says which
//! ([`PartImage`]), and `rlpt merge` checks that parts belong together and
//! combines them by sample count ([`merge`]). docs/cluster.md describes the file.
//!
//! Parts split the image's frames into contiguous ranges ([`Part::frames`]): the
//! random numbers of a part's image frames are those the unsplit render draws for
//! the same frames (`crate::math::sampler::rng_frame`), so that all parts together are
//! the unsplit render's samples, each once, whichever sampler makes them.

use crate::image::Image;
use crate::layout::RenderParams;
use crate::shared;
use anyhow::Context as _;
use std::collections::HashMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The K-th (from 0) of N parts of a render.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Part {
    pub index: u32,
    pub count: u32,
}

impl Part {
    /// `K/N` with 0 <= K < N; the error says what was expected.
    pub fn parse(s: &str) -> Result<Part, String> {
        let expected = "expected K/N, part K (from 0) of N, such as 0/4";
        let (k, n) = s.split_once('/').ok_or_else(|| format!("`{s}` is not a part: {expected}"))?;
        let number = |t: &str| t.trim().parse::<u32>().map_err(|_| format!("`{s}` is not a part: {expected}"));
        let (index, count) = (number(k)?, number(n)?);
        if count == 0 {
            return Err(format!("`{s}`: a render cannot be split into 0 parts; {expected}"));
        }
        if index >= count {
            return Err(format!("`{s}`: parts of {count} are numbered 0 to {}", count - 1));
        }
        Ok(Part { index, count })
    }

    /// The image frames of this part of a render of `total` frames: the K-th of
    /// N contiguous ranges, which tile `0..total` and differ in length by at most one.
    pub fn frames(&self, total: u32) -> Range<u32> {
        let at = |k: u32| (k as u64 * total as u64 / self.count as u64) as u32;
        at(self.index)..at(self.index + 1)
    }
}

impl fmt::Display for Part {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// FNV-1a over what a render's image depends on besides the scene and the seed:
/// the camera, the image size, bounces, NEE, MIS and guiding settings
/// (`RenderParams` with the seed left out, which parts compare on its own).
pub fn settings_hash(params: &RenderParams) -> u64 {
    let mut p = *params;
    p.seed = 0;
    fnv1a(bytemuck::bytes_of(&p))
}

/// FNV-1a of a saved field's file (`--guide-in`): which field a part started from.
pub fn field_hash(file: &[u8]) -> u64 {
    fnv1a(file)
}

fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

/// What a part's EXR header records (docs/cluster.md, "The part file").
#[derive(Clone, Debug, PartialEq)]
pub struct PartInfo {
    pub part: Part,
    /// `guide::scene_hash` of the scene.
    pub scene_hash: u64,
    /// [`settings_hash`] of the render.
    pub settings_hash: u64,
    pub seed: u32,
    /// The image frames of the whole render, all parts together.
    pub total_frames: u32,
    /// The part's first image frame of the whole render's.
    pub first_frame: u32,
    /// The image frames the part traced (fewer than its range where `--time` or
    /// Ctrl-C cut it short), a last one cut short included.
    pub frames: u32,
    /// Samples per pixel of the part: `frames` times 64, less what a last frame
    /// cut short by `--time` lacks (`crate::film::Film::partial_spp`).
    pub spp: u64,
    /// The guiding mode, in words (`off`, `octant`, `sphere`).
    pub guiding: String,
    /// [`field_hash`] of the saved field it started from (`--guide-in`); None
    /// where it learned from nothing.
    pub guide_in: Option<u64>,
}

/// A part: its header, its image and the variance of each pixel's mean (from the
/// spread of its frames; None where it has fewer than 2).
#[derive(Clone, Debug)]
pub struct PartImage {
    pub info: PartInfo,
    pub mean: Image,
    pub variance: Option<Image>,
}

/// The attribute names of a part's header.
const ATTR_PART: &str = "rlpt_part";
const ATTR_PARTS: &str = "rlpt_parts";
const ATTR_SCENE: &str = "rlpt_scene_hash";
const ATTR_SETTINGS: &str = "rlpt_settings_hash";
const ATTR_SEED: &str = "rlpt_seed";
const ATTR_SPP: &str = "rlpt_spp";
const ATTR_TOTAL: &str = "rlpt_total_frames";
const ATTR_FIRST: &str = "rlpt_first_frame";
const ATTR_FRAMES: &str = "rlpt_frames";
const ATTR_GUIDING: &str = "rlpt_guiding";
const ATTR_GUIDE_IN: &str = "rlpt_guide_in";
/// The variance channels' layer prefix: `variance.R`, `variance.G`, `variance.B`.
const VARIANCE: &str = "variance";

impl PartImage {
    /// The header as (name, text) pairs, in the order docs/cluster.md lists them.
    fn attributes(&self) -> Vec<(&'static str, String)> {
        let i = &self.info;
        vec![
            (ATTR_PART, i.part.index.to_string()),
            (ATTR_PARTS, i.part.count.to_string()),
            (ATTR_SCENE, format!("{:016x}", i.scene_hash)),
            (ATTR_SETTINGS, format!("{:016x}", i.settings_hash)),
            (ATTR_SEED, i.seed.to_string()),
            (ATTR_SPP, i.spp.to_string()),
            (ATTR_TOTAL, i.total_frames.to_string()),
            (ATTR_FIRST, i.first_frame.to_string()),
            (ATTR_FRAMES, i.frames.to_string()),
            (ATTR_GUIDING, i.guiding.clone()),
            (ATTR_GUIDE_IN, i.guide_in.map_or("none".into(), |h| format!("{h:016x}"))),
        ]
    }

    /// Writes the part as a linear float EXR: R, G, B the image (what any EXR
    /// viewer shows), `variance.R/G/B` the variance of each pixel's mean, and the
    /// header's text attributes. Written to a temporary file renamed over `path`.
    pub fn save(&self, path: &Path) -> anyhow::Result<()> {
        write_exr(path, &self.mean, self.variance.as_ref(), &self.attributes())
    }

    /// Reads a part that [`save`](Self::save) wrote; the error is one sentence
    /// naming the file and what is wrong.
    pub fn load(path: &Path) -> Result<PartImage, String> {
        use exr::prelude::*;
        let name = path.display();
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
            .map_err(|e| format!("{name} is not an EXR that rlpt can read: {e}"))?;
        let layer = &image.layer_data;
        let text: HashMap<String, String> = layer
            .attributes
            .other
            .iter()
            .chain(&image.attributes.other)
            .filter_map(|(k, v)| match v {
                AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
                _ => None,
            })
            .collect();
        if !text.contains_key(ATTR_PART) {
            return Err(format!(
                "{name} is not a part of a split render: its header has no {ATTR_PART} (render parts with \
                 `rlpt render --part K/N`)"
            ));
        }
        let get = |key: &str| -> std::result::Result<&String, String> {
            text.get(key).ok_or_else(|| format!("{name} is a damaged part: its header has {ATTR_PART} but no {key}"))
        };
        // A header number, decimal or hexadecimal, that fits T.
        fn number<T: TryFrom<u64>>(
            name: &impl fmt::Display,
            key: &str,
            v: &str,
            radix16: bool,
        ) -> std::result::Result<T, String> {
            let parsed = if radix16 { u64::from_str_radix(v, 16).ok() } else { v.parse::<u64>().ok() };
            parsed
                .and_then(|x| T::try_from(x).ok())
                .ok_or_else(|| format!("{name} is a damaged part: its {key} `{v}` is not a number"))
        }
        let dec = |key: &str| -> std::result::Result<u32, String> { number(&name, key, get(key)?, false) };
        let hex = |key: &str| -> std::result::Result<u64, String> { number(&name, key, get(key)?, true) };
        let (index, count) = (dec(ATTR_PART)?, dec(ATTR_PARTS)?);
        if count == 0 || index >= count {
            return Err(format!("{name} is a damaged part: part {index} of {count}"));
        }
        let spp: u64 = number(&name, ATTR_SPP, get(ATTR_SPP)?, false)?;
        let info = PartInfo {
            part: Part { index, count },
            scene_hash: hex(ATTR_SCENE)?,
            settings_hash: hex(ATTR_SETTINGS)?,
            seed: dec(ATTR_SEED)?,
            total_frames: dec(ATTR_TOTAL)?,
            first_frame: dec(ATTR_FIRST)?,
            frames: dec(ATTR_FRAMES)?,
            spp,
            guiding: get(ATTR_GUIDING)?.clone(),
            guide_in: match get(ATTR_GUIDE_IN)?.as_str() {
                "none" => None,
                v => Some(number(&name, ATTR_GUIDE_IN, v, true)?),
            },
        };
        // Whole frames, the last of which a deadline may have cut short (to at least one sample).
        let whole = info.frames as u64 * shared::SAMPLES_PER_FRAME as u64;
        let least = whole.saturating_sub(shared::SAMPLES_PER_FRAME as u64 - 1);
        if spp > whole || spp < least {
            return Err(format!(
                "{name} is a damaged part: its {ATTR_SPP} {spp} is not {} frames of {}, the last possibly cut short",
                info.frames,
                shared::SAMPLES_PER_FRAME
            ));
        }
        let size = layer.size;
        let (width, height) = (size.0 as u32, size.1 as u32);
        let channel = |c: &str| -> Option<Vec<f32>> {
            let ch = layer.channel_data.list.iter().find(|ch| ch.name.to_string() == c)?;
            Some(ch.sample_data.values_as_f32().collect())
        };
        let rgb = |prefix: &str| -> Option<crate::image::Image> {
            let [r, g, b] = ["R", "G", "B"].map(|c| channel(&format!("{prefix}{c}")));
            let (r, g, b) = (r?, g?, b?);
            Some(crate::image::Image { width, height, pixels: (0..r.len()).map(|i| [r[i], g[i], b[i]]).collect() })
        };
        let mean = rgb("").ok_or_else(|| format!("{name} is a damaged part: it lacks an R, G or B channel"))?;
        let variance = rgb(&format!("{VARIANCE}."));
        Ok(PartImage { info, mean, variance })
    }
}

/// Writes `mean`, and `variance` as `variance.R/G/B` where given, with the text
/// attributes `attrs`, to a temporary file renamed over `path` (as `Image::save`).
pub fn write_exr(
    path: &Path,
    mean: &Image,
    variance: Option<&Image>,
    attrs: &[(&'static str, String)],
) -> anyhow::Result<()> {
    use exr::prelude::*;
    let channel = |name: String, img: &crate::image::Image, c: usize| {
        AnyChannel::new(name.as_str(), FlatSamples::F32(img.pixels.iter().map(|p| p[c]).collect()))
    };
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, n) in ["R", "G", "B"].into_iter().enumerate() {
        channels.push(channel(n.to_string(), mean, c));
        if let Some(v) = variance {
            channels.push(channel(format!("{VARIANCE}.{n}"), v, c));
        }
    }
    let mut attributes = LayerAttributes::default();
    for (k, v) in attrs {
        let v = Text::new_or_none(v).with_context(|| format!("the header text `{v}` is not ASCII"))?;
        attributes.other.insert(Text::new_or_panic(k), AttributeValue::Text(v));
    }
    let size = (mean.width as usize, mean.height as usize);
    let layer = Layer::new(size, attributes, Encoding::SMALL_LOSSLESS, AnyChannels::sort(channels));
    let image = exr::image::Image::from_layer(layer);
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let temp = parent.join(format!(".{file}.{}.tmp", std::process::id()));
    let result = image
        .write()
        .to_file(&temp)
        .map_err(anyhow::Error::from)
        .and_then(|()| std::fs::rename(&temp, path).context("renaming the temporary file over it failed"));
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result.with_context(|| format!("cannot save {}", path.display()))
}

/// Parts combined: the image, the variance of its pixels' means where every part
/// had one, and what merge should say on stderr.
#[derive(Clone, Debug)]
pub struct Merged {
    pub mean: Image,
    pub variance: Option<Image>,
    /// Samples per pixel of all parts together.
    pub spp: u64,
    pub notes: Vec<String>,
}

/// Checks that `parts` (each with the file it came from) belong to one render and
/// combines them: each pixel's mean weighted by the parts' samples, and the
/// variance of that mean, `sum(n_i^2 var_i) / (sum n_i)^2`. Refuses, with a
/// sentence for each problem naming the file, parts of another scene, settings,
/// seed, size, split or render length, a part given twice, parts whose frames
/// overlap, and parts missing unless `allow_missing`.
pub fn merge(parts: &[(PathBuf, PartImage)], allow_missing: bool) -> Result<Merged, Vec<String>> {
    let Some((first_path, first)) = parts.first() else {
        return Err(vec!["no parts to merge".into()]);
    };
    let f = first_path.display();
    let a = &first.info;
    let mut problems = Vec::new();
    let mut notes = Vec::new();
    for (path, p) in &parts[1..] {
        let n = path.display();
        let b = &p.info;
        if b.scene_hash != a.scene_hash {
            problems.push(format!(
                "{n} is a render of another scene than {f} (scene hash {:016x}, not {:016x})",
                b.scene_hash, a.scene_hash
            ));
        }
        if (p.mean.width, p.mean.height) != (first.mean.width, first.mean.height) {
            problems.push(format!(
                "{n} is {}x{} but {f} is {}x{}",
                p.mean.width, p.mean.height, first.mean.width, first.mean.height
            ));
        } else if b.settings_hash != a.settings_hash {
            problems
                .push(format!("{n} was rendered with other settings than {f} (camera, bounces, NEE, MIS or guiding)"));
        }
        if b.guiding != a.guiding {
            problems.push(format!("{n} was rendered with guiding {} but {f} with guiding {}", b.guiding, a.guiding));
        }
        if b.guide_in != a.guide_in {
            // Each part is unbiased whatever its table started from: merged, but said.
            let field =
                |h: Option<u64>| h.map_or("learned from nothing".into(), |h| format!("started from field {h:016x}"));
            notes.push(format!(
                "{n} {} but {f} {}: the merged image is unbiased, but the parts of one render \
                 usually start from one saved field (--guide-in)",
                field(b.guide_in),
                field(a.guide_in)
            ));
        }
        if b.seed != a.seed {
            problems
                .push(format!("{n} has seed {} but {f} seed {}: parts of one render share its seed", b.seed, a.seed));
        }
        if b.part.count != a.part.count || b.total_frames != a.total_frames {
            problems.push(format!(
                "{n} is part {} of a render of {} frames, but {f} part {} of {} frames: they split different renders",
                b.part, b.total_frames, a.part, a.total_frames
            ));
        }
    }
    // A part given twice, and frames that two parts both traced.
    for (i, (pi, a)) in parts.iter().enumerate() {
        for (pj, b) in &parts[i + 1..] {
            let (ra, rb) = (
                a.info.first_frame..a.info.first_frame + a.info.frames,
                b.info.first_frame..b.info.first_frame + b.info.frames,
            );
            if a.info.part == b.info.part {
                problems.push(format!(
                    "{} and {} are both part {}: give each part once",
                    pi.display(),
                    pj.display(),
                    a.info.part
                ));
            } else if ra.start < rb.end && rb.start < ra.end {
                problems.push(format!(
                    "{} (frames {}..{}) and {} (frames {}..{}) overlap: their samples are not independent",
                    pi.display(),
                    ra.start,
                    ra.end,
                    pj.display(),
                    rb.start,
                    rb.end
                ));
            }
        }
    }
    if problems.is_empty() {
        let have: Vec<u32> = parts.iter().map(|(_, p)| p.info.part.index).collect();
        let missing: Vec<String> = (0..a.part.count).filter(|k| !have.contains(k)).map(|k| k.to_string()).collect();
        if !missing.is_empty() {
            let which =
                format!("part{} {} of {}", if missing.len() > 1 { "s" } else { "" }, missing.join(", "), a.part.count);
            if allow_missing {
                notes.push(format!("{which} missing: merged the {} given (--allow-missing)", parts.len()));
            } else {
                problems.push(format!("{which} missing: give every part, or merge those given with --allow-missing"));
            }
        }
        for (path, p) in parts {
            let range = p.info.part.frames(p.info.total_frames);
            let asked = range.len() as u64 * shared::SAMPLES_PER_FRAME as u64;
            if p.info.spp < asked {
                notes.push(format!(
                    "{} holds {} of its {} samples per pixel (cut short by --time or Ctrl-C): merged by the \
                     samples it has",
                    path.display(),
                    p.info.spp,
                    asked
                ));
            }
        }
    }
    if !problems.is_empty() {
        return Err(problems);
    }
    let total: u64 = parts.iter().map(|(_, p)| p.info.spp).sum();
    if total == 0 {
        return Err(vec!["the parts hold no samples".into()]);
    }
    let (w, h) = (first.mean.width, first.mean.height);
    let mut mean = vec![[0.0f64; 3]; first.mean.pixels.len()];
    let mut var = vec![[0.0f64; 3]; first.mean.pixels.len()];
    let all_variances = parts.iter().all(|(_, p)| p.variance.is_some());
    for (_, p) in parts {
        let n = p.info.spp as f64;
        for (i, m) in p.mean.pixels.iter().enumerate() {
            for c in 0..3 {
                mean[i][c] += n * m[c] as f64;
            }
        }
        if let Some(v) = p.variance.as_ref().filter(|_| all_variances) {
            for (i, v) in v.pixels.iter().enumerate() {
                for c in 0..3 {
                    var[i][c] += n * n * v[c] as f64;
                }
            }
        }
    }
    let t = total as f64;
    let mean = Image { width: w, height: h, pixels: mean.iter().map(|m| m.map(|s| (s / t) as f32)).collect() };
    let variance = all_variances.then(|| Image {
        width: w,
        height: h,
        pixels: var.iter().map(|v| v.map(|s| (s / (t * t)) as f32)).collect(),
    });
    if !all_variances {
        let without: Vec<String> =
            parts.iter().filter(|(_, p)| p.variance.is_none()).map(|(path, _)| path.display().to_string()).collect();
        notes.push(format!(
            "no variance merged: {} hold{} none (a part needs 2 frames for one)",
            without.join(", "),
            if without.len() == 1 { "s" } else { "" }
        ));
    }
    Ok(Merged { mean, variance, spp: total, notes })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The N ranges tile the frames in order, each within one frame of the others.
    #[test]
    fn part_ranges_tile_the_frames() {
        for total in [1u32, 2, 7, 64, 1000] {
            for count in 1..=9u32 {
                let mut next = 0;
                for index in 0..count {
                    let r = Part { index, count }.frames(total);
                    assert_eq!(r.start, next, "{index}/{count} of {total}");
                    assert!(r.len() as u32 == total / count || r.len() as u32 == total / count + 1);
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
    }
}
