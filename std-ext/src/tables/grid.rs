//! Speed grids for the bearing-level tables: uniform in rpm, or adaptive
//! (refined by bisection where the table's interpolation would miss the
//! direct computation by more than a tolerance).
//!
//! The interpolation is the one of the firmware lookup,
//! [`rotorid_core::table::weights`] (pole-factored linear: `p A / Omega^2`
//! and `p B / Omega^2` linear in `Omega` between grid speeds, with
//! `p(Omega) = prod_k (Omega_k^2 - Omega^2)` over the poles of the reduced
//! model), applied here to dynamic-size matrices by [`interpolate`]: the
//! grid is judged by exactly what the firmware will compute.
//!
//! The error measure at a speed is
//! `e = max(|A_i - A|_F / |A|_F, |B_i - B|_F / |B|_F)`
//! (Frobenius norms, `_i` interpolated, plain the direct computation).

use num_complex::Complex64;
use rotorid_core::table::{locate, weights, Position, TableError, POLE_GUARD};
use thiserror::Error;

use crate::reduce::{PoleSets, ReducedTerms};
use crate::units::rpm_to_rad_s;

/// Error building a grid.
#[derive(Debug, Error)]
pub enum GridError<E: std::error::Error + 'static> {
    /// Bad grid parameters (named).
    #[error("{0}")]
    Invalid(String),
    /// The direct computation failed at a speed.
    #[error("at {omega} rad/s: {source}")]
    Eval {
        /// Speed (rad/s).
        omega: f64,
        /// Cause.
        source: E,
    },
    /// The interpolation failed (e.g. a check speed on a pole).
    #[error("interpolation at {omega} rad/s: {source}")]
    Interp {
        /// Speed (rad/s).
        omega: f64,
        /// Cause.
        source: TableError,
    },
}

/// A uniform speed grid that cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpeedGridError {
    /// `rpm_min` is not finite or negative.
    #[error("--rpm-min must be finite and >= 0, got {0}")]
    Min(f64),
    /// `rpm_max` is not finite or below `rpm_min`.
    #[error("--rpm-max must be finite and >= --rpm-min ({min}), got {max}")]
    Max {
        /// The lower end (rpm).
        min: f64,
        /// The upper end (rpm).
        max: f64,
    },
    /// `rpm_step` is not finite or not positive.
    #[error("--rpm-step must be finite and > 0, got {0}")]
    Step(f64),
    /// More than [`MAX_GRID_POINTS`] speeds.
    #[error("{0} speeds is too many (at most 10000000)")]
    TooMany(f64),
}

/// The largest uniform grid [`uniform_rpm`] builds.
pub const MAX_GRID_POINTS: usize = 10_000_000;

/// The one uniform speed grid of rotorid (rpm): from `rpm_min` in steps of
/// `rpm_step` up to and including `rpm_max` when it falls on the grid
/// (within 1e-9 of a step). Speeds are `rpm_min + k rpm_step`, `k = 0..n`
/// with an integer count `n = floor((rpm_max - rpm_min) / rpm_step + 1e-9) + 1`,
/// so no rounding drift accumulates.
///
/// Requires finite values, `rpm_min >= 0`, `rpm_step > 0`,
/// `rpm_max >= rpm_min` and at most [`MAX_GRID_POINTS`] speeds. (Tables
/// need `rpm_min > 0`: they store `B / Omega^2`, which is lost at rest; the
/// table builder checks that.)
pub fn uniform_rpm(rpm_min: f64, rpm_max: f64, rpm_step: f64) -> Result<Vec<f64>, SpeedGridError> {
    if !(rpm_min.is_finite() && rpm_min >= 0.0) {
        return Err(SpeedGridError::Min(rpm_min));
    }
    if !(rpm_max.is_finite() && rpm_max >= rpm_min) {
        return Err(SpeedGridError::Max {
            min: rpm_min,
            max: rpm_max,
        });
    }
    if !(rpm_step.is_finite() && rpm_step > 0.0) {
        return Err(SpeedGridError::Step(rpm_step));
    }
    let span = (rpm_max - rpm_min) / rpm_step;
    if span >= MAX_GRID_POINTS as f64 {
        return Err(SpeedGridError::TooMany(span.floor() + 1.0));
    }
    let n = (span + 1e-9).floor() as usize + 1;
    Ok((0..n).map(|k| rpm_min + k as f64 * rpm_step).collect())
}

