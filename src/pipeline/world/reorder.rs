//! Storing the particles in another order: a pack re-sorted into one row-major order of
//! cells when its layers are too large for the caches (see `Packer`).

use super::*;

/// Reorders `v` in place in runs of `stride` entries a particle: run k takes the old
/// run `order[k]`. Each cycle of the permutation is followed once, holding one run
/// aside (as `Pairs::permute` does), so the array is never copied whole; `done` is a
/// bit a particle, cleared here.
fn permute_runs<T: Copy>(v: &mut [T], order: &[usize], stride: usize, done: &mut [u64]) {
    if stride == 0 || v.is_empty() {
        return;
    }
    debug_assert_eq!(v.len(), order.len() * stride);
    done.fill(0);
    let mut held = v[..stride].to_vec();
    for s in 0..order.len() {
        if done[s / 64] >> (s % 64) & 1 == 1 || order[s] == s {
            continue;
        }
        held.copy_from_slice(&v[s * stride..(s + 1) * stride]);
        let mut k = s;
        loop {
            done[k / 64] |= 1 << (k % 64);
            let o = order[k];
            if o == s {
                v[k * stride..(k + 1) * stride].copy_from_slice(&held);
                break;
            }
            v.copy_within(o * stride..(o + 1) * stride, k * stride);
            k = o;
        }
    }
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Stores the particles in a new order: particle k takes the state of the old
    /// particle `order[k]` (`order` must hold each of `0..len()` once). Every particle
    /// keeps its state (position, velocity, spin, force, wall history, frozen flag) and
    /// every pair its tangential history: a pair whose ends swap order has its stretch
    /// and its force turned round, since both are stored for the second end. Nothing is
    /// evaluated again, so the run goes on as it would have, except that each
    /// particle's forces are summed in the order of its new partners' indices (the
    /// last bits of the sums).
    ///
    /// The step reads each particle's pairs where its first particle stores them, so a
    /// pack stored layer by layer reads a sphere's contacts with the layer below a
    /// whole layer's state away: the layer loop re-sorts large packs into one
    /// row-major order of cells with this.
    pub fn reorder(&mut self, order: &[usize]) -> Result<()> {
        let n = self.len();
        if order.len() != n {
            return Err(Error::invalid(
                "order",
                format!("length {}", order.len()),
                &format!("must have one entry per particle ({n})"),
            ));
        }
        let mut new_index = vec![u32::MAX; n];
        for (k, &o) in order.iter().enumerate() {
            if o >= n || new_index[o] != u32::MAX {
                return Err(Error::invalid(
                    &format!("order[{k}]"),
                    o,
                    &format!("must be a permutation of 0..{n}: each index once"),
                ));
            }
            new_index[o] = k as u32;
        }
        // The pairs renumbered as one run in (i, j) order, in place (see
        // `Pairs::permute`); the partition into the frozen and the active run, and the
        // incidence lists, are made again below.
        let pr = &mut self.pairs;
        pr.merge_runs();
        for k in 0..pr.ij.len() {
            let [i, j] = pr.ij[k];
            let (a, b) = (new_index[i as usize], new_index[j as usize]);
            if a < b {
                pr.ij[k] = [a, b];
            } else {
                // The stretch and the force are those of the second end: turned round.
                pr.ij[k] = [b, a];
                let mut rec = pr.get(k);
                for c in 0..D {
                    rec.h[c] = -rec.h[c];
                    rec.f[c] = -rec.f[c];
                }
                pr.set(k, &rec);
            }
        }
        drop(new_index);
        let mut sorted: Vec<u32> = (0..pr.ij.len() as u32).collect();
        let ij = &pr.ij;
        sorted.par_sort_unstable_by_key(|&k| ij[k as usize]);
        pr.permute(&sorted);
        drop(sorted);

        // The particle arrays in place, one after the other: at a million spheres a
        // copy of the positions alone is 24 MB.
        let mut done = vec![0u64; n.div_ceil(64)];
        let p = &mut self.p;
        permute_runs(&mut p.x, order, 1, &mut done);
        permute_runs(&mut p.v, order, 1, &mut done);
        permute_runs(&mut p.f, order, 1, &mut done);
        permute_runs(&mut p.w, order, 1, &mut done);
        permute_runs(&mut p.t, order, 1, &mut done);
        permute_runs(&mut p.r, order, 1, &mut done);
        permute_runs(&mut p.m, order, 1, &mut done);
        permute_runs(&mut p.inv_m, order, 1, &mut done);
        permute_runs(&mut p.inv_i, order, 1, &mut done);
        permute_runs(&mut p.x_ref, order, 1, &mut done);
        permute_runs(&mut p.half_skin, order, 1, &mut done);
        permute_runs(&mut p.wall_hist, order, self.walls.len(), &mut done);
        if !p.wall_roll.is_empty() {
            permute_runs(&mut p.wall_roll, order, self.walls.len(), &mut done);
        }
        permute_runs(&mut p.wall_force, order, self.walls.len(), &mut done);
        permute_runs(&mut p.frozen, order, 1, &mut done);
        permute_runs(&mut p.wall_mask, order, 1, &mut done);
        permute_runs(&mut p.wall_near, order, 1, &mut done);
        drop(done);
        // Both runs again (in (i, j) order) and the incidence lists the gather reads.
        self.partition_pairs();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::seq::SliceRandom;
    use rand::SeedableRng;

    /// 400 spheres settling in a box under gravity, some of it frozen when `freeze`.
    fn settling_world(freeze: bool) -> World<3> {
        let mut c = SimConfig::<3>::paper();
        c.drag = 0.005;
        c.walls = Some((Vector::<3>::zeros(), Vector::<3>::new(0.2, 0.2, 10.0)));
        let mut w = World::new(c).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let r = 0.01;
        let mut x: Vec<Vector<3>> = Vec::new();
        'place: while x.len() < 400 {
            use rand::Rng;
            let p = Vector::<3>::new(
                rng.random_range(r..0.2 - r),
                rng.random_range(r..0.2 - r),
                rng.random_range(r..0.3),
            );
            for q in &x {
                if (p - q).norm() < 2.0 * r {
                    continue 'place;
                }
            }
            x.push(p);
        }
        let radii = vec![r; x.len()];
        w.add_particles(&x, &radii, None, None).unwrap();
        if freeze {
            w.set_freeze(Some(FreezeConfig {
                below: 0.06,
                speed: 0.05,
                force_ratio: 10.0,
                interval: 50,
            }))
            .unwrap();
        }
        w.step_n(6000).unwrap();
        w
    }

    /// A random permutation of the particles changes nothing but the order of each
    /// particle's sums: 200 steps later every particle is where its twin in the
    /// unpermuted world is, to round-off (1e-9 m against a motion of centimetres),
    /// with the same frozen flags, and the contacts carry the same tangential forces.
    #[test]
    fn a_permuted_world_moves_as_the_original() {
        for freeze in [false, true] {
            let mut a = settling_world(freeze);
            let mut b = a.clone();
            let mut order: Vec<usize> = (0..a.len()).collect();
            order.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(3));
            b.reorder(&order).unwrap();
            if freeze {
                assert!(a.n_frozen() > 10, "{} frozen", a.n_frozen());
                assert_eq!(a.n_frozen(), b.n_frozen());
            }
            a.step_n(200).unwrap();
            b.step_n(200).unwrap();
            let (xa, xb) = (a.positions(), b.positions());
            for (k, &o) in order.iter().enumerate() {
                assert!((xb[k] - xa[o]).norm() < 1e-9, "{:?} {:?}", xb[k], xa[o]);
                assert_eq!(b.frozen()[k], a.frozen()[o]);
            }
            let (ca, cb) = (a.contacts().unwrap(), b.contacts().unwrap());
            assert!(ca.len() > 100, "{} contacts", ca.len());
            assert_eq!(ca.len(), cb.len());
            let mut inv = vec![0; order.len()];
            for (k, &o) in order.iter().enumerate() {
                inv[o] = k;
            }
            // Contact c of a, found in b by its ends (in either order); a wall (j < 0)
            // stays the second end.
            let key = |i: i64, j: i64| if j < 0 { [i, j] } else { [i.min(j), i.max(j)] };
            let index: std::collections::HashMap<[i64; 2], usize> =
                (0..cb.len()).map(|c| (key(cb.i[c], cb.j[c]), c)).collect();
            let renumber = |q: i64| if q < 0 { q } else { inv[q as usize] as i64 };
            let (mut swapped, mut pairs) = (0, 0);
            for c in 0..ca.len() {
                let (i, j) = (renumber(ca.i[c]), renumber(ca.j[c]));
                let d = index[&key(i, j)];
                // The force on j: opposite when the ends are stored the other way round.
                let sign = if cb.i[d] == i { 1.0 } else { -1.0 };
                swapped += (sign < 0.0) as usize;
                pairs += (j >= 0) as usize;
                let (fa, fb) = (ca.force_tangential[c], sign * cb.force_tangential[d]);
                assert!(
                    (fa - fb).norm() <= 1e-6 * fa.norm() + 1e-12,
                    "{fa:?} {fb:?}"
                );
            }
            assert!(swapped > pairs / 4, "{swapped} of {pairs} swapped");
        }
    }

    /// The permutation in place gives what gathering through the order gives, for runs
    /// of one entry and of several (the wall state of a box: one run a particle).
    #[test]
    fn permutation_in_place_equals_a_gather() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for (n, stride) in [(1, 1), (7, 1), (300, 1), (300, 5), (1000, 3)] {
            let mut order: Vec<usize> = (0..n).collect();
            order.shuffle(&mut rng);
            let v: Vec<u32> = (0..(n * stride) as u32).collect();
            let gathered: Vec<u32> = order
                .iter()
                .flat_map(|&o| v[o * stride..(o + 1) * stride].iter().copied())
                .collect();
            let mut w = v.clone();
            let mut done = vec![u64::MAX; n.div_ceil(64)];
            permute_runs(&mut w, &order, stride, &mut done);
            assert_eq!(w, gathered, "n {n} stride {stride}");
        }
    }

    /// Anything but a permutation of the particles is refused by name.
    #[test]
    fn an_order_that_is_no_permutation_is_refused_by_name() {
        let mut w = settling_world(false);
        let n = w.len();
        let short: Vec<usize> = (0..n - 1).collect();
        let mut twice: Vec<usize> = (0..n).collect();
        twice[5] = 4;
        let mut past: Vec<usize> = (0..n).collect();
        past[0] = n;
        for bad in [short, twice, past] {
            let err = w.reorder(&bad).unwrap_err().to_string();
            assert!(err.contains("order"), "{err}");
        }
    }
}
