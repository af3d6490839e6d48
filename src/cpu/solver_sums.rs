//! The implicit solver's sums over the masses, taken as a CPU adapter (lavapipe) takes them on
//! either of its paths (`physics::SUM_LANES`): `physics::sum_groups(n)` groups of SUM_LANES
//! threads, each thread adding a strided share of the masses in f32, each group its threads in
//! order, and the groups' sums in eight strided shares, those in order. Every figure Newton and
//! CG decide on (|b|, p·Ap, r·z, BDF2's residual work) is such a sum, so the CPU's steps take the
//! same decisions as lavapipe's, bit for bit, where f64 sums per chunk (as here before) parted
//! from them at the last bit of α and β. Each thread's share runs
//! over the masses in order: the same on any number of the CPU's threads.

use glam::Vec4;

use crate::physics::{SUM_GROUPS_MOST, SUM_LANES, sum_groups};

const LANES: usize = SUM_LANES as usize;

/// Σ `value(i)` over the masses 0..n, per component, as lavapipe's solver kernels sum it.
#[inline(always)]
pub fn group_reduce(n: usize, value: impl Fn(usize) -> Vec4) -> Vec4 {
    let groups = sum_groups(n);
    if groups == 1 {
        // One group: its threads' sums added in order are the total (`grid_total` then adds
        // zeros to it).
        let mut lanes = [Vec4::ZERO; LANES];
        lane_sums_into(n, &mut lanes, value);
        return in_order(&lanes);
    }
    // The threads' sums (the grid's threads stride over the masses), each group's (`reduce_over`
    // over SUM_LANES threads at one level: in order), then `grid_total`: SUM_LANES shares of the
    // groups' sums, strided, each from zero, added in order. On the stack: no allocation in the
    // CG loop.
    let mut threads = [Vec4::ZERO; SUM_GROUPS_MOST * LANES];
    let threads = &mut threads[..groups * LANES];
    lane_sums_into(n, threads, value);
    let mut shares = [Vec4::ZERO; LANES];
    for (g, group) in threads.chunks(LANES).enumerate() {
        shares[g % LANES] += in_order(group);
    }
    in_order(&shares)
}

/// Sums from zero, in order (`reduce_over`'s level that one thread adds).
fn in_order(sums: &[Vec4]) -> Vec4 {
    sums.iter().fold(Vec4::ZERO, |total, s| total + *s)
}

/// Each of as many threads as `lanes` holds adds value(t), value(t + L), … (L threads) into
/// its lane, in order.
#[inline(always)]
fn lane_sums_into(n: usize, lanes: &mut [Vec4], value: impl Fn(usize) -> Vec4) {
    for base in (0..n).step_by(lanes.len()) {
        for (lane, sum) in lanes.iter_mut().enumerate().take(n - base) {
            *sum += value(base + lane);
        }
    }
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
        // Beyond one group: 3 groups of 8 threads striding by 24, each group's threads in
        // order, then the groups' sums in 8 strided shares (3 < 8: one each), in order.
        let n = 2 * crate::physics::SUM_GROUP_MASSES + 7;
        let big: Vec<f32> = (0..n)
            .map(|i| {
                if i % 97 == 0 {
                    3.0e7
                } else {
                    0.1 * (i % 13) as f32
                }
            })
            .collect();
        let got = group_reduce(n, |i| Vec4::splat(big[i])).x;
        let mut threads = [0.0f32; 24];
        for (i, v) in big.iter().enumerate() {
            threads[i % 24] += v;
        }
        let groups: Vec<f32> = threads
            .chunks(8)
            .map(|t| t.iter().fold(0.0f32, |a, b| a + b))
            .collect();
        let want = groups.iter().fold(0.0f32, |a, b| a + b);
        assert_eq!(got.to_bits(), want.to_bits());
        assert_eq!(group_max(3, |i| Vec4::splat(i as f32)), Vec4::splat(2.0));
    }
}
