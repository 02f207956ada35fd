//! Radius laws: the size distributions a scene can ask for, their checks, and exact
//! sampling (never clipping: a truncated law is sampled from the truncated density).
//!
//! "Mass" is the mass the engine gives a particle, proportional to r^p: p = 3 for
//! spheres and for 2D particles with a sphere's mass (`inertia_2d = "sphere"`), p = 2
//! for discs of unit thickness (`inertia_2d = "disc"`). Mass fractions (a discrete
//! mixture by mass, a sieve curve) become number fractions through w / r^p.

use crate::error::{Error, Result};
use crate::math::Real;
use rand::distr::weighted::WeightedIndex;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp1, StandardNormal};
use std::sync::Arc;

/// Tolerance on fractions that must sum to 1, and on a passing curve's ends.
pub const FRACTION_TOL: Real = 1e-9;

/// A truncated law whose window lies wholly beyond this many standard deviations
/// (of r for the Gaussian, of ln r for the lognormal) from the law's centre holds less
/// than 1.3e-12 of its mass: such a window is refused as holding no mass.
pub const MAX_WINDOW_Z: Real = 7.0;

/// Radius distribution of the particles.
#[derive(Clone, Debug, PartialEq)]
pub enum RadiusLaw {
    /// Every particle has this radius (m).
    Constant(Real),
    /// Gaussian with `mean` and `std` (m) truncated to [`min`, `max`], sampled exactly
    /// from the truncated law (rejection, never clipping).
    Gaussian {
        /// Mean of the untruncated Gaussian (m).
        mean: Real,
        /// Standard deviation of the untruncated Gaussian (m), >= 0.
        std: Real,
        /// Lower truncation (m), 0 < min <= mean.
        min: Real,
        /// Upper truncation (m), max >= mean.
        max: Real,
    },
    /// Radius uniform on [`min`, `max`] (m), by number.
    Uniform {
        /// Smallest radius (m), > 0.
        min: Real,
        /// Largest radius (m), >= min.
        max: Real,
    },
    /// Lognormal radius whose own `mean` and `std` (m, before truncation) are given,
    /// truncated to [`min`, `max`] and sampled exactly (a truncated normal of ln r).
    Lognormal {
        /// Mean of the untruncated radius (m), > 0.
        mean: Real,
        /// Standard deviation of the untruncated radius (m), >= 0.
        std: Real,
        /// Lower truncation (m), > 0.
        min: Real,
        /// Upper truncation (m), >= min.
        max: Real,
    },
    /// A mixture of a few radii (see [`DiscreteLaw`]).
    Discrete(DiscreteLaw),
    /// A sieve curve (see [`SieveLaw`]).
    Sieve(SieveLaw),
}

/// What the fractions of a discrete mixture count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FractionsBy {
    /// Fractions of the particle count.
    Number,
    /// Fractions of the mass (see the module's note on mass in 2D).
    Mass,
}

/// A mixture of radii with number fractions (built from number or mass fractions).
#[derive(Clone, Debug, PartialEq)]
pub struct DiscreteLaw {
    radii: Arc<[Real]>,
    number: Arc<[Real]>,
    pick: WeightedIndex<Real>,
}

/// A sieve curve: `sizes` are sieve openings (diameters, m), `passing` the cumulative
/// mass fraction passing each. Within a class [d_k, d_k+1] the mass is spread
/// log-linearly in the diameter (the passing fraction is linear in ln d, a straight
/// segment on the usual semi-log grading plot), so the number density in ln d is
/// proportional to d^-p. A class is picked by its number fraction and its diameter
/// drawn by inverse CDF: d^-p is uniform between d_k+1^-p and d_k^-p.
#[derive(Clone, Debug, PartialEq)]
pub struct SieveLaw {
    sizes: Arc<[Real]>,
    passing: Arc<[Real]>,
    mass_exponent: i32,
    number: Arc<[Real]>,
    pick: WeightedIndex<Real>,
}

fn increasing_positive(name: &str, v: &[Real], least: usize, what: &str) -> Result<()> {
    if v.len() < least {
        return Err(Error::invalid(
            name,
            format!("{v:?}"),
            &format!("needs at least {least} {what}"),
        ));
    }
    for (k, &x) in v.iter().enumerate() {
        if !(x.is_finite() && x > 0.0) {
            return Err(Error::invalid(
                &format!("{name}[{k}]"),
                x,
                "must be finite and > 0 (m)",
            ));
        }
        if k > 0 && x <= v[k - 1] {
            return Err(Error::invalid(
                &format!("{name}[{k}]"),
                x,
                &format!(
                    "{name} must be strictly increasing: must exceed {name}[{}] = {} (m)",
                    k - 1,
                    v[k - 1]
                ),
            ));
        }
    }
    Ok(())
}

