//! The one home of `unsafe` Vulkan: a [`Context`] owning instance, device,
//! queue and allocator (and, for the viewer, a window surface); RAII
//! [`Buffer`]s and [`Image`]s; compute [`Pipeline`]s; timestamp [`Timer`]s; the
//! viewer's [`Swapchain`]. Everything else in the crate is safe code on top of these.

mod buffer;
mod commands;
mod context;
mod device;
mod instance;
mod pipeline;
mod swapchain;
mod timer;
mod validation;

pub use buffer::{Buffer, BufferUsage};
pub use context::{Context, ContextOptions, GpuError, Surface, WindowTarget, DEVICE_MEMORY_HOOK};
pub use device::{list_devices, DeviceInfo};
pub use pipeline::{Binding, Pipeline, PipelineStatistic, PIPELINE_CACHE_SIZE};
pub use swapchain::{Acquired, Image, Swapchain};
pub use timer::Timer;
pub use validation::{validation_messages_total, ValidationCounter};

pub use ash::vk;

mod spirv {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// The SPIR-V of `glsl/NAME.comp`, compiled by build.rs.
pub fn shader(name: &str) -> &'static [u8] {
    spirv::SHADERS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| *s)
        .unwrap_or_else(|| panic!("no shader glsl/{name}.comp was compiled"))
}
