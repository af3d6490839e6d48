//! Masses ordered along a space-filling curve, so that a mass's neighbours on an irregular mesh
//! sit near it in memory, as a grid's do: the force gather then reads memory that is close by.

use glam::Vec3;

/// The vertices in Morton (Z-curve) order of their positions: `order[new] = old`.
pub fn morton_order(positions: &[Vec3]) -> Vec<u32> {
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    // One scale for all three axes keeps the curve's cells cubes.
    let extent = (hi - lo).max_element().max(f32::MIN_POSITIVE);
    let cell = |p: Vec3| {
        let q = ((p - lo) / extent * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
        spread(q.x as u32) | (spread(q.y as u32) << 1) | (spread(q.z as u32) << 2)
    };
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    order.sort_by_key(|&v| (cell(positions[v as usize]), v));
    order
}

/// The low 10 bits of `x`, two zero bits between each.
fn spread(x: u32) -> u32 {
    let mut x = x & 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    (x | (x << 2)) & 0x0924_9249
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_puts_two_zero_bits_between_bits() {
        assert_eq!(spread(0b111), 0b1001001);
        assert_eq!(spread(0x3ff), 0x0924_9249);
    }

    #[test]
    fn the_order_is_a_permutation_that_keeps_neighbours_near() {
        // A shuffled 16 × 16 grid: in Morton order, grid neighbours are close in the order.
        let mut pts: Vec<Vec3> = (0..256)
            .map(|i| Vec3::new((i % 16) as f32, (i / 16) as f32, 0.0))
            .collect();
        pts.reverse();
        let order = morton_order(&pts);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..256).collect::<Vec<u32>>());
        // The first four are one 2 × 2 block.
        let block: Vec<Vec3> = order[..4].iter().map(|&v| pts[v as usize]).collect();
        assert!(block.iter().all(|p| p.x < 2.0 && p.y < 2.0), "{block:?}");
    }
}