fn pow(x: Real, p: i32) -> Real {
    x.powi(p)
}

impl DiscreteLaw {
    /// A mixture of `radii` (m, strictly increasing) with `fractions` (each >= 0,
    /// summing to 1 within [`FRACTION_TOL`]) counted `by` number or mass; mass
    /// fractions w_k become number fractions proportional to w_k / r_k^p
    /// (`mass_exponent` p, see the module's note). Errors name the scene keys
    /// `radii`, `fractions`.
    pub fn new(
        radii: &[Real],
        fractions: &[Real],
        by: FractionsBy,
        mass_exponent: i32,
    ) -> Result<Self> {
        increasing_positive("radii", radii, 1, "radius (m)")?;
        if fractions.len() != radii.len() {
            return Err(Error::invalid(
                "fractions",
                format!("{fractions:?}"),
                &format!("needs one fraction per radius ({} values)", radii.len()),
            ));
        }
        check_fractions("fractions", fractions)?;
        let number: Vec<Real> = match by {
            FractionsBy::Number => fractions.to_vec(),
            FractionsBy::Mass => {
                let n: Vec<Real> = fractions
                    .iter()
                    .zip(radii)
                    .map(|(&w, &r)| w / pow(r, mass_exponent))
                    .collect();
                let total: Real = n.iter().sum();
                n.iter().map(|&x| x / total).collect()
            }
        };
        let pick = WeightedIndex::new(number.iter().copied())
            .map_err(|e| Error::invalid("fractions", format!("{fractions:?}"), &e.to_string()))?;
        Ok(DiscreteLaw {
            radii: radii.into(),
            number: number.into(),
            pick,
        })
    }

    /// The radii (m).
    pub fn radii(&self) -> &[Real] {
        &self.radii
    }

    /// Number fraction of each radius (sums to 1).
    pub fn number_fractions(&self) -> &[Real] {
        &self.number
    }

    fn support(&self) -> (Real, Real) {
        let first = self
            .number
            .iter()
            .position(|&n| n > 0.0)
            .expect("a fraction");
        let last = self
            .number
            .iter()
            .rposition(|&n| n > 0.0)
            .expect("a fraction");
        (self.radii[first], self.radii[last])
    }
}

fn check_fractions(name: &str, f: &[Real]) -> Result<()> {
    for (k, &w) in f.iter().enumerate() {
        if !(w.is_finite() && w >= 0.0) {
            return Err(Error::invalid(
                &format!("{name}[{k}]"),
                w,
                "must be finite and >= 0",
            ));
        }
    }
    let sum: Real = f.iter().sum();
    if (sum - 1.0).abs() > FRACTION_TOL {
        return Err(Error::invalid(
            name,
            format!("{f:?}"),
            &format!("must sum to 1 within {FRACTION_TOL:e} (they sum to {sum})"),
        ));
    }
    Ok(())
}

