//! Damped natural frequencies against speed (Campbell diagram), whirl
//! direction, logarithmic decrement and critical speeds.
//!
//! At each speed `Omega` the free motion `M q'' + (C + Omega G) q' + K q = 0`
//! (dense matrices of [`crate::fe::assembly`], pedestal DOFs explicit, bearing
//! coefficients at `Omega`) is written in first-order form. With
//! `D = C + Omega G` and a scale `s_c` (of the order of the largest natural
//! frequency, so that both blocks have similar norms), the state
//! `x = (q, q' / s_c)` obeys `x' = A x` with
//!
//! ```text
//! A = [ 0             s_c I     ]
//!     [ -M^-1 K / s_c  -M^-1 D ]
//! ```
//!
//! whose eigenvalues `lambda = sigma + j w_d` are those of the rotor (the
//! scaling is a similarity). They come from nalgebra's real Schur
//! decomposition. For each kept eigenvalue (`w_d > 0`, below the cut-off)
//! the eigenvector follows from two steps of inverse iteration with the
//! banded `Z(lambda) = K + lambda D + lambda^2 M` (pedestals condensed at
//! `lambda`), giving the shaft mode shape.
//!
//! Per mode: damped natural frequency `w_d = Im lambda` (rad/s), damping
//! ratio `zeta = -Re lambda / |lambda|`, logarithmic decrement
//! `delta = -2 pi Re lambda / Im lambda`.
//!
//! # Whirl direction
//!
//! At a node with mode-shape components `Y`, `Z`, the orbit is
//! `y = Re(Y e^{lambda t})`, `z = Re(Z e^{lambda t})`. For `Y = 1`, `Z = -j`
//! this is `(cos w t, sin w t)`, turning from +y toward +z with the rotor:
//! forward, and `Im(Y conj(Z)) = 1`. In general
//! `2 Im(Y conj(Z)) / (|Y|^2 + |Z|^2)` lies in `[-1, 1]`: +1 forward circular,
//! 0 straight line, -1 backward circular. A mode is `Forward` if every node
//! with appreciable amplitude whirls forward, `Backward` if every such node
//! whirls backward, `Mixed` otherwise; [`Mode::whirl_ratio`] is the
//! amplitude-weighted mean of the node values.
//!
//! # Critical speeds
//!
//! A critical speed is where a mode's damped frequency crosses the 1X line
//! `w_d = Omega`. Between consecutive speeds of the diagram, each mode of the
//! requested whirl is matched to the mode of the same whirl nearest in
//! frequency at the next speed; where `w_d - Omega` changes sign the
//! crossing is interpolated linearly.

use crate::fe::assembly::{FeError, FeModel};
use nalgebra::{DMatrix, Schur};
use num_complex::Complex64;

/// Whirl direction of a mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Whirl {
    /// Every node orbits with the rotation (from +y toward +z).
    Forward,
    /// Every node orbits against the rotation.
    Backward,
    /// Nodes orbit in different senses (or the orbits are straight lines).
    Mixed,
}

/// One damped mode at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    /// Eigenvalue `lambda = sigma + j w_d` (1/s).
    pub eigenvalue: Complex64,
    /// Damped natural frequency `w_d = Im lambda` (rad/s).
    pub frequency: f64,
    /// Undamped natural frequency `|lambda|` (rad/s).
    pub undamped_frequency: f64,
    /// Damping ratio `-Re lambda / |lambda|` (-).
    pub damping_ratio: f64,
    /// Logarithmic decrement `-2 pi Re lambda / Im lambda` (-).
    pub log_dec: f64,
    /// Whirl direction.
    pub whirl: Whirl,
    /// Amplitude-weighted mean of `2 Im(Y conj Z) / (|Y|^2 + |Z|^2)` over the
    /// shaft nodes, in `[-1, 1]` (+1: forward circular).
    pub whirl_ratio: f64,
    /// Shaft mode shape (length `n_shaft_dof`), normalised to unit
    /// Euclidean norm.
    pub shape: Vec<Complex64>,
}

/// The modes at one speed, sorted by frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct CampbellPoint {
    /// Speed (rad/s).
    pub omega: f64,
    /// Modes with positive damped frequency below the cut-off.
    pub modes: Vec<Mode>,
}

