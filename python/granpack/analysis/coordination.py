"""Coordination: contacts per particle, their distribution P[k], and rattlers.

Only particle-particle contacts count here (wall contacts are in ``Microstructure.z_walls``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["degrees", "coordination_distribution", "rattlers_iterative", "P_Z_KEYS"]

#: P[k] columns of ``Microstructure.to_dict()``: coordination_p0 .. coordination_p14, and
#: coordination_p15plus for k >= 15.
P_Z_KEYS = 15


def degrees(i, j, n: int) -> np.ndarray:
    """(n,) int64: the number of particle-particle contacts of each particle, from the
    contact ends ``i``, ``j`` (rows with j < 0, wall contacts, are left out)."""
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    keep = j >= 0
    return np.bincount(i[keep], minlength=n) + np.bincount(j[keep], minlength=n)


def coordination_distribution(degree) -> np.ndarray:
    """P[k], the fraction of particles with k particle-particle contacts (-).

    P has max(k) + 1 entries and sums to 1; sum_k k P[k] = Z = 2 N_c / N_p.
    """
    degree = np.asarray(degree, dtype=np.int64)
    counts = np.bincount(degree)
    return counts / degree.shape[0]


def rattlers_iterative(i, j, n: int, d: int, min_contacts: int | None = None):
    """Rattlers removed iteratively, the removal of LAMMPS ``compute rattlers/atom`` with
    the walls counted.

    A particle with fewer than ``min_contacts`` (default D + 1) contacts with particles not
    yet removed and with the walls cannot be held in place by them; it is removed with its
    contacts, which can leave a neighbour short, and so on until no such particle is left.
    Walls are never removed, so a particle on the floor keeps its floor contact.

    LAMMPS' compute counts only the pair contacts of its pair style (contacts with fix
    wall/gran walls are not in its neighbour list), so a particle held by a wall is a
    rattler there: in packs where many particles touch a wall the two counts differ by up
    to a factor of 2. Rows with j < 0 left out (``contacts.particle_pairs()``) give LAMMPS'
    count.

    Returns
    -------
    rattler : (n,) bool
        True for the removed particles.
    n_contacts : int
        The particle-particle contacts left among the others (the mechanical network).
    """
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    need = d + 1 if min_contacts is None else int(min_contacts)
    wall = j < 0
    fixed = np.bincount(i[wall], minlength=n)
    i, j = i[~wall], j[~wall]
    alive = np.ones(n, dtype=bool)
    live = np.ones(i.shape[0], dtype=bool)
    while True:
        deg = fixed + np.bincount(i[live], minlength=n) + np.bincount(j[live], minlength=n)
        weak = alive & (deg < need)
        if not np.any(weak):
            break
        alive &= ~weak
        live &= alive[i] & alive[j]
    return ~alive, int(np.sum(live))
