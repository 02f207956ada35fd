//! The stages' settings across the boundary (see `scene::stages`): a settings table read
//! into its spec with typed errors that name the key, the spec written back as a dict,
//! `_core.resolve_stage` (the one check of a stage's function), and the names and
//! defaults exported as `_core` constants (`_core.pyi` types them; `tests/stages/`
//! compares them with the Python signatures).

use super::{bad, container_from, MaterialArgs};
use crate::error::Error;
use crate::scene::stages::{
    ConsolidateSpec, DensitySpec, Lateral, Particles, RestSpec, TileSpec, CONSOLIDATE_KEYS,
    CONSOLIDATION_MODES, DEFAULT_DENSITY_TOL, DENSITY_METHODS, MAX_STRESS, MAX_WALL_SPEED,
    MIN_OVERLAP_RATIO, TARGET_KEYS,
};
use crate::scene::Stages;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList, PyString, PyTuple};

fn is_bool(v: &Bound<'_, PyAny>) -> bool {
    v.is_instance_of::<PyBool>()
        || v.get_type()
            .name()
            .is_ok_and(|n| n == "bool_" || n == "bool")
}

/// A real number (Python or NumPy; not a bool), or an error naming `key`.
fn real(key: &str, v: &Bound<'_, PyAny>, unit: &str) -> PyResult<f64> {
    if !is_bool(v) && !v.is_instance_of::<PyString>() {
        if let Ok(x) = v.extract::<f64>() {
            return Ok(x);
        }
        // an integer beyond any float is out of every range
        if let Ok(big) = v.gt(0) {
            if v.extract::<i128>().is_err() && v.call_method0("__index__").is_ok() {
                return Ok(if big {
                    f64::INFINITY
                } else {
                    f64::NEG_INFINITY
                });
            }
        }
    }
    Err(bad(
        key,
        format!("must be a real number{unit}, not {}", short(v)),
    ))
}

/// An integer (Python or NumPy; not a bool, not a float), or an error naming `key`.
fn integer(key: &str, v: &Bound<'_, PyAny>) -> PyResult<i128> {
    if !is_bool(v) {
        if let Ok(x) = v.extract::<i128>() {
            return Ok(x);
        }
    }
    Err(bad(key, format!("must be an integer, not {}", short(v))))
}

fn boolean(key: &str, v: &Bound<'_, PyAny>) -> PyResult<bool> {
    if is_bool(v) {
        return v.is_truthy();
    }
    Err(bad(key, format!("must be true or false, not {}", short(v))))
}

fn text(key: &str, v: &Bound<'_, PyAny>) -> PyResult<String> {
    v.extract::<String>()
        .map_err(|_| bad(key, format!("must be a name, not {}", short(v))))
}

fn short(v: &Bound<'_, PyAny>) -> String {
    let r = v.repr().map(|r| r.to_string()).unwrap_or_default();
    if r.chars().count() > 60 {
        format!("{}...", r.chars().take(57).collect::<String>())
    } else {
        r
    }
}

fn lateral(key: &str, v: &Bound<'_, PyAny>) -> PyResult<Lateral> {
    if let Ok(x) = real(key, v, " (Pa)") {
        return Ok(Lateral::One(x));
    }
    if !v.is_instance_of::<PyString>() {
        if let Ok(items) = v.try_iter() {
            let mut out = Vec::new();
            for item in items {
                out.push(real(key, &item?, " (Pa)")?);
            }
            return Ok(Lateral::Each(out));
        }
    }
    Err(bad(
        key,
        format!(
            "expected a stress (Pa) or (sigma_xx, sigma_yy), not {}",
            short(v)
        ),
    ))
}

