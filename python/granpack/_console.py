"""Where the ``granpack`` command talks: results to stdout, progress and notes to stderr."""

from __future__ import annotations

import re
import sys

__all__ = ["Console"]


class Console:
    """Where the command talks: results to stdout, progress to stderr; --quiet keeps
    only errors."""

    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet
        self._notes: dict[str, list[tuple[str, str]]] = {}

    def say(self, text: str) -> None:
        if not self.quiet:
            print(text, flush=True)

    def progress_mode(self) -> str | bool:
        return False if self.quiet else "auto"

    def note(self, message: str, where: str) -> None:
        """Collects a note about `where` (e.g. a pack); `flush_notes` prints each kind
        of note once (the first message in full), with the places it applies to."""
        kind = re.sub(r"\(.*?\)", "", message)  # details (numbers) differ between packs
        self._notes.setdefault(kind, []).append((message, where))

    def flush_notes(self) -> None:
        for items in self._notes.values():
            if self.quiet:
                continue
            message, where = items[0]
            more = f" and {len(items) - 1} more" if len(items) > 1 else ""
            print(f"granpack: note: {message} ({where}{more})", file=sys.stderr, flush=True)
        self._notes.clear()
