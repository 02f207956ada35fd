"""Element tests on a consolidated pack: drained triaxial compression
(`granpack.triaxial`), oedometric loading and unloading (`granpack.oedometer`) and
isotropic compression (`granpack.isotropic_compression`), each recording a table along
its path (`granpack.element_table`), and what a lab report derives from them
(`granpack.element.lab`) with its figures (`granpack.element.figures`).
docs/element_tests.md defines every column and every derived quantity."""

from .run import element_table, isotropic_compression, oedometer, triaxial

__all__ = ["triaxial", "oedometer", "isotropic_compression", "element_table"]
