"""Former home of the container tag, kept for one release: the tag is now part of
`granpack.analysis.container` (`Container.tag_words`, `Container.read_tag`,
`Container.from_tag`, `ContainerTag`). Importing this module warns."""

from __future__ import annotations

import warnings
from pathlib import Path

from .analysis.container import CONTAINERS, Container, ContainerTag

__all__ = ["ContainerTag", "container_tag", "parse_container_tag", "CONTAINER_KINDS"]

warnings.warn(
    "granpack.container_tag is now granpack.analysis.container (Container.tag_words, "
    "Container.read_tag, Container.from_tag, ContainerTag); granpack.container_tag will be "
    "removed in the next release",
    DeprecationWarning,
    stacklevel=2,
)

#: The container kinds a tag names: `granpack.analysis.container.CONTAINERS`.
CONTAINER_KINDS = CONTAINERS


def container_tag(
    kind: str, radius: float | None, lo=None, hi=None, lid: float | None = None
) -> str:
    """The tag's words for a container; now ``Container.tag_words`` (or
    ``ContainerTag(...).words()``)."""
    return ContainerTag(kind, radius, lo, hi, lid).words()


def parse_container_tag(text: str, path: Path, line: int, dim: int) -> ContainerTag | None:
    """The container tag a line names, or None; now ``Container.read_tag``."""
    return Container.read_tag(text, path, line, dim)
