//! Spatial search: a cell grid and the pair list built from it.

pub mod grid;

pub use grid::{brute_force_pairs, morton_order, neighbor_pairs, neighbor_pairs_active, CellGrid};
