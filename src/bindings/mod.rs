//! The only PyO3 code: arrays in and out, error mapping, GIL release.
//!
//! Each class wraps a 2D or 3D engine object behind an enum; a macro dispatches on it.
//! Shapes and values are checked here (and again in the engine); every error reaches
//! Python as a subclass of `granpack.GranpackError` (a `ValueError`), mapped from the
//! engine's error enum in one place (`From<Error> for PyErr`).

use crate::error::Error;
use crate::math::{AngOps, Dim, Real, Spatial, Vector};
use crate::pipeline::world::{geometric_contacts, Contacts};
use crate::pipeline::{LayerPlacer, LayerReport, Packer, RadiusLaw, World};
use crate::scene::{fills_box, Container, Inertia2D, SimConfig};
use crate::scene::{LawSpec, SceneSpec};
use crate::Material;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod scene;
mod stages;

/// The one place where the engine's errors become Python exceptions: each variant has
/// its class in `granpack.errors`, and its fields become keyword arguments (and so
/// attributes) of the exception.
impl From<Error> for PyErr {
    fn from(e: Error) -> PyErr {
        let msg = e.to_string();
        Python::attach(|py| match typed_error(py, &msg, e) {
            Ok(err) => err,
            // only if granpack.errors cannot be imported (a broken install)
            Err(import_failed) => {
                let err = PyValueError::new_err(msg);
                err.set_cause(py, Some(import_failed));
                err
            }
        })
    }
}

fn typed_error(py: Python<'_>, msg: &str, e: Error) -> PyResult<PyErr> {
    let kw = PyDict::new(py);
    let class = match e {
        Error::InvalidParameter {
            name,
            value,
            number,
            expected,
        } => {
            kw.set_item("parameter", name)?;
            match number {
                Some(x) => kw.set_item("value", x)?,
                None => kw.set_item("value", (!value.is_empty()).then_some(value))?,
            }
            kw.set_item("expected", expected)?;
            "InvalidParameterError"
        }
        Error::UnstableTimeStep {
            dt,
            critical,
            r_min,
        } => {
            kw.set_item("dt", dt)?;
            kw.set_item("critical", critical)?;
            kw.set_item("r_min", r_min)?;
            "UnstableTimeStepError"
        }
        Error::Blowup {
            step,
            time,
            particle,
            kind,
            ..
        } => {
            kw.set_item("step", step)?;
            kw.set_item("time", time)?;
            kw.set_item("particle", particle)?;
            kw.set_item("kind", kind.name())?;
            "BlowUpError"
        }
        Error::RsaSaturated {
            layer,
            reached,
            target,
            attempts,
        } => {
            kw.set_item("layer", layer)?;
            kw.set_item("reached", reached)?;
            kw.set_item("target", target)?;
            kw.set_item("attempts", attempts)?;
            "SaturationError"
        }
    };
    let cls = py.import("granpack.errors")?.getattr(class)?;
    Ok(PyErr::from_value(cls.call((msg,), Some(&kw))?))
}

/// Wall time between two checks for signals (Ctrl-C) during a long native call.
const SIGNAL_CHECK_EVERY: std::time::Duration = std::time::Duration::from_millis(100);

/// A poll for the engine's long loops: attaches to the interpreter and runs its
/// signal handlers (Ctrl-C raises KeyboardInterrupt there). Returns false, and keeps
/// the exception in `raised`, when a handler raised: the loop then stops and the
/// caller returns that exception.
fn signal_poll(raised: &mut Option<PyErr>) -> impl FnMut() -> bool + '_ {
    move || {
        Python::attach(|py| match py.check_signals() {
            Ok(()) => true,
            Err(e) => {
                *raised = Some(e);
                false
            }
        })
    }
}

/// A scene key (or material constant) of the wrong type, as `extract` reports it for
/// the `#[derive(FromPyObject)]` structs below ("failed to extract field
/// SceneArgs.skin_ratio", its cause the conversion's error): an InvalidParameterError
/// naming the key as the user spells it ("skin_ratio", "material.young"), as the
/// scene's own checks name it. Other errors pass unchanged.
fn key_type_error(py: Python<'_>, e: PyErr) -> PyErr {
    let mut keys: Vec<String> = Vec::new();
    let mut why = String::new();
    let mut cur = Some(e.clone_ref(py));
    while let Some(err) = cur {
        let text = err.value(py).to_string();
        match text
            .strip_prefix("failed to extract field ")
            .and_then(|rest| rest.split_once('.'))
        {
            Some((_, field)) => keys.push(field.to_string()),
            None => why = text,
        }
        cur = err.cause(py);
    }
    if keys.is_empty() {
        return e;
    }
    let key = keys.join(".");
    PyErr::from(Error::InvalidParameter {
        name: key,
        value: String::new(),
        number: None,
        expected: format!("wrong type ({why})"),
    })
}

fn bad(name: &str, msg: impl std::fmt::Display) -> PyErr {
    let msg = msg.to_string();
    PyErr::from(Error::InvalidParameter {
        name: name.to_string(),
        value: String::new(),
        number: None,
        expected: msg,
    })
}

/// Reads an (N, D) float64 array into vectors.
fn vectors<const D: usize>(name: &str, a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<Vector<D>>> {
    let v = a.as_array();
    if v.ncols() != D {
        return Err(bad(
            name,
            format!("shape {:?}, expected (N, {D})", v.shape()),
        ));
    }
    Ok(v.rows()
        .into_iter()
        .map(|r| Vector::<D>::from_fn(|k, _| r[k]))
        .collect())
}

fn vec_to_py<'py, const D: usize>(py: Python<'py>, v: &[Vector<D>]) -> Bound<'py, PyAny> {
    let flat: Vec<f64> = v.iter().flat_map(|x| x.iter().copied()).collect();
    Array2::from_shape_vec((v.len(), D), flat)
        .expect("shape")
        .into_pyarray(py)
        .into_any()
}

fn ang_to_py<'py, A: AngOps>(py: Python<'py>, w: &[A]) -> Bound<'py, PyAny> {
    if A::NCOMP == 1 {
        Array1::from_iter(w.iter().map(|x| x.comp(0)))
            .into_pyarray(py)
            .into_any()
    } else {
        let flat: Vec<f64> = w
            .iter()
            .flat_map(|x| (0..A::NCOMP).map(|k| x.comp(k)))
            .collect();
        Array2::from_shape_vec((w.len(), A::NCOMP), flat)
            .expect("shape")
            .into_pyarray(py)
            .into_any()
    }
}

