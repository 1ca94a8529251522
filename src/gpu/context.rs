use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{c_void, CStr, CString};
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

/// What a device is and whether rlpt can use it.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub device_type: String,
    pub driver: String,
    pub api_version: String,
    pub subgroup_size: u32,
    /// Subgroup operation classes supported in compute shaders.
    pub subgroup_operations: Vec<&'static str>,
    /// `VK_EXT_shader_atomic_float` with float atomic add on storage buffers (learned guiding).
    pub float_atomic_add: bool,
    /// `VK_NV_shader_subgroup_partitioned` (faster aggregated atomics).
    pub subgroup_partitioned: bool,
    pub timestamp_period_ns: f32,
    pub timestamps: bool,
    /// `maxComputeSharedMemorySize`: bytes of shared memory a workgroup may use
    /// (at least 16384 on every Vulkan device).
    pub max_compute_shared_memory: u32,
    /// `maxStorageBufferRange`: the largest storage buffer a shader can address.
    pub max_storage_buffer_range: u32,
    /// Bytes of the largest device-local memory heap: what buffers that shaders
    /// read and write are allocated from (see [`DEVICE_MEMORY_HOOK`] for tests).
    pub device_memory: u64,
    /// Every memory heap is device-local (lavapipe, integrated GPUs): host-visible
    /// buffers (uploads, readbacks) take the same memory as the device's own.
    pub unified_memory: bool,
    /// `VK_KHR_pipeline_executable_properties`: the driver reports each pipeline's
    /// register and memory use (`rlpt bench`).
    pub pipeline_statistics: bool,
    /// What rlpt requires and this device lacks; empty if usable.
    pub missing: Vec<String>,
    physical: vk::PhysicalDevice,
    queue_family: u32,
    discrete: bool,
}

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
    command_pool: Mutex<vk::CommandPool>,
    debug_instance: Option<ash::ext::debug_utils::Instance>,
    debug_device: Option<ash::ext::debug_utils::Device>,
    messenger: vk::DebugUtilsMessengerEXT,
    /// Validation messages of warning or error severity; shared so the callback's pointer
    /// stays valid and so that a [`ValidationCounter`] can read it after the context is gone.
    messages: Arc<AtomicU32>,
    /// Set once a call returned `VK_ERROR_DEVICE_LOST` (or [`Context::lose_device`]
    /// said so): every later submission fails the same way, without touching the device.
    lost: AtomicBool,
    /// Bytes of the buffers alive now ([`Context::note_allocation`]).
    allocated: AtomicU64,
    /// The device memory [`DEVICE_MEMORY_HOOK`] pretends, in bytes: allocations past it fail.
    memory_cap: Option<u64>,
}

/// Validation messages of warning or error severity reported in this process, by
/// every context, including those counted while a context was destroyed.
static MESSAGES_TOTAL: AtomicU32 = AtomicU32::new(0);

/// Number of warnings and errors the validation layer reported in this process so
/// far, over every context made and destroyed (the CLI fails on any, at exit).
pub fn validation_messages_total() -> u32 {
    MESSAGES_TOTAL.load(Ordering::SeqCst)
}

/// A context's validation message count that outlives the context: it also counts
/// what the layer reports while the context is destroyed (leaked objects, for one).
#[derive(Clone, Debug)]
pub struct ValidationCounter(Arc<AtomicU32>);

impl ValidationCounter {
    pub fn get(&self) -> u32 {
        self.0.load(Ordering::SeqCst)
    }
}

