//! Time integration of the full finite-element model through a speed ramp:
//! the reference the steady-state 1X response ([`crate::fe::response`]) is
//! checked against.
//!
//! # Equations of motion
//!
//! On all `n_dof` DOFs of [`FeModel`] (shaft and pedestals, nothing
//! reduced or condensed),
//!
//! ```text
//! M q'' + (C(Omega) + Omega G) q' + K(Omega) q = f(t),
//! ```
//!
//! `M`, `G` of shaft, disks and pedestal masses, `K(Omega)`, `C(Omega)` of
//! the shaft, the rotor's proportional damping, the bearings' coefficients
//! at the current speed ([`crate::model::BearingLaw::at`]) and the
//! pedestals. The speed follows a constant angular acceleration `alpha`
//! (rad/s^2; negative on a coast-down):
//!
//! ```text
//! Omega(t) = Omega_0 + alpha t,    theta(t) = theta_0 + Omega_0 t + alpha t^2 / 2   (rad)
//! ```
//!
//! `theta` the angle of the rotor, turning from +y toward +z.
//!
//! # Forcing
//!
//! A mass unbalance `m e` at angle `beta` sits at `e (cos(theta + beta),
//! sin(theta + beta))`; the rotor feels minus its mass times its
//! acceleration,
//!
//! ```text
//! f_y = m e (Omega^2 cos(theta + beta) + alpha sin(theta + beta))
//! f_z = m e (Omega^2 sin(theta + beta) - alpha cos(theta + beta))
//! ```
//!
//! i.e. `f = Re{ U (Omega^2 - j alpha) exp(j theta) }` with `U` the
//! unbalance's phasor force per unit `Omega^2` ([`FeModel::unbalance_force`]
//! at 1 rad/s: `a` on y, `-j a` on z, SPEC section 2). A shaft bow (fixed
//! in the rotating frame) adds `Re{ F_bow exp(j theta) }`. At constant
//! speed (`alpha = 0`) this is exactly the phasor forcing of the
//! steady-state solver with `Omega t = theta`.
//!
//! # Newmark's average acceleration
//!
//! With step `h`, `gamma = 1/2`, `beta = 1/4` (unconditionally stable, no
//! numerical damping):
//!
//! ```text
//! q_(n+1) = q_n + h v_n + h^2 (a_n + a_(n+1)) / 4
//! v_(n+1) = v_n + h (a_n + a_(n+1)) / 2
//! ```
//!
//! and the equation of motion at `t_(n+1)` (with `D = C + Omega G`,
//! everything at `Omega_(n+1)`) give one linear system per step:
//!
//! ```text
//! S q_(n+1) = f_(n+1) + M (4/h^2 q_n + 4/h v_n + a_n) + D (2/h q_n + v_n),
//! S = 4/h^2 M + 2/h D + K,
//! a_(n+1) = 4/h^2 (q_(n+1) - q_n - h v_n) - a_n,   v_(n+1) = 2/h (q_(n+1) - q_n) - v_n.
//! ```
//!
//! # Accuracy
//!
//! The scheme is the trapezoidal rule on `(q, v)`; for a forcing
//! `F exp(j Omega t)` at constant speed its steady state solves
//! `Z_h(Omega) Q = F` with the continuous dynamic stiffness at the warped
//! frequency
//!
//! ```text
//! Omega_h = (2/h) tan(Omega h / 2) = Omega (1 + (Omega h)^2 / 12 + ...),
//! Z_h = K(Omega) - Omega_h^2 M + j Omega_h (C(Omega) + Omega G)
//! ```
//!
//! (`K`, `C`, `G Omega` and the force stay at the true speed): the error of
//! the steady state is that of a frequency error `(Omega h)^2 / 12`, which
//! near a mode of damping ratio `zeta` moves the response by up to about
//! `(Omega h)^2 / (12 zeta)` relative. [`warped_response`] computes `Z_h^-1
//! F`, which the tests match to rounding.
//!
//! # Cost: one factorisation per speed interval
//!
//! The DOFs are reordered so that each pedestal's two DOFs follow its
//! bearing node's four: the system matrices are banded (half bandwidth 7
//! without pedestals, at most 9 with). `S` depends on the speed through
//! `Omega G` and the bearings. It is factored (banded LU) at a reference
//! speed `Omega_r` and re-factored when `|Omega - Omega_r|` exceeds
//! [`Integrator::REFACTOR`] `Omega_r`; each step solves `S(Omega) x = r`
//! by the iteration `x <- x + S(Omega_r)^-1 (r - S(Omega) x)` from the
//! predictor `q_n + h v_n + h^2 a_n / 2`, until the correction is below
//! [`Integrator::TOLERANCE`] of the largest displacement. The iteration
//! converges as `|S(Omega_r)^-1 (S(Omega) - S(Omega_r))|`, of the order
//! of the relative change of the bearing coefficients over the interval
//! plus `|Omega - Omega_r| h`: two or three solves a step, each
//! `O(n_dof x bandwidth)`. The converged step is the exact Newmark step
//! (to [`Integrator::TOLERANCE`]).

