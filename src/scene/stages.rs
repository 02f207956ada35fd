//! The stages after the layer loop, as a scene or a stage's function sets them: one spec
//! per stage (the flat top, the settling to rest, the density target, the
//! consolidation, the tiling), each with its defaults ([`Default`]) and its checks
//! (`validate(dim, &Container)`), the only ones. The Python package types the values
//! and exports the names and the defaults from here (`_core.CONSOLIDATION_MODES`,
//! `_core.CONSOLIDATE_DEFAULTS`, ...), so that the scene, the function and the command
//! line meet the same check and name the key the same way.
//!
//! A stage's checks that need the particles it runs on (the Hertz overlap a target
//! stress asks, the Rayleigh step of the smallest radius, the flat top's height against
//! the smallest particle) take them as [`Particles`]: the scene's radius law when a
//! scene is built, the pack's own radii when the stage starts.

use super::{Container, MAX_STEPS_PER_CALL};
use crate::dynamics::Material;
use crate::error::{check_range, fmt_g_digits, Error, Result};
use crate::math::Real;

/// The consolidation modes: the lid alone (K0), every wall the same stress, the lid
/// and the side walls each their own.
pub const CONSOLIDATION_MODES: [&str; 3] = ["oedometric", "isotropic", "anisotropic"];

/// The density target keys, in the order a scene lists them.
pub const TARGET_KEYS: [&str; 3] = ["target_phi", "target_void_ratio", "target_relative_density"];

/// The density methods.
pub const DENSITY_METHODS: [&str; 3] = ["auto", "deposition", "servo"];

/// The keys of a scene's `[consolidate]` table: the consolidation's settings.
pub const CONSOLIDATE_KEYS: [&str; 14] = [
    "stress",
    "mode",
    "lateral",
    "gravity",
    "stress_tol",
    "unbalanced_tol",
    "hold",
    "check_every",
    "max_steps",
    "max_wall_speed",
    "gain",
    "local_damping",
    "dt",
    "wall_friction",
];

/// The largest target stress any stage takes (Pa; N/m in 2D), whatever the material.
pub const MAX_STRESS: Real = 1e12;

/// The largest wall speed (m/s) a consolidation takes.
pub const MAX_WALL_SPEED: Real = 1e6;

/// The smallest overlap, over the mean radius, that a stress target may ask of a mean
/// contact. Below it the overlap is lost in the rounding of the positions (1e-9 r is
/// still about 1e5 units in the last place of a centre a hundred radii from the origin,
/// but a stress a thousand times smaller needs 1e-11 r) and the servo cannot measure the
/// stress it drives; a subnormal target would even make the stage's step infinite.
pub const MIN_OVERLAP_RATIO: Real = 1e-9;

/// The default tolerance of a density target in phi (-); a void-ratio or
/// relative-density target takes its equivalent.
pub const DEFAULT_DENSITY_TOL: Real = 0.002;

/// The largest density tolerance (-).
pub const MAX_DENSITY_TOL: Real = 0.1;

/// The smallest stress and balance tolerances (-).
pub const MIN_TOL: Real = 1e-9;

/// Most consecutive checks a stage may hold its tolerances for.
pub const MAX_HOLD: i128 = 1000;

/// Most steps between two checks of a stage.
pub const MAX_CHECK_EVERY: i128 = 1_000_000;

/// What a stage's checks need of the particles it runs on: the scene's radius law
/// when the scene is built, the pack's own radii when the stage starts.
#[derive(Clone, Copy, Debug)]
pub struct Particles<'a> {
    /// Smallest radius (m).
    pub r_min: Real,
    /// Mean radius (m).
    pub r_mean: Real,
    /// The particles' material.
    pub material: &'a Material,
    /// Largest overlap over the smaller radius the run takes (-).
    pub max_overlap_ratio: Real,
}

