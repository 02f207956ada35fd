//! Spatial search: a cell grid and the pair list built from it.

pub mod grid;

pub use grid::{brute_force_pairs, neighbor_pairs, CellGrid};
