//! A scene as the user writes it ([`SceneSpec`]: names, numbers and lists, the keys of
//! `granpack.PackScene`), the one validator of every range and cross-field rule, and
//! what a valid scene resolves to ([`Resolved`]: the radius law's moments, the
//! container, the critical step; [`PackConfig`]: what the layer loop runs).
//!
//! The Python package coerces types and reads TOML; every rule about values lives
//! here, so that a scene built in Python, by `granpack.Simulation`, by the layer loop or
//! on the command line meets the same checks and the same errors.

mod config;
mod container;
pub mod radius_law;
mod sim_config;
pub mod stages;

pub use config::{PackConfig, MAX_ATTEMPTS, MAX_LAYERS, MAX_PARTICLES, MAX_STEPS_PER_LAYER};
pub use container::{fills_box, Container, FILLS_BOX_TOL};
pub use radius_law::{DiscreteLaw, FractionsBy, RadiusLaw, SieveLaw};
pub use sim_config::{Inertia2D, SimConfig, MAX_STEPS_PER_CALL};
pub use stages::{
    ConsolidateSpec, DensitySpec, Particles, RestSpec, TileSpec, TrimSpec, DENSITY_METHODS,
    TARGET_KEYS,
};

use crate::dynamics::Material;
use crate::error::{check_range, Error, Result};
use crate::math::{Dim, Real, Spatial, Vector};
use radius_law::lognormal_params;

/// The containers a scene may name, one per variant of [`Container`]: walls all round,
/// periodic horizontal axes, a vertical cylinder.
pub const CONTAINERS: [&str; 3] = ["box", "periodic", "cylinder"];

/// Solid fraction near which random sequential addition saturates: 0.547 for discs,
/// 0.384 for spheres. A layer's `phi_layer` must stay below it.
pub const fn rsa_saturation(dim: usize) -> Real {
    if dim == 2 {
        0.547
    } else {
        0.384
    }
}

/// The radius-law keys of a scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LawSpec {
    /// `"constant"`, `"gaussian"`, `"uniform"`, `"lognormal"`, `"discrete"` or `"sieve"`.
    pub radius_law: String,
    /// Mean radius (m) (the constant radius; the Gaussian's and lognormal's mean).
    pub r_mean: Real,
    /// Standard deviation of the radius (m).
    pub r_std: Real,
    /// Truncation bounds (m); the uniform law's range.
    pub r_min: Option<Real>,
    /// See `r_min`.
    pub r_max: Option<Real>,
    /// The discrete law's radii (m) and fractions.
    pub radii: Option<Vec<Real>>,
    /// See `radii`.
    pub fractions: Option<Vec<Real>>,
    /// `"number"` or `"mass"`: what the discrete law's fractions count.
    pub fractions_by: String,
    /// The sieve curve: sizes (m, diameters) and the fractions passing them.
    pub sieve_sizes: Option<Vec<Real>>,
    /// See `sieve_sizes`.
    pub sieve_passing: Option<Vec<Real>>,
}