fn counted(name: &str, value: i128, hi: i128, unit: &str) -> Result<()> {
    if (1..=hi).contains(&value) {
        Ok(())
    } else {
        Err(Error::invalid(
            name,
            value,
            &format!("must lie in [1, {hi}]{unit}"),
        ))
    }
}

fn one_of(name: &str, value: &str, names: &[&str]) -> Result<()> {
    if names.contains(&value) {
        return Ok(());
    }
    let quoted: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
    Err(Error::invalid(
        name,
        format!("'{value}'"),
        &format!("must be one of {}", quoted.join(", ")),
    ))
}

/// The walls of a container in the engine's order, the lid (added by the
/// consolidation) last.
pub fn wall_names(dim: usize, container: &Container) -> Vec<&'static str> {
    match container {
        Container::Cylinder(_) => vec!["floor", "cylinder", "lid"],
        Container::Periodic => vec!["floor", "lid"],
        Container::Box if dim == 3 => vec!["floor", "x_lo", "x_hi", "y_lo", "y_hi", "lid"],
        Container::Box => vec!["floor", "x_lo", "x_hi", "lid"],
    }
}

/// The overlap (m) at which a Hertz contact of effective radius `r_eff` carries
/// `force`: F = 4/3 E* sqrt(R*) d^(3/2).
pub fn hertz_overlap(force: Real, r_eff: Real, e_star: Real) -> Real {
    (3.0 * force / (4.0 * e_star * r_eff.sqrt())).powf(2.0 / 3.0)
}

/// The overlap over the radius (-) that a mean contact of two mean spheres needs to
/// carry `stress` (Pa; N/m in 2D): the force sigma (2 r)^(D-1) on a Hertz contact of
/// R* = r / 2.
pub fn overlap_ratio(stress: Real, dim: usize, r_mean: Real, e_star: Real) -> Real {
    let force = stress * (2.0 * r_mean).powi(dim as i32 - 1);
    hertz_overlap(force, 0.5 * r_mean, e_star) / r_mean
}

/// The stresses (Pa; N/m in 2D) a stage takes for particles of mean radius `r_mean`
/// (m) of a material of effective modulus `e_star` (Pa): those whose mean contact needs
/// an overlap between [`MIN_OVERLAP_RATIO`] and `max_overlap_ratio` of the radius, and
/// at most [`MAX_STRESS`].
pub fn stress_range(
    dim: usize,
    r_mean: Real,
    e_star: Real,
    max_overlap_ratio: Real,
) -> (Real, Real) {
    let at = |ratio: Real| {
        let d = ratio * r_mean;
        let force = 4.0 / 3.0 * e_star * (0.5 * r_mean).sqrt() * d.powf(1.5);
        force / (2.0 * r_mean).powi(dim as i32 - 1)
    };
    (at(MIN_OVERLAP_RATIO), at(max_overlap_ratio).min(MAX_STRESS))
}

/// The flat top: every particle whose top lies above the scene's desired height is
/// removed after the last layer, and the rest relaxes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrimSpec {
    /// The height of the top (m); None (default): the scene's `height`.
    pub height: Option<Real>,
}

impl TrimSpec {
    /// Checks the height (m, positive and finite).
    pub fn validate(&self, _dim: usize, _container: &Container) -> Result<()> {
        if let Some(h) = self.height {
            check_range("height", h, 0.0, false, Real::INFINITY, false)?;
        }
        Ok(())
    }

    /// Refuses a top that would remove every particle: one resting on the floor reaches
    /// 2 r_min at least.
    pub fn check_particles(&self, height: Real, p: &Particles<'_>) -> Result<()> {
        let height = self.height.unwrap_or(height);
        if height < 2.0 * p.r_min {
            return Err(Error::invalid_number(
                "height",
                height,
                format!("{} m with trim = true", crate::error::fmt_g(height)),
                &format!(
                    "the flat top removes every particle whose top lies above height, and \
                     the smallest particle resting on the floor reaches 2 r_min = {} m; give \
                     height >= {} m, or trim = false",
                    2.0 * p.r_min,
                    2.0 * p.r_min
                ),
            ));
        }
        Ok(())
    }
}

