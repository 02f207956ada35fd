//! A team of threads for the step's particle and pair loops, cheaper per loop than a
//! rayon parallel iterator at the sizes of a pack's layers.
//!
//! Why: a step of a layer of 100 to 10 000 particles is 5 to 500 us of work in three
//! loops (kick and drift, pair pass, gather). With one rayon parallel loop per phase,
//! each loop paid the hand-off to the idle worker (which waits in `sched_yield` or
//! asleep), and on the project's 2-core machine two threads ran example 4.1 only 5 %
//! faster than one (3.13-3.18 s against 3.31-3.38 s; the team: 2.90-2.92 s on two
//! threads; 2026-11-23 (672f9b9) in HISTORY.md).
//!
//! How: a *segment* is a run of loops (phases) between two calls into rayon (pair-list
//! rebuilds, freeze decisions, checks). At its first phase with more than one item the
//! master (the thread that runs the step) spawns `threads - 1` helper jobs into the
//! enclosing rayon scope. Each phase is a number of items; item k belongs to slot
//! k * threads / items (slot 0 is the master), so each thread keeps working on the
//! same particles and pairs step after step (they stay in its cache), and takes items
//! of other slots once its own are done. The master returns from a phase once every
//! item is done. Between phases the helpers spin; [`Team::pause`] ends the segment,
//! and the helpers return to rayon, whose workers the rebuild's parallel loops need.
//!
//! A helper that never starts (its worker is busy elsewhere) costs nothing but its
//! share: the master takes all the items. While a segment is live the master must not
//! call into rayon: a helper job still queued on its own worker could then be run by
//! the master itself, and would wait for phases that never come. [`Team::pause`]
//! first.
//!
//! Results do not depend on who runs an item: each item writes its own outputs, and
//! [`Team::map_reduce`] merges per-item results in item order.

use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;

/// Spins of an idle helper (about 10 ns each) before it starts yielding its core
/// between looks at the phase counter.
const SPINS: u32 = 1 << 14;

/// Most threads a team uses: enough for the 16-core machine DEVELOPERS.md mentions,
/// with room. Beyond it the extra rayon threads are left out.
const MAX_THREADS: usize = 64;

/// One phase: its items and what runs each (item, slot).
struct Job<'a> {
    run: &'a (dyn Fn(usize, usize) + Sync),
    items: usize,
    threads: usize,
    /// The phase's number (`Shared::seq` once published).
    seq: u64,
}

impl Job<'_> {
    /// First item of slot `s`.
    fn start(&self, s: usize) -> usize {
        s * self.items / self.threads
    }
}

/// An atomic counter on a cache line of its own, so that each slot's claims do not
/// move the other slots' lines between cores.
#[derive(Default)]
#[repr(align(128))]
struct Padded(AtomicUsize);

/// What the master and the helpers of one segment share.
struct Shared {
    /// Bumped when a phase is published.
    seq: AtomicU64,
    /// The current phase, null between phases. Points into the master's stack.
    job: AtomicPtr<Job<'static>>,
    /// Next unclaimed item of each slot's range, as an offset from its start.
    next: Vec<Padded>,
    /// Items finished in the current phase, by each slot (each on its own line: the
    /// master polls them all; one shared counter moved between cores at every item).
    done: Vec<Padded>,
    /// The phase each slot last started (its `seq`).
    started: Vec<Padded>,
    /// Helpers between reading `job` and leaving the phase.
    active: AtomicUsize,
    /// Set once, when the segment ends.
    quit: AtomicBool,
    /// An item panicked on a helper.
    panicked: AtomicBool,
}

impl Shared {
    fn new(threads: usize) -> Self {
        Shared {
            seq: AtomicU64::new(0),
            job: AtomicPtr::new(std::ptr::null_mut()),
            next: (0..threads).map(|_| Padded::default()).collect(),
            done: (0..threads).map(|_| Padded::default()).collect(),
            started: (0..threads).map(|_| Padded::default()).collect(),
            active: AtomicUsize::new(0),
            quit: AtomicBool::new(false),
            panicked: AtomicBool::new(false),
        }
    }

