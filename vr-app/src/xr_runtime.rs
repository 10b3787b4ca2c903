//! OpenXR runtime glue (feature `openxr`): loads the OpenXR loader, creates an
//! instance and asks for a head-mounted display. With no loader or runtime it fails
//! with one clear message, and the app falls back to projection or desktop mode.
//! Rendering to the HMD's swapchains is a later step; the pure maths it will use is in
//! [`crate::xr`].

use crate::error::{VrError, VrResult, XrError};

/// What the runtime reported.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct XrRuntimeInfo {
    /// Runtime name and version.
    pub runtime: String,
    /// The head-mounted display's system name.
    pub system: String,
    /// Whether the runtime offers Vulkan interop (`XR_KHR_vulkan_enable2`).
    pub vulkan: bool,
}

/// The message shown when no OpenXR runtime can be used.
pub const NO_RUNTIME: &str = "no OpenXR runtime available: install the OpenXR loader \
    (libopenxr-loader1) and a runtime such as Monado or SteamVR, and set \
    XR_RUNTIME_JSON if it is not the active runtime";

/// Maps a failed runtime call at step `what` to [`XrError::Runtime`].
fn runtime(what: &'static str) -> impl Fn(openxr::sys::Result) -> VrError {
    move |cause| VrError::Xr(XrError::Runtime { what, cause })
}

/// Loads the OpenXR loader, creates an instance and finds a head-mounted display.
pub fn probe() -> VrResult<XrRuntimeInfo> {
    // SAFETY: `Entry::load` dlopens the system OpenXR loader (libopenxr_loader.so.1),
    // which the OpenXR specification defines; we call only core entry points on it.
    #[allow(unsafe_code)]
    let entry = unsafe { openxr::Entry::load(&()) }
        .map_err(|cause| VrError::Xr(XrError::Loader { cause }))?;
    let available = entry.enumerate_extensions().map_err(runtime(NO_RUNTIME))?;
    let mut wanted = openxr::ExtensionSet::default();
    wanted.khr_vulkan_enable2 = available.khr_vulkan_enable2;
    let app = openxr::ApplicationInfo {
        application_name: "wandsculpt",
        application_version: 1,
        engine_name: "wandsculpt",
        engine_version: 1,
        api_version: openxr::Version::new(1, 0, 0),
    };
    let instance = entry
        .create_instance(&app, &wanted, &[], &())
        .map_err(runtime("creating an instance"))?;
    let props = instance
        .properties()
        .map_err(runtime("runtime properties"))?;
    let system = instance
        .system(openxr::FormFactor::HEAD_MOUNTED_DISPLAY)
        .map_err(runtime("no head-mounted display is connected"))?;
    let sys_props = instance
        .system_properties(system)
        .map_err(runtime("system properties"))?;
    Ok(XrRuntimeInfo {
        runtime: format!("{} {}", props.runtime_name, props.runtime_version),
        system: sys_props.system_name,
        vulkan: available.khr_vulkan_enable2,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn probe_gives_a_result_or_the_clear_message() {
        // CI machines have no OpenXR runtime: the probe must fail with the message,
        // not panic. On a machine with a runtime it succeeds.
        match super::probe() {
            Ok(info) => assert!(!info.runtime.is_empty()),
            Err(e) => assert!(e.to_string().contains("OpenXR"), "{e}"),
        }
    }
}