/// The settling to rest: a deposit runs on under its own weight until YADE's
/// unbalanced-force ratio is at most `unbalanced_tol` for `hold` checks `check_every`
/// steps apart. Errors name the keys as `granpack.settle` spells them (the scene's
/// `rest_tol` is `unbalanced_tol`).
#[derive(Clone, Debug, PartialEq)]
pub struct RestSpec {
    /// Largest unbalanced-force ratio at rest (-), in [1e-9, 1). Default 1e-4.
    pub unbalanced_tol: Real,
    /// Consecutive checks that must meet it, in [1, 1000]. Default 5.
    pub hold: i128,
    /// Steps between two checks, in [1, 1e6]. Default 100.
    pub check_every: i128,
    /// Step budget, in [1, 1e10]. Default 2e6.
    pub max_steps: i128,
    /// Local non-viscous damping during the stage (-), in [0, 1). Default 0.4.
    pub local_damping: Real,
}

impl Default for RestSpec {
    fn default() -> Self {
        Self {
            unbalanced_tol: 1e-4,
            hold: 5,
            check_every: 100,
            max_steps: 2_000_000,
            local_damping: 0.4,
        }
    }
}

impl RestSpec {
    /// Checks every setting; errors name the key (after `prefix`) and its range.
    pub fn validate(&self, _dim: usize, _container: &Container) -> Result<()> {
        check_balance(
            "",
            self.unbalanced_tol,
            self.hold,
            self.check_every,
            self.max_steps,
        )?;
        check_range("local_damping", self.local_damping, 0.0, true, 1.0, false)
    }
}

fn check_balance(
    prefix: &str,
    unbalanced_tol: Real,
    hold: i128,
    check_every: i128,
    max_steps: i128,
) -> Result<()> {
    check_range(
        &format!("{prefix}unbalanced_tol"),
        unbalanced_tol,
        MIN_TOL,
        true,
        1.0,
        false,
    )?;
    counted(&format!("{prefix}hold"), hold, MAX_HOLD, " checks")?;
    counted(
        &format!("{prefix}check_every"),
        check_every,
        MAX_CHECK_EVERY,
        " steps",
    )?;
    counted(
        &format!("{prefix}max_steps"),
        max_steps,
        MAX_STEPS_PER_CALL as i128,
        " steps",
    )
}

/// The density target: at most one of phi, the void ratio e or the relative density
/// Dr, reached within `density_tol` by `density_method`.
#[derive(Clone, Debug, PartialEq)]
pub struct DensitySpec {
    /// The target solid fraction (-), in (0, 1).
    pub target_phi: Option<Real>,
    /// The target void ratio (-), in (0, inf).
    pub target_void_ratio: Option<Real>,
    /// The target relative density (-), in [0, 1].
    pub target_relative_density: Option<Real>,
    /// Largest distance from the target, in its own quantity, in (0, 0.1]. None
    /// (default): [`DEFAULT_DENSITY_TOL`] in phi, and its equivalent in e or Dr.
    pub density_tol: Option<Real>,
    /// One of [`DENSITY_METHODS`]. Default "auto".
    pub density_method: String,
}

impl Default for DensitySpec {
    fn default() -> Self {
        Self {
            target_phi: None,
            target_void_ratio: None,
            target_relative_density: None,
            density_tol: None,
            density_method: DENSITY_METHODS[0].to_string(),
        }
    }
}

impl DensitySpec {
    /// The target given, as (key, value), or None.
    pub fn target(&self) -> Option<(&'static str, Real)> {
        self.targets().first().copied()
    }

    fn targets(&self) -> Vec<(&'static str, Real)> {
        TARGET_KEYS
            .iter()
            .zip([
                self.target_phi,
                self.target_void_ratio,
                self.target_relative_density,
            ])
            .filter_map(|(k, v)| v.map(|v| (*k, v)))
            .collect()
    }