/// Modes against speed.
#[derive(Debug, Clone, PartialEq)]
pub struct CampbellDiagram {
    /// One entry per requested speed, in the order requested.
    pub points: Vec<CampbellPoint>,
}

/// Which modes to keep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CampbellOptions {
    /// Keep modes with damped frequency below this (rad/s); `None`: no limit.
    pub max_frequency: Option<f64>,
    /// Keep at most this many modes (the lowest) per speed.
    pub max_modes: usize,
}

impl Default for CampbellOptions {
    fn default() -> Self {
        CampbellOptions {
            max_frequency: None,
            max_modes: 12,
        }
    }
}

/// Most degrees of freedom of a model whose Campbell diagram is computed:
/// each speed solves a dense eigenproblem of `2 n` states (`O(n^2)` memory,
/// `O(n^3)` time, several seconds per speed at this size). 400 DOF are 99
/// shaft elements (4 DOF per node); the paper's rotor has 108.
pub const MAX_CAMPBELL_DOF: usize = 400;

/// Most work of one Campbell diagram, counted as `speeds x (2 n)^3` for
/// `n` DOF: a few minutes, about 1500 speeds of the paper's rotor (the
/// default diagram has 61), 61 speeds of a 312-DOF model or 29 speeds at
/// [`MAX_CAMPBELL_DOF`].
pub const MAX_CAMPBELL_WORK: f64 = 1.5e10;

/// Checks a Campbell diagram of `n_dof` DOF at `n_speeds` speeds against
/// [`MAX_CAMPBELL_DOF`] and [`MAX_CAMPBELL_WORK`], before anything is
/// allocated.
pub fn check_size(n_dof: usize, n_speeds: usize) -> Result<(), FeError> {
    if n_dof > MAX_CAMPBELL_DOF {
        return Err(FeError::Invalid(format!(
            "Campbell diagram of a model with {n_dof} degrees of freedom: at most {MAX_CAMPBELL_DOF} \
             (about {} shaft elements; each speed solves a dense {}x{} eigenproblem)",
            MAX_CAMPBELL_DOF / 4 - 1,
            2 * n_dof,
            2 * n_dof
        )));
    }
    let states = 2.0 * n_dof as f64;
    let work = n_speeds as f64 * states * states * states;
    if work > MAX_CAMPBELL_WORK {
        let max_speeds = (MAX_CAMPBELL_WORK / (states * states * states)).floor();
        return Err(FeError::Invalid(format!(
            "Campbell diagram at {n_speeds} speeds of a {n_dof}-DOF model: at most {max_speeds} speeds \
             for this model (use a larger speed step)"
        )));
    }
    Ok(())
}

/// A 1X crossing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalSpeed {
    /// Speed where the damped frequency equals the speed (rad/s).
    pub omega: f64,
    /// Whirl of the crossing mode.
    pub whirl: Whirl,
    /// Index of the mode (among modes of that whirl, by frequency) at the
    /// lower bracketing speed.
    pub mode: usize,
}

/// Campbell diagram with the default options (the 12 lowest modes).
pub fn campbell(fe: &FeModel, speeds: &[f64]) -> Result<CampbellDiagram, FeError> {
    campbell_with(fe, speeds, &CampbellOptions::default())
}

/// Campbell diagram with explicit options.
pub fn campbell_with(
    fe: &FeModel,
    speeds: &[f64],
    opts: &CampbellOptions,
) -> Result<CampbellDiagram, FeError> {
    check_size(fe.n_dof(), speeds.len())?;
    let m = fe.mass_matrix();
    let chol = m
        .clone()
        .cholesky()
        .ok_or_else(|| FeError::Eigen("mass matrix is not positive definite".into()))?;
    let g = fe.gyroscopic_matrix();
    let mut points = Vec::with_capacity(speeds.len());
    for &omega in speeds {
        if !omega.is_finite() || omega < 0.0 {
            return Err(FeError::Invalid(format!(
                "speeds must be finite and >= 0, got {omega}"
            )));
        }
        let modes = modes_at_impl(fe, &chol, &g, omega, opts)?;
        points.push(CampbellPoint { omega, modes });
    }
    Ok(CampbellDiagram { points })
}

/// The modes at one speed.
pub fn modes_at(fe: &FeModel, omega: f64, opts: &CampbellOptions) -> Result<Vec<Mode>, FeError> {
    Ok(campbell_with(fe, &[omega], opts)?
        .points
        .pop()
        .map(|p| p.modes)
        .unwrap_or_default())
}