/// [`uniform_rpm`] converted to rad/s.
pub fn uniform_rad_s(
    rpm_min: f64,
    rpm_max: f64,
    rpm_step: f64,
) -> Result<Vec<f64>, SpeedGridError> {
    Ok(uniform_rpm(rpm_min, rpm_max, rpm_step)?
        .into_iter()
        .map(rpm_to_rad_s)
        .collect())
}

/// `n >= 2` speeds equally spaced in `[omega_min, omega_max]` (rad/s).
pub fn linspace(omega_min: f64, omega_max: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    let h = (omega_max - omega_min) / (n - 1) as f64;
    (0..n)
        .map(|k| {
            if k == n - 1 {
                omega_max
            } else {
                omega_min + k as f64 * h
            }
        })
        .collect()
}

/// The table at `omega` from the grid `terms` (sorted by speed), with the
/// firmware's scheme ([`rotorid_core::table::weights`]): exact at grid
/// speeds, pole-factored linear between them, an error outside.
pub fn interpolate(
    terms: &[ReducedTerms],
    poles: &PoleSets,
    omega: f64,
) -> Result<ReducedTerms, TableError> {
    match locate(terms.len(), |i| terms.get(i).map(|t| t.omega), omega)? {
        Position::Exact(i) => terms.get(i).cloned().ok_or(TableError::Corrupt),
        Position::Between(i) => {
            let (t0, t1) = (
                terms.get(i).ok_or(TableError::Corrupt)?,
                terms.get(i + 1).ok_or(TableError::Corrupt)?,
            );
            let wa = weights(omega, t0.omega, t1.omega, &poles.a)?;
            let wb = weights(omega, t0.omega, t1.omega, &poles.b)?;
            Ok(ReducedTerms {
                omega,
                a: &t0.a * Complex64::from(wa.c0) + &t1.a * Complex64::from(wa.c1),
                b: &t0.b * Complex64::from(wb.c0) + &t1.b * Complex64::from(wb.c1),
            })
        }
    }
}

/// Relative interpolation error `max(|dA|_F / |A|_F, |dB|_F / |B|_F)` of
/// `approx` against `exact` (a matrix with zero norm contributes its
/// absolute error; an empty `B` contributes nothing).
pub fn relative_error(exact: &ReducedTerms, approx: &ReducedTerms) -> f64 {
    let rel = |x: f64, d: f64| if x > 0.0 { d / x } else { d };
    let ea = rel(exact.a.norm(), (&exact.a - &approx.a).norm());
    let eb = if exact.b.is_empty() {
        0.0
    } else {
        rel(exact.b.norm(), (&exact.b - &approx.b).norm())
    };
    ea.max(eb)
}

/// The pole whose guard band ([`POLE_GUARD`]) contains `omega`, if any.
fn guarding_pole(omega: f64, poles: &PoleSets) -> Option<f64> {
    poles
        .a
        .iter()
        .chain(&poles.b)
        .copied()
        .find(|&p| (omega - p).abs() <= POLE_GUARD * p)
}

/// Where to test and split `(w0, w1)`: the midpoint, or, if it lies in a
/// pole's guard band, the nearer of `p (1 -+ 2 POLE_GUARD)` inside the
/// interval; `None` if there is no such point.
fn split_point(w0: f64, w1: f64, poles: &PoleSets) -> Option<f64> {
    let mid = 0.5 * (w0 + w1);
    let Some(p) = guarding_pole(mid, poles) else {
        return Some(mid);
    };
    let g = 2.0 * POLE_GUARD * p;
    [p - g, p + g]
        .into_iter()
        .filter(|&s| s > w0 && s < w1 && guarding_pole(s, poles).is_none())
        .min_by(|a, b| (a - mid).abs().total_cmp(&(b - mid).abs()))
}