impl SieveLaw {
    /// A sieve curve: `sizes` (sieve openings, diameters in m, strictly increasing, at
    /// least two) and `passing` (cumulative mass fraction passing each size,
    /// non-decreasing from 0 to 1, ends within [`FRACTION_TOL`]). Mass within a class
    /// is log-linear in the diameter (see [`SieveLaw`]); `mass_exponent` p is the
    /// power of the radius the mass grows with. Errors name `sieve_sizes[k]` and
    /// `sieve_passing[k]`.
    pub fn new(sizes: &[Real], passing: &[Real], mass_exponent: i32) -> Result<Self> {
        increasing_positive("sieve_sizes", sizes, 2, "sieve sizes (diameters, m)")?;
        if passing.len() != sizes.len() {
            return Err(Error::invalid(
                "sieve_passing",
                format!("{passing:?}"),
                &format!(
                    "needs one passing fraction per sieve size ({} values)",
                    sizes.len()
                ),
            ));
        }
        for (k, &f) in passing.iter().enumerate() {
            if !(f.is_finite() && (0.0..=1.0 + FRACTION_TOL).contains(&f)) {
                return Err(Error::invalid(
                    &format!("sieve_passing[{k}]"),
                    f,
                    "a fraction passing must lie in [0, 1]",
                ));
            }
            if k > 0 && f < passing[k - 1] {
                return Err(Error::invalid(
                    &format!("sieve_passing[{k}]"),
                    f,
                    &format!(
                        "the passing curve must not decrease: must be >= sieve_passing[{}] = {}",
                        k - 1,
                        passing[k - 1]
                    ),
                ));
            }
        }
        if passing[0] > FRACTION_TOL {
            return Err(Error::invalid(
                "sieve_passing[0]",
                passing[0],
                "must be 0: nothing passes the smallest sieve (its size is the smallest \
                 diameter)",
            ));
        }
        let last = passing.len() - 1;
        if (passing[last] - 1.0).abs() > FRACTION_TOL {
            return Err(Error::invalid(
                &format!("sieve_passing[{last}]"),
                passing[last],
                "must be 1: everything passes the largest sieve (its size is the largest \
                 diameter)",
            ));
        }
        let p = mass_exponent;
        // mass w_k spread uniformly in u = ln d over the class: number density
        // (w_k / du_k) d^-p in u, so N_k = w_k (d_k^-p - d_k+1^-p) / (p du_k)
        let number: Vec<Real> = (0..last)
            .map(|k| {
                let w = passing[k + 1] - passing[k];
                let du = (sizes[k + 1] / sizes[k]).ln();
                w * (pow(sizes[k], -p) - pow(sizes[k + 1], -p)) / (Real::from(p) * du)
            })
            .collect();
        let total: Real = number.iter().sum();
        let number: Vec<Real> = number.iter().map(|&n| n / total).collect();
        let pick = WeightedIndex::new(number.iter().copied())
            .map_err(|e| Error::invalid("sieve_passing", format!("{passing:?}"), &e.to_string()))?;
        Ok(SieveLaw {
            sizes: sizes.into(),
            passing: passing.into(),
            mass_exponent: p,
            number: number.into(),
            pick,
        })
    }

    /// Sieve sizes (diameters, m).
    pub fn sizes(&self) -> &[Real] {
        &self.sizes
    }

    /// Cumulative mass fraction passing each size.
    pub fn passing(&self) -> &[Real] {
        &self.passing
    }

    /// Number fraction of each class [sizes[k], sizes[k + 1]] (sums to 1).
    pub fn number_fractions(&self) -> &[Real] {
        &self.number
    }

    /// The classes that hold particles: the first's lower and the last's upper size
    /// (diameters, m).
    fn support(&self) -> (Real, Real) {
        let first = self.number.iter().position(|&n| n > 0.0).expect("a class");
        let last = self.number.iter().rposition(|&n| n > 0.0).expect("a class");
        (self.sizes[first], self.sizes[last + 1])
    }

    /// Number moments of the diameter within class k: (count, sum d, sum d^2), up to
    /// a common factor, from the class density d^(-p-1) per unit diameter.
    fn class_moments(&self, k: usize) -> (Real, Real, Real) {
        let (a, b) = (self.sizes[k], self.sizes[k + 1]);
        let p = self.mass_exponent;
        let pf = Real::from(p);
        let m0 = (pow(a, -p) - pow(b, -p)) / pf;
        let m1 = (pow(a, 1 - p) - pow(b, 1 - p)) / (pf - 1.0);
        let m2 = if p == 2 {
            (b / a).ln()
        } else {
            (pow(b, 2 - p) - pow(a, 2 - p)) / (2.0 - pf)
        };
        (m0, m1, m2)
    }

    fn sample(&self, rng: &mut ChaCha8Rng) -> Real {
        let k = self.pick.sample(rng);
        let (a, b) = (self.sizes[k], self.sizes[k + 1]);
        let p = self.mass_exponent;
        let (hi, lo) = (pow(a, -p), pow(b, -p));
        let x = hi - rng.random::<f64>() * (hi - lo);
        let d = match p {
            2 => 1.0 / x.sqrt(),
            3 => 1.0 / x.cbrt(),
            _ => x.powf(-1.0 / Real::from(p)),
        };
        // (the clamp only mends rounding at the class edges)
        0.5 * d.clamp(a, b)
    }
}

/// The parameters (mu, sigma) of ln r for a lognormal radius of mean `mean` and
/// standard deviation `std`.
pub fn lognormal_params(mean: Real, std: Real) -> (Real, Real) {
    let s2 = (1.0 + (std / mean) * (std / mean)).ln();
    (mean.ln() - 0.5 * s2, s2.sqrt())
}

