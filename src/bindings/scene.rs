//! The names a scene may give its container and its radius law, exported as
//! `_core.CONTAINERS` and `_core.RADIUS_LAWS`, and the bounds of its counts
//! (`_core.MAX_ATTEMPTS`, `_core.MAX_LAYERS`, `_core.MAX_PARTICLES`) and RSA's saturation
//! (`_core.RSA_SATURATION`, 2D and 3D): the Python package takes them from
//! here, and `_core.pyi`'s `ContainerName` and `RadiusLawName` spell the same names
//! (`tests/test_scene_names.py` compares them).

use crate::scene::{
    rsa_saturation, RadiusLaw, CONTAINERS, MAX_ATTEMPTS, MAX_LAYERS, MAX_PARTICLES,
};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// Adds the name lists to the module, as tuples of strings, and the bounds of the
/// scene's counts.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MAX_ATTEMPTS", MAX_ATTEMPTS)?;
    m.add("MAX_LAYERS", MAX_LAYERS)?;
    m.add("MAX_PARTICLES", MAX_PARTICLES)?;
    m.add("RSA_SATURATION", (rsa_saturation(2), rsa_saturation(3)))?;
    m.add("CONTAINERS", PyTuple::new(m.py(), CONTAINERS)?)?;
    m.add("RADIUS_LAWS", PyTuple::new(m.py(), RadiusLaw::NAMES)?)?;
    Ok(())
}