/// Result of checking a grid on a finer one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckReport {
    /// Worst relative interpolation error found.
    pub worst_error: f64,
    /// Speed where it was found (rad/s).
    pub at_omega: f64,
    /// Number of check speeds (not counting the grid speeds).
    pub n_checked: usize,
    /// Check speeds skipped because they fall in a pole's guard band
    /// ([`POLE_GUARD`]), where the lookup answers `Err(Pole)` by design.
    pub n_skipped: usize,
}

/// Worst interpolation error of the grid `terms` on a `factor` times finer
/// check grid: each interval is cut into `factor` equal parts and the
/// `factor - 1` interior speeds are computed directly (`eval`) and compared
/// with [`interpolate`]; speeds in a pole's guard band are skipped (counted
/// in [`CheckReport::n_skipped`]). Stops early once an error exceeds
/// `stop_above` (pass `f64::INFINITY` for the full check).
pub fn check_grid<E: std::error::Error + 'static>(
    eval: &mut impl FnMut(f64) -> Result<ReducedTerms, E>,
    terms: &[ReducedTerms],
    poles: &PoleSets,
    factor: usize,
    stop_above: f64,
) -> Result<CheckReport, GridError<E>> {
    let mut rep = CheckReport {
        worst_error: 0.0,
        at_omega: terms.first().map_or(0.0, |t| t.omega),
        n_checked: 0,
        n_skipped: 0,
    };
    for pair in terms.windows(2) {
        let (w0, w1) = (pair[0].omega, pair[1].omega);
        for k in 1..factor {
            let omega = w0 + (w1 - w0) * k as f64 / factor as f64;
            if !(omega > w0 && omega < w1) {
                continue;
            }
            if guarding_pole(omega, poles).is_some() {
                rep.n_skipped += 1;
                continue;
            }
            let exact = eval(omega).map_err(|source| GridError::Eval { omega, source })?;
            let approx = interpolate(terms, poles, omega)
                .map_err(|source| GridError::Interp { omega, source })?;
            let e = relative_error(&exact, &approx);
            rep.n_checked += 1;
            if e > rep.worst_error || e.is_nan() {
                rep.worst_error = e;
                rep.at_omega = omega;
            }
            if e > stop_above || e.is_nan() {
                return Ok(rep);
            }
        }
    }
    Ok(rep)
}

/// Settings of the adaptive grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveOptions {
    /// Relative interpolation tolerance the grid must meet on the check grid.
    pub tol: f64,
    /// Midpoints are refined until their error is below `safety * tol`
    /// (the check grid then has margin), in (0, 1].
    pub safety: f64,
    /// Equal intervals of the starting grid.
    pub initial_intervals: usize,
    /// Check grid factor (10: ten times finer).
    pub check_factor: usize,
    /// Intervals narrower than `min_width` (rad/s) are not split further.
    pub min_width: f64,
    /// Upper bound on the number of grid speeds.
    pub max_points: usize,
}

impl AdaptiveOptions {
    /// Defaults for a tolerance: safety 0.5, 16 starting intervals, 10x
    /// check grid, 1e-6 rad/s minimum width, 200 000 points at most.
    pub fn new(tol: f64) -> Self {
        AdaptiveOptions {
            tol,
            safety: 0.5,
            initial_intervals: 16,
            check_factor: 10,
            min_width: 1e-6,
            max_points: 200_000,
        }
    }
}

/// An adaptive grid with its terms and its quality.
#[derive(Debug, Clone)]
pub struct AdaptiveGrid {
    /// Terms at the grid speeds, increasing speed.
    pub terms: Vec<ReducedTerms>,
    /// Worst error on the `check_factor` times finer check grid.
    pub check: CheckReport,
    /// Direct computations made while refining (midpoints included).
    pub evaluations: usize,
    /// Whether the check grid met the tolerance.
    pub met_tolerance: bool,
}

