//! The Vulkan devices the loader finds: what each is and whether rlpt can use it.

use super::context::{GpuError, Result};
use super::instance::{create_instance, load_entry};
use ash::vk;
use std::ffi::CStr;

/// What a device is and whether rlpt can use it.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub device_type: String,
    /// The device is a CPU (`VK_PHYSICAL_DEVICE_TYPE_CPU`: lavapipe): a few cores,
    /// and a fixed cost for every workgroup a dispatch starts.
    pub cpu: bool,
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
    /// `maxStorageBufferRange`: the largest storage buffer a shader can address.
    pub max_storage_buffer_range: u32,
    /// Bytes of the largest device-local memory heap: what buffers that shaders
    /// read and write are allocated from (see [`DEVICE_MEMORY_HOOK`](super::DEVICE_MEMORY_HOOK) for tests).
    pub device_memory: u64,
    /// Every memory heap is device-local (lavapipe, integrated GPUs): host-visible
    /// buffers (uploads, readbacks) take the same memory as the device's own.
    pub unified_memory: bool,
    /// `VK_KHR_pipeline_executable_properties`: the driver reports each pipeline's
    /// register and memory use (`rlpt bench`).
    pub pipeline_statistics: bool,
    /// What rlpt requires and this device lacks; empty if usable.
    pub missing: Vec<String>,
    pub(super) physical: vk::PhysicalDevice,
    pub(super) queue_family: u32,
    pub(super) discrete: bool,
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
    let cpu = props.device_type == vk::PhysicalDeviceType::CPU;
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
        cpu,
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

pub(super) fn enumerate(instance: &ash::Instance) -> Result<Vec<DeviceInfo>> {
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
