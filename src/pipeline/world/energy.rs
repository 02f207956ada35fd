//! Energies and the run-time guards: kinetic, potential and elastic energy, the state
//! check (non-finite values, centres through walls, speeds that tunnel) and the energy
//! balance check.

use super::*;

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Gravity and moving walls are the only sources of energy (contacts, drag and walls
    /// at rest dissipate; a moving wall's work is counted in `wall_work`), so
    /// kinetic plus potential energy may exceed its value at the last user-set state
    /// only by the elastic energy the contacts can release. That is bounded here,
    /// generously, by the work of lifting every particle by its radius (sum m |g| r)
    /// plus 1 % of the reference kinetic energy; a numerical blow-up exceeds it by
    /// orders of magnitude.
    pub(super) fn check_energy(&mut self) -> Result<()> {
        let e = self.kinetic_energy() + self.potential_energy() + self.elastic_energy();
        let g = self.cfg.gravity.norm();
        let Some(e_ref) = self.energy_ref else {
            self.energy_ref = Some(e);
            self.wall_work = 0.0;
            return Ok(());
        };
        let lift: Real = self.p.m.iter().zip(&self.p.r).map(|(m, r)| m * g * r).sum();
        let tol = lift + 0.01 * e_ref.abs() + 1e-300;
        // moving walls are a second source: the work they did (zero otherwise)
        let e_ref = e_ref + self.wall_work;
        if e > e_ref + tol {
            let fastest = (0..self.len())
                .max_by(|&a, &b| {
                    self.p.v[a]
                        .norm_squared()
                        .partial_cmp(&self.p.v[b].norm_squared())
                        .unwrap_or(std::cmp::Ordering::Equal)
                })
                .unwrap_or(0);
            return Err(Error::Blowup {
                step: self.steps,
                time: self.time,
                particle: fastest,
                kind: BlowupKind::Energy,
                what: format!(
                    "kinetic + potential + elastic energy grew from {e_ref:e} J to {e:e} J \
                     beyond the work of gravity and of moving walls (fastest particle \
                     shown); reduce dt"
                ),
            });
        }
        Ok(())
    }

    /// Stops on a non-finite value or a particle that has left the box.
    pub(super) fn check_state(&self) -> Result<()> {
        let p = &self.p;
        let walls = &self.walls;
        let dt = self.cfg.dt;
        let bad = (0..p.x.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .filter_map(|k| {
                let x = &p.x[k];
                if !(x.iter().all(|c| c.is_finite())
                    && p.v[k].iter().all(|c| c.is_finite())
                    && p.w[k].finite())
                {
                    return Some((
                        k,
                        BlowupKind::NonFinite,
                        "non-finite position, velocity or spin".to_string(),
                    ));
                }
                // A particle that moves more than half its radius in one step can tunnel
                // through a neighbour without the overlap guard ever seeing it.
                let step_len = p.v[k].norm() * dt;
                if step_len > 0.5 * p.r[k] {
                    return Some((
                        k,
                        BlowupKind::Speed,
                        format!(
                            "speed {:e} m/s moves it {:e} m per step, more than half its \
                             radius {:e} m; reduce dt",
                            p.v[k].norm(),
                            step_len,
                            p.r[k]
                        ),
                    ));
                }
                for (wi, wall) in walls.iter().enumerate() {
                    let s = wall.gap(x);
                    if s < 0.0 {
                        return Some((
                            k,
                            BlowupKind::WallCrossed,
                            format!(
                                "centre crossed wall {} ({})",
                                -(wi as i64) - 1,
                                wall.crossing(x)
                            ),
                        ));
                    }
                }
                None
            })
            .min_by_key(|(k, _, _)| *k);
        if let Some((k, kind, what)) = bad {
            return Err(Error::Blowup {
                step: self.steps,
                time: self.time,
                particle: k,
                kind,
                what,
            });
        }
        Ok(())
    }

    /// Kinetic energy, translational plus rotational (J). Summed in fixed chunks so
    /// the value does not depend on the thread count.
    pub fn kinetic_energy(&self) -> Real {
        let p = &self.p;
        let parts: Vec<Real> = (0..p.x.len().div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut e = 0.0;
                for k in c * CHUNK..((c + 1) * CHUNK).min(p.x.len()) {
                    e += 0.5 * p.m[k] * p.v[k].norm_squared();
                    if self.cfg.rotations {
                        e += 0.5 * p.w[k].norm2() / p.inv_i[k];
                    }
                }
                e
            })
            .collect();
        parts.iter().sum()
    }

    /// Elastic energy stored in the contacts at the last force evaluation (J): Hertz
    /// 8/15 E* sqrt(R*) d^{5/2} (= 2/5 f_el d), or 1/2 k_n d^2 under the linear law,
    /// plus the tangential springs 1/2 k_t |xi_t|^2, capped at (mu f_el)^2 / (2 k_t),
    /// over pairs and wall contacts. (The rolling springs' energy is left out: at most
    /// (mu_r R* f_n)^2 / (2 k_r R*^2) a contact, a share of the normal spring's.)
    pub fn elastic_energy(&self) -> Real {
        let mu = self.cfg.material.friction;
        // Energy of one contact from its law coefficients. A sliding contact stores the
        // stretch -(f_t + c_t v_t) / k_t, which includes the dashpot's share; the spring
        // itself can hold at most (mu f_n)^2 / (2 k_t) under Coulomb's cap, with f_n the
        // elastic normal force, so the tangential term is capped there.
        let linear = match self.cfg.material.law {
            ContactLaw::Linear { kn, kt } => Some((kn, kt)),
            ContactLaw::HertzMindlin => None,
        };
        let contact = |kn: Real, kt: Real, d: Real, h2: Real| {
            if let Some((kn, k_t)) = linear {
                // 1/2 k_n d^2 and the tangential spring, capped as below
                let f_el = kn * d;
                return 0.5 * f_el * d + (0.5 * k_t * h2).min((mu * f_el).powi(2) / (2.0 * k_t));
            }
            let s = d.sqrt();
            let f_el = (2.0 / 3.0) * kn * s * d;
            let k_t = kt * s;
            let tangential = if k_t > 0.0 {
                (0.5 * k_t * h2).min((mu * f_el).powi(2) / (2.0 * k_t))
            } else {
                0.0
            };
            0.4 * f_el * d + tangential
        };
        // the law's own constants: k_n = kn sqrt(R*) sqrt(d), k_t the same with kt
        let c = LawConsts::new(self.e_star, self.g_star, 0.0, mu);
        let pr = &self.pairs;
        let mut e = 0.0;
        for k in 0..pr.ij.len() {
            let rec = pr.get(k);
            if rec.d > 0.0 {
                let sr = rec.coefs.sr;
                let h2 = Vector::<D>::from(rec.h).norm_squared();
                e += contact(c.kn * sr, c.kt * sr, rec.d, h2);
            }
        }
        for q in 0..self.len() {
            for (wi, wall) in self.walls.iter().enumerate() {
                let d = self.p.r[q] - wall.gap(&self.p.x[q]);
                if d > 0.0 {
                    let sr = wall.r_eff(self.p.r[q]).sqrt();
                    let h2 = self.p.wall_hist[q * self.walls.len() + wi].norm_squared();
                    e += contact(c.kn * sr, c.kt * sr, d, h2);
                }
            }
        }
        e
    }

    /// Largest particle speed (m/s).
    pub fn max_speed(&self) -> Real {
        self.p
            .v
            .par_iter()
            .with_min_len(CHUNK)
            .map(|v| v.norm_squared())
            .reduce(|| 0.0, Real::max)
            .sqrt()
    }

    /// Gravitational potential energy relative to the origin, -sum m g.x (J).
    pub fn potential_energy(&self) -> Real {
        let g = self.cfg.gravity;
        self.p
            .x
            .iter()
            .zip(&self.p.m)
            .map(|(x, m)| -m * g.dot(x))
            .sum()
    }
}