/// A standard normal draw on [za, zb] with za <= 0 <= zb. Wide windows: propose from
/// the normal (acceptance >= 0.47); narrow ones: propose uniformly and accept with
/// exp(-z^2/2) (acceptance >= exp(-2)). Both are exact.
fn central_normal(za: Real, zb: Real, rng: &mut ChaCha8Rng) -> Real {
    loop {
        let z = if zb - za > 2.0 {
            let z: f64 = StandardNormal.sample(rng);
            if z < za || z > zb {
                continue;
            }
            z
        } else {
            let z = za + (zb - za) * rng.random::<f64>();
            if rng.random::<f64>() >= (-0.5 * z * z).exp() {
                continue;
            }
            z
        };
        return z;
    }
}

/// A standard normal draw on [a, b] with 0 < a <= b, exactly. A narrow window
/// (lambda (b - a) < 1) proposes uniformly and accepts with exp(-(z^2 - a^2)/2)
/// (acceptance >= about exp(-1)); a wide one proposes a + Exp(lambda) and accepts
/// with exp(-(z - lambda)^2/2), lambda = (a + sqrt(a^2 + 4))/2 (Robert 1995;
/// acceptance >= 0.76 before the cut at b, which keeps >= 1 - 1/e). Neither evaluates
/// the density itself, so a window far in the tail does not underflow.
fn tail_normal(a: Real, b: Real, rng: &mut ChaCha8Rng) -> Real {
    let lambda = 0.5 * (a + (a * a + 4.0).sqrt());
    loop {
        if lambda * (b - a) < 1.0 {
            let z = a + (b - a) * rng.random::<f64>();
            if rng.random::<f64>() < (-0.5 * (z - a) * (z + a)).exp() {
                return z;
            }
        } else {
            let e: f64 = Exp1.sample(rng);
            let z = a + e / lambda;
            if z <= b && rng.random::<f64>() < (-0.5 * (z - lambda) * (z - lambda)).exp() {
                return z;
            }
        }
    }
}

/// A standard normal draw truncated to [za, zb] (za <= zb), exactly.
fn truncated_normal(za: Real, zb: Real, rng: &mut ChaCha8Rng) -> Real {
    if za <= 0.0 && zb >= 0.0 {
        central_normal(za, zb, rng)
    } else if za > 0.0 {
        tail_normal(za, zb, rng)
    } else {
        -tail_normal(-zb, -za, rng)
    }
}

fn window(min: Real, max: Real) -> Result<()> {
    if !(min.is_finite() && min > 0.0) {
        return Err(Error::invalid("r_min", min, "must be finite and > 0 (m)"));
    }
    if !(max.is_finite() && max >= min) {
        return Err(Error::invalid(
            "r_max",
            max,
            &format!("must be finite and >= r_min = {min} (m)"),
        ));
    }
    Ok(())
}

impl RadiusLaw {
    /// The names a scene gives the laws (`PackScene.radius_law`), in the order of the
    /// variants.
    pub const NAMES: [&'static str; 6] = [
        "constant",
        "gaussian",
        "uniform",
        "lognormal",
        "discrete",
        "sieve",
    ];

