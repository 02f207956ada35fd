//! The container: the walls that bound the particles, and the periodic axes.
//!
//! Three containers share one model. Each has a floor (wall -1) and an open top:
//! - the box: plane side walls at `lo[k]` and `hi[k]` (walls -2 .. -5);
//! - the periodic cell: no side walls; the horizontal axes are periodic with periods
//!   `hi[k] - lo[k]`, pairs see each other by minimum image, and positions are wrapped
//!   into [lo, hi) at every pair-list rebuild (the pair list, keyed by particle
//!   indices, keeps its tangential history when a particle wraps);
//! - the cylinder (3D): one curved wall (-2), the inside of a vertical cylinder of
//!   radius R with its axis through (lo_x + R, lo_y + R).

use super::*;
pub use crate::geometry::Period;

/// A wall: a plane, or the inside of a vertical cylinder.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Wall {
    /// The plane `x[axis] = pos`; `sign` is the outward normal's sign (the normal
    /// points from the particle to the wall).
    Plane { axis: usize, pos: Real, sign: Real },
    /// The inside of the cylinder of radius `radius` around the vertical line through
    /// `centre` (on the first two axes).
    Cylinder { centre: [Real; 2], radius: Real },
}

impl Wall {
    /// Distance from `x` to the wall, positive on the particles' side (m).
    #[inline(always)]
    pub(crate) fn gap<const D: usize>(&self, x: &Vector<D>) -> Real {
        match *self {
            Wall::Plane { axis, pos, sign } => (pos - x[axis]) * sign,
            Wall::Cylinder { centre, radius } => {
                let (a, b) = (x[0] - centre[0], x[1] - centre[1]);
                radius - (a * a + b * b).sqrt()
            }
        }
    }

    /// Unit normal from a particle at `x` towards the wall. On the cylinder's axis,
    /// where the radial direction is undefined, x's first axis is taken (no particle
    /// touching the wall is there: R >= 2 r).
    #[inline(always)]
    pub(crate) fn normal<const D: usize>(&self, x: &Vector<D>) -> Vector<D> {
        let mut n = Vector::<D>::zeros();
        match *self {
            Wall::Plane { axis, sign, .. } => n[axis] = sign,
            Wall::Cylinder { centre, .. } => {
                let (a, b) = (x[0] - centre[0], x[1] - centre[1]);
                let rho = (a * a + b * b).sqrt();
                if rho > 0.0 {
                    (n[0], n[1]) = (a / rho, b / rho);
                } else {
                    n[0] = 1.0;
                }
            }
        }
        n
    }

    /// The effective radius R* of the Hertz law between a sphere of radius `r` and
    /// this wall (m). A plane: r. The cylinder is curved in the horizontal plane only:
    /// principal relative radii r along the axis and r R / (R - r) around it (1/R'' =
    /// 1/r - 1/R), and Hertz's elliptical contact is taken with the equivalent radius
    /// sqrt(R' R'') (Johnson, Contact Mechanics, 1985, section 4.2). For R >> r it tends
    /// to r, the plane.
    #[inline(always)]
    pub(crate) fn r_eff(&self, r: Real) -> Real {
        match *self {
            Wall::Plane { .. } => r,
            Wall::Cylinder { radius, .. } => r * (radius / (radius - r)).sqrt(),
        }
    }

    /// A short description of where a centre crossed this wall, for error messages.
    pub(crate) fn crossing<const D: usize>(&self, x: &Vector<D>) -> String {
        match *self {
            Wall::Plane { axis, .. } => format!("coordinate {axis} = {:e}", x[axis]),
            Wall::Cylinder { centre, radius } => {
                let (a, b) = (x[0] - centre[0], x[1] - centre[1]);
                format!(
                    "distance {:e} from the cylinder's axis, radius {radius:e}",
                    (a * a + b * b).sqrt()
                )
            }
        }
    }
}

/// The walls of a box in wall-id order (-1 floor, then -2 lo and -3 hi on the first
/// horizontal axis, -4 and -5 on the second): floor at `lo[vertical]`, side walls at
/// `lo[k]` and `hi[k]`; the top is open.
fn box_walls<const D: usize>(lo: &Vector<D>, hi: &Vector<D>) -> Vec<Wall> {
    let vert = D - 1;
    let mut walls = vec![floor(lo)];
    for k in 0..vert {
        walls.push(Wall::Plane {
            axis: k,
            pos: lo[k],
            sign: -1.0,
        });
        walls.push(Wall::Plane {
            axis: k,
            pos: hi[k],
            sign: 1.0,
        });
    }
    walls
}

/// The floor at `lo[vertical]`.
fn floor<const D: usize>(lo: &Vector<D>) -> Wall {
    Wall::Plane {
        axis: D - 1,
        pos: lo[D - 1],
        sign: -1.0,
    }
}

/// The walls of `container` with corners `lo`, `hi` (wall -1 the floor), and its
/// periodic axes.
pub(crate) fn container_walls<const D: usize>(
    container: Container,
    lo: &Vector<D>,
    hi: &Vector<D>,
) -> (Vec<Wall>, Option<Period<D>>) {
    match container {
        Container::Box => (box_walls(lo, hi), None),
        Container::Periodic => (vec![floor(lo)], Some(Period::lateral(lo, hi))),
        Container::Cylinder(radius) => (
            vec![
                floor(lo),
                Wall::Cylinder {
                    centre: [lo[0] + radius, lo[1] + radius],
                    radius,
                },
            ],
            None,
        ),
    }
}