use crate::fe::assembly::{Dir, FeError, FeModel};
use crate::fe::bearing::{damping, stiffness};
use crate::fe::response::Forcing;
use nalgebra::{DMatrix, Matrix2};
use num_complex::Complex64;

/// A real square band matrix (half bandwidth `w` above and below), row
/// storage: entry `(i, j)`, `|i - j| <= w`, at `i (2 w + 1) + j - i + w`.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    n: usize,
    w: usize,
    a: Vec<f64>,
}

impl Band {
    /// The zero `n x n` matrix of half bandwidth `w`.
    pub fn zeros(n: usize, w: usize) -> Self {
        Band {
            n,
            w,
            a: vec![0.0; n * (2 * w + 1)],
        }
    }

    fn idx(&self, i: usize, j: usize) -> usize {
        i * (2 * self.w + 1) + j + self.w - i
    }

    /// Adds `v` at `(i, j)`; outside the band is an error.
    pub fn add(&mut self, i: usize, j: usize, v: f64) -> Result<(), FeError> {
        if i >= self.n || j >= self.n || i.abs_diff(j) > self.w {
            return Err(FeError::Invalid(format!(
                "entry ({i}, {j}) outside the band (n = {}, w = {})",
                self.n, self.w
            )));
        }
        let k = self.idx(i, j);
        self.a[k] += v;
        Ok(())
    }

    /// Entry `(i, j)` (0 outside the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        if i >= self.n || j >= self.n || i.abs_diff(j) > self.w {
            0.0
        } else {
            self.a[self.idx(i, j)]
        }
    }

    /// `self + s other` (same shape).
    fn axpy(&mut self, s: f64, other: &Band) {
        for (a, b) in self.a.iter_mut().zip(&other.a) {
            *a += s * b;
        }
    }

    /// `y += s A x`.
    pub fn mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        let (n, w) = (self.n, self.w);
        let row_len = 2 * w + 1;
        for (i, yi) in y.iter_mut().enumerate().take(n) {
            let lo = i.saturating_sub(w);
            let hi = (i + w).min(n - 1);
            let row = &self.a[i * row_len + lo + w - i..=i * row_len + hi + w - i];
            let acc: f64 = row.iter().zip(&x[lo..=hi]).map(|(a, b)| a * b).sum();
            *yi += s * acc;
        }
    }

    /// LU factorisation without pivoting (`L` unit lower, both within the
    /// band). Fails on a pivot that is not finite or below `1e-14` of the
    /// largest entry. Used on `S = 4/h^2 M + 2/h D + K`, whose symmetric
    /// part is positive definite for the steps used (the mass term
    /// dominates), so that every leading minor is nonzero.
    pub fn into_lu(mut self) -> Result<Band, FeError> {
        let (n, w) = (self.n, self.w);
        let scale = self.a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for k in 0..n {
            let p = self.a[self.idx(k, k)];
            if !(p.is_finite() && p.abs() > 1e-14 * scale) {
                return Err(FeError::Invalid(format!(
                    "time step: zero pivot at DOF {k} in the Newmark system matrix"
                )));
            }
            let last = (k + w).min(n - 1);
            for i in k + 1..=last {
                let ik = self.idx(i, k);
                let l = self.a[ik] / p;
                self.a[ik] = l;
                if l != 0.0 {
                    for j in k + 1..=last {
                        let kj = self.a[self.idx(k, j)];
                        let ij = self.idx(i, j);
                        self.a[ij] -= l * kj;
                    }
                }
            }
        }
        Ok(self)
    }

    /// Solves `L U x = b` in place with the factors of [`Band::into_lu`].
    pub fn lu_solve(&self, b: &mut [f64]) {
        let (n, w) = (self.n, self.w);
        for i in 0..n {
            let lo = i.saturating_sub(w);
            let mut s = b[i];
            for (j, bj) in b.iter().enumerate().take(i).skip(lo) {
                s -= self.a[self.idx(i, j)] * bj;
            }
            b[i] = s;
        }
        for i in (0..n).rev() {
            let hi = (i + w).min(n - 1);
            let mut s = b[i];
            for (j, bj) in b.iter().enumerate().take(hi + 1).skip(i + 1) {
                s -= self.a[self.idx(i, j)] * bj;
            }
            b[i] = s / self.a[self.idx(i, i)];
        }
    }
}

