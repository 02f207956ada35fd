//! The contacts in force, for export: the engine's (with forces), and the geometric
//! contacts of a static pack given as arrays.

use super::*;

/// The contacts in force, in the column layout of `granpack.Contacts` (docs/microstructure.md).
#[derive(Clone, Debug, Default)]
pub struct Contacts<const D: usize> {
    /// First particle.
    pub i: Vec<i64>,
    /// Second particle, or a wall: -1 floor, -2 x = lo, -3 x = hi, -4 y = lo, -5 y = hi.
    pub j: Vec<i64>,
    /// Unit normal from i to j (to the wall).
    pub normal: Vec<Vector<D>>,
    /// Overlap r_i + r_j - |x_j - x_i| (m), > 0.
    pub overlap: Vec<Real>,
    /// Normal force magnitude (N) >= 0, pushing j away from i.
    pub force_normal: Vec<Real>,
    /// Tangential force on j (N), perpendicular to the normal.
    pub force_tangential: Vec<Vector<D>>,
    /// Branch vector from centre i to centre j, or to the contact point for walls (m).
    pub branch: Vec<Vector<D>>,
}

impl<const D: usize> Contacts<D> {
    /// Empty columns with room for `n` contacts (untouched memory until written).
    fn with_capacity(n: usize) -> Self {
        Contacts {
            i: Vec::with_capacity(n),
            j: Vec::with_capacity(n),
            normal: Vec::with_capacity(n),
            overlap: Vec::with_capacity(n),
            force_normal: Vec::with_capacity(n),
            force_tangential: Vec::with_capacity(n),
            branch: Vec::with_capacity(n),
        }
    }

    /// Number of contacts.
    pub fn len(&self) -> usize {
        self.i.len()
    }

    /// True when there is no contact.
    pub fn is_empty(&self) -> bool {
        self.i.is_empty()
    }

    /// Appends one contact; `fv` is the whole force on j (N), split here into its normal
    /// magnitude and tangential part.
    fn push(&mut self, i: i64, j: i64, n: Vector<D>, d: Real, fv: Vector<D>, branch: Vector<D>) {
        let fn_ = fv.dot(&n);
        self.i.push(i);
        self.j.push(j);
        self.normal.push(n);
        self.overlap.push(d);
        self.force_normal.push(fn_.max(0.0));
        self.force_tangential.push(fv - n * fn_);
        self.branch.push(branch);
    }

    /// Reverses the order of the contacts, in place.
    fn reverse(&mut self) {
        self.i.reverse();
        self.j.reverse();
        self.normal.reverse();
        self.overlap.reverse();
        self.force_normal.reverse();
        self.force_tangential.reverse();
        self.branch.reverse();
    }
}

/// The particle arrays of a world that has been spent (see [`World::into_finished`]).
#[derive(Clone, Debug)]
pub struct FinishedState<const D: usize>
where
    Dim<D>: Spatial<D>,
{
    /// Centres, wrapped into the periodic cell where there is one (m).
    pub positions: Vec<Vector<D>>,
    /// Velocities (m/s).
    pub velocities: Vec<Vector<D>>,
    /// Angular velocities (rad/s).
    pub spins: Vec<Ang<D>>,
    /// Radii (m).
    pub radii: Vec<Real>,
    /// Simulated time (s).
    pub time: Real,
}

