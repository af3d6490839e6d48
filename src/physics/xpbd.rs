//! XPBD's per-spring constants for one substep length, computed once in f64 for both backends.

use crate::model::Spring;

/// A spring's constants for one substep length h: α̃ = α / h² = 1 / (k h²) and
/// γ = α β / h = c / (k h). Computed in f64 and rounded once, the same for both backends.
/// Same layout as `XpbdSpring` in `shaders/xpbd.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct XpbdSpring {
    pub alpha_tilde: f32,
    pub gamma: f32,
}

/// Per spring, its [`XpbdSpring`] for substeps of `h_secs`. A broken spring (no stiffness) gets
/// zeros, and the solve skips it.
pub fn xpbd_constants(springs: &[Spring], h_secs: f64) -> Vec<XpbdSpring> {
    springs
        .iter()
        .map(|s| {
            let k = f64::from(s.stiffness_n_per_m);
            if k <= 0.0 {
                return XpbdSpring::default();
            }
            XpbdSpring {
                alpha_tilde: (1.0 / (k * h_secs * h_secs)) as f32,
                gamma: (f64::from(s.damping_n_s_per_m) / (k * h_secs)) as f32,
            }
        })
        .collect()
}