/// A `[consolidate]` table (a dict of `CONSOLIDATE_KEYS`, `stress` required) read into
/// its spec, and the table as given with every value typed (what the scene keeps and
/// writes back). None values of the optional keys take their defaults.
pub(super) fn consolidate_spec<'py>(
    table: &Bound<'py, PyAny>,
) -> PyResult<(ConsolidateSpec, Bound<'py, PyDict>)> {
    let py = table.py();
    let Ok(table) = table.cast::<PyDict>() else {
        return Err(bad(
            "consolidate",
            format!(
                "expected a table of consolidation settings ({}), not {}",
                CONSOLIDATE_KEYS.join(", "),
                short(table)
            ),
        ));
    };
    let mut spec = ConsolidateSpec::default();
    let typed = PyDict::new(py);
    let mut keys: Vec<String> = Vec::new();
    for k in table.keys() {
        keys.push(k.extract::<String>().unwrap_or_else(|_| short(&k)));
    }
    let mut unknown: Vec<&String> = keys
        .iter()
        .filter(|k| !CONSOLIDATE_KEYS.contains(&k.as_str()))
        .collect();
    unknown.sort();
    if let Some(k) = unknown.first() {
        return Err(bad(
            &format!("consolidate.{k}"),
            format!(
                "unknown key of the [consolidate] table; known: {}",
                CONSOLIDATE_KEYS.join(", ")
            ),
        ));
    }
    if !keys.iter().any(|k| k == "stress") {
        return Err(PyErr::from(Error::invalid(
            "consolidate.stress",
            "",
            "the table needs its target stress (Pa)",
        )));
    }
    // in the table's own order, so that the scene writes it back as it was given
    for (key, v) in table.iter() {
        let key: String = key.extract()?;
        let key = key.as_str();
        let name = format!("consolidate.{key}");
        let name = name.as_str();
        let optional = matches!(
            key,
            "lateral" | "gravity" | "max_wall_speed" | "dt" | "wall_friction"
        );
        if v.is_none() && optional {
            typed.set_item(key, py.None())?;
            continue;
        }
        match key {
            "stress" => {
                spec.stress = real(name, &v, " (Pa)")?;
                typed.set_item(key, spec.stress)?;
            }
            "mode" => {
                spec.mode = text(name, &v)?;
                typed.set_item(key, &spec.mode)?;
            }
            "lateral" => {
                let l = lateral(name, &v)?;
                match &l {
                    Lateral::One(x) => typed.set_item(key, *x)?,
                    Lateral::Each(xs) => typed.set_item(key, PyList::new(py, xs)?)?,
                }
                spec.lateral = Some(l);
            }
            "gravity" => {
                let g = boolean(name, &v)?;
                spec.gravity = Some(g);
                typed.set_item(key, g)?;
            }
            "stress_tol" => {
                spec.stress_tol = real(name, &v, "")?;
                typed.set_item(key, spec.stress_tol)?;
            }
            "unbalanced_tol" => {
                spec.unbalanced_tol = real(name, &v, "")?;
                typed.set_item(key, spec.unbalanced_tol)?;
            }
            "hold" => {
                spec.hold = integer(name, &v)?;
                typed.set_item(key, spec.hold)?;
            }
            "check_every" => {
                spec.check_every = integer(name, &v)?;
                typed.set_item(key, spec.check_every)?;
            }
            "max_steps" => {
                spec.max_steps = integer(name, &v)?;
                typed.set_item(key, spec.max_steps)?;
            }
            "max_wall_speed" => {
                let x = real(name, &v, " (m/s)")?;
                spec.max_wall_speed = Some(x);
                typed.set_item(key, x)?;
            }
            "gain" => {
                spec.gain = real(name, &v, "")?;
                typed.set_item(key, spec.gain)?;
            }
            "local_damping" => {
                spec.local_damping = real(name, &v, "")?;
                typed.set_item(key, spec.local_damping)?;
            }
            "dt" => {
                let x = real(name, &v, " (s)")?;
                spec.dt = Some(x);
                typed.set_item(key, x)?;
            }
            "wall_friction" => {
                let x = real(name, &v, "")?;
                spec.wall_friction = Some(x);
                typed.set_item(key, x)?;
            }
            _ => unreachable!("every key of CONSOLIDATE_KEYS is read"),
        }
    }
    Ok((spec, typed))
}

