//! The Vulkan instance and device made through the OpenXR runtime, adopted by wgpu's
//! Vulkan HAL.

use super::*;

/// The wgpu device on the runtime's Vulkan device, with the raw handles OpenXR needs.
pub(super) struct XrVulkan {
    pub(super) gpu: Gpu,
    pub(super) raw_instance: vk::Instance,
    pub(super) physical_device: vk::PhysicalDevice,
    pub(super) raw_device: vk::Device,
    pub(super) queue_family: u32,
}

pub(super) fn hal_err(
    what: &'static str,
) -> impl Fn(Box<dyn std::error::Error + Send + Sync>) -> VrError {
    move |cause| VrError::Xr(XrError::Hal { what, cause })
}

pub(super) fn vk_err(what: &'static str) -> impl Fn(vk::Result) -> VrError {
    move |cause| VrError::Xr(XrError::Vulkan { what, cause })
}

/// Where the raw Vulkan instance and device come from: the OpenXR runtime
/// ([`XrVulkanSource`]), or, in tests, plain Vulkan calls.
pub(super) trait VulkanSource {
    /// Checks the instance's API version against the source's limits.
    fn check_version(&self, api_version: u32) -> VrResult<()>;
    /// Creates the instance from `info`.
    fn create_instance(
        &self,
        entry: &ash::Entry,
        info: &vk::InstanceCreateInfo<'_>,
    ) -> VrResult<vk::Instance>;
    /// The physical device to use.
    fn physical_device(&self, instance: &ash::Instance) -> VrResult<vk::PhysicalDevice>;
    /// Creates the device from `info`.
    fn create_device(
        &self,
        entry: &ash::Entry,
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        info: &vk::DeviceCreateInfo<'_>,
    ) -> VrResult<vk::Device>;
}

/// The runtime creates the Vulkan objects (`XR_KHR_vulkan_enable2`) and chooses the
/// physical device.
pub(super) struct XrVulkanSource<'a> {
    pub(super) instance: &'a xr::Instance,
    pub(super) system: xr::SystemId,
    pub(super) reqs: <xr::Vulkan as xr::Graphics>::Requirements,
}

/// `vkGetInstanceProcAddr` of `entry` as openxr-sys declares it.
pub(super) fn xr_get_instance_proc_addr(
    entry: &ash::Entry,
) -> xr::sys::platform::VkGetInstanceProcAddr {
    // SAFETY: both function pointer types are `vkGetInstanceProcAddr` as the Vulkan
    // ABI defines it (openxr-sys and ash declare it separately).
    unsafe {
        std::mem::transmute::<vk::PFN_vkGetInstanceProcAddr, xr::sys::platform::VkGetInstanceProcAddr>(
            entry.static_fn().get_instance_proc_addr,
        )
    }
}

impl VulkanSource for XrVulkanSource<'_> {
    fn check_version(&self, api_version: u32) -> VrResult<()> {
        let have = xr::Version::new(
            vk::api_version_major(api_version) as u16,
            vk::api_version_minor(api_version) as u16,
            0,
        );
        if have < self.reqs.min_api_version_supported
            || have.major() > self.reqs.max_api_version_supported.major()
        {
            return Err(VrError::Xr(XrError::VulkanVersion {
                min: self.reqs.min_api_version_supported.to_string(),
                max: self.reqs.max_api_version_supported.to_string(),
                have: have.to_string(),
            }));
        }
        Ok(())
    }

    fn create_instance(
        &self,
        entry: &ash::Entry,
        info: &vk::InstanceCreateInfo<'_>,
    ) -> VrResult<vk::Instance> {
        // SAFETY: `info` and everything it points to live until the call returns; the
        // runtime adds the extensions it needs and creates the instance.
        let raw = unsafe {
            self.instance.create_vulkan_instance(
                self.system,
                xr_get_instance_proc_addr(entry),
                std::ptr::from_ref(info).cast(),
            )
        }
        .map_err(runtime("xrCreateVulkanInstanceKHR"))?
        .map_err(|r| vk_err("creating the Vulkan instance")(vk::Result::from_raw(r)))?;
        Ok(vk::Instance::from_raw(raw as u64))
    }

    fn physical_device(&self, instance: &ash::Instance) -> VrResult<vk::PhysicalDevice> {
        // SAFETY: the runtime reads the instance we created through it.
        let raw = unsafe {
            self.instance.vulkan_graphics_device(
                self.system,
                instance.handle().as_raw() as xr::sys::platform::VkInstance,
            )
        }
        .map_err(runtime("xrGetVulkanGraphicsDevice2KHR"))?;
        Ok(vk::PhysicalDevice::from_raw(raw as u64))
    }

    fn create_device(
        &self,
        entry: &ash::Entry,
        _instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        info: &vk::DeviceCreateInfo<'_>,
    ) -> VrResult<vk::Device> {
        // SAFETY: `info` and its chain live until the call returns; the physical
        // device is the runtime's own choice.
        let raw = unsafe {
            self.instance.create_vulkan_device(
                self.system,
                xr_get_instance_proc_addr(entry),
                physical_device.as_raw() as xr::sys::platform::VkPhysicalDevice,
                std::ptr::from_ref(info).cast(),
            )
        }
        .map_err(runtime("xrCreateVulkanDeviceKHR"))?
        .map_err(|r| vk_err("creating the Vulkan device")(vk::Result::from_raw(r)))?;
        Ok(vk::Device::from_raw(raw as u64))
    }
}