impl LawSpec {
    /// The law, checked; a key the law does not take, or one it lacks, is named.
    /// `mass_exponent`: the power of the radius a particle's mass grows with (3, or 2
    /// for discs of unit thickness).
    pub fn law(&self, mass_exponent: i32) -> Result<RadiusLaw> {
        let name = self.radius_law.as_str();
        let takes = |key: &str, given: bool, law: &str| -> Result<()> {
            if given && name != law {
                return Err(Error::invalid(
                    key,
                    "",
                    &format!(
                        "only radius_law = \"{law}\" takes {key} (radius_law = {name:?}); \
                         unset it (None)"
                    ),
                ));
            }
            Ok(())
        };
        takes("radii", self.radii.is_some(), "discrete")?;
        takes("fractions", self.fractions.is_some(), "discrete")?;
        takes("sieve_sizes", self.sieve_sizes.is_some(), "sieve")?;
        takes("sieve_passing", self.sieve_passing.is_some(), "sieve")?;
        let by = match self.fractions_by.as_str() {
            "number" => FractionsBy::Number,
            "mass" => FractionsBy::Mass,
            other => {
                return Err(Error::invalid(
                    "fractions_by",
                    format!("{other:?}"),
                    "must be \"number\" or \"mass\"",
                ))
            }
        };
        let need = |key: &str, v: &Option<Vec<Real>>| -> Result<Vec<Real>> {
            v.clone().ok_or_else(|| {
                Error::invalid(
                    key,
                    "",
                    &format!("radius_law = {name:?} needs {key} (a list of numbers)"),
                )
            })
        };
        let std = self.r_std;
        if !(std.is_finite() && std >= 0.0) {
            return Err(Error::invalid("r_std", std, "must be finite and >= 0 (m)"));
        }
        let law = match name {
            "constant" => RadiusLaw::Constant(self.r_mean),
            "gaussian" => RadiusLaw::Gaussian {
                mean: self.r_mean,
                std,
                min: self.r_min.unwrap_or(self.r_mean - 3.0 * std),
                max: self.r_max.unwrap_or(self.r_mean + 3.0 * std),
            },
            "uniform" => {
                let (Some(min), Some(max)) = (self.r_min, self.r_max) else {
                    return Err(Error::invalid(
                        if self.r_min.is_none() {
                            "r_min"
                        } else {
                            "r_max"
                        },
                        "",
                        "radius_law = \"uniform\" needs r_min and r_max (m)",
                    ));
                };
                RadiusLaw::Uniform { min, max }
            }
            "lognormal" => {
                // default window: three standard deviations of ln r about its mean
                let (mu, sigma) = if self.r_mean > 0.0 {
                    lognormal_params(self.r_mean, std)
                } else {
                    (Real::NAN, Real::NAN)
                };
                RadiusLaw::Lognormal {
                    mean: self.r_mean,
                    std,
                    min: self.r_min.unwrap_or((mu - 3.0 * sigma).exp()),
                    max: self.r_max.unwrap_or((mu + 3.0 * sigma).exp()),
                }
            }
            "discrete" => RadiusLaw::Discrete(DiscreteLaw::new(
                &need("radii", &self.radii)?,
                &need("fractions", &self.fractions)?,
                by,
                mass_exponent,
            )?),
            "sieve" => RadiusLaw::Sieve(SieveLaw::new(
                &need("sieve_sizes", &self.sieve_sizes)?,
                &need("sieve_passing", &self.sieve_passing)?,
                mass_exponent,
            )?),
            other => {
                return Err(Error::invalid(
                    "radius_law",
                    format!("{other:?}"),
                    &format!("must be one of {}", quoted(&RadiusLaw::NAMES)),
                ))
            }
        };
        law.validate()?;
        Ok(law)
    }
}

/// The names, each in double quotes, joined by commas ("a", "b" or "c").
fn quoted(names: &[&str]) -> String {
    let q: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    match q.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => q.join(""),
    }
}

/// The material constants of a scene (SI units).
pub type MaterialSpec = Material;

/// A whole scene as `granpack.PackScene` holds it, keys by their names there. The
/// keys the layer loop does not run (the flat top's rest tolerance, the density
/// target) are here too, for their checks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneSpec {
    /// 2 or 3.
    pub dim: i64,
    /// Lengths of the base along the horizontal axes (m), `dim - 1` of them.
    pub base: Vec<Real>,
    /// One of [`CONTAINERS`].
    pub container: String,
    /// The cylinder's radius (m); None takes base / 2 (a square base).
    pub cylinder_radius: Option<Real>,
    /// Desired height H_d (m).
    pub height: Real,
    /// The radius law.
    pub law: LawSpec,
    /// Layer slab thickness (m).
    pub h_layer: Real,
    /// Solid fraction of each RSA layer (-).
    pub phi_layer: Real,
    /// Material constants.
    pub material: Material,
    /// Time step (s).
    pub dt: Real,
    /// DEM time per layer (s).
    pub settle_time: Real,
    /// Gravity's magnitude (m/s^2), along -vertical.
    pub gravity: Real,
    /// Linear drag (N s/m).
    pub drag: Real,
    /// Whether particles spin.
    pub rotations: bool,
    /// Random seed and stream, each in [0, 2^64 - 1] (wider here, so that a value
    /// beyond the range is refused by name rather than by the conversion).
    pub seed: i128,
    /// See `seed`.
    pub stream: i128,
    /// `"sphere"` or `"disc"`: the mass and inertia of a 2D particle.
    pub inertia_2d: String,
    /// Largest Verlet skin over the smallest radius (-).
    pub skin_ratio: Real,
    /// Largest overlap over the smaller radius before the run stops (-).
    pub max_overlap_ratio: Real,
    /// Most consecutive failed placements.
    pub max_attempts: i128,
    /// Most layers.
    pub max_layers: i128,
    /// Adaptive settling tolerance (-), None: the fixed settle time.
    pub settle_tol: Option<Real>,
    /// The coarser step after each landing (s).
    pub settle_dt: Option<Real>,
    /// Freezing depth (m), None: never freeze.
    pub freeze_depth: Option<Real>,
    /// Freezing speed (m/s).
    pub freeze_speed: Real,
    /// Freezing force over weight (-).
    pub freeze_force: Real,
    /// The flat top at `height`.
    pub trim: bool,
    /// Unbalanced-force ratio a deposit is run to (-), None: not run.
    pub rest_tol: Option<Real>,
    /// The density targets, at most one given: phi (-), void ratio e (-), relative
    /// density Dr (-).
    pub target_phi: Option<Real>,
    /// See `target_phi`.
    pub target_void_ratio: Option<Real>,
    /// See `target_phi`.
    pub target_relative_density: Option<Real>,
    /// Tolerance of a density target, in the target's own quantity.
    pub density_tol: Option<Real>,
    /// `"auto"`, `"deposition"` or `"servo"`.
    pub density_method: String,
    /// The scene's `[consolidate]` table, None: no consolidation.
    pub consolidate: Option<ConsolidateSpec>,
}

