"""The deposit: the layer loop (the paper's Algorithm 1), with the flat top where the
scene asks for it (``trim``: run on the loop's own state before the pack is finished,
and recorded in the history as the "trim" stage)."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from dataclasses import dataclass

from .. import pack as _pack
from .._contact_model import phase_material
from ..pack import Pack
from ..scene import PackScene

__all__ = ["Spec", "spec_of", "run"]


@dataclass(frozen=True)
class Spec:
    """The deposit's settings beyond the scene's.

    Attributes
    ----------
    friction : float or None
        The friction (-) every layer is jammed with, the deposition friction of a
        density target's search; the pack keeps the scene's material (its friction).
        None: the material's friction.
    rolling_friction : float or None
        The rolling friction mu_r (-) every layer is jammed with (the density window's
        rolling knob, docs/contact_models.md); the pack keeps the scene's material. 0:
        no rolling resistance (``rolling = "none"``) during the layers; None: the
        material's rolling model unchanged, as a `friction` alone leaves it.
    engine : str
        The DEM of the layers: ``"granpack"`` (default), granpack's own engine, or
        ``"lammps"``, LAMMPS over MPI (`granpack.mpi`; same statistics, not the same
        bits).
    ranks : int
        MPI ranks of the LAMMPS engine (default 1); 1 for granpack's.
    mpiexec : str or None
        The MPI launcher of the LAMMPS engine (`granpack.mpi.launch.mpiexec_command`);
        None: found as that function says.
    """

    friction: float | None = None
    rolling_friction: float | None = None
    engine: str = "granpack"
    ranks: int = 1
    mpiexec: str | None = None


def spec_of(scene: PackScene) -> Spec:
    """The deposit of `scene`: its layers jammed at the material's friction."""
    return Spec()


def run(
    scene: PackScene,
    spec: Spec,
    progress: bool | Callable[[dict], None] = False,
    *,
    _stacklevel: int = 2,
) -> Pack:
    """The layer loop of `scene` (`granpack.pack.deposit`), every layer jammed with the
    material of ``spec.friction`` and ``spec.rolling_friction``
    (`granpack._contact_model.phase_material`) where they differ from the material's;
    the pack keeps the scene, its material whole."""
    mat = scene.material
    jam_mat = phase_material(mat, spec.friction, spec.rolling_friction)
    jam = scene if jam_mat is mat else scene.replace(material=jam_mat)
    if spec.engine == "lammps":
        from ..mpi import launch

        pack = launch.deposit(jam, spec.ranks, progress, mpiexec=spec.mpiexec)
        issue = _pack.settling_issue(pack)
        if issue is not None:
            warnings.warn(issue, _pack.UnsettledPackWarning, stacklevel=_stacklevel + 1)
    else:
        pack = _pack.deposit(jam, progress, _stacklevel=_stacklevel + 1)
    return pack if jam is scene else dataclasses.replace(pack, scene=scene)