/// A speed ramp at constant angular acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ramp {
    /// Speed at `t = 0` (rad/s).
    pub omega0: f64,
    /// Angular acceleration (rad/s^2), negative on a coast-down.
    pub alpha: f64,
    /// Rotor angle at `t = 0` (rad).
    pub theta0: f64,
}

impl Ramp {
    /// Speed at `t` (rad/s).
    pub fn omega(&self, t: f64) -> f64 {
        self.omega0 + self.alpha * t
    }

    /// Angle at `t` (rad).
    pub fn theta(&self, t: f64) -> f64 {
        self.theta0 + self.omega0 * t + 0.5 * self.alpha * t * t
    }
}

/// One bearing's coupling in the reordered DOFs.
#[derive(Debug, Clone)]
struct Support {
    /// Shaft y, z (reordered).
    shaft: [usize; 2],
    /// Pedestal y, z (reordered), if any.
    pedestal: Option<[usize; 2]>,
}

/// Newmark integration of one [`FeModel`] under one [`Forcing`] along a
/// [`Ramp`] (see the module documentation).
#[derive(Debug, Clone)]
pub struct Integrator {
    fe: FeModel,
    ramp: Ramp,
    h: f64,
    n: usize,
    /// `inv[old] = new` DOF index.
    inv: Vec<usize>,
    m: Band,
    g: Band,
    /// Speed-independent stiffness (shaft, pedestals to ground).
    k0: Band,
    /// Speed-independent damping (rotor's proportional, pedestals).
    c0: Band,
    supports: Vec<Support>,
    /// Unbalance force per unit `Omega^2 - j alpha`, and the bow force (reordered).
    unb: Vec<Complex64>,
    bow: Vec<Complex64>,
    /// `4/h^2 M + 2/h C0 + K0` (reordered).
    p: Band,
    lu: Band,
    omega_ref: f64,
    t: f64,
    step_no: u64,
    q: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    /// Scratch.
    r: Vec<f64>,
    x: Vec<f64>,
    res: Vec<f64>,
    /// Solves spent (statistics).
    solves: u64,
    factorisations: u64,
}

impl Integrator {
    /// Re-factor when the speed has moved by this fraction of the speed of
    /// the last factorisation (or by `1e-3` rad/s near rest).
    pub const REFACTOR: f64 = 2e-3;
    /// Converged when the correction is below this fraction of the largest
    /// displacement.
    pub const TOLERANCE: f64 = 1e-11;
    /// The most corrections a step may take.
    pub const MAX_ITERATIONS: usize = 30;

