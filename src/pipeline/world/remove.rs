//! Taking particles out of the world (the flat top of a trimmed pack).

use super::*;

/// Keeps the runs of `stride` entries whose flag in `keep` is set (a per-particle
/// array with `stride` entries a particle).
fn retain_runs<T: Copy>(v: &mut Vec<T>, keep: &[bool], stride: usize) {
    let mut out = 0;
    for (q, &k) in keep.iter().enumerate() {
        if k {
            v.copy_within(q * stride..(q + 1) * stride, out * stride);
            out += 1;
        }
    }
    v.truncate(out * stride);
}

fn retain_by<T>(v: &mut Vec<T>, keep: &[bool]) {
    let mut k = 0;
    v.retain(|_| {
        k += 1;
        keep[k - 1]
    });
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Removes the particles whose flag in `keep` is false. The others keep their
    /// order (their indices shift down) and their state; the pairs between two kept
    /// particles keep their tangential history, so a contact of the rest is not
    /// disturbed. Unfreezes every particle first (the frozen run is rebuilt anyway).
    pub fn remove_particles(&mut self, keep: &[bool]) -> Result<()> {
        let n = self.len();
        if keep.len() != n {
            return Err(Error::invalid(
                "keep",
                format!("length {}", keep.len()),
                &format!("must have one flag per particle ({n})"),
            ));
        }
        if keep.iter().all(|&k| k) {
            return Ok(());
        }
        self.set_freeze(None)?;
        // New index of each kept particle (old order, so (i, j) order is kept too).
        let mut new_index = vec![u32::MAX; n];
        for (next, (slot, _)) in new_index
            .iter_mut()
            .zip(keep)
            .filter(|(_, &k)| k)
            .enumerate()
        {
            *slot = next as u32;
        }
        // The pairs of two kept particles, renumbered, in (i, j) order with their state,
        // in place (a list built beside this one held two copies of the pair state at
        // once): the next rebuild merges them with the new list as after any rebuild.
        let pr = &mut self.pairs;
        pr.merge_runs();
        pr.retain_in_place(|[i, j]| {
            let (a, b) = (new_index[i as usize], new_index[j as usize]);
            (a != u32::MAX && b != u32::MAX).then_some([a, b])
        });

        let p = &mut self.p;
        retain_by(&mut p.x, keep);
        retain_by(&mut p.v, keep);
        retain_by(&mut p.f, keep);
        retain_by(&mut p.w, keep);
        retain_by(&mut p.t, keep);
        retain_by(&mut p.r, keep);
        retain_by(&mut p.m, keep);
        retain_by(&mut p.inv_m, keep);
        retain_by(&mut p.inv_i, keep);
        retain_by(&mut p.x_ref, keep);
        retain_by(&mut p.half_skin, keep);
        retain_runs(&mut p.wall_hist, keep, self.walls.len());
        if !p.wall_roll.is_empty() {
            retain_runs(&mut p.wall_roll, keep, self.walls.len());
        }
        retain_runs(&mut p.wall_force, keep, self.walls.len());
        retain_by(&mut p.frozen, keep);
        retain_by(&mut p.wall_mask, keep);
        retain_by(&mut p.wall_near, keep);
        self.forces_valid = false;
        self.list_valid = false;
        self.energy_ref = None;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pair in contact whose tangential spring builds up (slowly enough to stay below
    /// the Coulomb cap, so that the force tells the history) and, with `with_far`, a
    /// particle far away that touches nothing.
    fn world(with_far: bool) -> World<3> {
        let mut c = SimConfig::<3>::paper();
        c.gravity = Vector::<3>::zeros();
        c.dt = 1e-6;
        let mut w = World::new(c).unwrap();
        let r = 0.01;
        let mut x = vec![
            Vector::<3>::new(0.0, 0.0, 0.0),
            Vector::<3>::new(2.0 * r - 1e-5, 0.0, 0.0),
        ];
        let mut v = vec![
            Vector::<3>::new(0.01, 0.000_25, 0.0),
            Vector::<3>::new(-0.01, -0.000_25, 0.0),
        ];
        if with_far {
            x.insert(0, Vector::<3>::new(1.0, 1.0, 1.0));
            v.insert(0, Vector::<3>::zeros());
        }
        let radii = vec![r; x.len()];
        w.add_particles(&x, &radii, Some(&v), None).unwrap();
        w
    }

    /// Removing a particle that touches nothing leaves the others' motion as it would
    /// have been: the pair keeps its tangential history. Not bit for bit: the forces
    /// are evaluated once more after the removal, as after any change of the state (a
    /// new layer too), and that evaluation advances the tangential spring by one more
    /// step: 200 steps later the force differs by 6e-4 of itself, where a lost history
    /// would have halved it.
    #[test]
    fn removal_keeps_the_survivors_history() {
        let mut a = world(true);
        let mut b = world(false);
        a.step_n(200).unwrap();
        b.step_n(200).unwrap();
        a.remove_particles(&[false, true, true]).unwrap();
        assert_eq!(a.len(), 2);
        a.step_n(200).unwrap();
        b.step_n(200).unwrap();
        for (xa, xb) in a.positions().iter().zip(b.positions()) {
            assert!((xa - xb).norm() < 1e-9, "{xa:?} {xb:?}");
        }
        let (ca, cb) = (a.contacts().unwrap(), b.contacts().unwrap());
        let (fa, fb) = (ca.force_tangential[0], cb.force_tangential[0]);
        assert!(
            fb.norm() > 0.0 && (fa - fb).norm() < 1e-2 * fb.norm(),
            "{fa:?} {fb:?}"
        );
        assert!(a.remove_particles(&[true]).is_err());
    }
}