/// A stage's error as Python's: an unstable step names the stage's key (`consolidate.dt`).
pub(super) fn stage_error(py: Python<'_>, e: Error, dt_key: &str) -> PyErr {
    if !matches!(e, Error::UnstableTimeStep { .. }) {
        return PyErr::from(e);
    }
    let msg = e
        .to_string()
        .replacen("invalid dt", &format!("invalid {dt_key}"), 1);
    match super::typed_error(py, &msg, e) {
        Ok(err) => {
            // best effort: the class, the message and the fields are right regardless
            let _ = err.value(py).setattr("parameter", dt_key);
            err
        }
        Err(import_failed) => import_failed,
    }
}

fn lateral_to_py<'py>(py: Python<'py>, l: &Option<Lateral>) -> PyResult<Bound<'py, PyAny>> {
    Ok(match l {
        None => py.None().into_bound(py),
        Some(Lateral::One(x)) => x.into_pyobject(py)?.into_any(),
        Some(Lateral::Each(xs)) => PyList::new(py, xs)?.into_any(),
    })
}

/// Every setting of a consolidation, defaults filled in, as a dict (the keys of
/// `CONSOLIDATE_KEYS`).
fn consolidate_to_py<'py>(py: Python<'py>, s: &ConsolidateSpec) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("stress", s.stress)?;
    d.set_item("mode", &s.mode)?;
    d.set_item("lateral", lateral_to_py(py, &s.lateral)?)?;
    d.set_item("gravity", s.gravity)?;
    d.set_item("stress_tol", s.stress_tol)?;
    d.set_item("unbalanced_tol", s.unbalanced_tol)?;
    d.set_item("hold", s.hold)?;
    d.set_item("check_every", s.check_every)?;
    d.set_item("max_steps", s.max_steps)?;
    d.set_item("max_wall_speed", s.max_wall_speed)?;
    d.set_item("gain", s.gain)?;
    d.set_item("local_damping", s.local_damping)?;
    d.set_item("dt", s.dt)?;
    d.set_item("wall_friction", s.wall_friction)?;
    Ok(d)
}

fn rest_to_py<'py>(py: Python<'py>, s: &RestSpec) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("unbalanced_tol", s.unbalanced_tol)?;
    d.set_item("hold", s.hold)?;
    d.set_item("check_every", s.check_every)?;
    d.set_item("max_steps", s.max_steps)?;
    d.set_item("local_damping", s.local_damping)?;
    Ok(d)
}

fn density_to_py<'py>(py: Python<'py>, s: &DensitySpec) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("target_phi", s.target_phi)?;
    d.set_item("target_void_ratio", s.target_void_ratio)?;
    d.set_item("target_relative_density", s.target_relative_density)?;
    d.set_item("density_tol", s.density_tol)?;
    d.set_item("density_method", &s.density_method)?;
    Ok(d)
}

/// The stages a resolved scene lists, as `resolve_scene` returns them: each stage's
/// settings with the defaults filled in, or None.
pub(super) fn stages_to_py<'py>(py: Python<'py>, s: &Stages) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let trim = match &s.trim {
        Some(t) => {
            let t_d = PyDict::new(py);
            t_d.set_item("height", t.height)?;
            Some(t_d)
        }
        None => None,
    };
    d.set_item("trim", trim)?;
    d.set_item(
        "rest",
        s.rest.as_ref().map(|r| rest_to_py(py, r)).transpose()?,
    )?;
    d.set_item(
        "density",
        s.density
            .as_ref()
            .map(|r| density_to_py(py, r))
            .transpose()?,
    )?;
    d.set_item(
        "consolidate",
        s.consolidate
            .as_ref()
            .map(|r| consolidate_to_py(py, r))
            .transpose()?,
    )?;
    Ok(d)
}

