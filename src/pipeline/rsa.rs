//! Random sequential addition of one layer.
//!
//! Candidate centres are uniform in the slab [height, height + h_layer] (and at least
//! one radius inside every wall); a candidate is kept when it overlaps nothing placed
//! before, old or new. Overlap tests go through a cell grid that grows as particles
//! are accepted, so a layer costs O(attempts), not O(N^2).

use crate::error::{Error, Result};
use crate::geometry::Period;
use crate::math::{particle_volume, Real, Vector};
use crate::scene::Container;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

pub use crate::scene::RadiusLaw;

/// A growable cell grid over a slab, for overlap tests during insertion. On periodic
/// axes the grid divides the period into whole cells and wraps around.
struct InsertGrid<const D: usize> {
    lo: Vector<D>,
    cell: [Real; D],
    dims: [usize; D],
    period: Option<Period<D>>,
    cells: Vec<Vec<u32>>,
}

impl<const D: usize> InsertGrid<D> {
    fn new(lo: Vector<D>, hi: Vector<D>, cell: Real, period: Option<Period<D>>) -> Self {
        let mut dims = [1usize; D];
        let mut cells = [cell; D];
        for k in 0..D {
            if period.is_some_and(|p| p.periodic(k)) {
                dims[k] = (((hi[k] - lo[k]) / cell).floor() as usize).max(1);
                cells[k] = (hi[k] - lo[k]) / dims[k] as Real;
            } else {
                dims[k] = (((hi[k] - lo[k]) / cell).floor() as usize) + 1;
            }
        }
        let n: usize = dims.iter().product();
        InsertGrid {
            lo,
            cell: cells,
            dims,
            period,
            cells: vec![Vec::new(); n],
        }
    }

    fn coord(&self, p: &Vector<D>, k: usize) -> isize {
        ((p[k] - self.lo[k]) / self.cell[k]).floor() as isize
    }

    fn wraps(&self, k: usize) -> bool {
        self.period.is_some_and(|p| p.periodic(k))
    }

    fn insert(&mut self, p: &Vector<D>, id: u32) {
        let mut c = 0usize;
        for k in (0..D).rev() {
            let ik = self.coord(p, k).clamp(0, self.dims[k] as isize - 1) as usize;
            c = c * self.dims[k] + ik;
        }
        self.cells[c].push(id);
    }

    /// True if a ball (p, r) overlaps any stored particle (by minimum image on the
    /// periodic axes).
    fn overlaps(&self, p: &Vector<D>, r: Real, r_max: Real, x: &[Vector<D>], rad: &[Real]) -> bool {
        let reach = r + r_max;
        let mut lo = [0isize; D];
        let mut hi = [0isize; D];
        for k in 0..D {
            let a = ((p[k] - reach - self.lo[k]) / self.cell[k]).floor() as isize;
            let b = ((p[k] + reach - self.lo[k]) / self.cell[k]).floor() as isize;
            let d = self.dims[k] as isize;
            if self.wraps(k) {
                // every cell once, however far the reach spans
                (lo[k], hi[k]) = (a, b.min(a + d - 1));
            } else {
                (lo[k], hi[k]) = (a.clamp(0, d - 1), b.clamp(0, d - 1));
            }
        }
        let mut idx = lo;
        loop {
            let mut c = 0usize;
            for k in (0..D).rev() {
                let ik = if self.wraps(k) {
                    idx[k].rem_euclid(self.dims[k] as isize)
                } else {
                    idx[k]
                };
                c = c * self.dims[k] + ik as usize;
            }
            for &j in &self.cells[c] {
                let j = j as usize;
                let cut = r + rad[j];
                let d = match &self.period {
                    Some(per) => per.image(x[j] - p),
                    None => x[j] - p,
                };
                if d.norm_squared() < cut * cut {
                    return true;
                }
            }
            let mut k = 0;
            loop {
                if k == D {
                    return false;
                }
                if idx[k] < hi[k] {
                    idx[k] += 1;
                    break;
                }
                idx[k] = lo[k];
                k += 1;
            }
        }
    }
}

