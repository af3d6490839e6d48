//! The colour kernels' bind groups (XPBD's projection over spring colours, VBD's block solve over
//! mass colours): a window of one uniform buffer per colour and kind of sweep, and the groups,
//! workgroups and sweeps a plan's colour dispatches find (`Resources::colour_pass`).

use super::buffers::Alloc;
use super::dispatch::{ColourPass, Sweeps};
use super::layout::ColourRange;
use super::sizing::groups_for;

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

/// What a one-workgroup sweeps kernel (`xpbd_sweeps`, `vbd_sweeps`) loops over, in one buffer:
/// the sweeps, the colours, then where each colour's items start (one more than colours).
pub(super) fn sweep_plan(
    a: &mut Alloc<'_>,
    label: &str,
    iterations: u32,
    starts: &[u32],
) -> wgpu::Buffer {
    let colours = starts.len().saturating_sub(1) as u32;
    let plan: Vec<u32> = [iterations, colours]
        .into_iter()
        .chain(starts.iter().copied())
        .collect();
    a.model(label, bytemuck::cast_slice(&plan))
}

/// What a colour kernel's groups are made from: its bind group layout, a step's sweeps, and the
/// adapter's limits.
pub struct ColourSetup<'a> {
    pub layout: &'a wgpu::BindGroupLayout,
    pub iterations: u32,
    pub uniform_align: u32,
    pub max_per_dim: u32,
}

/// A colour kernel's bind groups, one per colour and kind of sweep (`kinds`: 2 when a step's
/// first sweep binds its own window, as XPBD's does to reset its multipliers; 1 for VBD), the
/// workgroups over each colour's items, and a step's sweeps.
pub struct ColourGroups {
    groups: Vec<wgpu::BindGroup>,
    kinds: usize,
    /// Each colour's items, and the workgroups over them.
    counts: Vec<u32>,
    max_per_dim: u32,
    workgroups: Vec<(u32, u32)>,
    pub sweeps: Sweeps,
    /// The items of the widest colour.
    pub widest: u32,
}

impl ColourGroups {
    /// `groups` in colour order (each colour's `kinds` together) over the colours whose items
    /// start at `starts`, swept `iterations` times a step, a thread per item.
    pub(super) fn new(
        groups: Vec<wgpu::BindGroup>,
        kinds: usize,
        starts: &[u32],
        max_per_dim: u32,
        iterations: u32,
    ) -> Self {
        let counts: Vec<u32> = starts.windows(2).map(|w| w[1] - w[0]).collect();
        let mut colour_groups = Self {
            widest: counts.iter().copied().max().unwrap_or(0),
            groups,
            kinds,
            sweeps: Sweeps {
                colours: counts.len() as u32,
                iterations,
                one_group: false,
            },
            counts,
            max_per_dim,
            workgroups: Vec::new(),
        };
        colour_groups.spread(1);
        colour_groups
    }

    /// The workgroups over each colour for `threads` threads an item (VBD's lanes).
    pub(super) fn spread(&mut self, threads: u32) {
        self.workgroups = self
            .counts
            .iter()
            .map(|&n| groups_for(n.saturating_mul(threads), self.max_per_dim))
            .collect();
    }

    /// Bind group 0 of a sweep over one colour.
    pub fn group(&self, pass: ColourPass) -> Option<&wgpu::BindGroup> {
        let first = usize::from(pass.first && self.kinds == 2);
        self.groups.get(self.kinds * pass.colour as usize + first)
    }

    /// Workgroups over one colour's items.
    pub fn workgroups(&self, colour: u32) -> Option<(u32, u32)> {
        self.workgroups.get(colour as usize).copied()
    }
}