/// What a valid scene resolves to: the values derived from its keys, in one place.
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    /// Smallest and largest radius of the law (m).
    pub r_min: Real,
    /// See `r_min`.
    pub r_max: Real,
    /// Mean and standard deviation of the radius by number (m); for the Gaussian and
    /// the lognormal, the parameters before truncation.
    pub r_mean: Real,
    /// See `r_mean`.
    pub r_std: Real,
    /// The base (m): a cylinder's is (2R, 2R).
    pub base: Vec<Real>,
    /// The cylinder's radius (m), None for the other containers.
    pub cylinder_radius: Option<Real>,
    /// The critical (Rayleigh) time step of r_min (s).
    pub critical_dt: Real,
    /// Rough particle count: layers of phi_layer filling 1.5 H_d / h_layer slabs.
    pub estimated_particles: Real,
    /// The stages the scene lists, checked: the flat top, the settling to rest, the
    /// density target, the consolidation.
    pub stages: Stages,
}

/// The stages a scene lists after its layer loop, each checked against the scene's
/// container and radii; None where the scene does not run it.
#[derive(Clone, Debug, PartialEq)]
pub struct Stages {
    /// The flat top at the scene's height (`trim = true`).
    pub trim: Option<TrimSpec>,
    /// The settling to rest (`rest_tol`), the tolerance in `unbalanced_tol`.
    pub rest: Option<RestSpec>,
    /// The density target, when one of [`TARGET_KEYS`] is given.
    pub density: Option<DensitySpec>,
    /// The consolidation (`[consolidate]`).
    pub consolidate: Option<ConsolidateSpec>,
}

impl SceneSpec {
    /// The power of the radius a particle's mass grows with: 3, or 2 for discs of unit
    /// thickness (`inertia_2d = "disc"` in 2D).
    pub fn mass_exponent(&self) -> i32 {
        if self.dim == 2 && self.inertia_2d == "disc" {
            2
        } else {
            3
        }
    }

    /// The radius law, checked.
    pub fn radius_law(&self) -> Result<RadiusLaw> {
        self.law.law(self.mass_exponent())
    }

    fn dim(&self) -> Result<usize> {
        match self.dim {
            2 => Ok(2),
            3 => Ok(3),
            other => Err(Error::invalid("dim", other, "must be 2 or 3")),
        }
    }

