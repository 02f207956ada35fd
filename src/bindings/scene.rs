//! The names a scene may give its container and its radius law, exported as
//! `_core.CONTAINERS` and `_core.RADIUS_LAWS`, and the bounds of its counts
//! (`_core.MAX_ATTEMPTS`, `_core.MAX_LAYERS`): the Python package takes them from
//! here, and `_core.pyi`'s `ContainerName` and `RadiusLawName` spell the same names
//! (`tests/test_scene_names.py` compares them).

use crate::pipeline::pack::{MAX_ATTEMPTS, MAX_LAYERS};
use crate::pipeline::RadiusLaw;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// The containers a scene may name (`PackScene.container`), one per variant of
/// [`crate::pipeline::world::Container`]: walls all round, periodic horizontal axes,
/// a vertical cylinder.
pub(crate) const CONTAINERS: [&str; 3] = ["box", "periodic", "cylinder"];

/// Adds the name lists to the module, as tuples of strings, and the bounds of the
/// scene's counts.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MAX_ATTEMPTS", MAX_ATTEMPTS)?;
    m.add("MAX_LAYERS", MAX_LAYERS)?;
    m.add("CONTAINERS", PyTuple::new(m.py(), CONTAINERS)?)?;
    m.add("RADIUS_LAWS", PyTuple::new(m.py(), RadiusLaw::NAMES)?)?;
    Ok(())
}