fn ang_from_py<A: AngOps>(name: &str, a: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<A>> {
    if A::NCOMP == 1 {
        let arr: PyReadonlyArray1<f64> = a
            .extract()
            .map_err(|_| bad(name, "expected a float64 array of shape (N,) in 2D"))?;
        let v = arr.as_array();
        if v.len() != n {
            return Err(bad(name, format!("length {}, expected {n}", v.len())));
        }
        Ok(v.iter().map(|&x| A::from_comps(&[x])).collect())
    } else {
        let arr: PyReadonlyArray2<f64> = a
            .extract()
            .map_err(|_| bad(name, "expected a float64 array of shape (N, 3) in 3D"))?;
        let v = arr.as_array();
        if v.nrows() != n || v.ncols() != 3 {
            return Err(bad(
                name,
                format!("shape {:?}, expected ({n}, 3)", v.shape()),
            ));
        }
        Ok(v.rows()
            .into_iter()
            .map(|r| A::from_comps(&[r[0], r[1], r[2]]))
            .collect())
    }
}

fn contacts_to_py<'py, const D: usize>(
    py: Python<'py>,
    c: Contacts<D>,
) -> PyResult<Bound<'py, PyDict>> {
    // Taken by value: the index and scalar columns move into numpy without a copy, and
    // each vector column is freed once it is copied (at a million spheres the contacts
    // are 250 MB, held beside the engine's state at the end of a pack).
    let Contacts {
        i,
        j,
        normal,
        overlap,
        force_normal,
        force_tangential,
        branch,
    } = c;
    let d = PyDict::new(py);
    d.set_item("i", Array1::from_vec(i).into_pyarray(py))?;
    d.set_item("j", Array1::from_vec(j).into_pyarray(py))?;
    d.set_item("normal", vec_to_py(py, &normal))?;
    drop(normal);
    d.set_item("overlap", Array1::from_vec(overlap).into_pyarray(py))?;
    d.set_item(
        "force_normal",
        Array1::from_vec(force_normal).into_pyarray(py),
    )?;
    d.set_item("force_tangential", vec_to_py(py, &force_tangential))?;
    drop(force_tangential);
    d.set_item("branch", vec_to_py(py, &branch))?;
    Ok(d)
}

fn report_to_py<'py>(py: Python<'py>, r: &LayerReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("layer", r.layer)?;
    d.set_item("added", r.added)?;
    d.set_item("total", r.total)?;
    d.set_item("phi_rsa", r.phi_rsa)?;
    d.set_item("height", r.height)?;
    d.set_item("steps", r.steps)?;
    d.set_item("kinetic_energy", r.kinetic_energy)?;
    d.set_item("wall_seconds", r.wall_seconds)?;
    d.set_item("frozen", r.frozen)?;
    Ok(d)
}

fn vector_from<const D: usize>(name: &str, v: &[f64]) -> PyResult<Vector<D>> {
    if v.len() != D {
        return Err(bad(name, format!("{} components, expected {D}", v.len())));
    }
    Ok(Vector::<D>::from_fn(|k, _| v[k]))
}

/// The container named `name` (one of [`scene::CONTAINERS`]; a cylinder takes its
/// radius from `radius`).
fn container_from(name: &str, radius: Option<f64>) -> PyResult<Container> {
    match (name, radius) {
        ("box", None) => Ok(Container::Box),
        ("periodic", None) => Ok(Container::Periodic),
        ("cylinder", Some(r)) => Ok(Container::Cylinder(r)),
        ("cylinder", None) => Err(bad(
            "cylinder_radius",
            "None: a cylinder needs its radius (m)",
        )),
        ("box" | "periodic", Some(r)) => Err(bad(
            "cylinder_radius",
            format!("{r}: only container \"cylinder\" has a radius"),
        )),
        (other, _) => Err(bad(
            "container",
            format!("{other:?}, expected \"box\", \"periodic\" or \"cylinder\""),
        )),
    }
}

/// Engine settings as they cross the boundary (the Python layer builds them).
#[allow(clippy::too_many_arguments)]
fn sim_config<const D: usize>(
    material: Material,
    dt: f64,
    gravity: &[f64],
    drag: f64,
    rotations: bool,
    walls: Option<(Vec<f64>, Vec<f64>)>,
    skin_ratio: f64,
    max_overlap_ratio: f64,
    inertia_2d: &str,
    container: Container,
) -> PyResult<SimConfig<D>>
where
    Dim<D>: Spatial<D>,
{
    let walls = match walls {
        None => None,
        Some((lo, hi)) => Some((vector_from::<D>("box", &lo)?, vector_from::<D>("box", &hi)?)),
    };
    let inertia_2d = match inertia_2d {
        "sphere" => Inertia2D::Sphere,
        "disc" => Inertia2D::Disc,
        other => {
            return Err(bad(
                "inertia_2d",
                format!("{other:?}, expected \"sphere\" or \"disc\""),
            ))
        }
    };
    Ok(SimConfig {
        material,
        dt,
        gravity: vector_from::<D>("gravity", gravity)?,
        drag,
        rotations,
        walls,
        container,
        skin_ratio,
        max_overlap_ratio,
        inertia_2d,
    })
}

#[derive(Clone)]
enum SimInner {
    D2(World<2>),
    D3(World<3>),
}

/// Runs `$body` with `$w` bound to the 2D or 3D engine object inside `$self` (an enum
/// with variants `D2` and `D3`) and the constant `$D` set to its dimension.
macro_rules! dispatch {
    ($enum:ident, $self:expr, $w:ident, $D:ident, $body:expr) => {
        match $self {
            $enum::D2($w) => {
                const $D: usize = 2;
                $body
            }
            $enum::D3($w) => {
                const $D: usize = 3;
                $body
            }
        }
    };
}

macro_rules! with_world {
    ($self:expr, $w:ident, $D:ident, $body:expr) => {
        dispatch!(SimInner, $self, $w, $D, $body)
    };
}

mod consolidate;

/// The DEM engine (see `granpack.Simulation` for the documented Python API).
#[pyclass(module = "granpack._core")]
struct Simulation {
    inner: SimInner,
}

