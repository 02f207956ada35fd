"""Microstructure of a pack (placeholder until the analysis module lands)."""


def microstructure(*args, **kwargs):
    raise NotImplementedError("granpack.microstructure is being written")
