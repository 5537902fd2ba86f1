//! `rotorid._rotorid`: the native module of the Python package `rotorid`.
//!
//! A thin layer over the library's front door (`rotorid::identify`,
//! `rotorid::diagnose`, `rotorid::campbell`, `rotorid::simulate`): numpy
//! arrays in and out, one conversion of the phasor arrays into the
//! library's `Measurements`, the GIL released while the library works, and
//! every library error raised as `rotorid.RotorIdError` with the one-line
//! message the command line prints. The JSON of `to_dict()` is the
//! command line's, made by the same code.
//!
//! Units and conventions are the command line's (SPEC sections 2, 4, 7):
//! speeds in rpm at the edge, phasors in metres with
//! `y(t) = Re{ Y exp(j Omega t) }`, channels `b1_y, b1_z, b2_y, ...`.

use num_complex::Complex64;
use numpy::ndarray::{Array2, Array3};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayLike1, PyArrayLike2,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use rotorid::cli::identify::{EstimatorArg, FormulationArg, IdentifyArgs, RunoutArg};
use rotorid::cli::CliError;
use rotorid::io::measurement::{Measurements, Sample, MAX_RESPONSE_M};
use rotorid::io::model_file::ModelFile;
use rotorid::units::{rad_s_to_rpm, rpm_to_rad_s};

pyo3::create_exception!(
    _rotorid,
    RotorIdError,
    PyValueError,
    "An input rotorid cannot use or a computation that failed; the message is the command line's one line."
);

/// Two arrays of one kind: stiffness and damping.
type Pair<'py, A> = (Bound<'py, A>, Bound<'py, A>);

fn err(msg: impl std::fmt::Display) -> PyErr {
    RotorIdError::new_err(msg.to_string())
}

fn cli_err(e: CliError) -> PyErr {
    err(e.one_line())
}

/// A rotor model: the shaft, disks, bearings, unbalance planes and the
/// probes of a rotorid or ROSS TOML file (or the built-in `paper`).
#[pyclass(module = "rotorid._rotorid", name = "Model")]
struct Model {
    file: ModelFile,
    /// The file's stem or the built-in name (the Campbell JSON's `model`).
    label: String,
}

#[pymethods]
impl Model {
    /// `Model.load(path_or_name)`: a rotorid or ROSS (2.x, 3.x) TOML file,
    /// or the name of a built-in model (`"paper"`).
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<Self> {
        let arg = path.to_string_lossy().into_owned();
        let file = rotorid::cli::load_model_arg(&arg).map_err(cli_err)?;
        Ok(Model {
            file,
            label: rotorid::cli::campbell::model_label(&arg),
        })
    }

    /// The paper's reference rotor (the built-in `paper`).
    #[staticmethod]
    fn paper() -> PyResult<Self> {
        Model::load("paper".into())
    }

    /// The model's name.
    #[getter]
    fn name(&self) -> String {
        self.file.model.name.clone()
    }

    /// The file's stem or the built-in name.
    #[getter]
    fn label(&self) -> String {
        self.label.clone()
    }

    /// Number of bearings.
    #[getter]
    fn n_bearings(&self) -> usize {
        self.file.model.bearings.len()
    }

    /// Bearing nodes (from 1), in bearing order.
    #[getter]
    fn bearing_nodes(&self) -> Vec<usize> {
        self.file
            .model
            .bearings
            .iter()
            .map(|b| b.node + 1)
            .collect()
    }

    /// Nodes (from 1) of the unbalance planes the identification estimates.
    #[getter]
    fn planes(&self) -> Vec<usize> {
        self.file.model.planes.iter().map(|n| n + 1).collect()
    }

    /// The phasor columns: `["b1_y", "b1_z", "b2_y", ...]`.
    #[getter]
    fn channels(&self) -> Vec<String> {
        rotorid::io::measurement::default_channel_names(self.file.model.bearings.len())
    }