#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (dim, material, dt, gravity, drag, rotations, walls, skin_ratio=0.2,
                        max_overlap_ratio=0.5, inertia_2d="disc", container="box",
                        cylinder_radius=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        dim: i64,
        material: MaterialArgs,
        dt: f64,
        gravity: Vec<f64>,
        drag: f64,
        rotations: bool,
        walls: Option<(Vec<f64>, Vec<f64>)>,
        skin_ratio: f64,
        max_overlap_ratio: f64,
        inertia_2d: &str,
        container: &str,
        cylinder_radius: Option<f64>,
    ) -> PyResult<Self> {
        let container = container_from(container, cylinder_radius)?;
        let material = material.material()?;
        macro_rules! make {
            ($D:literal, $variant:ident) => {
                SimInner::$variant(World::new(sim_config::<$D>(
                    material,
                    dt,
                    &gravity,
                    drag,
                    rotations,
                    walls,
                    skin_ratio,
                    max_overlap_ratio,
                    inertia_2d,
                    container,
                )?)?)
            };
        }
        let inner = match dim {
            2 => make!(2, D2),
            3 => make!(3, D3),
            other => return Err(bad("dim", format!("{other}, expected 2 or 3"))),
        };
        Ok(Simulation { inner })
    }

    #[getter]
    fn dim(&self) -> usize {
        with_world!(&self.inner, _w, D, D)
    }

    #[pyo3(signature = (positions, radii, velocities=None, spins=None))]
    fn add_particles(
        &mut self,
        positions: PyReadonlyArray2<'_, f64>,
        radii: PyReadonlyArray1<'_, f64>,
        velocities: Option<PyReadonlyArray2<'_, f64>>,
        spins: Option<Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let r: Vec<f64> = radii.as_array().to_vec();
        with_world!(&mut self.inner, w, D, {
            let x = vectors::<D>("positions", &positions)?;
            let v = match &velocities {
                Some(a) => Some(vectors::<D>("velocities", a)?),
                None => None,
            };
            let s = match &spins {
                Some(a) => Some(ang_from_py::<<Dim<D> as Spatial<D>>::Ang>(
                    "spins",
                    a,
                    x.len(),
                )?),
                None => None,
            };
            w.add_particles(&x, &r, v.as_deref(), s.as_deref())?;
        });
        Ok(())
    }

    /// Advances `n` steps with the GIL released; Ctrl-C stops it within about 0.1 s
    /// (KeyboardInterrupt, the steps taken so far kept).
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        let inner = &mut self.inner;
        let mut raised = None;
        py.detach(|| {
            let mut poll = signal_poll(&mut raised);
            with_world!(
                inner,
                w,
                _D,
                w.step_n_polled(n, SIGNAL_CHECK_EVERY, &mut poll)
            )
        })?;
        raised.map_or(Ok(()), Err)
    }

    /// Advances `seconds` of simulated time with the GIL released; Ctrl-C stops it as
    /// in `step`.
    fn run(&mut self, py: Python<'_>, seconds: f64) -> PyResult<()> {
        let n = with_world!(&self.inner, w, _D, w.steps_for(seconds))?;
        self.step(py, n)
    }

    #[getter]
    fn time(&self) -> f64 {
        with_world!(&self.inner, w, _D, w.time())
    }
    #[getter]
    fn steps(&self) -> u64 {
        with_world!(&self.inner, w, _D, w.steps())
    }
    #[getter]
    fn rebuilds(&self) -> u64 {
        with_world!(&self.inner, w, _D, w.rebuilds())
    }
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        with_world!(&self.inner, w, _D, vec_to_py(py, &w.positions_in_cell()))
    }
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        with_world!(&self.inner, w, _D, vec_to_py(py, w.velocities()))
    }
    #[setter]
    fn set_velocities(&mut self, v: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
        with_world!(&mut self.inner, w, D, {
            let v = vectors::<D>("velocities", &v)?;
            w.set_velocities(&v)?;
        });
        Ok(())
    }
    #[getter]
    fn spins<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        with_world!(&self.inner, w, _D, ang_to_py(py, w.spins()))
    }
    #[setter]
    fn set_spins(&mut self, s: Bound<'_, PyAny>) -> PyResult<()> {
        with_world!(&mut self.inner, w, D, {
            let s = ang_from_py::<<Dim<D> as Spatial<D>>::Ang>("spins", &s, w.len())?;
            w.set_spins(&s)?;
        });
        Ok(())
    }
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        with_world!(
            &self.inner,
            w,
            _D,
            Array1::from_vec(w.radii().to_vec())
                .into_pyarray(py)
                .into_any()
        )
    }
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        with_world!(
            &self.inner,
            w,
            _D,
            Array1::from_vec(w.masses().to_vec())
                .into_pyarray(py)
                .into_any()
        )
    }
    fn kinetic_energy(&self) -> f64 {
        with_world!(&self.inner, w, _D, w.kinetic_energy())
    }
    fn potential_energy(&self) -> f64 {
        with_world!(&self.inner, w, _D, w.potential_energy())
    }
    fn elastic_energy(&self) -> f64 {
        with_world!(&self.inner, w, _D, w.elastic_energy())
    }
    fn critical_time_step(&self) -> f64 {
        with_world!(&self.inner, w, _D, w.critical_time_step())
    }
    fn __len__(&self) -> usize {
        with_world!(&self.inner, w, _D, w.len())
    }
    fn contacts<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        with_world!(&mut self.inner, w, _D, {
            let c = w.contacts()?;
            contacts_to_py(py, c)
        })
    }

    // The consolidation stage's methods (bodies in `consolidate.rs`).

    /// Adds the lid at height `z` (m); returns its index in the wall list.
    fn add_lid(&mut self, z: f64) -> PyResult<usize> {
        consolidate::add_lid(&mut self.inner, z)
    }

    /// Each wall's position (m: a plane's coordinate, the cylinder's radius), the force
    /// the particles put on it along its outward normal (N), the stiffness of its
    /// contacts (N/m), its contacts, and its area (m^2; NaN where it has none yet: a
    /// side wall before the lid).
    fn walls<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        consolidate::walls(py, &mut self.inner)
    }

    /// The balance of forces: YADE's unbalanced ratio and PFC's maximum ratio.
    fn force_balance<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        consolidate::force_balance(py, &mut self.inner)
    }

    /// Runs the consolidation stage (see `pipeline::consolidate`) with the GIL
    /// released; Ctrl-C stops it after the current check (KeyboardInterrupt).
    #[pyo3(signature = (targets, *, stress_tol, unbalanced_tol, hold, check_every, max_steps,
                        max_wall_speed, gain, local_damping))]
    #[allow(clippy::too_many_arguments)]
    fn consolidate<'py>(
        &mut self,
        py: Python<'py>,
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
        consolidate::consolidate_stage(
            py,
            &mut self.inner,
            targets,
            stress_tol,
            unbalanced_tol,
            hold,
            check_every,
            max_steps,
            max_wall_speed,
            gain,
            local_damping,
        )
    }

    /// Runs `steps` steps of the triaxial drive (see `pipeline::shear`) with the GIL
    /// released: the lid (`axial`) moves in at `axial_speed` (m/s) while the side walls
    /// `lateral` hold `confining` (Pa), or, given `mean_stress` instead, the lateral
    /// stress that keeps the walls' mean stress there.
    #[pyo3(signature = (axial, axial_speed, lateral, *, confining=None, mean_stress=None,
                        steps, max_wall_speed, gain, local_damping))]
    #[allow(clippy::too_many_arguments)]
    fn shear(
        &mut self,
        py: Python<'_>,
        axial: usize,
        axial_speed: f64,
        lateral: Vec<usize>,
        confining: Option<f64>,
        mean_stress: Option<f64>,
        steps: u64,
        max_wall_speed: f64,
        gain: f64,
        local_damping: f64,
    ) -> PyResult<()> {
        use crate::pipeline::shear::{shear, Lateral, ShearConfig};
        let target = match (confining, mean_stress) {
            (Some(s), None) => Lateral::Stress(s),
            (None, Some(p)) => Lateral::MeanStress(p),
            _ => {
                return Err(bad(
                    "confining",
                    "give exactly one of confining and mean_stress",
                ))
            }
        };
        let cfg = ShearConfig {
            axial,
            axial_speed,
            lateral,
            target,
            max_wall_speed,
            gain,
            local_damping,
        };
        let inner = &mut self.inner;
        let mut raised = None;
        py.detach(|| {
            let mut poll = signal_poll(&mut raised);
            with_world!(inner, w, _D, shear(w, &cfg, steps, &mut poll))
        })?;
        if let Some(e) = raised {
            return Err(e);
        }
        Ok(())
    }

    /// Sets the Coulomb friction coefficient (-) of particles and walls from the next
    /// step on (finite, >= 0).
    fn set_friction(&mut self, friction: f64) -> PyResult<()> {
        consolidate::set_friction(&mut self.inner, friction)
    }

    /// Gives the walls their own Coulomb friction (-) from the next step on (finite,
    /// >= 0), or the material's again with None.
    #[pyo3(signature = (friction=None))]
    fn set_wall_friction(&mut self, friction: Option<f64>) -> PyResult<()> {
        Ok(with_world!(
            &mut self.inner,
            w,
            _D,
            w.set_wall_friction(friction)
        )?)
    }

    /// Sets the rolling friction coefficient mu_r (-) from the next step on (finite,
    /// >= 0); refused without a rolling model.
    fn set_rolling_friction(&mut self, rolling_friction: f64) -> PyResult<()> {
        Ok(with_world!(
            &mut self.inner,
            w,
            _D,
            w.set_rolling_friction(rolling_friction)
        )?)
    }

    /// A copy of the engine's whole state (particles, pair list and tangential
    /// history, walls, clocks): stepping the copy gives the same bits as stepping the
    /// original.
    #[pyo3(name = "clone")]
    fn copy_state(&self) -> Simulation {
        Simulation {
            inner: self.inner.clone(),
        }
    }
}

