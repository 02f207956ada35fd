//! The contact law over a batch of contacts, structure of arrays and branch-free.
//!
//! A per-contact loop is bound by latency: each contact is one dependent chain of
//! square roots and divisions. Here the pair pass first compacts the pairs in contact
//! into a [`Batch`] (geometry, relative velocity, history, coefficients), then
//! [`law_batch`] runs the same Hertz-Mindlin law as
//! [`hertz_mindlin_coefs`](super::hertz_mindlin_coefs) over plain `f64` arrays with
//! selects instead of branches, so that the compiler vectorises it and the chains of
//! different contacts overlap. The results are scattered back by the caller.

use crate::dynamics::PairParams;
use crate::math::Real;

/// The material's share of the law coefficients; a pair's own share is two numbers,
/// sqrt(R*) and sqrt(m* sqrt(R*)), so that the pair list stores 16 bytes of constants
/// per pair instead of 32 (see [`PairFactors`]).
///
/// For a pair: k_n = kn sqrt(R*) sqrt(d), c_n = cn sqrt(m* sqrt(R*)) d^{1/4}, and the
/// same with kt and ct, which equals [`LawCoefs`](super::LawCoefs) term by term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawConsts {
    /// 2 E* (Pa).
    pub kn: Real,
    /// 2 xi sqrt(2 E*) (Pa^{1/2}).
    pub cn: Real,
    /// 8 G* (Pa).
    pub kt: Real,
    /// 2 xi sqrt(8 G*) (Pa^{1/2}).
    pub ct: Real,
    /// Friction coefficient mu (-).
    pub mu: Real,
}

impl LawConsts {
    /// From the effective moduli E*, G* (Pa), damping ratio xi and friction mu.
    pub fn new(e_star: Real, g_star: Real, damping: Real, friction: Real) -> Self {
        LawConsts {
            kn: 2.0 * e_star,
            cn: 2.0 * damping * (2.0 * e_star).sqrt(),
            kt: 8.0 * g_star,
            ct: 2.0 * damping * (8.0 * g_star).sqrt(),
            mu: friction,
        }
    }
}

/// A pair's share of the law coefficients (see [`LawConsts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairFactors {
    /// sqrt(R*) (m^{1/2}).
    pub sr: Real,
    /// sqrt(m* sqrt(R*)) (kg^{1/2} m^{1/4}).
    pub sm: Real,
}

impl PairFactors {
    /// From the effective radius R* (m) and mass m* (kg) of `p`.
    #[inline]
    pub fn new(p: &PairParams) -> Self {
        let sr = p.r_eff.sqrt();
        PairFactors {
            sr,
            sm: (p.m_eff * sr).sqrt(),
        }
    }
}

/// Contacts per batch. A power of two: callers index with `len & (BATCH - 1)`.
pub const BATCH: usize = 128;
const _: () = assert!(BATCH.is_power_of_two());

/// Inputs and outputs of [`law_batch`] for up to [`BATCH`] contacts (SI units).
#[derive(Clone, Debug)]
pub struct Batch<const D: usize> {
    /// Number of contacts filled in.
    pub len: usize,
    /// Index of each contact's pair in the caller's arrays.
    pub pair: [u32; BATCH],
    /// Unit normal, by component.
    pub n: [[Real; BATCH]; D],
    /// Relative velocity of j's surface w.r.t. i's at the contact, by component.
    pub v: [[Real; BATCH]; D],
    /// Tangential history in (updated in place).
    pub h: [[Real; BATCH]; D],
    /// Overlap d > 0.
    pub d: [Real; BATCH],
    /// The pair's sqrt(R*) (see [`PairFactors`]).
    pub sr: [Real; BATCH],
    /// The pair's sqrt(m* sqrt(R*)).
    pub sm: [Real; BATCH],
    /// Output: normal force magnitude (N).
    pub fnorm: [Real; BATCH],
    /// Scratch: sqrt(d), d^{1/4} and the normal relative velocity, from the normal
    /// pass to the tangential one (cheaper to keep than to recompute).
    scratch: [[Real; BATCH]; 3],
    /// Output: tangential force on j (N), by component.
    pub ft: [[Real; BATCH]; D],
}

impl<const D: usize> Default for Batch<D> {
    fn default() -> Self {
        Batch {
            len: 0,
            pair: [0; BATCH],
            n: [[0.0; BATCH]; D],
            v: [[0.0; BATCH]; D],
            h: [[0.0; BATCH]; D],
            d: [0.0; BATCH],
            sr: [0.0; BATCH],
            sm: [0.0; BATCH],
            fnorm: [0.0; BATCH],
            scratch: [[0.0; BATCH]; 3],
            ft: [[0.0; BATCH]; D],
        }
    }
}