    /// The bearing responses at `speeds_rpm` (complex, metres, one row per
    /// speed, columns `channels`), as `rotorid simulate` computes them with
    /// the same arguments: the model's unbalance (scaled to
    /// `balance_grade`, mm/s, at the top speed, when given), the effects of
    /// its `[simulate]` section, relative noise `noise` and a probe floor
    /// `noise_floor` (m) drawn from `seed`.
    #[pyo3(signature = (speeds_rpm, *, noise = 0.0, noise_floor = 0.0, seed = 1, balance_grade = None))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        speeds_rpm: PyArrayLike1<'py, f64, AllowTypeChange>,
        noise: f64,
        noise_floor: f64,
        seed: u64,
        balance_grade: Option<f64>,
    ) -> PyResult<Bound<'py, PyArray2<Complex64>>> {
        let speeds = speeds_rpm.as_array().to_vec();
        if speeds.is_empty() {
            return Err(err("speeds_rpm is empty"));
        }
        if let Some(s) = speeds.iter().find(|s| !(s.is_finite() && **s >= 0.0)) {
            return Err(err(format!(
                "speeds_rpm: {s} is not a speed (finite, >= 0 rpm)"
            )));
        }
        if !(noise.is_finite() && noise >= 0.0) {
            return Err(err(format!("noise must be finite and >= 0, got {noise}")));
        }
        if !(noise_floor.is_finite() && noise_floor >= 0.0) {
            return Err(err(format!(
                "noise_floor must be finite and >= 0 (metres), got {noise_floor}"
            )));
        }
        let mut model = self.file.model.clone();
        if let Some(g) = balance_grade {
            let top = speeds.iter().copied().fold(0.0, f64::max);
            if !(g.is_finite() && g > 0.0 && top > 0.0) {
                return Err(err(format!(
                    "balance_grade must be finite and > 0 mm/s with a speed above 0, got {g}"
                )));
            }
            model = rotorid::simulate::at_balance_grade(&model, g, rpm_to_rad_s(top)).ok_or_else(
                || {
                    err(format!(
                        "balance_grade: model {} has no unbalance to scale",
                        self.label
                    ))
                },
            )?;
        }
        let opts = rotorid::SimOptions {
            speeds_rpm: speeds,
            noise,
            seed,
            effects: self.file.effects.clone(),
        };
        let m = py
            .detach(
                || -> Result<Measurements, rotorid::simulate::SimulateError> {
                    let mut m = rotorid::simulate(&model, &opts)?;
                    rotorid::simulate::add_floor_noise(&mut m, noise_floor, seed)?;
                    Ok(m)
                },
            )
            .map_err(|e| cli_err(CliError::from(e)))?;
        Ok(phasor_array(&m).into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!(
            "rotorid.Model({:?}: {} bearings at nodes {:?}, planes {:?})",
            self.file.model.name,
            self.file.model.bearings.len(),
            self.bearing_nodes(),
            self.planes()
        )
    }
}

/// `(n speeds, 2 N_b)` complex phasors of `m`.
fn phasor_array(m: &Measurements) -> Array2<Complex64> {
    let nc = 2 * m.n_bearings;
    Array2::from_shape_fn((m.samples.len(), nc), |(i, c)| m.samples[i].q[c])
}