enum PackInner {
    D2(Packer<2>),
    D3(Packer<3>),
}

macro_rules! with_packer {
    ($self:expr, $p:ident, $D:ident, $body:expr) => {
        dispatch!(PackInner, $self, $p, $D, $body)
    };
}

/// A `granpack.Material`, read by attribute.
#[derive(FromPyObject)]
pub(super) struct MaterialArgs {
    density: f64,
    young: f64,
    poisson: f64,
    damping: f64,
    friction: f64,
    contact_law: String,
    normal_stiffness: Option<f64>,
    tangential_stiffness: Option<f64>,
    rolling: String,
    rolling_friction: Option<f64>,
    rolling_stiffness: Option<f64>,
    rolling_damping: Option<f64>,
}

impl MaterialArgs {
    /// The engine's material; the keys' ranges are checked by the engine's validator,
    /// their combinations here (the Python `Material` checks both first).
    pub(super) fn material(&self) -> PyResult<Material> {
        use crate::dynamics::material::{ContactLaw, Rolling};
        let law = match (self.contact_law.as_str(), self.normal_stiffness) {
            ("hertz_mindlin", None) if self.tangential_stiffness.is_none() => {
                ContactLaw::HertzMindlin
            }
            ("hertz_mindlin", _) => {
                return Err(bad(
                    "normal_stiffness",
                    "given with contact_law = \"hertz_mindlin\": only the linear law takes \
                     the stiffness keys"
                        .to_string(),
                ))
            }
            ("linear", Some(kn)) => ContactLaw::Linear {
                kn,
                // Mindlin's ratio of the two stiffnesses, 2 (1 - nu) / (2 - nu)
                kt: self
                    .tangential_stiffness
                    .unwrap_or(kn * 2.0 * (1.0 - self.poisson) / (2.0 - self.poisson)),
            },
            ("linear", None) => {
                return Err(bad(
                    "normal_stiffness",
                    "None: the linear law needs k_n (N/m), > 0".to_string(),
                ))
            }
            (other, _) => {
                return Err(bad(
                    "contact_law",
                    format!("{other:?}, expected \"hertz_mindlin\" or \"linear\""),
                ))
            }
        };
        let given = self.rolling_friction.is_some()
            || self.rolling_stiffness.is_some()
            || self.rolling_damping.is_some();
        let rolling =
            match (self.rolling.as_str(), self.rolling_friction) {
                ("none", _) if !given => Rolling::None,
                ("none", _) => return Err(bad(
                    "rolling_friction",
                    "given with rolling = \"none\": only a rolling model takes the rolling keys"
                        .to_string(),
                )),
                ("epsd", Some(mu_r)) => Rolling::Epsd {
                    mu_r,
                    k_r: self.rolling_stiffness,
                    gamma_r: self.rolling_damping.unwrap_or(0.0),
                },
                ("epsd", None) => {
                    return Err(bad(
                        "rolling_friction",
                        "None: rolling = \"epsd\" needs mu_r >= 0".to_string(),
                    ))
                }
                (other, _) => {
                    return Err(bad(
                        "rolling",
                        format!("{other:?}, expected \"none\" or \"epsd\""),
                    ))
                }
            };
        let m = Material {
            density: self.density,
            young: self.young,
            poisson: self.poisson,
            damping: self.damping,
            friction: self.friction,
            law,
            rolling,
        };
        Ok(m)
    }
}