    /// Checks the law; the error names the scene key (`r_mean`, `r_std`, `r_min`,
    /// `r_max`; a discrete or sieve law is checked when it is built).
    pub fn validate(&self) -> Result<()> {
        match *self {
            RadiusLaw::Constant(r) => {
                if !(r.is_finite() && r > 0.0) {
                    return Err(Error::invalid("r_mean", r, "must be finite and > 0 (m)"));
                }
            }
            RadiusLaw::Gaussian {
                mean,
                std,
                min,
                max,
            } => {
                window(min, max)?;
                if !(mean >= min && mean <= max) {
                    return Err(Error::invalid(
                        "r_mean",
                        mean,
                        &format!("must lie in [r_min, r_max] = [{min}, {max}] (m)"),
                    ));
                }
                if !(std.is_finite() && std >= 0.0) {
                    return Err(Error::invalid("r_std", std, "must be finite and >= 0 (m)"));
                }
            }
            RadiusLaw::Uniform { min, max } => window(min, max)?,
            RadiusLaw::Lognormal {
                mean,
                std,
                min,
                max,
            } => {
                if !(mean.is_finite() && mean > 0.0) {
                    return Err(Error::invalid("r_mean", mean, "must be finite and > 0 (m)"));
                }
                if !(std.is_finite() && std >= 0.0) {
                    return Err(Error::invalid("r_std", std, "must be finite and >= 0 (m)"));
                }
                window(min, max)?;
                let (mu, sigma) = lognormal_params(mean, std);
                if !(sigma.is_finite() && mu.is_finite()) {
                    return Err(Error::invalid(
                        "r_std",
                        std,
                        &format!("r_std / r_mean = {} is too large to represent", std / mean),
                    ));
                }
                if sigma == 0.0 {
                    if !(mean >= min && mean <= max) {
                        return Err(Error::invalid(
                            "r_mean",
                            mean,
                            &format!(
                                "with r_std = 0 every radius is r_mean: it must lie in \
                                 [r_min, r_max] = [{min}, {max}] (m)"
                            ),
                        ));
                    }
                } else {
                    let za = (min.ln() - mu) / sigma;
                    let zb = (max.ln() - mu) / sigma;
                    if za > MAX_WINDOW_Z || zb < -MAX_WINDOW_Z {
                        let (name, value) = if za > MAX_WINDOW_Z {
                            ("r_min", min)
                        } else {
                            ("r_max", max)
                        };
                        return Err(Error::invalid(
                            name,
                            value,
                            &format!(
                                "the window [r_min, r_max] = [{min}, {max}] m holds no mass of \
                                 the lognormal law (r_mean = {mean}, r_std = {std}): it lies \
                                 {:.3} sd of ln r from the median {} m, beyond \
                                 {MAX_WINDOW_Z} sd (a fraction below 1.3e-12)",
                                za.abs().min(zb.abs()),
                                mu.exp()
                            ),
                        ));
                    }
                }
            }
            RadiusLaw::Discrete(_) | RadiusLaw::Sieve(_) => {}
        }
        Ok(())
    }

    /// Largest radius the law can produce (m).
    pub fn r_max(&self) -> Real {
        match self {
            RadiusLaw::Constant(r) => *r,
            RadiusLaw::Gaussian { max, .. }
            | RadiusLaw::Uniform { max, .. }
            | RadiusLaw::Lognormal { max, .. } => *max,
            RadiusLaw::Discrete(d) => d.support().1,
            RadiusLaw::Sieve(s) => 0.5 * s.support().1,
        }
    }

    /// Smallest radius the law can produce (m).
    pub fn r_min(&self) -> Real {
        match self {
            RadiusLaw::Constant(r) => *r,
            RadiusLaw::Gaussian { min, .. }
            | RadiusLaw::Uniform { min, .. }
            | RadiusLaw::Lognormal { min, .. } => *min,
            RadiusLaw::Discrete(d) => d.support().0,
            RadiusLaw::Sieve(s) => 0.5 * s.support().0,
        }
    }

    /// Mean radius by number (m): the constant; the mean parameter (before
    /// truncation) of the Gaussian and the lognormal; the exact mean of the others.
    pub fn r_mean(&self) -> Real {
        self.number_moments().0
    }

    /// Mean and standard deviation of the radius by number (m): the parameters
    /// (before truncation) of the Gaussian and the lognormal, exact for the others.
    pub fn number_moments(&self) -> (Real, Real) {
        match self {
            RadiusLaw::Constant(r) => (*r, 0.0),
            RadiusLaw::Gaussian { mean, std, .. } | RadiusLaw::Lognormal { mean, std, .. } => {
                (*mean, *std)
            }
            RadiusLaw::Uniform { min, max } => {
                (0.5 * (min + max), (max - min) / (12.0 as Real).sqrt())
            }
            RadiusLaw::Discrete(d) => {
                let m1: Real = d
                    .radii
                    .iter()
                    .zip(d.number.iter())
                    .map(|(r, n)| r * n)
                    .sum();
                let m2: Real = d
                    .radii
                    .iter()
                    .zip(d.number.iter())
                    .map(|(r, n)| r * r * n)
                    .sum();
                (m1, (m2 - m1 * m1).max(0.0).sqrt())
            }
            RadiusLaw::Sieve(s) => {
                // the classes' number fractions weight each class's own moments
                let (mut m1, mut m2) = (0.0, 0.0);
                for (k, &n) in s.number.iter().enumerate() {
                    if n > 0.0 {
                        let (c0, c1, c2) = s.class_moments(k);
                        m1 += n * c1 / c0;
                        m2 += n * c2 / c0;
                    }
                }
                // diameters to radii
                let (m1, m2) = (0.5 * m1, 0.25 * m2);
                (m1, (m2 - m1 * m1).max(0.0).sqrt())
            }
        }
    }