fn modes_at_impl(
    fe: &FeModel,
    chol: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    g: &DMatrix<f64>,
    omega: f64,
    opts: &CampbellOptions,
) -> Result<Vec<Mode>, FeError> {
    let n = fe.n_dof();
    let k = fe.stiffness_matrix(omega);
    let d = fe.damping_matrix(omega) + g * omega;
    let mk = chol.solve(&k);
    let md = chol.solve(&d);
    let diag_max = (0..n).map(|i| mk[(i, i)].abs()).fold(0.0, f64::max);
    let sc = diag_max.sqrt().max(1.0);
    let mut a = DMatrix::<f64>::zeros(2 * n, 2 * n);
    for i in 0..n {
        a[(i, n + i)] = sc;
        for j in 0..n {
            a[(n + i, j)] = -mk[(i, j)] / sc;
            a[(n + i, n + j)] = -md[(i, j)];
        }
    }
    if a.iter().any(|v| !v.is_finite()) {
        return Err(FeError::Eigen("non-finite state matrix".into()));
    }
    let schur = Schur::try_new(a, f64::EPSILON, 100_000).ok_or_else(|| {
        FeError::Eigen(format!("Schur iteration did not converge at {omega} rad/s"))
    })?;
    let eig = schur.complex_eigenvalues();
    let tol = 1e-9 * sc;
    let mut lams: Vec<Complex64> = eig
        .iter()
        .copied()
        .filter(|l| l.im > tol && opts.max_frequency.is_none_or(|f| l.im <= f))
        .collect();
    lams.sort_by(|x, y| x.im.total_cmp(&y.im));
    lams.truncate(opts.max_modes);
    let mut modes = Vec::with_capacity(lams.len());
    for lam in lams {
        let shape = eigenvector(fe, omega, lam)?;
        let (whirl, whirl_ratio) = classify_whirl(&shape, fe.n_nodes());
        let abs = lam.norm();
        modes.push(Mode {
            eigenvalue: lam,
            frequency: lam.im,
            undamped_frequency: abs,
            damping_ratio: -lam.re / abs,
            log_dec: -2.0 * core::f64::consts::PI * lam.re / lam.im,
            whirl,
            whirl_ratio,
            shape,
        });
    }
    Ok(modes)
}

