//! Helpers shared by all the integration tests: the one seeded generator,
//! the in-process command line, scratch paths, and for the identification
//! tests a noise-free simulation, an independent dense reduction and error
//! measures.
#![allow(dead_code)]

use std::ffi::{OsStr, OsString};
use std::path::PathBuf;

use nalgebra::DMatrix;
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rotorid::estimate::{
    identify_with, EstimateSet, Identification, IdentifyError, Options, TermsAt,
};
use rotorid::fe::assembly::FeModel;
use rotorid::fe::response::{unbalance_response, Forcing};
use rotorid::io::measurement::{Measurements, Sample};
use rotorid::model::RotorModel;
use rotorid::units::rpm_to_rad_s;

pub mod signals;

/// The one pseudo-random generator of the tests: ChaCha8 seeded with
/// `seed` (the generator of the library's noise, a fixed stream).
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// What a `rotorid` command line did: exit status, stdout, stderr.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Output {
    /// Exit status (0 success, 2 any error).
    pub status: i32,
    /// Everything written to stdout.
    pub stdout: String,
    /// Everything written to stderr.
    pub stderr: String,
}

impl Output {
    /// Exit status 0.
    pub fn success(&self) -> bool {
        self.status == 0
    }
}

/// Runs `rotorid ARGS...` in this process ([`rotorid::cli::run_with_io`],
/// the code behind the binary's `main`), collecting stdout and stderr.
pub fn cli<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let argv = std::iter::once(OsString::from("rotorid"))
        .chain(args.into_iter().map(|a| a.as_ref().to_os_string()));
    let (mut out, mut err) = (Vec::new(), Vec::new());
    let status = rotorid::cli::run_with_io(argv, &mut out, &mut err);
    Output {
        status,
        stdout: String::from_utf8_lossy(&out).into_owned(),
        stderr: String::from_utf8_lossy(&err).into_owned(),
    }
}

/// Runs the real `rotorid` binary with `args` (for the tests of the
/// binary's own wiring: exit status, stderr).
pub fn binary<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_rotorid"))
        .args(args)
        .output()
        .expect("run the rotorid binary");
    Output {
        status: o.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
    }
}

/// The file `name` of the crate's `examples/` (model files).
pub fn example(name: &str) -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

