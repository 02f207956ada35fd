"""The former home of :func:`read_contacts`: the contact files of other codes are read by
`granpack.io.contacts` now. Importing this module still works for one release, with a
`DeprecationWarning`; import from `granpack.io` (or `granpack`) in new code."""

import warnings

from .io.contacts import COLUMN_NAMES, LAYOUTS, ContactFile, read_contacts

__all__ = ["COLUMN_NAMES", "LAYOUTS", "ContactFile", "read_contacts"]

warnings.warn(
    "granpack.contact_files is now granpack.io; import from granpack.io in new code: "
    "granpack.contact_files is removed in the next release",
    DeprecationWarning,
    stacklevel=2,
)
