//! The Vulkan context: instance, device, queue and allocator made and destroyed in order,
//! the device chosen, and the memory its buffers take.

use super::device::{enumerate, DeviceInfo};
use super::instance::{create_instance, load_entry};
use super::validation::debug_callback;
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::c_void;
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// Failures a user can act on, each said in a sentence.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no Vulkan loader found ({0}). Install one and a driver: `apt install libvulkan1 mesa-vulkan-drivers` \
         (Mesa's lavapipe renders on the CPU), or render with `--device cpu`"
    )]
    NoLoader(String),
    #[error(
        "no Vulkan device found: the loader found no driver. Install one (`apt install mesa-vulkan-drivers` \
         for Mesa's lavapipe, or your GPU vendor's driver), or render with `--device cpu`"
    )]
    NoDevice,
    #[error("--gpu {index} does not exist: {count} Vulkan device(s) found (see `rlpt devices`)")]
    NoSuchGpu { index: usize, count: usize },
    #[error("Vulkan device {index} \"{name}\" cannot run rlpt: it lacks {missing} (see `rlpt devices`)")]
    Unsupported { index: usize, name: String, missing: String },
    #[error(
        "the Khronos validation layer was asked for (RLPT_VALIDATION=1) but is not installed: \
         `apt install vulkan-validationlayers`"
    )]
    NoValidationLayer,
    #[error(
        "the GPU ran out of memory allocating {what} (other programs may hold some of it): render a smaller \
         image (--width, --height), with fewer guiding bins (--bins) or cells, or on the CPU (--device cpu)"
    )]
    OutOfMemory { what: String },
    #[error(
        "the render needs about {} MB of GPU memory ({what}) and {device} has {} MB: {hint}",
        needed.div_ceil(1 << 20), available / (1 << 20)
    )]
    DeviceMemoryTooSmall { what: String, needed: u64, available: u64, device: String, hint: String },
    #[error(
        "{what} would take {} MB, more than the {} MB this device's shaders can address in one buffer \
         (maxStorageBufferRange): {hint}", bytes.div_ceil(1 << 20), limit / (1 << 20)
    )]
    BufferTooLarge { what: String, bytes: u64, limit: u64, hint: &'static str },
    #[error("cannot show a window through Vulkan: {0}")]
    NoPresentation(String),
    #[error(
        "the GPU stopped responding (device lost: {0}): render again, and if it recurs render a smaller \
         image, update the GPU driver, or render on the CPU (--device cpu)"
    )]
    DeviceLost(String),
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan { call: &'static str, result: vk::Result },
    #[error("GPU memory allocation failed for {what}: {source}")]
    Allocation { what: String, source: gpu_allocator::AllocationError },
}

impl GpuError {
    /// Wraps a `vk::Result` from `call`, turning the ones a user can act on into their own variants.
    pub fn vk(call: &'static str, result: vk::Result) -> GpuError {
        match result {
            vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost(format!("{call} returned {result:?}")),
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                GpuError::OutOfMemory { what: format!("for {call}") }
            }
            _ => GpuError::Vulkan { call, result },
        }
    }
}

pub type Result<T> = std::result::Result<T, GpuError>;

/// How to make a [`Context`].
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Device index as listed by `rlpt devices`; `None` picks the first discrete GPU, else the first usable one.
    pub gpu: Option<usize>,
    /// Turn on the Khronos validation layer, with synchronization validation where the
    /// layer offers `VK_EXT_validation_features`; every message it prints is counted.
    pub validation: bool,
    /// A window to present to (the viewer): the context then owns a surface for it,
    /// chooses a device whose compute queue can present to it, and enables swapchains.
    pub window: Option<WindowTarget>,
}

/// The platform handles of a window, for a [`Context`] that presents to it.
#[derive(Clone, Copy, Debug)]
pub struct WindowTarget {
    display: raw_window_handle::RawDisplayHandle,
    window: raw_window_handle::RawWindowHandle,
}

