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
        /// The offending value as a number, where the rule is about one number (the
        /// Python exception's `value` is then that number rather than its text).
        number: Option<f64>,
        /// The allowed range or form.
        expected: String,
    },
    /// The time step exceeds the stability estimate.
    #[error(
        "invalid dt = {dt:e} s: must not exceed the critical (Rayleigh) time step {critical:e} s \
         estimated for r_min = {r_min:e} m (sqrt(m / k) under the linear law; a rolling \
         spring shortens either); use dt <= \
         {critical:e}"
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
            number: None,
            expected: expected.to_string(),
        }
    }

    /// [`Error::invalid`] for a rule about the number `x`, shown in the message as
    /// `shown` (with its unit or context).
    pub fn invalid_number(
        name: &str,
        x: f64,
        shown: impl std::fmt::Display,
        expected: &str,
    ) -> Self {
        Error::InvalidParameter {
            name: name.to_string(),
            value: shown.to_string(),
            number: Some(x),
            expected: expected.to_string(),
        }
    }

    /// The same error naming `to` where it named `from`: a setting that a scene spells
    /// otherwise than the stage's function (the scene's `rest_tol` is `settle`'s
    /// `unbalanced_tol`).
    pub fn renamed(self, from: &str, to: &str) -> Self {
        match self {
            Error::InvalidParameter {
                name,
                value,
                number,
                expected,
            } if name == from => Error::InvalidParameter {
                name: to.to_string(),
                value,
                number,
                expected,
            },
            other => other,
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

/// `x` as C's and Python's `%g` write it: six significant digits, trailing zeros
/// dropped, the exponent form (with a signed, two-digit exponent) below 1e-4 and from
/// 1e6 on. Messages that quote a derived value use it, so that they read as the
/// Python package's.
pub fn fmt_g(x: f64) -> String {
    fmt_g_digits(x, 6)
}

/// `x` as C's and Python's `%.{digits}g` write it (`digits` at least 1): [`fmt_g`] with
/// another number of significant digits.
pub fn fmt_g_digits(x: f64, digits: usize) -> String {
    let digits = digits.max(1);
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let trim = |s: &str| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s.to_string()
        }
    };
    // the exponent after rounding to `digits` digits (9.999995 rounds up to 1e1)
    let sci = format!("{x:.*e}", digits - 1);
    let (mantissa, exp) = sci.split_once('e').expect("an exponent");
    let exp: i32 = exp.parse().expect("an integer exponent");
    if !(-4..digits as i32).contains(&exp) {
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{}e{sign}{:02}", trim(mantissa), exp.abs())
    } else {
        trim(&format!("{:.*}", (digits as i32 - 1 - exp) as usize, x))
    }
}

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

#[cfg(test)]
mod format_tests {
    use super::{fmt_g, fmt_g_digits};

    #[test]
    fn fmt_g_digits_writes_what_python_percent_3g_writes() {
        // the right-hand sides are Python's f"{x:.3g}"
        for (x, want) in [
            (88934.2, "8.89e+04"),
            (7.9512e-9, "7.95e-09"),
            (0.5, "0.5"),
            (123.456, "123"),
            (999.6, "1e+03"),
            (1e-4, "0.0001"),
            (0.00012345, "0.000123"),
            (1234.0, "1.23e+03"),
        ] {
            assert_eq!(fmt_g_digits(x, 3), want, "{x}");
        }
    }

    #[test]
    fn fmt_g_writes_what_python_percent_g_writes() {
        // the right-hand sides are Python's f"{x:g}"
        for (x, want) in [
            (1e12, "1e+12"),
            (0.5, "0.5"),
            (1e-4, "0.0001"),
            (1.5e-5, "1.5e-05"),
            (123456.0, "123456"),
            (1234567.0, "1.23457e+06"),
            (9.9999996, "10"),
            (-2.5e-7, "-2.5e-07"),
            (0.1 + 0.2, "0.3"),
            (100.0, "100"),
        ] {
            assert_eq!(fmt_g(x), want, "{x}");
        }
    }
}
