//! The Khronos validation layer's messages, counted per context and per process,
//! and the debug names it shows.

use super::context::Context;
use ash::vk;
use std::ffi::{c_void, CStr, CString};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

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

pub(super) const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

pub(super) unsafe extern "system" fn debug_callback(
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

impl Context {
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
}
