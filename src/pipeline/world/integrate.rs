//! Velocity Verlet: the first half kick and the drift (the second half kick runs in
//! the gather, `forces.rs`, as soon as each particle's force is known).

use super::*;

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Step part 1: the first half kick and the drift of every particle that is not
    /// frozen (`FROZEN`: some are), and of the spins with `TORQUE` (rotations and
    /// friction on). Returns whether the pair list may miss a contact now (see
    /// [`Crossed`] and [`Travel`]), or a position turned non-finite.
    pub(super) fn kick_drift<const TORQUE: bool, const FROZEN: bool>(
        &mut self,
        team: &mut Team,
    ) -> bool {
        let dt = self.cfg.dt;
        let half = 0.5 * dt;
        let ld = self.local_damping;
        let p = &mut self.p;
        let len = p.x.len();
        let per = self.period.as_ref();
        let (xs, vs, ws, xrs) = (
            Disjoint::new(&mut p.x),
            Disjoint::new(&mut p.v),
            Disjoint::new(&mut p.w),
            Disjoint::new(&mut p.x_ref),
        );
        let (fs, ims, hs, fzs, ts, iis) = (&p.f, &p.inv_m, &p.half_skin, &p.frozen, &p.t, &p.inv_i);
        let crossed = team.map_reduce(
            len.div_ceil(TEAM_CHUNK),
            Crossed::NONE,
            |c, _| {
                let r = c * TEAM_CHUNK..(c * TEAM_CHUNK + TEAM_CHUNK).min(len);
                // SAFETY: the items' ranges are disjoint.
                let (x, v, w, xr) = unsafe {
                    (
                        xs.range(r.clone()),
                        vs.range(r.clone()),
                        ws.range(r.clone()),
                        xrs.range(r.clone()),
                    )
                };
                let (f, im, h) = (&fs[r.clone()], &ims[r.clone()], &hs[r.clone()]);
                let (fz, t, ii) = (&fzs[r.clone()], &ts[r.clone()], &iis[r]);
                kick_drift_chunk::<D, TORQUE, FROZEN>(
                    KickDrift { x, v, w, xr },
                    f,
                    im,
                    per,
                    h,
                    fz,
                    t,
                    ii,
                    dt,
                    half,
                    ld,
                )
            },
            Crossed::merge,
        );
        if crossed.beyond {
            return true;
        }
        if !crossed.own {
            return false;
        }
        // Some particle is past its own half skin (the sum of the two largest excesses
        // can be positive only then): the exact test, over every particle.
        let (x, xr, h) = (&self.p.x, &self.p.x_ref, &self.p.half_skin);
        team.map_reduce(
            len.div_ceil(TEAM_CHUNK),
            Travel::NONE,
            |c, _| {
                let r = c * TEAM_CHUNK..(c * TEAM_CHUNK + TEAM_CHUNK).min(len);
                let mut t = Travel::NONE;
                for ((x, xr), &h) in x[r.clone()].iter().zip(&xr[r.clone()]).zip(&h[r]) {
                    t.add((x - xr).norm_squared(), h);
                }
                t
            },
            Travel::merge,
        )
        .may_touch()
    }
}

/// What the drift tells of a chunk's particles at no extra cost: whether one is past
/// its own half skin, or beyond twice it (or non-finite). Only in the first case is
/// the exact test ([`Travel`]) needed.
#[derive(Clone, Copy, Debug)]
pub(super) struct Crossed {
    /// Some particle has travelled more than its (shortened) half skin.
    own: bool,
    /// Some particle has travelled more than twice it, or is non-finite.
    beyond: bool,
}

impl Crossed {
    const NONE: Crossed = Crossed {
        own: false,
        beyond: false,
    };

    /// Takes a particle that travelled `d2` squared (m^2) with half skin `h` (m).
    #[inline(always)]
    fn add(&mut self, d2: Real, h: Real) {
        let h = short(h);
        // written so that NaN also trips it
        self.beyond |= d2.is_nan() | (d2 > 4.0 * h * h);
        self.own |= d2 > h * h;
    }

