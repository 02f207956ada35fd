"""The contact table that crosses the Rust/Python boundary."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

__all__ = ["Contacts", "WALL_IDS", "LID_ID"]

#: Wall identifiers used in column `j`: floor, then the low and high side walls.
#: The wall id of the lid of a consolidated pack, in every container.
LID_ID = -6

WALL_IDS = {-1: "floor", -2: "x = lo", -3: "x = hi", -4: "y = lo", -5: "y = hi", -6: "lid"}


@dataclass(frozen=True)
class Contacts:
    """Contacts in force (overlap > 0), one row per contact (M rows).

    Attributes
    ----------
    i : (M,) int64
        First particle.
    j : (M,) int64
        Second particle, or a wall when negative: -1 floor, -2 x = 0, -3 x = L,
        -4 y = 0, -5 y = B2.
    normal : (M, D) float64
        Unit normal from i to j (towards the wall for wall contacts).
    overlap : (M,) float64
        r_i + r_j - |x_j - x_i| (m), > 0.
    force_normal : (M,) float64
        Normal force magnitude (N), >= 0, pushing j away from i.
    force_tangential : (M, D) float64
        Tangential force on j (N), perpendicular to the normal.
    branch : (M, D) float64
        From centre i to centre j; to the contact point for walls (m).
    """

    i: np.ndarray
    j: np.ndarray
    normal: np.ndarray
    overlap: np.ndarray
    force_normal: np.ndarray
    force_tangential: np.ndarray
    branch: np.ndarray

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Contacts:
        """Builds the table from a dict of arrays with the column names above."""
        return cls(**{f.name: np.asarray(d[f.name]) for f in fields(cls)})

    def to_dict(self) -> dict[str, np.ndarray]:
        """The columns as a dict of arrays."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def __len__(self) -> int:
        return int(self.i.shape[0])

    @property
    def dim(self) -> int:
        """Spatial dimension D."""
        return int(self.normal.shape[1])

    @property
    def is_wall(self) -> np.ndarray:
        """(M,) bool: True for particle-wall contacts."""
        return self.j < 0

    def particle_pairs(self) -> Contacts:
        """Only the particle-particle contacts."""
        return self.select(~self.is_wall)

    def select(self, mask: np.ndarray) -> Contacts:
        """Rows where `mask` is True."""
        return Contacts(**{f.name: getattr(self, f.name)[mask] for f in fields(self)})
