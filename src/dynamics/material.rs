//! Material constants and the quantities derived from them.

use crate::error::{check_range, Result};
use crate::math::Real;

/// Particle (and wall) material. SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Mass density rho (kg/m^3). Default 1000.
    pub density: Real,
    /// Young's modulus E (Pa). Default 1e8.
    pub young: Real,
    /// Poisson's ratio nu, in (-1, 0.5). Default 0.25.
    pub poisson: Real,
    /// Damping ratio xi of the normal and tangential dashpots, in [0, 1]
    /// (the paper's "damping rate"). Default 0.1.
    pub damping: Real,
    /// Coulomb friction coefficient mu >= 0 (particle-particle and particle-wall).
    /// Default 0.2.
    pub friction: Real,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            density: 1000.0,
            young: 1e8,
            poisson: 0.25,
            damping: 0.1,
            friction: 0.2,
        }
    }
}

impl Material {
    /// Checks every field against its allowed range.
    pub fn validate(&self) -> Result<()> {
        check_range("density", self.density, 0.0, false, f64::INFINITY, false)?;
        check_range("young", self.young, 0.0, false, f64::INFINITY, false)?;
        check_range("poisson", self.poisson, -1.0, false, 0.5, false)?;
        check_range("damping", self.damping, 0.0, true, 1.0, true)?;
        check_range("friction", self.friction, 0.0, true, f64::INFINITY, false)?;
        Ok(())
    }

    /// Effective Young's modulus of two bodies of this material,
    /// E* = E / (2 (1 - nu^2)) (Pa).
    pub fn e_star(&self) -> Real {
        self.young / (2.0 * (1.0 - self.poisson * self.poisson))
    }

    /// Shear modulus G = E / (2 (1 + nu)) (Pa).
    pub fn shear_modulus(&self) -> Real {
        self.young / (2.0 * (1.0 + self.poisson))
    }

    /// Effective shear modulus of two bodies of this material,
    /// G* = G / (2 (2 - nu)) (Pa).
    pub fn g_star(&self) -> Real {
        self.shear_modulus() / (2.0 * (2.0 - self.poisson))
    }

    /// Rayleigh critical time step for the smallest radius `r_min` (m):
    /// pi r_min sqrt(rho / G) / (0.1631 nu + 0.8766) (s).
    pub fn rayleigh_time_step(&self, r_min: Real) -> Real {
        std::f64::consts::PI * r_min * (self.density / self.shear_modulus()).sqrt()
            / (0.1631 * self.poisson + 0.8766)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_moduli_of_the_paper_material() {
        let m = Material::default();
        assert!((m.e_star() - 1e8 / (2.0 * 0.9375)).abs() < 1e-6);
        assert!((m.shear_modulus() - 4e7).abs() < 1e-6);
        assert!((m.g_star() - 4e7 / 3.5).abs() < 1e-6);
        // Rayleigh step for r = 0.01 m: pi * 0.01 * sqrt(1000/4e7) / 0.917375
        let dt = m.rayleigh_time_step(0.01);
        assert!((dt - 1.712_23e-4).abs() < 1e-8, "{dt}");
    }

    #[test]
    fn validation_names_the_parameter() {
        let m = Material {
            poisson: 0.5,
            ..Material::default()
        };
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("poisson"), "{e}");
        let m = Material {
            friction: -0.1,
            ..Material::default()
        };
        assert!(m.validate().unwrap_err().to_string().contains("friction"));
    }
}
