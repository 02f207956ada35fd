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

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// The contacts in force at the last force evaluation (overlap > 0), pairs first in
    /// (i, j) order, then wall contacts by particle and wall.
    pub fn contacts(&mut self) -> Result<Contacts<D>> {
        if !self.list_valid {
            self.rebuild_pairs();
        }
        if !self.forces_valid && !self.is_empty() {
            self.compute_forces()?;
        }
        let mut out = Contacts::<D>::default();
        let pr = &self.pairs;
        for k in pr.sorted_order() {
            let k = k as usize;
            let rec = pr.get(k);
            if rec.d <= 0.0 {
                continue;
            }
            let [i, j] = pr.ij[k];
            let mut dx = self.p.x[j as usize] - self.p.x[i as usize];
            if let Some(per) = &self.period {
                dx = per.image(dx);
            }
            // the engine's normal, to the bit (see `pair_block` and `geometry_block`)
            let n = dx * (1.0 / dx.norm());
            let fv = Vector::<D>::from(rec.f);
            let fn_ = fv.dot(&n);
            out.i.push(i as i64);
            out.j.push(j as i64);
            out.normal.push(n);
            out.overlap.push(rec.d);
            out.force_normal.push(fn_.max(0.0));
            out.force_tangential.push(fv - n * fn_);
            out.branch.push(dx);
        }
        for q in 0..self.len() {
            for (wi, wall) in self.walls.iter().enumerate() {
                let s = wall.gap(&self.p.x[q]);
                let d = self.p.r[q] - s;
                if d <= 0.0 {
                    continue;
                }
                let n = wall.normal(&self.p.x[q]);
                let fv = self.p.wall_force[q * self.walls.len() + wi];
                let fn_ = fv.dot(&n);
                out.i.push(q as i64);
                out.j.push(-(wi as i64) - 1);
                out.normal.push(n);
                out.overlap.push(d);
                out.force_normal.push(fn_.max(0.0));
                out.force_tangential.push(fv - n * fn_);
                out.branch.push(n * (self.p.r[q] - 0.5 * d));
            }
        }
        Ok(out)
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
