//! Spatial search: a cell grid and the pair list built from it.

pub mod grid;
mod period;

pub use grid::{
    brute_force_pairs, brute_force_pairs_periodic, morton_order, neighbor_pairs,
    neighbor_pairs_active, neighbor_pairs_periodic, row_major_order, CellGrid,
};
pub use period::Period;