fn read_settings<'py>(
    settings: &Bound<'py, PyDict>,
    known: &[&str],
    stage: &str,
) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    let mut out = Vec::new();
    for (k, v) in settings.iter() {
        let k: String = k.extract()?;
        if !known.contains(&k.as_str()) {
            return Err(bad(
                &k,
                format!(
                    "not a setting of the {stage} stage; known: {}",
                    known.join(", ")
                ),
            ));
        }
        out.push((k, v));
    }
    Ok(out)
}

/// Checks a stage's settings as its function gets them (the same checks as the
/// scene's), against `scene` (a `granpack.PackScene`, read by attribute: dim, container,
/// cylinder_radius, material, max_overlap_ratio) and, for the consolidation, the
/// pack's own radii (`r_mean`, `r_min`, m). `stage`: "consolidate", "rest", "density"
/// or "tile". Returns every setting, the defaults filled in; the consolidation's also
/// `walls` (the container's walls in the engine's order, the lid last) and `targets`
/// ((wall, stress) pairs, the lid first). Errors name the key as the scene's table does
/// (`consolidate.max_wall_speed`), `settle`'s and the density target's by their own
/// names.
#[pyfunction]
#[pyo3(signature = (stage, scene, settings, *, r_mean=None, r_min=None))]
fn resolve_stage<'py>(
    stage: &str,
    scene: &Bound<'py, PyAny>,
    settings: &Bound<'py, PyDict>,
    r_mean: Option<f64>,
    r_min: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let py = scene.py();
    let dim: usize = scene.getattr("dim")?.extract()?;
    let name: String = scene.getattr("container")?.extract()?;
    let radius: Option<f64> = scene.getattr("cylinder_radius")?.extract()?;
    let container = container_from(&name, radius)?;
    match stage {
        "consolidate" => {
            let (spec, _) = consolidate_spec(settings.as_any())?;
            spec.validate(dim, &container)?;
            let m: MaterialArgs = scene.getattr("material")?.extract()?;
            let material = m.material()?;
            let r_mean = match r_mean {
                Some(r) => r,
                None => scene.getattr("r_mean")?.extract()?,
            };
            let r_min = match r_min {
                Some(r) => r,
                None => scene.getattr("r_min")?.extract()?,
            };
            let p = Particles {
                r_min,
                r_mean,
                material: &material,
                max_overlap_ratio: scene.getattr("max_overlap_ratio")?.extract()?,
            };
            spec.check_particles(dim, &container, &p)
                .map_err(|e| stage_error(py, e, "consolidate.dt"))?;
            let d = consolidate_to_py(py, &spec)?;
            let walls = crate::scene::stages::wall_names(dim, &container);
            d.set_item("walls", PyList::new(py, &walls)?)?;
            let targets = spec.targets(dim, &container)?;
            d.set_item("targets", PyList::new(py, targets)?)?;
            Ok(d)
        }
        "rest" => {
            let mut spec = RestSpec::default();
            for (k, v) in read_settings(
                settings,
                &[
                    "unbalanced_tol",
                    "hold",
                    "check_every",
                    "max_steps",
                    "local_damping",
                ],
                stage,
            )? {
                match k.as_str() {
                    "unbalanced_tol" => spec.unbalanced_tol = real(&k, &v, "")?,
                    "hold" => spec.hold = integer(&k, &v)?,
                    "check_every" => spec.check_every = integer(&k, &v)?,
                    "max_steps" => spec.max_steps = integer(&k, &v)?,
                    _ => spec.local_damping = real(&k, &v, "")?,
                }
            }
            spec.validate(dim, &container)?;
            rest_to_py(py, &spec)
        }
        "density" => {
            let mut spec = DensitySpec::default();
            let keys = [
                "target_phi",
                "target_void_ratio",
                "target_relative_density",
                "density_tol",
                "density_method",
            ];
            for (k, v) in read_settings(settings, &keys, stage)? {
                if v.is_none() && k != "density_method" {
                    continue;
                }
                match k.as_str() {
                    "target_phi" => spec.target_phi = Some(real(&k, &v, "")?),
                    "target_void_ratio" => spec.target_void_ratio = Some(real(&k, &v, "")?),
                    "target_relative_density" => {
                        spec.target_relative_density = Some(real(&k, &v, "")?)
                    }
                    "density_tol" => spec.density_tol = Some(real(&k, &v, "")?),
                    _ => spec.density_method = text(&k, &v)?,
                }
            }
            spec.validate(dim, &container)?;
            density_to_py(py, &spec)
        }
        "tile" => {
            let mut spec = TileSpec::for_dim(dim);
            for (k, v) in read_settings(settings, &["counts"], stage)? {
                let _ = k;
                let mut counts = Vec::new();
                for item in v
                    .try_iter()
                    .map_err(|_| bad("counts", "expected integers >= 1"))?
                {
                    counts.push(integer("counts", &item?)?);
                }
                spec.counts = counts;
            }
            spec.validate(dim, &container)?;
            let d = PyDict::new(py);
            d.set_item("counts", PyTuple::new(py, &spec.counts)?)?;
            Ok(d)
        }
        other => Err(bad(
            "stage",
            format!("{other:?}, expected \"consolidate\", \"rest\", \"density\" or \"tile\""),
        )),
    }
}

