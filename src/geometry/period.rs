//! Periodic axes: the minimum image and the wrap into the cell.

use crate::math::{Real, Vector};

/// Periodic axes: origin, period and its inverse per axis (a zero period: not
/// periodic).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Period<const D: usize> {
    /// Lower corner of the cell (m).
    pub lo: Vector<D>,
    /// Period per axis (m), 0 where the axis is not periodic.
    pub len: Vector<D>,
    inv: Vector<D>,
}

impl<const D: usize> Period<D> {
    /// Periodic horizontal axes with periods `hi[k] - lo[k]`; the vertical is not.
    pub fn lateral(lo: &Vector<D>, hi: &Vector<D>) -> Self {
        let flags: Vec<bool> = (0..D).map(|k| k + 1 < D).collect();
        Self::new(lo, hi, &flags)
    }

    /// The axes with `flags[k]` periodic, with periods `hi[k] - lo[k]`.
    pub fn new(lo: &Vector<D>, hi: &Vector<D>, flags: &[bool]) -> Self {
        let mut len = Vector::<D>::zeros();
        let mut inv = Vector::<D>::zeros();
        for k in 0..D {
            if flags.get(k).copied().unwrap_or(false) {
                len[k] = hi[k] - lo[k];
                inv[k] = 1.0 / len[k];
            }
        }
        Period { lo: *lo, len, inv }
    }

    /// The same cell with axis `k` no longer periodic.
    pub fn without_axis(mut self, k: usize) -> Self {
        self.len[k] = 0.0;
        self.inv[k] = 0.0;
        self
    }

    /// Whether axis `k` is periodic.
    #[inline(always)]
    pub fn periodic(&self, k: usize) -> bool {
        self.len[k] > 0.0
    }

    /// The minimum image of a separation `d` (m): each periodic component brought into
    /// [-L/2, L/2].
    #[inline(always)]
    pub fn image(&self, mut d: Vector<D>) -> Vector<D> {
        for k in 0..D {
            if self.len[k] > 0.0 {
                d[k] -= self.len[k] * round_near_one(d[k] * self.inv[k]);
            }
        }
        d
    }

    /// `x` wrapped into [lo, lo + L) on the periodic axes.
    #[inline]
    pub fn wrap(&self, mut x: Vector<D>) -> Vector<D> {
        for k in 0..D {
            let l = self.len[k];
            if l > 0.0 {
                let lo = self.lo[k];
                if !(x[k] >= lo && x[k] < lo + l) {
                    let mut v = x[k] - l * ((x[k] - lo) * self.inv[k]).floor();
                    // rounding can land on the upper end (a tiny negative offset)
                    if v >= lo + l {
                        v -= l;
                    }
                    if v < lo {
                        v = lo;
                    }
                    x[k] = v;
                }
            }
        }
        x
    }
}

/// `t.round()`, bit for bit (signed zeros and NaN included), without the library call
/// that `round` costs on x86-64 below SSE4.1 where |t| < 1.5: a separation between two
/// particles in the cell is under one and a half periods (positions wrap at each
/// rebuild), so the minimum image takes this path on every pair.
#[inline(always)]
fn round_near_one(t: Real) -> Real {
    let a = t.abs();
    if a < 1.5 {
        // round is 1 from 0.5 up (halves away from zero), and carries t's sign, -0.0
        // included
        Real::from(u8::from(a >= 0.5)).copysign(t)
    } else {
        t.round()
    }
}

#[cfg(test)]
mod tests {
    use super::round_near_one;

    /// Equal to `round` bit for bit on the halves, their neighbours, signed zeros,
    /// infinities, NaN and a sweep of values across [-3, 3].
    #[test]
    fn round_near_one_is_round() {
        let mut ts = vec![
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1e-300,
            -1e-300,
        ];
        for h in [0.5f64, 1.5, 2.5, 1.0] {
            for t in [h, h.next_up(), h.next_down()] {
                ts.push(t);
                ts.push(-t);
            }
        }
        ts.extend((0..=6000).map(|k| -3.0 + k as f64 * 1e-3));
        for t in ts {
            assert_eq!(
                round_near_one(t).to_bits(),
                t.round().to_bits(),
                "t = {t:e}"
            );
        }
    }
}