/// Inputs of one RSA layer.
pub struct LayerSpec<'a, const D: usize> {
    /// The container: centres are placed one radius inside its walls, and uniformly
    /// over its cross-section (in area for the cylinder); periodic axes have no walls
    /// and overlaps are tested across the seam.
    pub container: Container,
    /// Box lower corner (m); floor at `lo[vertical]`.
    pub lo: Vector<D>,
    /// Box upper corner (m); `hi[vertical]` unused.
    pub hi: Vector<D>,
    /// Vertical axis index.
    pub vertical: usize,
    /// Bottom of the slab (m): the current pack height.
    pub height: Real,
    /// Slab thickness (m).
    pub h_layer: Real,
    /// Target solid fraction of the slab (-).
    pub phi_layer: Real,
    /// Radius law.
    pub radii: RadiusLaw,
    /// Most consecutive failed placements before declaring saturation.
    pub max_attempts: u64,
    /// Particles already in the box (positions, radii).
    pub existing: (&'a [Vector<D>], &'a [Real]),
    /// Layer index, for messages.
    pub layer: usize,
}

/// Places one layer; returns the new centres and radii.
pub fn place_layer<const D: usize>(
    spec: &LayerSpec<'_, D>,
    rng: &mut ChaCha8Rng,
) -> Result<(Vec<Vector<D>>, Vec<Real>)> {
    Ok(place_layer_polled(spec, rng, &mut || true)?.expect("a poll that never stops"))
}

/// Failed placements between two calls of the poll of [`place_layer_polled`].
const POLL_ATTEMPTS: u64 = 1 << 14;

