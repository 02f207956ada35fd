//! The container, as the scene names it: what bounds the particles laterally, and the
//! one rule a cylinder's box follows (its side is 2R), which the scene's check, the
//! engine's settings and the contact search of a file all apply with one tolerance.

use crate::math::Real;

/// What bounds the particles laterally (the floor is always a wall, the top open).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Container {
    /// Plane side walls at the box corners (the paper's box).
    #[default]
    Box,
    /// Periodic horizontal axes, periods = the box's lateral lengths.
    Periodic,
    /// A vertical cylinder (3D) of this radius (m), axis through `lo + (R, R)`.
    Cylinder(Real),
}

/// Relative tolerance of "this box side is 2R" ([`fills_box`]): the side is given as
/// exactly 2.0 * R by granpack, or R taken as side / 2, so only rounding is absorbed.
pub const FILLS_BOX_TOL: Real = 1e-12;

/// Whether a box side `side` (m) is the one a cylinder of radius `radius` (m) fills:
/// 2R within [`FILLS_BOX_TOL`] of the larger of the two.
pub fn fills_box(side: Real, radius: Real) -> bool {
    (side - 2.0 * radius).abs() <= FILLS_BOX_TOL * side.abs().max(2.0 * radius)
}
