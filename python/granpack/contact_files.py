"""The former home of :func:`read_contacts`, kept so that existing scripts run unchanged:
the contact files of other codes are read by `granpack.io.contacts` now."""

from .io.contacts import COLUMN_NAMES, LAYOUTS, ContactFile, read_contacts

__all__ = ["COLUMN_NAMES", "LAYOUTS", "ContactFile", "read_contacts"]