impl WindowTarget {
    /// # Safety
    /// The handles must be those of a live window that outlives every [`Context`]
    /// made with this target: the context's surface refers to the window.
    pub unsafe fn new(
        display: raw_window_handle::RawDisplayHandle,
        window: raw_window_handle::RawWindowHandle,
    ) -> WindowTarget {
        WindowTarget { display, window }
    }
}

/// The window surface a context owns.
pub struct Surface {
    pub loader: ash::khr::surface::Instance,
    pub raw: vk::SurfaceKHR,
}

impl ContextOptions {
    /// Validation on when the environment variable `RLPT_VALIDATION` is `1`.
    pub fn from_env(gpu: Option<usize>) -> ContextOptions {
        ContextOptions { gpu, validation: std::env::var("RLPT_VALIDATION").is_ok_and(|v| v == "1"), window: None }
    }
}

/// Owner of the Vulkan instance, device, queue and memory allocator. Shared by
/// `Arc` with every resource made from it, so it is destroyed last; its `Drop`
/// waits for the device, then frees in reverse order (allocator before device).
pub struct Context {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub device: ash::Device,
    pub physical: vk::PhysicalDevice,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub info: DeviceInfo,
    /// The window surface, when made with [`ContextOptions::window`].
    pub surface: Option<Surface>,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    pub(super) command_pool: Mutex<vk::CommandPool>,
    pub(super) debug_instance: Option<ash::ext::debug_utils::Instance>,
    pub(super) debug_device: Option<ash::ext::debug_utils::Device>,
    messenger: vk::DebugUtilsMessengerEXT,
    /// Validation messages of warning or error severity; shared so the callback's pointer
    /// stays valid and so that a [`ValidationCounter`] can read it after the context is gone.
    pub(super) messages: Arc<AtomicU32>,
    /// Set once a call returned `VK_ERROR_DEVICE_LOST` (or [`Context::lose_device`]
    /// said so): every later submission fails the same way, without touching the device.
    lost: AtomicBool,
    /// Bytes of the buffers alive now ([`Context::note_allocation`]).
    allocated: AtomicU64,
    /// The device memory [`DEVICE_MEMORY_HOOK`] pretends, in bytes: allocations past it fail.
    memory_cap: Option<u64>,
    /// Pipelines compiled on this device, for the next renderer that asks for
    /// the same one (`super::pipeline::PipelineCache`).
    pub(super) pipelines: super::pipeline::PipelineCache,
}

/// Test hook, for tests only: `RLPT_TEST_DEVICE_MEMORY_MB=N` makes a [`Context`]
/// report a device of N MiB of memory ([`DeviceInfo::device_memory`]), and refuse
/// buffer allocations past it as out of memory, the way a real device that is full
/// does: lavapipe reports 2 GiB but lets every buffer take host memory, and no render
/// its 128 MiB buffer limit allows comes near that, so a test cannot fill it.
pub const DEVICE_MEMORY_HOOK: &str = "RLPT_TEST_DEVICE_MEMORY_MB";