/// Test hook, for tests only: `RLPT_TEST_DEVICE_MEMORY_MB=N` makes a [`Context`]
/// report a device of N MiB of memory ([`DeviceInfo::device_memory`]), and refuse
/// buffer allocations past it as out of memory, the way a real device that is full
/// does: lavapipe reports 2 GiB but lets every buffer take host memory, and no render
/// its 128 MiB buffer limit allows comes near that, so a test cannot fill it.
pub const DEVICE_MEMORY_HOOK: &str = "RLPT_TEST_DEVICE_MEMORY_MB";

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if severity
        .intersects(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
    {
        MESSAGES_TOTAL.fetch_add(1, Ordering::SeqCst);
        // SAFETY: `user` is the `AtomicU32` the Context holds until after it destroys the
        // messenger and the instance; `data` is valid for the duration of the callback.
        unsafe {
            (*(user as *const AtomicU32)).fetch_add(1, Ordering::SeqCst);
            let msg = if data.is_null() || (*data).p_message.is_null() {
                "(no message)".into()
            } else {
                CStr::from_ptr((*data).p_message).to_string_lossy()
            };
            eprintln!("vulkan validation ({severity:?}): {msg}");
        }
    }
    vk::FALSE
}

fn load_entry() -> Result<ash::Entry> {
    // SAFETY: loading the system Vulkan loader; ash checks the library's entry points.
    unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoLoader(e.to_string()))
}

fn create_instance(
    entry: &ash::Entry,
    validation: bool,
    messenger_info: Option<&mut vk::DebugUtilsMessengerCreateInfoEXT<'_>>,
    display: Option<raw_window_handle::RawDisplayHandle>,
) -> Result<ash::Instance> {
    let app_name = c"rlpt";
    let app = vk::ApplicationInfo::default()
        .application_name(app_name)
        .application_version(1)
        .engine_name(app_name)
        .api_version(vk::API_VERSION_1_2);
    let mut layers = Vec::new();
    let mut extensions = Vec::new();
    let mut sync_validation = false;
    if let Some(display) = display {
        let needed = ash_window::enumerate_required_extensions(display)
            .map_err(|e| GpuError::vk("ash_window::enumerate_required_extensions", e))?;
        // SAFETY: plain enumeration.
        let available = unsafe { entry.enumerate_instance_extension_properties(None) }
            .map_err(|e| GpuError::vk("vkEnumerateInstanceExtensionProperties", e))?;
        for &ext in needed {
            // SAFETY: ash_window returns pointers to static NUL-terminated names.
            let name = unsafe { CStr::from_ptr(ext) };
            if !available.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name)) {
                return Err(GpuError::NoPresentation(format!(
                    "the Vulkan loader offers no {} (the window system's surface extension)",
                    name.to_string_lossy()
                )));
            }
        }
        extensions.extend_from_slice(needed);
    }
    if validation {
        // SAFETY: plain enumeration.
        let available = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(|e| GpuError::vk("vkEnumerateInstanceLayerProperties", e))?;
        if !available.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER)) {
            return Err(GpuError::NoValidationLayer);
        }
        layers.push(VALIDATION_LAYER.as_ptr());
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        // SAFETY: plain enumeration of the layer's own extensions.
        let layer_extensions = unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }
            .map_err(|e| GpuError::vk("vkEnumerateInstanceExtensionProperties", e))?;
        sync_validation = layer_extensions
            .iter()
            .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == ash::ext::validation_features::NAME));
        if sync_validation {
            extensions.push(ash::ext::validation_features::NAME.as_ptr());
        }
    }
    // Synchronization validation too: read/write hazards between commands (dispatches,
    // copies) within and across submissions, which the core checks do not see.
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    if sync_validation {
        info = info.push_next(&mut features);
    }
    if let Some(m) = messenger_info {
        info = info.push_next(m);
    }
    // SAFETY: every pointer in `info` outlives the call.
    match unsafe { entry.create_instance(&info, None) } {
        Ok(i) => Ok(i),
        Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => Err(GpuError::NoDevice),
        Err(e) => Err(GpuError::vk("vkCreateInstance", e)),
    }
}

