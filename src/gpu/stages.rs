//! Stage slots: the per-dispatch uniform (`Stage` in WGSL) holding a stage's time, dt and every
//! collider's pose then, computed on the host as the CPU backend computes them. A submission of
//! k steps uses slots 4k..4k+3 for step k, and the last slot for the snapshot's reductions.

use super::bindings::{bind_group, buffers};
use super::layout::{MAX_COLLIDERS, Pose, Stage};
use crate::integrator::Integrator;
use crate::model::Model;
use crate::physics::BackwardStep;

/// The run's time: its dt, where it is, and the steps since the last snapshot was asked for.
#[derive(Debug, Clone, Copy)]
pub struct Clock {
    pub dt: f32,
    /// The run's integrator: a backward scheme's step slot holds its solve's step and blend.
    pub integrator: Integrator,
    pub time_secs: f64,
    pub steps: u64,
    /// Substeps advanced since the last snapshot was requested: a frame stepped in chunks
    /// numbers its steps on from here, so the first bad step is found within the whole frame.
    pub frame_steps: u32,
}

impl Clock {
    pub fn new(dt_secs: f64, integrator: Integrator) -> Self {
        Self {
            dt: dt_secs as f32,
            integrator,
            time_secs: 0.0,
            steps: 0,
            frame_steps: 0,
        }
    }

    /// The time after `steps` more steps, accumulated by repeated addition exactly as the CPU
    /// backend accumulates it.
    pub fn time_after(&self, steps: u32) -> f64 {
        let h = f64::from(self.dt);
        (0..steps).fold(self.time_secs, |t, _| t + h)
    }

    pub fn advance(&mut self, steps: u32) {
        self.time_secs = self.time_after(steps);
        self.steps += u64::from(steps);
        self.frame_steps += steps;
    }

    /// Stage slots for the first `laid` of `steps` steps from now: t, t + h/2 (RK4 stage 2),
    /// t + h/2 (stage 3), t + h. (A submission stepped in one workgroup reads its first step's
    /// slots alone.) The last slot is where implicit Euler and BDF2 take their forces: its dt
    /// is their solve's step, `physics::BackwardStep`, its `history` their blend.
    pub fn stages<'a>(
        &'a self,
        model: &'a Model,
        steps: u32,
        laid: u32,
    ) -> impl Iterator<Item = Stage> + 'a {
        let h = f64::from(self.dt);
        let mut t = self.time_secs;
        (0..laid.min(steps)).flat_map(move |k| {
            let at = |time: f64, weight: f32, next_scale: f32| Stage {
                weight,
                next_scale,
                step: self.frame_steps + k,
                steps: steps - k,
                ..self.stage_at(model, time)
            };
            let backward = BackwardStep::of(self.integrator, self.dt, self.steps + u64::from(k));
            let slots = [
                at(t, 1.0, 0.5),
                at(t + 0.5 * h, 2.0, 0.5),
                at(t + 0.5 * h, 2.0, 1.0),
                Stage {
                    dt: backward.solve_secs,
                    history: backward.history,
                    ..at(t + h, 1.0, 1.0)
                },
            ];
            t += h;
            slots
        })
    }

    /// A stage slot at `time`: its dt and every collider's pose then.
    pub fn stage_at(&self, model: &Model, time: f64) -> Stage {
        let mut poses = [Pose::default(); MAX_COLLIDERS];
        for (slot, c) in poses.iter_mut().zip(&model.effects.colliders) {
            let p = c.path.pose_at(time);
            *slot = Pose {
                position: p.position_m.extend(0.0).to_array(),
                velocity: p.velocity_m_per_s.extend(0.0).to_array(),
            };
        }
        Stage {
            time: time as f32,
            dt: self.dt,
            weight: 1.0,
            next_scale: 1.0,
            step: 0,
            steps: 1,
            whole_dt: self.dt,
            history: 0.0,
            poses,
        }
    }
}

/// The stage uniform buffer and its bind group (group 2 of every kernel).
///
/// A slot's window is a whole `Stage` (the WGSL struct holds every collider's pose there could
/// be), but slots lie only as far apart as the run's colliders need (the header and their poses,
/// rounded up to the adapter's alignment): the windows overlap, each kernel reads the poses of
/// `collider_count` colliders alone, and writing a step's four slots costs a few hundred bytes
/// instead of two kilobytes, which was most of the host's time per step on small scenes.
pub struct StageSlots {
    buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Every slot as words (`StageWords`), for a kernel that runs many steps.
    words: wgpu::BindGroup,
    /// Slots lie this far apart, at offsets the adapter accepts for a dynamic uniform.
    stride: u64,
    /// The bytes of a slot that kernels read: the header and the run's colliders' poses.
    used: usize,
    slots: u32,
    /// The bytes of the last write, kept so that a write allocates nothing new.
    bytes: Vec<u8>,
}