    /// Claims and runs items of `job` as slot `slot`: its own range first, in order,
    /// then what is left of the others'.
    fn work(&self, job: &Job, slot: usize) {
        self.started[slot]
            .0
            .store(job.seq as usize, Ordering::Relaxed);
        self.claim(job, slot, slot);
        for s in (slot + 1..job.threads).chain(0..slot) {
            if self.started[s].0.load(Ordering::Relaxed) != job.seq as usize {
                self.claim(job, s, slot);
            }
        }
    }

    /// Runs what is left of slot `s`'s items, as slot `slot`.
    fn claim(&self, job: &Job, s: usize, slot: usize) {
        let (lo, hi) = (job.start(s), job.start(s + 1));
        loop {
            let k = lo + self.next[s].0.fetch_add(1, Ordering::Relaxed);
            if k >= hi {
                break;
            }
            (job.run)(k, slot);
            self.done[slot].0.fetch_add(1, Ordering::Release);
        }
    }

    /// A helper's life: join each phase published until the segment ends.
    fn helper(&self, slot: usize) {
        // u64::MAX: join the phase running now, if any
        let mut seen = u64::MAX;
        let mut idle = 0u32;
        while !self.quit.load(Ordering::Acquire) {
            let s = self.seq.load(Ordering::Acquire);
            if s == seen {
                idle = idle.saturating_add(1);
                if idle < SPINS {
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
                continue;
            }
            (seen, idle) = (s, 0);
            // Announce before reading the pointer; the master nulls the pointer before
            // it waits for `active` to drain (both SeqCst), so a helper either sees null
            // or is waited for.
            self.active.fetch_add(1, Ordering::SeqCst);
            let job = self.job.load(Ordering::SeqCst);
            if !job.is_null() {
                // SAFETY: the master keeps the job alive until `active` drains.
                let job = unsafe { &*job };
                if catch_unwind(AssertUnwindSafe(|| self.work(job, slot))).is_err() {
                    self.panicked.store(true, Ordering::SeqCst);
                }
            }
            self.active.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// The step's thread team (see the module docs). Lives for one `step_n` call, inside
/// its rayon scope.
pub(super) struct Team<'a, 'scope> {
    scope: &'a rayon::Scope<'scope>,
    threads: usize,
    live: Option<Arc<Shared>>,
}

impl<'a, 'scope> Team<'a, 'scope> {
    /// A team of all the threads of the current rayon pool (at most [`MAX_THREADS`]),
    /// spawning its helpers into `scope`.
    pub(super) fn new(scope: &'a rayon::Scope<'scope>) -> Self {
        Team {
            scope,
            threads: rayon::current_num_threads().clamp(1, MAX_THREADS),
            live: None,
        }
    }

    /// Runs `f` with a team in a rayon scope of its own: the helpers are spawned into
    /// that scope, which waits for them after the team is dropped (and paused).
    pub(super) fn scoped<R: Send>(f: impl FnOnce(&mut Team<'_, '_>) -> R + Send) -> R {
        rayon::scope(|s| f(&mut Team::new(s)))
    }

    /// Threads that may run a phase's items.
    pub(super) fn threads(&self) -> usize {
        self.threads
    }

    /// Ends the segment: the helpers return to rayon. Call before any rayon call.
    pub(super) fn pause(&mut self) {
        if let Some(s) = self.live.take() {
            s.quit.store(true, Ordering::Release);
        }
    }

    /// Runs `f(item, slot)` for every item in `0..items`, each once, on the team;
    /// `slot < self.threads()` identifies the running thread (for scratch space).
    /// Returns when all are done. A panic in an item is raised here.
    pub(super) fn run(&mut self, items: usize, f: &(dyn Fn(usize, usize) + Sync)) {
        if items <= 1 || self.threads == 1 {
            (0..items).for_each(|k| f(k, 0));
            return;
        }
        let shared = match &self.live {
            Some(s) => s.clone(),
            None => {
                let s = Arc::new(Shared::new(self.threads));
                for slot in 1..self.threads {
                    let h = s.clone();
                    self.scope.spawn(move |_| h.helper(slot));
                }
                self.live = Some(s.clone());
                s
            }
        };
        let job = Job {
            run: f,
            items,
            threads: self.threads,
            // only the master writes seq
            seq: shared.seq.load(Ordering::Relaxed) + 1,
        };
        for (n, d) in shared.next.iter().zip(&shared.done) {
            n.0.store(0, Ordering::Relaxed);
            d.0.store(0, Ordering::Relaxed);
        }
        let ptr = &job as *const Job as *mut Job<'static>;
        shared.job.store(ptr, Ordering::SeqCst);
        shared.seq.store(job.seq, Ordering::SeqCst);
        // The master's own items; a panic must not unwind past the job while helpers
        // may still read it.
        let mut mine = catch_unwind(AssertUnwindSafe(|| shared.work(&job, 0)));
        let mut spins = 0u32;
        while mine.is_ok()
            && shared
                .done
                .iter()
                .map(|d| d.0.load(Ordering::Acquire))
                .sum::<usize>()
                < items
            && !shared.panicked.load(Ordering::Acquire)
        {
            // a helper finishing an item it claimed
            spins = spins.saturating_add(1);
            if spins < SPINS {
                std::hint::spin_loop();
            } else {
                // a helper that has started but stalls (its core taken away): take
                // what it has not claimed
                if spins == SPINS {
                    mine = catch_unwind(AssertUnwindSafe(|| {
                        (1..self.threads).for_each(|s| shared.claim(&job, s, 0))
                    }));
                }
                std::thread::yield_now();
            }
        }
        shared.job.store(std::ptr::null_mut(), Ordering::SeqCst);
        while shared.active.load(Ordering::SeqCst) != 0 {
            std::hint::spin_loop();
        }
        if let Err(e) = mine {
            self.pause();
            resume_unwind(e);
        }
        if shared.panicked.load(Ordering::SeqCst) {
            self.pause();
            panic!("a thread of the step's team panicked (see its message above)");
        }
    }

    /// `f` over `0..items` on the team, the results merged in item order (so the
    /// result is the same whoever ran each item), starting from `identity`.
    pub(super) fn map_reduce<R: Copy + Send>(
        &mut self,
        items: usize,
        identity: R,
        f: impl Fn(usize, usize) -> R + Sync,
        merge: impl Fn(R, R) -> R,
    ) -> R {
        if items <= 1 || self.threads == 1 {
            return (0..items).fold(identity, |a, k| merge(a, f(k, 0)));
        }
        let mut out = vec![identity; items];
        let slots = Disjoint::new(&mut out);
        self.run(items, &|k, slot| {
            let r = f(k, slot);
            // SAFETY: k < items, and each item is run once.
            unsafe { *slots.one(k) = r };
        });
        out.into_iter().fold(identity, merge)
    }
}

impl Drop for Team<'_, '_> {
    fn drop(&mut self) {
        self.pause();
    }
}

/// A mutable slice whose elements the team's items borrow in disjoint ranges.
pub(super) struct Disjoint<'s, T> {
    ptr: *mut T,
    len: usize,
    _borrow: std::marker::PhantomData<&'s mut [T]>,
}

impl<'s, T> Disjoint<'s, T> {
    pub(super) fn new(s: &'s mut [T]) -> Self {
        Disjoint {
            ptr: s.as_mut_ptr(),
            len: s.len(),
            _borrow: std::marker::PhantomData,
        }
    }

    /// Elements `r` (checked against the length).
    ///
    /// # Safety
    /// No other borrow of these elements is live while this one is.
    #[allow(clippy::mut_from_ref)]
    pub(super) unsafe fn range(&self, r: std::ops::Range<usize>) -> &'s mut [T] {
        assert!(r.start <= r.end && r.end <= self.len);
        // SAFETY: in bounds (checked), and not aliased (caller).
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(r.start), r.end - r.start) }
    }

