//! What is wrong on the OpenXR path.

use thiserror::Error;

/// What is wrong on the OpenXR path.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum XrError {
    /// A view's field of view is not a valid frustum (left, right, up, down in
    /// radians).
    #[error("invalid field of view {0:?} (left, right, up, down)")]
    Fov([f64; 4]),
    /// The clip planes are not `0 < near < far`.
    #[error("need 0 < near < far")]
    ClipPlanes,
    /// An eye or stage pose is not finite.
    #[error("eye pose is not finite")]
    EyePose,
    /// The OpenXR loader could not be loaded.
    #[cfg(feature = "openxr")]
    #[error("no loader: libopenxr_loader.so.1 did not load ({cause}); install libopenxr-loader1")]
    Loader {
        /// The loader's reason.
        cause: openxr::EntryError,
    },
    /// The loader found no usable runtime; `hint` says what is missing.
    #[cfg(feature = "openxr")]
    #[error("no runtime: {hint} ({cause})")]
    NoRuntime {
        /// What is missing (the runtime manifest named by `XR_RUNTIME_JSON`, or any
        /// active runtime).
        hint: String,
        /// The loader's result code.
        cause: openxr::sys::Result,
    },
    /// The runtime cannot share Vulkan images (`XR_KHR_vulkan_enable2`).
    #[cfg(feature = "openxr")]
    #[error("the OpenXR runtime {runtime} does not offer XR_KHR_vulkan_enable2")]
    NoVulkanEnable2 {
        /// The runtime's name.
        runtime: String,
    },
    /// The Vulkan loader could not be loaded.
    #[cfg(feature = "openxr")]
    #[error("no Vulkan loader: {0}")]
    VulkanLoader(#[source] ash::LoadingError),
    /// A Vulkan call made for the runtime failed; `what` names the step.
    #[cfg(feature = "openxr")]
    #[error("{what}: {cause}")]
    Vulkan {
        /// The step.
        what: &'static str,
        /// Vulkan's result.
        cause: ash::vk::Result,
    },
    /// The runtime's Vulkan version range excludes what wgpu can use.
    #[cfg(feature = "openxr")]
    #[error("the OpenXR runtime needs Vulkan {min} to {max}; this Vulkan offers {have}")]
    VulkanVersion {
        /// The runtime's minimum.
        min: String,
        /// The runtime's maximum.
        max: String,
        /// The instance's version.
        have: String,
    },
    /// wgpu could not adopt the runtime's Vulkan instance, device or images.
    #[cfg(feature = "openxr")]
    #[error("wgpu on the runtime's Vulkan device: {what}: {cause}")]
    Hal {
        /// The step.
        what: &'static str,
        /// wgpu's reason.
        #[source]
        cause: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A file of the headset session (pose log header, replay config) could not be
    /// encoded.
    #[error("encoding {what}: {cause}")]
    Encode {
        /// The file.
        what: &'static str,
        /// The encoder's reason.
        #[source]
        cause: Box<dyn std::error::Error + Send + Sync>,
    },
    /// None of the swapchain formats the runtime offers is one the renderer draws.
    #[error("no usable swapchain format among {0:?} (VkFormat values)")]
    SwapchainFormat(Vec<i64>),
    /// A runtime call failed; `what` names the step.
    #[cfg(feature = "openxr")]
    #[error("{what}: {cause}")]
    Runtime {
        /// The step (`creating an instance`, `no head-mounted display is connected`).
        what: &'static str,
        /// The runtime's result code.
        cause: openxr::sys::Result,
    },
}
