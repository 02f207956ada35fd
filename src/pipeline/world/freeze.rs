//! Freezing of settled particles: its configuration, the freeze and thaw decisions,
//! and the partition of the pair list into the frozen and the active run.

use super::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Steps between two freeze/unfreeze decisions of a pack ([`FreezeConfig::interval`]):
/// each decision needs every particle's net force, so it runs on a step whose forces
/// are gathered for all particles anyway.
pub const FREEZE_INTERVAL: u64 = 100;

/// Freezing of settled particles (skip what a settled pack does not need).
///
/// Every `interval` steps the world evaluates the net force on every particle. A
/// particle whose top lies below `below` (m, along the vertical), whose speed is under
/// `speed` and whose net force is under `force_ratio` times its weight is frozen: it is
/// no longer integrated (velocity and spin set to zero) and its contacts with other
/// frozen particles keep their last force instead of being recomputed; they still act
/// on the active particles above. A frozen particle whose net force grows beyond
/// `force_ratio` times its weight (something above pushes it) is unfrozen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreezeConfig {
    /// Vertical coordinate (m) below which (z + r < below) particles may freeze.
    pub below: Real,
    /// Speed (m/s) under which a particle counts as at rest.
    pub speed: Real,
    /// Net force over weight under which a particle counts as in equilibrium (-).
    pub force_ratio: Real,
    /// Steps between freeze/unfreeze decisions.
    pub interval: u64,
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Sets (or clears) the freezing of settled particles. Clearing it unfreezes all.
    pub fn set_freeze(&mut self, freeze: Option<FreezeConfig>) -> Result<()> {
        if let Some(f) = &freeze {
            check_range("freeze.speed", f.speed, 0.0, true, f64::INFINITY, false)?;
            check_range(
                "freeze.force_ratio",
                f.force_ratio,
                0.0,
                true,
                f64::INFINITY,
                false,
            )?;
            if f.below.is_nan() {
                return Err(Error::invalid(
                    "freeze.below",
                    f.below,
                    "must not be NaN (m)",
                ));
            }
            if f.interval == 0 {
                return Err(Error::invalid("freeze.interval", 0, "must be >= 1 step"));
            }
        } else if self.n_frozen > 0 {
            self.p.frozen.iter_mut().for_each(|z| *z = false);
            self.n_frozen = 0;
            self.forces_valid = false;
            self.list_valid = false;
        }
        self.freeze = freeze;
        Ok(())
    }

    /// Number of frozen particles.
    pub fn n_frozen(&self) -> usize {
        self.n_frozen
    }

    /// Which particles are frozen.
    pub fn frozen(&self) -> &[bool] {
        &self.p.frozen
    }

    /// Puts the pairs of two frozen particles in front of the others (both runs in
    /// (i, j) order) and rebuilds the incidence lists. Runs after every full rebuild and
    /// whenever particles freeze or thaw.
    pub(super) fn partition_pairs(&mut self) {
        let fz = &self.p.frozen;
        let pr = &mut self.pairs;
        // Nothing frozen now or before: the list is already one sorted run.
        if self.n_frozen > 0 || pr.n_frozen_pairs > 0 {
            let both = |k: &u32| {
                let [i, j] = pr.ij[*k as usize];
                fz[i as usize] && fz[j as usize]
            };
            let (frozen, active): (Vec<u32>, Vec<u32>) =
                pr.sorted_order().into_iter().partition(both);
            pr.n_frozen_pairs = frozen.len();
            pr.permute(&[frozen, active].concat());
        }
        self.build_incidence();
    }

    /// Freezes settled particles below the freeze level and unfreezes pushed ones.
    /// Runs right after a full force evaluation; each decision is per particle, so the
    /// result does not depend on the thread count.
    pub(super) fn update_frozen(&mut self) {
        let Some(fc) = self.freeze else { return };
        let vert = <Dim<D> as Spatial<D>>::VERTICAL;
        let g = self.cfg.gravity.norm();
        let p = &mut self.p;
        let (x, f, r, m) = (&p.x, &p.f, &p.r, &p.m);
        let speed2 = fc.speed * fc.speed;
        let thawed = AtomicBool::new(false);
        p.frozen
            .par_chunks_mut(CHUNK)
            .zip(p.v.par_chunks_mut(CHUNK))
            .zip(p.w.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, ((fz, v), w))| {
                for k in 0..fz.len() {
                    let q = c * CHUNK + k;
                    let fmax = fc.force_ratio * m[q] * g;
                    let quiet = f[q].norm_squared() <= fmax * fmax;
                    if fz[k] {
                        if !quiet {
                            fz[k] = false;
                            thawed.store(true, Ordering::Relaxed);
                        }
                    } else if quiet && x[q][vert] + r[q] < fc.below && v[k].norm_squared() <= speed2
                    {
                        fz[k] = true;
                        v[k] = Vector::<D>::zeros();
                        w[k] = Ang::<D>::default();
                    }
                }
            });
        let (n_before, thawed) = (self.n_frozen, thawed.load(Ordering::Relaxed));
        self.n_frozen = self.p.frozen.iter().filter(|&&z| z).count();
        if thawed {
            // A thawed particle may move again: its pairs leave the frozen run and are
            // searched afresh at the next (partial) rebuild, which sees it as active.
            self.partition_pairs();
            self.list_valid = false;
        } else if self.n_frozen != n_before {
            self.partition_pairs();
        }
    }
}