    /// An integrator with step `h` (s), starting at `t = 0` on the scheme's
    /// own steady state at `ramp.omega0`, [`warped_response`] `Q_h`: the
    /// displacement `Re{Q_h exp(j theta0)}`, the velocity `Re{j Omega_h Q_h
    /// exp(j theta0)}`, the acceleration from the equation of motion
    /// (`Re{-Omega_h^2 Q_h exp(j theta0)}`), `Omega_h = (2/h) tan(Omega_0 h
    /// / 2)`. At constant speed the integration then stays on it (to
    /// rounding and [`Integrator::TOLERANCE`]), and a slow ramp starts
    /// without a transient.
    pub fn new(fe: &FeModel, forcing: &Forcing, ramp: Ramp, h: f64) -> Result<Self, FeError> {
        if !(h.is_finite() && h > 0.0) {
            return Err(FeError::Invalid(format!(
                "time step must be finite and > 0 s, got {h}"
            )));
        }
        if !(ramp.omega0.is_finite()
            && ramp.omega0 >= 0.0
            && ramp.alpha.is_finite()
            && ramp.theta0.is_finite())
        {
            return Err(FeError::Invalid(format!(
                "speed ramp must be finite with a speed >= 0, got {ramp:?}"
            )));
        }
        let model = fe.model();
        let n = fe.n_dof();
        let ns = fe.n_shaft_dof();
        // Order: each node's 4 DOFs, then the pedestal DOFs of the bearings
        // at that node.
        let mut perm = Vec::with_capacity(n);
        for node in 0..fe.n_nodes() {
            perm.extend((0..4).map(|d| 4 * node + d));
            for (bi, b) in model.bearings.iter().enumerate() {
                if b.node == node {
                    if let (Some(py), Some(pz)) =
                        (fe.pedestal_dof(bi, Dir::Y), fe.pedestal_dof(bi, Dir::Z))
                    {
                        perm.extend([py, pz]);
                    }
                }
            }
        }
        if perm.len() != n {
            return Err(FeError::Invalid(
                "DOF numbering: pedestal DOFs do not match the bearings".into(),
            ));
        }
        let mut inv = vec![0; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old] = new;
        }
        let supports: Vec<Support> = model
            .bearings
            .iter()
            .enumerate()
            .map(|(bi, b)| Support {
                shaft: [inv[fe.dof(b.node, Dir::Y)], inv[fe.dof(b.node, Dir::Z)]],
                pedestal: match (fe.pedestal_dof(bi, Dir::Y), fe.pedestal_dof(bi, Dir::Z)) {
                    (Some(py), Some(pz)) => Some([inv[py], inv[pz]]),
                    _ => None,
                },
            })
            .collect();
        // Half bandwidth: shaft elements couple DOFs within 7 of each other
        // (old numbering); bearings couple shaft and pedestal.
        let mut w = 0usize;
        for i in 0..ns {
            for j in i..(i + 8).min(ns) {
                w = w.max(inv[i].abs_diff(inv[j]));
            }
        }
        for s in &supports {
            if let Some(p) = s.pedestal {
                for a in s.shaft {
                    for b in p {
                        w = w.max(a.abs_diff(b));
                    }
                }
            }
        }
        // Speed-independent parts: the dense matrices at a zero bearing law
        // would need a model copy; take them apart instead: K(Omega) minus
        // the bearings' K at that speed, likewise C.
        let omega_probe = ramp.omega0;
        let to_band = |d: &DMatrix<f64>| -> Result<Band, FeError> {
            let mut b = Band::zeros(n, w);
            for i in 0..n {
                for j in 0..n {
                    let v = d[(perm[i], perm[j])];
                    if v != 0.0 {
                        b.add(i, j, v)?;
                    }
                }
            }
            Ok(b)
        };
        let m = to_band(&fe.mass_matrix())?;
        let g = to_band(&fe.gyroscopic_matrix())?;
        let mut k0 = to_band(&fe.stiffness_matrix(omega_probe))?;
        let mut c0 = to_band(&fe.damping_matrix(omega_probe))?;
        for (s, b) in supports.iter().zip(&model.bearings) {
            let coefs = b.law.at(omega_probe);
            add_support(&mut k0, s, &stiffness(&coefs), -1.0)?;
            add_support(&mut c0, s, &damping(&coefs), -1.0)?;
        }
        let reorder = |f: &[Complex64]| -> Vec<Complex64> {
            let mut out = vec![Complex64::new(0.0, 0.0); n];
            for (old, v) in f.iter().enumerate() {
                out[inv[old]] = *v;
            }
            out
        };
        let unb = reorder(&fe.unbalance_force(&forcing.unbalance, 1.0)?);
        let bow = match &forcing.bow {
            Some(b) => reorder(&fe.bow_force(b)?),
            None => vec![Complex64::new(0.0, 0.0); n],
        };
        let (c_m, c_v) = (4.0 / (h * h), 2.0 / h);
        let mut p = m.clone();
        for x in p.a.iter_mut() {
            *x *= c_m;
        }
        p.axpy(c_v, &c0);
        p.axpy(1.0, &k0);
        // Initial state: the scheme's steady state at omega0.
        if ramp.omega0 * h >= std::f64::consts::PI {
            return Err(FeError::Invalid(format!(
                "time step {h} s is half a revolution or more at {} rad/s",
                ramp.omega0
            )));
        }
        let qss = reorder(&warped_response(fe, forcing, ramp.omega0, h)?);
        let rot = Complex64::from_polar(1.0, ramp.theta0);
        let jw = Complex64::new(0.0, warped_frequency(ramp.omega0, h));
        let q: Vec<f64> = qss.iter().map(|z| (z * rot).re).collect();
        let v: Vec<f64> = qss.iter().map(|z| (z * rot * jw).re).collect();
        let mut it = Integrator {
            fe: fe.clone(),
            ramp,
            h,
            n,
            inv,
            lu: Band::zeros(0, 0),
            m,
            g,
            k0,
            c0,
            supports,
            unb,
            bow,
            p,
            omega_ref: f64::NAN,
            t: 0.0,
            step_no: 0,
            q,
            v,
            a: vec![0.0; n],
            r: vec![0.0; n],
            x: vec![0.0; n],
            res: vec![0.0; n],
            solves: 0,
            factorisations: 0,
        };
        // M a0 = f(0) - D(Omega0) v0 - K(Omega0) q0.
        let mut rhs = it.force(0.0);
        let q0 = it.q.clone();
        let v0 = it.v.clone();
        it.apply_k(ramp.omega0, &q0, -1.0, &mut rhs);
        it.apply_d(ramp.omega0, &v0, -1.0, &mut rhs);
        let mlu = it.m.clone().into_lu()?;
        mlu.lu_solve(&mut rhs);
        it.a = rhs;
        Ok(it)
    }

    /// The force at time `t` (reordered DOFs).
    fn force(&self, t: f64) -> Vec<f64> {
        let w = self.ramp.omega(t);
        let e = Complex64::from_polar(1.0, self.ramp.theta(t));
        let su = Complex64::new(w * w, -self.ramp.alpha) * e;
        self.unb
            .iter()
            .zip(&self.bow)
            .map(|(u, b)| (u * su + b * e).re)
            .collect()
    }

    /// `y += s K(omega) x`.
    fn apply_k(&self, omega: f64, x: &[f64], s: f64, y: &mut [f64]) {
        self.k0.mul_add(s, x, y);
        for (sp, b) in self.supports.iter().zip(&self.fe.model().bearings) {
            support_mul_add(sp, &stiffness(&b.law.at(omega)), s, x, y);
        }
    }

    /// `y += s (C(omega) + omega G) x`.
    fn apply_d(&self, omega: f64, x: &[f64], s: f64, y: &mut [f64]) {
        self.c0.mul_add(s, x, y);
        self.g.mul_add(s * omega, x, y);
        for (sp, b) in self.supports.iter().zip(&self.fe.model().bearings) {
            support_mul_add(sp, &damping(&b.law.at(omega)), s, x, y);
        }
    }

    /// Factors `S(omega)`.
    fn factor(&mut self, omega: f64) -> Result<(), FeError> {
        let c_v = 2.0 / self.h;
        let mut s = self.p.clone();
        s.axpy(c_v * omega, &self.g);
        for (sp, b) in self.supports.iter().zip(&self.fe.model().bearings) {
            let coefs = b.law.at(omega);
            add_support(
                &mut s,
                sp,
                &(stiffness(&coefs) + damping(&coefs) * c_v),
                1.0,
            )?;
        }
        self.lu = s.into_lu()?;
        self.omega_ref = omega;
        self.factorisations += 1;
        Ok(())
    }

    /// One Newmark step from `t` to `t + h`.
    pub fn step(&mut self) -> Result<(), FeError> {
        let h = self.h;
        let t1 = (self.step_no + 1) as f64 * h;
        let w1 = self.ramp.omega(t1);
        if !(w1.is_finite() && w1 >= 0.0) {
            return Err(FeError::Invalid(format!(
                "the speed ramp reaches {w1} rad/s at t = {t1} s"
            )));
        }
        if !(self.omega_ref.is_finite()
            && (w1 - self.omega_ref).abs() <= Self::REFACTOR * self.omega_ref.max(0.5))
        {
            self.factor(w1)?;
        }
        let (c_m, c_v, c_a) = (4.0 / (h * h), 2.0 / h, 4.0 / h);
        let n = self.n;
        // r = f1 + M (c_m q + c_a v + a) + D1 (c_v q + v).
        let mut r = self.force(t1);
        let tmp: Vec<f64> = (0..n)
            .map(|i| c_m * self.q[i] + c_a * self.v[i] + self.a[i])
            .collect();
        self.m.mul_add(1.0, &tmp, &mut r);
        let tmp: Vec<f64> = (0..n).map(|i| c_v * self.q[i] + self.v[i]).collect();
        self.apply_d(w1, &tmp, 1.0, &mut r);
        self.r = r;
        // Predictor, then x <- x + S_ref^-1 (r - S(w1) x).
        for i in 0..n {
            self.x[i] = self.q[i] + h * self.v[i] + 0.5 * h * h * self.a[i];
        }
        let mut converged = false;
        for _ in 0..Self::MAX_ITERATIONS {
            self.res.copy_from_slice(&self.r);
            let x = std::mem::take(&mut self.x);
            let mut res = std::mem::take(&mut self.res);
            self.p.mul_add(-1.0, &x, &mut res);
            self.g.mul_add(-c_v * w1, &x, &mut res);
            for (sp, b) in self.supports.iter().zip(&self.fe.model().bearings) {
                let coefs = b.law.at(w1);
                support_mul_add(
                    sp,
                    &(stiffness(&coefs) + damping(&coefs) * c_v),
                    -1.0,
                    &x,
                    &mut res,
                );
            }
            self.lu.lu_solve(&mut res);
            self.solves += 1;
            let mut x = x;
            let (mut dmax, mut xmax) = (0.0f64, 0.0f64);
            for (xi, di) in x.iter_mut().zip(&res) {
                *xi += di;
                dmax = dmax.max(di.abs());
                xmax = xmax.max(xi.abs());
            }
            self.x = x;
            self.res = res;
            if !(dmax.is_finite() && xmax.is_finite()) {
                break;
            }
            if dmax <= Self::TOLERANCE * xmax {
                converged = true;
                break;
            }
        }
        if !converged {
            return Err(FeError::Invalid(format!(
                "Newmark step at t = {t1} s did not converge in {} corrections",
                Self::MAX_ITERATIONS
            )));
        }
        for i in 0..n {
            let dq = self.x[i] - self.q[i];
            let a1 = c_m * (dq - h * self.v[i]) - self.a[i];
            let v1 = c_v * dq - self.v[i];
            self.q[i] = self.x[i];
            self.v[i] = v1;
            self.a[i] = a1;
        }
        self.step_no += 1;
        self.t = t1;
        Ok(())
    }

    /// Current time (s).
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Step (s).
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// The ramp.
    pub fn ramp(&self) -> &Ramp {
        &self.ramp
    }

    /// Current displacement of DOF `dof` in [`FeModel`]'s numbering (m or
    /// rad); 0 for a DOF out of range.
    pub fn displacement(&self, dof: usize) -> f64 {
        self.inv.get(dof).map_or(0.0, |&i| self.q[i])
    }

    /// All displacements in [`FeModel`]'s numbering.
    pub fn displacements(&self) -> Vec<f64> {
        self.inv.iter().map(|&i| self.q[i]).collect()
    }

    /// Banded LU solves and factorisations spent so far.
    pub fn work(&self) -> (u64, u64) {
        (self.solves, self.factorisations)
    }
}

