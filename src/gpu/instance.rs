//! Loading the Vulkan loader and making an instance (with the validation layer when asked).

use super::context::{GpuError, Result};
use super::validation::VALIDATION_LAYER;
use ash::vk;
use std::ffi::CStr;

pub(super) fn load_entry() -> Result<ash::Entry> {
    // SAFETY: loading the system Vulkan loader; ash checks the library's entry points.
    unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoLoader(e.to_string()))
}

pub(super) fn create_instance(
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
