//! Choosing an adapter and opening a device with the adapter's real limits; waiting on it, and
//! what its errors mean for the user.

use std::sync::atomic::AtomicUsize;
use std::sync::{Arc, Mutex};

use crate::backend::BackendError;

/// Why no device could be opened for a run, or the scene does not fit the one opened; each says
/// what would fix it.
#[derive(Debug, thiserror::Error)]
pub enum AdapterError {
    #[error(
        "no GPU adapter found (wgpu sees no Vulkan, Metal, DX12 or GL device). \
         Run with `--backend cpu`, or on Linux without a GPU install Mesa's software Vulkan: \
         `apt-get install mesa-vulkan-drivers libvulkan1`"
    )]
    NoAdapter,
    #[error("no adapter matches --adapter '{want}'; available: {}", available.join("; "))]
    NoMatch {
        want: String,
        available: Vec<String>,
    },
    #[error("opening {adapter} failed: {source}")]
    RequestDevice {
        adapter: String,
        source: wgpu::RequestDeviceError,
    },
    #[error(
        "the scene is too large for {adapter}: its {what} buffer needs {bytes} bytes, the adapter allows {limit} bytes per storage buffer \
         ({masses} masses, {springs} springs). Use a smaller grid or --backend cpu"
    )]
    BufferTooLarge {
        adapter: String,
        what: &'static str,
        bytes: u64,
        limit: u64,
        masses: u64,
        springs: u64,
    },
    #[error(
        "the model has {colliders} colliders; the GPU backend passes at most {max} (their poses \
         ride in each stage's uniform slot). Use fewer colliders or --backend cpu"
    )]
    TooManyColliders { colliders: usize, max: usize },
    #[error(
        "{adapter} allows {allowed} storage buffers per shader stage; Hooke's kernels need {needed}. Use --backend cpu"
    )]
    TooFewStorageBuffers {
        adapter: String,
        allowed: u32,
        needed: u32,
    },
}

/// What stops a run on an open device, or before the GPU backend takes a run at all.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// The run's integrator cannot simulate one of its effects (`Integrator::supports`).
    #[error("{0} ([{field}]): use {instead}", field = .0.scene_field(), instead = .0.instead(""))]
    Unsupported(#[from] crate::integrator::Unsupported),
    /// An asynchronous error, or the device lost (the first reported).
    #[error("the GPU reported an error on {adapter}: {fault}")]
    Reported { adapter: String, fault: Fault },
    #[error("waiting for {adapter} failed: {cause}")]
    Wait {
        adapter: String,
        cause: wgpu::PollError,
    },
    #[error("reading {what} back from {adapter} failed: {cause}")]
    ReadBack {
        what: ReadBackOf,
        adapter: String,
        cause: ReadBackCause,
    },
}

/// What the device reported on its own: an error its callback caught, or its loss. Its message
/// says what the user can do about it.
#[derive(Debug)]
pub enum Fault {
    Error(wgpu::Error),
    Lost {
        reason: wgpu::DeviceLostReason,
        /// The driver's own words.
        message: String,
    },
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fault::Error(e) => f.write_str(&describe_error(e)),
            Fault::Lost { reason, message } => f.write_str(&describe_loss(*reason, message)),
        }
    }
}

/// What a read-back was for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadBackOf {
    /// A frame's snapshot (positions, strain, energies, counters).
    Snapshot,
    /// Implicit Euler's solve record of a frame.
    SolverStatus,
    /// The per-kernel timestamps of `bench throughput`.
    Timestamps,
    /// The hash grid (a test hook).
    Grid,
    /// The adapter's probes (`loop_budget`).
    Probe,
}

impl std::fmt::Display for ReadBackOf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ReadBackOf::Snapshot => "a snapshot",
            ReadBackOf::SolverStatus => "the solver status",
            ReadBackOf::Timestamps => "timestamps",
            ReadBackOf::Grid => "the grid",
            ReadBackOf::Probe => "a probe's result",
        })
    }
}

