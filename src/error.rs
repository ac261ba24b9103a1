//! The error type of the crate: every failure a user can cause ends here as a
//! one-line message, never as a panic.

use ash::vk;

/// Everything that can go wrong in ssbc.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene file is missing, malformed, or asks for something refused.
    #[error("scene {path}: {message}")]
    Scene {
        /// The scene that failed (file path or built-in name).
        path: String,
        /// What is wrong with it.
        message: String,
    },
    /// A parameter is outside what ssbc or the device supports.
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// No usable Vulkan implementation.
    #[error(
        "no usable Vulkan device: {0}. On Debian/Ubuntu install the CPU driver (Mesa lavapipe) and \
         loader with `apt-get install mesa-vulkan-drivers libvulkan1` (or run scripts/setup.sh)"
    )]
    NoDevice(String),
    /// No window could be opened (`ssbc view`): no display, or a window-system
    /// library is missing (the message names it and its Debian package).
    #[error("cannot open a window: {0}")]
    WindowSystem(String),
    /// Validation was asked for but the layer is not installed.
    #[error(
        "validation requested but VK_LAYER_KHRONOS_validation is not installed \
         (`apt-get install vulkan-validationlayers`, or run scripts/setup.sh)"
    )]
    NoValidationLayer,
    /// A Vulkan call failed.
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan {
        /// The function that failed.
        call: &'static str,
        /// Its result code.
        result: vk::Result,
    },
    /// GPU memory could not be allocated.
    #[error("GPU memory allocation failed: {0}")]
    Allocation(#[from] gpu_allocator::AllocationError),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// An output image could not be encoded.
    #[error("writing {path}: {message}")]
    Output {
        /// The output file.
        path: String,
        /// What failed.
        message: String,
    },
}

/// Result with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

unstable_pub! {
    /// Maps a `vk::Result` error into [`Error::Vulkan`], naming the call
    /// (unstable).
    trait VkResultExt<T> {
        /// Attach the Vulkan function name to the error.
        fn vk(self, call: &'static str) -> Result<T>;
    }
}

impl<T> VkResultExt<T> for Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}

impl Error {
    pub(crate) fn scene(path: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Scene {
            path: path.into(),
            message: message.into(),
        }
    }
    pub(crate) fn io(path: impl AsRef<std::path::Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().display().to_string(),
            source,
        }
    }
}
