"""Files written whole or not at all: `atomic_write` writes through a temporary file in
the same folder and a rename, and `remove_stale_temporaries` clears the temporaries a
killed run left behind. Every writer of granpack (packs, exports, tables, figures,
reports) goes through it; it imports nothing of granpack but the error types, so any
module can use it."""

from __future__ import annotations

import errno
import os
import re
import stat
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import BinaryIO

from ._validate import GranpackError

__all__ = ["atomic_write", "is_temporary", "remove_stale_temporaries", "TEMP_SUFFIX"]

#: The temporary files of `atomic_write`: ``.<name>.<8 random characters>.tmp`` beside
#: the file written (the characters are those of `tempfile.mkstemp`).
TEMP_SUFFIX = ".tmp"
_TEMP_NAME = re.compile(r"^\.(.+)\.[a-z0-9_]{8}\.tmp$")


def is_temporary(name: str) -> bool:
    """Whether a file name is that of an `atomic_write` temporary."""
    return _TEMP_NAME.match(name) is not None


def remove_stale_temporaries(folder: str | Path, of: Iterable[str] | None = None) -> list[Path]:
    """Removes the temporaries that writes cut off by a kill left under `folder` (only
    files named as `atomic_write` names them; nothing else is touched) and returns them.
    With `of` (file names), only the temporaries of those files directly in `folder`.
    Call it only where no other write of those files is under way (the command line
    holds the output folder's lock)."""
    removed = []
    targets = None if of is None else set(of)
    if targets is None:
        walk = os.walk(folder)
    else:  # that folder alone, not what lies below it
        walk = iter([(str(folder), [], os.listdir(folder))])
    for dirpath, _dirs, files in walk:
        for name in files:
            p = Path(dirpath) / name
            m = _TEMP_NAME.match(name)
            if m is None or (targets is not None and m.group(1) not in targets):
                continue
            if p.is_file() and not p.is_symlink():
                try:
                    p.unlink()
                except FileNotFoundError:
                    continue
                removed.append(p)
    return sorted(removed)


def atomic_write(path: str | Path, data: bytes | Callable[[BinaryIO], object]) -> Path:
    """Writes `data` to `path` through a temporary file in the same folder and a rename,
    so a reader never sees a half-written file. `data` is the bytes, or a function that
    writes them to the open (binary, seekable) temporary file."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # a file where a folder of the path should be
        raise OSError(errno.ENOTDIR, "a folder of the path is a file", str(path)) from None
    except OSError as exc:
        raise _naming(exc, path) from None
    try:
        mode = path.stat().st_mode
    except OSError:  # missing (the usual case) or unreadable: the rename decides
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        # a rename would replace a device (/dev/null), a pipe or a folder, not write to it
        raise GranpackError(f"cannot write {path}: not a regular file")
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=TEMP_SUFFIX)
    except OSError as exc:
        raise _naming(exc, path) from None
    try:
        with os.fdopen(fd, "wb") as f:
            if callable(data):
                data(f)
            else:
                f.write(data)
            f.flush()
            # mkstemp creates the file 0600; the result gets the mode any other new
            # file would, 0666 less the umask
            os.fchmod(f.fileno(), 0o666 & ~_umask())
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise _naming(exc, path) from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _naming(exc: OSError, path: Path) -> OSError:
    """`exc` as it concerns the file the caller asked for: the same kind of OSError
    (errno and message), naming `path`, not the temporary file that the write went
    through (which is gone) nor nothing at all (a full disk's ENOSPC names no file)."""
    if exc.errno is None:
        return OSError(f"cannot write {path}: {exc}")
    return OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(path))


def _umask() -> int:
    """The process's umask, read without changing it where the system tells it."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)  # elsewhere: set and restore (not thread-safe, but brief)
    os.umask(mask)
    return mask
