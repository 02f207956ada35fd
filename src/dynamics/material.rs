//! Material constants and the quantities derived from them.

use crate::error::{check_range, Result};
use crate::math::Real;

/// The normal and tangential contact law of pairs and walls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ContactLaw {
    /// Hertz normal spring, Mindlin tangential spring, both from E and nu (the default).
    HertzMindlin,
    /// Constant springs: PFC's `linear`, LAMMPS `hooke`, YADE's Cundall-Strack law.
    Linear {
        /// Normal stiffness k_n (N/m), > 0.
        kn: Real,
        /// Tangential stiffness k_t (N/m), > 0.
        kt: Real,
    },
}

/// Rolling resistance of pairs and walls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rolling {
    /// None (the default): contacts transmit no moment.
    None,
    /// The elastic-plastic spring-dashpot model, type C of Ai, Chen, Rotter and Ooi
    /// (2011): LIGGGHTS `epsd2`, LAMMPS `rolling sds`. A spring on the rolling
    /// displacement (R* times the relative rotation), capped at mu_r R* F_n, with a
    /// dashpot.
    Epsd {
        /// Rolling friction coefficient mu_r >= 0 (-).
        mu_r: Real,
        /// Rolling spring k_r (N/m); `None`: 2.25 mu_r^2 k_n, k_n the contact's
        /// current normal stiffness (Ai et al. 2011).
        k_r: Option<Real>,
        /// Rolling dashpot gamma_r (N s/m), >= 0.
        gamma_r: Real,
    },
}

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
    /// The contact law. Default Hertz-Mindlin.
    pub law: ContactLaw,
    /// Rolling resistance. Default none.
    pub rolling: Rolling,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            density: 1000.0,
            young: 1e8,
            poisson: 0.25,
            damping: 0.1,
            friction: 0.2,
            law: ContactLaw::HertzMindlin,
            rolling: Rolling::None,
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
        if let ContactLaw::Linear { kn, kt } = self.law {
            check_range("normal_stiffness", kn, 0.0, false, f64::INFINITY, false)?;
            check_range("tangential_stiffness", kt, 0.0, false, f64::INFINITY, false)?;
        }
        if let Rolling::Epsd { mu_r, k_r, gamma_r } = self.rolling {
            check_range("rolling_friction", mu_r, 0.0, true, f64::INFINITY, false)?;
            if let Some(k) = k_r {
                check_range("rolling_stiffness", k, 0.0, false, f64::INFINITY, false)?;
            }
            check_range("rolling_damping", gamma_r, 0.0, true, f64::INFINITY, false)?;
        }
        Ok(())
    }

    /// Whether contacts carry a rolling moment.
    pub fn has_rolling(&self) -> bool {
        !matches!(self.rolling, Rolling::None)
    }

    /// The critical time step for the smallest radius `r_min` (s): the Rayleigh step
    /// for Hertz-Mindlin ([`rayleigh_time_step`](Self::rayleigh_time_step)); for the
    /// linear law sqrt(m / k) with m the mass of a sphere of radius r_min (the mass of
    /// a disc of unit thickness is larger below r = 0.75 m, so this is the safe side)
    /// and k the stiffer of the two springs. A given rolling spring adds
    /// sqrt(0.4 m / k_r), the rotational period of that sphere on a wall (R* = r), the
    /// stiffest case.
    pub fn critical_time_step(&self, r_min: Real) -> Real {
        let m = 4.0 / 3.0 * std::f64::consts::PI * self.density * r_min.powi(3);
        let base = match self.law {
            ContactLaw::HertzMindlin => self.rayleigh_time_step(r_min),
            ContactLaw::Linear { kn, kt } => (m / kn.max(kt)).sqrt(),
        };
        match self.rolling {
            Rolling::Epsd { k_r: Some(k), .. } => base.min((0.4 * m / k).sqrt()),
            // 2.25 mu_r^2 k_n on R* = r against I = 0.4 m r^2: a rotational frequency
            // sqrt(5.625) mu_r times the normal one
            Rolling::Epsd {
                mu_r, k_r: None, ..
            } => base / (5.625f64.sqrt() * mu_r).max(1.0),
            Rolling::None => base,
        }
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
