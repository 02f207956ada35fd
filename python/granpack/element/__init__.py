"""Element tests on a consolidated pack: drained triaxial compression, oedometric
loading and unloading, isotropic compression, and what a lab report derives from them
(`granpack.element.lab`, `granpack.element.figures`)."""
