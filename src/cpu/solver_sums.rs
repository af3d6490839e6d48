//! The implicit solver's sums over the masses, taken as shaders/solver_sums.wgsl's `reduce_over`
//! takes them in the one-workgroup step on a CPU adapter (lavapipe): `physics::SUM_LANES`
//! threads each add the masses lane, lane + SUM_LANES, … in f32, from zero and in order, and the
//! lanes' sums are then added in order (one level: `dispatch::sum_level` of SUM_LANES threads is
//! SUM_LANES). Every figure Newton and CG decide on (|b|, p·Ap, r·z, BDF2's residual work) is
//! such a sum, so the CPU's steps take the same decisions as lavapipe's, bit for bit, where an
//! f64 sum (as here until the fourteenth session) parted from it at the last bit of α and β.
//! The lanes are a strided sum over the masses in order: the same on any number of threads.

use glam::Vec4;

use crate::physics::SUM_LANES;

const LANES: usize = SUM_LANES as usize;

/// Σ `value(i)` over the masses 0..n, per component, as the one-workgroup step sums it.
#[inline(always)]
pub fn group_reduce(n: usize, value: impl Fn(usize) -> Vec4) -> Vec4 {
    let mut lanes = [Vec4::ZERO; LANES];
    let whole = n - n % LANES;
    for base in (0..whole).step_by(LANES) {
        for (lane, sum) in lanes.iter_mut().enumerate() {
            *sum += value(base + lane);
        }
    }
    for (lane, sum) in lanes.iter_mut().enumerate().take(n - whole) {
        *sum += value(whole + lane);
    }
    // reduce_over's second level: the first thread adds the lanes' sums from zero, in order.
    lanes.iter().fold(Vec4::ZERO, |total, lane| total + *lane)
}

/// The largest `value(i)` per component (non-negative figures): order does not matter to a
/// maximum, so this is the GPU's as it is.
#[inline(always)]
pub fn group_max(n: usize, value: impl Fn(usize) -> Vec4) -> Vec4 {
    (0..n).fold(Vec4::ZERO, |m, i| m.max(value(i)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lanes' order is the GPU's: a sum that f32 rounding makes depend on the order comes
    /// out as eight strided partial sums added in order, not as a sum in mass order.
    #[test]
    fn the_lanes_add_strided_shares_then_each_other_in_order() {
        // 1e8 then ones: in mass order every one is lost to rounding (f32's step at 1e8 is 8);
        // in lanes, seven of them add up their ones first. 5 masses beyond whole rounds of 8.
        let values: Vec<f32> = (0..8 * 64 + 5)
            .map(|i| if i == 0 { 1.0e8 } else { 1.0 })
            .collect();
        let got = group_reduce(values.len(), |i| Vec4::splat(values[i])).x;
        let mut lanes = [0.0f32; 8];
        for (i, v) in values.iter().enumerate() {
            lanes[i % 8] += v;
        }
        let want = lanes.iter().fold(0.0f32, |t, l| t + l);
        assert_eq!(got.to_bits(), want.to_bits());
        let in_order = values.iter().fold(0.0f32, |t, v| t + v);
        assert_ne!(
            got.to_bits(),
            in_order.to_bits(),
            "the order should matter here"
        );
        assert_eq!(group_reduce(0, |_| Vec4::ONE), Vec4::ZERO);
        assert_eq!(group_max(3, |i| Vec4::splat(i as f32)), Vec4::splat(2.0));
    }
}
