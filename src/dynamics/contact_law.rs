//! The contact law as a pure function: Hertz normal force with a viscous dashpot,
//! Mindlin tangential spring with Cundall-Strack history, Coulomb cap.
//!
//! Geometry (overlap, normal, relative velocity) is computed by the caller; pair
//! parameters (R*, m*, E*, G*, xi, mu) come in a [`PairParams`]. This split (geometry,
//! parameters, law) follows YADE's Ig2/Ip2/Law2 functors and keeps the law testable.

use crate::math::{Real, Vector};

/// Constants of one contact (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParams {
    /// Effective radius R* = r_i r_j / (r_i + r_j) (m); r_i for a wall.
    pub r_eff: Real,
    /// Effective mass m* = m_i m_j / (m_i + m_j) (kg); m_i for a wall.
    pub m_eff: Real,
    /// Effective Young's modulus E* (Pa).
    pub e_star: Real,
    /// Effective shear modulus G* (Pa).
    pub g_star: Real,
    /// Damping ratio xi (-).
    pub damping: Real,
    /// Friction coefficient mu (-). Zero switches the tangential law off entirely.
    pub friction: Real,
}

/// Force of one contact, acting on the second body (j, or the wall) along `n` from
/// the first body (i) to the second; the first body gets the opposite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactForce<const D: usize> {
    /// Normal force magnitude (N), >= 0: it pushes j away from i.
    pub normal: Real,
    /// Tangential force on j (N), perpendicular to n.
    pub tangential: Vector<D>,
}

/// Per-contact constants of the law, precomputed once per pair so that a step costs
/// two square roots of the overlap (sqrt(d) and d^{1/4}) and nothing else per pair:
/// k_n = kn s, c_n = cn q, k_t = kt s, c_t = ct q with s = sqrt(d), q = sqrt(s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawCoefs {
    /// 2 E* sqrt(R*) (Pa m^{1/2}).
    pub kn: Real,
    /// 2 xi sqrt(2 E* m* sqrt(R*)) (N s m^{-5/4}).
    pub cn: Real,
    /// 8 G* sqrt(R*) (Pa m^{1/2}).
    pub kt: Real,
    /// 2 xi sqrt(8 G* m* sqrt(R*)) (N s m^{-5/4}).
    pub ct: Real,
    /// Friction coefficient mu.
    pub mu: Real,
}

impl LawCoefs {
    /// The coefficients of a pair.
    #[inline]
    pub fn new(p: &PairParams) -> Self {
        let sr = p.r_eff.sqrt();
        LawCoefs {
            kn: 2.0 * p.e_star * sr,
            cn: 2.0 * p.damping * (2.0 * p.e_star * sr * p.m_eff).sqrt(),
            kt: 8.0 * p.g_star * sr,
            ct: 2.0 * p.damping * (8.0 * p.g_star * sr * p.m_eff).sqrt(),
            mu: p.friction,
        }
    }

    /// The linear law's coefficients of a pair: k_n, c_n = 2 xi sqrt(m* k_n), k_t,
    /// c_t = 2 xi sqrt(m* k_t), mu (for [`linear_coefs`]).
    #[inline]
    pub fn linear(p: &PairParams, kn: Real, kt: Real) -> Self {
        LawCoefs {
            kn,
            cn: 2.0 * p.damping * (kn * p.m_eff).sqrt(),
            kt,
            ct: 2.0 * p.damping * (kt * p.m_eff).sqrt(),
            mu: p.friction,
        }
    }
}

/// Evaluates the Hertz-Mindlin law for one step and advances the tangential history.
///
/// * `overlap` d > 0 (m), `n` the unit normal from i to j;
/// * `v_rel` the velocity of j's surface relative to i's at the contact point (m/s);
/// * `history` the accumulated elastic tangential displacement xi_t (m), updated in
///   place: projected on the current tangent plane (magnitude kept), incremented by
///   v_t dt, and, when Coulomb's cap is active, reset to the displacement that the
///   capped force implies (Cundall & Strack 1979, as in LAMMPS' `granular` pair styles).
///
/// Normal: f_n = 4/3 E* sqrt(R*) d^{3/2} - c_n v_n, c_n = 2 xi sqrt(m* k_n),
/// k_n = 2 E* sqrt(R* d); the total is clamped at 0 (a contact never pulls).
/// Tangential: f_t = -k_t xi_t - c_t v_t, k_t = 8 G* sqrt(R* d), c_t = 2 xi sqrt(m* k_t),
/// |f_t| <= mu f_n.
#[inline(always)]
pub fn hertz_mindlin<const D: usize>(
    p: &PairParams,
    overlap: Real,
    n: &Vector<D>,
    v_rel: &Vector<D>,
    history: &mut Vector<D>,
    dt: Real,
) -> ContactForce<D> {
    hertz_mindlin_coefs(&LawCoefs::new(p), overlap, n, v_rel, history, dt)
}

