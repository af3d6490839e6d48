//! XPBD on the GPU: the springs' colouring and constants, uploaded once (both computed by the
//! CPU backend's functions, so the two backends solve alike), each spring's multiplier, and one
//! bind group per colour and kind of sweep for `xpbd_solve_spring` (shaders/xpbd.wgsl).

use super::bindings::{bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::colours::{ColourGroups, ColourWindows};
use crate::model::Model;
use crate::physics::{colour_springs, xpbd_constants};

/// What the XPBD buffers are made from: the run's substep and sweeps, and the adapter's limits.
pub struct XpbdSetup<'a> {
    pub layout: &'a wgpu::BindGroupLayout,
    pub dt_secs: f64,
    pub iterations: u32,
    pub uniform_align: u32,
    pub max_per_dim: u32,
}

/// XPBD's colour groups, with its constants and multipliers.
pub(super) fn xpbd_groups(
    a: &mut Alloc<'_>,
    b: &Bufs,
    model: &Model,
    s: &XpbdSetup<'_>,
) -> ColourGroups {
    let colouring = colour_springs(&model.springs, &model.inv_mass);
    let constants = a.model(
        "xpbd constants",
        bytemuck::cast_slice(&xpbd_constants(&model.springs, s.dt_secs)),
    );
    let order = a.model("xpbd colour order", bytemuck::cast_slice(&colouring.order));
    let lambda = a.zeros("xpbd lambda", 4 * model.spring_count());
    let colours = colouring.colours();
    let windows = ColourWindows::new(a, "xpbd colours", &colouring.starts, s.uniform_align);
    let groups = (0..2 * colours)
        .map(|k| {
            let colour = windows.binding(k / 2, k % 2 == 1);
            let group = buffers::XpbdSolve {
                params: &b.params,
                colour,
                springs: &b.springs,
                constants: &constants,
                colour_order: &order,
                mass: &b.mass,
                x: &b.x,
                dx: &b.xt,
                lambda: &lambda,
            };
            bind_group(a.device, s.layout, &group)
        })
        .collect();
    ColourGroups::new(groups, 2, (&colouring.starts, s.max_per_dim), s.iterations)
}
