//! VBD on the GPU: the masses' colouring (the CPU backend's function, so both backends sweep
//! alike), one bind group per colour for `vbd_solve_mass` (shaders/vbd.wgsl) and, for small
//! scenes, the one group of `vbd_sweeps` (shaders/vbd_sweeps.wgsl), every sweep in a dispatch.
//! The guess and the new state are integrate.wgsl's `vbd_predict` and `vbd_final`, over the
//! run's own buffers.

use super::bindings::{bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::colours::{ColourGroups, ColourSetup, ColourWindows, sweep_plan};
use crate::model::Model;
use crate::physics::vbd_colouring;

/// VBD's colour groups, and the bind group of `vbd_sweeps` on `sweeps_layout` (when the run
/// compiles it).
pub(super) fn vbd_groups(
    a: &mut Alloc<'_>,
    b: &Bufs,
    model: &Model,
    s: &ColourSetup<'_>,
    sweeps_layout: Option<&wgpu::BindGroupLayout>,
) -> (ColourGroups, Option<wgpu::BindGroup>) {
    let colouring = vbd_colouring(model);
    let order = a.model("vbd colour order", bytemuck::cast_slice(&colouring.order));
    let colours = colouring.colours();
    let windows = ColourWindows::new(a, "vbd colours", &colouring.starts, s.uniform_align);
    let masses = || buffers::VbdMasses {
        base: b.forces_model(),
        colour_order: &order,
        x: &b.x,
        v: &b.v,
        x_in: &b.xt,
        v_in: &b.vt,
    };
    let groups = (0..colours)
        .map(|c| {
            let group = buffers::VbdSolve {
                base: masses(),
                colour: windows.binding(c, false),
            };
            bind_group(a.device, s.layout, &group)
        })
        .collect();
    let sweep_plan = sweep_plan(a, "vbd sweep plan", s.iterations, &colouring.starts);
    let sweeps_group = sweeps_layout.map(|layout| {
        let group = buffers::VbdSweeps {
            base: masses(),
            sweep_plan: &sweep_plan,
        };
        bind_group(a.device, layout, &group)
    });
    // Whether the sweeps take one workgroup depends on the adapter (tuning.rs's `specialise`).
    let colour_groups =
        ColourGroups::new(groups, 1, &colouring.starts, s.max_per_dim, s.iterations);
    (colour_groups, sweeps_group)
}