fn describe(instance: &ash::Instance, index: usize, physical: vk::PhysicalDevice) -> DeviceInfo {
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup).push_next(&mut driver);
    // SAFETY: `physical` came from this instance; the chained structs live through the call.
    unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    let props = props2.properties;
    let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let driver_name = driver.driver_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let driver_info = driver.driver_info_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let api = props.api_version;
    let api_version =
        format!("{}.{}.{}", vk::api_version_major(api), vk::api_version_minor(api), vk::api_version_patch(api));
    let device_type = match props.device_type {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
    .to_string();
    // SAFETY: as above.
    let extensions = unsafe { instance.enumerate_device_extension_properties(physical) }.unwrap_or_default();
    let has_ext = |ext: &CStr| extensions.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == ext));
    let mut float_atomic_add = false;
    if has_ext(ash::ext::shader_atomic_float::NAME) {
        let mut atomic = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default();
        let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut atomic);
        // SAFETY: as above.
        unsafe { instance.get_physical_device_features2(physical, &mut features) };
        float_atomic_add = atomic.shader_buffer_float32_atomic_add == vk::TRUE;
    }
    let mut pipeline_statistics = false;
    if has_ext(ash::khr::pipeline_executable_properties::NAME) {
        let mut exec = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default();
        let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut exec);
        // SAFETY: as above.
        unsafe { instance.get_physical_device_features2(physical, &mut features) };
        pipeline_statistics = exec.pipeline_executable_info == vk::TRUE;
    }
    // SAFETY: as above.
    let memory = unsafe { instance.get_physical_device_memory_properties(physical) };
    let heaps = &memory.memory_heaps[..memory.memory_heap_count as usize];
    let local = |h: &&vk::MemoryHeap| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL);
    let device_memory = heaps.iter().filter(local).map(|h| h.size).max().unwrap_or(0);
    let unified_memory = !heaps.is_empty() && heaps.iter().all(|h| local(&h));
    // SAFETY: as above.
    let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let queue_family = families.iter().position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE));
    let timestamps = queue_family.is_some_and(|q| families[q].timestamp_valid_bits > 0)
        && props.limits.timestamp_compute_and_graphics == vk::TRUE;

    let ops = subgroup.supported_operations;
    let mut subgroup_operations = Vec::new();
    for (flag, label) in [
        (vk::SubgroupFeatureFlags::BASIC, "basic"),
        (vk::SubgroupFeatureFlags::VOTE, "vote"),
        (vk::SubgroupFeatureFlags::ARITHMETIC, "arithmetic"),
        (vk::SubgroupFeatureFlags::BALLOT, "ballot"),
        (vk::SubgroupFeatureFlags::SHUFFLE, "shuffle"),
        (vk::SubgroupFeatureFlags::CLUSTERED, "clustered"),
        (vk::SubgroupFeatureFlags::PARTITIONED_NV, "partitioned"),
    ] {
        if ops.contains(flag) {
            subgroup_operations.push(label);
        }
    }
    let mut missing = Vec::new();
    if vk::api_version_major(api) < 1 || (vk::api_version_major(api) == 1 && vk::api_version_minor(api) < 2) {
        missing.push(format!("Vulkan 1.2 (it offers {api_version})"));
    }
    if queue_family.is_none() {
        missing.push("a compute queue".into());
    }
    if !subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE) {
        missing.push("subgroup operations in compute shaders".into());
    }
    // What the kernels use: elect (basic), sums (arithmetic), ballots (ballot)
    // and the reduction's shuffles.
    for (flag, label) in [
        (vk::SubgroupFeatureFlags::BASIC, "basic"),
        (vk::SubgroupFeatureFlags::ARITHMETIC, "arithmetic"),
        (vk::SubgroupFeatureFlags::BALLOT, "ballot"),
        (vk::SubgroupFeatureFlags::SHUFFLE, "shuffle"),
    ] {
        if !ops.contains(flag) {
            missing.push(format!("subgroup {label} operations"));
        }
    }
    if !subgroup.subgroup_size.is_power_of_two() {
        missing.push(format!("a power-of-two subgroup size (it reports {})", subgroup.subgroup_size));
    }
    DeviceInfo {
        index,
        name,
        device_type,
        driver: format!("{driver_name} {driver_info}").trim().to_string(),
        api_version,
        subgroup_size: subgroup.subgroup_size,
        subgroup_operations,
        float_atomic_add,
        // RLPT_SUBGROUP_PARTITION=0 runs the portable ballot loop where the device
        // offers partitioning too (scripts/consistency.sh checks both).
        subgroup_partitioned: ops.contains(vk::SubgroupFeatureFlags::PARTITIONED_NV)
            && std::env::var("RLPT_SUBGROUP_PARTITION").map_or(true, |v| v != "0"),
        timestamp_period_ns: props.limits.timestamp_period,
        timestamps,
        max_compute_shared_memory: props.limits.max_compute_shared_memory_size,
        max_storage_buffer_range: props.limits.max_storage_buffer_range,
        device_memory,
        unified_memory,
        pipeline_statistics,
        missing,
        physical,
        queue_family: queue_family.unwrap_or(0) as u32,
        discrete: props.device_type == vk::PhysicalDeviceType::DISCRETE_GPU,
    }
}