/// Why a read-back failed.
#[derive(Debug, thiserror::Error)]
pub enum ReadBackCause {
    #[error(transparent)]
    Poll(#[from] wgpu::PollError),
    #[error("the mapping never completed ({0})")]
    Callback(#[from] std::sync::mpsc::RecvError),
    #[error(transparent)]
    Map(#[from] wgpu::BufferAsyncError),
    #[error(transparent)]
    Range(#[from] wgpu::MapRangeError),
}

impl From<DeviceError> for BackendError {
    fn from(e: DeviceError) -> Self {
        BackendError::Device(Box::new(e))
    }
}

impl From<AdapterError> for BackendError {
    fn from(e: AdapterError) -> Self {
        BackendError::Device(Box::new(e))
    }
}

/// An open device, and where its asynchronous errors land (wgpu's default handler would panic).
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
    errors: Arc<Mutex<Vec<Fault>>>,
    /// How many dispatches a submission of a long plan holds, as the last timed one said (0:
    /// none timed yet): `encode::Dispatcher::encode_in_submissions` keeps it from one call to
    /// the next, so that only a run's first long plan starts small and waits.
    pub submission_dispatches: AtomicUsize,
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

/// The best of `all`, or the first whose name contains `name` (case-insensitive).
fn choose(all: Vec<wgpu::Adapter>, name: Option<&str>) -> Result<wgpu::Adapter, AdapterError> {
    let Some(want) = name else {
        return all.into_iter().next().ok_or(AdapterError::NoAdapter);
    };
    if all.is_empty() {
        return Err(AdapterError::NoAdapter);
    }
    let available: Vec<String> = all.iter().map(|a| describe(&a.get_info())).collect();
    let want_l = want.to_lowercase();
    all.into_iter()
        .find(|a| a.get_info().name.to_lowercase().contains(&want_l))
        .ok_or_else(|| AdapterError::NoMatch {
            want: want.to_owned(),
            available,
        })
}

impl GpuContext {
    /// Open the best adapter, or the first whose name contains `name` (case-insensitive).
    pub fn open(name: Option<&str>) -> Result<Self, AdapterError> {
        let adapter = choose(adapters(), name)?;
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
        .map_err(|source| AdapterError::RequestDevice {
            adapter: describe(&info),
            source,
        })?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(Fault::Error(e));
            }
        }));
        // A reset driver, a removed card or a destroyed device: later calls fail; say why first.
        let sink = errors.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut v) = sink.lock() {
                v.insert(0, Fault::Lost { reason, message });
            }
        });
        Ok(Self {
            device,
            queue,
            info,
            limits,
            features,
            errors,
            submission_dispatches: AtomicUsize::new(0),
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
    pub fn take_error(&self) -> Option<Fault> {
        self.errors.lock().ok().and_then(|mut v| {
            if v.is_empty() {
                None
            } else {
                Some(v.remove(0))
            }
        })
    }
}

impl GpuContext {
    /// The first error the device reported, as a run's error.
    pub fn check(&self) -> Result<(), BackendError> {
        match self.take_error() {
            Some(e) => Err(self.reported(e)),
            None => Ok(()),
        }
    }

    fn reported(&self, fault: Fault) -> BackendError {
        DeviceError::Reported {
            adapter: self.describe(),
            fault,
        }
        .into()
    }

    /// Wait until everything submitted has run.
    pub fn wait_idle(&self) -> Result<(), BackendError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|cause| DeviceError::Wait {
                adapter: self.describe(),
                cause,
            })?;
        self.check()
    }

    /// Wait until submission `index` has run (and not what was submitted after it).
    pub fn wait_for(&self, index: wgpu::SubmissionIndex) -> Result<(), BackendError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|cause| DeviceError::Wait {
                adapter: self.describe(),
                cause,
            })?;
        self.check()
    }

    /// Map `slice` for reading once submission `index` has run, waiting for that submission
    /// only: work submitted after it keeps the GPU busy meanwhile.
    pub fn map_and_wait(
        &self,
        slice: &wgpu::BufferSlice<'_>,
        index: wgpu::SubmissionIndex,
        what: ReadBackOf,
    ) -> Result<(), BackendError> {
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        // A lost device fails the mapping; its own message says more than the mapping's.
        let lost = |e: ReadBackCause| match self.take_error() {
            Some(fault) => self.reported(fault),
            None => self.read_back_failed(what, e),
        };
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|e| lost(e.into()))?;
        rx.recv()
            .map_err(|e| lost(e.into()))?
            .map_err(|e| lost(e.into()))?;
        self.check()
    }

    /// Reading `what` back failed for `cause`.
    pub fn read_back_failed(
        &self,
        what: ReadBackOf,
        cause: impl Into<ReadBackCause>,
    ) -> BackendError {
        DeviceError::ReadBack {
            what,
            adapter: self.describe(),
            cause: cause.into(),
        }
        .into()
    }

    pub fn encoder(&self, label: &'static str) -> wgpu::CommandEncoder {
        self.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }
}
