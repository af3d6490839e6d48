//! How large the mass–mass contact's hash grid is: its table (a whole number of the GPU prefix
//! sum's blocks) and its cell. Both backends size their grid by these, so that they bin and visit
//! the masses alike.

/// Table entries per block of the GPU's prefix sum (`SCAN_BLOCK` in `shaders/common.wgsl`); the
/// table is a whole number of blocks.
pub const SCAN_BLOCK: u32 = 256;

/// Buckets in the table for `mass_count` masses: a power of two, at least twice the masses, so
/// that few cells share a bucket.
pub fn table_size(mass_count: usize) -> u32 {
    let n = u32::try_from(mass_count.max(1)).unwrap_or(u32::MAX / 4);
    (2 * n).next_power_of_two().max(SCAN_BLOCK)
}

/// Inverse of the cell size, 1 / (2 · radius): the GPU is handed this very value.
pub fn inv_cell_per_m(radius_m: f32) -> f32 {
    1.0 / (2.0 * radius_m)
}