/// The library's sweep from the arrays: one copy of the phasors. Every
/// value is checked as the measurement file's reader checks its rows.
fn measurements(
    model: &Model,
    speeds_rpm: &PyArrayLike1<'_, f64, AllowTypeChange>,
    phasors: &PyArrayLike2<'_, Complex64, AllowTypeChange>,
) -> PyResult<Measurements> {
    let speeds = speeds_rpm.as_array();
    let q = phasors.as_array();
    let nb = model.file.model.bearings.len();
    let names = rotorid::io::measurement::default_channel_names(nb);
    if q.ncols() != 2 * nb {
        return Err(err(format!(
            "phasors: {} columns, the model's {nb} bearings need {} ({})",
            q.ncols(),
            2 * nb,
            names.join(", ")
        )));
    }
    if q.nrows() != speeds.len() {
        return Err(err(format!(
            "phasors: {} rows for {} speeds",
            q.nrows(),
            speeds.len()
        )));
    }
    let mut samples = Vec::with_capacity(speeds.len());
    for (i, (&rpm, row)) in speeds.iter().zip(q.rows()).enumerate() {
        if !(rpm.is_finite() && rpm >= 0.0) {
            return Err(err(format!(
                "sample {}: speed {rpm} rpm is not a speed (finite, >= 0)",
                i + 1
            )));
        }
        for (c, z) in row.iter().enumerate() {
            if !(z.re.is_finite() && z.im.is_finite()) {
                return Err(err(format!(
                    "sample {} ({rpm} rpm): {} is not finite",
                    i + 1,
                    names[c]
                )));
            }
            if z.norm() > MAX_RESPONSE_M {
                return Err(err(format!(
                    "sample {} ({rpm} rpm): {} = {:e} m is beyond {MAX_RESPONSE_M} m: not a vibration in metres",
                    i + 1,
                    names[c],
                    z.norm()
                )));
            }
        }
        samples.push(Sample {
            omega: rpm_to_rad_s(rpm),
            q: row.to_vec(),
        });
    }
    Ok(Measurements {
        comments: Vec::new(),
        n_bearings: nb,
        samples,
        node_probes: Vec::new(),
        node_q: Vec::new(),
    })
}

/// Per-sample standard deviations `(n speeds, 2 N_b)` (m) as rows.
fn std_rows(
    std: &PyArrayLike2<'_, f64, AllowTypeChange>,
    m: &Measurements,
) -> PyResult<Vec<Vec<f64>>> {
    let s = std.as_array();
    if s.nrows() != m.samples.len() || s.ncols() != 2 * m.n_bearings {
        return Err(err(format!(
            "std: shape ({}, {}), the phasors' is ({}, {})",
            s.nrows(),
            s.ncols(),
            m.samples.len(),
            2 * m.n_bearings
        )));
    }
    if let Some(v) = s.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(err(format!(
            "std: {v} is not a standard deviation (finite, > 0 m)"
        )));
    }
    Ok(s.rows().into_iter().map(|r| r.to_vec()).collect())
}

/// The speed in rpm whose conversion back ([`rpm_to_rad_s`]) is `omega`
/// exactly: the file's value for a speed read from a file, so that a sweep
/// read here and handed to `identify` reaches the library with the same
/// bits as the command line's. Among the few doubles next to
/// `omega * 30 / pi`, the first that converts back to `omega`; that value
/// itself when none does.
fn rpm_of(omega: f64) -> f64 {
    let r0 = rad_s_to_rpm(omega);
    if !(r0.is_finite() && r0 > 0.0) {
        return r0;
    }
    let bits = r0.to_bits();
    (0..=4u64)
        .flat_map(|k| [bits + k, bits - k])
        .map(f64::from_bits)
        .find(|&r| rpm_to_rad_s(r) == omega)
        .unwrap_or(r0)
}

/// `read_measurements(path, model=None)`: a measurement CSV (SPEC sections
/// 4 and 7, its `# conventions:` line applied) as `(speeds_rpm, phasors,
/// std)`; `std` is `None` when the file has no `_std` columns. With
/// `model`, a file named by the model's probes is read and turned into
/// the shaft's `y`, `z`, as `identify` does.
#[pyfunction]
#[pyo3(signature = (path, model = None))]
#[allow(clippy::type_complexity)]
fn read_measurements<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    model: Option<PyRef<'py, Model>>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<Complex64>>,
    Option<Bound<'py, PyArray2<f64>>>,
)> {
    let read = match &model {
        Some(m) => rotorid::io::measurement::read_for_model(&path, &m.file),
        None => rotorid::io::measurement::read_csv_located(&path).map(|(measurements, located)| {
            rotorid::io::measurement::ModelMeasurements {
                measurements,
                sample_std: located.sample_std.clone(),
                located,
                probe_readings: false,
            }
        }),
    }
    .map_err(|e| cli_err(rotorid::cli::measurement_error(&path, e)))?;
    let m = &read.measurements;
    let speeds: Vec<f64> = m.samples.iter().map(|s| rpm_of(s.omega)).collect();
    let std = (!read.sample_std.is_empty()).then(|| {
        let nc = 2 * m.n_bearings;
        Array2::from_shape_fn((m.samples.len(), nc), |(i, c)| read.sample_std[i][c])
            .into_pyarray(py)
    });
    Ok((
        speeds.into_pyarray(py),
        phasor_array(m).into_pyarray(py),
        std,
    ))
}

