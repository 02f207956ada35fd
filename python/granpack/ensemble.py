"""Ensembles of packs: each pack is an independent task, run in local worker processes or
on a Dask distributed cluster, written to disk as soon as it is finished.

Seeds. Pack k of an ensemble with master seed S is ``scene.replace(seed=S, stream=k)``.
The engine gives the same pack for the same scene on any machine and thread count, so an
ensemble does not depend on where (or in what order) its packs ran, and pack k is the
same whatever the ensemble size (a 2-pack run is the start of the 10-pack run).

Resuming. Every finished pack is written atomically (`Pack.save`) by the calling
process (or, with ``write_on_workers``, by the Dask worker that made it), so an
interrupted run loses only the packs still in progress. A task whose file
already exists and was made from the same scene is skipped; a file made from another
scene is an error (choose another output folder), never silently overwritten.

Where packs run
    * ``workers=1`` (or a single pending pack): in this process.
    * default: a ``concurrent.futures.ProcessPoolExecutor`` (``spawn`` start method, so
      no state leaks from the parent) with one process per core, each process's engine
      limited to ``cores // workers`` threads (``RAYON_NUM_THREADS``) so that the
      workers do not oversubscribe the cores.
    * ``scheduler="tcp://host:8786"`` (or a ``distributed.Client``): on that Dask
      cluster (``pip install "granpack[dask]"``; the workers need granpack installed).
      Results travel back to this process, which writes them, so the workers need no
      shared file system. Progress is then reported per pack (no layer reports).
    * ``scheduler=..., write_on_workers=True``: each Dask worker saves its pack itself,
      atomically, at the task's path, and sends back only a `PackSummary` (a few
      numbers). For a batch cluster whose workers and this process share a file system
      (`granpack.cluster` builds one): the packs do not cross the network and this
      process holds none of them.
"""

from __future__ import annotations

import concurrent.futures as cf
import ctypes
import functools
import multiprocessing as mp
import os
import queue as queue_mod
import signal
import socket
import sys
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._validate import FileFormatError, GranpackError, InvalidParameterError, as_int
from .generation import generate
from .pack import Pack, UnsettledPackWarning, load_pack, settling_issue
from .packfile import NEWER_FORMAT, scene_record_error
from .scene import PackScene

__all__ = [
    "PackTask",
    "PackSummary",
    "ensemble_tasks",
    "run_tasks",
    "run_ensemble",
    "pack_path",
    "Progress",
    "MAX_PACKS",
    "max_workers",
]

#: Most packs of one ensemble: the task list is built up front, and pack files are
#: numbered pack_000 .. pack_99999.
MAX_PACKS = 100_000


def max_workers() -> int:
    """Most local worker processes: four per core (more only add memory and switching)."""
    return 4 * (os.cpu_count() or 1)


@dataclass(frozen=True)
class PackTask:
    """One pack to make: its full scene (seed and stream set), the file it goes to, and
    a short label for progress messages."""

    scene: PackScene
    path: Path
    label: str
    #: `granpack.generate`'s engine settings (``engine``, ``ranks``, ``mpiexec``) as
    #: (key, value) pairs; empty: granpack's engine.
    engine: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class PackSummary:
    """What a worker that saved a pack itself sends back (``write_on_workers=True``):
    the file and a few numbers, not the pack.

    Attributes
    ----------
    path : str
        The pack file the worker wrote (the task's path).
    n : int
        Particles in the pack.
    phi : float
        Its solid fraction up to its height (-), `Pack.phi`.
    height : float
        Its height H_top (m), `Pack.height`.
    wall_time : float
        Seconds the generation took on the worker, `Pack.wall_time`.
    issue : str or None
        Why the pack has not come to rest (`granpack.pack.settling_issue`), or None.
    host : str
        The worker's host name (named when this process cannot see the file).
    """

    path: str
    n: int
    phi: float
    height: float
    wall_time: float
    issue: str | None = None
    host: str = ""

    @classmethod
    def of(cls, pack: Pack, path: str | Path) -> PackSummary:
        """The summary of `pack`, saved at `path`."""
        return cls(
            path=str(path),
            n=len(pack),
            phi=pack.phi,
            height=pack.height,
            wall_time=pack.wall_time,
            issue=settling_issue(pack),
            host=socket.gethostname(),
        )


def pack_path(out_dir: str | Path, k: int) -> Path:
    """File of pack k in an ensemble folder: ``out_dir/pack_000.npz``."""
    return Path(out_dir) / f"pack_{k:03d}.npz"


