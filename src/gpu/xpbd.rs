//! XPBD on the GPU: the springs' colouring and constants, uploaded once (both computed by the
//! CPU backend's functions, so the two backends solve alike), each spring's multiplier, one bind
//! group per colour and kind of sweep for `xpbd_solve_spring` (shaders/xpbd.wgsl), and for small
//! scenes the one group of `xpbd_sweeps` (shaders/xpbd_sweeps.wgsl), every sweep in a dispatch.

use super::bindings::{bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::colours::{ColourGroups, ColourSetup, ColourWindows, sweep_plan};
use super::sizing::xpbd_in_one_group;
use crate::model::Model;
use crate::physics::{colour_springs, xpbd_constants};

/// XPBD's colour groups for substeps of `dt_secs`, with its constants and multipliers, and the
/// bind group of `xpbd_sweeps` on `sweeps_layout` (when the run compiles it).
pub(super) fn xpbd_groups(
    a: &mut Alloc<'_>,
    b: &Bufs,
    model: &Model,
    dt_secs: f64,
    s: &ColourSetup<'_>,
    sweeps_layout: Option<&wgpu::BindGroupLayout>,
) -> (ColourGroups, Option<wgpu::BindGroup>) {
    let colouring = colour_springs(&model.springs, &model.inv_mass);
    let constants = a.model(
        "xpbd constants",
        bytemuck::cast_slice(&xpbd_constants(&model.springs, dt_secs)),
    );
    let order = a.model("xpbd colour order", bytemuck::cast_slice(&colouring.order));
    let lambda = a.zeros("xpbd lambda", 4 * model.spring_count());
    let colours = colouring.colours();
    let windows = ColourWindows::new(a, "xpbd colours", &colouring.starts, s.uniform_align);
    let springs = || buffers::XpbdSprings {
        params: &b.params,
        springs: &b.springs,
        constants: &constants,
        colour_order: &order,
        mass: &b.mass,
        x: &b.x,
        dx: &b.xt,
        lambda: &lambda,
    };
    let groups = (0..2 * colours)
        .map(|k| {
            let group = buffers::XpbdSolve {
                base: springs(),
                colour: windows.binding(k / 2, k % 2 == 1),
            };
            bind_group(a.device, s.layout, &group)
        })
        .collect();
    let sweep_plan = sweep_plan(a, "xpbd sweep plan", s.iterations, &colouring.starts);
    let sweeps_group = sweeps_layout.map(|layout| {
        let group = buffers::XpbdSweeps {
            base: springs(),
            sweep_plan: &sweep_plan,
        };
        bind_group(a.device, layout, &group)
    });
    let mut colour_groups =
        ColourGroups::new(groups, 2, &colouring.starts, s.max_per_dim, s.iterations);
    colour_groups.sweeps.one_group =
        xpbd_in_one_group(model.spring_count(), colour_groups.sweeps.iterations);
    (colour_groups, sweeps_group)
}