/// The radius-law keys of a `granpack.PackScene`, read by attribute (the scene's own
/// names: errors name them as the user wrote them).
#[derive(FromPyObject)]
struct LawArgs {
    dim: i64,
    inertia_2d: String,
    radius_law: String,
    r_mean: f64,
    r_std: f64,
    r_min: Option<f64>,
    r_max: Option<f64>,
    radii: Option<Vec<f64>>,
    fractions: Option<Vec<f64>>,
    fractions_by: String,
    sieve_sizes: Option<Vec<f64>>,
    sieve_passing: Option<Vec<f64>>,
}

impl LawArgs {
    fn spec(self) -> LawSpec {
        LawSpec {
            radius_law: self.radius_law,
            r_mean: self.r_mean,
            r_std: self.r_std,
            r_min: self.r_min,
            r_max: self.r_max,
            radii: self.radii,
            fractions: self.fractions,
            fractions_by: self.fractions_by,
            sieve_sizes: self.sieve_sizes,
            sieve_passing: self.sieve_passing,
        }
    }

    /// The law, checked by the scene's validator.
    fn law(self) -> PyResult<RadiusLaw> {
        let exponent = if self.dim == 2 && self.inertia_2d == "disc" {
            2
        } else {
            3
        };
        Ok(self.spec().law(exponent)?)
    }
}

/// The keys of a `granpack.PackScene` that are not the radius law's, read by attribute
/// (the radius law's keys are read into [`LawArgs`]); the integers wider than the
/// engine's, so that a value out of range is refused by the validator, by name.
#[derive(FromPyObject)]
struct SceneArgs<'py> {
    dim: i64,
    base: Vec<f64>,
    container: String,
    cylinder_radius: Option<f64>,
    height: f64,
    h_layer: f64,
    phi_layer: f64,
    material: MaterialArgs,
    dt: f64,
    settle_time: f64,
    gravity: f64,
    drag: f64,
    rotations: bool,
    seed: i128,
    stream: i128,
    inertia_2d: String,
    skin_ratio: f64,
    max_overlap_ratio: f64,
    max_attempts: i128,
    max_layers: i128,
    settle_tol: Option<f64>,
    settle_dt: Option<f64>,
    freeze_depth: Option<f64>,
    freeze_speed: f64,
    freeze_force: f64,
    trim: bool,
    rest_tol: Option<f64>,
    target_phi: Option<f64>,
    target_void_ratio: Option<f64>,
    target_relative_density: Option<f64>,
    density_tol: Option<f64>,
    density_method: String,
    consolidate: Option<Bound<'py, PyAny>>,
}

/// A `granpack.PackScene` as the scene's validator takes it, and its `[consolidate]`
/// table as given with its values typed.
fn scene_spec<'py>(scene: &Bound<'py, PyAny>) -> PyResult<(SceneSpec, Option<Bound<'py, PyDict>>)> {
    let s: SceneArgs = scene.extract().map_err(|e| key_type_error(scene.py(), e))?;
    let (consolidate, table) = match &s.consolidate {
        Some(t) => {
            let (spec, typed) = stages::consolidate_spec(t)?;
            (Some(spec), Some(typed))
        }
        None => (None, None),
    };
    let law = scene
        .extract::<LawArgs>()
        .map_err(|e| key_type_error(scene.py(), e))?
        .spec();
    let material = s.material.material()?;
    let spec = SceneSpec {
        dim: s.dim,
        base: s.base,
        container: s.container,
        cylinder_radius: s.cylinder_radius,
        height: s.height,
        law,
        h_layer: s.h_layer,
        phi_layer: s.phi_layer,
        material,
        dt: s.dt,
        settle_time: s.settle_time,
        gravity: s.gravity,
        drag: s.drag,
        rotations: s.rotations,
        seed: s.seed,
        stream: s.stream,
        inertia_2d: s.inertia_2d,
        skin_ratio: s.skin_ratio,
        max_overlap_ratio: s.max_overlap_ratio,
        max_attempts: s.max_attempts,
        max_layers: s.max_layers,
        settle_tol: s.settle_tol,
        settle_dt: s.settle_dt,
        freeze_depth: s.freeze_depth,
        freeze_speed: s.freeze_speed,
        freeze_force: s.freeze_force,
        trim: s.trim,
        rest_tol: s.rest_tol,
        target_phi: s.target_phi,
        target_void_ratio: s.target_void_ratio,
        target_relative_density: s.target_relative_density,
        density_tol: s.density_tol,
        density_method: s.density_method,
        consolidate,
    };
    Ok((spec, table))
}

/// Checks a whole scene (`granpack.PackScene`, read by attribute) with the scene's one
/// validator, the same checks as `LayerPacker(scene)` and more, and returns what it
/// resolves to: r_min, r_max, r_mean, r_std (m), base (m), cylinder_radius (m or
/// None), critical_dt (s), estimated_particles; `consolidate`, the scene's table as
/// given with its values typed (None without one); and `stages`, every stage the scene
/// lists with its settings, defaults filled in (`trim`, `rest`, `density`,
/// `consolidate`; None where the scene does not run it). The error names the scene key
/// (`consolidate.KEY` for the table's).
#[pyfunction]
fn resolve_scene<'py>(scene: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let py = scene.py();
    let (spec, table) = scene_spec(scene)?;
    let r = spec.resolve().map_err(|e| match e {
        // the scene's own step is checked first: an unstable step of another value is
        // the consolidation's
        Error::UnstableTimeStep { dt, .. } if dt != spec.dt => {
            stages::stage_error(py, e, "consolidate.dt")
        }
        e => PyErr::from(e),
    })?;
    let d = PyDict::new(py);
    d.set_item("r_min", r.r_min)?;
    d.set_item("r_max", r.r_max)?;
    d.set_item("r_mean", r.r_mean)?;
    d.set_item("r_std", r.r_std)?;
    d.set_item("base", r.base)?;
    d.set_item("cylinder_radius", r.cylinder_radius)?;
    d.set_item("critical_dt", r.critical_dt)?;
    d.set_item("estimated_particles", r.estimated_particles)?;
    d.set_item("consolidate", table)?;
    d.set_item("stages", stages::stages_to_py(py, &r.stages)?)?;
    Ok(d)
}