struct Refiner<'a, E, F: FnMut(f64) -> Result<ReducedTerms, E>> {
    eval: &'a mut F,
    poles: &'a PoleSets,
    target: f64,
    min_width: f64,
    max_points: usize,
    evaluations: usize,
    _e: std::marker::PhantomData<E>,
}

impl<E: std::error::Error + 'static, F: FnMut(f64) -> Result<ReducedTerms, E>> Refiner<'_, E, F> {
    fn eval(&mut self, omega: f64) -> Result<ReducedTerms, GridError<E>> {
        self.evaluations += 1;
        (self.eval)(omega).map_err(|source| GridError::Eval { omega, source })
    }

    /// Appends to `out` the refined speeds of `(left, right]`, in order.
    fn refine(
        &mut self,
        left: &ReducedTerms,
        right: ReducedTerms,
        out: &mut Vec<ReducedTerms>,
        depth: usize,
    ) -> Result<(), GridError<E>> {
        let width = right.omega - left.omega;
        let split = split_point(left.omega, right.omega, self.poles);
        let Some(mid) =
            split.filter(|_| depth <= 60 && width > self.min_width && out.len() < self.max_points)
        else {
            out.push(right);
            return Ok(());
        };
        let exact = self.eval(mid)?;
        let pair = [left.clone(), right];
        let e = match interpolate(&pair, self.poles, mid) {
            Ok(approx) => relative_error(&exact, &approx),
            // Midpoint on a pole: split.
            Err(_) => f64::INFINITY,
        };
        let [_, right] = pair;
        if e <= self.target {
            out.push(right);
            return Ok(());
        }
        self.refine(left, exact.clone(), out, depth + 1)?;
        self.refine(&exact, right, out, depth + 1)
    }
}

/// Adaptive grid on `[omega_min, omega_max]` (rad/s): starts from
/// `initial_intervals` equal intervals, bisects every interval whose
/// midpoint interpolation error (against `eval`, the direct computation)
/// exceeds `safety * tol`, then checks the result on a `check_factor` times
/// finer grid; intervals that still fail there are bisected and refined
/// again (up to 8 rounds). The returned [`AdaptiveGrid::check`] is the
/// final full check.
pub fn adaptive<E: std::error::Error + 'static>(
    mut eval: impl FnMut(f64) -> Result<ReducedTerms, E>,
    poles: &PoleSets,
    omega_min: f64,
    omega_max: f64,
    opts: AdaptiveOptions,
) -> Result<AdaptiveGrid, GridError<E>> {
    if !(omega_min.is_finite() && omega_max.is_finite() && omega_min > 0.0 && omega_max > omega_min)
    {
        return Err(GridError::Invalid(format!(
            "adaptive grid needs 0 < min < max, got [{omega_min}, {omega_max}] rad/s"
        )));
    }
    if !(opts.tol.is_finite() && opts.tol > 0.0) {
        return Err(GridError::Invalid(format!(
            "tolerance must be finite and > 0, got {}",
            opts.tol
        )));
    }
    if !(opts.safety > 0.0 && opts.safety <= 1.0) || opts.check_factor < 2 {
        return Err(GridError::Invalid(
            "safety must be in (0, 1] and check factor >= 2".into(),
        ));
    }
    let mut r = Refiner {
        eval: &mut eval,
        poles,
        target: opts.safety * opts.tol,
        min_width: opts.min_width,
        max_points: opts.max_points,
        evaluations: 0,
        _e: std::marker::PhantomData,
    };
    let start = linspace(omega_min, omega_max, opts.initial_intervals.max(1) + 1);
    let mut nodes = Vec::with_capacity(start.len());
    for &w in &start {
        nodes.push(r.eval(w)?);
    }
    let mut terms = vec![nodes[0].clone()];
    for pair in nodes.windows(2) {
        r.refine(&pair[0], pair[1].clone(), &mut terms, 0)?;
    }
    let mut check = CheckReport {
        worst_error: f64::INFINITY,
        at_omega: omega_min,
        n_checked: 0,
        n_skipped: 0,
    };
    for _round in 0..8 {
        check = check_grid(r.eval, &terms, poles, opts.check_factor, f64::INFINITY)?;
        r.evaluations += check.n_checked;
        if check.worst_error <= opts.tol || terms.len() >= opts.max_points {
            break;
        }
        // Split every interval with a failing check speed, and refine.
        let mut next = vec![terms[0].clone()];
        for pair in terms.windows(2) {
            let (w0, w1) = (pair[0].omega, pair[1].omega);
            let mut worst: f64 = 0.0;
            for k in 1..opts.check_factor {
                let omega = w0 + (w1 - w0) * k as f64 / opts.check_factor as f64;
                if !(omega > w0 && omega < w1) || guarding_pole(omega, poles).is_some() {
                    continue;
                }
                let exact = r.eval(omega)?;
                let e = interpolate(pair, poles, omega)
                    .map(|a| relative_error(&exact, &a))
                    .unwrap_or(f64::INFINITY);
                worst = worst.max(e);
            }
            let split = split_point(w0, w1, poles).filter(|_| w1 - w0 > opts.min_width);
            if let (true, Some(s)) = (worst > opts.tol, split) {
                let mid = r.eval(s)?;
                r.refine(&pair[0], mid.clone(), &mut next, 0)?;
                r.refine(&mid, pair[1].clone(), &mut next, 0)?;
            } else {
                next.push(pair[1].clone());
            }
        }
        terms = next;
    }
    Ok(AdaptiveGrid {
        met_tolerance: check.worst_error <= opts.tol,
        terms,
        check,
        evaluations: r.evaluations,
    })
}