def ensemble_tasks(
    scene: PackScene,
    n_packs: int,
    out_dir: str | Path,
    seed: int | None = None,
    label: str = "",
    engine: dict[str, Any] | None = None,
) -> list[PackTask]:
    """The tasks of an ensemble: pack k uses ``scene.replace(seed=seed, stream=k)`` and
    goes to ``pack_path(out_dir, k)``. `seed` defaults to ``scene.seed``; `engine`, the
    keywords of `granpack.generate`'s engine (``engine``, ``ranks``, ``mpiexec``),
    defaults to granpack's engine."""
    n_packs = as_int("n_packs", n_packs, 1, MAX_PACKS)
    seed = scene.seed if seed is None else as_int("seed", seed, 0, 2**64 - 1)
    prefix = f"{label} " if label else ""
    return [
        PackTask(
            scene.replace(seed=seed, stream=k),
            pack_path(out_dir, k),
            f"{prefix}#{k}",
            tuple(sorted((engine or {}).items())),
        )
        for k in range(n_packs)
    ]


def run_ensemble(
    scene: PackScene,
    n_packs: int,
    seed: int | None,
    out_dir: str | Path,
    *,
    scheduler=None,
    workers: int | None = None,
    progress: bool | str | Callable[[dict], None] = "auto",
    write_on_workers: bool = False,
) -> list[Path]:
    """Makes packs 0..n_packs-1 of an ensemble into `out_dir` (skipping those already
    there) and returns their paths in pack order.

    Parameters
    ----------
    scene : PackScene
    n_packs : int
        Ensemble size (>= 1).
    seed : int or None
        Master seed; None keeps ``scene.seed``.
    out_dir : path
        Folder of the pack files (``pack_000.npz``, ...); created if needed.
    scheduler : str or distributed.Client, optional
        Address of a Dask scheduler (e.g. ``"tcp://10.0.0.1:8786"``); default: local.
    workers : int, optional
        Local worker processes; default: one per core (never more than pending packs).
    progress : bool, "auto", "bar", "lines" or callable
        "auto"/True: a tqdm bar on a terminal, plain lines otherwise (stderr);
        False: silent; a callable gets event dicts (see `Progress`).
    write_on_workers : bool
        Only with `scheduler`. Default False: the packs travel back and this process
        saves them. True: each Dask worker saves its pack at its path (atomically) and
        sends back a `PackSummary`; `out_dir` must then be on a file system that the
        workers and this process share (as on a batch cluster), which is checked at the
        end of the run.
    """
    tasks = ensemble_tasks(scene, n_packs, out_dir, seed)
    return run_tasks(
        tasks,
        scheduler=scheduler,
        workers=workers,
        progress=progress,
        write_on_workers=write_on_workers,
    )


# -- progress --------------------------------------------------------------------------------


