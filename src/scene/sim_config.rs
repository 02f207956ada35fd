//! The engine's settings: the material, time step, gravity, drag, walls, skin and
//! guards; the scene resolves into them, and the world runs them.

use super::container::{fills_box, Container};
use crate::dynamics::Material;
use crate::error::{check_range, Error, Result};
use crate::math::{Dim, Real, Spatial, Vector};

/// Most steps one call may ask for (1e10: hours for a handful of particles, far more
/// for a pack); beyond it a request is refused by name before any step is taken.
pub const MAX_STEPS_PER_CALL: u64 = 10_000_000_000;

/// Mass and moment of inertia of a 2D particle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Inertia2D {
    /// A sphere confined to the plane: m = 4/3 pi r^3 rho, I = 2/5 m r^2 (default;
    /// the reading of the paper's 2D examples).
    #[default]
    Sphere,
    /// A disc of unit thickness: m = pi r^2 rho (kg per m of thickness), I = 1/2 m r^2.
    Disc,
}

/// Engine settings. SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig<const D: usize> {
    /// Particle and wall material.
    pub material: Material,
    /// Time step (s). Default 1e-4. Must not exceed the Rayleigh estimate.
    pub dt: Real,
    /// Body acceleration (m/s^2). Default 2 m/s^2 downwards (the paper's jamming force).
    pub gravity: Vector<D>,
    /// Linear drag coefficient c_D (N s/m): f = -c_D v. Default 0.
    pub drag: Real,
    /// Integrate spins and torques. Default true. When false, spins stay zero.
    pub rotations: bool,
    /// Box corners: floor at `lo[vertical]`, side walls at `lo[k]` and `hi[k]` for the
    /// horizontal axes; `hi[vertical]` is ignored (open top). None: no walls.
    pub walls: Option<(Vector<D>, Vector<D>)>,
    /// What bounds the particles laterally inside `walls`' corners: side walls (the
    /// default), periodic axes, or a cylinder (see [`Container`]). Needs `walls`.
    pub container: Container,
    /// Largest Verlet skin, as a fraction of the smallest radius (-). Default 0.2.
    /// Each particle has a skin of its own, chosen at each rebuild from its speed so
    /// that it lasts about the world's `SKIN_STEPS` steps, within its `SKIN_FLOOR` of this and
    /// this: falling particles keep the wide skin while the resting bed under them
    /// tests few pairs. Never changes a result, only the speed: it sets when the list
    /// is rebuilt, and no force or position depends on that.
    pub skin_ratio: Real,
    /// Largest overlap tolerated, as a fraction of the smaller radius, before the run
    /// stops as unstable (-). Default 0.5.
    pub max_overlap_ratio: Real,
    /// 2D mass model. Ignored in 3D.
    pub inertia_2d: Inertia2D,
}

impl<const D: usize> SimConfig<D>
where
    Dim<D>: Spatial<D>,
{
    /// The paper's settings: its material, dt = 1e-4 s, g = 2 m/s^2 down, no drag,
    /// rotations on, no walls.
    pub fn paper() -> Self {
        let mut g = Vector::<D>::zeros();
        g[<Dim<D> as Spatial<D>>::VERTICAL] = -2.0;
        SimConfig {
            material: Material::default(),
            dt: 1e-4,
            gravity: g,
            drag: 0.0,
            rotations: true,
            walls: None,
            container: Container::Box,
            skin_ratio: 0.2,
            max_overlap_ratio: 0.5,
            inertia_2d: Inertia2D::Sphere,
        }
    }

    /// Checks every field; the error names the field and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.material.validate()?;
        check_range("dt", self.dt, 0.0, false, f64::INFINITY, false)?;
        for k in 0..D {
            check_range("gravity", self.gravity[k], -f64::MAX, true, f64::MAX, true)?;
        }
        check_range("drag", self.drag, 0.0, true, f64::INFINITY, false)?;
        check_range("skin_ratio", self.skin_ratio, 0.0, true, 10.0, true)?;
        check_range(
            "max_overlap_ratio",
            self.max_overlap_ratio,
            0.0,
            false,
            1.0,
            true,
        )?;
        if self.container != Container::Box && self.walls.is_none() {
            return Err(Error::invalid(
                "container",
                format!("{:?}", self.container),
                "needs the box corners (walls) that it fills",
            ));
        }
        if let (Container::Cylinder(radius), Some((lo, hi))) = (self.container, &self.walls) {
            if D != 3 {
                return Err(Error::invalid(
                    "container",
                    "cylinder",
                    "a cylinder needs 3 dimensions",
                ));
            }
            check_range("cylinder_radius", radius, 0.0, false, f64::MAX, true)?;
            for k in 0..2 {
                let side = hi[k] - lo[k];
                if !fills_box(side, radius) {
                    return Err(Error::invalid(
                        "box",
                        format!("side {side} on axis {k}"),
                        &format!(
                            "a cylinder of radius {radius} fills a box of side 2R = {}",
                            2.0 * radius
                        ),
                    ));
                }
            }
        }
        if let Some((lo, hi)) = &self.walls {
            let vert = <Dim<D> as Spatial<D>>::VERTICAL;
            for k in 0..D {
                if !lo[k].is_finite() {
                    return Err(Error::invalid("box", lo[k], "lower corner must be finite"));
                }
                if k != vert && !(hi[k].is_finite() && hi[k] > lo[k]) {
                    return Err(Error::invalid(
                        "box",
                        format!("[{}, {}] on axis {k}", lo[k], hi[k]),
                        "side walls must be finite with hi > lo",
                    ));
                }
            }
        }
        Ok(())
    }
}
