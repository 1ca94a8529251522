//! The window's input: keys, mouse drags and the wheel, turned into the viewer's actions.

use super::{Flow, ViewOptions, Viewer, CONTROLS};
use crate::guide::GuidingMode;
use crate::shared;
use anyhow::Result;
use std::path::{Path, PathBuf};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::keyboard::{KeyCode, PhysicalKey};

impl Viewer {
    pub(super) fn handle(&mut self, event: WindowEvent, options: &ViewOptions) -> Result<Flow> {
        match event {
            WindowEvent::CloseRequested => return Ok(Flow::Exit),
            WindowEvent::Resized(_) => {
                self.swapchain_dirty = true;
                self.window.request_redraw();
            }
            WindowEvent::RedrawRequested if !self.hidden() => return self.redraw(options),
            WindowEvent::Occluded(hidden) => {
                self.occluded = hidden;
                self.window.request_redraw();
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    return self.key(code);
                }
            }
            WindowEvent::MouseInput { button: MouseButton::Left, state, .. } => {
                self.drag_from = (state == ElementState::Pressed).then_some(self.cursor).flatten();
            }
            WindowEvent::CursorMoved { position, .. } => {
                let now = (position.x, position.y);
                if let Some(from) = self.drag_from {
                    self.camera.orbit((now.0 - from.0) as f32, (now.1 - from.1) as f32);
                    self.drag_from = Some(now);
                    self.camera_changed();
                }
                self.cursor = Some(now);
            }
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                if lines != 0.0 {
                    self.camera.zoom(lines);
                    self.camera_changed();
                }
            }
            _ => {}
        }
        Ok(Flow::Continue)
    }

    fn key(&mut self, code: KeyCode) -> Result<Flow> {
        let step = self.camera.step();
        match code {
            KeyCode::Escape => return Ok(Flow::Exit),
            KeyCode::KeyW => self.camera.translate(step, 0.0, 0.0),
            KeyCode::KeyS => self.camera.translate(-step, 0.0, 0.0),
            KeyCode::KeyD => self.camera.translate(0.0, step, 0.0),
            KeyCode::KeyA => self.camera.translate(0.0, -step, 0.0),
            KeyCode::KeyE => self.camera.translate(0.0, 0.0, step),
            KeyCode::KeyQ => self.camera.translate(0.0, 0.0, -step),
            KeyCode::KeyR => {
                self.restart()?;
                return Ok(Flow::Continue);
            }
            KeyCode::KeyG => {
                self.cycle_guiding()?;
                return Ok(Flow::Continue);
            }
            KeyCode::KeyN => {
                self.nee = !self.nee;
                println!("next-event estimation {}", if self.nee { "on" } else { "off" });
                self.apply_params()?;
                return Ok(Flow::Continue);
            }
            KeyCode::KeyV => {
                self.inset_on = !self.inset_on;
                if self.inset_on && self.renderer().mode == GuidingMode::Off {
                    println!("V: guiding is off, so nothing is learned; press G to turn it on");
                }
                self.update_inset(true)?;
                self.window.request_redraw();
                return Ok(Flow::Continue);
            }
            KeyCode::Space => {
                self.paused = !self.paused;
                self.update_title();
                self.window.request_redraw();
                return Ok(Flow::Continue);
            }
            KeyCode::KeyP => {
                self.merge_if_due(true)?;
                let spp = self.shown_frames() * shared::SAMPLES_PER_FRAME;
                let stem = Path::new(&self.scene_name).file_stem().map(|s| s.to_string_lossy().into_owned());
                let png = PathBuf::from(format!("rlpt-{}-{spp}spp.png", stem.unwrap_or_else(|| "view".into())));
                self.save(&png)?;
                return Ok(Flow::Continue);
            }
            KeyCode::KeyH => {
                println!("{CONTROLS}");
                return Ok(Flow::Continue);
            }
            _ => return Ok(Flow::Continue),
        }
        // A movement key.
        self.camera_changed();
        Ok(Flow::Continue)
    }

    fn camera_changed(&mut self) {
        if let Err(e) = self.apply_params() {
            log::error!("{e:#}");
        }
    }
}