    /// Checks every setting; errors name the key and its range.
    pub fn validate(&self, _dim: usize, _container: &Container) -> Result<()> {
        let given = self.targets();
        if given.len() > 1 {
            return Err(Error::invalid(
                given[1].0,
                given[1].1,
                &format!(
                    "a scene gives at most one density target, and {} is set too",
                    given[0].0
                ),
            ));
        }
        if let Some(phi) = self.target_phi {
            check_range("target_phi", phi, 0.0, false, 1.0, false)?;
        }
        if let Some(e) = self.target_void_ratio {
            check_range("target_void_ratio", e, 0.0, false, Real::INFINITY, false)?;
        }
        if let Some(dr) = self.target_relative_density {
            check_range("target_relative_density", dr, 0.0, true, 1.0, true)?;
        }
        if let Some(tol) = self.density_tol {
            check_range("density_tol", tol, 0.0, false, MAX_DENSITY_TOL, true)?;
        }
        one_of("density_method", &self.density_method, &DENSITY_METHODS)
    }
}

/// The side walls' target in the anisotropic mode.
#[derive(Clone, Debug, PartialEq)]
pub enum Lateral {
    /// One stress for every side wall (Pa).
    One(Real),
    /// One stress per horizontal axis (Pa): (sigma_xx, sigma_yy) in a 3D box,
    /// (sigma_rr) in a cylinder.
    Each(Vec<Real>),
}

/// The consolidation: servo-controlled walls drive a pack to a target stress and hold
/// it until it is in static equilibrium. Errors name the keys as the scene's table
/// spells them, `consolidate.KEY`.
#[derive(Clone, Debug, PartialEq)]
pub struct ConsolidateSpec {
    /// Target normal stress on the lid (Pa; N/m in 2D), in (0, 1e12]. No default (NaN).
    pub stress: Real,
    /// One of [`CONSOLIDATION_MODES`]. Default "oedometric".
    pub mode: String,
    /// The side walls' target in the anisotropic mode (Pa). Default None.
    pub lateral: Option<Lateral>,
    /// Gravity during the stage. None (default): on unless the stress exceeds 100 times
    /// the weight stress at the floor.
    pub gravity: Option<bool>,
    /// Largest relative stress error at equilibrium (-), in [1e-9, 1). Default 1e-3.
    pub stress_tol: Real,
    /// Largest unbalanced-force ratio at equilibrium (-), in [1e-9, 1). Default 1e-4.
    pub unbalanced_tol: Real,
    /// Consecutive checks that must meet both tolerances, in [1, 1000]. Default 5.
    pub hold: i128,
    /// Steps between two checks, in [1, 1e6]. Default 100.
    pub check_every: i128,
    /// Step budget, in [1, 1e10]. Default 2e6.
    pub max_steps: i128,
    /// Largest wall speed (m/s), in (0, 1e6]. None (default): the quasi-static speed
    /// the stage derives from the pack.
    pub max_wall_speed: Option<Real>,
    /// Servo gain (-), in (0, 1]. Default 0.5 (PFC's).
    pub gain: Real,
    /// Local non-viscous damping during the stage (-), in [0, 1). Default 0.4.
    pub local_damping: Real,
    /// Time step (s), at most the Rayleigh step of the smallest particle. None
    /// (default): the stage's own, from the stiffest contact it expects.
    pub dt: Option<Real>,
    /// The walls' Coulomb friction during the stage (-), finite and >= 0. None
    /// (default): the material's. 0 makes the smooth walls of the element tests.
    pub wall_friction: Option<Real>,
}

impl Default for ConsolidateSpec {
    fn default() -> Self {
        Self {
            stress: Real::NAN,
            mode: CONSOLIDATION_MODES[0].to_string(),
            lateral: None,
            gravity: None,
            stress_tol: 1e-3,
            unbalanced_tol: 1e-4,
            hold: 5,
            check_every: 100,
            max_steps: 2_000_000,
            max_wall_speed: None,
            gain: 0.5,
            local_damping: 0.4,
            dt: None,
            wall_friction: None,
        }
    }
}

