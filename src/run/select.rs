//! The choice of backend: the CPU reference or the wgpu compute backend, on which adapter. It
//! sits above both backends (each of which implements [`Backend`] from the layer below), so
//! that neither they nor the trait need to know the other exists.

use std::sync::Arc;

use crate::backend::{Backend, BackendError};
use crate::conformance::Verify;
use crate::integrator::Step;
use crate::model::Model;

/// Which backend steps the simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum BackendKind {
    /// wgpu compute shaders on the best (or the named) adapter.
    #[default]
    Gpu,
    /// The multi-threaded CPU reference.
    Cpu,
}

/// The backend a command asked for: its kind and, for the GPU, (part of) the adapter's name and
/// when to probe whether the adapter computes what the CPU does (`conformance`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Device {
    pub kind: BackendKind,
    pub adapter: Option<String>,
    pub verify: Verify,
}

impl Device {
    /// The CPU reference (which has no adapter).
    pub fn cpu() -> Self {
        Self {
            kind: BackendKind::Cpu,
            adapter: None,
            verify: Verify::Never,
        }
    }

    /// A backend of this kind stepping `model` as `step` says.
    pub fn create(&self, model: Arc<Model>, step: Step) -> Result<Box<dyn Backend>, BackendError> {
        if self.kind == BackendKind::Gpu {
            let gpu = crate::gpu::GpuBackend::new(model, step, self.adapter.as_deref())?;
            crate::conformance::verify(&gpu, self.verify).map_err(|e| BackendError::Device(e))?;
            return Ok(Box::new(gpu));
        }
        create(self.kind, model, step, self.adapter.as_deref())
    }
}

/// A backend of `kind` stepping `model` as `step` says; a GPU one on the adapter whose name
/// contains `adapter` (the best one when `None`).
pub fn create(
    kind: BackendKind,
    model: Arc<Model>,
    step: Step,
    adapter: Option<&str>,
) -> Result<Box<dyn Backend>, BackendError> {
    Ok(match kind {
        BackendKind::Cpu => Box::new(crate::cpu::CpuBackend::new(model, step)),
        BackendKind::Gpu => Box::new(crate::gpu::GpuBackend::new(model, step, adapter)?),
    })
}
