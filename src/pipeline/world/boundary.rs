//! The container: the walls that bound the particles.

use super::*;

/// A wall plane: axis, position, outward normal sign (normal points from the particle
/// to the wall).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Wall {
    pub(super) axis: usize,
    pub(super) pos: Real,
    pub(super) sign: Real,
}

impl Wall {
    /// Distance from `x` to the plane, positive on the box side (m).
    #[inline(always)]
    pub(crate) fn gap<const D: usize>(&self, x: &Vector<D>) -> Real {
        (self.pos - x[self.axis]) * self.sign
    }

    /// Unit normal from a particle towards the wall.
    #[inline(always)]
    pub(crate) fn normal<const D: usize>(&self) -> Vector<D> {
        let mut n = Vector::<D>::zeros();
        n[self.axis] = self.sign;
        n
    }
}

/// The walls of a box in wall-id order (-1 floor, then -2 lo and -3 hi on the first
/// horizontal axis, -4 and -5 on the second): floor at `lo[vertical]`, side walls at
/// `lo[k]` and `hi[k]`; the top is open.
pub(crate) fn box_walls<const D: usize>(lo: &Vector<D>, hi: &Vector<D>) -> Vec<Wall> {
    let vert = D - 1;
    let mut walls = vec![Wall {
        axis: vert,
        pos: lo[vert],
        sign: -1.0,
    }];
    for k in 0..vert {
        walls.push(Wall {
            axis: k,
            pos: lo[k],
            sign: -1.0,
        });
        walls.push(Wall {
            axis: k,
            pos: hi[k],
            sign: 1.0,
        });
    }
    walls
}