    /// The container and the base it takes: a cylinder without a radius takes
    /// R = base / 2 (the base must be square), one with a radius has the base
    /// (2R, 2R). `r_max`: the law's largest radius (m).
    pub fn container(&self, r_max: Real) -> Result<(Container, Vec<Real>)> {
        let base = self.base.clone();
        let quoted_base = || {
            let b: Vec<String> = base.iter().map(|b| format!("{b:?}")).collect();
            format!("({})", b.join(", "))
        };
        match (self.container.as_str(), self.cylinder_radius) {
            ("box", None) => Ok((Container::Box, base)),
            ("periodic", None) => Ok((Container::Periodic, base)),
            (name @ ("box" | "periodic"), Some(r)) => Err(Error::invalid(
                "cylinder_radius",
                r,
                &format!("only a container = 'cylinder' has a radius (container = '{name}')"),
            )),
            ("cylinder", _) if self.dim != 3 => Err(Error::invalid(
                "container",
                "'cylinder'",
                "a cylinder needs dim = 3 (in 2D use 'box' or 'periodic')",
            )),
            ("cylinder", None) => {
                if base.len() == 2 && base[0] != base[1] {
                    return Err(Error::invalid(
                        "base",
                        quoted_base(),
                        "a cylinder without cylinder_radius takes R = base / 2, so base \
                         must be square (2R, 2R)",
                    ));
                }
                let radius = 0.5 * base[0];
                check_cylinder(radius, r_max)?;
                Ok((Container::Cylinder(radius), base))
            }
            ("cylinder", Some(radius)) => {
                check_range("cylinder_radius", radius, 0.0, false, Real::INFINITY, false)?;
                if !base.iter().all(|&b| fills_box(b, radius)) {
                    return Err(Error::invalid(
                        "base",
                        format!("{} with cylinder_radius = {radius} m", quoted_base()),
                        &format!(
                            "a cylinder's base is (2R, 2R) = ({d}, {d}) m; give base to \
                             match, or leave cylinder_radius unset to take R = base / 2",
                            d = 2.0 * radius
                        ),
                    ));
                }
                check_cylinder(radius, r_max)?;
                Ok((Container::Cylinder(radius), vec![2.0 * radius; 2]))
            }
            (other, _) => Err(Error::invalid(
                "container",
                format!("'{other}'"),
                &format!(
                    "must be one of {}",
                    CONTAINERS.map(|c| format!("'{c}'")).join(", ")
                ),
            )),
        }
    }

    fn pack_config_with<const D: usize>(&self, law: RadiusLaw) -> Result<(PackConfig<D>, Vec<Real>)>
    where
        Dim<D>: Spatial<D>,
    {
        if self.base.len() != D - 1 {
            return Err(Error::invalid(
                "base",
                format!("{:?}", self.base),
                &format!("expected {} length(s) (m) for dim = {D}", D - 1),
            ));
        }
        let (container, base) = self.container(law.r_max())?;
        let inertia_2d = match self.inertia_2d.as_str() {
            "sphere" => Inertia2D::Sphere,
            "disc" => Inertia2D::Disc,
            other => {
                return Err(Error::invalid(
                    "inertia_2d",
                    format!("'{other}'"),
                    "must be 'sphere' or 'disc'",
                ))
            }
        };
        let saturation = rsa_saturation(D);
        if !(self.phi_layer > 0.0 && self.phi_layer < saturation) {
            return Err(Error::invalid(
                "phi_layer",
                self.phi_layer,
                &format!("must lie in (0, {saturation}) (RSA saturates near {saturation} in {D}D)"),
            ));
        }
        if !(self.gravity > 0.0 && self.gravity.is_finite()) {
            return Err(Error::invalid(
                "gravity",
                self.gravity,
                "must lie in (0, inf] (m/s^2; a magnitude, the pull is along -vertical)",
            ));
        }
        let v = <Dim<D> as Spatial<D>>::VERTICAL;
        let mut gravity = Vector::<D>::zeros();
        gravity[v] = -self.gravity;
        let mut b = Vector::<D>::zeros();
        let mut it = base.iter();
        for k in (0..D).filter(|&k| k != v) {
            b[k] = *it.next().expect("D - 1 lengths");
        }
        let counted = |name: &str, value: i128, hi: i128| -> Result<i128> {
            if (1..=hi).contains(&value) {
                Ok(value)
            } else {
                Err(Error::invalid(
                    name,
                    value,
                    &format!("must lie in [1, {hi}]"),
                ))
            }
        };
        let seed = |name: &str, value: i128| -> Result<u64> {
            u64::try_from(value)
                .map_err(|_| Error::invalid(name, value, &format!("must lie in [0, {}]", u64::MAX)))
        };
        let cfg = PackConfig {
            sim: SimConfig {
                material: self.material,
                dt: self.dt,
                gravity,
                drag: self.drag,
                rotations: self.rotations,
                walls: None,
                container,
                skin_ratio: self.skin_ratio,
                max_overlap_ratio: self.max_overlap_ratio,
                inertia_2d,
            },
            base: b,
            height: self.height,
            radii: law,
            h_layer: self.h_layer,
            phi_layer: self.phi_layer,
            settle_time: self.settle_time,
            seed: seed("seed", self.seed)?,
            stream: seed("stream", self.stream)?,
            max_attempts: counted("max_attempts", self.max_attempts, MAX_ATTEMPTS as i128)? as u64,
            max_layers: counted("max_layers", self.max_layers, MAX_LAYERS as i128)? as usize,
            settle_tol: self.settle_tol,
            freeze_depth: self.freeze_depth,
            freeze_speed: self.freeze_speed,
            freeze_force: self.freeze_force,
            settle_dt: self.settle_dt,
        };
        cfg.validate()?;
        Ok((cfg, base))
    }