/// Pairs between two frees of the list's tail in [`World::into_finished`]: 16 384
/// pairs (a whole number of blocks), 1.5 MB of pair state in 3D.
const FREE_EVERY: usize = 16384_usize.next_multiple_of(BLOCK);

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Appends the contact of pair `ij` with state `rec` (in force: overlap > 0).
    fn push_pair_contact(&self, out: &mut Contacts<D>, ij: [u32; 2], rec: &PairRecord<D>) {
        let [i, j] = ij;
        let mut dx = self.p.x[j as usize] - self.p.x[i as usize];
        if let Some(per) = &self.period {
            dx = per.image(dx);
        }
        // the engine's normal, to the bit (see `pair_block` and `geometry_block`)
        let n = dx * (1.0 / dx.norm());
        out.push(i as i64, j as i64, n, rec.d, Vector::<D>::from(rec.f), dx);
    }

    /// Overlap of particle q with wall `wi` (m); in contact when > 0.
    fn wall_overlap(&self, q: usize, wi: usize) -> Real {
        self.p.r[q] - self.walls[wi].gap(&self.p.x[q])
    }

    /// Appends the contact of particle q with wall `wi`, if it is in force.
    fn push_wall_contact(&self, out: &mut Contacts<D>, q: usize, wi: usize) {
        let d = self.wall_overlap(q, wi);
        if d <= 0.0 {
            return;
        }
        let n = self.walls[wi].normal(&self.p.x[q]);
        let fv = self.p.wall_force[q * self.walls.len() + wi];
        let branch = n * (self.p.r[q] - 0.5 * d);
        out.push(q as i64, -(wi as i64) - 1, n, d, fv, branch);
    }

    /// Brings the pair list and the forces up to date for the contacts.
    fn contacts_ready(&mut self) -> Result<()> {
        if !self.list_valid {
            self.rebuild_pairs();
        }
        if !self.forces_valid && !self.is_empty() {
            self.compute_forces()?;
        }
        Ok(())
    }

    /// The contacts in force at the last force evaluation (overlap > 0), pairs first in
    /// (i, j) order, then wall contacts by particle and wall.
    pub fn contacts(&mut self) -> Result<Contacts<D>> {
        self.contacts_ready()?;
        let mut out = Contacts::<D>::default();
        let pr = &self.pairs;
        for k in pr.sorted_order() {
            let k = k as usize;
            let rec = pr.get(k);
            if rec.d > 0.0 {
                self.push_pair_contact(&mut out, pr.ij[k], &rec);
            }
        }
        for q in 0..self.len() {
            for wi in 0..self.walls.len() {
                self.push_wall_contact(&mut out, q, wi);
            }
        }
        Ok(out)
    }

    /// The contacts in force, the same as [`World::contacts`] to the bit, and the
    /// particle arrays, with the world spent to make them: the pair list is freed from
    /// its end while the contacts are written, so the contact table never sits beside
    /// the whole pair state (at a million spheres each is about 270 bytes a particle,
    /// and together they set the peak of a pack's generation). The particle arrays
    /// move out without a copy; everything else is dropped.
    pub fn into_finished(self) -> Result<(Contacts<D>, FinishedState<D>)> {
        self.into_finished_freeing(FREE_EVERY)
    }

    /// [`World::into_finished`], freeing the list's tail every `every` pairs (a
    /// multiple of `BLOCK`; the tests free it at every block).
    pub(super) fn into_finished_freeing(
        mut self,
        every: usize,
    ) -> Result<(Contacts<D>, FinishedState<D>)> {
        debug_assert!(every > 0 && every.is_multiple_of(BLOCK));
        self.contacts_ready()?;
        let mut pr = std::mem::take(&mut self.pairs);
        pr.drop_incidence();
        pr.merge_runs();
        let (n, nw, m) = (self.len(), self.walls.len(), pr.ij.len());
        let in_pairs = (0..m).filter(|&k| pr.get(k).d > 0.0).count();
        let on_walls = (0..n * nw)
            .filter(|&e| self.wall_overlap(e / nw, e % nw) > 0.0)
            .count();
        let mut out = Contacts::<D>::with_capacity(in_pairs + on_walls);
        // Written last to first and reversed at the end, so that the pair state behind
        // the contacts written so far can go.
        for q in (0..n).rev() {
            for wi in (0..nw).rev() {
                self.push_wall_contact(&mut out, q, wi);
            }
        }
        for k in (0..m).rev() {
            let rec = pr.get(k);
            if rec.d > 0.0 {
                self.push_pair_contact(&mut out, pr.ij[k], &rec);
            }
            if k.is_multiple_of(every) {
                // Shrinking a large allocation hands its tail back to the system
                // (glibc's realloc of a mapped chunk is an mremap, in place).
                pr.blocks.truncate(k >> BLOCK_SHIFT);
                pr.blocks.shrink_to_fit();
                pr.roll.truncate(k >> BLOCK_SHIFT);
                pr.roll.shrink_to_fit();
                pr.ij.truncate(k);
                pr.ij.shrink_to_fit();
            }
        }
        drop(pr);
        debug_assert_eq!(out.len(), in_pairs + on_walls);
        out.reverse();
        let positions = match &self.period {
            Some(per) => {
                let mut x = std::mem::take(&mut self.p.x);
                x.iter_mut().for_each(|x| *x = per.wrap(*x));
                x
            }
            None => std::mem::take(&mut self.p.x),
        };
        let state = FinishedState {
            positions,
            velocities: std::mem::take(&mut self.p.v),
            spins: std::mem::take(&mut self.p.w),
            radii: std::mem::take(&mut self.p.r),
            time: self.time,
        };
        Ok((out, state))
    }
}