/// A scratch path `name` in a directory of the running test's own:
/// `<temp>/rotorid-tests-<pid>/<test path>/name` (libtest runs each test on
/// a thread named after it, so tests running in parallel never share
/// files). The directory exists; the file is not touched.
pub fn tmp(name: &str) -> PathBuf {
    let thread = std::thread::current();
    let test = match thread.name() {
        Some(n) => n.replace("::", "-"),
        None => format!("{:?}", thread.id()),
    };
    let dir = std::env::temp_dir()
        .join(format!("rotorid-tests-{}", std::process::id()))
        .join(test);
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Speeds `rpm_min, rpm_min + step, ..., <= rpm_max` (rad/s).
pub fn sweep(rpm_min: f64, rpm_max: f64, step: f64) -> Vec<f64> {
    let n = ((rpm_max - rpm_min) / step + 1e-9).floor() as usize;
    (0..=n)
        .map(|i| rpm_to_rad_s(rpm_min + step * i as f64))
        .collect()
}

/// Noise-free bearing responses of `model` (its true unbalance) at `speeds`.
pub fn simulate(model: &RotorModel, speeds: &[f64]) -> Measurements {
    let fe = FeModel::new(model).unwrap();
    let resp = unbalance_response(&fe, &Forcing::from_model(model), speeds).unwrap();
    Measurements {
        comments: vec![],
        n_bearings: model.bearings.len(),
        node_probes: Vec::new(),
        node_q: Vec::new(),
        samples: resp
            .into_iter()
            .map(|r| Sample {
                omega: r.omega,
                q: r.bearings,
            })
            .collect(),
    }
}

/// Independent dense reduction (no table code): with `Z_R` the shaft and
/// disk dynamic stiffness, `B` the bearing DOFs and `i` the others,
/// `Y = Z_Bi Z_ii^-1`, `A = Z_BB - Y Z_iB`, `B = Omega^2 (T_B - Y T_i)`.
pub struct DenseReduction {
    fe: FeModel,
    planes: Vec<usize>,
}

impl DenseReduction {
    pub fn new(model: &RotorModel) -> Self {
        DenseReduction {
            fe: FeModel::new(model).unwrap(),
            planes: model.planes.clone(),
        }
    }

    pub fn terms(&self, omega: f64) -> TermsAt {
        let z = self.fe.rotor_dynamic_stiffness(omega).to_dense();
        let t = self.fe.unbalance_distribution(&self.planes).unwrap();
        let bd = self.fe.bearing_dofs();
        let id: Vec<usize> = (0..z.nrows()).filter(|i| !bd.contains(i)).collect();
        let sub = |m: &DMatrix<Complex64>, r: &[usize], c: &[usize]| {
            DMatrix::from_fn(r.len(), c.len(), |i, j| m[(r[i], c[j])])
        };
        let all_p: Vec<usize> = (0..t.ncols()).collect();
        let zii = sub(&z, &id, &id);
        let zib = sub(&z, &id, &bd);
        let zbi = sub(&z, &bd, &id);
        let zbb = sub(&z, &bd, &bd);
        let ti = sub(&t, &id, &all_p);
        let tb = sub(&t, &bd, &all_p);
        let lu = zii.lu();
        // Y X = Z_Bi Z_ii^-1 X = Z_Bi (Z_ii^-1 X).
        let a = &zbb - &zbi * lu.solve(&zib).unwrap();
        let b = (&tb - &zbi * lu.solve(&ti).unwrap()) * Complex64::new(omega * omega, 0.0);
        (a, b)
    }

    pub fn source(&self) -> impl FnMut(f64) -> Result<TermsAt, IdentifyError> + '_ {
        move |w| Ok(self.terms(w))
    }

    /// `identify_with` on `model`'s bearings and planes, the terms from
    /// this reduction.
    pub fn identify(
        &self,
        model: &RotorModel,
        meas: &Measurements,
        opts: &Options,
    ) -> Result<Identification, IdentifyError> {
        identify_with(
            &model.bearing_nodes(),
            &model.planes,
            meas,
            opts,
            &mut self.source(),
            None,
        )
    }
}

/// True bearing coefficients of `model` at `omega`: `(k, c)` per bearing.
pub fn true_bearings(model: &RotorModel, omega: f64) -> Vec<([f64; 4], [f64; 4])> {
    model
        .bearings
        .iter()
        .map(|b| {
            let c = b.law.at(omega);
            (c.k, c.c)
        })
        .collect()
}

/// Worst relative errors `(k, c, me)` and worst phase error (deg) of an
/// estimate against `model`'s truth at the estimate's speed.
pub fn errors(model: &RotorModel, e: &EstimateSet) -> (f64, f64, f64, f64) {
    let truth = true_bearings(model, e.omega);
    let (mut ek, mut ec, mut em, mut ep) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (b, (k, c)) in e.bearings.iter().zip(&truth) {
        for j in 0..4 {
            ek = ek.max((b.k[j] - k[j]).abs() / k[j].abs());
            ec = ec.max((b.c[j] - c[j]).abs() / c[j].abs());
        }
    }
    for (u, t) in e.unbalance.iter().zip(&model.unbalance) {
        em = em.max((u.me - t.me).abs() / t.me);
        let mut d = (u.phase - t.phase).to_degrees();
        while d > 180.0 {
            d -= 360.0;
        }
        while d < -180.0 {
            d += 360.0;
        }
        ep = ep.max(d.abs());
    }
    (ek, ec, em, ep)
}