impl ConsolidateSpec {
    /// Checks every setting and the mode against the container; errors name
    /// `consolidate.KEY` and its range.
    pub fn validate(&self, dim: usize, container: &Container) -> Result<()> {
        check_range(
            "consolidate.stress",
            self.stress,
            0.0,
            false,
            MAX_STRESS,
            true,
        )?;
        one_of("consolidate.mode", &self.mode, &CONSOLIDATION_MODES)?;
        check_range(
            "consolidate.stress_tol",
            self.stress_tol,
            MIN_TOL,
            true,
            1.0,
            false,
        )?;
        check_balance(
            "consolidate.",
            self.unbalanced_tol,
            self.hold,
            self.check_every,
            self.max_steps,
        )?;
        if let Some(v) = self.max_wall_speed {
            check_range(
                "consolidate.max_wall_speed",
                v,
                0.0,
                false,
                MAX_WALL_SPEED,
                true,
            )?;
        }
        check_range("consolidate.gain", self.gain, 0.0, false, 1.0, true)?;
        check_range(
            "consolidate.local_damping",
            self.local_damping,
            0.0,
            true,
            1.0,
            false,
        )?;
        if let Some(dt) = self.dt {
            check_range("consolidate.dt", dt, 0.0, false, Real::INFINITY, false)?;
        }
        if let Some(mu) = self.wall_friction {
            check_range(
                "consolidate.wall_friction",
                mu,
                0.0,
                true,
                Real::INFINITY,
                false,
            )?;
        }
        self.targets(dim, container).map(|_| ())
    }

    /// Each controlled wall and its target stress (Pa), the lid first, the side walls
    /// in the engine's order; refuses a mode the container cannot do and a lateral
    /// target the mode does not take.
    pub fn targets(&self, dim: usize, container: &Container) -> Result<Vec<(&'static str, Real)>> {
        let lateral_named = |why: &str| Err(Error::invalid("consolidate.lateral", "", why));
        let mut out = vec![("lid", self.stress)];
        let sides: Vec<&'static str> = wall_names(dim, container)
            .into_iter()
            .filter(|n| !matches!(*n, "floor" | "lid"))
            .collect();
        match self.mode.as_str() {
            "oedometric" => {
                if self.lateral.is_some() {
                    return lateral_named(
                        "an oedometric stage controls the lid alone (the side walls stay \
                         where they are); give mode = 'anisotropic' for a lateral target",
                    );
                }
                return Ok(out);
            }
            mode if matches!(container, Container::Periodic) => {
                return Err(Error::invalid(
                    "consolidate.mode",
                    format!("'{mode}'"),
                    "a periodic cell has no lateral walls to control; use mode = 'oedometric'",
                ));
            }
            "isotropic" => {
                if self.lateral.is_some() {
                    return lateral_named(
                        "an isotropic stage gives every wall the same stress; give mode = \
                         'anisotropic' for a separate lateral target",
                    );
                }
                out.extend(sides.iter().map(|n| (*n, self.stress)));
                return Ok(out);
            }
            _ => {}
        }
        let values: Vec<Real> = match &self.lateral {
            None => {
                return lateral_named(
                    "an anisotropic stage needs the lateral target stress (Pa): one value, \
                     or (sigma_xx, sigma_yy) in a 3D box",
                )
            }
            Some(Lateral::One(v)) => vec![*v; dim - 1],
            Some(Lateral::Each(v)) => {
                let want = if matches!(container, Container::Cylinder(_)) {
                    1
                } else {
                    dim - 1
                };
                if v.len() != want {
                    let what = if want == 1 && dim == 3 {
                        "a cylinder has one lateral stress, sigma_rr".to_string()
                    } else {
                        format!("a {dim}D box takes {want} lateral stress(es)")
                    };
                    return lateral_named(&format!("{what}, not {}", v.len()));
                }
                v.clone()
            }
        };
        for v in &values {
            check_range("consolidate.lateral", *v, 0.0, false, MAX_STRESS, true)?;
        }
        for n in sides {
            let v = if matches!(container, Container::Cylinder(_)) || n.starts_with('x') {
                values[0]
            } else {
                values[values.len() - 1]
            };
            out.push((n, v));
        }
        Ok(out)
    }

