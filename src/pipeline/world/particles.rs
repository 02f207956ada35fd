//! Particle state (structure of arrays) and how particles enter the world.

use super::*;

/// Particle state, structure of arrays.
#[derive(Clone, Debug, Default)]
pub(super) struct Particles<const D: usize, A> {
    pub(super) x: Vec<Vector<D>>,
    pub(super) v: Vec<Vector<D>>,
    pub(super) f: Vec<Vector<D>>,
    pub(super) w: Vec<A>,
    pub(super) t: Vec<A>,
    pub(super) r: Vec<Real>,
    pub(super) m: Vec<Real>,
    pub(super) inv_m: Vec<Real>,
    pub(super) inv_i: Vec<Real>,
    /// Position at the last pair-list rebuild (skin check).
    pub(super) x_ref: Vec<Vector<D>>,
    /// Half skin h (m) chosen at the last rebuild: the list holds every pair within
    /// h_i + h_j of contact, so it stays valid while no two particles have together
    /// travelled more than h_i + h_j (see `integrate::Travel`).
    pub(super) half_skin: Vec<Real>,
    /// Tangential history and last force on each wall, one entry per wall the world
    /// has (particle q's against wall w at `q * n_walls + w`): a periodic cell stores
    /// its floor's alone (and the lid's once it has one), not the box's six.
    pub(super) wall_hist: Vec<Vector<D>>,
    pub(super) wall_force: Vec<Vector<D>>,
    /// Rolling displacement on each wall, laid out as `wall_hist`; empty without
    /// rolling resistance.
    pub(super) wall_roll: Vec<Vector<D>>,
    /// Frozen particles are not integrated (see [`FreezeConfig`]).
    pub(super) frozen: Vec<bool>,
    /// Bit w set: wall w was in contact at the last evaluation (its state is nonzero).
    pub(super) wall_mask: Vec<u8>,
    /// Bit w set: wall w lies within r + 2 h of the particle at the last pair-list
    /// rebuild, so a contact with it is possible until the next rebuild.
    pub(super) wall_near: Vec<u8>,
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Adds particles. `v` and `w` default to zero. Validates shapes and values (radius
    /// > 0 and finite, finite positions and velocities, inside the box's walls).
    pub fn add_particles(
        &mut self,
        x: &[Vector<D>],
        r: &[Real],
        v: Option<&[Vector<D>]>,
        w: Option<&[Ang<D>]>,
    ) -> Result<()> {
        let n = x.len();
        if r.len() != n {
            return Err(Error::invalid(
                "radii",
                format!("length {}", r.len()),
                &format!("must have one entry per position ({n})"),
            ));
        }
        if let Some(v) = v {
            if v.len() != n {
                return Err(Error::invalid(
                    "velocities",
                    format!("length {}", v.len()),
                    &format!("must have one row per position ({n})"),
                ));
            }
        }
        if let Some(w) = w {
            if w.len() != n {
                return Err(Error::invalid(
                    "spins",
                    format!("length {}", w.len()),
                    &format!("must have one row per position ({n})"),
                ));
            }
        }
        for (k, &rk) in r.iter().enumerate() {
            if !(rk.is_finite() && rk > 0.0) {
                return Err(Error::invalid(
                    &format!("radii[{k}]"),
                    rk,
                    "must be finite and > 0 (m)",
                ));
            }
        }
        for (k, xk) in x.iter().enumerate() {
            if !xk.iter().all(|c| c.is_finite()) {
                return Err(Error::invalid(
                    &format!("positions[{k}]"),
                    format!("{:?}", xk.as_slice()),
                    "must be finite (m)",
                ));
            }
            for wall in &self.walls {
                let s = wall.gap(xk);
                if s < 0.0 {
                    return Err(Error::invalid(
                        &format!("positions[{k}]"),
                        format!("{:?}", xk.as_slice()),
                        "centre lies outside the container's walls",
                    ));
                }
            }
        }
        if let Some(v) = v {
            for (k, vk) in v.iter().enumerate() {
                if !vk.iter().all(|c| c.is_finite()) {
                    return Err(Error::invalid(
                        &format!("velocities[{k}]"),
                        format!("{:?}", vk.as_slice()),
                        "must be finite (m/s)",
                    ));
                }
            }
        }
        if let Some(w) = w {
            for (k, wk) in w.iter().enumerate() {
                if !wk.finite() {
                    return Err(Error::invalid(
                        &format!("spins[{k}]"),
                        format!("{wk:?}"),
                        "must be finite (rad/s)",
                    ));
                }
            }
        }
        let rho = self.cfg.material.density;
        for k in 0..n {
            let rk = r[k];
            let (m, inertia) = if D == 2 && self.cfg.inertia_2d == Inertia2D::Disc {
                let m = std::f64::consts::PI * rk * rk * rho;
                (m, 0.5 * m * rk * rk)
            } else {
                let m = 4.0 / 3.0 * std::f64::consts::PI * rk * rk * rk * rho;
                (m, 0.4 * m * rk * rk)
            };
            self.p.x.push(x[k]);
            self.p.x_ref.push(x[k]);
            self.p.half_skin.push(0.0);
            self.p.v.push(v.map_or(Vector::<D>::zeros(), |v| v[k]));
            self.p.f.push(Vector::<D>::zeros());
            let wk = if self.cfg.rotations {
                w.map_or(Ang::<D>::default(), |w| w[k])
            } else {
                Ang::<D>::default()
            };
            self.p.w.push(wk);
            self.p.t.push(Ang::<D>::default());
            self.p.r.push(rk);
            self.p.m.push(m);
            self.p.inv_m.push(1.0 / m);
            self.p.inv_i.push(1.0 / inertia);
            let walls = self.walls.len();
            self.p
                .wall_hist
                .extend(std::iter::repeat_n(Vector::<D>::zeros(), walls));
            self.p
                .wall_force
                .extend(std::iter::repeat_n(Vector::<D>::zeros(), walls));
            if self.cfg.material.has_rolling() {
                self.p
                    .wall_roll
                    .extend(std::iter::repeat_n(Vector::<D>::zeros(), walls));
            }
            self.p.frozen.push(false);
            self.p.wall_mask.push(0);
            self.p.wall_near.push(0);
        }
        self.forces_valid = false;
        self.list_valid = false;
        self.dt_checked = false;
        self.energy_ref = None;
        Ok(())
    }

    /// Overwrites velocities (m/s) of all particles.
    pub fn set_velocities(&mut self, v: &[Vector<D>]) -> Result<()> {
        if v.len() != self.len() || !v.iter().all(|x| x.iter().all(|c| c.is_finite())) {
            return Err(Error::invalid(
                "velocities",
                format!("{} rows", v.len()),
                &format!("must be {} finite rows", self.len()),
            ));
        }
        self.p.v.copy_from_slice(v);
        self.forces_valid = false;
        self.energy_ref = None;
        Ok(())
    }

    /// Overwrites spins (rad/s) of all particles (ignored when rotations are off).
    pub fn set_spins(&mut self, w: &[Ang<D>]) -> Result<()> {
        if w.len() != self.len() || !w.iter().all(|x| x.finite()) {
            return Err(Error::invalid(
                "spins",
                format!("{} rows", w.len()),
                &format!("must be {} finite rows", self.len()),
            ));
        }
        if self.cfg.rotations {
            self.p.w.copy_from_slice(w);
        }
        self.forces_valid = false;
        self.energy_ref = None;
        Ok(())
    }
}