/// The JSON text of a serialisable result, as a Python object.
fn to_py<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(err)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// An identification: bearing coefficients, unbalance, noise model and
/// warnings, as `rotorid identify` reports them.
#[pyclass(module = "rotorid._rotorid", name = "Identification")]
struct Identification {
    id: rotorid::Identification,
    model: rotorid::RotorModel,
    meas: Measurements,
}

#[pymethods]
impl Identification {
    /// Speed (rpm) at which `k` and `c` are given: the sweep's last.
    #[getter]
    fn speed_rpm(&self) -> f64 {
        rpm_of(self.id.last.omega)
    }

    /// Stiffness `(N_b, 4)` (N/m), `[kyy, kyz, kzy, kzz]` per bearing, at
    /// `speed_rpm`.
    #[getter]
    fn k<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let b = &self.id.last.bearings;
        Array2::from_shape_fn((b.len(), 4), |(i, j)| b[i].k[j]).into_pyarray(py)
    }

    /// Damping `(N_b, 4)` (N s/m), `[cyy, cyz, czy, czz]`, at `speed_rpm`.
    #[getter]
    fn c<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let b = &self.id.last.bearings;
        Array2::from_shape_fn((b.len(), 4), |(i, j)| b[i].c[j]).into_pyarray(py)
    }

    /// Standard deviations of `k` and `c` (same shapes), or `None` when the
    /// sweep is too short for them.
    #[getter]
    fn std<'py>(&self, py: Python<'py>) -> Option<Pair<'py, PyArray2<f64>>> {
        let s = self.id.std()?;
        let b = &s.bearings;
        Some((
            Array2::from_shape_fn((b.len(), 4), |(i, j)| b[i].0[j]).into_pyarray(py),
            Array2::from_shape_fn((b.len(), 4), |(i, j)| b[i].1[j]).into_pyarray(py),
        ))
    }

    /// The identified laws at `speeds_rpm`: `(k, c)`, each
    /// `(n speeds, N_b, 4)` (a law of order 1 is the same at every speed).
    fn bearings_at<'py>(
        &self,
        py: Python<'py>,
        speeds_rpm: PyArrayLike1<'py, f64, AllowTypeChange>,
    ) -> PyResult<Pair<'py, PyArray3<f64>>> {
        let speeds = speeds_rpm.as_array();
        let laws = self.id.bearing_laws();
        let at: Vec<Vec<rotorid::model::BearingCoefficients>> = speeds
            .iter()
            .map(|&r| laws.iter().map(|l| l.at(rpm_to_rad_s(r))).collect())
            .collect();
        let nb = laws.len();
        let k = Array3::from_shape_fn((speeds.len(), nb, 4), |(n, b, j)| at[n][b].k[j]);
        let c = Array3::from_shape_fn((speeds.len(), nb, 4), |(n, b, j)| at[n][b].c[j]);
        Ok((k.into_pyarray(py), c.into_pyarray(py)))
    }

    /// The unbalance per plane, complex `a = m e exp(j alpha)` (kg m), in
    /// the order of `planes`.
    #[getter]
    fn unbalance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        let u: Vec<Complex64> = self.id.last.unbalance.iter().map(|u| u.a).collect();
        u.into_pyarray(py)
    }

    /// Nodes (from 1) of the unbalance planes.
    #[getter]
    fn planes(&self) -> Vec<usize> {
        self.id.param.plane_nodes.iter().map(|n| n + 1).collect()
    }

    /// The noise model the fit used (`floor_m`, `relative`, `source`), as
    /// in the JSON; `None` for the QRD/RLS estimate alone.
    #[getter]
    fn noise<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.id.result().noise)
    }

    /// Warnings of the fit check (also on the command line's stderr).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.id.result().warnings
    }

    /// The JSON of `rotorid identify --json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.id.result())
    }

    /// The model as a ROSS rotor file (TOML text) with the identified
    /// bearings, as `rotorid identify --ross-out` writes it.
    fn ross_toml(&self) -> PyResult<String> {
        self.id
            .ross_toml(&self.model, &self.meas)
            .map_err(|e| err(format!("ross_toml: {e}")))
    }
}