/// Number fractions of a scene's discrete radii or sieve classes (as `radii` or the
/// classes between consecutive `sieve_sizes`), after any conversion from mass; None
/// for the other laws.
#[pyfunction]
fn number_fractions(scene: &Bound<'_, PyAny>) -> PyResult<Option<Vec<f64>>> {
    let law = scene
        .extract::<LawArgs>()
        .map_err(|e| key_type_error(scene.py(), e))?
        .law()?;
    Ok(match law {
        RadiusLaw::Discrete(d) => Some(d.number_fractions().to_vec()),
        RadiusLaw::Sieve(s) => Some(s.number_fractions().to_vec()),
        _ => None,
    })
}

/// Most radii one `sample_radii` call draws.
const MAX_SAMPLES: u64 = 100_000_000;

/// `n` radii (m) drawn from a scene's radius law with the engine's sampler, from the
/// stream (seed, stream) of the layer loop's generator (a pack of that seed draws
/// other numbers too, so these are not its radii).
#[pyfunction]
#[pyo3(signature = (scene, n, seed=0, stream=0))]
fn sample_radii<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    n: u64,
    seed: u64,
    stream: u64,
) -> PyResult<Bound<'py, PyAny>> {
    use rand::SeedableRng;
    let law = scene
        .extract::<LawArgs>()
        .map_err(|e| key_type_error(scene.py(), e))?
        .law()?;
    if n > MAX_SAMPLES {
        return Err(Error::invalid("n", n, &format!("must be <= {MAX_SAMPLES}")).into());
    }
    let r: Vec<f64> = py.detach(|| {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        (0..n).map(|_| law.sample(&mut rng)).collect()
    });
    Ok(Array1::from_vec(r).into_pyarray(py).into_any())
}

enum PlacerInner {
    D2(LayerPlacer<2>),
    D3(LayerPlacer<3>),
}

/// The layer loop's placement alone (random sequential addition of one loose layer),
/// for an engine outside granpack that jams each layer (`granpack.mpi`). Seeded as
/// `LayerPacker` is: on the same particles beneath, each layer is the one the native
/// layer loop places, in the same order.
#[pyclass(module = "granpack._core", name = "LayerPlacer")]
struct PyLayerPlacer {
    inner: PlacerInner,
}

#[pymethods]
impl PyLayerPlacer {
    /// The placement of `scene` (a `granpack.PackScene`, read by attribute and
    /// validated as `LayerPacker(scene)` validates it).
    #[new]
    fn new(scene: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (spec, _) = scene_spec(scene)?;
        let inner = match spec.dim {
            2 => PlacerInner::D2(LayerPlacer::new(spec.checked_config::<2>()?)?),
            3 => PlacerInner::D3(LayerPlacer::new(spec.checked_config::<3>()?)?),
            other => return Err(bad("dim", format!("{other}, expected 2 or 3"))),
        };
        Ok(PyLayerPlacer { inner })
    }

    /// Layers placed so far.
    #[getter]
    fn layers(&self) -> usize {
        dispatch!(PlacerInner, &self.inner, p, _D, p.layers())
    }

    /// The next layer on top of the particles `positions` (N, D) and `radii` (N,) (m),
    /// whose height max(z + r) is `height` (m): (positions (M, D), radii (M,)) of the
    /// new layer, in Morton order (GIL released; Ctrl-C raises KeyboardInterrupt and
    /// the placer is then spent). Only the particles whose top lies above `height` -
    /// 2 r_max can touch the new slab: any subset that holds them gives the same layer.
    fn place<'py>(
        &mut self,
        py: Python<'py>,
        positions: PyReadonlyArray2<'py, f64>,
        radii: PyReadonlyArray1<'py, f64>,
        height: f64,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let r: Vec<f64> = radii.as_array().to_vec();
        let inner = &mut self.inner;
        let mut raised = None;
        let out = dispatch!(PlacerInner, inner, p, D, {
            let x = vectors::<D>("positions", &positions)?;
            let placed = py.detach(|| {
                let mut poll = signal_poll(&mut raised);
                p.place_polled((&x, &r), height, &mut poll)
            })?;
            match (placed, raised) {
                (_, Some(e)) => Err(e),
                (Some((x, r)), None) => Ok((
                    vec_to_py(py, &x),
                    Array1::from_vec(r).into_pyarray(py).into_any(),
                )),
                (None, None) => Err(PyRuntimeError::new_err("the placement was stopped midway")),
            }
        });
        out
    }
}

/// The layer packer's state as `LayerPacker.state` and `finish` give it: positions,
/// velocities, spins, radii, layer, time.
fn packer_state_to_py<'py, const D: usize, A: AngOps>(
    py: Python<'py>,
    positions: &[Vector<D>],
    velocities: &[Vector<D>],
    spins: &[A],
    radii: Vec<f64>,
    layer: &[u32],
    time: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("positions", vec_to_py(py, positions))?;
    d.set_item("velocities", vec_to_py(py, velocities))?;
    d.set_item("spins", ang_to_py(py, spins))?;
    d.set_item("radii", Array1::from_vec(radii).into_pyarray(py))?;
    let layer: Vec<i64> = layer.iter().map(|&l| l as i64).collect();
    d.set_item("layer", Array1::from_vec(layer).into_pyarray(py))?;
    d.set_item("time", time)?;
    Ok(d)
}

/// The layer loop (see `granpack.generate` for the documented Python API).
#[pyclass(module = "granpack._core")]
struct LayerPacker {
    /// None once `finish` has moved the pack out.
    inner: Option<PackInner>,
}

impl LayerPacker {
    fn packer(&self) -> PyResult<&PackInner> {
        self.inner.as_ref().ok_or_else(spent)
    }

    fn packer_mut(&mut self) -> PyResult<&mut PackInner> {
        self.inner.as_mut().ok_or_else(spent)
    }
}

/// The error of a LayerPacker used after `finish`.
fn spent() -> PyErr {
    PyRuntimeError::new_err(
        "the layer packer is finished: its state moved into the pack (LayerPacker.finish)",
    )
}

#[pymethods]
impl LayerPacker {
    /// The layer loop of `scene` (a `granpack.PackScene`, read by attribute and
    /// validated here).
    #[new]
    fn new(scene: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (spec, _) = scene_spec(scene)?;
        let inner = match spec.dim {
            2 => PackInner::D2(Packer::new(spec.checked_config::<2>()?)?),
            3 => PackInner::D3(Packer::new(spec.checked_config::<3>()?)?),
            other => return Err(bad("dim", format!("{other}, expected 2 or 3"))),
        };
        Ok(LayerPacker { inner: Some(inner) })
    }