    fn merge(a: Crossed, b: Crossed) -> Crossed {
        Crossed {
            own: a.own | b.own,
            beyond: a.beyond | b.beyond,
        }
    }
}

/// The half skin `h` a hair short: a wrapped particle's reference moved by a period in
/// floating point, which may round its distance by an ulp of the cell.
#[inline(always)]
fn short(h: Real) -> Real {
    h * (1.0 - 1e-9)
}

/// Wraps `x` into the periodic cell `per` and moves its reference `xr` with it: kept
/// out of the drift's loop, which would otherwise compute the wrap for every particle
/// (it is vectorised branch-free), for the few that leave the cell in a step.
#[cold]
#[inline(never)]
fn wrap_into<const D: usize>(per: &Period<D>, x: &mut Vector<D>, xr: &mut Vector<D>) {
    let inside = per.wrap(*x);
    *xr += inside - *x;
    *x = inside;
}

/// How far the particles have travelled since the last rebuild, against their half
/// skins: enough to tell whether the pair list may miss a contact.
///
/// A pair (i, j) left out of the list was at least h_i + h_j from contact at the
/// rebuild, so it can touch only once d_i + d_j > h_i + h_j, with d the distance a
/// particle has travelled since. With e = d - h (the excess over the half skin), the
/// list holds every contact while the two largest excesses sum to at most zero. That
/// lets one particle run past its own skin by the smallest margin any other has left:
/// at scale, where some particle always moves, the first to cross its skin no longer
/// sets off a rebuild of the whole list on its own. The walls' near flags are set
/// within 3 h of contact (see `rebuild_pairs`), and d <= 2 h is kept for every
/// particle as well ([`Crossed`], which also catches a non-finite position). Which step
/// rebuilds does not change a force: pairs out of contact add exact zeros.
#[derive(Clone, Copy, Debug)]
pub(super) struct Travel {
    /// The largest excess d - h (m).
    first: Real,
    /// The second largest (m).
    second: Real,
}

impl Travel {
    /// No particle: nothing travelled.
    const NONE: Travel = Travel {
        first: Real::NEG_INFINITY,
        second: Real::NEG_INFINITY,
    };

    /// Takes a particle that travelled `d2` squared (m^2) with half skin `h` (m).
    #[inline(always)]
    fn add(&mut self, d2: Real, h: Real) {
        let e = d2.sqrt() - short(h);
        let low = e.min(self.first);
        self.first = self.first.max(e);
        self.second = self.second.max(low);
    }

    /// Both chunks' particles together (exact: maxima and minima do not round).
    fn merge(a: Travel, b: Travel) -> Travel {
        let low = a.first.min(b.first);
        Travel {
            first: a.first.max(b.first),
            second: a.second.max(b.second).max(low),
        }
    }

    /// Whether two particles may have come into contact unlisted.
    fn may_touch(&self) -> bool {
        self.first + self.second > 0.0
    }
}

/// What kick/drift changes in one chunk of particles.
struct KickDrift<'a, const D: usize>
where
    Dim<D>: Spatial<D>,
{
    x: &'a mut [Vector<D>],
    v: &'a mut [Vector<D>],
    w: &'a mut [Ang<D>],
    /// The positions at the last rebuild, moved with a particle that wraps.
    xr: &'a mut [Vector<D>],
}

