//! XPBD on the GPU: the springs' colouring and constants, uploaded once (both computed by the
//! CPU backend's functions, so the two backends solve alike), each spring's multiplier, and one
//! bind group per colour and kind of sweep for `xpbd_solve_spring` (shaders/xpbd.wgsl).

use super::bindings::{bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::dispatch::{ColourPass, Sweeps};
use super::layout::ColourRange;

/// One uniform `ColourRange` per (colour, first sweep or not), each at an offset a binding may
/// start at, in one buffer: the windows the colour kernels' bind groups hold.
pub(super) struct ColourWindows {
    uniform: wgpu::Buffer,
    stride: usize,
}

impl ColourWindows {
    /// The windows of the colours whose items start at `starts` (one more than colours).
    pub(super) fn new(a: &mut Alloc<'_>, label: &str, starts: &[u32], align: u32) -> Self {
        let stride = std::mem::size_of::<ColourRange>().next_multiple_of(align.max(1) as usize);
        let colours = starts.len() - 1;
        let mut uniforms = vec![0u8; (2 * colours).max(1) * stride];
        for c in 0..colours {
            for first in [0u32, 1] {
                let u = ColourRange {
                    start: starts[c],
                    count: starts[c + 1] - starts[c],
                    first,
                    _pad: 0,
                };
                let at = (2 * c + first as usize) * stride;
                uniforms[at..at + std::mem::size_of::<ColourRange>()]
                    .copy_from_slice(bytemuck::bytes_of(&u));
            }
        }
        Self {
            uniform: a.uniform(label, &uniforms),
            stride,
        }
    }

    /// Colour `c`'s window, on a first sweep or a later one.
    pub(super) fn binding(&self, c: usize, first: bool) -> wgpu::BufferBinding<'_> {
        wgpu::BufferBinding {
            buffer: &self.uniform,
            offset: ((2 * c + usize::from(first)) * self.stride) as u64,
            size: wgpu::BufferSize::new(std::mem::size_of::<ColourRange>() as u64),
        }
    }
}
use super::shaders::groups_for;
use crate::model::Model;
use crate::physics::{colour_springs, xpbd_constants};

pub struct XpbdBuffers {
    /// Bind group 0 of `xpbd_solve_spring` for colour c: [2c] a later sweep, [2c + 1] the first.
    groups: Vec<wgpu::BindGroup>,
    /// Workgroups over each colour's springs.
    workgroups: Vec<(u32, u32)>,
    pub sweeps: Sweeps,
}

/// What the XPBD buffers are made from: the run's substep and sweeps, and the adapter's limits.
pub struct XpbdSetup<'a> {
    pub layout: &'a wgpu::BindGroupLayout,
    pub dt_secs: f64,
    pub iterations: u32,
    pub uniform_align: u32,
    pub max_per_dim: u32,
}

impl XpbdBuffers {
    pub(super) fn new(a: &mut Alloc<'_>, b: &Bufs, model: &Model, s: &XpbdSetup<'_>) -> Self {
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
        let workgroups = (0..colours)
            .map(|c| groups_for(colouring.springs_of(c).len() as u32, s.max_per_dim))
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
        self.groups
            .get(2 * pass.colour as usize + usize::from(pass.first))
    }

    /// Workgroups over one colour's springs.
    pub fn workgroups(&self, colour: u32) -> Option<(u32, u32)> {
        self.workgroups.get(colour as usize).copied()
    }
}
