//! VBD on the GPU: the masses' colouring (the CPU backend's function, so both backends sweep
//! alike) and one bind group per colour for `vbd_solve_mass` (shaders/vbd.wgsl). The guess and
//! the new state are integrate.wgsl's `vbd_predict` and `vbd_final`, over the run's own buffers.

use super::bindings::{bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::dispatch::{ColourPass, Sweeps};
use super::shaders::groups_for;
use super::xpbd::ColourWindows;
use crate::model::Model;
use crate::physics::vbd_colouring;

pub struct VbdBuffers {
    /// Bind group 0 of `vbd_solve_mass` for each colour.
    groups: Vec<wgpu::BindGroup>,
    /// Workgroups over each colour's masses.
    workgroups: Vec<(u32, u32)>,
    pub sweeps: Sweeps,
}

/// What the VBD buffers are made from: the run's sweeps, and the adapter's limits.
pub struct VbdSetup<'a> {
    pub layout: &'a wgpu::BindGroupLayout,
    pub iterations: u32,
    pub uniform_align: u32,
    pub max_per_dim: u32,
}

impl VbdBuffers {
    pub(super) fn new(a: &mut Alloc<'_>, b: &Bufs, model: &Model, s: &VbdSetup<'_>) -> Self {
        let colouring = vbd_colouring(model);
        let order = a.model("vbd colour order", bytemuck::cast_slice(&colouring.order));
        let colours = colouring.colours();
        let windows = ColourWindows::new(a, "vbd colours", &colouring.starts, s.uniform_align);
        let groups = (0..colours)
            .map(|c| {
                let group = buffers::VbdSolve {
                    base: b.forces_model(),
                    colour: windows.binding(c, false),
                    colour_order: &order,
                    x: &b.x,
                    v: &b.v,
                    x_in: &b.xt,
                    v_in: &b.vt,
                };
                bind_group(a.device, s.layout, &group)
            })
            .collect();
        let workgroups = (0..colours)
            .map(|c| groups_for(colouring.masses_of(c).len() as u32, s.max_per_dim))
            .collect();
        Self {
            groups,
            workgroups,
            sweeps: Sweeps {
                colours: colours as u32,
                iterations: s.iterations,
            },
        }
    }

    /// Bind group 0 of a sweep over one colour.
    pub fn group(&self, pass: ColourPass) -> Option<&wgpu::BindGroup> {
        self.groups.get(pass.colour as usize)
    }

    /// Workgroups over one colour's masses.
    pub fn workgroups(&self, colour: u32) -> Option<(u32, u32)> {
        self.workgroups.get(colour as usize).copied()
    }
}
