//! The Vulkan instance, the validation layer and its debug messenger.
//!
//! With validation on, `VK_LAYER_KHRONOS_validation` runs with synchronization
//! validation, and every message it sends is printed and counted in a
//! [`ValidationLog`] that outlives the instance, so a caller can check for
//! messages sent while the device and instance were destroyed (leaks).

use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

use ash::vk;

use super::driver_libraries::LoadedLibraries;
use crate::error::{Error, Result, VkResultExt};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Counts the warnings and errors the validation layer reported, and keeps
/// the first [`ValidationLog::KEPT`] messages.
#[derive(Debug, Default)]
pub struct ValidationLog {
    warnings: AtomicU32,
    errors: AtomicU32,
    messages: std::sync::Mutex<Vec<String>>,
}

impl ValidationLog {
    /// Number of validation warnings so far.
    pub fn warnings(&self) -> u32 {
        self.warnings.load(Ordering::SeqCst)
    }
    /// Number of validation errors so far.
    pub fn errors(&self) -> u32 {
        self.errors.load(Ordering::SeqCst)
    }
    /// Warnings plus errors.
    pub fn total(&self) -> u32 {
        self.warnings() + self.errors()
    }

    /// Messages kept.
    pub const KEPT: usize = 64;

    /// The first warnings and errors, as the layer wrote them.
    pub fn messages(&self) -> Vec<String> {
        self.messages
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    fn keep(&self, message: &str) {
        let mut kept = self.messages.lock().unwrap_or_else(|p| p.into_inner());
        if kept.len() < Self::KEPT {
            kept.push(message.to_string());
        }
    }
}

/// Called by the validation layer on its own threads; only touches atomics,
/// the log's mutex and stderr.
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes a valid callback-data struct for the duration of
    // the call; `user_data` is the `ValidationLog` that the Instance keeps alive
    // until after the messenger and the instance are destroyed.
    let (message, log) = unsafe {
        let message = if data.is_null() || (*data).p_message.is_null() {
            std::borrow::Cow::Borrowed("(no message)")
        } else {
            CStr::from_ptr((*data).p_message).to_string_lossy()
        };
        (message, &*(user_data as *const ValidationLog))
    };
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        log.errors.fetch_add(1, Ordering::SeqCst);
        log.keep(&message);
        eprintln!("[vulkan validation error] {kind:?}: {message}");
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log.warnings.fetch_add(1, Ordering::SeqCst);
        log.keep(&message);
        eprintln!("[vulkan validation warning] {kind:?}: {message}");
    } else {
        log::debug!("[vulkan] {message}");
    }
    vk::FALSE
}

/// What the Khronos validation layer checks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Validation {
    /// No layer.
    #[default]
    Off,
    /// The API rules and synchronization validation (hazards between
    /// commands): what every GPU test runs with.
    Synchronization,
    /// The API rules and GPU-assisted validation: shaders are instrumented
    /// to report out-of-bounds buffer and image accesses.
    GpuAssisted,
}

/// An `ash` instance with its optional debug messenger.
pub struct Instance {
    /// The loaded Vulkan library.
    pub entry: ash::Entry,
    /// The raw instance.
    pub raw: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    validation_log: Arc<ValidationLog>,
    validation: Validation,
    /// VK_EXT_debug_utils is enabled (names and labels can be set).
    debug_utils: bool,
    /// False for a host engine's instance: never destroyed here.
    owned: bool,
    /// What was mapped before this instance loaded Vulkan (None for a
    /// host's instance): what appeared since stays loaded.
    libraries_before: Option<LoadedLibraries>,
}