/// Adds `s X` of a bearing between its shaft DOFs and its pedestal (or the
/// ground) to `b`.
fn add_support(b: &mut Band, sp: &Support, x: &Matrix2<f64>, s: f64) -> Result<(), FeError> {
    for r in 0..2 {
        for c in 0..2 {
            let v = s * x[(r, c)];
            b.add(sp.shaft[r], sp.shaft[c], v)?;
            if let Some(p) = sp.pedestal {
                b.add(sp.shaft[r], p[c], -v)?;
                b.add(p[r], sp.shaft[c], -v)?;
                b.add(p[r], p[c], v)?;
            }
        }
    }
    Ok(())
}

/// `y += s X_bearing x` for a bearing's coupling `X` (see [`add_support`]).
fn support_mul_add(sp: &Support, x: &Matrix2<f64>, s: f64, xv: &[f64], y: &mut [f64]) {
    let rel = |k: usize| match sp.pedestal {
        Some(p) => xv[sp.shaft[k]] - xv[p[k]],
        None => xv[sp.shaft[k]],
    };
    let d = [rel(0), rel(1)];
    for r in 0..2 {
        let f = s * (x[(r, 0)] * d[0] + x[(r, 1)] * d[1]);
        y[sp.shaft[r]] += f;
        if let Some(p) = sp.pedestal {
            y[p[r]] -= f;
        }
    }
}

