//! Peak memory of the engine for a large 3D scene: the peers' 4.3 pack tiled
//! `tiles` x `tiles` times (8952 spheres each), one pair-list build and a few steps.
//! Prints bytes per particle from the process's peak resident set (VmHWM).
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
    let w = common::settled_world::<3>(tiles, 5, 1);
    let peak = vm_hwm_kib();
    let (pairs, _) = w.pair_counts();
    println!(
        "{} spheres, {} pairs: engine state {:.0} bytes per particle; peak RSS {:.1} MiB \
         (baseline {:.1} MiB) = {:.0} bytes per particle",
        w.len(),
        pairs,
        w.state_bytes() as f64 / w.len() as f64,
        peak as f64 / 1024.0,
        before as f64 / 1024.0,
        (peak - before) as f64 * 1024.0 / w.len() as f64
    );
}