/// Runs the law on the first `b.len` contacts: fills `fnorm` and `ft`, advances `h`.
/// Same formulas, in the same order, as `hertz_mindlin_coefs`.
#[inline(never)]
pub fn law_batch<const D: usize>(b: &mut Batch<D>, c: &LawConsts, dt: Real) {
    let len = b.len;
    let mu = c.mu;
    for m in 0..len {
        let d = b.d[m];
        let s = d.sqrt();
        let q = s.sqrt();
        let mut vn = 0.0;
        for a in 0..D {
            vn += b.v[a][m] * b.n[a][m];
        }
        let f_elastic = (2.0 / 3.0) * (c.kn * b.sr[m]) * s * d;
        b.fnorm[m] = (f_elastic - (c.cn * b.sm[m]) * q * vn).max(0.0);
        b.scratch[0][m] = s;
        b.scratch[1][m] = q;
        b.scratch[2][m] = vn;
    }
    if mu <= 0.0 {
        // no friction: no tangential force, and no history to keep
        for a in 0..D {
            b.ft[a][..len].fill(0.0);
        }
        return;
    }
    for m in 0..len {
        let (s, q, vn) = (b.scratch[0][m], b.scratch[1][m], b.scratch[2][m]);
        let mut hn = 0.0;
        let mut h_old2 = 0.0;
        for a in 0..D {
            hn += b.h[a][m] * b.n[a][m];
            h_old2 += b.h[a][m] * b.h[a][m];
        }
        let mut hp = [0.0; D];
        let mut h_new2 = 0.0;
        for (a, x) in hp.iter_mut().enumerate() {
            *x = b.h[a][m] - b.n[a][m] * hn;
            h_new2 += *x * *x;
        }
        // Keep the stored elastic displacement's magnitude when projecting it.
        let rescale = if h_new2 > 0.0 {
            (h_old2 / h_new2).sqrt()
        } else {
            1.0
        };
        let k_t = (c.kt * b.sr[m]) * s;
        let c_t = (c.ct * b.sm[m]) * q;
        let mut vt = [0.0; D];
        let mut ft = [0.0; D];
        let mut ft2 = 0.0;
        for a in 0..D {
            vt[a] = b.v[a][m] - b.n[a][m] * vn;
            hp[a] = hp[a] * rescale + vt[a] * dt;
            ft[a] = -(hp[a] * k_t) - vt[a] * c_t;
            ft2 += ft[a] * ft[a];
        }
        let f_max = mu * b.fnorm[m];
        let slide = ft2 > f_max * f_max;
        // slide implies ft2 > 0
        let scale = if slide { f_max / ft2.sqrt() } else { 1.0 };
        for a in 0..D {
            let f = ft[a] * scale;
            b.ft[a][m] = f;
            // sliding: the spring stretch consistent with the capped force
            b.h[a][m] = if slide {
                -(f + vt[a] * c_t) / k_t
            } else {
                hp[a]
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{hertz_mindlin_coefs, LawCoefs, PairParams};
    use crate::math::Vector;
    use rand::{Rng, SeedableRng};

    /// The batch law agrees with the scalar law contact by contact, sticking and
    /// sliding, with and without friction.
    #[test]
    fn batch_law_matches_the_scalar_law() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for mu in [0.0, 0.2, 1.0] {
            let mut b = Batch::<3>::default();
            let consts = LawConsts::new(5.3e7, 1.1e7, 0.1, mu);
            let mut expect = Vec::new();
            for m in 0..BATCH {
                let p = PairParams {
                    r_eff: 0.005 + 0.01 * rng.random::<f64>(),
                    m_eff: 1e-3 + 1e-2 * rng.random::<f64>(),
                    e_star: 5.3e7,
                    g_star: 1.1e7,
                    damping: 0.1,
                    friction: mu,
                };
                let c = LawCoefs::new(&p);
                let n = Vector::<3>::from_fn(|_, _| rng.random::<f64>() - 0.5).normalize();
                let v = Vector::<3>::from_fn(|_, _| rng.random::<f64>() - 0.5);
                let h = Vector::<3>::from_fn(|_, _| 1e-5 * (rng.random::<f64>() - 0.5));
                let d = 1e-5 * rng.random::<f64>() + 1e-9;
                let mut h_scalar = h;
                let f = hertz_mindlin_coefs(&c, d, &n, &v, &mut h_scalar, 1e-4);
                expect.push((f, h_scalar));
                b.d[m] = d;
                let pf = PairFactors::new(&p);
                b.sr[m] = pf.sr;
                b.sm[m] = pf.sm;
                for a in 0..3 {
                    b.n[a][m] = n[a];
                    b.v[a][m] = v[a];
                    b.h[a][m] = h[a];
                }
            }
            b.len = BATCH;
            law_batch(&mut b, &consts, 1e-4);
            for (m, (f, h)) in expect.iter().enumerate() {
                let tol = 1e-12 * (1.0 + f.normal.abs());
                assert!((b.fnorm[m] - f.normal).abs() <= tol);
                for a in 0..3 {
                    assert!((b.ft[a][m] - f.tangential[a]).abs() <= tol);
                    assert!(
                        (b.h[a][m] - h[a]).abs() <= 1e-12 * (1e-5 + h.norm()),
                        "mu {mu} m {m} a {a}: {} vs {}",
                        b.h[a][m],
                        h[a]
                    );
                }
            }
        }
    }
}