    /// Refuses a target stress the stage cannot drive on these particles, by its own key
    /// (`consolidate.stress` for the lid, `consolidate.lateral` for the side walls), and
    /// a `dt` beyond the critical step of the smallest one ([`Error::UnstableTimeStep`]).
    pub fn check_particles(
        &self,
        dim: usize,
        container: &Container,
        p: &Particles<'_>,
    ) -> Result<()> {
        let e_star = p.material.e_star();
        // the linear law's mean contact: d = F / k_n for the force sigma (2 r)^(D-1)
        let linear_kn = match p.material.law {
            crate::dynamics::material::ContactLaw::Linear { kn, .. } => Some(kn),
            crate::dynamics::material::ContactLaw::HertzMindlin => None,
        };
        let area = (2.0 * p.r_mean).powi(dim as i32 - 1);
        let (lo, hi) = match linear_kn {
            Some(kn) => {
                let at = |ratio: Real| kn * ratio * p.r_mean / area;
                (
                    at(MIN_OVERLAP_RATIO),
                    at(p.max_overlap_ratio).min(MAX_STRESS),
                )
            }
            None => stress_range(dim, p.r_mean, e_star, p.max_overlap_ratio),
        };
        let stiffness = match linear_kn {
            Some(kn) => format!("k_n = {} N/m", crate::error::fmt_g(kn)),
            None => format!("E = {} Pa", crate::error::fmt_g(p.material.young)),
        };
        for (wall, value) in self.targets(dim, container)? {
            let key = if wall == "lid" {
                "consolidate.stress"
            } else {
                "consolidate.lateral"
            };
            let est = match linear_kn {
                Some(kn) => value * area / kn / p.r_mean,
                None => overlap_ratio(value, dim, p.r_mean, e_star),
            };
            let g3 = |x: Real| fmt_g_digits(x, 3);
            let why = if est > p.max_overlap_ratio {
                format!(
                    "it needs overlaps of about {} of the radius, beyond max_overlap_ratio = \
                     {}, where the contact law does not hold; lower the stress or stiffen the \
                     material",
                    g3(est),
                    crate::error::fmt_g(p.max_overlap_ratio)
                )
            } else if est < MIN_OVERLAP_RATIO {
                format!(
                    "it needs overlaps of about {} of the radius, below the {} that the \
                     positions resolve, so the servo could not measure it",
                    g3(est),
                    crate::error::fmt_g(MIN_OVERLAP_RATIO)
                )
            } else {
                continue;
            };
            let allowed = format!("[{}, {}] Pa", g3(lo), g3(hi));
            return Err(Error::InvalidParameter {
                name: key.to_string(),
                value: format!("{} Pa", crate::error::fmt_g(value)),
                number: Some(value),
                expected: format!(
                    "with {stiffness} and a mean radius {} m {why}. It must lie in {allowed}",
                    crate::error::fmt_g(p.r_mean)
                ),
            });
        }
        if let Some(dt) = self.dt {
            let critical = p.material.critical_time_step(p.r_min);
            if dt > critical {
                return Err(Error::UnstableTimeStep {
                    dt,
                    critical,
                    r_min: p.r_min,
                });
            }
        }
        Ok(())
    }
}

/// The tiling of a periodic pack: `counts` copies along each horizontal axis.
#[derive(Clone, Debug, PartialEq)]
pub struct TileSpec {
    /// Copies along x (and y in 3D), each at least 1. Default one each (the pack
    /// itself).
    pub counts: Vec<i128>,
}