crate::cpu::multiversion! {
/// Kick/drift of one chunk (see [`World::kick_drift`]); compiled for each
/// instruction-set level (see [`crate::cpu`]).
fn kick_drift_chunk [const D: usize, const TORQUE: bool, const FROZEN: bool] (
    s: KickDrift<D>,
    f: &[Vector<D>],
    im: &[Real],
    per: Option<&Period<D>>,
    h: &[Real],
    fz: &[bool],
    t: &[Ang<D>],
    ii: &[Real],
    dt: Real,
    half: Real,
    ld: Real,
) -> Crossed where [Dim<D>: Spatial<D>] [D, TORQUE, FROZEN] {
    let mut moved = Crossed::NONE;
    // the cell's bounds on its periodic axes (+-inf on the others)
    let (mut lo, mut hi) = ([Real::NEG_INFINITY; D], [Real::INFINITY; D]);
    if let Some(per) = per {
        for a in 0..D {
            if per.len[a] > 0.0 {
                (lo[a], hi[a]) = (per.lo[a], per.lo[a] + per.len[a]);
            }
        }
    }
    // Every chunk slice cut to one length: the loop then runs without bounds checks.
    let n = s.x.len();
    let (x, v, w, xr) = (&mut s.x[..n], &mut s.v[..n], &mut s.w[..n], &mut s.xr[..n]);
    let (f, im, h, fz) = (&f[..n], &im[..n], &h[..n], &fz[..n]);
    let (t, ii) = (&t[..n], &ii[..n]);
    for k in 0..n {
        if FROZEN && fz[k] {
            // a frozen particle keeps what it travelled before it froze
            moved.add((x[k] - xr[k]).norm_squared(), h[k]);
            continue;
        }
        if ld > 0.0 {
            v[k] += super::forces::local_damped(f[k], &v[k], ld) * (im[k] * half);
        } else {
            v[k] += f[k] * (im[k] * half);
        }
        x[k] += v[k] * dt;
        // A particle that leaves a periodic cell re-enters it on the drift that takes
        // it out, whatever the pair list does: positions, and so every separation's
        // rounding, do not depend on when the list is rebuilt (nor on the skin). The
        // bounds are those `Period::wrap` tests; NaN is out too, and left to the checks.
        let mut out = false;
        for a in 0..D {
            out |= !((x[k][a] >= lo[a]) & (x[k][a] < hi[a]));
        }
        if out {
            if let Some(per) = per {
                wrap_into(per, &mut x[k], &mut xr[k]);
            }
        }
        moved.add((x[k] - xr[k]).norm_squared(), h[k]);
        if TORQUE {
            w[k] += t[k] * (ii[k] * half);
        }
    }
    moved
}
}

#[cfg(test)]
mod tests {
    use super::{short, Crossed, Travel};
    use crate::math::Real;
    use proptest::prelude::*;

    proptest! {
        /// The drift's cheap flags and, when some particle is past its own half skin,
        /// the two largest excesses gathered chunk by chunk in any split, say that the
        /// list may miss a contact exactly when some two particles have together
        /// travelled more than their half skins, or one more than twice its own.
        #[test]
        fn travel_equals_the_pairwise_test(
            moves in prop::collection::vec((0.0..3.0f64, 0.1..1.0f64), 0..40),
            split in 0usize..40,
        ) {
            let d2h: Vec<(Real, Real)> = moves.iter().map(|&(f, h)| ((f * h) * (f * h), h)).collect();
            let split = split.min(d2h.len());
            let mut a = Travel::NONE;
            let mut b = Travel::NONE;
            for &(d2, h) in &d2h[..split] {
                a.add(d2, h);
            }
            for &(d2, h) in &d2h[split..] {
                b.add(d2, h);
            }
            let mut c = Crossed::NONE;
            for &(d2, h) in &d2h {
                c.add(d2, h);
            }
            let got = c.beyond || (c.own && Travel::merge(b, a).may_touch());
            let mut want = d2h.iter().any(|&(d2, h)| d2.sqrt() > 2.0 * short(h));
            for (i, &(di2, hi)) in d2h.iter().enumerate() {
                for &(dj2, hj) in &d2h[i + 1..] {
                    want |= di2.sqrt() + dj2.sqrt() > short(hi) + short(hj);
                }
            }
            prop_assert_eq!(got, want);
        }
    }

    /// A non-finite position asks for the rebuild that finds it.
    #[test]
    fn a_nan_position_is_stale() {
        let mut c = Crossed::NONE;
        for d2 in [0.0, Real::NAN, 0.0] {
            c.add(d2, 1.0);
        }
        assert!(c.beyond);
    }
}
