//! Dimension-generic small vectors.
//!
//! One engine serves 2D discs and 3D spheres. Translational quantities are
//! `nalgebra::SVector<f64, D>`; angular quantities (spin, torque) are a scalar in 2D and
//! a 3-vector in 3D. The [`Spatial`] trait, implemented for [`Dim<2>`] and [`Dim<3>`],
//! supplies the angular type and the two generalised cross products the contact law
//! needs (the layout follows parry's `math` module). Engine types carry the bound
//! `Dim<D>: Spatial<D>`.

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Mul, Neg, Sub};

/// Floating-point type of the engine (SI units throughout).
pub type Real = f64;

/// A translational vector (position, velocity, force) in `D` dimensions.
pub type Vector<const D: usize> = nalgebra::SVector<Real, D>;

/// Marker for the spatial dimension; `Dim<2>` and `Dim<3>` implement [`Spatial`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Dim<const D: usize>;

/// Arithmetic an angular quantity (a scalar in 2D, a 3-vector in 3D) must support.
pub trait AngOps:
    Copy
    + Default
    + Debug
    + Send
    + Sync
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<Real, Output = Self>
    + AddAssign
    + 'static
{
    /// Number of components stored per particle (1 in 2D, 3 in 3D).
    const NCOMP: usize;
    /// Squared magnitude.
    fn norm2(&self) -> Real;
    /// True when every component is finite.
    fn finite(&self) -> bool;
    /// Component `k` (`k < NCOMP`).
    fn comp(&self, k: usize) -> Real;
    /// Builds the value from `NCOMP` components.
    fn from_comps(c: &[Real]) -> Self;
}

impl AngOps for Real {
    const NCOMP: usize = 1;
    #[inline(always)]
    fn norm2(&self) -> Real {
        self * self
    }
    #[inline(always)]
    fn finite(&self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn comp(&self, _k: usize) -> Real {
        *self
    }
    fn from_comps(c: &[Real]) -> Self {
        c[0]
    }
}

impl AngOps for Vector<3> {
    const NCOMP: usize = 3;
    #[inline(always)]
    fn norm2(&self) -> Real {
        self.norm_squared()
    }
    #[inline(always)]
    fn finite(&self) -> bool {
        self.iter().all(|c| c.is_finite())
    }
    #[inline(always)]
    fn comp(&self, k: usize) -> Real {
        self[k]
    }
    fn from_comps(c: &[Real]) -> Self {
        Vector::<3>::new(c[0], c[1], c[2])
    }
}

/// What differs between 2D and 3D beyond the vector length.
pub trait Spatial<const D: usize>: Send + Sync + 'static {
    /// Angular velocity / torque type: `f64` in 2D (about the out-of-plane axis),
    /// `Vector<3>` in 3D.
    type Ang: AngOps;
    /// Index of the vertical axis (gravity acts along minus this axis by default):
    /// y (1) in 2D, z (2) in 3D.
    const VERTICAL: usize;
    /// `w x v`: velocity of a point at arm `v` on a body spinning with `w`.
    fn cross_wv(w: Self::Ang, v: &Vector<D>) -> Vector<D>;
    /// `a x b`: the torque of force `b` at arm `a`.
    fn cross_vv(a: &Vector<D>, b: &Vector<D>) -> Self::Ang;
}

impl Spatial<2> for Dim<2> {
    type Ang = Real;
    const VERTICAL: usize = 1;
    #[inline(always)]
    fn cross_wv(w: Real, v: &Vector<2>) -> Vector<2> {
        // (0, 0, w) x (vx, vy, 0) = (-w vy, w vx, 0)
        Vector::<2>::new(-w * v[1], w * v[0])
    }
    #[inline(always)]
    fn cross_vv(a: &Vector<2>, b: &Vector<2>) -> Real {
        a[0] * b[1] - a[1] * b[0]
    }
}

impl Spatial<3> for Dim<3> {
    type Ang = Vector<3>;
    const VERTICAL: usize = 2;
    #[inline(always)]
    fn cross_wv(w: Vector<3>, v: &Vector<3>) -> Vector<3> {
        w.cross(v)
    }
    #[inline(always)]
    fn cross_vv(a: &Vector<3>, b: &Vector<3>) -> Vector<3> {
        a.cross(b)
    }
}

/// Volume of a particle of radius `r`: the disc area in 2D, the sphere volume in 3D.
#[inline]
pub fn particle_volume<const D: usize>(r: Real) -> Real {
    if D == 2 {
        std::f64::consts::PI * r * r
    } else {
        4.0 / 3.0 * std::f64::consts::PI * r * r * r
    }
}

/// [`particle_volume`] for a dimension known at run time (2: a disc, otherwise a
/// sphere).
#[inline]
pub fn particle_volume_of(dim: usize, r: Real) -> Real {
    if dim == 2 {
        particle_volume::<2>(r)
    } else {
        particle_volume::<3>(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_products_2d_match_3d_embedding() {
        let w = 0.7;
        let v = Vector::<2>::new(0.3, -1.1);
        let w3 = Vector::<3>::new(0.0, 0.0, w);
        let v3 = Vector::<3>::new(v[0], v[1], 0.0);
        let c3 = w3.cross(&v3);
        let c2 = Dim::<2>::cross_wv(w, &v);
        assert!((c2[0] - c3[0]).abs() < 1e-15 && (c2[1] - c3[1]).abs() < 1e-15);
        let a = Vector::<2>::new(2.0, 0.5);
        let a3 = Vector::<3>::new(2.0, 0.5, 0.0);
        assert!((Dim::<2>::cross_vv(&a, &v) - a3.cross(&v3)[2]).abs() < 1e-15);
    }
}