impl Context {
    pub fn new(options: &ContextOptions) -> Result<Arc<Context>> {
        let entry = load_entry()?;
        let messages = Arc::new(AtomicU32::new(0));
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(&*messages as *const AtomicU32 as *mut c_void);
        let instance = create_instance(
            &entry,
            options.validation,
            options.validation.then_some(&mut messenger_info),
            options.window.map(|w| w.display),
        )?;
        // From here on, failures must destroy the surface and the instance: a guard does it.
        struct InstanceGuard(
            Option<ash::Instance>,
            Option<(ash::khr::surface::Instance, vk::SurfaceKHR)>,
            Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
        );
        impl Drop for InstanceGuard {
            fn drop(&mut self) {
                // SAFETY: only reached on an error path, before any other child object exists.
                unsafe {
                    if let Some((loader, surface)) = self.1.take() {
                        loader.destroy_surface(surface, None);
                    }
                    if let Some((debug, messenger)) = self.2.take() {
                        debug.destroy_debug_utils_messenger(messenger, None);
                    }
                    if let Some(i) = self.0.take() {
                        i.destroy_instance(None);
                    }
                }
            }
        }
        let mut guard = InstanceGuard(Some(instance.clone()), None, None);
        // The messenger first, so that every later call's messages are counted (those of
        // vkCreateDevice included); the one chained to the instance's creation covers
        // only vkCreateInstance and vkDestroyInstance.
        let (debug_instance, messenger) = if options.validation {
            let di = ash::ext::debug_utils::Instance::new(&entry, &instance);
            // The create info was chained into the instance's: unchain it.
            let mut own = messenger_info;
            own.p_next = std::ptr::null();
            // SAFETY: the messenger is destroyed in Drop before the instance; its user data outlives it.
            let m = unsafe { di.create_debug_utils_messenger(&own, None) }
                .map_err(|e| GpuError::vk("vkCreateDebugUtilsMessengerEXT", e))?;
            guard.2 = Some((di.clone(), m));
            (Some(di), m)
        } else {
            (None, vk::DebugUtilsMessengerEXT::null())
        };
        let surface = match options.window {
            None => None,
            Some(w) => {
                // SAFETY: the handles are those of a live window that outlives the context (WindowTarget::new's contract).
                let raw = unsafe { ash_window::create_surface(&entry, &instance, w.display, w.window, None) }
                    .map_err(|e| GpuError::NoPresentation(format!("creating a surface for the window failed: {e}")))?;
                let loader = ash::khr::surface::Instance::new(&entry, &instance);
                guard.1 = Some((loader.clone(), raw));
                Some(Surface { loader, raw })
            }
        };

        let mut devices = enumerate(&instance)?;
        if let Some(s) = &surface {
            for d in &mut devices {
                // SAFETY: device, family and surface all belong to this instance.
                let presents =
                    unsafe { s.loader.get_physical_device_surface_support(d.physical, d.queue_family, s.raw) }
                        .unwrap_or(false);
                if !presents {
                    d.missing.push("presentation to this window from its compute queue".into());
                }
                // SAFETY: plain enumeration.
                let exts = unsafe { instance.enumerate_device_extension_properties(d.physical) }.unwrap_or_default();
                if !exts.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == ash::khr::swapchain::NAME)) {
                    d.missing.push("swapchains (VK_KHR_swapchain)".into());
                }
            }
        }
        let chosen = match options.gpu {
            Some(i) => devices.get(i).ok_or(GpuError::NoSuchGpu { index: i, count: devices.len() })?,
            None => devices
                .iter()
                .find(|d| d.discrete && d.missing.is_empty())
                .or_else(|| devices.iter().find(|d| d.missing.is_empty()))
                .unwrap_or(&devices[0]),
        };
        if !chosen.missing.is_empty() {
            return Err(GpuError::Unsupported {
                index: chosen.index,
                name: chosen.name.clone(),
                missing: chosen.missing.join(", "),
            });
        }
        let mut info = chosen.clone();
        let memory_cap =
            std::env::var(DEVICE_MEMORY_HOOK).ok().and_then(|v| v.trim().parse::<u64>().ok()).map(|mb| mb << 20);
        if let Some(cap) = memory_cap {
            info.device_memory = info.device_memory.min(cap);
        }

        let priorities = [1.0f32];
        let queue_info =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(info.queue_family).queue_priorities(&priorities)];
        let mut extensions = Vec::new();
        let mut atomic =
            vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default().shader_buffer_float32_atomic_add(true);
        let mut device_info = vk::DeviceCreateInfo::default().queue_create_infos(&queue_info);
        if info.float_atomic_add {
            extensions.push(ash::ext::shader_atomic_float::NAME.as_ptr());
            device_info = device_info.push_next(&mut atomic);
        }
        if info.subgroup_partitioned {
            extensions.push(ash::nv::shader_subgroup_partitioned::NAME.as_ptr());
        }
        let mut exec =
            vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default().pipeline_executable_info(true);
        if info.pipeline_statistics {
            extensions.push(ash::khr::pipeline_executable_properties::NAME.as_ptr());
            device_info = device_info.push_next(&mut exec);
        }
        if surface.is_some() {
            extensions.push(ash::khr::swapchain::NAME.as_ptr());
        }
        let device_info = device_info.enabled_extension_names(&extensions);
        // SAFETY: `info.physical` belongs to `instance`; all pointers outlive the call.
        let device = unsafe { instance.create_device(info.physical, &device_info, None) }
            .map_err(|e| GpuError::vk("vkCreateDevice", e))?;
        // SAFETY: family and index exist (one queue was requested from this family).
        let queue = unsafe { device.get_device_queue(info.queue_family, 0) };

        let debug_device = debug_instance.as_ref().map(|_| ash::ext::debug_utils::Device::new(&instance, &device));

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: info.physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| GpuError::Allocation { what: "the allocator".into(), source: e })?;

        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(info.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device.
        let command_pool = unsafe { device.create_command_pool(&pool_info, None) }
            .map_err(|e| GpuError::vk("vkCreateCommandPool", e))?;

        guard.0 = None;
        guard.1 = None;
        guard.2 = None;
        let ctx = Context {
            entry,
            instance,
            device,
            physical: info.physical,
            queue,
            queue_family: info.queue_family,
            info,
            surface,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            command_pool: Mutex::new(command_pool),
            debug_instance,
            debug_device,
            messenger,
            messages,
            lost: AtomicBool::new(false),
            allocated: AtomicU64::new(0),
            memory_cap,
            pipelines: Default::default(),
        };
        ctx.set_name(ctx.queue, "rlpt queue");
        Ok(Arc::new(ctx))
    }

    /// How many pipelines this context has compiled: a [`super::Pipeline`] of a
    /// shader, bindings and specialization it compiled before takes that one.
    pub fn pipelines_compiled(&self) -> u64 {
        self.pipelines.compiled.load(Ordering::Relaxed)
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether the device was lost: every submission fails from then on.
    pub fn is_lost(&self) -> bool {
        self.lost.load(Ordering::SeqCst)
    }

    /// Marks the device lost, as a submission that returned `VK_ERROR_DEVICE_LOST`
    /// does, and returns that error: the way tests reach the device-lost path
    /// (`render::DEVICE_LOST_HOOK`), which no test can cause for real.
    pub fn lose_device(&self, call: &'static str) -> GpuError {
        self.lost.store(true, Ordering::SeqCst);
        GpuError::vk(call, vk::Result::ERROR_DEVICE_LOST)
    }

    /// `GpuError::vk`, noting a lost device.
    pub(super) fn vk_error(&self, call: &'static str, result: vk::Result) -> GpuError {
        if result == vk::Result::ERROR_DEVICE_LOST {
            self.lost.store(true, Ordering::SeqCst);
        }
        GpuError::vk(call, result)
    }

    /// Counts a buffer of `bytes` against the device's memory before it is
    /// allocated: an error where [`DEVICE_MEMORY_HOOK`] caps the memory and it
    /// would not fit. [`Context::note_free`] gives the bytes back.
    pub(crate) fn note_allocation(&self, what: &str, bytes: u64) -> Result<()> {
        let before = self.allocated.fetch_add(bytes, Ordering::SeqCst);
        if self.memory_cap.is_some_and(|cap| before + bytes > cap) {
            self.allocated.fetch_sub(bytes, Ordering::SeqCst);
            return Err(GpuError::OutOfMemory { what: what.to_string() });
        }
        Ok(())
    }

    /// Gives back what [`Context::note_allocation`] counted.
    pub(crate) fn note_free(&self, bytes: u64) {
        self.allocated.fetch_sub(bytes, Ordering::SeqCst);
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: every resource made from the context holds an Arc to it, so none is alive now;
        // objects are destroyed in reverse order of creation, the allocator before the device.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.pipelines.clear();
            self.device.destroy_command_pool(*self.command_pool.get_mut().unwrap_or_else(|e| e.into_inner()), None);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some(s) = &self.surface {
                s.loader.destroy_surface(s.raw, None);
            }
            if let Some(d) = &self.debug_instance {
                d.destroy_debug_utils_messenger(self.messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