/// The stage groups' layouts: one slot (a dynamic window), and every slot as words.
#[derive(Clone, Copy)]
pub struct StageLayouts<'a> {
    pub slot: &'a wgpu::BindGroupLayout,
    pub words: &'a wgpu::BindGroupLayout,
}

impl StageSlots {
    /// How far apart the slots lie for `colliders` colliders on an adapter aligning dynamic
    /// uniform offsets to `align` bytes, and how many bytes of each kernels read.
    pub fn stride_for(align: u32, colliders: usize) -> (u64, usize) {
        let align = u64::from(align).max(1);
        let used = std::mem::size_of::<Stage>()
            - std::mem::size_of::<Pose>() * (MAX_COLLIDERS - colliders.min(MAX_COLLIDERS));
        ((used as u64).div_ceil(align) * align, used)
    }

    pub fn new(
        device: &wgpu::Device,
        layouts: StageLayouts<'_>,
        align: u32,
        colliders: usize,
    ) -> Self {
        let (stride, used) = Self::stride_for(align, colliders);
        let (buffer, bind_group, words) = Self::make(device, layouts, stride, 1);
        Self {
            buffer,
            bind_group,
            words,
            stride,
            used,
            slots: 1,
            bytes: Vec::new(),
        }
    }

    fn make(
        device: &wgpu::Device,
        layouts: StageLayouts<'_>,
        stride: u64,
        slots: u32,
    ) -> (wgpu::Buffer, wgpu::BindGroup, wgpu::BindGroup) {
        // The last slot's window runs a whole Stage past its offset.
        let window = std::mem::size_of::<Stage>() as u64;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stage"),
            size: stride * u64::from(slots - 1) + window.max(stride),
            usage: wgpu::BufferUsages::UNIFORM
                | wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // One slot's window; the dispatch gives its offset. The same group serves as a fused
        // step's end slot (group 3, `StageEnd`), whose layout is the same.
        let slot = buffers::StageSlot {
            stage: wgpu::BufferBinding {
                buffer: &buffer,
                offset: 0,
                size: wgpu::BufferSize::new(window),
            },
        };
        let one = bind_group(device, layouts.slot, &slot);
        let words = bind_group(
            device,
            layouts.words,
            &buffers::StageWords {
                stage_words: &buffer,
            },
        );
        (buffer, one, words)
    }

    /// Make room for `slots` slots (grows, never shrinks).
    pub fn reserve(&mut self, device: &wgpu::Device, layouts: StageLayouts<'_>, slots: u32) {
        if slots <= self.slots {
            return;
        }
        let slots = slots.next_power_of_two();
        (self.buffer, self.bind_group, self.words) =
            Self::make(device, layouts, self.stride, slots);
        self.slots = slots;
    }

    /// The last slot: the snapshot's reductions', after the stepping slots.
    pub fn last(&self) -> u32 {
        self.slots - 1
    }

    /// Write `stages` from slot `first` on: the bytes kernels read of each.
    pub fn write(
        &mut self,
        queue: &wgpu::Queue,
        first: u32,
        stages: impl IntoIterator<Item = Stage>,
    ) {
        let (stride, used) = (self.stride as usize, self.used);
        self.bytes.clear();
        for s in stages {
            self.bytes
                .extend_from_slice(&bytemuck::bytes_of(&s)[..used]);
            self.bytes.resize(self.bytes.len() + stride - used, 0);
        }
        queue.write_buffer(&self.buffer, u64::from(first) * self.stride, &self.bytes);
    }

    /// Bind every slot, as words, as group `index`.
    pub fn bind_words(&self, pass: &mut wgpu::ComputePass<'_>, index: u32) {
        pass.set_bind_group(index, &self.words, &[]);
    }

    /// Bind slot `slot` as group `index`: 2, a dispatch's stage; 3, a fused step's end.
    pub fn bind_as(&self, pass: &mut wgpu::ComputePass<'_>, index: u32, slot: u32) {
        pass.set_bind_group(
            index,
            &self.bind_group,
            &[(u64::from(slot) * self.stride) as u32],
        );
    }
}
