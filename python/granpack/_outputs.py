"""What the runs that write an output folder share (the ``granpack`` commands and the
paper's reproduction): the folder's lock, the checks that keep a run from writing over its
input or its own results, strict JSON, the per-pack records and the development options."""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ._console import Console
from ._contact_model import model_record
from ._validate import GranpackError, InvalidParameterError, check_outputs
from .history import stage_table

#: The lock file of an output folder (see `locked`).
LOCK_NAME = ".granpack.lock"
#: What generate and paper write under --out, besides scene.toml: files, then folders.
RUN_FILES = ("report.md", LOCK_NAME)
RUN_FOLDERS = ("packs", "micro", "tables", "figures")


# -- the output folder -----------------------------------------------------------------------------


@contextlib.contextmanager
def locked(out: Path) -> Iterator[None]:
    """Holds the output folder's lock (an exclusive flock on out/.granpack.lock) while
    a run writes into it: a second run into the same folder is refused at once, instead
    of mixing its packs, tables and report with the first one's. The kernel drops the
    lock when the process ends, however it ends."""
    import fcntl

    out.mkdir(parents=True, exist_ok=True)
    path = out / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EWOULDBLOCK, errno.EACCES, errno.EAGAIN):
                raise
            try:
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip()
            except OSError:
                holder = ""
            who = f" (process {holder})" if holder.isdigit() else ""
            raise GranpackError(
                f"another granpack run{who} is writing into {out}; wait for it to finish "
                "or choose another --out"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)


def same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def refuse_scene_among_outputs(source: Path, out: Path) -> None:
    """Refuses a scene file that the run would write over: one of the files or inside
    one of the folders a run writes under `out` (out/scene.toml itself is the rerun
    from the folder's record, checked by the caller); and an `out` the run cannot write
    (`check_outputs`)."""
    # a folder the run cannot write is refused here, before the work, naming it
    check_outputs([out / f for f in RUN_FILES], [source] if source.exists() else [], "--out")
    if not source.exists():
        return
    where = source.resolve()
    for folder in RUN_FOLDERS:
        if where.is_relative_to((out / folder).resolve()):
            raise InvalidParameterError(
                f"invalid --out = {str(out)!r}: the scene file {source} lies in {out / folder}, "
                "where the run writes its results; move it or choose another --out",
                parameter="out",
                value=str(out),
                expected="a folder whose results do not hold the scene file",
            )


def sweep_temporaries(out: Path, console: Console) -> None:
    """Removes, and names, the temporaries that writes cut off by a kill left in the
    output folder (only files named as granpack's atomic writes name them). Called
    under the folder's lock: no other run is writing there."""
    from ._files import remove_stale_temporaries

    say_removed(remove_stale_temporaries(out), out, console)


def sweep_written(files: Sequence[Path], console: Console) -> None:
    """Removes, and names, the temporaries that a killed write of the same `files` left
    beside them (a command that writes beside its input: export, tile)."""
    from ._files import remove_stale_temporaries

    for folder in sorted({f.parent for f in files}):
        names = [f.name for f in files if f.parent == folder]
        say_removed(remove_stale_temporaries(folder, of=names), folder, console)


def say_removed(removed: list[Path], out: Path, console: Console) -> None:
    """A note naming the stale temporaries removed under `out`, if any."""
    if removed:
        names = ", ".join(str(p.relative_to(out)) for p in removed[:5])
        more = f" and {len(removed) - 5} more" if len(removed) > 5 else ""
        console.note(
            f"removed {len(removed)} stale temporary file(s) that an interrupted run left: "
            f"{names}{more}",
            str(out),
        )
        console.flush_notes()


# -- packs and their records -------------------------------------------------------------------


@contextlib.contextmanager
def unsettled_as_notes(console: Console) -> Iterator[None]:
    """UnsettledPackWarnings raised while a run makes its packs become console notes
    (one line per kind, with the packs it concerns), not warnings with a source line."""
    from .pack import UnsettledPackWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnsettledPackWarning)
        try:
            yield
        finally:
            for w in caught:
                if issubclass(w.category, UnsettledPackWarning):
                    label, _, message = str(w.message).partition(": ")
                    console.note(f"unsettled pack: {message}", label)
                else:
                    warnings.warn(w.message, w.category, stacklevel=2)
            console.flush_notes()


def jsonable(d: dict) -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, np.generic):
            v = v.item()
        elif isinstance(v, np.ndarray):
            v = v.tolist()
        out[k] = v
    return out