fn enumerate(instance: &ash::Instance) -> Result<Vec<DeviceInfo>> {
    // SAFETY: plain enumeration on a live instance.
    let physicals = match unsafe { instance.enumerate_physical_devices() } {
        Ok(p) => p,
        Err(vk::Result::ERROR_INITIALIZATION_FAILED) => return Err(GpuError::NoDevice),
        Err(e) => return Err(GpuError::vk("vkEnumeratePhysicalDevices", e)),
    };
    if physicals.is_empty() {
        return Err(GpuError::NoDevice);
    }
    Ok(physicals.into_iter().enumerate().map(|(i, p)| describe(instance, i, p)).collect())
}

/// Every Vulkan device the loader finds, usable or not (`rlpt devices`).
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    let entry = load_entry()?;
    let instance = create_instance(&entry, false, None, None)?;
    let result = enumerate(&instance);
    // SAFETY: nothing made from the instance outlives it.
    unsafe { instance.destroy_instance(None) };
    result
}

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
        };
        ctx.set_name(ctx.queue, "rlpt queue");
        Ok(Arc::new(ctx))
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Number of warnings and errors the validation layer reported so far (0 when it is off).
    pub fn validation_messages(&self) -> u32 {
        self.messages.load(Ordering::SeqCst)
    }

    /// The count of [`validation_messages`](Self::validation_messages), readable after the
    /// context is dropped, so that messages at its destruction are seen too.
    pub fn validation_counter(&self) -> ValidationCounter {
        ValidationCounter(self.messages.clone())
    }

    /// True when the validation layer is on.
    pub fn validation_enabled(&self) -> bool {
        self.debug_instance.is_some()
    }

    /// Gives a Vulkan object a name that validation messages and debuggers show.
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(d) = &self.debug_device {
            let name = CString::new(name.replace('\0', " ")).unwrap_or_default();
            let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&name);
            // SAFETY: the handle belongs to this device. A failure to name is harmless.
            let _ = unsafe { d.set_debug_utils_object_name(&info) };
        }
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
    fn vk_error(&self, call: &'static str, result: vk::Result) -> GpuError {
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

    /// Records commands with `record`, submits them and waits for completion.
    pub fn run_commands(&self, name: &str, record: impl FnOnce(vk::CommandBuffer)) -> Result<()> {
        self.run_commands_synced(name, &[], &[], record)
    }

    /// [`run_commands`](Self::run_commands) whose submission first waits on `waits`
    /// (each semaphore at its stage) and signals `signals` when done (presentation).
    pub fn run_commands_synced(
        &self,
        name: &str,
        waits: &[(vk::Semaphore, vk::PipelineStageFlags)],
        signals: &[vk::Semaphore],
        record: impl FnOnce(vk::CommandBuffer),
    ) -> Result<()> {
        if self.is_lost() {
            return Err(GpuError::vk("vkQueueSubmit", vk::Result::ERROR_DEVICE_LOST));
        }
        let wait_semaphores: Vec<vk::Semaphore> = waits.iter().map(|w| w.0).collect();
        let wait_stages: Vec<vk::PipelineStageFlags> = waits.iter().map(|w| w.1).collect();
        let pool = self.command_pool.lock().unwrap_or_else(|e| e.into_inner());
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is locked for the duration; the command buffer is freed below.
        let cmd = unsafe { self.device.allocate_command_buffers(&alloc) }
            .map_err(|e| GpuError::vk("vkAllocateCommandBuffers", e))?[0];
        self.set_name(cmd, name);
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: fresh command buffer from our pool.
            unsafe { self.device.begin_command_buffer(cmd, &begin) }
                .map_err(|e| GpuError::vk("vkBeginCommandBuffer", e))?;
            record(cmd);
            // SAFETY: recording state.
            unsafe { self.device.end_command_buffer(cmd) }.map_err(|e| GpuError::vk("vkEndCommandBuffer", e))?;
            // SAFETY: plain fence.
            let fence = unsafe { self.device.create_fence(&vk::FenceCreateInfo::default(), None) }
                .map_err(|e| GpuError::vk("vkCreateFence", e))?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default()
                .command_buffers(&cmds)
                .wait_semaphores(&wait_semaphores)
                .wait_dst_stage_mask(&wait_stages)
                .signal_semaphores(signals)];
            // SAFETY: the queue is used from one thread at a time (the pool lock is held).
            let r = unsafe { self.device.queue_submit(self.queue, &submit, fence) }
                .map_err(|e| self.vk_error("vkQueueSubmit", e))
                // SAFETY: the fence was just submitted.
                .and_then(|_| {
                    unsafe { self.device.wait_for_fences(&[fence], true, u64::MAX) }
                        .map_err(|e| self.vk_error("vkWaitForFences", e))
                });
            // SAFETY: after the wait (or a failed submit) the fence is unused.
            unsafe { self.device.destroy_fence(fence, None) };
            r
        })();
        // SAFETY: the command buffer is no longer executing (waited above or never submitted).
        unsafe { self.device.free_command_buffers(*pool, &[cmd]) };
        result
    }

    /// Presents swapchain image `index` once `wait` is signalled, on the context's queue.
    /// `Ok(true)` when the swapchain no longer matches the surface (suboptimal or out of
    /// date) and should be recreated.
    pub fn present(
        &self,
        loader: &ash::khr::swapchain::Device,
        swapchain: vk::SwapchainKHR,
        index: u32,
        wait: vk::Semaphore,
    ) -> Result<bool> {
        // Queue access is serialised by the command pool's lock, as in run_commands.
        let _pool = self.command_pool.lock().unwrap_or_else(|e| e.into_inner());
        let (waits, swapchains, indices) = ([wait], [swapchain], [index]);
        let info =
            vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&swapchains).image_indices(&indices);
        // SAFETY: the swapchain belongs to this device and `index` was acquired from it.
        match unsafe { loader.queue_present(self.queue, &info) } {
            Ok(suboptimal) => Ok(suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(true),
            Err(e) => Err(self.vk_error("vkQueuePresentKHR", e)),
        }
    }

    /// A memory barrier making compute and transfer writes visible to later compute and transfer work.
    pub fn barrier(&self, cmd: vk::CommandBuffer) {
        let barrier = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(
                vk::AccessFlags::SHADER_READ
                    | vk::AccessFlags::SHADER_WRITE
                    | vk::AccessFlags::TRANSFER_READ
                    | vk::AccessFlags::TRANSFER_WRITE,
            )];
        let stages = vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER;
        // SAFETY: `cmd` is recording.
        unsafe {
            self.device.cmd_pipeline_barrier(cmd, stages, stages, vk::DependencyFlags::empty(), &barrier, &[], &[])
        };
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: every resource made from the context holds an Arc to it, so none is alive now;
        // objects are destroyed in reverse order of creation, the allocator before the device.
        unsafe {
            let _ = self.device.device_wait_idle();
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
