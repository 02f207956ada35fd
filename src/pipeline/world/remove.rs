//! Taking particles out of the world (the flat top of a trimmed pack).

use super::*;

/// Keeps the entries of `v` whose flag in `keep` is set, in order.
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
        // The pairs of two kept particles, renumbered, in (i, j) order with their state:
        // the next rebuild merges them with the new list as it does after any rebuild.
        let order = self.pairs.sorted_order();
        let survivors: Vec<u32> = order
            .into_iter()
            .filter(|&k| {
                let [i, j] = self.pairs.ij[k as usize];
                keep[i as usize] && keep[j as usize]
            })
            .collect();
        let old = std::mem::take(&mut self.pairs);
        let pairs = Pairs::<D> {
            ij: survivors
                .iter()
                .map(|&k| {
                    let [i, j] = old.ij[k as usize];
                    [new_index[i as usize], new_index[j as usize]]
                })
                .collect(),
            blocks: Pairs::<D>::build_blocks(survivors.len(), |k| old.get(survivors[k] as usize)),
            ..Pairs::default()
        };
        self.pairs = pairs;

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
        retain_by(&mut p.wall_hist, keep);
        retain_by(&mut p.wall_force, keep);
        retain_by(&mut p.frozen, keep);
        retain_by(&mut p.wall_mask, keep);
        retain_by(&mut p.wall_near, keep);
        self.forces_valid = false;
        self.list_valid = false;
        self.energy_ref = None;
        Ok(())
    }
}