/// The smallest number of equally spaced speeds on `[omega_min, omega_max]`
/// whose `check_factor` times finer check error is at most `tol`, found by
/// doubling then bisection on the count (up to `max_points`); `None` if even
/// `max_points` does not reach it. Returns the count and its check report.
pub fn uniform_points_needed<E: std::error::Error + 'static>(
    mut eval: impl FnMut(f64) -> Result<ReducedTerms, E>,
    poles: &PoleSets,
    omega_min: f64,
    omega_max: f64,
    tol: f64,
    check_factor: usize,
    max_points: usize,
) -> Result<Option<(usize, CheckReport)>, GridError<E>> {
    let mut try_n = |n: usize| -> Result<(bool, CheckReport), GridError<E>> {
        let mut terms = Vec::with_capacity(n);
        for w in linspace(omega_min, omega_max, n) {
            terms.push(eval(w).map_err(|source| GridError::Eval { omega: w, source })?);
        }
        let rep = check_grid(&mut eval, &terms, poles, check_factor, tol)?;
        Ok((rep.worst_error <= tol, rep))
    };
    let mut lo = 1usize; // fails (or is below the minimum of 2)
    let mut hi = 2usize;
    let mut best;
    loop {
        let (ok, rep) = try_n(hi)?;
        if ok {
            best = rep;
            break;
        }
        if hi >= max_points {
            return Ok(None);
        }
        lo = hi;
        hi = (hi * 2).min(max_points);
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        let (ok, rep) = try_n(mid)?;
        if ok {
            hi = mid;
            best = rep;
        } else {
            lo = mid;
        }
    }
    Ok(Some((hi, best)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_includes_max_on_grid_only() {
        let g = uniform_rpm(50.0, 15000.0, 50.0).unwrap();
        assert_eq!(g.len(), 300);
        assert_eq!(*g.last().unwrap(), 15000.0);
        let g = uniform_rpm(0.0, 1.0, 0.1).unwrap();
        assert_eq!(g.len(), 11);
        assert!((g[10] - 1.0).abs() < 1e-12);
        let g = uniform_rpm(0.0, 1.05, 0.1).unwrap();
        assert_eq!(g.len(), 11);
        assert_eq!(uniform_rpm(100.0, 100.0, 50.0).unwrap(), vec![100.0]);
        assert!(uniform_rpm(100.0, 50.0, 50.0).is_err());
        assert!(uniform_rpm(0.0, 50.0, 0.0).is_err());
        assert!(uniform_rpm(-1.0, 50.0, 1.0).is_err());
        assert!(uniform_rpm(0.0, f64::NAN, 1.0).is_err());
        assert!(uniform_rpm(0.0, 1e12, 1e-3).is_err());
    }
    use nalgebra::DMatrix;

    #[test]
    fn uniform_grid_follows_the_spec() {
        let g = uniform_rpm(50.0, 15000.0, 50.0).unwrap();
        assert_eq!(g.len(), 300);
        assert_eq!(g[0], 50.0);
        assert_eq!(*g.last().unwrap(), 15000.0);
        let g = uniform_rpm(50.0, 1020.0, 100.0).unwrap();
        assert_eq!(*g.last().unwrap(), 950.0);
        assert_eq!(uniform_rpm(10.0, 10.0, 5.0).unwrap(), vec![10.0]);
        // A grid may start at rest (simulate); the table builder and
        // `rotorid tables` refuse speed 0 themselves (tests/tables/cli.rs).
        assert_eq!(uniform_rpm(0.0, 10.0, 5.0).unwrap(), vec![0.0, 5.0, 10.0]);
        assert!(uniform_rpm(10.0, 5.0, 5.0).is_err());
        assert!(uniform_rpm(10.0, 50.0, 0.0).is_err());
        assert!(uniform_rpm(10.0, f64::NAN, 1.0).is_err());
        // 0.1 steps: the integer count avoids drift.
        let g = uniform_rpm(0.1, 1.0, 0.1).unwrap();
        assert_eq!(g.len(), 10);
    }

    #[derive(Debug, thiserror::Error)]
    #[error("never")]
    struct Never;

    /// A synthetic reduced model with a pole at 100 rad/s:
    /// `A = [[1 + 1e4 / (1e4 - w^2), 2], [0.5 j, 3]]`, `B = w^2 / (1e4 - w^2)`.
    fn synthetic(w: f64) -> Result<ReducedTerms, Never> {
        let d = 1e4 - w * w;
        let a = DMatrix::from_row_slice(
            2,
            2,
            &[
                Complex64::new(1.0 + 1e4 / d, 0.0),
                Complex64::new(2.0, 0.0),
                Complex64::new(0.0, 0.5),
                Complex64::new(3.0, 0.0),
            ],
        );
        let b = DMatrix::from_element(2, 1, Complex64::new(w * w / d, 0.0));
        Ok(ReducedTerms { omega: w, a, b })
    }

    #[test]
    fn adaptive_grid_meets_tolerance_across_a_pole() {
        for tol in [1e-4, 1e-6] {
            let poles = PoleSets {
                a: vec![100.0],
                b: vec![100.0],
            };
            let g = adaptive(synthetic, &poles, 10.0, 200.0, AdaptiveOptions::new(tol)).unwrap();
            assert!(g.met_tolerance, "{tol}: {:?}", g.check);
            assert!(g.check.worst_error <= tol);
            for p in g.terms.windows(2) {
                assert!(p[1].omega > p[0].omega);
            }
            // An independent check grid, denser still.
            let check = check_grid(&mut synthetic, &g.terms, &poles, 37, f64::INFINITY).unwrap();
            assert!(check.worst_error <= 1.5 * tol, "{tol}: {check:?}");
        }
    }

    #[test]
    fn plain_linear_interpolation_fails_near_the_pole() {
        // Without the pole factor, the interval holding the pole is O(1) wrong.
        let g = adaptive(
            synthetic,
            &PoleSets::none(),
            10.0,
            200.0,
            AdaptiveOptions::new(1e-4),
        )
        .unwrap();
        assert!(!g.met_tolerance || g.terms.len() > 10_000);
    }
}