/// [`hertz_mindlin`] with precomputed [`LawCoefs`]: the scalar reference of the batched
/// law the engine runs (`dynamics::batched_law::law_block`, tested against it).
#[inline(always)]
pub fn hertz_mindlin_coefs<const D: usize>(
    c: &LawCoefs,
    overlap: Real,
    n: &Vector<D>,
    v_rel: &Vector<D>,
    history: &mut Vector<D>,
    dt: Real,
) -> ContactForce<D> {
    let s = overlap.sqrt();
    let q = s.sqrt();
    let vn = v_rel.dot(n);
    // 4/3 E* sqrt(R*) d^{3/2} = 2/3 k_n d
    let f_elastic = (2.0 / 3.0) * c.kn * s * overlap;
    // vn < 0 while approaching: the dashpot then adds to the repulsion.
    let f_n = (f_elastic - c.cn * q * vn).max(0.0);

    if c.mu <= 0.0 {
        return ContactForce {
            normal: f_n,
            tangential: Vector::<D>::zeros(),
        };
    }

    tangential(c.mu, f_n, c.kt * s, c.ct * q, n, v_rel, vn, history, dt)
}

/// The linear law with constant springs, for one step (see [`hertz_mindlin`] for the
/// arguments): f_n = k_n d - c_n v_n clamped at 0, c_n = 2 xi sqrt(m* k_n); the same
/// Cundall-Strack tangential spring with k_t and c_t = 2 xi sqrt(m* k_t). `c` holds
/// k_n, c_n, k_t, c_t themselves ([`LawCoefs::linear`]).
#[inline(always)]
pub fn linear_coefs<const D: usize>(
    c: &LawCoefs,
    overlap: Real,
    n: &Vector<D>,
    v_rel: &Vector<D>,
    history: &mut Vector<D>,
    dt: Real,
) -> ContactForce<D> {
    let vn = v_rel.dot(n);
    let f_n = (c.kn * overlap - c.cn * vn).max(0.0);
    if c.mu <= 0.0 {
        return ContactForce {
            normal: f_n,
            tangential: Vector::<D>::zeros(),
        };
    }
    tangential(c.mu, f_n, c.kt, c.ct, n, v_rel, vn, history, dt)
}

/// The Cundall-Strack tangential spring of both laws: stiffness `k_t`, dashpot `c_t`,
/// capped at mu f_n (see [`hertz_mindlin`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn tangential<const D: usize>(
    mu: Real,
    f_n: Real,
    k_t: Real,
    c_t: Real,
    n: &Vector<D>,
    v_rel: &Vector<D>,
    vn: Real,
    history: &mut Vector<D>,
    dt: Real,
) -> ContactForce<D> {
    let v_t = v_rel - n * vn;
    let f_t = spring_slider(k_t, c_t, &v_t, n, mu * f_n, history, dt);
    ContactForce {
        normal: f_n,
        tangential: f_t,
    }
}

/// The spring-dashpot-slider of the tangential and the rolling law (Cundall and Strack
/// 1979, as in LAMMPS' `granular` sub-models): the stored displacement `history` (m) is
/// kept in the tangent plane of `n` with its magnitude, advanced by `v dt`, and gives
/// the force -k xi - c v; beyond `f_max` the force is capped there and the
/// displacement reset to the one the capped force implies. Returns the force (N).
#[inline(always)]
fn spring_slider<const D: usize>(
    k: Real,
    c: Real,
    v: &Vector<D>,
    n: &Vector<D>,
    f_max: Real,
    history: &mut Vector<D>,
    dt: Real,
) -> Vector<D> {
    // Keep the history in the current tangent plane; rescale so that rotating the
    // contact frame does not change the stored elastic energy.
    let h_old2 = history.norm_squared();
    let mut h = *history - n * history.dot(n);
    let h_new2 = h.norm_squared();
    if h_new2 > 0.0 && h_new2 != h_old2 {
        h *= (h_old2 / h_new2).sqrt();
    }
    h += v * dt;

    let mut f = -(h * k) - v * c;
    let f2 = f.norm_squared();
    if f2 > f_max * f_max {
        // Sliding (rolling): cap |f| at f_max and store the stretch consistent with it.
        let scale = if f2 > 0.0 { f_max / f2.sqrt() } else { 0.0 };
        f *= scale;
        h = if k > 0.0 {
            -(f + v * c) * (1.0 / k)
        } else {
            Vector::<D>::zeros()
        };
    }
    *history = h;
    f
}

/// The rolling-resistance constants of the elastic-plastic spring-dashpot model
/// ([`Rolling::Epsd`](super::material::Rolling)), as the law takes them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RollCoefs {
    /// Rolling friction coefficient mu_r (-).
    pub mu_r: Real,
    /// A given rolling spring k_r (N/m), 0 when derived.
    pub k_abs: Real,
    /// The derived spring's factor on the normal stiffness, 2.25 mu_r^2, 0 when given.
    pub k_rel: Real,
    /// Rolling dashpot gamma_r (N s/m).
    pub gamma: Real,
}

