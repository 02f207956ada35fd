//! Velocity Verlet: the first half kick and the drift (the second half kick runs in
//! the gather, `forces.rs`, as soon as each particle's force is known).

use super::*;

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Step part 1: the first half kick and the drift of every particle that is not
    /// frozen (`FROZEN`: some are), and of the spins with `TORQUE` (rotations and
    /// friction on). Returns whether a particle has moved more than its half skin since
    /// the last rebuild (or turned non-finite).
    pub(super) fn kick_drift<const TORQUE: bool, const FROZEN: bool>(
        &mut self,
        team: &mut Team,
    ) -> bool {
        let dt = self.cfg.dt;
        let half = 0.5 * dt;
        let ld = self.local_damping;
        let p = &mut self.p;
        let len = p.x.len();
        let (xs, vs, ws) = (
            Disjoint::new(&mut p.x),
            Disjoint::new(&mut p.v),
            Disjoint::new(&mut p.w),
        );
        let (fs, ims, xrs, hs, fzs, ts, iis) = (
            &p.f,
            &p.inv_m,
            &p.x_ref,
            &p.half_skin,
            &p.frozen,
            &p.t,
            &p.inv_i,
        );
        team.map_reduce(
            len.div_ceil(TEAM_CHUNK),
            false,
            |c, _| {
                let r = c * TEAM_CHUNK..(c * TEAM_CHUNK + TEAM_CHUNK).min(len);
                // SAFETY: the items' ranges are disjoint.
                let (x, v, w) = unsafe {
                    (
                        xs.range(r.clone()),
                        vs.range(r.clone()),
                        ws.range(r.clone()),
                    )
                };
                let (f, im, xr, h) = (
                    &fs[r.clone()],
                    &ims[r.clone()],
                    &xrs[r.clone()],
                    &hs[r.clone()],
                );
                let (fz, t, ii) = (&fzs[r.clone()], &ts[r.clone()], &iis[r]);
                kick_drift_chunk::<D, TORQUE, FROZEN>(
                    KickDrift { x, v, w },
                    f,
                    im,
                    xr,
                    h,
                    fz,
                    t,
                    ii,
                    dt,
                    half,
                    ld,
                )
            },
            |a, b| a | b,
        )
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
}

crate::cpu::multiversion! {
/// Kick/drift of one chunk (see [`World::kick_drift`]); compiled for each
/// instruction-set level (see [`crate::cpu`]).
fn kick_drift_chunk [const D: usize, const TORQUE: bool, const FROZEN: bool] (
    s: KickDrift<D>,
    f: &[Vector<D>],
    im: &[Real],
    xr: &[Vector<D>],
    h: &[Real],
    fz: &[bool],
    t: &[Ang<D>],
    ii: &[Real],
    dt: Real,
    half: Real,
    ld: Real,
) -> bool where [Dim<D>: Spatial<D>] [D, TORQUE, FROZEN] {
    let mut moved = false;
    // Every chunk slice cut to one length: the loop then runs without bounds checks.
    let n = s.x.len();
    let (x, v, w) = (&mut s.x[..n], &mut s.v[..n], &mut s.w[..n]);
    let (f, im, xr, h, fz) = (&f[..n], &im[..n], &xr[..n], &h[..n], &fz[..n]);
    let (t, ii) = (&t[..n], &ii[..n]);
    for k in 0..n {
        if FROZEN && fz[k] {
            continue;
        }
        if ld > 0.0 {
            v[k] += super::forces::local_damped(f[k], &v[k], ld) * (im[k] * half);
        } else {
            v[k] += f[k] * (im[k] * half);
        }
        x[k] += v[k] * dt;
        // written so that NaN also trips it
        let d2 = (x[k] - xr[k]).norm_squared();
        moved |= d2.is_nan() | (d2 > h[k] * h[k]);
        if TORQUE {
            w[k] += t[k] * (ii[k] * half);
        }
    }
    moved
}
}