    /// True for the laws whose layers are placed largest first (see
    /// `place_layer`): every law but the constant and the Gaussian, which keep the
    /// paper's order and so their packs.
    pub fn places_largest_first(&self) -> bool {
        !matches!(self, RadiusLaw::Constant(_) | RadiusLaw::Gaussian { .. })
    }

    /// One radius (m).
    pub fn sample(&self, rng: &mut ChaCha8Rng) -> Real {
        match self {
            RadiusLaw::Constant(r) => *r,
            &RadiusLaw::Gaussian {
                mean,
                std,
                min,
                max,
            } => {
                if std == 0.0 || min == max {
                    return mean;
                }
                let (za, zb) = ((min - mean) / std, (max - mean) / std);
                // the window contains z = 0 (min <= mean <= max)
                (mean + std * central_normal(za, zb, rng)).clamp(min, max)
            }
            &RadiusLaw::Uniform { min, max } => {
                (min + (max - min) * rng.random::<f64>()).clamp(min, max)
            }
            &RadiusLaw::Lognormal {
                mean,
                std,
                min,
                max,
            } => {
                if std == 0.0 {
                    return mean;
                }
                if min == max {
                    return min;
                }
                let (mu, sigma) = lognormal_params(mean, std);
                let (za, zb) = ((min.ln() - mu) / sigma, (max.ln() - mu) / sigma);
                // (the clamp only mends rounding at the window's edges)
                (mu + sigma * truncated_normal(za, zb, rng))
                    .exp()
                    .clamp(min, max)
            }
            RadiusLaw::Discrete(d) => d.radii[d.pick.sample(rng)],
            RadiusLaw::Sieve(s) => s.sample(rng),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The Kolmogorov-Smirnov statistic sqrt(n) D of `sample` against `cdf`.
    fn ks(mut sample: Vec<Real>, cdf: impl Fn(Real) -> Real) -> Real {
        sample.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let n = sample.len() as Real;
        let mut d: Real = 0.0;
        for (i, &x) in sample.iter().enumerate() {
            let f = cdf(x);
            d = d.max(f - i as Real / n).max((i + 1) as Real / n - f);
        }
        d * n.sqrt()
    }

    /// The critical value of sqrt(n) D at 1 % (Kolmogorov distribution).
    const KS_1PC: Real = 1.628;

    fn draws(law: &RadiusLaw, n: usize, seed: u64) -> Vec<Real> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| law.sample(&mut rng)).collect()
    }

