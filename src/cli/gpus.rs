//! `--gpus all|I,J,...`: the GPUs a render, bench or view runs on, each with its
//! own context (`rlpt::render::MultiGpuRenderer`). `--gpu N` picks one device
//! and stays as it was; `--gpus N` is the same render as `--gpu N`, and the two
//! are not given together.

use crate::*;
use rlpt::gpu::DeviceInfo;
use std::sync::Arc;

/// Test hook, for tests only: `RLPT_TEST_DUPLICATE_GPUS=1` lets `--gpus` name a
/// device more than once (a context each), so that the several-GPU render runs
/// end to end on a machine with one device.
pub(crate) const DUPLICATE_GPUS_HOOK: &str = "RLPT_TEST_DUPLICATE_GPUS";

/// What `--gpus` names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum GpuList {
    /// Every usable device.
    All,
    /// These device indices (`rlpt devices`), in order.
    Indices(Vec<usize>),
}

impl std::fmt::Display for GpuList {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GpuList::All => write!(f, "all"),
            GpuList::Indices(v) => {
                write!(f, "{}", v.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(","))
            }
        }
    }
}

pub(crate) fn parse_gpus(s: &str) -> Result<GpuList, String> {
    let s = s.trim();
    if s.eq_ignore_ascii_case("all") {
        return Ok(GpuList::All);
    }
    let indices: Result<Vec<usize>, String> = s
        .split(',')
        .map(|t| {
            t.trim().parse::<usize>().map_err(|_| {
                format!(
                    "`{}` is not a device index: give `all` or indices from `rlpt devices` separated by commas, \
                     e.g. 0,2",
                    t.trim()
                )
            })
        })
        .collect();
    Ok(GpuList::Indices(indices?))
}

/// Refuses `--gpu` and `--gpus` together, before any work.
pub(crate) fn check_gpu_flags(settings: &Settings) -> Result<()> {
    if let (Some(one), Some(list)) = (settings.gpu, &settings.gpus) {
        bail!(
            "--gpu {one} and --gpus {list} both pick GPUs: give one of them (--gpu N renders on device N, --gpus a \
             list of devices, and --gpus N is --gpu N)"
        );
    }
    Ok(())
}

/// The devices, in words, for the refusals: "0 NAME, 1 NAME (unusable: ...)".
fn listing(devices: &[DeviceInfo]) -> String {
    devices
        .iter()
        .map(|d| match d.missing.is_empty() {
            true => format!("{} \"{}\"", d.index, d.name),
            false => format!("{} \"{}\" (unusable: it lacks {})", d.index, d.name, d.missing.join(", ")),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The device indices `list` names, checked against `devices`: no index twice
/// (unless [`DUPLICATE_GPUS_HOOK`]), none past the last device; `all` takes the
/// usable ones.
pub(crate) fn resolve_gpus(list: &GpuList, devices: &[DeviceInfo], duplicates: bool) -> Result<Vec<usize>> {
    let found = format!("{} Vulkan device(s) found: {} (see `rlpt devices`)", devices.len(), listing(devices));
    let indices = match list {
        GpuList::All => {
            let usable: Vec<usize> = devices.iter().filter(|d| d.missing.is_empty()).map(|d| d.index).collect();
            if usable.is_empty() {
                bail!("--gpus all: no device can run rlpt; {found}");
            }
            usable
        }
        GpuList::Indices(v) => v.clone(),
    };
    for (k, &i) in indices.iter().enumerate() {
        if i >= devices.len() {
            bail!("--gpus {list}: there is no device {i}; {found}");
        }
        if !duplicates && indices[..k].contains(&i) {
            bail!("--gpus {list}: device {i} is named twice; each GPU renders once. {found}");
        }
    }
    Ok(indices)
}

/// The device indices `--gpus` names (checked by [`resolve_gpus`]), or None
/// where it is not given.
pub(crate) fn gpu_indices(settings: &Settings) -> Result<Option<Vec<usize>>> {
    check_gpu_flags(settings)?;
    let Some(list) = &settings.gpus else { return Ok(None) };
    let duplicates = std::env::var(DUPLICATE_GPUS_HOOK).is_ok_and(|v| v == "1");
    Ok(Some(resolve_gpus(list, &rlpt::gpu::list_devices()?, duplicates)?))
}

/// The contexts a render runs on: `--gpus`' devices, or the one `--gpu` picks
/// (the first discrete GPU where neither is given).
pub(crate) fn open_gpus(settings: &Settings) -> Result<Vec<Arc<Context>>> {
    open_gpus_at(settings, gpu_indices(settings)?)
}

/// [`open_gpus`] where `--gpus`' indices were resolved already ([`gpu_indices`]):
/// the devices are enumerated once.
pub(crate) fn open_gpus_at(settings: &Settings, indices: Option<Vec<usize>>) -> Result<Vec<Arc<Context>>> {
    let Some(indices) = indices else {
        return Ok(vec![Context::new(&ContextOptions::from_env(settings.gpu))?]);
    };
    let mut contexts = Vec::with_capacity(indices.len());
    for i in indices {
        contexts.push(Context::new(&ContextOptions::from_env(Some(i)))?);
    }
    Ok(contexts)
}

/// The renderer of `prepared` on `contexts` (`rlpt::render::GpuSet`, which the
/// viewer builds too); a part's image frames start at `offset`.
pub(crate) fn gpu_renderer(
    contexts: &[Arc<Context>],
    prepared: &PreparedScene,
    offset: u32,
    learned: rlpt::film::Learned,
) -> Result<Box<dyn Renderer>> {
    Ok(Box::new(rlpt::render::GpuSet::new(contexts, prepared, offset, learned)?))
}

/// Several GPUs trace every frame guided: the race of `--unguided-frames auto`
/// chooses frame by frame on one device (`guide::FrameRace`).
pub(crate) fn refuse_race_on_several(prepared: &PreparedScene) -> Result<()> {
    match rlpt::render::several_gpus_refusal(prepared) {
        Some(why) => anyhow::bail!(why),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_lists_parse_and_refuse_with_a_sentence() {
        assert_eq!(parse_gpus("all"), Ok(GpuList::All));
        assert_eq!(parse_gpus("0, 2"), Ok(GpuList::Indices(vec![0, 2])));
        let e = parse_gpus("0,x").unwrap_err();
        assert!(e.contains("`x` is not a device index"), "{e}");
        assert!(parse_gpus("").is_err() && parse_gpus("-1").is_err());
    }
}