    /// Checks every rule of the scene and returns what it resolves to. The error names
    /// the scene key and its allowed range (an unstable `dt` is
    /// [`Error::UnstableTimeStep`]).
    pub fn resolve(&self) -> Result<Resolved> {
        match self.dim()? {
            2 => self.checked::<2>().map(|(r, _)| r),
            _ => self.checked::<3>().map(|(r, _)| r),
        }
    }

    /// What the layer loop runs, after every rule of the scene is checked (as
    /// [`SceneSpec::resolve`] checks them): `dim` must be `D`.
    pub fn checked_config<const D: usize>(&self) -> Result<PackConfig<D>>
    where
        Dim<D>: Spatial<D>,
    {
        if self.dim()? != D {
            return Err(Error::invalid("dim", self.dim, &format!("expected {D}")));
        }
        self.checked::<D>().map(|(_, cfg)| cfg)
    }

    fn checked<const D: usize>(&self) -> Result<(Resolved, PackConfig<D>)>
    where
        Dim<D>: Spatial<D>,
    {
        let law = self.radius_law()?;
        let (r_min, r_max) = (law.r_min(), law.r_max());
        let (r_mean, r_std) = law.number_moments();
        let (cfg, base) = self.pack_config_with::<D>(law)?;
        let container = cfg.sim.container;
        let particles = Particles {
            r_min,
            r_mean,
            material: &self.material,
            max_overlap_ratio: self.max_overlap_ratio,
        };
        let stages = self.stages(D, &container, &particles)?;
        let resolved = Resolved {
            r_min,
            r_max,
            r_mean,
            r_std,
            base,
            cylinder_radius: match cfg.sim.container {
                Container::Cylinder(radius) => Some(radius),
                _ => None,
            },
            critical_dt: self.material.critical_time_step(r_min),
            estimated_particles: cfg.estimated_particles(),
            stages,
        };
        Ok((resolved, cfg))
    }

    /// The stages the scene lists, each checked by its own spec (the scene's
    /// `rest_tol` named as such), and the rules between them.
    fn stages(&self, dim: usize, container: &Container, p: &Particles<'_>) -> Result<Stages> {
        let rest = match self.rest_tol {
            Some(tol) => {
                let spec = RestSpec {
                    unbalanced_tol: tol,
                    ..RestSpec::default()
                };
                spec.validate(dim, container)
                    .map_err(|e| e.renamed("unbalanced_tol", "rest_tol"))?;
                Some(spec)
            }
            None => None,
        };
        let density = DensitySpec {
            target_phi: self.target_phi,
            target_void_ratio: self.target_void_ratio,
            target_relative_density: self.target_relative_density,
            density_tol: self.density_tol,
            density_method: self.density_method.clone(),
        };
        density.validate(dim, container)?;
        if let Some(c) = &self.consolidate {
            c.validate(dim, container)?;
        }
        if density.density_method == "servo"
            && density.target().is_some()
            && self.consolidate.is_none()
        {
            return Err(Error::invalid(
                "density_method",
                "'servo'",
                "the servo's friction reduction runs in the consolidation stage; give a \
                 [consolidate] table, or density_method = 'deposition'",
            ));
        }
        let trim = if self.trim {
            let spec = TrimSpec::default();
            spec.validate(dim, container)?;
            spec.check_particles(self.height, p)?;
            Some(spec)
        } else {
            None
        };
        if let Some(c) = &self.consolidate {
            c.check_particles(dim, container, p)?;
        }
        Ok(Stages {
            trim,
            rest,
            density: density.target().is_some().then_some(density),
            consolidate: self.consolidate.clone(),
        })
    }
}

/// A cylinder's radius must hold a particle: at least 2 r_max.
fn check_cylinder(radius: Real, r_max: Real) -> Result<()> {
    if radius < 2.0 * r_max || radius.is_nan() {
        return Err(Error::invalid(
            "cylinder_radius",
            format!("{radius} m"),
            &format!("must be at least 2 r_max = {} m", 2.0 * r_max),
        ));
    }
    Ok(())
}
