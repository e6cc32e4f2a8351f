//! Finding an adapter and opening a device, for headless use or for a window surface.

use super::error::RenderError;

/// The wgpu objects every renderer needs. Fields are public so a window can share them with e.g. egui.
#[derive(Debug)]
pub struct Gpu {
    /// The wgpu instance the adapter came from (needed to create surfaces).
    pub instance: wgpu::Instance,
    /// The physical (or software) adapter.
    pub adapter: wgpu::Adapter,
    /// The logical device.
    pub device: wgpu::Device,
    /// The device's command queue.
    pub queue: wgpu::Queue,
}

/// Memory a render target takes per pixel across its textures and read-back copies (measured: peak
/// resident memory of `render` at 4096x4096 on llvmpipe, rounded up).
const BYTES_PER_PIXEL: u64 = 64;

impl Gpu {
    /// Open a device without any window: tries a high-performance adapter, then a fallback (software)
    /// adapter, then any adapter at all. Honours `WGPU_BACKEND` and related environment variables.
    pub fn new_headless() -> Result<Self, RenderError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pick_adapter(&instance, None)?;
        Self::from_adapter(instance, adapter)
    }

    /// Open a device whose adapter can present to `surface` (created from `instance` by the window code).
    pub fn for_surface(instance: wgpu::Instance, surface: &wgpu::Surface<'_>) -> Result<Self, RenderError> {
        let adapter = pick_adapter(&instance, Some(surface))?;
        Self::from_adapter(instance, adapter)
    }

    /// Open a device on an adapter chosen by the caller.
    pub fn from_adapter(instance: wgpu::Instance, adapter: wgpu::Adapter) -> Result<Self, RenderError> {
        // Ask for the adapter's real format capabilities (e.g. MSAA counts) when it can report them.
        let required_features = adapter.features() & wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
        let desc = wgpu::DeviceDescriptor {
            label: Some("shellwarp device"),
            required_features,
            required_limits: adapter.limits(),
            ..Default::default()
        };
        let (device, queue) =
            pollster::block_on(adapter.request_device(&desc)).map_err(|e| RenderError::RequestDevice(e.to_string()))?;
        Ok(Self { instance, adapter, device, queue })
    }

    /// Human-readable adapter name, e.g. `llvmpipe (LLVM 19.1.7, 256 bits)`.
    pub fn adapter_name(&self) -> String {
        self.adapter.get_info().name
    }

    /// Run `f` inside out-of-memory and validation error scopes, so that wgpu errors it causes come
    /// back as one-line [`RenderError::Gpu`]s instead of panicking in wgpu's uncaptured-error handler.
    pub(crate) fn scoped<T>(
        &self,
        context: &'static str,
        f: impl FnOnce() -> Result<T, RenderError>,
    ) -> Result<T, RenderError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let result = f();
        // Innermost scope first; an unpopped scope is popped when its guard drops.
        for scope in [validation, oom] {
            if let Some(err) = pollster::block_on(scope.pop()) {
                return Err(RenderError::gpu(context, &err));
            }
        }
        result
    }

    /// Refuse empty render targets, ones larger than the device allows, and ones that would need more
    /// memory than the machine has (on a software adapter the GPU's memory is the machine's).
    pub(crate) fn check_size(&self, (width, height): (u32, u32)) -> Result<(), RenderError> {
        let pixels = u64::from(width) * u64::from(height);
        crate::memory::check(crate::memory::times(pixels, BYTES_PER_PIXEL), || format!("a {width}x{height} picture"))?;
        let max = self.device.limits().max_texture_dimension_2d;
        let reason = if width == 0 || height == 0 {
            "width and height must be positive".to_string()
        } else if width > max || height > max {
            format!("this GPU allows at most {max} pixels per side")
        } else {
            return Ok(());
        };
        Err(RenderError::BadSize { width, height, reason })
    }

    /// Whether textures of `format` can be rendered with `count` samples per pixel on this device.
    pub fn supports_sample_count(&self, format: wgpu::TextureFormat, count: u32) -> bool {
        if count <= 1 {
            return true;
        }
        let adapter_ok = self.adapter.get_texture_format_features(format).flags.sample_count_supported(count);
        // Without the adapter-specific feature, wgpu validates against the WebGPU guarantees only.
        let device_features = self.device.features();
        let device_ok = device_features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES)
            || format.guaranteed_format_features(device_features).flags.sample_count_supported(count);
        adapter_ok && device_ok
    }
}

/// Try, in order: high performance, forced fallback, then the first adapter the instance lists.
fn pick_adapter(instance: &wgpu::Instance, surface: Option<&wgpu::Surface<'_>>) -> Result<wgpu::Adapter, RenderError> {
    for force_fallback_adapter in [false, true] {
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter,
            compatible_surface: surface,
            ..Default::default()
        };
        if let Ok(adapter) = pollster::block_on(instance.request_adapter(&options)) {
            return Ok(adapter);
        }
    }
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
    adapters.into_iter().find(|a| surface.is_none_or(|s| a.is_surface_supported(s))).ok_or(RenderError::NoAdapter)
}