/// `identify(model, speeds_rpm, phasors, std=None, **options)`: the bearing
/// coefficients and unbalance of `model` from the phasors
/// `(n speeds, 2 N_b)` (m) at `speeds_rpm`, with the options and defaults
/// of `rotorid identify` (see the docstring of `rotorid.identify`).
#[pyfunction]
#[pyo3(signature = (
    model, speeds_rpm, phasors, std = None, *,
    formulation = "physical", estimator = "oe", order = 1, lam = 0.999, delta = 1e-7,
    f32 = false, normalise_rows = false, steady_margin_rpm = 0.0, steady_guard = true,
    scaling = true, noise_floor = None, runout = "auto", slow_roll_rpm = None, outliers = true
))]
#[allow(clippy::too_many_arguments)]
fn identify<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    speeds_rpm: PyArrayLike1<'py, f64, AllowTypeChange>,
    phasors: PyArrayLike2<'py, Complex64, AllowTypeChange>,
    std: Option<PyArrayLike2<'py, f64, AllowTypeChange>>,
    formulation: &str,
    estimator: &str,
    order: usize,
    lam: f64,
    delta: f64,
    f32: bool,
    normalise_rows: bool,
    steady_margin_rpm: f64,
    steady_guard: bool,
    scaling: bool,
    noise_floor: Option<f64>,
    runout: &str,
    slow_roll_rpm: Option<f64>,
    outliers: bool,
) -> PyResult<Identification> {
    let args = IdentifyArgs {
        model: model.label.clone(),
        measurements: std::path::PathBuf::new(),
        formulation: match formulation {
            "physical" => FormulationArg::Physical,
            "paper" => FormulationArg::Paper,
            other => {
                return Err(err(format!(
                    "formulation: {other:?} is not physical or paper"
                )))
            }
        },
        estimator: match estimator {
            "oe" => EstimatorArg::Oe,
            "rls" => EstimatorArg::Rls,
            other => return Err(err(format!("estimator: {other:?} is not oe or rls"))),
        },
        order,
        lambda: lam,
        delta,
        f32,
        json: None,
        plot: None,
        ross_out: None,
        normalise_rows,
        steady_margin: steady_margin_rpm,
        no_steady_guard: !steady_guard,
        no_scaling: !scaling,
        noise_floor,
        runout: match runout {
            "auto" => RunoutArg::Auto,
            "fit" => RunoutArg::Fit,
            "none" => RunoutArg::None,
            other => return Err(err(format!("runout: {other:?} is not auto, fit or none"))),
        },
        slow_roll: slow_roll_rpm,
        no_outliers: !outliers,
        conventions: Default::default(),
    };
    let opts = rotorid::cli::identify::options(&args).map_err(cli_err)?;
    let meas = measurements(&model, &speeds_rpm, &phasors)?;
    let std = std.map(|s| std_rows(&s, &meas)).transpose()?;
    let rotor = model.file.model.clone();
    let id = py
        .detach(|| rotorid::estimate::identify_with_std(&rotor, &meas, std.as_deref(), &opts))
        .map_err(|e| match e {
            rotorid::IdentifyError::Step { index, rpm, source } => {
                err(format!("sample {} ({rpm} rpm): {source}", index + 1))
            }
            other => err(other),
        })?;
    Ok(Identification {
        id,
        model: rotor,
        meas,
    })
}