/// Adds the stages' names, bounds and defaults to the module, and `resolve_stage`.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add(
        "CONSOLIDATION_MODES",
        PyTuple::new(py, CONSOLIDATION_MODES)?,
    )?;
    m.add("CONSOLIDATE_KEYS", PyTuple::new(py, CONSOLIDATE_KEYS)?)?;
    m.add("TARGET_KEYS", PyTuple::new(py, TARGET_KEYS)?)?;
    m.add("DENSITY_METHODS", PyTuple::new(py, DENSITY_METHODS)?)?;
    m.add("MAX_STRESS", MAX_STRESS)?;
    m.add("MAX_WALL_SPEED", MAX_WALL_SPEED)?;
    m.add("MIN_OVERLAP_RATIO", MIN_OVERLAP_RATIO)?;
    m.add("DEFAULT_DENSITY_TOL", DEFAULT_DENSITY_TOL)?;
    // the defaults of every optional setting, as the functions' signatures take them
    // (read-only mappings: a caller cannot change a default for everyone)
    let frozen = py.import("types")?.getattr("MappingProxyType")?;
    let c = consolidate_to_py(py, &ConsolidateSpec::default())?;
    c.del_item("stress")?;
    m.add("DEFAULT_CONSOLIDATE", frozen.call1((c,))?)?;
    m.add(
        "DEFAULT_REST",
        frozen.call1((rest_to_py(py, &RestSpec::default())?,))?,
    )?;
    m.add(
        "DEFAULT_DENSITY",
        frozen.call1((density_to_py(py, &DensitySpec::default())?,))?,
    )?;
    m.add_function(wrap_pyfunction!(resolve_stage, m)?)?;
    m.add_function(wrap_pyfunction!(stress_range, m)?)?;
    m.add_function(wrap_pyfunction!(overlap_ratio, m)?)?;
    Ok(())
}

/// The stresses (Pa; N/m in 2D) a consolidation takes for particles of mean radius
/// `r_mean` (m) of effective modulus `e_star` (Pa): (lo, hi), those whose mean contact
/// overlaps between MIN_OVERLAP_RATIO and `max_overlap_ratio` of the radius, hi at most
/// MAX_STRESS.
#[pyfunction]
fn stress_range(dim: usize, r_mean: f64, e_star: f64, max_overlap_ratio: f64) -> (f64, f64) {
    crate::scene::stages::stress_range(dim, r_mean, e_star, max_overlap_ratio)
}

/// The overlap over the radius (-) that a mean contact of two mean particles needs to
/// carry `stress` (Pa; N/m in 2D).
#[pyfunction]
fn overlap_ratio(stress: f64, dim: usize, r_mean: f64, e_star: f64) -> f64 {
    crate::scene::stages::overlap_ratio(stress, dim, r_mean, e_star)
}