    /// The standard normal CDF by numerical quadrature of its density from -40
    /// (Simpson, fine enough for 1e-10).
    fn phi(z: Real) -> Real {
        let a = -40.0_f64;
        if z <= a {
            return 0.0;
        }
        let n = 20_000;
        let h = (z - a) / n as Real;
        let f = |x: Real| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let mut s = f(a) + f(z);
        for i in 1..n {
            s += f(a + i as Real * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    #[test]
    fn the_truncated_normal_fits_in_every_window() {
        // central, one-sided near the mode, narrow and wide tails, far tail
        for (k, &(a, b)) in [
            (-1.0, 2.5),
            (-0.3, 0.4),
            (0.5, 3.0),
            (2.0, 2.2),
            (3.0, 9.0),
            (-6.0, -5.5),
            (30.0, 31.0),
        ]
        .iter()
        .enumerate()
        {
            let mut rng = ChaCha8Rng::seed_from_u64(80 + k as u64);
            let s: Vec<Real> = (0..5000)
                .map(|_| truncated_normal(a, b, &mut rng))
                .collect();
            assert!(s.iter().all(|&z| (a..=b).contains(&z)));
            // far in the tail the CDF is that of the exponential limit: compare
            // in the shifted, scaled variable instead of through phi
            let stat = if a > 20.0 {
                let m = 1.0 - (-a * (b - a)).exp();
                ks(s, |z| (1.0 - (-a * (z - a)).exp()) / m)
            } else {
                let (pa, pb) = (phi(a), phi(b));
                ks(s, |z| (phi(z) - pa) / (pb - pa))
            };
            // the far tail's limit is itself off by O(1/a^2): a looser bound there
            let bound = if a > 20.0 { 2.5 } else { KS_1PC };
            assert!(stat < bound, "window [{a}, {b}]: sqrt(n) D = {stat}");
        }
    }

    #[test]
    fn uniform_and_lognormal_fit_their_laws() {
        let u = RadiusLaw::Uniform {
            min: 0.01,
            max: 0.03,
        };
        let stat = ks(draws(&u, 5000, 1), |r| (r - 0.01) / 0.02);
        assert!(stat < KS_1PC, "{stat}");
        let (mean, std, min, max) = (0.02, 0.008, 0.012, 0.05);
        let l = RadiusLaw::Lognormal {
            mean,
            std,
            min,
            max,
        };
        l.validate().unwrap();
        let (mu, sigma) = lognormal_params(mean, std);
        let z = |r: Real| (r.ln() - mu) / sigma;
        let (pa, pb) = (phi(z(min)), phi(z(max)));
        let s = draws(&l, 5000, 2);
        assert!(s.iter().all(|&r| (min..=max).contains(&r)));
        let stat = ks(s, |r| (phi(z(r)) - pa) / (pb - pa));
        assert!(stat < KS_1PC, "{stat}");
        // untruncated (a wide window): the radius's own mean and sd
        let wide = RadiusLaw::Lognormal {
            mean,
            std,
            min: 1e-4,
            max: 1.0,
        };
        let s = draws(&wide, 40_000, 3);
        let m = s.iter().sum::<Real>() / s.len() as Real;
        let sd = (s.iter().map(|r| (r - m) * (r - m)).sum::<Real>() / s.len() as Real).sqrt();
        assert!((m - mean).abs() < 4.0 * std / 200.0, "{m}");
        assert!((sd - std).abs() < 0.05 * std, "{sd}");
    }

    #[test]
    fn a_lognormal_window_without_mass_is_refused() {
        let far = RadiusLaw::Lognormal {
            mean: 0.01,
            std: 0.001,
            min: 0.05,
            max: 0.06,
        };
        let e = far.validate().unwrap_err().to_string();
        assert!(e.contains("r_min") && e.contains("no mass"), "{e}");
        let low = RadiusLaw::Lognormal {
            mean: 0.01,
            std: 0.001,
            min: 1e-5,
            max: 2e-3,
        };
        assert!(low.validate().unwrap_err().to_string().contains("r_max"));
    }

    #[test]
    fn discrete_mass_fractions_become_number_fractions() {
        let d = DiscreteLaw::new(&[0.01, 0.02], &[0.5, 0.5], FractionsBy::Mass, 3).unwrap();
        // equal masses: 8 small spheres per large one
        let n = d.number_fractions();
        assert!((n[0] - 8.0 / 9.0).abs() < 1e-15 && (n[1] - 1.0 / 9.0).abs() < 1e-15);
        let law = RadiusLaw::Discrete(d);
        let s = draws(&law, 9000, 5);
        let small = s.iter().filter(|&&r| r == 0.01).count();
        assert_eq!(small + s.iter().filter(|&&r| r == 0.02).count(), s.len());
        // binomial sd sqrt(9000 * 8/9 * 1/9) = 30
        assert!((small as Real - 8000.0).abs() < 90.0, "{small}");
        assert_eq!((law.r_min(), law.r_max()), (0.01, 0.02));
        // discs of unit thickness: mass by area
        let d2 = DiscreteLaw::new(&[0.01, 0.02], &[0.5, 0.5], FractionsBy::Mass, 2).unwrap();
        assert!((d2.number_fractions()[0] - 0.8).abs() < 1e-15);
    }

    #[test]
    fn discrete_input_is_checked_by_name() {
        let e = |r: &[Real], f: &[Real]| {
            DiscreteLaw::new(r, f, FractionsBy::Number, 3)
                .unwrap_err()
                .to_string()
        };
        assert!(e(&[0.02, 0.01], &[0.5, 0.5]).contains("invalid radii[1]"));
        assert!(e(&[0.0, 0.01], &[0.5, 0.5]).contains("invalid radii[0]"));
        assert!(e(&[0.01, 0.02], &[1.5, -0.5]).contains("invalid fractions[1]"));
        assert!(e(&[0.01, 0.02], &[0.5, 0.4]).contains("sum to 1"));
        assert!(e(&[0.01, 0.02], &[1.0]).contains("one fraction per radius"));
        // within the tolerance
        DiscreteLaw::new(&[0.01, 0.02], &[0.3, 0.7 + 5e-10], FractionsBy::Number, 3).unwrap();
    }

    #[test]
    fn sieve_input_is_checked_by_name() {
        let e = |d: &[Real], p: &[Real]| SieveLaw::new(d, p, 3).unwrap_err().to_string();
        let d = [0.02, 0.03, 0.05, 0.08];
        assert!(e(&d, &[0.0, 0.5, 0.4, 1.0]).contains("invalid sieve_passing[2]"));
        assert!(e(&d, &[0.1, 0.3, 0.7, 1.0]).contains("invalid sieve_passing[0]"));
        assert!(e(&d, &[0.0, 0.3, 0.7, 0.9]).contains("invalid sieve_passing[3]"));
        assert!(
            e(&[0.02, 0.05, 0.03, 0.08], &[0.0, 0.3, 0.7, 1.0]).contains("invalid sieve_sizes[2]")
        );
        assert!(
            e(&[-0.02, 0.03, 0.05, 0.08], &[0.0, 0.3, 0.7, 1.0]).contains("invalid sieve_sizes[0]")
        );
        assert!(e(&d, &[0.0, 1.0]).contains("one passing fraction per sieve size"));
        assert!(e(&[0.02], &[0.0]).contains("at least 2"));
    }

    /// The mass passing a diameter under a sieve law, log-linear within classes.
    fn sieve_passing_at(d: &[Real], p: &[Real], x: Real) -> Real {
        if x <= d[0] {
            return 0.0;
        }
        for k in 0..d.len() - 1 {
            if x <= d[k + 1] {
                let t = (x / d[k]).ln() / (d[k + 1] / d[k]).ln();
                return p[k] + t * (p[k + 1] - p[k]);
            }
        }
        1.0
    }

    #[test]
    fn a_sieve_law_meets_its_curve_by_number_and_by_mass() {
        let d = [0.02, 0.03, 0.05, 0.08];
        let p = [0.0, 0.3, 0.7, 1.0];
        let law = SieveLaw::new(&d, &p, 3).unwrap();
        let rl = RadiusLaw::Sieve(law.clone());
        assert_eq!((rl.r_min(), rl.r_max()), (0.01, 0.04));
        let s = draws(&rl, 6000, 9);
        // by number: the CDF of the diameter, class by class
        let cum: Vec<Real> = std::iter::once(0.0)
            .chain(law.number_fractions().iter().scan(0.0, |c, &n| {
                *c += n;
                Some(*c)
            }))
            .collect();
        let cdf = |r: Real| {
            let x = 2.0 * r;
            let k = (0..3).find(|&k| x <= d[k + 1]).unwrap_or(2);
            let (a, b) = (d[k], d[k + 1]);
            let t = (a.powi(-3) - x.powi(-3)) / (a.powi(-3) - b.powi(-3));
            cum[k] + t * (cum[k + 1] - cum[k])
        };
        let stat = ks(s.clone(), cdf);
        assert!(stat < KS_1PC, "by number: {stat}");
        // by mass: the realised mass passing each sieve against the curve; the mass-
        // weighted empirical CDF has the effective size n_eff = (sum m)^2 / sum m^2
        let m: Vec<Real> = s.iter().map(|r| r.powi(3)).collect();
        let total: Real = m.iter().sum();
        let n_eff = total * total / m.iter().map(|x| x * x).sum::<Real>();
        let dkw = ((2.0 / 0.01_f64).ln() / (2.0 * n_eff)).sqrt();
        for x in [0.025, 0.03, 0.04, 0.05, 0.065] {
            let passing: Real = s
                .iter()
                .zip(&m)
                .filter(|(&r, _)| 2.0 * r <= x)
                .map(|(_, &w)| w)
                .sum::<Real>()
                / total;
            let target = sieve_passing_at(&d, &p, x);
            assert!(
                (passing - target).abs() < dkw,
                "{x}: {passing} vs {target} (bound {dkw})"
            );
        }
        // the number moments match the draws
        let (mean, sd) = rl.number_moments();
        let m1 = s.iter().sum::<Real>() / s.len() as Real;
        assert!(
            (m1 - mean).abs() < 4.0 * sd / (s.len() as Real).sqrt(),
            "{m1} {mean}"
        );
    }

    #[test]
    fn a_sieve_with_empty_end_classes_reports_its_real_support() {
        let law = SieveLaw::new(&[0.01, 0.02, 0.04, 0.08], &[0.0, 0.0, 1.0, 1.0], 3).unwrap();
        let rl = RadiusLaw::Sieve(law);
        assert_eq!((rl.r_min(), rl.r_max()), (0.01, 0.02));
        assert!(draws(&rl, 1000, 1)
            .iter()
            .all(|&r| (0.01..=0.02).contains(&r)));
    }
}