/// A diagnosis: the effect the nominal model lacks, as `rotorid diagnose`
/// reports it.
#[pyclass(module = "rotorid._rotorid", name = "Diagnosis")]
struct Diagnosis {
    json: rotorid::report::diagnose::DiagnoseJson,
}

#[pymethods]
impl Diagnosis {
    /// The named effect (`"none"` when the nominal model explains the data).
    #[getter]
    fn effect(&self) -> &'static str {
        self.json.effect
    }

    /// The effects of the extended model (two for a pair).
    #[getter]
    fn effects(&self) -> Vec<&'static str> {
        self.json.effects.clone()
    }

    /// Residual of the nominal model over that of the extended one.
    #[getter]
    fn gain(&self) -> f64 {
        self.json.gain
    }

    /// Every hypothesis fitted (dicts, as in the JSON).
    #[getter]
    fn hypotheses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.json.hypotheses)
    }

    /// What the data can show (dicts, as in the JSON).
    #[getter]
    fn observability<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.json.observability)
    }

    /// Warnings.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.json.warnings.clone()
    }

    /// The JSON of `rotorid diagnose --json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.json)
    }
}

/// `diagnose(model, speeds_rpm, phasors, *, order=1, false_alarm=1e-3,
/// noise_floor=None)`: which physical effect the nominal model lacks.
#[pyfunction]
#[pyo3(signature = (model, speeds_rpm, phasors, *, order = 1, false_alarm = 1e-3, noise_floor = None))]
fn diagnose<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    speeds_rpm: PyArrayLike1<'py, f64, AllowTypeChange>,
    phasors: PyArrayLike2<'py, Complex64, AllowTypeChange>,
    order: usize,
    false_alarm: f64,
    noise_floor: Option<f64>,
) -> PyResult<Diagnosis> {
    let meas = measurements(&model, &speeds_rpm, &phasors)?;
    if meas.samples.len() < 8 {
        return Err(err(format!(
            "{} speeds: the diagnosis needs at least 8 (and many more to tell effects apart)",
            meas.samples.len()
        )));
    }
    let opts = rotorid::DiagnoseOptions {
        order,
        false_alarm,
        relative_probes: model.file.model.probes == rotorid::model::ProbeReference::Relative,
        noise_floor: rotorid::cli::noise_floor_option(noise_floor).map_err(cli_err)?,
        ..Default::default()
    };
    let rotor = model.file.model.clone();
    let d = py
        .detach(|| rotorid::diagnose(&rotor, &meas, &opts))
        .map_err(|e| err(format!("diagnose: {e}")))?;
    Ok(Diagnosis {
        json: rotorid::report::diagnose::json(&d),
    })
}

/// `campbell(model, *, rpm_max=15000, rpm_step=250, modes=8)`: the
/// Campbell diagram and critical speeds as the dict of `rotorid campbell
/// --json`.
#[pyfunction]
#[pyo3(signature = (model, *, rpm_max = 15000.0, rpm_step = 250.0, modes = 8))]
fn campbell<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    rpm_max: f64,
    rpm_step: f64,
    modes: usize,
) -> PyResult<Bound<'py, PyAny>> {
    if !(rpm_max.is_finite() && rpm_max > 0.0) {
        return Err(err(format!(
            "rpm_max must be finite and > 0, got {rpm_max}"
        )));
    }
    if modes == 0 {
        return Err(err("modes must be at least 1"));
    }
    let opts = rotorid::CampbellOptions {
        rpm_max,
        rpm_step,
        modes,
    };
    let rotor = model.file.model.clone();
    let analysis = py
        .detach(|| rotorid::campbell(&rotor, &opts))
        .map_err(|e| cli_err(CliError::from(e)))?;
    let report = rotorid::report::campbell::CampbellReport::new(model.label.clone(), &analysis);
    let d = to_py(py, &report.json())?;
    let _: &Bound<'py, PyDict> = d.cast()?;
    Ok(d)
}

