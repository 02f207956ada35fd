//! The names a scene may give its container and its radius law, exported as
//! `_core.CONTAINERS` and `_core.RADIUS_LAWS`: the Python package takes its lists from
//! here, and `_core.pyi`'s `ContainerName` and `RadiusLawName` spell the same names
//! (`tests/test_scene_names.py` compares them).

use crate::pipeline::RadiusLaw;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// The containers a scene may name (`PackScene.container`), one per variant of
/// [`crate::pipeline::world::Container`]: walls all round, periodic horizontal axes,
/// a vertical cylinder.
pub(crate) const CONTAINERS: [&str; 3] = ["box", "periodic", "cylinder"];

/// Adds the name lists to the module, as tuples of strings.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CONTAINERS", PyTuple::new(m.py(), CONTAINERS)?)?;
    m.add("RADIUS_LAWS", PyTuple::new(m.py(), RadiusLaw::NAMES)?)?;
    Ok(())
}
