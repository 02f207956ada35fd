//! Walls that move: the lid, the servo's wall speeds, and the loads on the walls.
//!
//! A wall moves along its own normal: a plane along its axis, the cylinder by its
//! radius. Its speed enters the contact law (the relative velocity at the contact, so
//! the dashpot and the tangential spring see it), and the work it does on the
//! particles widens the energy guard's budget. The loads are summed over particles in
//! index order, one thread, so they are the same bits on any thread count.

use super::*;

/// The load that the particles put on one wall.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WallLoad {
    /// Force along the wall's outward normal (N): positive when the particles push
    /// the wall outwards. In 2D, per metre of thickness for discs as for the pairs.
    pub force: Real,
    /// The Hertz tangent stiffness of its contacts, sum of 2 E* sqrt(R* d) (N/m): the
    /// force the wall gains per metre it moves in while the particles stay put.
    pub stiffness: Real,
    /// The normal dashpots of its contacts, sum of 2 xi sqrt(m k_n) (N s/m): the force
    /// the wall gains per m/s it moves in.
    pub viscosity: Real,
    /// Contacts in force on it.
    pub contacts: usize,
}

impl WallLoad {
    /// The force the wall gains when it moves in by `dx` (m) in one step of `dt` (s)
    /// while the particles stay put: the springs' K dx and the dashpots' C dx / dt
    /// (N per m). At the paper's settings the dashpots' share is the larger one.
    pub fn step_stiffness(&self, dt: Real) -> Real {
        self.stiffness + self.viscosity / dt
    }
}

/// The balance of forces on the particles (YADE's and PFC's equilibrium measures).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ForceBalance {
    /// Mean over particles of |net force| (N), gravity and drag included.
    pub mean_net: Real,
    /// Largest |net force| over particles (N).
    pub max_net: Real,
    /// Mean |contact force| over the contacts in force, wall contacts included (N).
    pub mean_contact: Real,
    /// Contacts in force (pairs and walls).
    pub contacts: usize,
}

impl ForceBalance {
    /// YADE's unbalanced-force ratio: mean |net force| over mean |contact force| (-);
    /// infinity when no contact carries force.
    pub fn unbalanced(&self) -> Real {
        if self.mean_contact > 0.0 {
            self.mean_net / self.mean_contact
        } else {
            Real::INFINITY
        }
    }

    /// PFC's maximum unbalanced-force ratio: largest |net force| over the mean
    /// |contact force| (-).
    pub fn max_ratio(&self) -> Real {
        if self.mean_contact > 0.0 {
            self.max_net / self.mean_contact
        } else {
            Real::INFINITY
        }
    }
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Adds a lid: a plane wall at height `z` (m) on the vertical axis that faces down,
    /// after the container's walls (its id is the next: -6 in a 3D box, -4 in a 2D
    /// box, -3 in a cylinder, -2 in a periodic cell). Returns its index in the wall
    /// list (id = -index - 1). Needs the container's walls, at most one lid, and no
    /// particle centre above `z`.
    pub fn add_lid(&mut self, z: Real) -> Result<usize> {
        let vert = <Dim<D> as Spatial<D>>::VERTICAL;
        let Some((lo, _)) = &self.cfg.walls else {
            return Err(Error::invalid(
                "lid",
                z,
                "needs a container (box, periodic cell or cylinder) to close",
            ));
        };
        if self.has_lid() {
            return Err(Error::invalid("lid", z, "the world already has a lid"));
        }
        if !(z.is_finite() && z > lo[vert]) {
            return Err(Error::invalid(
                "lid",
                z,
                &format!("must be finite and above the floor at {} m", lo[vert]),
            ));
        }
        if let Some(q) = self.p.x.iter().position(|x| x[vert] >= z) {
            return Err(Error::invalid(
                "lid",
                z,
                &format!(
                    "must lie above every centre; particle {q} has its centre at {} m",
                    self.p.x[q][vert]
                ),
            ));
        }
        // every particle's wall state gains the lid's entry, zero
        let (walls, n) = (self.walls.len(), self.p.x.len());
        let widen = |v: &mut Vec<Vector<D>>| {
            let mut wide = Vec::with_capacity(n * (walls + 1));
            for q in 0..n {
                wide.extend_from_slice(&v[q * walls..(q + 1) * walls]);
                wide.push(Vector::<D>::zeros());
            }
            *v = wide;
        };
        widen(&mut self.p.wall_hist);
        widen(&mut self.p.wall_force);
        if self.cfg.material.has_rolling() {
            widen(&mut self.p.wall_roll);
        }
        self.walls.push(Wall::Plane {
            axis: vert,
            pos: z,
            sign: 1.0,
        });
        self.list_valid = false;
        self.forces_valid = false;
        Ok(self.walls.len() - 1)
    }