/// `vectors(path, config=None, *, speed_min_rpm=None, speed_max_rpm=None,
/// revolutions=8, pool=True)`: the 1X vectors of a recording of probe and
/// keyphasor signals (the signals CSV of SPEC section 8, or a WAV file
/// with a configuration), as `rotorid vectors` makes them:
/// `(speeds_rpm, phasors, std, info)`, `info` a dict of the channels, the
/// sweep rate, the revolutions accepted and rejected by cause.
#[pyfunction]
#[pyo3(signature = (path, config = None, *, speed_min_rpm = None, speed_max_rpm = None, revolutions = 8, pool = true))]
#[allow(clippy::type_complexity)]
fn vectors<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    config: Option<std::path::PathBuf>,
    speed_min_rpm: Option<f64>,
    speed_max_rpm: Option<f64>,
    revolutions: u32,
    pool: bool,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<Complex64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyAny>,
)> {
    use rotorid::signals;
    let rev_max = rotorid::core::ordertrack::MAX_REVOLUTIONS;
    if !(3..=rev_max).contains(&revolutions) {
        return Err(err(format!(
            "revolutions must be in 3..={rev_max}, got {revolutions}"
        )));
    }
    let config = match &config {
        Some(p) => signals::SignalConfig::from_file(p).map_err(err)?,
        None => signals::SignalConfig::default(),
    };
    let shown = path.display().to_string();
    let wav = rotorid::cli::vectors::is_wav(&path).map_err(cli_err)?;
    let opts = signals::ExtractOptions {
        speed_min_rpm,
        speed_max_rpm,
        revolutions,
        hysteresis: config.kp_hysteresis,
        pool,
    };
    let v = py
        .detach(|| -> Result<signals::Vectors, String> {
            let rec = if wav {
                signals::read_wav(&path, &config)
            } else {
                signals::read_csv_with(&path, &config)
            }
            .map_err(|e| format!("{shown}: {e}"))?;
            signals::extract(&rec, &opts, None).map_err(|e| format!("{shown}: {e}"))
        })
        .map_err(err)?;
    if v.rows.is_empty() {
        return Err(err(format!(
            "{shown}: no averaged vectors: {} revolutions accepted, {} rejected",
            v.counts.accepted,
            v.counts.rejected()
        )));
    }
    let nc = v.channels.len();
    let speeds: Vec<f64> = v.rows.iter().map(|r| rad_s_to_rpm(r.omega)).collect();
    let q = Array2::from_shape_fn((v.rows.len(), nc), |(i, c)| v.rows[i].x1[c]);
    let std = Array2::from_shape_fn((v.rows.len(), nc), |(i, c)| v.rows[i].std[c]);
    let info = PyDict::new(py);
    let names: Vec<String> = v.channels.iter().map(|c| c.to_string()).collect();
    info.set_item("channels", names)?;
    info.set_item("sweep_rate_rpm_per_s", v.sweep_rate_rpm_per_s)?;
    info.set_item("accepted", v.counts.accepted)?;
    let rejected = PyDict::new(py);
    for (cause, n) in signals::output::rejection_counts(&v) {
        rejected.set_item(cause, n)?;
    }
    info.set_item("rejected", rejected)?;
    Ok((
        speeds.into_pyarray(py),
        q.into_pyarray(py),
        std.into_pyarray(py),
        info.into_any(),
    ))
}

/// The native module.
#[pymodule]
fn _rotorid(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("RotorIdError", m.py().get_type::<RotorIdError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Model>()?;
    m.add_class::<Identification>()?;
    m.add_class::<Diagnosis>()?;
    m.add_function(wrap_pyfunction!(read_measurements, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(campbell, m)?)?;
    m.add_function(wrap_pyfunction!(vectors, m)?)?;
    Ok(())
}
