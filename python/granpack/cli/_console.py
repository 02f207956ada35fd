"""Where the command talks, under the name the command modules have used
(`granpack._console`)."""

from .._console import Console

__all__ = ["Console"]
