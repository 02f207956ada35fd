//! Run-time choice of the instruction set for the hot kernels.
//!
//! The crate is built for a portable baseline (plain x86-64, whatever command builds it),
//! so a wheel runs on any x86-64 CPU. The kernels that bound a step's cost (the pair
//! geometry and contact law over a block, the gather of each particle's forces, and
//! kick/drift) are compiled again for three x86-64 micro-architecture levels and chosen
//! once per process from what the CPU reports:
//!
//! | level | features (beyond the one below) |
//! |---|---|
//! | `x86-64` | SSE2 (every x86-64 CPU) |
//! | `x86-64-v2` | SSE3, SSSE3, SSE4.1, SSE4.2, POPCNT, CMPXCHG16B |
//! | `x86-64-v3` | AVX, AVX2, BMI1, BMI2, F16C, FMA, LZCNT, MOVBE |
//! | `x86-64-v4` | AVX-512 F, BW, CD, DQ, VL |
//!
//! The environment variable `GRANPACK_CPU_LEVEL` (one of the names above) forces a
//! level at or below the CPU's, for testing and for users who want to check; a level
//! the CPU lacks is refused by [`level_from_env`] and [`set_level`], never run.
//! `native` names the CPU's highest (what an unset variable gives), as compilers spell it.
//!
//! Every level gives the same bits: Rust never contracts `a * b + c` into an FMA, and
//! vector square roots and divisions are correctly rounded, as their scalar forms are.
//! The test `every_level_gives_the_same_bits` and the `.ci/run` check under
//! `qemu-x86_64 -cpu Nehalem` / `-cpu max` hold the crate to that.
//!
//! On other architectures there is one level, the baseline.

use std::sync::atomic::{AtomicU8, Ordering};

use crate::error::{Error, Result};

/// An instruction-set level the hot kernels are compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum Level {
    /// The build's own target (plain x86-64: SSE2), or the only level elsewhere.
    Baseline = 0,
    /// x86-64-v2 (Nehalem, 2008, and later).
    V2 = 1,
    /// x86-64-v3: AVX2 and FMA (Haswell, 2013; Zen 1).
    V3 = 2,
    /// x86-64-v4: AVX-512 (Skylake-X; Zen 4).
    V4 = 3,
}

/// Every level, lowest first.
pub const LEVELS: [Level; 4] = [Level::Baseline, Level::V2, Level::V3, Level::V4];

/// The environment variable that forces a level.
pub const LEVEL_ENV: &str = "GRANPACK_CPU_LEVEL";

impl Level {
    /// The level's name, as LLVM's `target-cpu` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Level::Baseline => {
                if cfg!(target_arch = "x86_64") {
                    "x86-64"
                } else {
                    "baseline"
                }
            }
            Level::V2 => "x86-64-v2",
            Level::V3 => "x86-64-v3",
            Level::V4 => "x86-64-v4",
        }
    }

    /// The level named `name` (see [`Level::name`]; `baseline` also names the lowest,
    /// `native` the CPU's highest).
    pub fn parse(name: &str) -> Result<Level> {
        let name = name.trim();
        if name == "baseline" {
            return Ok(Level::Baseline);
        }
        if name == "native" {
            return Ok(detected());
        }
        LEVELS
            .into_iter()
            .find(|l| l.name() == name)
            .ok_or_else(|| Error::invalid(LEVEL_ENV, truncated(name), ALLOWED))
    }

    fn from_u8(v: u8) -> Level {
        LEVELS[usize::from(v.min(3))]
    }
}

/// What the variable may hold, for a message.
const ALLOWED: &str =
    "must be one of x86-64, x86-64-v2, x86-64-v3, x86-64-v4, baseline (the lowest) or native (the CPU's highest)";

/// At most 40 characters of a user's value, for a message.
fn truncated(s: &str) -> String {
    if s.chars().count() <= 40 {
        s.to_string()
    } else {
        format!("{}...", s.chars().take(40).collect::<String>())
    }
}

/// The highest level this CPU runs.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        let v2 = has!("sse3")
            && has!("ssse3")
            && has!("sse4.1")
            && has!("sse4.2")
            && has!("popcnt")
            && has!("cmpxchg16b");
        let v3 = v2
            && has!("avx")
            && has!("avx2")
            && has!("bmi1")
            && has!("bmi2")
            && has!("f16c")
            && has!("fma")
            && has!("lzcnt")
            && has!("movbe");
        let v4 = v3
            && has!("avx512f")
            && has!("avx512bw")
            && has!("avx512cd")
            && has!("avx512dq")
            && has!("avx512vl");
        if v4 {
            Level::V4
        } else if v3 {
            Level::V3
        } else if v2 {
            Level::V2
        } else {
            Level::Baseline
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Level::Baseline
    }
}

