//! What one dispatch of a step plan is: a kernel, the state it reads or the states it flows
//! between, its stage slot and, for XPBD's projection and VBD's block solve, its colour. The
//! plans (`plan.rs`, `implicit/plan.rs`) are lists of these; `encode.rs` records them. How
//! many threads and workgroups a dispatch takes is `sizing.rs`'s.

use super::kernels::Kernel;

/// Stage slots per substep: t, t + h/2 (twice, for RK4's two midpoint stages), t + h.
pub const SLOTS_PER_STEP: u32 = 4;

/// Which state a kernel reads through bind group 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StateIn {
    XV,
    XtVt,
    XVt,
}

/// The state a fused kernel reads and the one it writes (bind group 1): A is the run's x and v,
/// B its xt and vt, C the second stage point RK4's middle stages alternate with B.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    AB,
    BA,
    BC,
    CB,
}

/// One sweep over one colour: of springs (XPBD's projection) or of masses (VBD's block solve).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColourPass {
    pub colour: u32,
    /// The substep's first sweep, which starts XPBD's multipliers from zero (VBD: unused).
    pub first: bool,
}

/// XPBD's sweeps of a substep (the springs' colours) or VBD's of a step (the masses'), and the
/// sweeps over all of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sweeps {
    pub colours: u32,
    pub iterations: u32,
    /// Every sweep over every colour in one dispatch of one workgroup (XPBD on a small scene:
    /// [`xpbd_in_one_group`]) instead of a dispatch per colour and sweep.
    pub one_group: bool,
}

/// One dispatch: a kernel, the state it reads (for the kernels that read one) or the states it
/// reads and writes (the fused kernels), its stage slot relative to its step's first, and for
/// XPBD's projection the colour it solves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dispatch {
    pub kernel: Kernel,
    pub state: Option<StateIn>,
    pub flow: Option<Flow>,
    pub slot: u32,
    pub colour: Option<ColourPass>,
    /// The multigrid cycle's coarse level (1 the first; 0 for every other kernel).
    pub level: u32,
}

impl Dispatch {
    /// A kernel that reads no state.
    pub const fn at(kernel: Kernel, slot: u32) -> Self {
        Self {
            kernel,
            state: None,
            flow: None,
            slot,
            colour: None,
            level: 0,
        }
    }

    /// A kernel that reads `state`.
    pub const fn reading(kernel: Kernel, state: StateIn, slot: u32) -> Self {
        Self {
            state: Some(state),
            ..Self::at(kernel, slot)
        }
    }

    /// A fused kernel, reading and writing the states of `flow`.
    pub const fn flowing(kernel: Kernel, flow: Flow, slot: u32) -> Self {
        Self {
            flow: Some(flow),
            ..Self::at(kernel, slot)
        }
    }

    /// A kernel over one colour (XPBD's projection, VBD's block solve).
    pub const fn colour(kernel: Kernel, pass: ColourPass, slot: u32) -> Self {
        Self {
            colour: Some(pass),
            ..Self::at(kernel, slot)
        }
    }
}
