//! The renderers of the guiding modes the viewer switches between (`G`), each
//! built as `rlpt render` builds its own (`render::GpuSet`) on the viewer's GPUs.

use super::Viewer;
use crate::gpu::Context;
use crate::guide::{GuideField, GuidingMode};
use crate::options::RenderOptions;
use crate::prepared::PreparedScene;
use crate::render::GpuSet;
use crate::scene::Scene;
use anyhow::Result;
use std::path::PathBuf;
use std::sync::Arc;

/// One guiding mode's renderer (made when first shown; each keeps its own table).
pub(super) struct ModeRenderer {
    pub(super) mode: GuidingMode,
    pub(super) prepared: PreparedScene,
    pub(super) renderer: GpuSet,
}

impl Viewer {
    pub(super) fn renderer(&self) -> &ModeRenderer {
        &self.renderers[self.current]
    }

    pub(super) fn cycle_guiding(&mut self) -> Result<()> {
        let next = match self.renderer().mode {
            GuidingMode::Off => GuidingMode::Octant,
            GuidingMode::Octant => GuidingMode::Sphere,
            GuidingMode::Sphere => GuidingMode::Off,
        };
        let index = match self.renderers.iter().position(|r| r.mode == next) {
            Some(i) => i,
            None => match make_renderer(&self.contexts, &self.scene, &self.base, next, self.guide_in.as_ref()) {
                Ok(r) => {
                    self.renderers.push(r);
                    self.renderers.len() - 1
                }
                Err(e) => {
                    // A device without float atomics cannot guide: say so and stay.
                    println!("guiding {}: {e:#}", next.name());
                    return Ok(());
                }
            },
        };
        self.current = index;
        self.display.bind(self.shown_accumulation()?);
        println!("guiding {}", next.name());
        self.apply_params()?;
        self.update_inset(true)
    }
}

/// The renderer of guiding `mode` on `contexts` (the first presents), started
/// from `field` where its bins are the mode's.
pub(super) fn make_renderer(
    contexts: &[Arc<Context>],
    scene: &Scene,
    base: &RenderOptions,
    mode: GuidingMode,
    field: Option<&(PathBuf, GuideField)>,
) -> Result<ModeRenderer> {
    let mut opts = base.clone();
    opts.guiding = mode;
    let mut prepared = PreparedScene::new(scene, &opts)?;
    if let (Some((path, field)), Some(cfg)) = (field, prepared.guide) {
        if cfg.bins == field.bins {
            prepared.start_from(field.clone(), path, &opts)?;
            println!("guiding {}: starts from the learned field {}", mode.name(), path.display());
        } else {
            println!(
                "guiding {}: {} holds {}x{} bins and this mode has {}x{}: it starts from a blank table",
                mode.name(),
                path.display(),
                field.bins.rows,
                field.bins.cols,
                cfg.bins.rows,
                cfg.bins.cols
            );
        }
    }
    let renderer = GpuSet::new(contexts, &prepared, 0, crate::film::Learned::Fold)?;
    Ok(ModeRenderer { mode, prepared, renderer })
}