def json_text(d: dict) -> str:
    """Strict JSON of a flat dict: an undefined (NaN) quantity is null, so that any JSON
    reader (jq, JavaScript, polars) takes the file."""
    clean = {k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in d.items()}
    return json.dumps(clean, indent=1, allow_nan=False) + "\n"


def micro_record(pack, m, k: int) -> dict:
    """The per-pack record written to micro/pack_k.json: identity, size, and the
    microstructure's scalars."""
    rec = {
        "pack": k,
        "seed": pack.scene.seed,
        "stream": pack.scene.stream,
        "rotations": pack.scene.rotations,
        # the contact model and its constants (docs/contact_models.md)
        **model_record(pack.scene.material),
        "n_particles": len(pack),
        "n_layers": pack.n_layers,
        "height": pack.height,
        "wall_time": pack.wall_time,
    }
    if pack.engine is not None:
        # the engine that ran the layer loop's DEM, where it was not granpack's
        rec.update(
            engine=pack.engine["name"],
            engine_version=pack.engine["version"],
            engine_ranks=pack.engine["ranks"],
        )
    trim = stage_table(pack, "trim")
    if trim is not None:
        rec.update(trim_removed=trim["removed"], trim_top=trim["top"], phi_hd=trim["phi_hd"])
    c = stage_table(pack, "consolidate")
    if c is not None:
        rec.update(
            consolidation_mode=c["mode"],
            lid_stress=c["wall_stress"]["lid"],
            consolidation_k0=c["k0"],
            consolidation_steps=c["steps"],
        )
    d = stage_table(pack, "density")
    if d is not None:
        rec.update(
            density_target=next(iter(d["target"])),
            density_target_value=next(iter(d["target"].values())),
            density_measure=d["measure"],
            density_phi=d["phi"],
            density_method=d["method"],
            density_friction=d["friction"],
            **(
                {"density_rolling_friction": d["rolling_friction"]}
                if "rolling_friction" in d
                else {}
            ),
            density_generations=d["generations"],
        )
        if "e_min" in d:
            rec.update(
                density_e_min=d["e_min"],
                density_e_max=d["e_max"],
                density_relative_density=d["relative_density"],
            )
    rec.update(jsonable(m.to_dict()))
    return rec


def microstructure(console: Console, label: str, *args, **kwargs):
    """granpack.microstructure(...), with its MicrostructureWarnings (an undefined
    quantity, e.g. an empty core window in a small pack) turned into notes that the
    console prints once per message, instead of warnings with a source line."""
    from . import analysis as ms

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ms.MicrostructureWarning)
        m = ms.microstructure(*args, **kwargs)
    for w in caught:
        if issubclass(w.category, ms.MicrostructureWarning):
            console.note(str(w.message), label)
        else:
            warnings.warn(w.message, w.category, stacklevel=2)
    return m


def analyze_packs(paths: Sequence[Path], micro_dir: Path, console: Console) -> list:
    """Loads each pack, computes its microstructure and writes micro/pack_k.json.
    Returns [(pack, microstructure, record)] in order."""
    from ._files import atomic_write
    from .pack import load_pack

    out = []
    for k, path in enumerate(paths):
        pack = load_pack(path)
        m = microstructure(console, f"{path.parent.name}/{path.stem}", pack)
        rec = micro_record(pack, m, k)
        target = micro_dir / (path.stem + ".json")
        atomic_write(target, json_text(rec).encode())
        out.append((pack, m, rec))
    console.flush_notes()
    return out


# -- the development options -----------------------------------------------------------------------


def dev_changes(scene, settle_time: float | None, scale: float | None) -> dict:
    """Scene changes from the hidden development options (--scale, --settle-time)."""
    changes: dict = {}
    if settle_time is not None:
        changes["settle_time"] = settle_time
    if scale is not None:
        changes["base"] = tuple(b * scale for b in scene.base)
        changes["height"] = scene.height * scale
        if scene.cylinder_radius is not None:
            changes["cylinder_radius"] = scene.cylinder_radius * scale
    return changes


def dev_note(settle_time: float | None, scale: float | None) -> dict:
    """The hidden development options in force, for the report's warning."""
    note = {}
    if settle_time is not None:
        note["settle_time"] = f"{settle_time:g} s per layer"
    if scale is not None:
        note["base and height scaled by"] = f"{scale:g}"
    return note
