//! VBD on the GPU: the masses' colouring (the CPU backend's function, so both backends sweep
//! alike) and one bind group per colour for `vbd_solve_mass` (shaders/vbd.wgsl). The guess and
//! the new state are integrate.wgsl's `vbd_predict` and `vbd_final`, over the run's own buffers.

use super::bindings::{bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::colours::{ColourGroups, ColourSetup, ColourWindows};
use crate::model::Model;
use crate::physics::vbd_colouring;

/// VBD's colour groups.
pub(super) fn vbd_groups(
    a: &mut Alloc<'_>,
    b: &Bufs,
    model: &Model,
    s: &ColourSetup<'_>,
) -> ColourGroups {
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
    ColourGroups::new(groups, 1, (&colouring.starts, s.max_per_dim), s.iterations)
}
