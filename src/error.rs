//! The crate's one error type. Every fallible entry point returns [`Result`]; the
//! bindings map each variant to a subclass of `granpack.GranpackError` (a
//! `ValueError`) that carries the variant's fields as attributes.

use thiserror::Error;

/// Everything that can go wrong in granpack's engine.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    /// A parameter is outside its allowed range. The message names the parameter, the
    /// value and the range.
    #[error("{}", invalid_message(name, value, expected))]
    InvalidParameter {
        /// Parameter name as the user spells it.
        name: String,
        /// The offending value, formatted.
        value: String,
        /// The allowed range or form.
        expected: String,
    },
    /// The time step exceeds the stability estimate.
    #[error(
        "invalid dt = {dt:e} s: must not exceed the critical (Rayleigh) time step {critical:e} s \
         estimated for r_min = {r_min:e} m; use dt <= {critical:e}"
    )]
    UnstableTimeStep {
        /// Requested step (s).
        dt: f64,
        /// Estimated critical step (s).
        critical: f64,
        /// Smallest radius the estimate used (m).
        r_min: f64,
    },
    /// The simulation blew up; the run stopped instead of returning garbage.
    #[error(
        "simulation became unstable at step {step} (t = {time:e} s): particle {particle}: {what}"
    )]
    Blowup {
        /// Step counter when it was detected.
        step: u64,
        /// Simulated time (s).
        time: f64,
        /// Index of the particle concerned.
        particle: usize,
        /// Which guard stopped the run.
        kind: BlowupKind,
        /// What was detected, with the value.
        what: String,
    },
    /// Random sequential addition saturated before reaching the layer fraction.
    #[error(
        "random sequential addition saturated: layer {layer} reached solid fraction {reached:.4} \
         of the requested phi_layer = {target:.4} after {attempts} failed attempts in a row; \
         lower phi_layer (RSA saturates near 0.547 in 2D and 0.38 in 3D) or thicken h_layer"
    )]
    RsaSaturated {
        /// Layer index (0-based).
        layer: usize,
        /// Fraction reached.
        reached: f64,
        /// Fraction asked for.
        target: f64,
        /// Consecutive failed attempts.
        attempts: u64,
    },
}

/// Which guard stopped a run that blew up (see [`Error::Blowup`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlowupKind {
    /// A pair overlap beyond `max_overlap_ratio` of the smaller radius.
    Overlap,
    /// A wall overlap beyond `max_overlap_ratio` of the radius.
    WallOverlap,
    /// The total energy grew with gravity the only source.
    Energy,
    /// A position, velocity or spin became NaN or infinite.
    NonFinite,
    /// A particle moves more than half its radius per step (it could tunnel).
    Speed,
    /// A centre crossed a wall.
    WallCrossed,
}

impl BlowupKind {
    /// The kind as Python's `BlowUpError.kind` spells it.
    pub fn name(self) -> &'static str {
        match self {
            BlowupKind::Overlap => "overlap",
            BlowupKind::WallOverlap => "wall_overlap",
            BlowupKind::Energy => "energy",
            BlowupKind::NonFinite => "non_finite",
            BlowupKind::Speed => "speed",
            BlowupKind::WallCrossed => "wall_crossed",
        }
    }
}

impl Error {
    /// Shorthand for [`Error::InvalidParameter`].
    pub fn invalid(name: &str, value: impl std::fmt::Display, expected: &str) -> Self {
        Error::InvalidParameter {
            name: name.to_string(),
            value: value.to_string(),
            expected: expected.to_string(),
        }
    }
}

/// "invalid name = value: expected", or without "= value" when there is no single value
/// to show (an array's shape, say).
fn invalid_message(name: &str, value: &str, expected: &str) -> String {
    if value.is_empty() {
        format!("invalid {name}: {expected}")
    } else {
        format!("invalid {name} = {value}: {expected}")
    }
}

/// The crate's result type.
pub type Result<T> = std::result::Result<T, Error>;

/// Checks `lo < value < hi` (open) or `lo <= value <= hi` (closed ends as flagged) and
/// finiteness, naming the parameter in the error.
pub fn check_range(
    name: &str,
    value: f64,
    lo: f64,
    lo_closed: bool,
    hi: f64,
    hi_closed: bool,
) -> Result<()> {
    let ok_lo = if lo_closed { value >= lo } else { value > lo };
    let ok_hi = if hi_closed { value <= hi } else { value < hi };
    if value.is_nan() || !ok_lo || !ok_hi || (value.is_infinite() && hi.is_finite()) {
        let l = if lo_closed { '[' } else { '(' };
        let h = if hi_closed { ']' } else { ')' };
        return Err(Error::invalid(
            name,
            value,
            &format!("must lie in {l}{lo}, {hi}{h}"),
        ));
    }
    Ok(())
}
