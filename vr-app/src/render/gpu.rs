//! The GPU context: instance, adapter, device and queue, with clear errors when there
//! is no adapter.

use crate::error::{AdapterError, GpuError, VrError, VrResult};

/// Environment variable naming the adapter to use (a case-insensitive substring of the
/// adapter's name, for example `llvmpipe` for lavapipe).
pub const ADAPTER_ENV: &str = "WANDSCULPT_ADAPTER";

/// A wgpu device with its queue and the adapter it came from.
#[derive(Debug, Clone)]
pub struct Gpu {
    /// The instance.
    pub instance: wgpu::Instance,
    /// The chosen adapter.
    pub adapter: wgpu::Adapter,
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// A device for offscreen rendering, with no window.
    ///
    /// The adapter is the one named by `WANDSCULPT_ADAPTER` (a name substring) if set,
    /// otherwise the best one available (a hardware GPU before lavapipe).
    pub fn headless() -> VrResult<Self> {
        let name = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty());
        Self::headless_named(name.as_deref())
    }

    /// A device on the adapter whose name contains `name` (case-insensitive), or the
    /// default adapter when `name` is `None`.
    pub fn headless_named(name: Option<&str>) -> VrResult<Self> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = match name {
            Some(want) => {
                let want_lc = want.to_lowercase();
                let adapters =
                    pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
                let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
                adapters
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&want_lc))
                    .ok_or_else(|| {
                        VrError::NoAdapter(AdapterError::NotNamed {
                            want: want.to_string(),
                            found: names,
                        })
                    })?
            }
            None => pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                ..Default::default()
            }))
            .map_err(|e| VrError::NoAdapter(AdapterError::Request(e)))?,
        };
        Self::from_adapter(instance, adapter)
    }

    /// Opens a device on `adapter`.
    pub fn from_adapter(instance: wgpu::Instance, adapter: wgpu::Adapter) -> VrResult<Self> {
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("wandsculpt"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            experimental_features: wgpu::ExperimentalFeatures::default(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|cause| {
            VrError::Gpu(GpuError::Device {
                adapter: adapter.get_info().name,
                cause,
            })
        })?;
        Ok(Self {
            instance,
            adapter,
            device,
            queue,
        })
    }

    /// A one-line description of the adapter (name, backend, type).
    pub fn describe(&self) -> String {
        let i = self.adapter.get_info();
        format!(
            "{} ({:?}, {:?}, driver {})",
            i.name, i.backend, i.device_type, i.driver_info
        )
    }

    /// True when this is Mesa's lavapipe (the CPU Vulkan driver used in CI).
    pub fn is_lavapipe(&self) -> bool {
        self.adapter
            .get_info()
            .name
            .to_lowercase()
            .contains("llvmpipe")
    }
}