    /// True once the pack has reached the desired height.
    #[getter]
    fn done(&self) -> PyResult<bool> {
        Ok(with_packer!(self.packer()?, p, _D, p.done()))
    }

    #[getter]
    fn height(&self) -> PyResult<f64> {
        Ok(with_packer!(self.packer()?, p, _D, p.height()))
    }

    /// Places and settles one layer (GIL released); returns its report as a dict.
    /// Ctrl-C stops the layer within about 0.1 s (KeyboardInterrupt); the packer is
    /// then spent.
    fn next_layer<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let inner = self.packer_mut()?;
        let mut raised = None;
        let rep = py.detach(|| {
            let mut poll = signal_poll(&mut raised);
            with_packer!(inner, p, _D, p.next_layer_polled(&mut poll))
        })?;
        // A handler that raised wins over a finished layer: the signal came during
        // the layer's last chunk, and the caller must still see it.
        match (rep, raised) {
            (_, Some(e)) => Err(e),
            (Some(rep), None) => report_to_py(py, &rep),
            // (unreachable: the poll stops a layer only when a handler raised)
            (None, None) => Err(PyRuntimeError::new_err("the layer was stopped midway")),
        }
    }

    /// The flat top, after the last layer: removes every particle whose top lies above
    /// `height` (m) and relaxes the rest as the final relax does (GIL released; Ctrl-C
    /// as in next_layer). Returns {"removed", "steps", "height"}.
    fn trim<'py>(&mut self, py: Python<'py>, height: f64) -> PyResult<Bound<'py, PyDict>> {
        // A height below every particle's top would leave an empty pack: refused, with
        // the range that keeps particles (the engine's own checks come first).
        let (done, lowest) = with_packer!(self.packer()?, p, D, {
            let v = <Dim<D> as Spatial<D>>::VERTICAL;
            let w = p.world();
            let lowest = w
                .positions()
                .iter()
                .zip(w.radii())
                .map(|(x, r)| x[v] + r)
                .fold(f64::INFINITY, f64::min);
            (p.done(), lowest)
        });
        if done && height.is_finite() && height > 0.0 && lowest > height {
            return Err(Error::invalid(
                "height",
                height,
                &format!(
                    "a flat top (trim) at this height keeps no particle: every particle's \
                     top lies above it, the lowest at {lowest} m; give height >= {lowest} m \
                     (or no trim)"
                ),
            )
            .into());
        }
        let inner = self.packer_mut()?;
        let mut raised = None;
        let out = py.detach(|| {
            let mut poll = signal_poll(&mut raised);
            with_packer!(inner, p, _D, p.trim_polled(height, &mut poll))
        })?;
        match (out, raised) {
            (_, Some(e)) => Err(e),
            (Some((removed, steps)), None) => {
                let d = PyDict::new(py);
                d.set_item("removed", removed)?;
                d.set_item("steps", steps)?;
                d.set_item("height", with_packer!(self.packer()?, p, _D, p.height()))?;
                Ok(d)
            }
            (None, None) => Err(PyRuntimeError::new_err("the relax was stopped midway")),
        }
    }

    /// Bytes of the engine's state by group (`World::memory`: particles,
    /// wall_contacts, pair_list, incidence) and the layer loop's own (`layers`: each
    /// particle's layer), with the particle and pair counts they are for.
    fn memory<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        with_packer!(self.packer()?, p, _D, {
            let w = p.world();
            for (name, bytes) in w.memory() {
                d.set_item(name, bytes)?;
            }
            d.set_item("layers", std::mem::size_of_val(p.layers()))?;
            d.set_item("particles_count", w.len())?;
            d.set_item("pairs_count", w.pair_counts().0)?;
        });
        Ok(d)
    }

    /// Particle arrays: positions, radii, velocities, spins, layer.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        with_packer!(self.packer()?, p, _D, {
            let w = p.world();
            packer_state_to_py(
                py,
                &w.positions_in_cell(),
                w.velocities(),
                w.spins(),
                w.radii().to_vec(),
                p.layers(),
                w.time(),
            )
        })
    }

    fn contacts<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        with_packer!(self.packer_mut()?, p, _D, {
            let c = p.world_mut().contacts()?;
            contacts_to_py(py, c)
        })
    }

    /// The finished pack: (state, contacts), as `state()` and `contacts()` give them,
    /// with the packer spent to make them (GIL released while the contacts are
    /// written): the engine's pair state is freed as the contact table grows, so the
    /// two are never held whole at once. Every later call raises RuntimeError.
    fn finish<'py>(
        &mut self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let inner = self.inner.take().ok_or_else(spent)?;
        dispatch!(PackInner, inner, p, _D, {
            let done = py.detach(|| p.finish())?;
            let st = done.state;
            let d = packer_state_to_py(
                py,
                &st.positions,
                &st.velocities,
                &st.spins,
                st.radii,
                &done.layer,
                st.time,
            )?;
            Ok((d, contacts_to_py(py, done.contacts)?))
        })
    }
}

