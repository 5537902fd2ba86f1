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
//! # Mode tracking
//!
//! A mode is followed across speed by its shape, not by its rank in
//! frequency or its whirl: between neighbouring speeds the modes are paired
//! by the assignment that maximises the summed modal assurance criterion
//! `MAC(u, v) = |u^H v|^2 / ((u^H u)(v^H v))` of the shaft mode shapes
//! ([`track_modes`]). Curves that cross in frequency, or whose whirl
//! changes (a planar mode at rest becomes backward or forward once
//! spinning), stay one mode each.
//!
//! # Critical speeds
//!
//! As in ROSS (`Rotor.run_critical_speed`), a critical speed is a fixed
//! point `f_k(Omega) = Omega` of a mode's natural frequency: the damped
//! `f_k = Im lambda_k` (ROSS `wd`, [`Crossing::Damped`]) or the undamped
//! `f_k = |lambda_k|` (ROSS `wn`, [`Crossing::Undamped`]), for every whirl
//! (forward, backward and mixed). [`critical_speeds`] brackets the sign
//! changes of `f_k(Omega) - Omega` along each tracked mode on the diagram's
//! speeds, then refines each root with new eigen-solves at trial speeds
//! (Illinois regula falsi) to [`CRITICAL_SPEED_RTOL`], so the speeds do not
//! depend on the diagram's speed step. (ROSS iterates on the k-th mode by
//! frequency rank from the rest frequency with `scipy.optimize.newton` to
//! `rtol = 0.005`; a crossing of the rank-ordered curves is a crossing of
//! some mode, so the converged speeds are the same.)

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
    /// Modes with positive damped frequency below the cut-off, the lowest
    /// by `|lambda|`, sorted by damped frequency.
    pub modes: Vec<Mode>,
}

/// Modes against speed.
#[derive(Debug, Clone, PartialEq)]
pub struct CampbellDiagram {
    /// One entry per requested speed, in the order requested.
    pub points: Vec<CampbellPoint>,
}

/// Which modes a diagram keeps at each speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeSelection {
    /// Keep modes with damped frequency below this (rad/s); `None`: no limit.
    pub max_frequency: Option<f64>,
    /// Keep at most this many modes per speed: the lowest by undamped
    /// natural frequency `|lambda|`.
    pub max_modes: usize,
}