/// The geometric contacts (overlap > 0, forces zero) of a static pack given by
/// positions and radii: pairs from the grid in (i, j) order, then the walls of the box
/// `bounds` (lo, hi) if given. Coincident centres are refused.
///
/// `periodic[k]` makes horizontal axis k periodic with period hi[k] - lo[k] (pairs by
/// minimum image, branch vectors too; no walls on that axis; each period must exceed
/// twice the largest diameter, checked by the caller). `cylinder` replaces the side
/// walls by a vertical cylinder of that radius with its axis through lo + (R, R)
/// (wall -2). Wall ids follow the box: -1 floor, -2/-3 the first horizontal axis,
/// -4/-5 the second.
pub fn geometric_contacts<const D: usize>(
    x: &[Vector<D>],
    r: &[Real],
    bounds: Option<(Vector<D>, Vector<D>)>,
    periodic: &[bool],
    cylinder: Option<Real>,
) -> Result<Contacts<D>> {
    let mut c = Contacts::<D>::default();
    let period = match (&bounds, periodic.iter().any(|&p| p)) {
        (Some((lo, hi)), true) => Some(Period::new(lo, hi, periodic)),
        _ => None,
    };
    let pairs = match &period {
        Some(per) => {
            let xw: Vec<Vector<D>> = x.iter().map(|p| per.wrap(*p)).collect();
            crate::geometry::neighbor_pairs_periodic(&xw, r, Some(per))
        }
        None => crate::geometry::neighbor_pairs(x, r),
    };
    for [i, j] in pairs {
        let (i, j) = (i as usize, j as usize);
        let dx = match &period {
            Some(per) => per.image(x[j] - x[i]),
            None => x[j] - x[i],
        };
        let dist = dx.norm();
        // coincident centres have no normal
        if dist == 0.0 {
            return Err(Error::invalid(
                "positions",
                format!("particles {i} and {j} at {:?}", x[i].as_slice()),
                "centres coincide: not a valid pack",
            ));
        }
        c.i.push(i as i64);
        c.j.push(j as i64);
        c.normal.push(dx / dist);
        c.overlap.push(r[i] + r[j] - dist);
        c.force_normal.push(0.0);
        c.force_tangential.push(Vector::<D>::zeros());
        c.branch.push(dx);
    }
    if let Some((lo, hi)) = bounds {
        let container = match cylinder {
            Some(radius) => Container::Cylinder(radius),
            None => Container::Box,
        };
        let (walls, _) = container_walls(container, &lo, &hi);
        for q in 0..x.len() {
            for (w, wall) in walls.iter().enumerate() {
                if let Wall::Plane { axis, .. } = wall {
                    if *axis + 1 < D && periodic.get(*axis).copied().unwrap_or(false) {
                        continue;
                    }
                }
                let d = r[q] - wall.gap(&x[q]);
                if d > 0.0 {
                    let n = wall.normal(&x[q]);
                    c.i.push(q as i64);
                    c.j.push(-(w as i64) - 1);
                    c.normal.push(n);
                    c.overlap.push(d);
                    c.force_normal.push(0.0);
                    c.force_tangential.push(Vector::<D>::zeros());
                    c.branch.push(n * (r[q] - 0.5 * d));
                }
            }
        }
    }
    Ok(c)
}