/// Geometric contacts (overlap > 0) of a pack given by positions and radii, with the
/// box walls if `walls` is given (floor and side walls; the top is open); forces are
/// zero. Uses the cell grid; no dynamics, so any overlap is accepted. `periodic` (one
/// flag per horizontal axis) makes axes of the box periodic: pairs by minimum image,
/// no walls there. `cylinder` (a radius, 3D) replaces the side walls by a vertical
/// cylinder with its axis through lo + (R, R).
#[pyfunction]
#[pyo3(signature = (positions, radii, walls=None, periodic=None, cylinder=None))]
fn find_contacts<'py>(
    py: Python<'py>,
    positions: PyReadonlyArray2<'py, f64>,
    radii: PyReadonlyArray1<'py, f64>,
    walls: Option<(Vec<f64>, Vec<f64>)>,
    periodic: Option<Vec<bool>>,
    cylinder: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let dim = positions.as_array().ncols();
    let r: Vec<Real> = radii.as_array().to_vec();
    macro_rules! go {
        ($D:literal) => {{
            let x = vectors::<$D>("positions", &positions)?;
            if r.len() != x.len() || !r.iter().all(|&v| v.is_finite() && v > 0.0) {
                return Err(bad(
                    "radii",
                    format!("expected {} finite values > 0 (m)", x.len()),
                ));
            }
            if !x.iter().all(|p| p.iter().all(|c| c.is_finite())) {
                return Err(bad("positions", "must be finite (m)"));
            }
            for k in 0..$D {
                let (lo, hi) = x
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                        (l.min(p[k]), h.max(p[k]))
                    });
                if x.len() > 1 && !(hi - lo).is_finite() {
                    return Err(bad(
                        "positions",
                        format!("axis {k} spans [{lo:e}, {hi:e}] m, whose length overflows"),
                    ));
                }
            }
            let box_ = match walls {
                Some((lo, hi)) => Some((
                    vector_from::<$D>("box", &lo)?,
                    vector_from::<$D>("box", &hi)?,
                )),
                None => None,
            };
            let flags = periodic.clone().unwrap_or_else(|| vec![false; $D - 1]);
            if flags.len() != $D - 1 {
                return Err(bad(
                    "periodic",
                    format!(
                        "{} flags, expected one per horizontal axis ({})",
                        flags.len(),
                        $D - 1
                    ),
                ));
            }
            if box_.is_none() && (flags.iter().any(|&f| f) || cylinder.is_some()) {
                return Err(bad(
                    if cylinder.is_some() {
                        "cylinder"
                    } else {
                        "periodic"
                    },
                    "needs the box (walls) whose sides it replaces",
                ));
            }
            let r_max = r.iter().cloned().fold(0.0, f64::max);
            if let Some((lo, hi)) = &box_ {
                for (a, &f) in flags.iter().enumerate() {
                    // one nearest image per pair: a period above twice the largest cutoff
                    if f && (hi[a] - lo[a] <= 4.0 * r_max || (hi[a] - lo[a]).is_nan()) {
                        return Err(bad(
                            "periodic",
                            format!(
                                "axis {a} has period {} m: must exceed 4 r_max = {} m",
                                hi[a] - lo[a],
                                4.0 * r_max
                            ),
                        ));
                    }
                }
                if let Some(radius) = cylinder {
                    if $D != 3 || flags.iter().any(|&f| f) {
                        return Err(bad(
                            "cylinder",
                            "a cylinder needs 3D positions and no periodic axis",
                        ));
                    }
                    if !(radius.is_finite() && radius > 0.0) {
                        return Err(bad(
                            "cylinder",
                            format!("{radius}: must be a radius > 0 (m)"),
                        ));
                    }
                    for a in 0..2 {
                        let side = hi[a] - lo[a];
                        if !fills_box(side, radius) {
                            return Err(bad(
                                "walls",
                                format!(
                                    "side {side} m on axis {a}: a cylinder of radius {radius} m \
                                     fills a box of side 2R = {} m",
                                    2.0 * radius
                                ),
                            ));
                        }
                    }
                }
                for (k, p) in x.iter().enumerate() {
                    // the top is open: only the floor and the side walls bound the pack
                    let out = (0..$D).any(|a| {
                        let lateral = a + 1 < $D;
                        if lateral && (flags[a] || cylinder.is_some()) {
                            return false;
                        }
                        p[a] < lo[a] || (lateral && p[a] > hi[a])
                    });
                    let outside_cylinder = cylinder.is_some_and(|radius| {
                        let (u, v) = (p[0] - lo[0] - radius, p[1] - lo[1] - radius);
                        u * u + v * v > radius * radius
                    });
                    if out || outside_cylinder {
                        return Err(bad(
                            &format!("positions[{k}]"),
                            format!("{:?}: centre lies outside the container", p.as_slice()),
                        ));
                    }
                }
            }
            let c = py.detach(|| geometric_contacts::<$D>(&x, &r, box_, &flags, cylinder))?;
            contacts_to_py(py, c)
        }};
    }
    match dim {
        2 => go!(2),
        3 => go!(3),
        other => Err(bad(
            "positions",
            format!("{other} columns, expected 2 or 3"),
        )),
    }
}

/// Rayleigh critical time step (s) for material and smallest radius r_min (m).
#[pyfunction]
fn rayleigh_time_step(density: f64, young: f64, poisson: f64, r_min: f64) -> PyResult<f64> {
    let m = Material {
        density,
        young,
        poisson,
        ..Material::default()
    };
    m.validate()?;
    crate::error::check_range("r_min", r_min, 0.0, false, f64::INFINITY, false)?;
    Ok(m.rayleigh_time_step(r_min))
}

/// The critical time step (s) of a `granpack.Material` for the smallest radius r_min
/// (m): the Rayleigh step, or the linear law's, shortened by a rolling spring
/// (`Material::critical_time_step`).
#[pyfunction]
fn critical_time_step(material: MaterialArgs, r_min: f64) -> PyResult<f64> {
    let m = material.material()?;
    m.validate()?;
    crate::error::check_range("r_min", r_min, 0.0, false, f64::INFINITY, false)?;
    Ok(m.critical_time_step(r_min))
}

/// The instruction-set level the hot kernels run at (`x86-64`, `x86-64-v2`, `x86-64-v3`
/// or `x86-64-v4`; `baseline` off x86-64): the CPU's highest, or `GRANPACK_CPU_LEVEL`.
#[pyfunction]
fn cpu_level() -> &'static str {
    crate::cpu::level().name()
}

/// The levels this CPU runs, lowest first.
#[pyfunction]
fn cpu_levels() -> Vec<&'static str> {
    crate::cpu::available()
        .into_iter()
        .map(|l| l.name())
        .collect()
}

/// The native module `granpack._core`.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // A GRANPACK_CPU_LEVEL that names no level, or one this CPU lacks, fails the
    // import with a message naming the variable (the engine alone would ignore it).
    if let Some(l) = crate::cpu::level_from_env()? {
        crate::cpu::set_level(l)?;
    }
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(cpu_level, m)?)?;
    m.add_function(wrap_pyfunction!(cpu_levels, m)?)?;

    m.add("MAX_STEPS_PER_CALL", crate::scene::MAX_STEPS_PER_CALL)?;
    m.add("MAX_STEPS_PER_LAYER", crate::scene::MAX_STEPS_PER_LAYER)?;
    m.add_class::<Simulation>()?;
    m.add_class::<LayerPacker>()?;
    m.add_class::<PyLayerPlacer>()?;
    m.add_function(wrap_pyfunction!(find_contacts, m)?)?;
    m.add_function(wrap_pyfunction!(rayleigh_time_step, m)?)?;
    m.add_function(wrap_pyfunction!(critical_time_step, m)?)?;
    m.add_function(wrap_pyfunction!(resolve_scene, m)?)?;
    m.add_function(wrap_pyfunction!(number_fractions, m)?)?;
    m.add_function(wrap_pyfunction!(sample_radii, m)?)?;
    scene::register(m)?;
    stages::register(m)?;
    Ok(())
}
