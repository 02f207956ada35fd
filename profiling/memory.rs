//! Peak memory of the engine for a large 3D scene: the peers' 4.3 pack tiled
//! `tiles` x `tiles` times (8952 spheres each), one pair-list build and a few steps,
//! then one more sphere dropped in, which forces a rebuild with the full list in place.
//! The rebuild merges the new list into the old one's memory (`Pairs::merge_in_place`),
//! so its peak should be the first build's; before that merge it held the old and the
//! new pair state at once, a third more (1 211 against 907 bytes a particle at 573k).
//! Then the top 5 % of the pack is removed in place (`World::remove_particles`, the flat
//! top of a trimmed pack), and the world is spent for its finished pack
//! (`World::into_finished`: the contact table is written while the pair state is freed
//! from its end); both peaks should stay the rebuild's. Prints bytes per particle from
//! the process's peak resident set (VmHWM).
#[path = "../benches/common/mod.rs"]
mod common;

fn vm_hwm_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        .unwrap_or(0)
}

fn main() {
    let tiles: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(11);
    let before = vm_hwm_kib();
    let mut w = common::settled_world::<3>(tiles, 5, 1);
    let first = vm_hwm_kib();
    // a sphere above the pack, inside the box: the next step rebuilds the whole list
    let top = w.positions().iter().map(|p| p[2]).fold(0.0, f64::max);
    let r = w.radii()[0];
    w.add_particles(
        &[_core::Vector::<3>::new(0.5, 0.5, top + 0.2)],
        &[r],
        None,
        None,
    )
    .expect("one more sphere");
    let rebuilds = w.rebuilds();
    w.step_n(1).expect("a step after the rebuild");
    assert!(w.rebuilds() > rebuilds, "the list was rebuilt");
    let peak = vm_hwm_kib();
    let (pairs, _) = w.pair_counts();
    // bytes per particle of the whole pack, before its flat top
    let n_all = w.len();
    let per = |kib: u64| (kib - before) as f64 * 1024.0 / n_all as f64;
    println!(
        "{} spheres, {} pairs: engine state {:.0} bytes per particle; peak RSS {:.1} MiB \
         (baseline {:.1} MiB) = {:.0} bytes per particle ({:.0} after the first build)",
        w.len(),
        pairs,
        w.state_bytes() as f64 / w.len() as f64,
        peak as f64 / 1024.0,
        before as f64 / 1024.0,
        per(peak),
        per(first)
    );
    // the flat top of a trimmed pack: the spheres whose centre lies in the top 5 % go
    let cut = 0.95 * top;
    let keep: Vec<bool> = w.positions().iter().map(|p| p[2] <= cut).collect();
    w.remove_particles(&keep).expect("the flat top");
    w.step_n(1).expect("a step after the removal");
    let trimmed = vm_hwm_kib();
    println!(
        "flat top: {} spheres left; peak RSS {:.1} MiB = {:.0} bytes per particle",
        w.len(),
        trimmed as f64 / 1024.0,
        per(trimmed)
    );
    let (contacts, state) = w.into_finished().expect("the finished pack");
    let done = vm_hwm_kib();
    println!(
        "finished pack: {} contacts and {} spheres' arrays; peak RSS {:.1} MiB = {:.0} bytes \
         per particle",
        contacts.len(),
        state.radii.len(),
        done as f64 / 1024.0,
        per(done)
    );
}