    /// Whether the last wall is a lid (a plane on the vertical axis facing down).
    pub fn has_lid(&self) -> bool {
        let vert = <Dim<D> as Spatial<D>>::VERTICAL;
        matches!(self.walls.last(), Some(Wall::Plane { axis, sign, .. })
            if *axis == vert && *sign > 0.0)
    }

    /// Number of walls (the container's, and the lid).
    pub fn wall_count(&self) -> usize {
        self.walls.len()
    }

    /// Where wall `wi` is (m): a plane's coordinate on its axis, the cylinder's radius.
    pub fn wall_position(&self, wi: usize) -> Real {
        match self.walls[wi] {
            Wall::Plane { pos, .. } => pos,
            Wall::Cylinder { radius, .. } => radius,
        }
    }

    /// The area of wall `wi` that the particles can touch (m^2; in 2D, m per metre of
    /// thickness): the floor and the lid span the cell (the box between its side
    /// walls, the periodic cell's periods, the cylinder's disc); a side wall or the
    /// cylinder spans the height from the floor to the lid, which must exist.
    pub fn wall_area(&self, wi: usize) -> Result<Real> {
        let vert = <Dim<D> as Spatial<D>>::VERTICAL;
        let Some((lo, hi)) = self.cfg.walls else {
            return Err(Error::invalid("wall", wi, "the world has no container"));
        };
        // the lateral extent along horizontal axis k: between the box's side walls where
        // they are now (walls 1 + 2k and 2 + 2k), the period otherwise
        let extent = |k: usize| match self.cfg.container {
            Container::Box => self.wall_position(2 + 2 * k) - self.wall_position(1 + 2 * k),
            _ => hi[k] - lo[k],
        };
        let height = || -> Result<Real> {
            if !self.has_lid() {
                return Err(Error::invalid(
                    "wall",
                    wi,
                    "a side wall's area needs the lid that bounds the sample",
                ));
            }
            Ok(self.wall_position(self.walls.len() - 1) - self.wall_position(0))
        };
        Ok(match self.walls[wi] {
            Wall::Cylinder { radius, .. } => 2.0 * std::f64::consts::PI * radius * height()?,
            Wall::Plane { axis, .. } if axis == vert => match self.walls.get(1) {
                Some(Wall::Cylinder { radius, .. }) => std::f64::consts::PI * radius * radius,
                _ => (0..vert).map(extent).product(),
            },
            Wall::Plane { axis, .. } => {
                height()?
                    * (0..vert)
                        .filter(|&k| k != axis)
                        .map(extent)
                        .product::<Real>()
            }
        })
    }

    /// Sets each wall's speed along its outward normal (m/s; negative moves it in,
    /// towards the particles) and moves it by speed x dt, ahead of the next step's
    /// drift. `loads` (from [`World::wall_loads`] on the current state) price the work
    /// the walls do on the particles, which widens the energy guard's budget.
    ///
    /// While walls move, their near-lists reach `margin` further (set by
    /// [`World::set_wall_margin`]); a wall that has moved that far since the last
    /// rebuild triggers the next one. With no margin set, every move triggers one.
    pub fn move_walls(&mut self, rates: &[Real], loads: &[WallLoad]) -> Result<()> {
        if rates.len() != self.walls.len() || loads.len() != self.walls.len() {
            return Err(Error::invalid(
                "rates",
                format!("{} rates, {} loads", rates.len(), loads.len()),
                &format!("one per wall ({})", self.walls.len()),
            ));
        }
        let dt = self.cfg.dt;
        let mut travel: Real = 0.0;
        // the second half of the last move's work, at the force it led to
        for (wi, load) in loads.iter().enumerate() {
            self.wall_work -= 0.5 * load.force * self.wall_rate[wi] * dt;
        }
        for (wi, (&rate, load)) in rates.iter().zip(loads).enumerate() {
            if !rate.is_finite() {
                return Err(Error::invalid("rates", rate, "must be finite (m/s)"));
            }
            self.wall_rate[wi] = rate;
            if rate == 0.0 {
                continue;
            }
            let step = rate * dt;
            match &mut self.walls[wi] {
                Wall::Plane { pos, sign, .. } => *pos += *sign * step,
                Wall::Cylinder { radius, .. } => *radius += step,
            }
            travel = travel.max(step.abs());
            // The particles push the wall out with `force`: moving in, it does work
            // on them. Priced by the trapezoid rule over each move, the force before
            // it now and the force after it at the next call (see below): the force
            // at the start alone undercounts the work while the servo closes in.
            self.wall_work -= 0.5 * load.force * step;
        }
        if travel > 0.0 {
            self.wall_travel += travel;
            if self.wall_travel >= self.wall_margin {
                self.list_valid = false;
            }
            // The forces stay valid: as for the particles, the step's first half kick
            // takes those of the last evaluation, and the next evaluation, after the
            // drift, sees the wall where it has moved.
        }
        Ok(())
    }