impl Default for TileSpec {
    /// One copy along x and y: the pack itself (a 2D pack takes the first).
    fn default() -> Self {
        Self { counts: vec![1, 1] }
    }
}

impl TileSpec {
    /// The default for a `dim`-dimensional pack: one copy along each horizontal axis.
    pub fn for_dim(dim: usize) -> Self {
        Self {
            counts: vec![1; dim.saturating_sub(1)],
        }
    }
}

impl TileSpec {
    /// Checks the container (periodic: a wall would lie inside the tiled pack), the
    /// number of counts (`dim - 1`) and each count (at least 1).
    pub fn validate(&self, dim: usize, container: &Container) -> Result<()> {
        let name = match container {
            Container::Periodic => None,
            Container::Box => Some("box"),
            Container::Cylinder(_) => Some("cylinder"),
        };
        if let Some(name) = name {
            return Err(Error::invalid(
                "pack",
                "",
                &format!(
                    "its container is '{name}', whose walls would lie inside the tiled \
                     pack; only a pack made with container = 'periodic' tiles"
                ),
            ));
        }
        let form = if dim == 2 { "(nx,)" } else { "(nx, ny)" };
        if self.counts.len() != dim - 1 {
            return Err(Error::invalid(
                "counts",
                format!("{:?}", self.counts),
                &format!(
                    "a {dim}D pack takes {form}, {} count(s), not {}",
                    dim - 1,
                    self.counts.len()
                ),
            ));
        }
        for &c in &self.counts {
            if c < 1 {
                return Err(Error::invalid(
                    "counts",
                    format!("{:?}", self.counts),
                    &format!("{form}, integers >= 1"),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_pass_their_own_checks() {
        let c = Container::Box;
        RestSpec::default().validate(3, &c).unwrap();
        DensitySpec::default().validate(3, &c).unwrap();
        TrimSpec::default().validate(3, &c).unwrap();
        let spec = ConsolidateSpec {
            stress: 1e4,
            ..Default::default()
        };
        spec.validate(3, &c).unwrap();
        TileSpec::default()
            .validate(3, &Container::Periodic)
            .unwrap();
    }

    #[test]
    fn each_bad_setting_names_its_key() {
        let c = Container::Box;
        let base = ConsolidateSpec {
            stress: 1e4,
            ..Default::default()
        };
        let cases: Vec<(&str, ConsolidateSpec)> = vec![
            (
                "consolidate.stress",
                ConsolidateSpec {
                    stress: 0.0,
                    ..base.clone()
                },
            ),
            (
                "consolidate.mode",
                ConsolidateSpec {
                    mode: "triaxial".into(),
                    ..base.clone()
                },
            ),
            (
                "consolidate.max_wall_speed",
                ConsolidateSpec {
                    max_wall_speed: Some(2e6),
                    ..base.clone()
                },
            ),
            (
                "consolidate.hold",
                ConsolidateSpec {
                    hold: 0,
                    ..base.clone()
                },
            ),
            (
                "consolidate.lateral",
                ConsolidateSpec {
                    mode: "anisotropic".into(),
                    ..base.clone()
                },
            ),
        ];
        for (key, spec) in cases {
            match spec.validate(3, &c) {
                Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, key),
                other => panic!("{key}: {other:?}"),
            }
        }
        let periodic = ConsolidateSpec {
            mode: "isotropic".into(),
            ..base
        };
        match periodic.validate(3, &Container::Periodic) {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "consolidate.mode"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn anisotropic_targets_follow_the_walls() {
        let spec = ConsolidateSpec {
            stress: 3.0,
            mode: "anisotropic".into(),
            lateral: Some(Lateral::Each(vec![1.0, 2.0])),
            ..Default::default()
        };
        let t = spec.targets(3, &Container::Box).unwrap();
        assert_eq!(
            t,
            vec![
                ("lid", 3.0),
                ("x_lo", 1.0),
                ("x_hi", 1.0),
                ("y_lo", 2.0),
                ("y_hi", 2.0)
            ]
        );
    }
}