/// Shaft mode shape for eigenvalue `lam` by inverse iteration with the
/// banded `Z(lam)` (slightly shifted so that it is not exactly singular).
fn eigenvector(fe: &FeModel, omega: f64, lam: Complex64) -> Result<Vec<Complex64>, FeError> {
    let n = fe.n_shaft_dof();
    let mut v: Vec<Complex64> = (0..n)
        .map(|i| Complex64::from_polar(1.0, 0.7 * i as f64 + 0.3))
        .collect();
    let mut shift = 1e-10;
    for _ in 0..6 {
        let s = lam * (1.0 + shift);
        let lu = match fe.system_dynamic_stiffness_at(omega, s)?.into_lu() {
            Ok(lu) => lu,
            Err(crate::fe::banded::BandedError::Singular(_)) => {
                shift *= 100.0;
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        for _ in 0..3 {
            lu.solve(&mut v)?;
            let norm = v.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
            if !(norm.is_finite() && norm > 0.0) {
                return Err(FeError::Eigen("inverse iteration broke down".into()));
            }
            v.iter_mut().for_each(|x| *x /= norm);
        }
        // Phase: largest component real positive.
        let (imax, _) =
            v.iter().enumerate().fold(
                (0, 0.0),
                |acc, (i, x)| if x.norm() > acc.1 { (i, x.norm()) } else { acc },
            );
        let ph = v[imax] / v[imax].norm();
        v.iter_mut().for_each(|x| *x /= ph);
        return Ok(v);
    }
    Err(FeError::Eigen(format!("no eigenvector for lambda = {lam}")))
}

/// Whirl of a shaft mode shape (see the module documentation).
pub fn classify_whirl(shape: &[Complex64], n_nodes: usize) -> (Whirl, f64) {
    let mut amps = Vec::with_capacity(n_nodes);
    let mut num = 0.0;
    let mut den = 0.0;
    for node in 0..n_nodes {
        let (y, z) = match (shape.get(4 * node), shape.get(4 * node + 1)) {
            (Some(y), Some(z)) => (*y, *z),
            _ => break,
        };
        let amp = y.norm_sqr() + z.norm_sqr();
        let w = 2.0 * (y * z.conj()).im;
        num += w;
        den += amp;
        amps.push((amp, w));
    }
    let amax = amps.iter().map(|a| a.0).fold(0.0, f64::max);
    let ratio = if den > 0.0 { num / den } else { 0.0 };
    let (mut fwd, mut bwd) = (false, false);
    for &(amp, w) in &amps {
        if amp < 1e-4 * amax {
            continue;
        }
        let r = w / amp;
        if r > 1e-6 {
            fwd = true;
        } else if r < -1e-6 {
            bwd = true;
        } else {
            // A straight-line orbit belongs to neither sense.
            fwd = true;
            bwd = true;
        }
    }
    let whirl = match (fwd, bwd) {
        (true, false) => Whirl::Forward,
        (false, true) => Whirl::Backward,
        _ => Whirl::Mixed,
    };
    (whirl, ratio)
}

/// Speeds (rad/s) where a mode of the given whirl crosses the 1X line, by
/// linear interpolation between consecutive diagram speeds (the diagram's
/// speeds must be increasing for the result to be meaningful; pairs that
/// are not are skipped).
pub fn critical_speeds(diagram: &CampbellDiagram, whirl: Whirl) -> Vec<CriticalSpeed> {
    let mut out = Vec::new();
    for pair in diagram.points.windows(2) {
        let (p0, p1) = (&pair[0], &pair[1]);
        if p1.omega <= p0.omega {
            continue;
        }
        let f0: Vec<f64> = p0
            .modes
            .iter()
            .filter(|m| m.whirl == whirl)
            .map(|m| m.frequency)
            .collect();
        let f1: Vec<f64> = p1
            .modes
            .iter()
            .filter(|m| m.whirl == whirl)
            .map(|m| m.frequency)
            .collect();
        for (idx, &a) in f0.iter().enumerate() {
            // Nearest mode of the same whirl at the next speed.
            let Some(&b) = f1
                .iter()
                .min_by(|x, y| (*x - a).abs().total_cmp(&(*y - a).abs()))
            else {
                continue;
            };
            if (b - a).abs() > 0.2 * a.max(b) {
                continue;
            }
            let g0 = a - p0.omega;
            let g1 = b - p1.omega;
            if g0 > 0.0 && g1 <= 0.0 || g0 < 0.0 && g1 >= 0.0 {
                let t = g0 / (g0 - g1);
                out.push(CriticalSpeed {
                    omega: p0.omega + t * (p1.omega - p0.omega),
                    whirl,
                    mode: idx,
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whirl_of_synthetic_orbits() {
        let c = Complex64::new;
        // Node 0: Y = 1, Z = -j (forward circular); node 1: elliptic forward.
        let fwd = [
            c(1.0, 0.0),
            c(0.0, -1.0),
            c(0.0, 0.0),
            c(0.0, 0.0),
            c(2.0, 0.0),
            c(0.0, -0.5),
            c(0.0, 0.0),
            c(0.0, 0.0),
        ];
        let (w, r) = classify_whirl(&fwd, 2);
        assert_eq!(w, Whirl::Forward);
        assert!(r > 0.0 && r <= 1.0);
        let (w, r) = classify_whirl(&[c(1.0, 0.0), c(0.0, -1.0), c(0.0, 0.0), c(0.0, 0.0)], 1);
        assert_eq!(w, Whirl::Forward);
        assert!((r - 1.0).abs() < 1e-15);
        let bwd: Vec<Complex64> = fwd.iter().map(|v| v.conj()).collect();
        assert_eq!(classify_whirl(&bwd, 2).0, Whirl::Backward);
        let mut mixed = fwd;
        mixed[5] = c(0.0, 0.5);
        assert_eq!(classify_whirl(&mixed, 2).0, Whirl::Mixed);
        // A straight-line orbit has no sense.
        let line = [c(1.0, 0.0), c(1.0, 0.0), c(0.0, 0.0), c(0.0, 0.0)];
        assert_eq!(classify_whirl(&line, 1).0, Whirl::Mixed);
    }
}