impl RollCoefs {
    /// From the material's rolling model; all zero without one.
    pub fn new(rolling: &super::material::Rolling) -> Self {
        match *rolling {
            super::material::Rolling::None => RollCoefs::default(),
            super::material::Rolling::Epsd { mu_r, k_r, gamma_r } => RollCoefs {
                mu_r,
                k_abs: k_r.unwrap_or(0.0),
                k_rel: if k_r.is_some() {
                    0.0
                } else {
                    2.25 * mu_r * mu_r
                },
                gamma: gamma_r,
            },
        }
    }
}

/// The elastic-plastic spring-dashpot rolling law for one step (LAMMPS `rolling sds`,
/// Ai et al. 2011 type C), returning the rolling force f_r; the moment on i is
/// -R* n x f_r, on j +R* n x f_r.
///
/// * `v_r` the rolling velocity R* (w_j - w_i) x n (m/s);
/// * `f_n` the contact's normal force (N), `k_n` its normal stiffness (N/m), which
///   sets a derived rolling spring;
/// * `history` the rolling displacement (m), kept in the tangent plane with its
///   magnitude, advanced by v_r dt, and reset to the capped force's displacement when
///   the moment reaches mu_r R* f_n.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn rolling_epsd<const D: usize>(
    rc: &RollCoefs,
    f_n: Real,
    k_n: Real,
    n: &Vector<D>,
    v_r: &Vector<D>,
    history: &mut Vector<D>,
    dt: Real,
) -> Vector<D> {
    let k_r = rc.k_abs + rc.k_rel * k_n;
    let f_r = spring_slider(k_r, rc.gamma, v_r, n, rc.mu_r * f_n, history, dt);
    // without a spring (mu_r = 0 under the derived k_r) nothing is stored: a
    // displacement would otherwise grow unbounded and snap back once mu_r returns
    if k_r <= 0.0 {
        *history = Vector::<D>::zeros();
    }
    f_r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> PairParams {
        PairParams {
            r_eff: 0.005,
            m_eff: 0.002,
            e_star: 5.333e7,
            g_star: 1.143e7,
            damping: 0.1,
            friction: 0.2,
        }
    }

    #[test]
    fn static_hertz_force_matches_formula() {
        let p = PairParams {
            damping: 0.0,
            ..params()
        };
        let n = Vector::<3>::new(0.0, 0.0, 1.0);
        let mut h = Vector::<3>::zeros();
        let d = 1e-5;
        let f = hertz_mindlin(&p, d, &n, &Vector::<3>::zeros(), &mut h, 1e-4);
        let expected = 4.0 / 3.0 * p.e_star * p.r_eff.sqrt() * d.powf(1.5);
        assert!((f.normal - expected).abs() < 1e-12 * expected.max(1.0));
        assert_eq!(f.tangential, Vector::<3>::zeros());
    }

    #[test]
    fn normal_force_never_pulls() {
        let n = Vector::<2>::new(1.0, 0.0);
        let mut h = Vector::<2>::zeros();
        // Fast separation: the dashpot term would make the total negative.
        let f = hertz_mindlin(
            &params(),
            1e-7,
            &n,
            &Vector::<2>::new(100.0, 0.0),
            &mut h,
            1e-4,
        );
        assert_eq!(f.normal, 0.0);
    }

    #[test]
    fn coulomb_cap_holds_and_history_is_consistent() {
        let p = params();
        let n = Vector::<3>::new(0.0, 0.0, 1.0);
        let v = Vector::<3>::new(1.0, 0.0, 0.0);
        let mut h = Vector::<3>::zeros();
        for _ in 0..100 {
            let f = hertz_mindlin(&p, 1e-4, &n, &v, &mut h, 1e-4);
            assert!(f.tangential.norm() <= p.friction * f.normal * (1.0 + 1e-12));
            assert!(f.tangential.dot(&n).abs() < 1e-12);
        }
        // After sliding, the spring alone plus the dashpot reproduce the capped force.
        let f = hertz_mindlin(&p, 1e-4, &n, &v, &mut h, 1e-4);
        assert!((f.tangential.norm() - p.friction * f.normal).abs() < 1e-9 * f.normal);
        assert!(f.tangential[0] < 0.0, "friction opposes sliding");
    }

    #[test]
    fn zero_friction_keeps_no_history() {
        let p = PairParams {
            friction: 0.0,
            ..params()
        };
        let n = Vector::<3>::new(0.0, 0.0, 1.0);
        let mut h = Vector::<3>::zeros();
        let f = hertz_mindlin(&p, 1e-4, &n, &Vector::<3>::new(1.0, 0.0, 0.0), &mut h, 1e-4);
        assert_eq!(h, Vector::<3>::zeros());
        assert_eq!(f.tangential, Vector::<3>::zeros());
    }

    #[test]
    fn history_is_rotated_into_the_tangent_plane() {
        let p = PairParams {
            friction: 10.0,
            damping: 0.0,
            ..params()
        };
        let n = Vector::<3>::new(0.0, 0.0, 1.0);
        let mut h = Vector::<3>::new(1e-6, 0.0, 1e-6);
        let norm_before = h.norm();
        hertz_mindlin(&p, 1e-4, &n, &Vector::<3>::zeros(), &mut h, 1e-4);
        assert!(h[2].abs() < 1e-20);
        assert!((h.norm() - norm_before).abs() < 1e-18);
    }
}