/// The levels this CPU runs, lowest first.
pub fn available() -> Vec<Level> {
    let top = detected();
    LEVELS.into_iter().filter(|&l| l <= top).collect()
}

/// The level `GRANPACK_CPU_LEVEL` asks for (`None` when unset or empty), refused when
/// it is not a level's name (bytes that are no UTF-8 included) or the CPU lacks it.
pub fn level_from_env() -> Result<Option<Level>> {
    match std::env::var(LEVEL_ENV) {
        Ok(s) if !s.trim().is_empty() => {
            let l = Level::parse(&s)?;
            check_supported(l)?;
            Ok(Some(l))
        }
        Err(std::env::VarError::NotUnicode(raw)) => Err(Error::invalid(
            LEVEL_ENV,
            // the bytes escaped (\xff): a terminal shows no replacement characters
            truncated(&format!("{raw:?}")),
            &format!("{ALLOWED}; the value is not UTF-8 text"),
        )),
        _ => Ok(None),
    }
}

fn check_supported(l: Level) -> Result<()> {
    let top = detected();
    if l > top {
        return Err(Error::invalid(
            LEVEL_ENV,
            l.name(),
            &format!("this CPU runs at most {}", top.name()),
        ));
    }
    Ok(())
}

const UNSET: u8 = u8::MAX;
static CHOSEN: AtomicU8 = AtomicU8::new(UNSET);

/// The level the kernels run at: set by [`set_level`], else chosen on first use from
/// `GRANPACK_CPU_LEVEL` or, when that is unset or refused, the CPU's highest. (The
/// bindings check the variable at import and raise on a refused value, so Python users
/// see the error; here a bad value must not stop a run.)
#[inline]
pub fn level() -> Level {
    let v = CHOSEN.load(Ordering::Relaxed);
    if v != UNSET {
        return Level::from_u8(v);
    }
    let l = level_from_env().ok().flatten().unwrap_or_else(detected);
    CHOSEN.store(l as u8, Ordering::Relaxed);
    l
}

/// Makes the kernels run at `l` from now on (all threads). Refused when the CPU lacks
/// it. Results do not depend on the level, so this only changes speed.
pub fn set_level(l: Level) -> Result<()> {
    check_supported(l)?;
    CHOSEN.store(l as u8, Ordering::Relaxed);
    Ok(())
}