/// Creates the Vulkan instance and device through `source` and hands them to wgpu
/// through its Vulkan HAL.
pub(super) fn adopt_vulkan(source: &impl VulkanSource) -> VrResult<XrVulkan> {
    // SAFETY: loads the system Vulkan loader (libvulkan.so.1), kept loaded by the entry.
    let vk_entry =
        unsafe { ash::Entry::load() }.map_err(|e| VrError::Xr(XrError::VulkanLoader(e)))?;
    // SAFETY: a global Vulkan query with no handles involved.
    let have = unsafe { vk_entry.try_enumerate_instance_version() }
        .map_err(vk_err("vkEnumerateInstanceVersion"))?
        .unwrap_or(vk::API_VERSION_1_0);
    // wgpu-hal uses at most Vulkan 1.3.
    let api_version = have.min(vk::API_VERSION_1_3);
    source.check_version(api_version)?;
    let flags = wgpu::InstanceFlags::empty();
    let extensions = hal::vulkan::Instance::desired_extensions(&vk_entry, api_version, flags)
        .map_err(|e| hal_err("Vulkan instance extensions")(Box::new(e)))?;
    let extension_ptrs: Vec<*const std::ffi::c_char> =
        extensions.iter().map(|e| e.as_ptr()).collect();
    let vk_app = vk::ApplicationInfo::default()
        .application_name(c"wandsculpt")
        .engine_name(c"wandsculpt")
        .api_version(api_version);
    let create_info = vk::InstanceCreateInfo::default()
        .application_info(&vk_app)
        .enabled_extension_names(&extension_ptrs);
    let raw_instance = source.create_instance(&vk_entry, &create_info)?;
    // SAFETY: `raw_instance` was just created from `vk_entry`'s loader.
    let ash_instance = unsafe { ash::Instance::load(vk_entry.static_fn(), raw_instance) };
    let physical_device = source.physical_device(&ash_instance)?;
    // SAFETY: `ash_instance` was created from `vk_entry` with `api_version`, exactly
    // `extensions` (a superset of `desired_extensions`; the runtime may add more) and
    // `flags`; with no drop callback, wgpu-hal owns and destroys the instance.
    let hal_instance = unsafe {
        hal::vulkan::Instance::from_raw(
            vk_entry.clone(),
            ash_instance.clone(),
            api_version,
            0,
            None,
            extensions,
            flags,
            wgpu::MemoryBudgetThresholds::default(),
            false,
            None,
        )
    }
    .map_err(|e| hal_err("adopting the Vulkan instance")(Box::new(e)))?;
    let exposed = hal_instance
        .expose_adapter(physical_device)
        .ok_or_else(|| hal_err("the physical device")("wgpu cannot use it".into()))?;
    // SAFETY: a query on a physical device of this instance.
    let queue_family =
        unsafe { ash_instance.get_physical_device_queue_family_properties(physical_device) }
            .iter()
            .position(|q| q.queue_flags.contains(vk::QueueFlags::GRAPHICS))
            .ok_or_else(|| hal_err("the physical device")("no graphics queue".into()))?
            as u32;
    let features = wgpu::Features::empty();
    let device_extensions = exposed.adapter.required_device_extensions(features);
    let mut device_features = exposed
        .adapter
        .physical_device_features(&device_extensions, features);
    let device_extension_ptrs: Vec<*const std::ffi::c_char> =
        device_extensions.iter().map(|e| e.as_ptr()).collect();
    let priorities = [1.0f32];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let device_info = device_features.add_to_device_create(
        vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(&device_extension_ptrs),
    );
    let raw_device =
        source.create_device(&vk_entry, &ash_instance, physical_device, &device_info)?;
    // SAFETY: `raw_device` was just created on `ash_instance`.
    let ash_device = unsafe { ash::Device::load(ash_instance.fp_v1_0(), raw_device) };
    let limits =
        wgpu::Limits::downlevel_defaults().using_resolution(exposed.capabilities.limits.clone());
    // SAFETY: the device was created from this adapter's physical device with queue
    // family `queue_family`, `device_extensions` (what wgpu requires for `features`)
    // and `physical_device_features()`; with no drop callback wgpu-hal owns it.
    let open = unsafe {
        exposed.adapter.device_from_raw(
            ash_device,
            None,
            &device_extensions,
            features,
            &limits,
            &wgpu::MemoryHints::Performance,
            queue_family,
            0,
        )
    }
    .map_err(|e| hal_err("adopting the Vulkan device")(Box::new(e)))?;
    // SAFETY: `hal_instance` is a valid Vulkan HAL instance; `exposed` and `open` come
    // from it.
    let wgpu_instance = unsafe { wgpu::Instance::from_hal::<hal::api::Vulkan>(hal_instance) };
    // SAFETY: see above.
    let adapter = unsafe { wgpu_instance.create_adapter_from_hal(exposed) };
    // SAFETY: `open` was opened on `adapter`'s HAL adapter with these limits.
    let (device, queue) = unsafe {
        adapter.create_device_from_hal(
            open,
            &wgpu::DeviceDescriptor {
                label: Some("wandsculpt xr"),
                required_features: features,
                required_limits: limits,
                experimental_features: wgpu::ExperimentalFeatures::default(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            },
        )
    }
    .map_err(|e| hal_err("creating the wgpu device")(Box::new(e)))?;
    Ok(XrVulkan {
        gpu: Gpu {
            instance: wgpu_instance,
            adapter,
            device,
            queue,
        },
        raw_instance,
        physical_device,
        raw_device,
        queue_family,
    })
}

/// Creates the Vulkan instance and device through the runtime and hands them to wgpu.
pub(super) fn create_vulkan(instance: &xr::Instance, system: xr::SystemId) -> VrResult<XrVulkan> {
    let reqs = instance
        .graphics_requirements::<xr::Vulkan>(system)
        .map_err(runtime("Vulkan graphics requirements"))?;
    adopt_vulkan(&XrVulkanSource {
        instance,
        system,
        reqs,
    })
}