/// The frequency the scheme's steady state at speed `omega` (rad/s) and
/// step `h` (s) sees: `Omega_h = (2/h) tan(Omega h / 2)` (rad/s).
pub fn warped_frequency(omega: f64, h: f64) -> f64 {
    2.0 / h * (omega * h / 2.0).tan()
}

/// The steady state of the Newmark scheme at constant speed `omega` and
/// step `h`: `Q = Z_h^-1 F` on all DOFs, `Z_h = K(Omega) - Omega_h^2 M + j
/// Omega_h (C(Omega) + Omega G)`, `Omega_h = (2/h) tan(Omega h / 2)`, `F`
/// the 1X forcing of `forcing` at `omega` (dense solve, for tests).
pub fn warped_response(
    fe: &FeModel,
    forcing: &Forcing,
    omega: f64,
    h: f64,
) -> Result<Vec<Complex64>, FeError> {
    let n = fe.n_dof();
    let wh = warped_frequency(omega, h);
    let m = fe.mass_matrix();
    let g = fe.gyroscopic_matrix();
    let k = fe.stiffness_matrix(omega);
    let c = fe.damping_matrix(omega);
    let z = DMatrix::from_fn(n, n, |i, j| {
        Complex64::new(
            k[(i, j)] - wh * wh * m[(i, j)],
            wh * (c[(i, j)] + omega * g[(i, j)]),
        )
    });
    let mut f = nalgebra::DVector::<Complex64>::zeros(n);
    let unb = fe.unbalance_force(&forcing.unbalance, omega)?;
    for (i, u) in unb.iter().enumerate() {
        f[i] += u;
    }
    if let Some(b) = &forcing.bow {
        for (i, u) in fe.bow_force(b)?.iter().enumerate() {
            f[i] += u;
        }
    }
    let q = z.lu().solve(&f).ok_or_else(|| {
        FeError::Invalid(format!(
            "singular warped dynamic stiffness at {omega} rad/s"
        ))
    })?;
    Ok(q.iter().copied().collect())
}