/// The layers and instance extensions to enable (the validation layer and
/// its features with `validation`; debug utils, for object names and
/// command labels in captures and validation messages, whenever the loader
/// offers it), and whether debug utils is among them.
fn layers_and_extensions(
    entry: &ash::Entry,
    validation: bool,
    extra_extensions: &[&CStr],
) -> Result<(Vec<*const i8>, Vec<*const i8>, bool)> {
    let mut layers = Vec::new();
    let mut extensions: Vec<*const i8> = extra_extensions.iter().map(|e| e.as_ptr()).collect();
    if validation {
        // SAFETY: plain enumeration on a loaded entry.
        let available = unsafe { entry.enumerate_instance_layer_properties() }
            .vk("vkEnumerateInstanceLayerProperties")?;
        let present = available
            .iter()
            .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
        if !present {
            return Err(Error::NoValidationLayer);
        }
        layers.push(VALIDATION_LAYER.as_ptr());
        extensions.push(ash::ext::validation_features::NAME.as_ptr());
    }
    // SAFETY: plain enumeration on a loaded entry.
    let debug_utils = validation
        || unsafe { entry.enumerate_instance_extension_properties(None) }
            .map(|exts| {
                exts.iter()
                    .any(|e| e.extension_name_as_c_str().ok() == Some(ash::ext::debug_utils::NAME))
            })
            .unwrap_or(false);
    if debug_utils {
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    Ok((layers, extensions, debug_utils))
}

impl Instance {
    /// Loads Vulkan and creates an instance for API 1.3. With `validation`,
    /// enables the Khronos layer with synchronization validation. Extra
    /// instance extensions (e.g. for surfaces) can be requested.
    pub fn new(validation: bool, extra_extensions: &[&CStr]) -> Result<Arc<Self>> {
        let mode = if validation {
            Validation::Synchronization
        } else {
            Validation::Off
        };
        Self::with_validation(mode, extra_extensions)
    }

    /// Like [`Instance::new`], choosing what the validation layer checks.
    pub fn with_validation(mode: Validation, extra_extensions: &[&CStr]) -> Result<Arc<Self>> {
        let validation = mode != Validation::Off;
        let libraries_before = LoadedLibraries::now();
        // SAFETY: loading the system Vulkan loader runs its initialisers; we
        // trust the installed loader like any Vulkan application must.
        let entry = unsafe { ash::Entry::load() }
            .map_err(|e| Error::NoDevice(format!("cannot load the Vulkan loader ({e})")))?;

        let validation_log = Arc::new(ValidationLog::default());
        let (layers, extensions, debug_utils) =
            layers_and_extensions(&entry, validation, extra_extensions)?;
        let app_info = vk::ApplicationInfo::default()
            .application_name(c"ssbc")
            .engine_name(c"ssbc")
            .api_version(vk::API_VERSION_1_3);
        let enabled_features: &[vk::ValidationFeatureEnableEXT] = match mode {
            Validation::GpuAssisted => &[
                vk::ValidationFeatureEnableEXT::GPU_ASSISTED,
                vk::ValidationFeatureEnableEXT::GPU_ASSISTED_RESERVE_BINDING_SLOT,
            ],
            _ => &[vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION],
        };
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(enabled_features);
        let user_data = Arc::as_ptr(&validation_log) as *mut c_void;
        let messenger_info = || {
            vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                        | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(user_data)
        };
        // Chained into the instance create info: also reports during
        // vkCreateInstance/vkDestroyInstance.
        let mut chained_messenger = messenger_info();
        let mut create_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if validation {
            create_info = create_info
                .push_next(&mut validation_features)
                .push_next(&mut chained_messenger);
        }
        // SAFETY: every pointer in create_info refers to locals alive here.
        let raw = unsafe { entry.create_instance(&create_info, None) }.map_err(|e| match e {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER | vk::Result::ERROR_INITIALIZATION_FAILED => {
                Error::NoDevice(format!("vkCreateInstance returned {e}"))
            }
            vk::Result::ERROR_EXTENSION_NOT_PRESENT => Error::NoDevice(
                "an instance extension ssbc needs is missing (debug utils, validation features or surface)".into(),
            ),
            result => Error::Vulkan { call: "vkCreateInstance", result },
        })?;
        libraries_before.pin_new();

        let debug = if validation {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &raw);
            // SAFETY: valid instance; messenger_info's user data outlives the
            // messenger (destroyed in Drop before validation_log).
            let messenger = unsafe { loader.create_debug_utils_messenger(&messenger_info(), None) };
            match messenger {
                Ok(m) => Some((loader, m)),
                Err(result) => {
                    // SAFETY: nothing was created from this instance yet.
                    unsafe { raw.destroy_instance(None) };
                    return Err(Error::Vulkan {
                        call: "vkCreateDebugUtilsMessengerEXT",
                        result,
                    });
                }
            }
        } else {
            None
        };
        Ok(Arc::new(Self {
            entry,
            raw,
            debug,
            validation_log,
            validation: mode,
            debug_utils,
            owned: true,
            libraries_before: Some(libraries_before),
        }))
    }

    /// Wraps an instance a host engine created and owns (API 1.3). ssbc
    /// never destroys it; validation, if any, is the host's.
    pub fn from_host(entry: ash::Entry, raw: ash::Instance) -> Arc<Self> {
        Arc::new(Self {
            entry,
            raw,
            debug: None,
            validation_log: Arc::default(),
            validation: Validation::Off,
            debug_utils: false,
            owned: false,
            libraries_before: None,
        })
    }

    /// What the validation layer checks on this instance.
    pub fn validation_mode(&self) -> Validation {
        self.validation
    }

    /// Whether VK_EXT_debug_utils is enabled (ssbc then names its objects
    /// and labels its passes).
    pub fn debug_utils_enabled(&self) -> bool {
        self.debug_utils
    }

    /// Whether ssbc enabled the validation layer on this instance.
    pub fn validation_enabled(&self) -> bool {
        self.debug.is_some()
    }

    /// The counter of validation messages; stays valid after the instance is
    /// gone, so leaks reported at destruction are visible too.
    pub fn validation_log(&self) -> Arc<ValidationLog> {
        self.validation_log.clone()
    }

    /// Keeps what Vulkan loaded since this instance began (the driver's
    /// libraries, some loaded only with a device) mapped for good: see
    /// driver_libraries.rs. Nothing for a host's instance.
    pub(crate) fn pin_driver_libraries(&self) {
        if let Some(before) = &self.libraries_before {
            before.pin_new();
        }
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: every device of this instance holds an Arc to it and has
        // been destroyed before this runs.
        unsafe {
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            if self.owned {
                self.raw.destroy_instance(None);
            }
        }
    }
}