/// [`place_layer`], calling `poll` every few thousand failed placements (a layer near
/// saturation may try `max_attempts` times); None when `poll` returns false. The poll
/// draws no random numbers: the layer does not depend on it.
pub fn place_layer_polled<const D: usize>(
    spec: &LayerSpec<'_, D>,
    rng: &mut ChaCha8Rng,
    poll: &mut dyn FnMut() -> bool,
) -> Result<Option<(Vec<Vector<D>>, Vec<Real>)>> {
    let v = spec.vertical;
    let r_max = spec.radii.r_max();
    let mut slab_volume = spec.h_layer;
    for k in (0..D).filter(|&k| k != v) {
        let width = spec.hi[k] - spec.lo[k];
        if width < 2.0 * r_max {
            return Err(Error::invalid(
                "base",
                width,
                &format!(
                    "must be at least one particle diameter 2 r_max = {} (m)",
                    2.0 * r_max
                ),
            ));
        }
        slab_volume *= width;
    }
    let cylinder = match spec.container {
        Container::Cylinder(radius) => {
            if D != 3 {
                return Err(Error::invalid(
                    "container",
                    "cylinder",
                    "needs 3 dimensions",
                ));
            }
            slab_volume = std::f64::consts::PI * radius * radius * spec.h_layer;
            Some(([spec.lo[0] + radius, spec.lo[1] + radius], radius))
        }
        _ => None,
    };
    let period = match spec.container {
        Container::Periodic => Some(Period::lateral(&spec.lo, &spec.hi)),
        _ => None,
    };
    let target = spec.phi_layer * slab_volume;
    let z_lo = spec.height;
    let z_hi = spec.height + spec.h_layer;

    let mut glo = spec.lo;
    let mut ghi = spec.hi;
    glo[v] = spec.height - 2.0 * r_max;
    ghi[v] = z_hi + r_max;
    let mut grid = InsertGrid::<D>::new(glo, ghi, 2.0 * r_max, period);
    let (ex, er) = spec.existing;
    let mut x: Vec<Vector<D>> = Vec::new();
    let mut r: Vec<Real> = Vec::new();
    // Old particles near the slab, then new ones, in one index space: old ids first.
    let mut all_x: Vec<Vector<D>> = Vec::new();
    let mut all_r: Vec<Real> = Vec::new();
    for (p, &rp) in ex.iter().zip(er) {
        if p[v] + rp + r_max > spec.height - r_max {
            grid.insert(p, all_x.len() as u32);
            all_x.push(*p);
            all_r.push(rp);
        }
    }
    let mut volume = 0.0;
    // Wide laws draw the layer's radii first, until their volume reaches the target,
    // and place them largest first: a large particle drawn late would find no hole
    // among the small ones. The radii are the same i.i.d. draws with the same
    // stopping rule; constant and gaussian keep the paper's order (draw, place, repeat).
    let largest_first = spec.radii.places_largest_first();
    let mut queue: Vec<Real> = Vec::new();
    if largest_first {
        let mut drawn = 0.0;
        while drawn < target {
            let rad = spec.radii.sample(rng);
            drawn += particle_volume::<D>(rad);
            queue.push(rad);
        }
        queue.sort_by(|a, b| a.total_cmp(b));
    }
    loop {
        let rad = if largest_first {
            match queue.pop() {
                Some(rad) => rad,
                None => break,
            }
        } else if volume < target {
            spec.radii.sample(rng)
        } else {
            break;
        };
        let z_min = z_lo.max(spec.lo[v] + rad);
        let mut failures = 0u64;
        loop {
            let mut c = Vector::<D>::zeros();
            for k in 0..D {
                let (a, b) = if k == v {
                    (z_min, z_hi.max(z_min))
                } else if period.is_some() {
                    (spec.lo[k], spec.hi[k])
                } else {
                    (spec.lo[k] + rad, spec.hi[k] - rad)
                };
                c[k] = a + (b - a) * rng.random::<f64>();
            }
            if let Some(per) = &period {
                // the draw's upper end, lo + L, belongs to the next cell
                c = per.wrap(c);
            }
            // In the cylinder the draw from the square [c - (R - r), c + (R - r)] is
            // kept only inside the disc of radius R - r: uniform in area.
            let outside = cylinder.is_some_and(|(axis, radius)| {
                let (a, b) = (c[0] - axis[0], c[1] - axis[1]);
                let reach = radius - rad;
                a * a + b * b > reach * reach
            });
            if outside {
                // not a failed placement: the draw was outside the cross-section
                // (accepted with probability pi/4 or more)
                continue;
            }
            if !grid.overlaps(&c, rad, r_max, &all_x, &all_r) {
                grid.insert(&c, all_x.len() as u32);
                all_x.push(c);
                all_r.push(rad);
                x.push(c);
                r.push(rad);
                volume += particle_volume::<D>(rad);
                break;
            }
            failures += 1;
            if failures.is_multiple_of(POLL_ATTEMPTS) && !poll() {
                return Ok(None);
            }
            if failures >= spec.max_attempts {
                return Err(Error::RsaSaturated {
                    layer: spec.layer,
                    reached: volume / slab_volume,
                    target: spec.phi_layer,
                    attempts: failures,
                });
            }
        }
    }
    Ok(Some((x, r)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::brute_force_pairs;
    use rand::SeedableRng;

    #[test]
    fn truncated_gaussian_stays_in_bounds_and_keeps_its_mean() {
        let law = RadiusLaw::Gaussian {
            mean: 0.01,
            std: 0.001,
            min: 0.007,
            max: 0.013,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 20_000;
        let s: Vec<f64> = (0..n).map(|_| law.sample(&mut rng)).collect();
        assert!(s.iter().all(|&r| (0.007..=0.013).contains(&r)));
        let mean = s.iter().sum::<f64>() / n as f64;
        // symmetric truncation keeps the mean; sd of the mean ~ 0.001/sqrt(n) = 7e-6
        assert!((mean - 0.01).abs() < 3e-5, "{mean}");
    }

    #[test]
    fn a_layer_has_no_overlaps_and_reaches_its_fraction() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let spec = LayerSpec::<2> {
            container: Container::Box,
            lo: Vector::<2>::zeros(),
            hi: Vector::<2>::new(1.0, f64::INFINITY),
            vertical: 1,
            height: 0.0,
            h_layer: 0.1,
            phi_layer: 0.4,
            radii: RadiusLaw::Constant(0.01),
            max_attempts: 100_000,
            existing: (&[], &[]),
            layer: 0,
        };
        let (x, r) = place_layer(&spec, &mut rng).unwrap();
        assert!(brute_force_pairs(&x, &r).is_empty());
        let phi: f64 = r.iter().map(|&r| particle_volume::<2>(r)).sum::<f64>() / 0.1;
        let one = particle_volume::<2>(0.01) / 0.1;
        assert!(phi >= 0.4 && phi < 0.4 + one, "{phi}");
        assert!(x
            .iter()
            .all(|p| p[0] >= 0.01 && p[0] <= 0.99 && p[1] >= 0.01));
    }

    /// At a size ratio of 8 (radii nearly uniform on [0.005, 0.04] m), on top of a
    /// bed of the same law, in a box and in a periodic cell: the insertion grid misses
    /// no overlap (brute force over old and new, minimum image in the cell), and the
    /// layer reaches its fraction. (A loose fraction: at 0.2 a large sphere drawn late
    /// finds no hole among the small ones within the attempts, and the layer reports
    /// saturation near 0.165.)
    #[test]
    fn wide_size_ratio_layers_have_no_overlaps() {
        let law = RadiusLaw::Gaussian {
            mean: 0.0225,
            std: 0.35,
            min: 0.005,
            max: 0.04,
        };
        for container in [Container::Box, Container::Periodic] {
            let mut rng = ChaCha8Rng::seed_from_u64(4);
            let mut spec = LayerSpec::<3> {
                container,
                lo: Vector::<3>::zeros(),
                hi: Vector::<3>::new(0.5, 0.5, f64::INFINITY),
                vertical: 2,
                height: 0.0,
                h_layer: 0.16,
                phi_layer: 0.12,
                radii: law.clone(),
                max_attempts: 1_000_000,
                existing: (&[], &[]),
                layer: 0,
            };
            let (x0, r0) = place_layer(&spec, &mut rng).unwrap();
            spec.height = 0.08;
            spec.existing = (&x0, &r0);
            let (x1, r1) = place_layer(&spec, &mut rng).unwrap();
            let x: Vec<Vector<3>> = x0.iter().chain(&x1).cloned().collect();
            let r: Vec<Real> = r0.iter().chain(&r1).cloned().collect();
            let overlapping = match container {
                Container::Periodic => {
                    let per = Period::lateral(&spec.lo, &spec.hi);
                    crate::geometry::brute_force_pairs_periodic(&x, &r, &per)
                }
                _ => brute_force_pairs(&x, &r),
            };
            assert!(overlapping.is_empty(), "{container:?}: {overlapping:?}");
            let vol: Real = r1.iter().map(|&r| particle_volume::<3>(r)).sum();
            assert!(vol / (0.25 * 0.16) >= 0.12, "{container:?}");
            let spread =
                r1.iter().cloned().fold(0.0, Real::max) / r1.iter().cloned().fold(1.0, Real::min);
            assert!(spread > 6.0, "{spread}");
        }
    }

    #[test]
    fn saturation_is_reported_with_the_fraction_reached() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let spec = LayerSpec::<2> {
            container: Container::Box,
            lo: Vector::<2>::zeros(),
            hi: Vector::<2>::new(0.3, f64::INFINITY),
            vertical: 1,
            height: 0.0,
            h_layer: 0.1,
            phi_layer: 0.7,
            radii: RadiusLaw::Constant(0.01),
            max_attempts: 20_000,
            existing: (&[], &[]),
            layer: 0,
        };
        let e = place_layer(&spec, &mut rng).unwrap_err().to_string();
        assert!(e.contains("saturated") && e.contains("0.7"), "{e}");
        // a poll that answers false stops the attempts before they run out
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut polls = 0;
        let stopped = place_layer_polled(&spec, &mut rng, &mut || {
            polls += 1;
            false
        });
        assert!(matches!(stopped, Ok(None)));
        assert_eq!(polls, 1);
    }

    #[test]
    fn a_sieve_layer_is_placed_largest_first_from_iid_draws() {
        // size ratio 4 in a box of four large diameters: drawn and placed one by one,
        // the large ones drawn late find no hole; largest first the layer fills
        let law = RadiusLaw::Sieve(
            crate::pipeline::SieveLaw::new(&[0.02, 0.03, 0.05, 0.08], &[0.0, 0.3, 0.7, 1.0], 3)
                .unwrap(),
        );
        let spec = LayerSpec::<3> {
            container: Container::Box,
            lo: Vector::<3>::zeros(),
            hi: Vector::<3>::new(0.3, 0.3, f64::INFINITY),
            vertical: 2,
            height: 0.0,
            h_layer: 0.1,
            phi_layer: 0.25,
            radii: law.clone(),
            max_attempts: 100_000,
            existing: (&[], &[]),
            layer: 0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let (x, r) = place_layer(&spec, &mut rng).unwrap();
        assert!(brute_force_pairs(&x, &r).is_empty());
        let phi: f64 = r.iter().map(|&r| particle_volume::<3>(r)).sum::<f64>() / (0.09 * 0.1);
        assert!(phi >= 0.25, "{phi}");
        assert!(r.windows(2).all(|w| w[0] >= w[1]), "largest first");
        // the radii are the law's first draws of the stream, in another order
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut draws: Vec<f64> = (0..r.len()).map(|_| law.sample(&mut rng)).collect();
        draws.sort_by(|a, b| b.total_cmp(a));
        assert_eq!(draws, r);
    }
}
