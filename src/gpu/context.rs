//! Choosing an adapter and opening a device with the adapter's real limits.

use std::sync::{Arc, Mutex};

/// An open device, and where its asynchronous errors land (wgpu's default handler would panic).
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
    errors: Arc<Mutex<Vec<String>>>,
}

/// Set to 1 (as CI does) to turn "no adapter" from a skip into a failure in the GPU tests.
pub const REQUIRE_ADAPTER_ENV: &str = "HOOKE_REQUIRE_ADAPTER";

fn describe(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
}

/// All adapters wgpu can see, best first (discrete, integrated, virtual, CPU).
pub fn adapters() -> Vec<wgpu::Adapter> {
    // wgpu's own variables (WGPU_BACKEND, WGPU_ADAPTER_NAME, …) are honoured.
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let mut all = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
    let rank = |t: wgpu::DeviceType| match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    // Vulkan before GL for the same device: it has timestamp queries and more limits.
    let backend_rank = |b: wgpu::Backend| if b == wgpu::Backend::Gl { 1 } else { 0 };
    all.sort_by_key(|a| {
        let i = a.get_info();
        (rank(i.device_type), backend_rank(i.backend))
    });
    all
}

/// What an asynchronous device error means for the user.
pub fn describe_error(e: &wgpu::Error) -> String {
    match e {
        wgpu::Error::OutOfMemory { .. } => format!(
            "the GPU ran out of memory ({e}). Free GPU memory (other processes: nvidia-smi), \
             use a smaller grid, or run with --backend cpu"
        ),
        _ => e.to_string(),
    }
}

/// What a lost device means for the user.
pub fn describe_loss(reason: wgpu::DeviceLostReason, message: &str) -> String {
    let why = match reason {
        wgpu::DeviceLostReason::Destroyed => "the device was destroyed".to_owned(),
        wgpu::DeviceLostReason::Unknown => format!("the device was lost: {message}"),
    };
    format!(
        "{why}. The driver may have reset or the GPU gone away; check it (nvidia-smi, dmesg) and \
         run again, or run with --backend cpu"
    )
}

impl GpuContext {
    /// Open the best adapter, or the first whose name contains `name` (case-insensitive).
    pub fn open(name: Option<&str>) -> Result<Self, String> {
        let all = adapters();
        if all.is_empty() {
            return Err("no GPU adapter found (wgpu sees no Vulkan, Metal, DX12 or GL device). \
                 Run with `--backend cpu`, or on Linux without a GPU install Mesa's software Vulkan: \
                 `apt-get install mesa-vulkan-drivers libvulkan1`"
                .to_owned());
        }
        let adapter = match name {
            None => all.into_iter().next(),
            Some(want) => {
                let names: Vec<String> = all.iter().map(|a| describe(&a.get_info())).collect();
                let want_l = want.to_lowercase();
                all.into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&want_l))
                    .ok_or_else(|| {
                        format!(
                            "no adapter matches --adapter '{want}'; available: {}",
                            names.join("; ")
                        )
                    })
                    .map(Some)?
            }
        }
        .ok_or_else(|| "no adapter".to_owned())?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let wanted =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        let features = adapter.features() & wanted;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("hooke"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| format!("opening {} failed: {e}", describe(&info)))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(describe_error(&e));
            }
        }));
        // A reset driver, a removed card or a destroyed device: later calls fail; say why first.
        let sink = errors.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut v) = sink.lock() {
                v.insert(0, describe_loss(reason, &message));
            }
        });
        Ok(Self {
            device,
            queue,
            info,
            limits,
            features,
            errors,
        })
    }

    pub fn describe(&self) -> String {
        describe(&self.info)
    }

    /// Lose the device on purpose, as a driver reset would (for fault tests).
    pub fn lose_device(&self) {
        self.device.destroy();
    }

    /// The first error the device reported since the last call, if any.
    pub fn take_error(&self) -> Option<String> {
        self.errors.lock().ok().and_then(|mut v| {
            if v.is_empty() {
                None
            } else {
                Some(v.remove(0))
            }
        })
    }
}