    /// Sets every wall's speed to zero (they stay where they are).
    pub fn stop_walls(&mut self) {
        self.wall_rate.iter_mut().for_each(|r| *r = 0.0);
    }

    /// The extra reach of the walls' near-lists while they move (m).
    pub fn wall_margin(&self) -> Real {
        self.wall_margin
    }

    /// The extra reach of the walls' near-lists while they move (m, >= 0).
    pub fn set_wall_margin(&mut self, margin: Real) -> Result<()> {
        check_range("wall_margin", margin, 0.0, true, f64::INFINITY, false)?;
        self.wall_margin = margin;
        self.list_valid = false;
        Ok(())
    }

    /// Local non-viscous damping of the translational motion (-), in [0, 1): 0 (the
    /// default) is off. See `forces::local_damped`.
    pub fn set_local_damping(&mut self, alpha: Real) -> Result<()> {
        check_range("local_damping", alpha, 0.0, true, 1.0, false)?;
        self.local_damping = alpha;
        Ok(())
    }

    /// The wall contacts in force at the last evaluation, in particle order, then wall
    /// order: (particle, wall, overlap). Only walls whose bit is set in the particle's
    /// mask can touch it (see `forces::gather_one`).
    fn wall_contacts(&self) -> impl Iterator<Item = (usize, usize, Real)> + '_ {
        (0..self.len()).flat_map(move |q| {
            let mask = self.p.wall_mask[q];
            (0..self.walls.len()).filter_map(move |wi| {
                if mask & (1 << wi) == 0 {
                    return None;
                }
                let d = self.p.r[q] - self.walls[wi].gap(&self.p.x[q]);
                (d > 0.0).then_some((q, wi, d))
            })
        })
    }

    /// The load on each wall at the last force evaluation, summed over particles in
    /// index order.
    pub fn wall_loads(&self) -> Vec<WallLoad> {
        let mut loads = vec![WallLoad::default(); self.walls.len()];
        let kn = 2.0 * self.e_star;
        let xi = self.cfg.material.damping;
        for (q, wi, d) in self.wall_contacts() {
            let wall = &self.walls[wi];
            let n = wall.normal(&self.p.x[q]);
            let l = &mut loads[wi];
            l.force += self.p.wall_force[q * self.walls.len() + wi].dot(&n);
            let k = kn * (wall.r_eff(self.p.r[q]) * d).sqrt();
            l.stiffness += k;
            l.viscosity += 2.0 * xi * (self.p.m[q] * k).sqrt();
            l.contacts += 1;
        }
        loads
    }

    /// The balance of forces at the last force evaluation (see [`ForceBalance`]);
    /// sums in index order.
    pub fn force_balance(&self) -> ForceBalance {
        let mut fb = ForceBalance::default();
        let n = self.len();
        for f in &self.p.f {
            let a = f.norm();
            fb.mean_net += a;
            fb.max_net = fb.max_net.max(a);
        }
        if n > 0 {
            fb.mean_net /= n as Real;
        }
        let mut sum = 0.0;
        let pr = &self.pairs;
        for k in 0..pr.ij.len() {
            let rec = pr.get(k);
            if rec.d > 0.0 {
                sum += Vector::<D>::from(rec.f).norm();
                fb.contacts += 1;
            }
        }
        for (q, wi, _) in self.wall_contacts() {
            sum += self.p.wall_force[q * self.walls.len() + wi].norm();
            fb.contacts += 1;
        }
        if fb.contacts > 0 {
            fb.mean_contact = sum / fb.contacts as Real;
        }
        fb
    }

    /// Advances up to `n` steps in one scope of the step's team, calling `before`
    /// ahead of each step; it may change walls (not particles) and returns false to
    /// stop. Returns the steps taken.
    pub fn step_n_with(
        &mut self,
        n: u64,
        before: &mut (dyn FnMut(&mut Self) -> Result<bool> + Send),
    ) -> Result<u64> {
        self.check_dt()?;
        Team::scoped(|team| {
            for k in 0..n {
                if !before(self)? {
                    return Ok(k);
                }
                if self.is_empty() {
                    self.steps += 1;
                    self.time += self.cfg.dt;
                } else {
                    self.step_once(team)?;
                }
            }
            Ok(n)
        })
    }

    /// Computes the forces of the current state if they are not valid (after walls
    /// were moved or particles set), so that loads and balances read fresh values.
    pub fn refresh_forces(&mut self) -> Result<()> {
        if !self.list_valid {
            self.rebuild_pairs();
        }
        if !self.forces_valid && !self.is_empty() {
            self.compute_forces()?;
        }
        Ok(())
    }
}
