"""Prints the instruction-set level granpack's kernels run at and a checksum of a short
DEM run, for checking that a wheel gives the same bits on every CPU.

    python tools/cpu_check.py                                  # this CPU, its best level
    GRANPACK_CPU_LEVEL=x86-64 python tools/cpu_check.py        # a forced level
    qemu-x86_64 -cpu Nehalem "$(command -v python)" tools/cpu_check.py   # an older CPU

(Where OPENBLAS_CORETYPE is set for the host, set it to Nehalem for the Nehalem run, as
.ci/run does: numpy's OpenBLAS would otherwise run the host's kernels on the emulated CPU.)

The run is small (a few hundred steps: emulators are slow) but takes every hot kernel
through contacts: a 3D bed of 180 spheres and a 2D one of 60 discs, with friction,
spins and walls, fall onto their floors; then one RSA layer of the presets with Gaussian
radii (4.2, 4.4) is placed and stepped briefly. The checksum hashes the bits of the final
positions, velocities and spins; equal checksums mean bit-identical runs. The second
checksum ("models") hashes the same beds under rolling resistance and under the linear
law.
"""

from __future__ import annotations

import hashlib

import numpy as np

import granpack as gp
from granpack import _core


def bed(dim: int, n_side: int, layers: int) -> tuple[np.ndarray, np.ndarray]:
    """A jittered lattice of particles just above the floor, overlapping a little, so
    that the first steps push them apart."""
    rng = np.random.default_rng(1)
    axes = [np.arange(n_side)] * (dim - 1) + [np.arange(layers)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    x = 0.0095 + 0.0185 * grid.astype(float)
    x[:, :-1] += 0.002 * rng.random((len(x), dim - 1))
    r = 0.009 + 0.0015 * rng.random(len(x))
    return x, r


def run(dim: int, steps: int, material: gp.Material | None = None) -> bytes:
    n_side, layers = (6, 5) if dim == 3 else (12, 5)
    x, r = bed(dim, n_side, layers)
    top = [0.0185 * n_side + 0.01] * (dim - 1) + [float("inf")]
    sim = gp.Simulation(
        dim=dim,
        material=material or gp.Material(friction=0.5),
        dt=2e-5,
        gravity=[0.0] * (dim - 1) + [-9.81],
        box=([0.0] * dim, top),
    )
    sim.add_particles(x, r)
    assert len(sim.contacts().i) > len(x), "the bed starts in contact"
    sim.step(steps)
    return b"".join(
        np.ascontiguousarray(a).tobytes() for a in (sim.positions, sim.velocities, sim.spins)
    )


def rsa_layer(preset: str) -> bytes:
    """One RSA layer of a preset with Gaussian radii, and 50 DEM steps on it: the
    radius sampling and placement (which call libm, whose exp and log glibc picks per
    CPU) as well as the step."""
    from granpack.pack import _packer

    scene = gp.PackScene.preset(preset).replace(settle_time=50 * 1e-4, height=0.1)
    packer = _packer(scene)
    packer.next_layer()
    st = packer.state()
    return b"".join(
        np.ascontiguousarray(st[k]).tobytes() for k in ("positions", "radii", "velocities")
    )


def main() -> None:
    h = hashlib.sha256()
    for dim in (3, 2):
        h.update(run(dim, 300))
    for preset in ("4.2", "4.4"):
        h.update(rsa_layer(preset))
    # the user's contact models, hashed apart so that the first checksum keeps its value
    models = hashlib.sha256()
    for material in (
        gp.Material(friction=0.5, rolling="epsd", rolling_friction=0.3, rolling_damping=1e-3),
        gp.Material(friction=0.5, contact_law="linear", normal_stiffness=2e4),
    ):
        for dim in (3, 2):
            models.update(run(dim, 300, material))
    print(
        f"level {_core.cpu_level()} checksum {h.hexdigest()[:16]} models {models.hexdigest()[:16]}"
    )


if __name__ == "__main__":
    main()
