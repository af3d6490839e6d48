//! The buffers every run binds, created and counted: the model's (read-only after upload) and
//! the state's. `resources.rs` binds them, with the buffers of the effects a scene has.

use glam::Vec3;
use wgpu::util::DeviceExt as _;

use super::bindings::buffers;
use super::layout::{self, Collider, Params};
use super::limits::{deriv_bytes, scratch_bytes};
use crate::backend::RUNAWAY_SPEED_M_PER_S;
use crate::integrator::Integrator;
use crate::model::{Model, Shape};

/// Creates buffers and counts their bytes.
pub(super) struct Alloc<'a> {
    pub(super) device: &'a wgpu::Device,
    pub(super) bytes: u64,
}

pub(super) const COPY: wgpu::BufferUsages =
    wgpu::BufferUsages::COPY_SRC.union(wgpu::BufferUsages::COPY_DST);

impl Alloc<'_> {
    pub(super) fn count(&mut self, b: wgpu::Buffer) -> wgpu::Buffer {
        self.bytes += b.size();
        b
    }

    pub(super) fn storage(
        &mut self,
        label: &str,
        contents: &[u8],
        extra: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        // wgpu rejects zero-sized bindings: give empty arrays one zeroed element.
        let zeros = [0u8; 64];
        let b = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: if contents.is_empty() {
                    &zeros
                } else {
                    contents
                },
                usage: wgpu::BufferUsages::STORAGE | extra,
            });
        self.count(b)
    }

    /// Read-only after upload.
    pub(super) fn model(&mut self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        self.storage(label, contents, wgpu::BufferUsages::empty())
    }

    pub(super) fn zeros(&mut self, label: &str, bytes: usize) -> wgpu::Buffer {
        self.storage(label, &vec![0u8; bytes], COPY)
    }

    pub(super) fn uniform(&mut self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        let b = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::UNIFORM,
            });
        self.count(b)
    }

    /// A zeroed buffer of `live`'s size and usage, to copy it to and back.
    pub(super) fn copy_of(&mut self, live: &wgpu::Buffer, label: &str) -> wgpu::Buffer {
        let b = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: live.size(),
            usage: live.usage(),
            mapped_at_creation: false,
        });
        self.count(b)
    }

    /// Where the host maps what it reads back.
    pub(super) fn read_back(&mut self, label: &str, size: u64) -> wgpu::Buffer {
        let b = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.count(b)
    }
}

/// The buffers bind groups are made of, by name.
pub(super) struct Bufs {
    pub(super) params: wgpu::Buffer,
    pub(super) springs: wgpu::Buffer,
    pub(super) offsets: wgpu::Buffer,
    pub(super) neighbors: wgpu::Buffer,
    pub(super) colliders: wgpu::Buffer,
    pub(super) mass: wgpu::Buffer,
    pub(super) x: wgpu::Buffer,
    pub(super) v: wgpu::Buffer,
    pub(super) xt: wgpu::Buffer,
    pub(super) vt: wgpu::Buffer,
    pub(super) deriv: wgpu::Buffer,
    pub(super) sums: wgpu::Buffer,
    pub(super) ledger: wgpu::Buffer,
    pub(super) counters: wgpu::Buffer,
    pub(super) strain: wgpu::Buffer,
    pub(super) partials: wgpu::Buffer,
}

impl Bufs {
    pub(super) fn new(
        a: &mut Alloc<'_>,
        model: &Model,
        integrator: Integrator,
        partial_count: u64,
    ) -> Self {
        let (n, ns) = (model.mass_count(), model.spring_count());
        let mass: Vec<[f32; 2]> = model
            .mass_kg
            .iter()
            .zip(&model.inv_mass)
            .map(|(&m, &w)| [m, w])
            .collect();
        Self {
            params: a.uniform("params", bytemuck::bytes_of(&params(model))),
            // Copied: implicit Euler's per-pass path keeps a frame's start to replay it from.
            springs: a.storage("springs", bytemuck::cast_slice(&model.springs), COPY),
            offsets: a.model("offsets", bytemuck::cast_slice(&model.adjacency.offsets)),
            neighbors: a.model("neighbors", bytemuck::cast_slice(&model.adjacency.entries)),
            colliders: a.model("colliders", bytemuck::cast_slice(&colliders(model))),
            mass: a.model("mass", bytemuck::cast_slice(&mass)),
            x: a.storage("x", bytemuck::cast_slice(&vec4s(&model.initial.x)), COPY),
            v: a.storage("v", bytemuck::cast_slice(&vec4s(&model.initial.v)), COPY),
            xt: a.zeros("xt", 16 * n),
            vt: a.zeros("vt", 16 * n),
            deriv: a.zeros("deriv", deriv_bytes(model, integrator) as usize),
            sums: a.zeros("sums", scratch_bytes(model, integrator) as usize),
            ledger: a.zeros("ledger", 16 * n),
            counters: a.zeros("counters", layout::COUNTERS_BYTES as usize),
            strain: a.zeros("strain", 4 * ns),
            partials: a.zeros("partials", 48 * partial_count as usize),
        }
    }
}

impl Bufs {
    /// `compute_forces`' group, which implicit Euler's and VBD's extend.
    pub(super) fn forces_model(&self) -> buffers::ForcesModel<'_> {
        buffers::ForcesModel {
            params: &self.params,
            springs: &self.springs,
            offsets: &self.offsets,
            neighbors: &self.neighbors,
            colliders: &self.colliders,
            mass: &self.mass,
            deriv: &self.deriv,
        }
    }
}

fn vec4s(v: &[Vec3]) -> Vec<[f32; 4]> {
    v.iter().map(|p| [p.x, p.y, p.z, 0.0]).collect()
}

/// Scene-wide constants.
fn params(model: &Model) -> Params {
    let e = &model.effects;
    let ground = e.ground;
    Params {
        mass_count: model.mass_count() as u32,
        spring_count: model.spring_count() as u32,
        collider_count: e.colliders.len() as u32,
        runaway_speed: RUNAWAY_SPEED_M_PER_S,
        gravity: e.gravity_m_per_s2.unwrap_or(Vec3::ZERO).to_array(),
        drag_per_s: e.air_drag_per_s.unwrap_or(0.0),
        ground_height: ground.map_or(0.0, |g| g.height_m),
        ground_stiffness: ground.map_or(0.0, |g| g.contact.stiffness_n_per_m),
        ground_friction: ground.map_or(0.0, |g| g.contact.friction),
        ground_damping_ratio: ground.map_or(0.0, |g| g.contact.damping_ratio),
        ground_max_depth: ground.map_or(0.0, |g| g.max_depth_m),
        _pad: [0.0; 3],
    }
}

fn colliders(model: &Model) -> Vec<Collider> {
    let collider = |c: &crate::model::Collider| {
        let (kind, shape) = match c.shape {
            Shape::Sphere { radius_m } => (layout::SPHERE, [radius_m, 0.0, 0.0, 0.0]),
            Shape::Box { half_extents_m } => (layout::BOX, half_extents_m.extend(0.0).to_array()),
            Shape::Plane { normal } => (layout::PLANE, normal.extend(0.0).to_array()),
        };
        Collider {
            kind,
            stiffness: c.contact.stiffness_n_per_m,
            friction: c.contact.friction,
            damping_ratio: c.contact.damping_ratio,
            shape,
            max_depth: c.max_depth_m,
            _pad: [0.0; 3],
        }
    };
    model.effects.colliders.iter().map(collider).collect()
}