class Progress:
    """Reports ensemble progress: a tqdm bar (on a terminal), plain lines, or events.

    Events (dicts) given to a callable: ``{"event": "start", "total", "skipped"}``,
    ``{"event": "skip", "label", "path"}``, ``{"event": "layer", "label", "layer",
    "total" (particles), "height", "wall_seconds", ...}``, ``{"event": "pack", "label",
    "path", "n", "phi", "height", "wall_time", "done", "total"}``, ``{"event": "end"}``.
    """

    def __init__(self, mode: bool | str | Callable[[dict], None] = "auto", stream=None):
        self.stream = sys.stderr if stream is None else stream
        self.callback = mode if callable(mode) else None
        if mode is True or mode == "auto":
            isatty = getattr(self.stream, "isatty", lambda: False)
            mode = "bar" if isatty() else "lines"
        if mode in (False, None, "none", "quiet"):
            mode = "none"
        if self.callback is None and mode not in ("bar", "lines", "none"):
            raise InvalidParameterError(
                f"invalid progress = {mode!r}: use True, False, 'auto', 'bar', 'lines' "
                "or a callable",
                parameter="progress",
            )
        self.mode = "callback" if self.callback is not None else mode
        self.bar: Any = None  # a tqdm bar in "bar" mode
        self.total = 0
        self.done = 0
        self.running: dict[str, float] = {}  # label -> fraction of the target height
        self.finished: set[str] = set()
        self.last = ""

    def _emit(self, event: dict) -> None:
        if self.callback is not None:
            self.callback(event)

    def _line(self, text: str) -> None:
        print(text, file=self.stream, flush=True)

    def start(self, total: int, skipped: int) -> None:
        self.total = total
        self.done = skipped
        self._emit({"event": "start", "total": total, "skipped": skipped})
        if self.mode == "bar":
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=total,
                initial=skipped,
                unit="pack",
                desc="packs",
                file=self.stream,
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total} "
                "[{elapsed}<{remaining}{postfix}]",
            )
        elif self.mode == "lines" and total:
            self._line(f"granpack: {total} packs, {skipped} already on disk")

    def skip(self, task: PackTask) -> None:
        self._emit({"event": "skip", "label": task.label, "path": str(task.path)})

    def layer(self, task_label: str, target: float, rep: dict) -> None:
        if task_label in self.finished:  # a late report from a worker's queue
            return
        self._emit({"event": "layer", "label": task_label, **rep})
        # A running pack counts as the fraction of its target height reached (never
        # a whole pack until it is saved).
        self.running[task_label] = min(0.99, rep["height"] / target) if target > 0 else 0.0
        if self.mode == "bar" and self.bar is not None:
            self.last = (
                f"{task_label}: layer {rep['layer']}, N={rep['total']}, "
                f"H={rep['height']:.3f}/{target:g} m"
            )
            self._refresh()
        elif self.mode == "lines":
            self._line(
                f"  {task_label}: layer {rep['layer']} N={rep['total']} "
                f"H={rep['height']:.4f} m ({rep['wall_seconds']:.1f} s)"
            )

    def pack(self, task: PackTask, pack: Pack | PackSummary) -> None:
        """A finished pack, from the pack itself or from a worker's `PackSummary`."""
        if isinstance(pack, Pack):
            n = len(pack)
        else:
            n = pack.n
        self.done += 1
        self.finished.add(task.label)
        self.running.pop(task.label, None)
        info = {
            "label": task.label,
            "path": str(task.path),
            "n": n,
            "phi": pack.phi,
            "height": pack.height,
            "wall_time": pack.wall_time,
            "done": self.done,
            "total": self.total,
        }
        self._emit({"event": "pack", **info})
        if self.mode == "bar" and self.bar is not None:
            self.last = f"{task.label} done: N={n}, phi={pack.phi:.3f}"
            self._refresh()
        elif self.mode == "lines":
            width = len(str(self.total))
            self._line(
                f"[{self.done:>{width}}/{self.total}] {task.label} done: N={n} "
                f"phi={pack.phi:.4f} H={pack.height:.4f} m in {pack.wall_time:.1f} s "
                f"-> {task.path}"
            )

    def _refresh(self) -> None:
        self.bar.n = round(self.done + sum(self.running.values()), 3)
        self.bar.set_postfix_str(self.last, refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.n = self.done
            self.bar.refresh()
            self.bar.close()
            self.bar = None
        self._emit({"event": "end"})


# -- workers ---------------------------------------------------------------------------------

# Set in each local worker process by `_init_worker`: where layer reports go.
_LAYER_QUEUE = None


#: Linux prctl option: the signal a process gets when its parent dies.
_PR_SET_PDEATHSIG = 1


def _die_with_parent(parent: int) -> None:
    """Makes this worker exit when `parent` (the process that runs the ensemble) dies,
    even by SIGKILL: otherwise the workers, and the resource tracker that waits for
    them, live on and hold the parent's stdout and stderr (``granpack ... | tee log``
    never ends). On Linux the kernel sends SIGKILL at the parent's death (prctl
    PR_SET_PDEATHSIG); everywhere a watchdog thread checks the parent twice a second."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass  # the watchdog below still runs

    def watch() -> None:
        while True:
            if os.getppid() != parent:
                os._exit(1)
            time.sleep(0.5)

    # the parent may have died before prctl took effect: the first check is immediate
    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=watch, name="granpack-parent-watchdog", daemon=True).start()


def _init_worker(layer_queue, threads: int, parent: int | None = None) -> None:
    """Runs once in each spawned worker, before any pack: the engine's thread pool is
    created lazily on first use, so the thread count set here takes effect."""
    global _LAYER_QUEUE
    _LAYER_QUEUE = layer_queue
    os.environ["RAYON_NUM_THREADS"] = str(threads)
    # Ctrl-C reaches the whole process group; the parent handles it (it stops the
    # workers), so the workers ignore it instead of each printing a traceback. SIGTERM
    # keeps its default: the parent terminates the workers with it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if parent is not None:
        _die_with_parent(parent)


def _build_in_worker(scene: PackScene, label: str, engine: tuple = ()) -> Pack:
    q = _LAYER_QUEUE

    def report(rep: dict) -> None:
        if q is not None:
            q.put((label, rep))

    return _generate_quietly(scene, report, engine)


def _generate_quietly(scene: PackScene, progress=False, engine: tuple = ()) -> Pack:
    """generate() without its UnsettledPackWarning: the process that saves the pack
    checks it again (`_finish`) and warns there, where the caller sees it. `engine`:
    a task's `PackTask.engine`."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnsettledPackWarning)
        return generate(scene, progress=progress, **dict(engine))


def _build_plain(scene: PackScene, engine: tuple = ()) -> Pack:
    """The Dask task: a pack from its scene (no progress; the pack travels back)."""
    return _generate_quietly(scene, engine=engine)


def _build_and_save(scene: PackScene, path: str, engine: tuple = ()) -> PackSummary:
    """The Dask task with ``write_on_workers``: the pack made and saved (atomically) at
    `path` on the worker; only its summary travels back."""
    pack = _generate_quietly(scene, engine=engine)
    if len(pack) == 0:  # never saved: every later step would fail on it
        raise GranpackError("the pack holds no particle; nothing was saved")
    try:
        pack.save(path)
    except OSError as exc:
        # an OSError's fields do not all survive the trip back; the client prefixes
        # the task's label to this one line
        raise GranpackError(
            f"the worker on {socket.gethostname()} cannot write the pack: {exc}"
        ) from None
    return PackSummary.of(pack, path)


def _existing(task: PackTask) -> bool:
    """True if the task's file holds a whole pack of the same scene; raises if it holds
    another scene, or a pack of a newer format; False if missing or damaged (then it is
    made again)."""
    if not task.path.exists():
        return False
    try:
        # The whole pack is read and checked, not only its scene record: a file whose
        # arrays were damaged on disk is made again instead of being trusted (and
        # failing every later step that reads it).
        pack = load_pack(task.path)
    except GranpackError as exc:
        if NEWER_FORMAT in str(exc):
            raise GranpackError(f"{exc}; or use another output folder") from None
        # A granpack pack whose scene this version cannot read (a newer granpack's key
        # or value) is someone's result, not damage: never made again over it.
        why = scene_record_error(task.path)
        if why is not None:
            raise FileFormatError(
                f"cannot read pack {task.path}: its scene record is one this version of "
                f"granpack cannot read ({why}); a newer granpack wrote it? {NEWER_FORMAT}; "
                "or use another output folder",
                path=task.path,
                reason=f"scene record this version cannot read ({why})",
            ) from None
        # Not a readable pack (written by something else, or damaged on disk): it is
        # replaced, since granpack itself never leaves partial files.
        return False
    if len(pack) == 0:
        # an empty pack is no result (older versions saved one when a flat top removed
        # every particle): made again, which names what is wrong with the scene
        return False
    scene = pack.scene
    if scene != task.scene:
        raise GranpackError(
            f"{task.path} holds a pack of a different scene (seed={scene.seed}, "
            f"stream={scene.stream}, ...) than this run asks for; use another output "
            "folder or remove the file"
        )
    return True


def check_write_on_workers(write_on_workers, scheduler) -> None:
    """Refuses a `write_on_workers` that is not a bool, or True without a scheduler
    (only Dask workers write packs themselves), before any work."""
    if not isinstance(write_on_workers, bool):
        raise InvalidParameterError(
            f"invalid write_on_workers = {write_on_workers!r}: must be True or False",
            parameter="write_on_workers",
        )
    if write_on_workers and scheduler is None:
        raise InvalidParameterError(
            "invalid write_on_workers = True without a scheduler: the Dask workers write "
            "the packs, so give a scheduler (--scheduler ADDRESS), or leave "
            "write_on_workers (--write-on-workers) off",
            parameter="write_on_workers",
        )


def run_tasks(
    tasks: Sequence[PackTask],
    *,
    scheduler=None,
    workers: int | None = None,
    progress: bool | str | Callable[[dict], None] | Progress = "auto",
    write_on_workers: bool = False,
) -> list[Path]:
    """Makes every task's pack that is not on disk yet; returns all tasks' paths (in
    task order). Parameters as in `run_ensemble`."""
    tasks = list(tasks)
    if workers is not None:
        workers = as_int("workers", workers, 1, max_workers())
    check_write_on_workers(write_on_workers, scheduler)
    prog = progress if isinstance(progress, Progress) else Progress(progress)
    pending = []
    for t in tasks:
        if _existing(t):
            prog.skip(t)
        else:
            pending.append(t)
    # Largest packs first, so the last packs to finish are short ones (less idle time).
    pending.sort(key=lambda t: -t.scene.estimated_particles())
    prog.start(len(tasks), len(tasks) - len(pending))
    try:
        if not pending:
            pass
        elif scheduler is not None:
            _run_dask(pending, scheduler, prog, write_on_workers)
        else:
            cores = os.cpu_count() or 1
            # a LAMMPS pack holds `ranks` cores itself: by default as many packs at once
            # as the cores hold
            ranks = max(int(dict(t.engine).get("ranks", 1)) for t in pending)
            n_workers = min(workers or max(1, cores // ranks), len(pending))
            if n_workers == 1:
                _run_here(pending, prog)
            else:
                _run_pool(pending, n_workers, max(1, cores // n_workers), prog)
    finally:
        prog.close()
    return [t.path for t in tasks]


def _finish(task: PackTask, pack: Pack, prog: Progress) -> None:
    if len(pack) == 0:  # never saved: every later step would fail on it
        raise GranpackError(f"{task.label}: the pack holds no particle; nothing was saved")
    pack.save(task.path)
    issue = settling_issue(pack)
    if issue is not None:
        warnings.warn(f"{task.label}: {issue}", UnsettledPackWarning, stacklevel=2)
    prog.pack(task, pack)


def _finish_summary(task: PackTask, summary: PackSummary, prog: Progress) -> None:
    """`_finish` for a pack its worker saved: the warning and the progress from its
    summary, the pack itself not read."""
    if summary.issue is not None:
        warnings.warn(f"{task.label}: {summary.issue}", UnsettledPackWarning, stacklevel=2)
    prog.pack(task, summary)


#: Seconds this process waits for the packs its Dask workers wrote to appear: a network
#: file system may show another host's new file only once its cached view of the
#: folder expires (NFS caches a folder's attributes for up to 60 s by default).
SHARED_FS_WAIT = 90.0


def _check_written(
    written: list[tuple[PackTask, PackSummary]], wait: float = SHARED_FS_WAIT
) -> None:
    """Raises unless every pack the workers wrote is a file this process sees (after
    waiting up to `wait` seconds): with ``write_on_workers`` the folder must be on a
    file system that they share."""
    missing = [(t, s) for t, s in written if not t.path.is_file()]
    deadline = time.monotonic() + wait
    while missing and time.monotonic() < deadline:
        time.sleep(min(2.0, max(0.0, deadline - time.monotonic())))
        missing = [(t, s) for t, s in missing if not t.path.is_file()]
    if missing:
        hosts = sorted({s.host for _, s in missing if s.host})
        shown = ", ".join(f"{t.label} ({s.path})" for t, s in missing[:3])
        more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
        raise GranpackError(
            f"{len(missing)} pack(s) the Dask workers wrote are not visible here after "
            f"{wait:g} s: {shown}{more}, written on {', '.join(hosts) or 'the workers'}; "
            "write_on_workers (--write-on-workers) needs an output folder on a file system "
            "that the workers and this process share"
        )


def _run_here(pending: list[PackTask], prog: Progress) -> None:
    for t in pending:
        try:
            pack = _generate_quietly(
                t.scene, functools.partial(prog.layer, t.label, t.scene.height), t.engine
            )
        except GranpackError as exc:
            raise exc.with_prefix(f"{t.label}: ") from None
        _finish(t, pack, prog)


def _run_pool(pending: list[PackTask], n_workers: int, threads: int, prog: Progress) -> None:
    ctx = mp.get_context("spawn")
    layer_queue = ctx.Queue()
    pool = cf.ProcessPoolExecutor(
        max_workers=n_workers,
        mp_context=ctx,
        initializer=_init_worker,
        initargs=(layer_queue, threads, os.getpid()),
    )
    futures = {pool.submit(_build_in_worker, t.scene, t.label, t.engine): t for t in pending}
    by_label = {t.label: t for t in pending}
    ok = False
    try:
        remaining = set(futures)
        while remaining:
            done, remaining = cf.wait(remaining, timeout=0.25, return_when=cf.FIRST_COMPLETED)
            _drain(layer_queue, by_label, prog)
            for f in done:
                t = futures[f]
                try:
                    pack = f.result()
                except cf.process.BrokenProcessPool:
                    raise GranpackError(
                        f"a worker process died while making {t.label} (out of memory?); "
                        "finished packs are on disk, rerun to continue"
                    ) from None
                except GranpackError as exc:
                    raise exc.with_prefix(f"{t.label}: ") from None
                _finish(t, pack, prog)
        ok = True
    finally:
        if not ok:
            # A failed or interrupted run stops the packs in progress at once instead of
            # waiting for them (minutes for a 3D pack); the finished ones are on disk.
            _terminate_workers(pool)
        pool.shutdown(wait=True, cancel_futures=True)
        layer_queue.close()
        layer_queue.cancel_join_thread()


def _terminate_workers(pool: cf.ProcessPoolExecutor) -> None:
    if hasattr(pool, "terminate_workers"):  # Python >= 3.14
        pool.terminate_workers()
        return
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        proc.terminate()


def _drain(layer_queue, by_label: dict, prog: Progress) -> None:
    while True:
        try:
            label, rep = layer_queue.get_nowait()
        except queue_mod.Empty:
            return
        t = by_label.get(label)
        if t is not None:
            prog.layer(label, t.scene.height, rep)


def _run_dask(
    pending: list[PackTask], scheduler, prog: Progress, write_on_workers: bool = False
) -> None:
    try:
        from distributed import Client, KilledWorker, as_completed
    except ImportError:
        raise GranpackError(
            "--scheduler needs dask.distributed: pip install 'granpack[dask]'"
        ) from None
    own = not isinstance(scheduler, Client)
    if own:
        _check_scheduler_address(scheduler)
        try:
            client = Client(scheduler, timeout="10s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise GranpackError(
                f"cannot connect to the Dask scheduler {scheduler!r}: {exc}"
            ) from None
    else:
        client = scheduler
    futures: list[Any] = []  # Dask futures of Packs, or of PackSummaries
    try:
        by_key = {}
        for t in pending:
            if write_on_workers:
                # absolute: a worker's working folder is not this process's
                f: Any = client.submit(
                    _build_and_save, t.scene, os.path.abspath(t.path), t.engine, pure=False
                )
            else:
                f = client.submit(_build_plain, t.scene, t.engine, pure=False)
            futures.append(f)
            by_key[f.key] = t
        written: list[tuple[PackTask, PackSummary]] = []
        for f in as_completed(futures, loop=client.loop):
            t = by_key[f.key]
            try:
                result = f.result()
            except GranpackError as exc:
                raise exc.with_prefix(f"{t.label}: ") from None
            except KilledWorker:
                raise GranpackError(
                    f"{t.label}: the Dask workers that ran it died (out of memory, or the "
                    "batch job's walltime?); finished packs are on disk, rerun to continue"
                ) from None
            if write_on_workers:
                _finish_summary(t, result, prog)
                written.append((t, result))
            else:
                _finish(t, result, prog)
            f.release()
        _check_written(written)
    finally:
        if futures:
            client.cancel([f for f in futures if not f.done()])
        if own:
            client.close()


#: Seconds to wait for a scheduler's port to answer before giving up.
SCHEDULER_CONNECT_TIMEOUT = 3.0


def _check_scheduler_address(address) -> None:
    """Refuses a scheduler address that is malformed or whose port does not answer, in
    a few seconds and one line, before Dask's own connection (which retries for its
    whole timeout and then raises a long traceback)."""
    text = address if isinstance(address, str) else None
    if text is None:
        raise InvalidParameterError(
            f"invalid scheduler = {type(address).__name__}: expected an address such as "
            "tcp://host:8786 or a distributed.Client",
            parameter="scheduler",
        )
    shown = text if len(text) <= 80 else text[:60] + "..."
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme not in ("tcp", "tls"):
        # inproc://, ucx:// and the like: no cheap check, Dask's own connect decides
        return
    host, colon, port_text = rest.rstrip("/").rpartition(":")
    host = host.strip("[]")
    if not colon or not host or not port_text.isdigit() or not 0 < int(port_text) < 65536:
        raise InvalidParameterError(
            f"invalid scheduler address {shown!r}: expected tcp://HOST:PORT with a port in "
            "[1, 65535] (e.g. tcp://10.0.0.1:8786)",
            parameter="scheduler",
        )
    try:
        with socket.create_connection((host, int(port_text)), SCHEDULER_CONNECT_TIMEOUT):
            pass
    except (OSError, UnicodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise GranpackError(
            f"cannot connect to the Dask scheduler {shown!r}: {reason or type(exc).__name__} "
            f"(no answer within {SCHEDULER_CONNECT_TIMEOUT:g} s); is it running?"
        ) from None