impl Default for ModeSelection {
    fn default() -> Self {
        ModeSelection {
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

/// Campbell diagram of the 12 lowest modes ([`ModeSelection::default`]) at
/// `speeds` (rad/s); [`crate::campbell()`] is the whole analysis of a
/// model (speeds, tracked modes, critical speeds).
pub fn diagram(fe: &FeModel, speeds: &[f64]) -> Result<CampbellDiagram, FeError> {
    diagram_with(fe, speeds, &ModeSelection::default())
}

/// Campbell diagram of the modes `opts` selects at `speeds` (rad/s).
pub fn diagram_with(
    fe: &FeModel,
    speeds: &[f64],
    opts: &ModeSelection,
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
pub fn modes_at(fe: &FeModel, omega: f64, opts: &ModeSelection) -> Result<Vec<Mode>, FeError> {
    Ok(diagram_with(fe, &[omega], opts)?
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
    opts: &ModeSelection,
) -> Result<Vec<Mode>, FeError> {
    let mut lams = eigenvalues_at(fe, chol, g, omega)?;
    lams.retain(|l| opts.max_frequency.is_none_or(|f| l.im <= f));
    // The lowest by |lambda| (as ROSS's shift-invert selection), then by
    // damped frequency: heavily overdamped pairs (e.g. from stiffness-
    // proportional damping) have a tiny `Im lambda` once spinning but a
    // large `|lambda|`, and are not among the low modes.
    lams.sort_by(|x, y| x.norm().total_cmp(&y.norm()));
    lams.truncate(opts.max_modes);
    lams.sort_by(|x, y| x.im.total_cmp(&y.im));
    lams.into_iter().map(|l| mode_of(fe, omega, l)).collect()
}

/// The eigenvalues with `Im lambda > 0` at `omega`, sorted by `Im lambda`
/// (damped natural frequency).
fn eigenvalues_at(
    fe: &FeModel,
    chol: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    g: &DMatrix<f64>,
    omega: f64,
) -> Result<Vec<Complex64>, FeError> {
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
    let mut lams: Vec<Complex64> = eig.iter().copied().filter(|l| l.im > tol).collect();
    lams.sort_by(|x, y| x.im.total_cmp(&y.im));
    Ok(lams)
}

/// The mode of eigenvalue `lam` at `omega`: shape, whirl, damping.
fn mode_of(fe: &FeModel, omega: f64, lam: Complex64) -> Result<Mode, FeError> {
    let shape = eigenvector(fe, omega, lam)?;
    let (whirl, whirl_ratio) = classify_whirl(&shape, fe.n_nodes());
    let abs = lam.norm();
    Ok(Mode {
        eigenvalue: lam,
        frequency: lam.im,
        undamped_frequency: abs,
        damping_ratio: -lam.re / abs,
        log_dec: -2.0 * core::f64::consts::PI * lam.re / lam.im,
        whirl,
        whirl_ratio,
        shape,
    })
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

/// Modal assurance criterion of two complex shapes,
/// `MAC = |u^H v|^2 / ((u^H u) (v^H v))`, in `[0, 1]`: 1 for proportional
/// shapes, 0 for orthogonal ones (e.g. the forward and backward circular
/// whirl of the same bending shape). Shapes of different lengths or a zero
/// shape give 0.
pub fn mac(u: &[Complex64], v: &[Complex64]) -> f64 {
    if u.len() != v.len() {
        return 0.0;
    }
    let uv: Complex64 = u.iter().zip(v).map(|(a, b)| a.conj() * b).sum();
    let uu: f64 = u.iter().map(|a| a.norm_sqr()).sum();
    let vv: f64 = v.iter().map(|a| a.norm_sqr()).sum();
    if uu > 0.0 && vv > 0.0 {
        (uv.norm_sqr() / (uu * vv)).min(1.0)
    } else {
        0.0
    }
}

/// Least MAC for two modes at neighbouring speeds to be linked as one mode
/// (below it, the mode ends and another begins).
pub const MIN_TRACK_MAC: f64 = 0.2;

/// One mode followed across the speeds of a [`CampbellDiagram`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Track {
    /// Per diagram point: the index of this mode in that point's
    /// [`CampbellPoint::modes`], `None` where it is not among them.
    pub modes: Vec<Option<usize>>,
}

impl Track {
    /// The mode at diagram point `point`, if present.
    pub fn mode<'a>(&self, diagram: &'a CampbellDiagram, point: usize) -> Option<&'a Mode> {
        let i = (*self.modes.get(point)?)?;
        diagram.points.get(point)?.modes.get(i)
    }

    /// The first diagram point where the mode is present.
    pub fn first(&self) -> Option<usize> {
        self.modes.iter().position(Option::is_some)
    }
}

/// Follows the modes across speed by mode shape. Between neighbouring
/// speeds `p`, `p + 1`, the modes are paired by the assignment that
/// maximises the summed MAC ([`mac`]) of the shaft mode shapes (Hungarian
/// algorithm), so each mode continues as one curve whatever its whirl and
/// its rank in frequency; a pair with `MAC < MIN_TRACK_MAC` is not linked
/// (the mode ends; the other starts a new track). Tracks are ordered by
/// the point where they start, then by frequency there (track 0 is the
/// lowest mode at the first speed).
pub fn track_modes(diagram: &CampbellDiagram) -> Vec<Track> {
    let n_pts = diagram.points.len();
    let mut tracks: Vec<Track> = Vec::new();
    // Track index of each mode at the previous point.
    let mut prev: Vec<usize> = Vec::new();
    for (p, point) in diagram.points.iter().enumerate() {
        let mut cur = vec![usize::MAX; point.modes.len()];
        if p > 0 {
            let before = &diagram.points[p - 1].modes;
            let w = DMatrix::from_fn(before.len(), point.modes.len(), |i, j| {
                mac(&before[i].shape, &point.modes[j].shape)
            });
            for (i, j) in max_weight_assignment(&w).into_iter().enumerate() {
                if let Some(j) = j {
                    if w[(i, j)] >= MIN_TRACK_MAC {
                        cur[j] = prev[i];
                    }
                }
            }
        }
        for (j, t) in cur.iter_mut().enumerate() {
            if *t == usize::MAX {
                *t = tracks.len();
                tracks.push(Track {
                    modes: vec![None; n_pts],
                });
            }
            tracks[*t].modes[p] = Some(j);
        }
        prev = cur;
    }
    // New tracks were numbered by start point, then by frequency rank at
    // that point (modes are sorted by frequency): already the documented
    // order.
    tracks
}

/// The assignment of rows to columns maximising the summed weight
/// (Hungarian algorithm, `O(n^2 m)`): `out[i]` is the column of row `i`,
/// `None` for rows left over when there are more rows than columns.
pub fn max_weight_assignment(w: &DMatrix<f64>) -> Vec<Option<usize>> {
    let (r, c) = w.shape();
    if r == 0 || c == 0 {
        return vec![None; r];
    }
    if r > c {
        // Assign the columns to rows instead.
        let cols = max_weight_assignment(&w.transpose());
        let mut out = vec![None; r];
        for (j, i) in cols.into_iter().enumerate() {
            if let Some(i) = i {
                out[i] = Some(j);
            }
        }
        return out;
    }
    // Minimum cost -w, rows n <= columns m; 1-based potentials (e-maxx).
    let (n, m) = (r, c);
    let cost = |i: usize, j: usize| -w[(i - 1, j - 1)];
    let mut u = vec![0.0; n + 1];
    let mut v = vec![0.0; m + 1];
    let mut p = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        p[0] = i;
        let mut j0 = 0usize;
        let mut minv = vec![f64::INFINITY; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0usize;
            for j in 1..=m {
                if !used[j] {
                    let cur = cost(i0, j) - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            if j1 == 0 {
                // Non-finite weights: nothing more to assign.
                break;
            }
            for j in 0..=m {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut out = vec![None; n];
    for j in 1..=m {
        if p[j] != 0 {
            out[p[j] - 1] = Some(j - 1);
        }
    }
    out
}

/// Which natural frequency meets the 1X line at a critical speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Crossing {
    /// The damped natural frequency: `Im lambda(Omega) = Omega` (ROSS
    /// `run_critical_speed().wd`, the frequency of the Campbell diagram).
    Damped,
    /// The undamped natural frequency: `|lambda(Omega)| = Omega` (ROSS
    /// `run_critical_speed().wn`).
    Undamped,
}

impl Crossing {
    fn frequency(self, m: &Mode) -> f64 {
        match self {
            Crossing::Damped => m.frequency,
            Crossing::Undamped => m.undamped_frequency,
        }
    }
}

/// A critical speed: a tracked mode's natural frequency equals the speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalSpeed {
    /// The speed (rad/s), also the natural frequency there.
    pub omega: f64,
    /// Which frequency crosses the 1X line.
    pub crossing: Crossing,
    /// The crossing mode: its index in the `tracks` given to
    /// [`critical_speeds`].
    pub mode: usize,
    /// Whirl of the mode at the critical speed.
    pub whirl: Whirl,
    /// Logarithmic decrement of the mode at the critical speed (-).
    pub log_dec: f64,
    /// Damping ratio of the mode at the critical speed (-).
    pub damping_ratio: f64,
    /// `|f(Omega) - Omega| / Omega` at the returned speed, `f` the crossing
    /// frequency: how well the crossing is resolved.
    pub residual: f64,
}

/// Relative speed tolerance of the critical-speed refinement.
pub const CRITICAL_SPEED_RTOL: f64 = 1e-10;

/// Most trial speeds (each one eigen-solve) spent refining one critical
/// speed.
pub const MAX_REFINE_SOLVES: usize = 60;

/// The critical speeds of the tracked modes in the diagram's speed range.
///
/// For tracked mode `k` with crossing frequency `f_k(Omega)` (`Im lambda`
/// or `|lambda|`, see [`Crossing`]), `g_k(Omega) = f_k(Omega) - Omega`.
/// Where `g_k` changes sign between neighbouring diagram speeds (both with
/// the mode present), the root is refined by the Illinois variant of
/// regula falsi: at each trial speed the mode is found again (Newton's
/// method on the eigenvalue, or a full eigen-solve and the best shape
/// match, see `matching_mode`); iteration stops when
/// the bracket or the step is below [`CRITICAL_SPEED_RTOL`] relative. The
/// result therefore does not depend on the speed step, as long as the step
/// brackets each crossing once (two crossings of one mode within one step
/// cancel and are missed). Sorted by speed.
pub fn critical_speeds(
    fe: &FeModel,
    diagram: &CampbellDiagram,
    tracks: &[Track],
    crossing: Crossing,
) -> Result<Vec<CriticalSpeed>, FeError> {
    let m = fe.mass_matrix();
    let chol = m
        .cholesky()
        .ok_or_else(|| FeError::Eigen("mass matrix is not positive definite".into()))?;
    let g = fe.gyroscopic_matrix();
    let mut out = Vec::new();
    for (k, track) in tracks.iter().enumerate() {
        for p in 0..diagram.points.len().saturating_sub(1) {
            let (Some(a), Some(b)) = (track.mode(diagram, p), track.mode(diagram, p + 1)) else {
                continue;
            };
            let (w0, w1) = (diagram.points[p].omega, diagram.points[p + 1].omega);
            if w1 <= w0 {
                continue;
            }
            let g0 = crossing.frequency(a) - w0;
            let g1 = crossing.frequency(b) - w1;
            let brackets = (g0 > 0.0 && g1 <= 0.0) || (g0 < 0.0 && g1 >= 0.0);
            if !brackets {
                continue;
            }
            let (omega, mode) = if g1 == 0.0 {
                (w1, b.clone())
            } else {
                let eval = |s: f64| -> Result<(f64, Mode), FeError> {
                    let md = matching_mode(fe, &chol, &g, s, (w0, a), (w1, b))?;
                    Ok((crossing.frequency(&md) - s, md))
                };
                refine_root(eval, (w0, g0, a), (w1, g1, b))?
            };
            out.push(CriticalSpeed {
                omega,
                crossing,
                mode: k,
                whirl: mode.whirl,
                log_dec: mode.log_dec,
                damping_ratio: mode.damping_ratio,
                residual: (crossing.frequency(&mode) - omega).abs() / omega,
            });
        }
    }
    out.sort_by(|x, y| x.omega.total_cmp(&y.omega));
    Ok(out)
}

/// Least distance-weighted MAC with the bracketing modes for the eigenvalue
/// found by [`newton_eigenvalue`] to be accepted as the tracked mode;
/// otherwise the full eigen-solve decides.
const NEWTON_ACCEPT_MAC: f64 = 0.8;

/// The mode at speed `s` that continues the tracked mode known at the
/// bracketing speeds `(w0, a)` and `(w1, b)`.
///
/// First, Newton's method on the quadratic eigenproblem from the linear
/// interpolation of `a`'s and `b`'s eigenvalues ([`newton_eigenvalue`], one
/// dense `n x n` LU per step instead of the `2n x 2n` Schur form); its
/// result is kept when its shape matches theirs (distance-weighted MAC at
/// least 0.8). Otherwise all eigenvalues are solved and, among the six
/// nearest the interpolation, the one whose shape has the largest
/// distance-weighted MAC with theirs is taken.
fn matching_mode(
    fe: &FeModel,
    chol: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    g: &DMatrix<f64>,
    s: f64,
    (w0, a): (f64, &Mode),
    (w1, b): (f64, &Mode),
) -> Result<Mode, FeError> {
    let t = ((s - w0) / (w1 - w0)).clamp(0.0, 1.0);
    let guess = a.eigenvalue + (b.eigenvalue - a.eigenvalue) * t;
    let score = |md: &Mode| (1.0 - t) * mac(&md.shape, &a.shape) + t * mac(&md.shape, &b.shape);
    let start = if t < 0.5 { &a.shape } else { &b.shape };
    if let Some(lam) = newton_eigenvalue(fe, g, s, guess, start) {
        if lam.im > 0.0 {
            let md = mode_of(fe, s, lam)?;
            if score(&md) >= NEWTON_ACCEPT_MAC {
                return Ok(md);
            }
        }
    }
    let mut lams = eigenvalues_at(fe, chol, g, s)?;
    lams.sort_by(|x, y| (x - guess).norm().total_cmp(&(y - guess).norm()));
    lams.truncate(6);
    let mut best: Option<(f64, Mode)> = None;
    for lam in lams {
        let md = mode_of(fe, s, lam)?;
        let sc = score(&md);
        if best.as_ref().is_none_or(|(bs, _)| sc > *bs) {
            best = Some((sc, md));
        }
    }
    best.map(|(_, m)| m)
        .ok_or_else(|| FeError::Eigen(format!("no mode to follow at {s} rad/s")))
}

/// An eigenvalue of `Z(lambda) = K + lambda D + lambda^2 M` (dense, all
/// DOF, `D = C + Omega G`, coefficients at `omega`) near `guess`, by
/// nonlinear inverse iteration (Newton's method on the eigenvalue, Ruhe
/// 1973): with a fixed normalisation vector `e`,
///
/// ```text
/// u = Z(lambda_k)^-1 Z'(lambda_k) x_k,   Z' = D + 2 lambda M
/// lambda_{k+1} = lambda_k - (e^H x_k) / (e^H u),   x_{k+1} = u / (e^H u)
/// ```
///
/// converging quadratically to a simple eigenvalue. The start vector is the
/// shaft shape `shape` (pedestal DOFs zero) after one inverse-iteration
/// step. `None` when the Newton step does not fall below `1e-11 |lambda|`
/// within 30 steps (the error after such a step is of rounding size).
fn newton_eigenvalue(
    fe: &FeModel,
    g: &DMatrix<f64>,
    omega: f64,
    guess: Complex64,
    shape: &[Complex64],
) -> Option<Complex64> {
    use nalgebra::DVector;
    let n = fe.n_dof();
    let cplx = |m: DMatrix<f64>| m.map(Complex64::from);
    let k = cplx(fe.stiffness_matrix(omega));
    let d = cplx(fe.damping_matrix(omega) + g * omega);
    let m = cplx(fe.mass_matrix());
    let z_at = |lam: Complex64| &k + &d * lam + &m * (lam * lam);
    let dz_at = |lam: Complex64| &d + &m * (lam * 2.0);
    let mut x = DVector::from_fn(n, |i, _| shape.get(i).copied().unwrap_or_default());
    let mut lam = guess;
    // One inverse-iteration step turns the shaft shape into a full vector.
    x = z_at(lam).lu().solve(&(dz_at(lam) * &x))?;
    let e = x.clone();
    let ex = e.dotc(&x);
    if !(ex.norm() > 0.0 && ex.is_finite()) {
        return None;
    }
    x /= ex;
    for _ in 0..30 {
        let u = z_at(lam).lu().solve(&(dz_at(lam) * &x))?;
        let eu = e.dotc(&u);
        if !(eu.norm() > 0.0 && eu.is_finite()) {
            return None;
        }
        let step = e.dotc(&x) / eu;
        lam -= step;
        x = u / eu;
        if !lam.is_finite() {
            return None;
        }
        if step.norm() <= 1e-11 * lam.norm() {
            return Some(lam);
        }
    }
    None
}

/// Root of `eval` in the bracket `[x0, x1]` (`g0`, `g1` of opposite signs)
/// by the Illinois method, with bisection when a step would leave the
/// bracket. Returns the speed and the mode there.
fn refine_root(
    mut eval: impl FnMut(f64) -> Result<(f64, Mode), FeError>,
    (mut x0, mut g0, m0): (f64, f64, &Mode),
    (mut x1, mut g1, m1): (f64, f64, &Mode),
) -> Result<(f64, Mode), FeError> {
    let mut best = if g0.abs() < g1.abs() {
        (x0, g0, m0.clone())
    } else {
        (x1, g1, m1.clone())
    };
    let mut side = 0i8;
    let mut last = f64::NAN;
    for _ in 0..MAX_REFINE_SOLVES {
        let mut x = (x0 * g1 - x1 * g0) / (g1 - g0);
        let (lo, hi) = (x0.min(x1), x0.max(x1));
        if !(x > lo && x < hi) {
            x = 0.5 * (x0 + x1);
        }
        let (gx, mode) = eval(x)?;
        let step = (x - last).abs();
        last = x;
        if gx.abs() < best.1.abs() {
            best = (x, gx, mode);
        }
        let tol = CRITICAL_SPEED_RTOL * x.abs();
        if gx == 0.0 || step <= tol || (x1 - x0).abs() <= tol {
            break;
        }
        if (gx > 0.0) == (g1 > 0.0) {
            x1 = x;
            g1 = gx;
            if side == -1 {
                g0 *= 0.5;
            }
            side = -1;
        } else {
            x0 = x;
            g0 = gx;
            if side == 1 {
                g1 *= 0.5;
            }
            side = 1;
        }
    }
    Ok((best.0, best.2))
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

    #[test]
    fn mac_of_shapes() {
        let c = Complex64::new;
        let u = [c(1.0, 0.0), c(0.0, -1.0)];
        // Proportional (complex factor): 1; forward vs backward circular: 0.
        let v: Vec<Complex64> = u.iter().map(|x| x * c(0.3, -2.0)).collect();
        assert!((mac(&u, &v) - 1.0).abs() < 1e-15);
        assert_eq!(mac(&u, &[c(1.0, 0.0), c(0.0, 1.0)]), 0.0);
        // Planar vs circular: 1/2.
        assert!((mac(&u, &[c(1.0, 0.0), c(0.0, 0.0)]) - 0.5).abs() < 1e-15);
        assert_eq!(mac(&u, &[c(1.0, 0.0)]), 0.0);
        assert_eq!(mac(&u, &[c(0.0, 0.0), c(0.0, 0.0)]), 0.0);
    }

    #[test]
    fn assignment_maximises_the_sum() {
        // Greedy (row 0 takes its best, 0.9) gives 0.9 + 0.1; the optimum
        // is 0.8 + 0.85.
        let w = DMatrix::from_row_slice(2, 2, &[0.9, 0.8, 0.85, 0.1]);
        assert_eq!(max_weight_assignment(&w), vec![Some(1), Some(0)]);
        // Rectangular both ways.
        let w = DMatrix::from_row_slice(2, 3, &[0.1, 0.2, 0.9, 0.7, 0.1, 0.8]);
        assert_eq!(max_weight_assignment(&w), vec![Some(2), Some(0)]);
        let w = w.transpose();
        assert_eq!(max_weight_assignment(&w), vec![Some(1), None, Some(0)]);
        assert!(max_weight_assignment(&DMatrix::zeros(0, 3)).is_empty());
    }
}