    /// Element `k`, as [`range`](Self::range).
    ///
    /// # Safety
    /// As for [`range`](Self::range).
    #[allow(clippy::mut_from_ref)]
    pub(super) unsafe fn one(&self, k: usize) -> &'s mut T {
        assert!(k < self.len);
        // SAFETY: as above.
        unsafe { &mut *self.ptr.add(k) }
    }
}
// SAFETY: the team's items borrow disjoint elements (each use says why).
unsafe impl<T: Send> Sync for Disjoint<'_, T> {}
unsafe impl<T: Send> Send for Disjoint<'_, T> {}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;
    use std::sync::atomic::AtomicU32;

    /// Every item of every phase runs exactly once, whatever the thread count, and
    /// map_reduce's result is that of the serial fold.
    #[test]
    fn each_item_runs_once() {
        for threads in [1, 2, 3, 5] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                Team::scoped(|team| {
                    assert_eq!(team.threads(), threads);
                    for phase in 0..2000usize {
                        let items = phase % 37;
                        let runs: Vec<AtomicU32> = (0..items).map(|_| AtomicU32::new(0)).collect();
                        let sum = team.map_reduce(
                            items,
                            0u64,
                            |k, slot| {
                                assert!(slot < threads);
                                runs[k].fetch_add(1, Ordering::Relaxed);
                                (k * k) as u64
                            },
                            |a, b| a + b,
                        );
                        assert!(runs.iter().all(|r| r.load(Ordering::Relaxed) == 1));
                        assert_eq!(sum, (0..items).map(|k| (k * k) as u64).sum::<u64>());
                        if phase % 100 == 0 {
                            // a segment ends, and rayon runs between two
                            team.pause();
                            let s: u64 = (0..1000u64)
                                .into_par_iter()
                                .map(|x| x)
                                .reduce(|| 0, |a, b| a + b);
                            assert_eq!(s, 499_500);
                        }
                    }
                })
            });
        }
    }

    /// A helper that cannot start (its worker is busy) leaves its items to the master:
    /// the phases complete without it.
    #[test]
    fn a_helper_that_never_starts_costs_nothing_but_its_share() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        pool.install(|| {
            let (started, release) = (AtomicBool::new(false), AtomicBool::new(false));
            rayon::scope(|s| {
                // occupy the other worker until the team is done
                s.spawn(|_| {
                    started.store(true, Ordering::SeqCst);
                    while !release.load(Ordering::SeqCst) {
                        std::hint::spin_loop();
                    }
                });
                while !started.load(Ordering::SeqCst) {
                    std::hint::spin_loop();
                }
                let mut team = Team::new(s);
                let runs: Vec<AtomicU32> = (0..50).map(|_| AtomicU32::new(0)).collect();
                for _ in 0..100 {
                    team.run(50, &|k, slot| {
                        assert_eq!(slot, 0, "only the master runs");
                        runs[k].fetch_add(1, Ordering::Relaxed);
                    });
                }
                assert!(runs.iter().all(|r| r.load(Ordering::Relaxed) == 100));
                team.pause();
                release.store(true, Ordering::SeqCst);
            });
        });
    }

    /// A panic in an item, on whichever thread, is raised on the master, and the
    /// team's threads all return.
    #[test]
    fn a_panicking_item_is_raised() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let r = std::panic::catch_unwind(AssertUnwindSafe(|| {
            pool.install(|| Team::scoped(|team| team.run(64, &|k, _| assert!(k != 40, "item 40"))))
        }));
        assert!(r.is_err());
    }
}