/// Defines the function `$name` with body `$body`, compiled once per level: the body
/// goes into an `#[inline(always)]` function, and a `#[target_feature]` function per
/// level calls it, so that the whole body (and what it inlines) uses that level's
/// instructions; `$name` calls the copy for the [`level`] chosen at run time. The
/// generics are given twice: as declared (`[const D: usize]`) and as passed on (`[D]`).
///
/// ```ignore
/// crate::cpu::multiversion! {
/// /// Doc comment of the function.
/// pub fn kernel [const D: usize] (x: &mut [f64], a: f64) -> () where [] [D] {
///     for v in x.iter_mut() { *v *= a; }
/// }
/// }
/// ```
macro_rules! multiversion {
    (
        $(#[$attr:meta])*
        $vis:vis unsafe fn $name:ident [$($gen:tt)*] ($($arg:ident : $ty:ty),* $(,)?)
            $(-> $ret:ty)? where [$($bound:tt)*] [$($garg:tt)*] $body:block
    ) => {
        $crate::cpu::multiversion!(@def [$(#[$attr])*] [$vis] [unsafe] $name [$($gen)*]
            ($($arg: $ty),*) [$($ret)?] [$($bound)*] [$($garg)*] $body);
    };
    (
        $(#[$attr:meta])*
        $vis:vis fn $name:ident [$($gen:tt)*] ($($arg:ident : $ty:ty),* $(,)?)
            $(-> $ret:ty)? where [$($bound:tt)*] [$($garg:tt)*] $body:block
    ) => {
        $crate::cpu::multiversion!(@def [$(#[$attr])*] [$vis] [] $name [$($gen)*]
            ($($arg: $ty),*) [$($ret)?] [$($bound)*] [$($garg)*] $body);
    };
    (@def [$($attr:tt)*] [$vis:vis] [$($unsafety:tt)?] $name:ident [$($gen:tt)*]
        ($($arg:ident : $ty:ty),*) [$($ret:ty)?] [$($bound:tt)*] [$($garg:tt)*] $body:block
    ) => {
        $($attr)*
        #[inline]
        #[allow(clippy::too_many_arguments, clippy::unused_unit, unused_unsafe)]
        $vis $($unsafety)? fn $name<$($gen)*>($($arg: $ty),*) $(-> $ret)? where $($bound)* {
            #[inline(always)]
            #[allow(clippy::too_many_arguments, clippy::needless_range_loop, clippy::unused_unit)]
            $($unsafety)? fn body<$($gen)*>($($arg: $ty),*) $(-> $ret)? where $($bound)* $body

            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "sse3,ssse3,sse4.1,sse4.2,popcnt,cmpxchg16b")]
                #[allow(clippy::too_many_arguments, clippy::unused_unit, unused_unsafe)]
                unsafe fn v2<$($gen)*>($($arg: $ty),*) $(-> $ret)? where $($bound)* {
                    // SAFETY: as for the caller.
                    unsafe { body::<$($garg)*>($($arg),*) }
                }
                #[target_feature(enable = "sse3,ssse3,sse4.1,sse4.2,popcnt,cmpxchg16b,\
                    avx,avx2,bmi1,bmi2,f16c,fma,lzcnt,movbe")]
                #[allow(clippy::too_many_arguments, clippy::unused_unit, unused_unsafe)]
                unsafe fn v3<$($gen)*>($($arg: $ty),*) $(-> $ret)? where $($bound)* {
                    // SAFETY: as for the caller.
                    unsafe { body::<$($garg)*>($($arg),*) }
                }
                #[target_feature(enable = "sse3,ssse3,sse4.1,sse4.2,popcnt,cmpxchg16b,\
                    avx,avx2,bmi1,bmi2,f16c,fma,lzcnt,movbe,\
                    avx512f,avx512bw,avx512cd,avx512dq,avx512vl")]
                #[allow(clippy::too_many_arguments, clippy::unused_unit, unused_unsafe)]
                unsafe fn v4<$($gen)*>($($arg: $ty),*) $(-> $ret)? where $($bound)* {
                    // SAFETY: as for the caller.
                    unsafe { body::<$($garg)*>($($arg),*) }
                }
                // SAFETY: `level()` never exceeds what the CPU reports (`detected`).
                match $crate::cpu::level() {
                    $crate::cpu::Level::V4 => return unsafe { v4::<$($garg)*>($($arg),*) },
                    $crate::cpu::Level::V3 => return unsafe { v3::<$($garg)*>($($arg),*) },
                    $crate::cpu::Level::V2 => return unsafe { v2::<$($garg)*>($($arg),*) },
                    $crate::cpu::Level::Baseline => {}
                }
            }
            // SAFETY: as for the caller.
            unsafe { body::<$($garg)*>($($arg),*) }
        }
    };
}
pub(crate) use multiversion;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_are_refused_by_name() {
        for l in LEVELS {
            assert_eq!(Level::parse(l.name()).unwrap(), l);
        }
        assert_eq!(Level::parse("baseline").unwrap(), Level::Baseline);
        assert_eq!(Level::parse("native").unwrap(), detected());
        assert_eq!(Level::parse(" native ").unwrap(), detected());
        let e = Level::parse("avx9000").unwrap_err().to_string();
        assert!(
            e.contains("GRANPACK_CPU_LEVEL") && e.contains("x86-64-v3"),
            "{e}"
        );
        let long = "x".repeat(10_000);
        assert!(Level::parse(&long).unwrap_err().to_string().len() < 300);
    }

    #[test]
    fn a_level_above_the_cpu_is_refused() {
        // (check_supported, not set_level: the level is process-wide, and
        // `every_level_gives_the_same_bits` sets it)
        let top = detected();
        assert!(check_supported(top).is_ok());
        if top < Level::V4 {
            let e = check_supported(Level::V4).unwrap_err().to_string();
            assert!(e.contains("this CPU runs at most"), "{e}");
        }
        assert_eq!(available().last(), Some(&top));
        assert_eq!(available()[0], Level::Baseline);
    }
}
