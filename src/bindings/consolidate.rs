//! The lid, the loads on the walls and the consolidation stage: the bodies of the
//! stage methods of `Simulation` (see its `#[pymethods]` in `bindings/mod.rs`, and
//! `granpack.consolidation`).

use super::{bad, signal_poll, SimInner};
use crate::math::Real;
use crate::pipeline::consolidate::{consolidate, ConsolidateConfig, ServoTarget};
use crate::pipeline::world::ForceBalance;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Adds the lid at height `z` (m); returns its index in the wall list.
pub(super) fn add_lid(inner: &mut SimInner, z: f64) -> PyResult<usize> {
    Ok(with_world!(inner, w, _D, w.add_lid(z))?)
}

/// Each wall's position (m: a plane's coordinate, the cylinder's radius), the force
/// the particles put on it along its outward normal (N), the stiffness of its contacts
/// (N/m), its contacts, and its area (m^2; NaN where it has none yet: a side wall
/// before the lid).
pub(super) fn walls<'py>(py: Python<'py>, inner: &mut SimInner) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    with_world!(inner, w, _D, {
        w.refresh_forces()?;
        let loads = w.wall_loads();
        let n = w.wall_count();
        let pos: Vec<Real> = (0..n).map(|k| w.wall_position(k)).collect();
        let area: Vec<Real> = (0..n)
            .map(|k| w.wall_area(k).unwrap_or(Real::NAN))
            .collect();
        d.set_item("position", pos.into_pyarray(py))?;
        d.set_item("area", area.into_pyarray(py))?;
        d.set_item(
            "force",
            loads
                .iter()
                .map(|l| l.force)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
        d.set_item(
            "stiffness",
            loads
                .iter()
                .map(|l| l.stiffness)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
        d.set_item(
            "contacts",
            loads
                .iter()
                .map(|l| l.contacts as i64)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
        d.set_item("lid", w.has_lid())?;
    });
    Ok(d)
}

fn balance_dict<'py>(py: Python<'py>, fb: &ForceBalance) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("mean_net", fb.mean_net)?;
    d.set_item("max_net", fb.max_net)?;
    d.set_item("mean_contact", fb.mean_contact)?;
    d.set_item("contacts", fb.contacts)?;
    d.set_item("unbalanced", fb.unbalanced())?;
    d.set_item("max_ratio", fb.max_ratio())?;
    Ok(d)
}

/// The balance of forces: YADE's unbalanced ratio and PFC's maximum ratio.
pub(super) fn force_balance<'py>(
    py: Python<'py>,
    inner: &mut SimInner,
) -> PyResult<Bound<'py, PyDict>> {
    let fb = with_world!(inner, w, _D, {
        w.refresh_forces()?;
        w.force_balance()
    });
    balance_dict(py, &fb)
}

/// Runs the consolidation stage (see `pipeline::consolidate`) with the GIL released;
/// Ctrl-C stops it after the current check (KeyboardInterrupt).
#[allow(clippy::too_many_arguments)]
pub(super) fn consolidate_stage<'py>(
    py: Python<'py>,
    inner: &mut SimInner,
    targets: Vec<(usize, f64)>,
    stress_tol: f64,
    unbalanced_tol: f64,
    hold: u32,
    check_every: u64,
    max_steps: u64,
    max_wall_speed: f64,
    gain: f64,
    local_damping: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let cfg = ConsolidateConfig {
        targets: targets
            .iter()
            .map(|&(wall, stress)| ServoTarget { wall, stress })
            .collect(),
        stress_tol,
        unbalanced_tol,
        hold,
        check_every,
        max_steps,
        max_wall_speed,
        gain,
        local_damping,
    };
    let mut raised = None;
    let report = py.detach(|| {
        let mut poll = signal_poll(&mut raised);
        with_world!(inner, w, _D, consolidate(w, &cfg, &mut poll))
    })?;
    if let Some(e) = raised {
        return Err(e);
    }
    let d = PyDict::new(py);
    d.set_item("converged", report.converged)?;
    d.set_item("steps", report.steps)?;
    d.set_item("max_speed", report.max_speed)?;
    let checks = &report.checks;
    let col = |f: &dyn Fn(&crate::pipeline::ServoCheck) -> f64| -> Vec<f64> {
        checks.iter().map(f).collect()
    };
    let h = PyDict::new(py);
    h.set_item(
        "step",
        checks
            .iter()
            .map(|c| c.step as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    h.set_item("stress_error", col(&|c| c.stress_error).into_pyarray(py))?;
    h.set_item(
        "unbalanced",
        col(&|c| c.balance.unbalanced()).into_pyarray(py),
    )?;
    h.set_item(
        "max_ratio",
        col(&|c| c.balance.max_ratio()).into_pyarray(py),
    )?;
    let stress: Vec<f64> = checks.iter().flat_map(|c| c.stress.clone()).collect();
    let stress = numpy::ndarray::Array2::from_shape_vec((checks.len(), targets.len()), stress)
        .map_err(|e| bad("targets", e))?;
    h.set_item("stress", stress.into_pyarray(py))?;
    d.set_item("history", h)?;
    Ok(d)
}

/// Sets the Coulomb friction coefficient (-) of particles and walls from the next
/// step on (finite, >= 0).
pub(super) fn set_friction(inner: &mut SimInner, friction: f64) -> PyResult<()> {
    Ok(with_world!(inner, w, _D, w.set_friction(friction))?)
}
