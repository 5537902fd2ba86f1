//! The nominal prediction model extended by the hypotheses' effects.
//!
//! # Model
//!
//! At speed `Omega`, with the terms of [`super::terms`], the nominal
//! bearing law `Z_B(theta)` and plane unbalance `a(theta)` of the
//! [`Predictor`], the shaft's bearing-node response solves
//!
//! ```text
//!     (A + dA de + Z_eff) q = (B + dB de) a + sum_n b_n u_n + sum_n g_n beta_n
//! ```
//!
//! and the probes read `y = P q + r`:
//!
//! | extension | parameters (scaled) | enters as |
//! |---|---|---|
//! | [`Extension::Runout`] | `r_c = q_s (x + j y)` per channel | `y_c += r_c` |
//! | [`Extension::Plane`] | `u = s_a (x + j y)` (kg m) at node `n` | `b_n u` |
//! | [`Extension::Spread`] | `u = s_a (x + j y)` (kg m) shared by nodes `a..=b` | `(1 / (b - a + 1)) sum_{n=a..b} b_n u` |
//! | [`Extension::Bow`] | `beta = q_s (x + j y)` (m) at node `n` | `g_n beta` (or the bearing line's `g_n`) |
//! | [`Extension::EScale`] | `de = 0.01 x` about the terms' own factor, in the form of [`crate::diagnose::terms::StiffnessForm`] | `dA de`, `dB a de` |
//! | [`Extension::Pedestal`] | `m = m_0 e^x1`, `w_d = w_0 e^x_d`, `zeta_d = x_d / 10`; with `split`, `m_y = m e^x6`, `m_z = m e^-x6` | `Z_eff`, `P` |
//! | [`Extension::NodeRunout`] | `r = q_s (x + j y)` on output `c` (a probe at another node) | `y_c += r` |
//! | [`Extension::Gain`] | `g = 0.01 x` on output `c` | `y_c <- (1 + g) y_c`, last |
//! | [`Extension::FilmLaw`] | per bearing `x_d, x_x, x_c`: `dK_yy = dK_zz = s_K r x_d`, `dK_yz = -dK_zy = s_K r x_x`, `dC_yy = dC_zz = (s_K / Omega_r) r x_c`, `r = Omega / Omega_r` | `Z_B += dK + j Omega dC` ([`film_entries`]) |
//!
//! (`q_s`: RMS measured response, `s_a`, `s_K`, `Omega_r`: the unbalance,
//! stiffness and speed scales of the parametrization.) A pedestal under bearing `m` with
//! `Z_P = diag(m_p (w_d^2 - Omega^2 + 2 j zeta_d w_d Omega))` puts the
//! bearing `Z_B` and the pedestal in series:
//!
//! ```text
//!     Z_eff = Z_B - Z_B (Z_B + Z_P)^-1 Z_B,
//! ```
//!
//! and a probe mounted on the pedestal (relative, the default) reads the
//! shaft's motion less the pedestal's, `P = (Z_B + Z_P)^-1 Z_P` on that
//! bearing's channels (`P = I` for absolute probes and elsewhere).
//!
//! # Jacobian
//!
//! The prediction is `q = H^-1 f` with `H`, `f` affine in every nominal
//! and forcing parameter, so `dq/dtheta_i = H^-1 (df_i - dH_i q)`: the
//! identification's [`Predictor`] columns plus one per extension
//! parameter. With a pedestal, `S = (Z_B + Z_P)^-1`, `T = S Z_P`:
//!
//! ```text
//!     d Z_eff = Z_P S dZ_B S Z_P          (a bearing entry of that bearing)
//!     d Z_eff = Z_B S dZ_P S Z_B          (a pedestal parameter)
//!     d T     = -S dZ_B T,   d T = S dZ_P S Z_B
//! ```
//!
//! and `dy = P dq + dT q_m` on the pedestal's channels. Checked against
//! central differences and against the full FE response in the tests.

use nalgebra::{DMatrix, DVector, Matrix2};
use num_complex::Complex64;

use crate::diagnose::terms::SpeedTerms;
use crate::estimate::predictor::{Entry, PredictError, Predictor};

/// Step of the shaft modulus parameter: `de = E_STEP x`.
pub const E_STEP: f64 = 0.01;

/// Step of a probe gain parameter: `g = GAIN_STEP x`, the reading
/// `(1 + g)` times the probe's true signal.
pub const GAIN_STEP: f64 = 0.01;

/// One effect added to the nominal model (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Extension {
    /// A constant phasor on every channel.
    Runout,
    /// Unbalance at a node (0-based) that is not a plane.
    Plane {
        /// Node (0-based).
        node: usize,
    },
    /// Unbalance shared equally by the consecutive nodes `first..=last`
    /// (0-based, none a plane): an unbalance spread along a section.
    Spread {
        /// First node (0-based).
        first: usize,
        /// Last node (0-based).
        last: usize,
    },
    /// A bow of the shaft with its offset at a node (0-based).
    Bow {
        /// Node (0-based).
        node: usize,
        /// Measured from the bearing line (zero at every bearing,
        /// [`SpeedTerms::g_line`]) rather than from the line through the
        /// shaft's ends.
        line: bool,
    },
    /// A pedestal under a bearing (0-based).
    Pedestal {
        /// Bearing (0-based).
        bearing: usize,
        /// Its masses in y and z differ (a sixth parameter, the log of
        /// their ratio's square root; [`PedestalParams::split`]).
        split: bool,
    },
    /// A factor on the shaft's modulus.
    EScale,
    /// A constant phasor on output `output` (0-based, a probe at another
    /// node: at least the number of bearing channels), the runout of a
    /// mid-span probe ([`Extension::Runout`] covers the bearing channels).
    NodeRunout {
        /// Output index (0-based).
        output: usize,
    },
    /// A probe whose scale factor is off: output `channel` (0-based: the
    /// bearing channels `b1_y, b1_z, ...`, then the probes at other
    /// nodes) reads `1 + g` times its signal, runout included.
    Gain {
        /// Output index (0-based).
        channel: usize,
    },
    /// A fluid-film law on every bearing, beside the nominal constants:
    /// the direct stiffness, the cross-coupled stiffness (`k_yz = -k_zy`,
    /// a film's signs for `x_x > 0`) and the direct damping each change in
    /// proportion to the speed, three parameters per bearing
    /// ([`film_entries`]). Leaner than a polynomial law one order higher
    /// (eight per bearing), in the shape fluid films have.
    FilmLaw,
}

/// The entries of [`Extension::FilmLaw`] at `omega` (rad/s) with `nq`
/// channels and the parametrization's `scaling`: `(row, col, dz, k)`, the
/// law adds `dz x_k` to `Z_B[row][col]` for its parameter `k` (`3 b`,
/// `3 b + 1`, `3 b + 2` for bearing `b`: direct stiffness, cross-coupled
/// stiffness, direct damping). With `r = Omega / Omega_r`:
///
/// ```text
///     dK_yy = dK_zz = s_K r x_3b           (N/m)
///     dK_yz = -dK_zy = s_K r x_3b+1        (N/m)
///     dC_yy = dC_zz = (s_K / Omega_r) r x_3b+2,  Z_B += j Omega dC = j s_K r^2 x_3b+2
/// ```
pub fn film_entries(
    nq: usize,
    scaling: &rotorid_core::scaling::ColumnScaling<f64>,
    omega: f64,
) -> Vec<(usize, usize, Complex64, usize)> {
    let r = omega / scaling.omega_ref;
    let k = Complex64::new(scaling.stiffness * r, 0.0);
    let c = Complex64::new(0.0, scaling.stiffness * r * r);
    (0..nq / 2)
        .flat_map(|b| {
            let (i, p) = (2 * b, 3 * b);
            [
                (i, i, k, p),
                (i + 1, i + 1, k, p),
                (i, i + 1, k, p + 1),
                (i + 1, i, -k, p + 1),
                (i, i, c, p + 2),
                (i + 1, i + 1, c, p + 2),
            ]
        })
        .collect()
}

impl Extension {
    /// The nodes `(first, last)` (0-based) an extra unbalance is at: one
    /// node for a plane, a run for a spread; `None` for other extensions.
    pub fn unbalance_nodes(&self) -> Option<(usize, usize)> {
        match *self {
            Extension::Plane { node } => Some((node, node)),
            Extension::Spread { first, last } => Some((first, last)),
            _ => None,
        }
    }

    /// Number of real parameters with `nq` channels.
    pub fn n_params(&self, nq: usize) -> usize {
        match self {
            Extension::Runout => 2 * nq,
            Extension::Plane { .. }
            | Extension::Spread { .. }
            | Extension::Bow { .. }
            | Extension::NodeRunout { .. } => 2,
            Extension::Pedestal { split, .. } => 5 + usize::from(*split),
            Extension::EScale | Extension::Gain { .. } => 1,
            Extension::FilmLaw => 3 * (nq / 2),
        }
    }
}

/// Reference magnitudes of the extension parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scales {
    /// Response scale `q_s` (m): RMS of the measured responses.
    pub q: f64,
    /// Pedestal reference mass `m_0` (kg).
    pub mass: f64,
    /// Pedestal reference frequency `w_0` (rad/s).
    pub omega: f64,
}

/// A pedestal's physical parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PedestalParams {
    /// Mass (kg): the geometric mean of the masses in y and z.
    pub mass: f64,
    /// The masses in y and z are `mass e^split`, `mass e^-split` (0: one
    /// mass).
    pub split: f64,
    /// Natural frequencies on its own springs, y and z (rad/s).
    pub omega: [f64; 2],
    /// Damping ratios, y and z.
    pub zeta: [f64; 2],
}

impl PedestalParams {
    /// From the scaled parameters.
    pub fn from_scaled(p: &[f64], s: &Scales) -> Self {
        PedestalParams {
            mass: s.mass * p[0].exp(),
            split: p.get(5).copied().unwrap_or(0.0),
            omega: [s.omega * p[1].exp(), s.omega * p[2].exp()],
            zeta: [0.1 * p[3], 0.1 * p[4]],
        }
    }

    /// The masses in y and z (kg).
    pub fn masses(&self) -> [f64; 2] {
        [
            self.mass * self.split.exp(),
            self.mass * (-self.split).exp(),
        ]
    }

    /// The scaled parameters of the one-mass form (`split` left out).
    pub fn to_scaled(&self, s: &Scales) -> [f64; 5] {
        [
            (self.mass / s.mass).ln(),
            (self.omega[0] / s.omega).ln(),
            (self.omega[1] / s.omega).ln(),
            10.0 * self.zeta[0],
            10.0 * self.zeta[1],
        ]
    }

    /// Stiffness `k_d = m_d w_d^2` (N/m) and damping `c_d = 2 zeta_d m_d
    /// w_d` (N s/m).
    pub fn k_c(&self) -> ([f64; 2], [f64; 2]) {
        let m = self.masses();
        let k = [
            m[0] * self.omega[0] * self.omega[0],
            m[1] * self.omega[1] * self.omega[1],
        ];
        let c = [
            2.0 * self.zeta[0] * m[0] * self.omega[0],
            2.0 * self.zeta[1] * m[1] * self.omega[1],
        ];
        (k, c)
    }

    /// `Z_P(Omega)` (N/m), diagonal: `m_d (w_d^2 - Omega^2) + j 2 zeta_d
    /// m_d w_d Omega`.
    pub fn impedance(&self, omega: f64) -> Matrix2<Complex64> {
        let m = self.masses();
        let z = |d: usize| {
            let w = self.omega[d];
            Complex64::new(
                m[d] * (w * w - omega * omega),
                2.0 * m[d] * self.zeta[d] * w * omega,
            )
        };
        Matrix2::new(
            z(0),
            Complex64::new(0.0, 0.0),
            Complex64::new(0.0, 0.0),
            z(1),
        )
    }
}

/// The extended prediction model.
#[derive(Debug, Clone, PartialEq)]
pub struct ExtendedModel {
    /// The nominal parameters (bearing law and plane unbalance).
    pub pr: Predictor,
    /// The effects added, in parameter order after the nominal ones.
    pub ext: Vec<Extension>,
    /// Reference magnitudes.
    pub scales: Scales,
    /// Probes on the pedestals read relative motion.
    pub relative_probes: bool,
}

/// One evaluation at one speed: what the Jacobian is formed from
/// ([`ExtendedModel::evaluate`], then [`ExtendedModel::predict_from`]).
#[derive(Debug, Clone)]
pub struct Eval {
    q: DVector<Complex64>,
    y: DVector<Complex64>,
    h_inv: DMatrix<Complex64>,
    a: DVector<Complex64>,
    /// `B + dB de` with the modulus extension (else `B` itself).
    b_eff: Option<DMatrix<Complex64>>,
    /// One per pedestal, in extension order (different bearings).
    ped: Vec<PedEval>,
    /// One per probe gain, in extension order (different outputs).
    gains: Vec<GainEval>,
}

impl Eval {
    /// The probe readings `y` (m): the bearing channels, then the probes
    /// at other nodes.
    pub fn readings(&self) -> &DVector<Complex64> {
        &self.y
    }
}

/// A probe gain at one speed: `y_c = factor before`.
#[derive(Debug, Clone)]
struct GainEval {
    /// Output index.
    channel: usize,
    /// Parameter offset.
    o: usize,
    /// `1 + g`.
    factor: f64,
    /// The reading before the gain (m).
    before: Complex64,
}

/// The pedestal's matrices at one speed (bearing block from channel `i0`).
#[derive(Debug, Clone)]
struct PedEval {
    i0: usize,
    /// Parameter offset of the pedestal.
    o: usize,
    params: PedestalParams,
    zb: Matrix2<Complex64>,
    zp: Matrix2<Complex64>,
    /// `(Z_B + Z_P)^-1`.
    s: Matrix2<Complex64>,
    /// `P` on the block: `S Z_P` (relative) or `I`.
    t: Matrix2<Complex64>,
    /// `Z_P S`.
    zp_s: Matrix2<Complex64>,
    /// `S Z_P q_m` (`q_m` the shaft's motion at the bearing).
    s_zp_q: nalgebra::Vector2<Complex64>,
    /// `T q_m`.
    t_q: nalgebra::Vector2<Complex64>,
}

/// The inverse of a small complex matrix: the output-error predictor's
/// elimination with partial pivoting ([`crate::estimate::predictor`], on
/// the column-major storage of `a`); `None` if a pivot is zero or an entry
/// of the inverse is not finite (a singular or overflowing `H`).
fn invert(mut a: DMatrix<Complex64>) -> Option<DMatrix<Complex64>> {
    let n = a.nrows();
    if a.ncols() != n {
        return None;
    }
    let mut inv = DMatrix::<Complex64>::zeros(n, n);
    crate::estimate::predictor::invert(n, a.as_mut_slice(), inv.as_mut_slice()).then_some(inv)
}

impl ExtendedModel {
    /// Number of channels `2 N_b`.
    pub fn n_channels(&self) -> usize {
        2 * self.pr.param.n_bearings()
    }

    /// Number of real parameters.
    pub fn n_params(&self) -> usize {
        let nq = self.n_channels();
        self.pr.n_params() + self.ext.iter().map(|e| e.n_params(nq)).sum::<usize>()
    }

    /// Index of the first parameter of extension `k`.
    pub fn offset(&self, k: usize) -> usize {
        let nq = self.n_channels();
        self.pr.n_params()
            + self
                .ext
                .iter()
                .take(k)
                .map(|e| e.n_params(nq))
                .sum::<usize>()
    }

    fn eval(
        &self,
        st: &SpeedTerms,
        entries: &[Entry],
        theta: &[f64],
    ) -> Result<Eval, PredictError> {
        let nq = st.a.nrows();
        let np = st.b.ncols();
        let nom = self.pr.n_params();
        if theta.len() != self.n_params() || entries.len() != nom || nq != self.n_channels() {
            return Err(PredictError::Dimension);
        }
        let mut h = st.a.clone();
        let mut a = DVector::<Complex64>::zeros(np);
        for (en, &t) in entries.iter().zip(&theta[..nom]) {
            match *en {
                Entry::Bearing { row, col, dz } => h[(row, col)] += dz * t,
                Entry::Unbalance { plane, da } => a[plane] += da * t,
            }
        }
        // The film law's entries, with their parameters' values.
        let film: Vec<(usize, usize, Complex64)> =
            match self.ext.iter().position(|e| *e == Extension::FilmLaw) {
                Some(k) => {
                    let o = self.offset(k);
                    film_entries(nq, &self.pr.param.scaling, st.omega)
                        .into_iter()
                        .map(|(row, col, dz, i)| (row, col, dz * theta[o + i]))
                        .collect()
                }
                None => Vec::new(),
            };
        for &(row, col, v) in &film {
            h[(row, col)] += v;
        }
        let mut f = &st.b * &a;
        let mut b_eff: Option<DMatrix<Complex64>> = None;
        let mut runout: Option<&[f64]> = None;
        let mut ped: Vec<PedEval> = Vec::new();
        for (k, ext) in self.ext.iter().enumerate() {
            let o = self.offset(k);
            let p = &theta[o..o + ext.n_params(nq)];
            match *ext {
                Extension::Runout => runout = Some(p),
                Extension::Plane { node } | Extension::Bow { node, .. }
                    if node >= st.b_node.ncols() || node >= st.g_node.ncols() =>
                {
                    return Err(PredictError::Dimension)
                }
                Extension::Bow { line: true, .. } if st.g_line.is_none() => {
                    return Err(PredictError::Dimension)
                }
                Extension::Spread { first, last } if first > last || last >= st.b_node.ncols() => {
                    return Err(PredictError::Dimension)
                }
                Extension::Plane { node } => {
                    let u = Complex64::new(p[0], p[1]) * self.pr.param.scaling.unbalance;
                    f += st.b_node.column(node) * u;
                }
                Extension::Spread { first, last } => {
                    let u = Complex64::new(p[0], p[1]) * self.pr.param.scaling.unbalance;
                    f += st.spread_column(first, last) * u;
                }
                Extension::Bow { node, line } => {
                    let beta = Complex64::new(p[0], p[1]) * self.scales.q;
                    f += st.bow_column(node, line) * beta;
                }
                Extension::EScale => {
                    let de = Complex64::from(p[0] * E_STEP);
                    let (da, db) = match (&st.da_de, &st.db_de) {
                        (Some(da), Some(db)) => (da, db),
                        _ => return Err(PredictError::Dimension),
                    };
                    h += da * de;
                    f += db * &a * de;
                    let mut be = b_eff.take().unwrap_or_else(|| st.b.clone());
                    be += db * de;
                    b_eff = Some(be);
                }
                Extension::Pedestal { bearing, .. } => {
                    let i0 = 2 * bearing;
                    if i0 + 2 > nq || ped.iter().any(|pe| pe.i0 == i0) {
                        return Err(PredictError::Dimension);
                    }
                    // Z_B block of this bearing from the nominal entries.
                    let mut zb = Matrix2::<Complex64>::zeros();
                    let in_block = |row: usize, col: usize| {
                        (i0..i0 + 2).contains(&row) && (i0..i0 + 2).contains(&col)
                    };
                    for (en, &t) in entries.iter().zip(&theta[..nom]) {
                        if let Entry::Bearing { row, col, dz } = *en {
                            if in_block(row, col) {
                                zb[(row - i0, col - i0)] += dz * t;
                            }
                        }
                    }
                    for &(row, col, v) in &film {
                        if in_block(row, col) {
                            zb[(row - i0, col - i0)] += v;
                        }
                    }
                    let params = PedestalParams::from_scaled(p, &self.scales);
                    let zp = params.impedance(st.omega);
                    let s = (zb + zp)
                        .try_inverse()
                        .ok_or(PredictError::Singular { omega: st.omega })?;
                    let zeff = zb - zb * s * zb;
                    for r in 0..2 {
                        for c in 0..2 {
                            h[(i0 + r, i0 + c)] += zeff[(r, c)] - zb[(r, c)];
                        }
                    }
                    let t = if self.relative_probes {
                        s * zp
                    } else {
                        Matrix2::identity()
                    };
                    ped.push(PedEval {
                        i0,
                        o,
                        params,
                        zb,
                        zp,
                        s,
                        t,
                        zp_s: zp * s,
                        // Set once `q` is known (below).
                        s_zp_q: nalgebra::Vector2::zeros(),
                        t_q: nalgebra::Vector2::zeros(),
                    });
                }
                Extension::Gain { .. } | Extension::NodeRunout { .. } | Extension::FilmLaw => {}
            }
        }
        let h_inv = invert(h).ok_or(PredictError::Singular { omega: st.omega })?;
        let q = &h_inv * f;
        let mut y = q.clone();
        for pe in &mut ped {
            let qm = nalgebra::Vector2::new(q[pe.i0], q[pe.i0 + 1]);
            pe.s_zp_q = pe.s * pe.zp * qm;
            pe.t_q = pe.t * qm;
        }
        for pe in &ped {
            let i0 = pe.i0;
            for r in 0..2 {
                y[i0 + r] = pe.t[(r, 0)] * q[i0] + pe.t[(r, 1)] * q[i0 + 1];
            }
        }
        if let Some(p) = runout {
            for c in 0..nq {
                y[c] += Complex64::new(p[2 * c], p[2 * c + 1]) * self.scales.q;
            }
        }
        if let Some(nt) = &st.probes {
            // Probes at other nodes: x = P q + u a + extension loads.
            let mut x = &nt.p * &q + &nt.u * &a;
            for (k, ext) in self.ext.iter().enumerate() {
                let o = self.offset(k);
                match *ext {
                    Extension::Plane { node } => {
                        let u = Complex64::new(theta[o], theta[o + 1])
                            * self.pr.param.scaling.unbalance;
                        x += nt.u_node.column(node) * u;
                    }
                    Extension::Spread { first, last } => {
                        let u = Complex64::new(theta[o], theta[o + 1])
                            * self.pr.param.scaling.unbalance;
                        x += nt.spread_column(first, last) * u;
                    }
                    Extension::Bow { node, line } => {
                        let beta = Complex64::new(theta[o], theta[o + 1]) * self.scales.q;
                        x += nt.bow_column(node, line)? * beta;
                    }
                    Extension::EScale => {
                        let de = Complex64::from(theta[o] * E_STEP);
                        let (Some(dp), Some(du)) = (&nt.dp_de, &nt.du_de) else {
                            return Err(PredictError::Dimension);
                        };
                        x += (dp * &q + du * &a) * de;
                    }
                    Extension::Runout
                    | Extension::Pedestal { .. }
                    | Extension::Gain { .. }
                    | Extension::NodeRunout { .. }
                    | Extension::FilmLaw => {}
                }
            }
            y = DVector::from_iterator(nq + x.len(), y.iter().chain(x.iter()).copied());
        }
        // Runout of the probes at other nodes.
        for (k, ext) in self.ext.iter().enumerate() {
            if let Extension::NodeRunout { output } = *ext {
                if output < nq || output >= y.len() {
                    return Err(PredictError::Dimension);
                }
                let o = self.offset(k);
                y[output] += Complex64::new(theta[o], theta[o + 1]) * self.scales.q;
            }
        }
        // Probe gains, on the readings as they stand (runout included).
        let mut gains: Vec<GainEval> = Vec::new();
        for (k, ext) in self.ext.iter().enumerate() {
            if let Extension::Gain { channel } = *ext {
                let o = self.offset(k);
                if channel >= y.len() || gains.iter().any(|g| g.channel == channel) {
                    return Err(PredictError::Dimension);
                }
                let factor = 1.0 + GAIN_STEP * theta[o];
                gains.push(GainEval {
                    channel,
                    o,
                    factor,
                    before: y[channel],
                });
                y[channel] *= factor;
            }
        }
        Ok(Eval {
            q,
            y,
            h_inv,
            a,
            b_eff,
            ped,
            gains,
        })
    }

    /// Number of probe readings at one speed: the `2 N_b` bearing channels
    /// and `y, z` of every probe at another node.
    pub fn n_outputs(&self, st: &SpeedTerms) -> usize {
        self.n_channels() + st.probes.as_ref().map_or(0, |nt| nt.p.nrows())
    }

    /// The probe readings `y` at one speed (m): the bearing channels, then
    /// the probes at other nodes; and, when `jac` is given, `dy/dtheta`
    /// into it ([`ExtendedModel::n_outputs`]` x P`). `entries` are the
    /// nominal parameters' [`Entry`]s at this speed
    /// ([`Predictor::entries`]).
    pub fn predict(
        &self,
        st: &SpeedTerms,
        entries: &[Entry],
        theta: &[f64],
        jac: Option<&mut DMatrix<Complex64>>,
    ) -> Result<DVector<Complex64>, PredictError> {
        let ev = self.eval(st, entries, theta)?;
        self.predict_from(ev, st, entries, theta, jac)
    }

    /// The evaluation at one speed that [`ExtendedModel::predict`] starts
    /// from: its readings are [`Eval::readings`]. Kept, it gives the
    /// Jacobian at the same `theta` later without evaluating again
    /// ([`ExtendedModel::predict_from`]).
    pub fn evaluate(
        &self,
        st: &SpeedTerms,
        entries: &[Entry],
        theta: &[f64],
    ) -> Result<Eval, PredictError> {
        self.eval(st, entries, theta)
    }

    /// [`ExtendedModel::predict`] from `ev`, the evaluation of this model
    /// at `st`, `entries` and `theta` ([`ExtendedModel::evaluate`]): the
    /// same numbers, bit for bit.
    pub fn predict_from(
        &self,
        ev: Eval,
        st: &SpeedTerms,
        entries: &[Entry],
        theta: &[f64],
        jac: Option<&mut DMatrix<Complex64>>,
    ) -> Result<DVector<Complex64>, PredictError> {
        self.predict_columns(ev, st, entries, theta, jac, None)
    }

    /// [`ExtendedModel::predict_from`] with only the Jacobian's columns
    /// `want[i]` formed (every one with `None`): those the same numbers,
    /// bit for bit; the others hold no meaning. A profile that
    /// solves for a few parameters (the unbalance) at many points of the
    /// others needs only their columns.
    // Long (~250 lines): one pass filling the Jacobian's columns from one `eval`; a hot path.
    pub fn predict_columns(
        &self,
        ev: Eval,
        st: &SpeedTerms,
        entries: &[Entry],
        theta: &[f64],
        jac: Option<&mut DMatrix<Complex64>>,
        want: Option<&[bool]>,
    ) -> Result<DVector<Complex64>, PredictError> {
        let Some(jac_full) = jac else {
            return Ok(ev.y);
        };
        let nq = self.n_channels();
        let np = self.n_params();
        if jac_full.nrows() != self.n_outputs(st)
            || jac_full.ncols() != np
            || want.is_some_and(|w| w.len() != np)
        {
            return Err(PredictError::Dimension);
        }
        let wanted = |i: usize| want.is_none_or(|w| w[i]);
        let any_wanted = |o: usize, n: usize| (o..o + n).any(wanted);
        let node_rows;
        {
            let mut jac = jac_full.rows_mut(0, nq);
            let j = Complex64::new(0.0, 1.0);
            let zero = Complex64::new(0.0, 0.0);
            // Columns of dq (before the probe transform P), and for a relative
            // pedestal probe the extra `dT q_m` on its block.
            // (pedestal, column, term) of the relative probes' `dT q_m`.
            let mut extra: Vec<(usize, usize, [Complex64; 2])> =
                Vec::with_capacity(if ev.ped.is_empty() {
                    0
                } else {
                    entries.len() + 5 * ev.ped.len()
                });
            // dq = -H^-1 [dZ_eff] q with `u = dZ_eff q_m` on the block,
            // into column `i`.
            let block_dq = |jac: &mut nalgebra::DMatrixViewMut<'_, Complex64>,
                            i: usize,
                            u: &nalgebra::Vector2<Complex64>,
                            pe: &PedEval| {
                for r in 0..nq {
                    jac[(r, i)] = -(ev.h_inv[(r, pe.i0)] * u[0] + ev.h_inv[(r, pe.i0 + 1)] * u[1]);
                }
            };
            let qm = |pe: &PedEval| nalgebra::Vector2::new(ev.q[pe.i0], ev.q[pe.i0 + 1]);
            // A bearing entry `dZ_B[row][col] = dz` added into column `i`
            // (zeroed before its first entry).
            let bearing_entry =
                |jac: &mut nalgebra::DMatrixViewMut<'_, Complex64>,
                 extra: &mut Vec<(usize, usize, [Complex64; 2])>,
                 i: usize,
                 (row, col, dz): (usize, usize, Complex64)| {
                    let in_block = ev.ped.iter().position(|pe| {
                        (pe.i0..pe.i0 + 2).contains(&row) && (pe.i0..pe.i0 + 2).contains(&col)
                    });
                    if let Some(ip) = in_block {
                        // `dZ_B = dz e_r e_c^T`: `dZ_eff q_m = (Z_P S) e_r dz (S
                        // Z_P q_m)_c` and `dT q_m = -S e_r dz (T q_m)_c`, outer
                        // products instead of the matrix chain.
                        let pe = &ev.ped[ip];
                        let (r, c) = (row - pe.i0, col - pe.i0);
                        let u = pe.zp_s.column(r) * (dz * pe.s_zp_q[c]);
                        for rr in 0..nq {
                            jac[(rr, i)] -=
                                ev.h_inv[(rr, pe.i0)] * u[0] + ev.h_inv[(rr, pe.i0 + 1)] * u[1];
                        }
                        if self.relative_probes {
                            let d = pe.s.column(r) * (-dz * pe.t_q[c]);
                            extra.push((ip, i, [d[0], d[1]]));
                        }
                    } else {
                        let s = dz * ev.q[col];
                        for rr in 0..nq {
                            jac[(rr, i)] -= ev.h_inv[(rr, row)] * s;
                        }
                    }
                };
            for (i, en) in entries.iter().enumerate() {
                if !wanted(i) {
                    jac.column_mut(i).fill(zero);
                    continue;
                }
                match *en {
                    Entry::Bearing { row, col, dz } => {
                        jac.column_mut(i).fill(zero);
                        bearing_entry(&mut jac, &mut extra, i, (row, col, dz));
                    }
                    Entry::Unbalance { plane, da } => {
                        // H^-1 (B + dB de) e_plane da, without temporaries.
                        let b_eff = ev.b_eff.as_ref().unwrap_or(&st.b);
                        for r in 0..nq {
                            let mut v = zero;
                            for c in 0..nq {
                                v += ev.h_inv[(r, c)] * b_eff[(c, plane)];
                            }
                            jac[(r, i)] = v * da;
                        }
                    }
                }
            }
            let mut runout_cols: Option<usize> = None;
            for (k, ext) in self.ext.iter().enumerate() {
                let o = self.offset(k);
                if !any_wanted(o, ext.n_params(nq)) {
                    jac.columns_mut(o, ext.n_params(nq)).fill(zero);
                    continue;
                }
                match *ext {
                    Extension::Runout => runout_cols = Some(o),
                    Extension::Plane { .. } | Extension::Spread { .. } | Extension::Bow { .. } => {
                        // H^-1 (b_n, the spread's mean b_n or g_n) times the
                        // scale, and j times it (only the spread's column is
                        // formed; the others are views).
                        let spread;
                        let (col, scale) = match *ext {
                            Extension::Bow { node, line } => {
                                (st.bow_column(node, line), self.scales.q)
                            }
                            Extension::Spread { first, last } => {
                                spread = st.spread_column(first, last);
                                (spread.column(0), self.pr.param.scaling.unbalance)
                            }
                            Extension::Plane { node } => {
                                (st.b_node.column(node), self.pr.param.scaling.unbalance)
                            }
                            _ => return Err(PredictError::Dimension),
                        };
                        let scale = Complex64::from(scale);
                        for r in 0..nq {
                            let mut v = zero;
                            for c in 0..nq {
                                v += ev.h_inv[(r, c)] * col[c];
                            }
                            let v = v * scale;
                            jac[(r, o)] = v;
                            jac[(r, o + 1)] = v * j;
                        }
                    }
                    Extension::EScale => {
                        let (da, db) = match (&st.da_de, &st.db_de) {
                            (Some(da), Some(db)) => (da, db),
                            _ => return Err(PredictError::Dimension),
                        };
                        let v = &ev.h_inv * (db * &ev.a - da * &ev.q) * Complex64::from(E_STEP);
                        jac.set_column(o, &v);
                    }
                    Extension::Pedestal { .. } => {
                        let Some(ip) = ev.ped.iter().position(|pe| pe.o == o) else {
                            return Err(PredictError::Dimension);
                        };
                        let pe = &ev.ped[ip];
                        let qm = qm(pe);
                        let w = st.omega;
                        let pp = &pe.params;
                        let mass = pp.masses();
                        for d in 0..ext.n_params(nq) {
                            // dZ_P / dx_d, diagonal.
                            let mut dzp = Matrix2::<Complex64>::zeros();
                            match d {
                                0 => dzp = pe.zp,
                                1 | 2 => {
                                    let k = d - 1;
                                    let wk = pp.omega[k];
                                    dzp[(k, k)] = Complex64::new(
                                        2.0 * mass[k] * wk * wk,
                                        2.0 * mass[k] * pp.zeta[k] * wk * w,
                                    );
                                }
                                3 | 4 => {
                                    let k = d - 3;
                                    dzp[(k, k)] =
                                        Complex64::new(0.0, 0.2 * mass[k] * pp.omega[k] * w);
                                }
                                _ => {
                                    // The split: Z_P,y e^s and Z_P,z e^-s.
                                    dzp[(0, 0)] = pe.zp[(0, 0)];
                                    dzp[(1, 1)] = -pe.zp[(1, 1)];
                                }
                            }
                            let dzeff = pe.zb * pe.s * dzp * pe.s * pe.zb;
                            block_dq(&mut jac, o + d, &(dzeff * qm), pe);
                            if self.relative_probes {
                                let dt = pe.s * dzp * pe.s * pe.zb * qm;
                                extra.push((ip, o + d, [dt[0], dt[1]]));
                            }
                        }
                    }
                    Extension::FilmLaw => {
                        // As a nominal bearing entry, each of its entries
                        // added into its parameter's column.
                        for c in 0..ext.n_params(nq) {
                            jac.column_mut(o + c).fill(zero);
                        }
                        for (row, col, dz, k) in film_entries(nq, &self.pr.param.scaling, st.omega)
                        {
                            bearing_entry(&mut jac, &mut extra, o + k, (row, col, dz));
                        }
                    }
                    // Their columns are set once every row is (below).
                    Extension::Gain { .. } | Extension::NodeRunout { .. } => {}
                }
            }
            // Probes at other nodes: P dq plus the loads' direct terms (before
            // the pedestal's probe transform, which acts on bearing channels).
            node_rows = match &st.probes {
                None => None,
                Some(nt) => {
                    let mut dq = jac.clone_owned();
                    if let Some(o) = runout_cols {
                        for c in 0..2 * nq {
                            dq.column_mut(o + c).fill(zero);
                        }
                    }
                    // P + dP de with the modulus extension.
                    let e_idx = self.ext.iter().position(|x| *x == Extension::EScale);
                    let mut jn = match (e_idx, &nt.dp_de) {
                        (Some(k), Some(dp)) => {
                            (&nt.p + dp * Complex64::from(theta[self.offset(k)] * E_STEP)) * dq
                        }
                        _ => &nt.p * dq,
                    };
                    for (i, en) in entries.iter().enumerate() {
                        if let Entry::Unbalance { plane, da } = *en {
                            let mut u = nt.u.column(plane) * da;
                            if let (Some(du), Some(k)) = (&nt.du_de, e_idx) {
                                u += du.column(plane) * (da * theta[self.offset(k)] * E_STEP);
                            }
                            let mut col = jn.column_mut(i);
                            col += u;
                        }
                    }
                    for (k, ext) in self.ext.iter().enumerate() {
                        let o = self.offset(k);
                        match *ext {
                            Extension::Plane { node } => {
                                let v = nt.u_node.column(node)
                                    * Complex64::from(self.pr.param.scaling.unbalance);
                                let mut c0 = jn.column_mut(o);
                                c0 += &v;
                                let mut c1 = jn.column_mut(o + 1);
                                c1 += v * j;
                            }
                            Extension::Spread { first, last } => {
                                let v = nt.spread_column(first, last)
                                    * Complex64::from(self.pr.param.scaling.unbalance);
                                let mut c0 = jn.column_mut(o);
                                c0 += &v;
                                let mut c1 = jn.column_mut(o + 1);
                                c1 += v * j;
                            }
                            Extension::Bow { node, line } => {
                                let v = nt.bow_column(node, line)? * Complex64::from(self.scales.q);
                                let mut c0 = jn.column_mut(o);
                                c0 += &v;
                                let mut c1 = jn.column_mut(o + 1);
                                c1 += v * j;
                            }
                            Extension::EScale => {
                                let (Some(dp), Some(du)) = (&nt.dp_de, &nt.du_de) else {
                                    return Err(PredictError::Dimension);
                                };
                                let v = (dp * &ev.q + du * &ev.a) * Complex64::from(E_STEP);
                                let mut c0 = jn.column_mut(o);
                                c0 += v;
                            }
                            Extension::Runout
                            | Extension::Pedestal { .. }
                            | Extension::Gain { .. }
                            | Extension::NodeRunout { .. }
                            | Extension::FilmLaw => {}
                        }
                    }
                    Some(jn)
                }
            };
            // The probe transform on the pedestal's block, then its own terms.
            // (The pedestals' blocks are disjoint: each transform acts on
            // its own two rows.)
            for (ip, pe) in ev.ped.iter().enumerate().filter(|_| self.relative_probes) {
                for i in (0..np).filter(|&i| wanted(i)) {
                    let a0 = jac[(pe.i0, i)];
                    let a1 = jac[(pe.i0 + 1, i)];
                    jac[(pe.i0, i)] = pe.t[(0, 0)] * a0 + pe.t[(0, 1)] * a1;
                    jac[(pe.i0 + 1, i)] = pe.t[(1, 0)] * a0 + pe.t[(1, 1)] * a1;
                }
                for (_, i, d) in extra.iter().filter(|x| x.0 == ip) {
                    jac[(pe.i0, *i)] += d[0];
                    jac[(pe.i0 + 1, *i)] += d[1];
                }
            }
            if let Some(o) = runout_cols {
                for c in 0..nq {
                    for r in 0..nq {
                        jac[(r, o + 2 * c)] = zero;
                        jac[(r, o + 2 * c + 1)] = zero;
                    }
                    jac[(c, o + 2 * c)] = Complex64::from(self.scales.q);
                    jac[(c, o + 2 * c + 1)] = j * self.scales.q;
                }
            }
        }
        if let Some(jn) = node_rows {
            jac_full.rows_mut(nq, jn.nrows()).copy_from(&jn);
        }
        // A node probe's runout: `dy_c / dx = q_s`, `dy_c / dy = j q_s`.
        for (k, ext) in self.ext.iter().enumerate() {
            if let Extension::NodeRunout { output } = *ext {
                let o = self.offset(k);
                jac_full.column_mut(o).fill(Complex64::new(0.0, 0.0));
                jac_full.column_mut(o + 1).fill(Complex64::new(0.0, 0.0));
                jac_full[(output, o)] = Complex64::from(self.scales.q);
                jac_full[(output, o + 1)] = Complex64::new(0.0, self.scales.q);
            }
        }
        // A gain scales its row (every other column, `dy_c = (1 + g) dy`)
        // and adds its own column `dy_c / dx = GAIN_STEP y_before`.
        for g in &ev.gains {
            let mut row = jac_full.row_mut(g.channel);
            row *= Complex64::from(g.factor);
            jac_full.column_mut(g.o).fill(Complex64::new(0.0, 0.0));
            jac_full[(g.channel, g.o)] = g.before * GAIN_STEP;
        }
        Ok(ev.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::terms::build;
    use crate::estimate::Parametrization;
    use crate::fe::assembly::FeModel;
    use crate::fe::response::{bearing_response, Forcing};
    use crate::model::{BowPoint, RotorModel, ShaftBow, Unbalance};
    use crate::tables::auto_scaling;
    use rotorid_core::parametrization::Structure;

    fn model_for(m: &RotorModel, ext: Vec<Extension>) -> ExtendedModel {
        let param = Parametrization {
            structure: Structure::physical(1),
            scaling: auto_scaling(m, 1500.0),
            bearing_nodes: m.bearing_nodes(),
            plane_nodes: m.planes.clone(),
        };
        ExtendedModel {
            pr: Predictor::new(param),
            ext,
            scales: Scales {
                q: 1e-5,
                mass: 50.0,
                omega: 1000.0,
            },
            relative_probes: true,
        }
    }

    /// The nominal parameters of the paper rotor (physical order 1: K then
    /// C per bearing entry, then Re/Im of the plane unbalances, scaled).
    fn nominal_theta(m: &RotorModel, x: &ExtendedModel) -> Vec<f64> {
        let p = &x.pr.param;
        let mut w = vec![Complex64::new(0.0, 0.0); p.n_unknowns()];
        for (j, wj) in w.iter_mut().enumerate() {
            let s = p.scale(j);
            *wj = match p.unknown(j).unwrap() {
                rotorid_core::parametrization::Unknown::Bearing {
                    bearing,
                    row,
                    col,
                    term,
                } => {
                    let co = m.bearings[bearing].law.at(0.0);
                    let v = match term {
                        rotorid_core::parametrization::BearingTerm::K { .. } => co.k[2 * row + col],
                        _ => co.c[2 * row + col],
                    };
                    Complex64::from(v / s)
                }
                rotorid_core::parametrization::Unknown::Unbalance { plane, part } => {
                    let u = m
                        .unbalance
                        .iter()
                        .find(|u| u.node == m.planes[plane])
                        .unwrap();
                    let a = u.phasor();
                    let v = match part {
                        rotorid_core::parametrization::UnbalancePart::Re => a.re,
                        rotorid_core::parametrization::UnbalancePart::Im => a.im,
                        rotorid_core::parametrization::UnbalancePart::Phasor => unreachable!(),
                    };
                    Complex64::from(v / s)
                }
            };
        }
        x.pr.theta(&w)
    }

    /// Bow and extra plane through the extended model equal the full FE
    /// response of the paper rotor with that bow and unbalance.
    /// A bow from the bearing line on a rotor with three bearings (the
    /// paper rotor with a third at mid-span, node 15) equals the FE
    /// response to the same bow: offsets zero at the three bearings and
    /// `beta` at node 8, at the bearing channels and at a node probe.
    #[test]
    fn line_bow_on_three_bearings_matches_the_fe_response() {
        let mut m = RotorModel::paper();
        let mut mid = m.bearings[0].clone();
        mid.node = 14;
        m.bearings.insert(1, mid);
        let x = model_for(
            &m,
            vec![Extension::Bow {
                node: 7,
                line: true,
            }],
        );
        let omegas = [300.0, 900.0, 1400.0];
        let nodes = [20];
        let terms =
            crate::diagnose::terms::build_with_probes(&m, &omegas, 1.0, false, &nodes).unwrap();
        assert!(terms[0].g_line.is_some());
        let mut theta = nominal_theta(&m, &x);
        let beta = Complex64::from_polar(2e-5, 0.4);
        theta.extend([beta.re / 1e-5, beta.im / 1e-5]);
        let mut forcing = Forcing::from_model(&m);
        forcing.bow = Some(ShaftBow {
            points: vec![
                BowPoint {
                    node: 7,
                    amplitude: beta.norm(),
                    phase: beta.arg(),
                },
                BowPoint {
                    node: 14,
                    amplitude: 0.0,
                    phase: 0.0,
                },
            ],
        });
        let fe = FeModel::new(&m).unwrap();
        let full = crate::fe::response::unbalance_response(&fe, &forcing, &omegas).unwrap();
        for (k, st) in terms.iter().enumerate() {
            let y = x
                .predict(st, &x.pr.entries(st.omega), &theta, None)
                .unwrap();
            assert_eq!(y.len(), 8);
            let dofs = [0, 14, 26, 20].into_iter().flat_map(|n| {
                [
                    fe.dof(n, crate::fe::assembly::Dir::Y),
                    fe.dof(n, crate::fe::assembly::Dir::Z),
                ]
            });
            for (r, d) in dofs.enumerate() {
                let want = full[k].q[d];
                assert!(
                    (y[r] - want).norm() <= 1e-8 * want.norm().max(1e-9),
                    "speed {k} output {r}: {} vs {want}",
                    y[r]
                );
            }
        }
    }

    #[test]
    fn bow_and_plane_match_the_fe_response() {
        let m = RotorModel::paper();
        let x = model_for(
            &m,
            vec![
                Extension::Plane { node: 15 },
                Extension::Bow {
                    node: 14,
                    line: false,
                },
            ],
        );
        let omegas = [200.0, 700.0, 1300.0];
        let terms = build(&m, &omegas, 1.0, false).unwrap();
        let mut theta = nominal_theta(&m, &x);
        let u = Complex64::from_polar(2e-4, 0.7);
        let beta = Complex64::from_polar(2e-5, -1.1);
        let su = x.pr.param.scaling.unbalance;
        theta.extend([u.re / su, u.im / su, beta.re / 1e-5, beta.im / 1e-5]);
        let mut forcing = Forcing::from_model(&m);
        forcing.unbalance.push(Unbalance {
            node: 15,
            me: u.norm(),
            phase: u.arg(),
        });
        forcing.bow = Some(ShaftBow {
            points: vec![BowPoint {
                node: 14,
                amplitude: beta.norm(),
                phase: beta.arg(),
            }],
        });
        let fe = FeModel::new(&m).unwrap();
        let want = bearing_response(&fe, &forcing, &omegas).unwrap();
        for (k, st) in terms.iter().enumerate() {
            let y = x
                .predict(st, &x.pr.entries(st.omega), &theta, None)
                .unwrap();
            let w = DVector::from_vec(want[k].clone());
            assert!((&y - &w).norm() <= 1e-8 * w.norm(), "{k}: {y} vs {w}");
        }
        // Probes at other nodes (one at a bearing node, one at the extra
        // plane, one at mid-span) equal the FE response there; so does a
        // modulus factor, against a model rebuilt with it.
        let nodes = [0, 9, 13, 15];
        for e in [1.0, 1.04] {
            let mut me = m.clone();
            for el in &mut me.shaft {
                el.material.e *= e;
                el.material.g *= e;
            }
            let full = crate::fe::response::unbalance_response(
                &FeModel::new(&me).unwrap(),
                &forcing,
                &omegas,
            )
            .unwrap();
            let terms =
                crate::diagnose::terms::build_with_probes(&m, &omegas, e, false, &nodes).unwrap();
            for (k, st) in terms.iter().enumerate() {
                let y = x
                    .predict(st, &x.pr.entries(st.omega), &theta, None)
                    .unwrap();
                assert_eq!(y.len(), 4 + 2 * nodes.len());
                assert_node_probes(&y, &full[k].q, &fe, &nodes, &format!("e {e} speed {k}"));
            }
        }
    }

    /// The readings of the probes at `nodes` in `y` (after the four
    /// bearing channels, `y` and `z` per node) equal the FE response `q`
    /// there, to 1e-8.
    fn assert_node_probes(
        y: &DVector<Complex64>,
        q: &[Complex64],
        fe: &FeModel,
        nodes: &[usize],
        what: &str,
    ) {
        for (i, &n) in nodes.iter().enumerate() {
            for (d, dir) in [crate::fe::assembly::Dir::Y, crate::fe::assembly::Dir::Z]
                .into_iter()
                .enumerate()
            {
                let want = q[fe.dof(n, dir)];
                let got = y[4 + 2 * i + d];
                assert!(
                    (got - want).norm() <= 1e-8 * want.norm(),
                    "{what} node {n}: {got} vs {want}"
                );
            }
        }
    }

    /// An unbalance shared by a run of nodes equals the FE response to
    /// the run's nodes each carrying its share, at the bearings and at
    /// probes at other nodes (one inside the run).
    #[test]
    fn spread_matches_the_fe_response() {
        let m = RotorModel::paper();
        let x = model_for(
            &m,
            vec![Extension::Spread {
                first: 14,
                last: 16,
            }],
        );
        let omegas = [200.0, 700.0, 1300.0];
        let mut theta = nominal_theta(&m, &x);
        let u = Complex64::from_polar(3e-4, 0.4);
        let su = x.pr.param.scaling.unbalance;
        theta.extend([u.re / su, u.im / su]);
        let mut forcing = Forcing::from_model(&m);
        for node in 14..=16 {
            forcing.unbalance.push(Unbalance {
                node,
                me: u.norm() / 3.0,
                phase: u.arg(),
            });
        }
        let fe = FeModel::new(&m).unwrap();
        let full = crate::fe::response::unbalance_response(&fe, &forcing, &omegas).unwrap();
        let nodes = [5, 15, 20];
        let terms =
            crate::diagnose::terms::build_with_probes(&m, &omegas, 1.0, false, &nodes).unwrap();
        for (k, st) in terms.iter().enumerate() {
            let y = x
                .predict(st, &x.pr.entries(st.omega), &theta, None)
                .unwrap();
            for i in 0..4 {
                let want = full[k].bearings[i];
                assert!(
                    (y[i] - want).norm() <= 1e-8 * want.norm(),
                    "speed {k} channel {i}: {} vs {want}",
                    y[i]
                );
            }
            assert_node_probes(&y, &full[k].q, &fe, &nodes, &format!("speed {k}"));
        }
        // A run of one node is the plane.
        let one = model_for(
            &m,
            vec![Extension::Spread {
                first: 15,
                last: 15,
            }],
        );
        let plane = model_for(&m, vec![Extension::Plane { node: 15 }]);
        for st in &terms {
            let en = one.pr.entries(st.omega);
            assert_eq!(
                one.predict(st, &en, &theta, None).unwrap(),
                plane.predict(st, &en, &theta, None).unwrap()
            );
        }
        // A run past the last node is refused.
        let past = model_for(
            &m,
            vec![Extension::Spread {
                first: 25,
                last: 40,
            }],
        );
        let st = &terms[0];
        assert!(past
            .predict(st, &past.pr.entries(st.omega), &theta, None)
            .is_err());
    }

    /// The film law through the extended model equals the FE response of
    /// the rotor whose bearings follow the same law written as polynomials
    /// in `Omega` ([`crate::model::BearingLaw::Polynomial`]: `K_1 = (s_K /
    /// Omega_r) [x_d, x_x, -x_x, x_d]`, `C_1 = (s_K / Omega_r^2) [x_c, 0,
    /// 0, x_c]`), also with a pedestal under one bearing.
    #[test]
    fn film_law_matches_the_fe_response() {
        let m = RotorModel::paper();
        for pedestal in [false, true] {
            let mut ext = vec![Extension::FilmLaw];
            if pedestal {
                ext.push(Extension::Pedestal {
                    bearing: 1,
                    split: false,
                });
            }
            let x = model_for(&m, ext);
            let sc = x.pr.param.scaling;
            let film = [[0.3, -0.2, 0.5], [-0.4, 0.25, -0.3]];
            let mut theta = nominal_theta(&m, &x);
            let mut mp = m.clone();
            for (b, p) in film.iter().enumerate() {
                theta.extend_from_slice(p);
                let co = m.bearings[b].law.at(0.0);
                let (kk, cc) = (
                    sc.stiffness / sc.omega_ref,
                    sc.stiffness / sc.omega_ref.powi(2),
                );
                mp.bearings[b].law = crate::model::BearingLaw::Polynomial {
                    k: vec![co.k, [kk * p[0], kk * p[1], -kk * p[1], kk * p[0]]],
                    c: vec![co.c, [cc * p[2], 0.0, 0.0, cc * p[2]]],
                };
            }
            if pedestal {
                let ped = PedestalParams {
                    mass: 60.0,
                    split: 0.0,
                    omega: [900.0, 1300.0],
                    zeta: [0.05, 0.04],
                };
                let (k, c) = ped.k_c();
                mp.bearings[1].pedestal = Some(crate::model::Pedestal {
                    mass: ped.masses(),
                    k,
                    c,
                });
                theta.extend(ped.to_scaled(&x.scales));
            }
            let omegas = [300.0, 950.0, 1400.0];
            let terms = build(&m, &omegas, 1.0, false).unwrap();
            let fe = FeModel::new(&mp).unwrap();
            let resp =
                crate::fe::response::unbalance_response(&fe, &Forcing::from_model(&mp), &omegas)
                    .unwrap();
            for (n, st) in terms.iter().enumerate() {
                let y = x
                    .predict(st, &x.pr.entries(st.omega), &theta, None)
                    .unwrap();
                let r = &resp[n];
                let w = DVector::from_iterator(
                    4,
                    (0..4).map(|i| {
                        if pedestal {
                            r.bearings[i] - r.pedestals[i]
                        } else {
                            r.bearings[i]
                        }
                    }),
                );
                // The law changes the response: not the nominal one.
                let y0 = model_for(&m, Vec::new())
                    .predict(st, &x.pr.entries(st.omega), &theta[..x.pr.n_params()], None)
                    .unwrap();
                assert!((&y0 - &w).norm() > 1e-3 * w.norm() || pedestal);
                assert!(
                    (&y - &w).norm() <= 1e-8 * w.norm(),
                    "pedestal {pedestal} speed {n}: {y} vs {w}"
                );
            }
        }
    }

    /// A pedestal through the extended model equals the FE response of the
    /// rotor with that pedestal, read absolutely and relatively.
    #[test]
    fn pedestal_matches_the_fe_response() {
        let m = RotorModel::paper();
        pedestals_match_the_fe_response(&m, &[1]);
        pedestals_match_the_fe_response(&m, &[1, 0]);
    }

    /// The extended prediction with pedestals under `bearings` against the
    /// FE response of the model with those pedestals (the second one
    /// lighter and stiffer; the first with one mass, the others with
    /// their masses in y and z apart, [`PedestalParams::split`]).
    fn pedestals_match_the_fe_response(m: &RotorModel, bearings: &[usize]) {
        let mut x = model_for(
            m,
            bearings
                .iter()
                .enumerate()
                .map(|(i, &bearing)| Extension::Pedestal {
                    bearing,
                    split: i > 0,
                })
                .collect(),
        );
        let mut mp = m.clone();
        let mut theta = nominal_theta(m, &x);
        for (i, &b) in bearings.iter().enumerate() {
            let ped = PedestalParams {
                mass: 80.0 / (1 + i) as f64,
                split: if i > 0 { 0.2 } else { 0.0 },
                omega: [900.0 + 400.0 * i as f64, 1100.0],
                zeta: [0.05, 0.03],
            };
            let (k, c) = ped.k_c();
            mp.bearings[b].pedestal = Some(crate::model::Pedestal {
                mass: ped.masses(),
                k,
                c,
            });
            theta.extend(ped.to_scaled(&x.scales));
            if i > 0 {
                theta.push(ped.split);
            }
        }
        let omegas = [300.0, 950.0, 1400.0];
        let terms = build(m, &omegas, 1.0, false).unwrap();
        let fe = FeModel::new(&mp).unwrap();
        let resp = crate::fe::response::unbalance_response(&fe, &Forcing::from_model(&mp), &omegas)
            .unwrap();
        for relative in [false, true] {
            x.relative_probes = relative;
            for (n, st) in terms.iter().enumerate() {
                let y = x
                    .predict(st, &x.pr.entries(st.omega), &theta, None)
                    .unwrap();
                let want: Vec<Complex64> = (0..4)
                    .map(|i| {
                        let r = &resp[n];
                        if relative {
                            r.bearings[i] - r.pedestals[i]
                        } else {
                            r.bearings[i]
                        }
                    })
                    .collect();
                let w = DVector::from_vec(want);
                assert!(
                    (&y - &w).norm() <= 1e-8 * w.norm(),
                    "{relative} {n}: {y} vs {w}"
                );
            }
        }
    }

    /// The analytic Jacobian equals central differences, with and without
    /// a pedestal, relative and absolute probes, probe gains on a bearing
    /// channel (one under a pedestal, one with runout) and on a node probe,
    /// the film law on bearings with and without a pedestal; and its
    /// columns formed alone equal those of the whole Jacobian.
    #[test]
    fn jacobian_matches_central_differences() {
        let m = RotorModel::paper();
        let plain = vec![
            Extension::Runout,
            Extension::Plane { node: 16 },
            Extension::Bow {
                node: 9,
                line: false,
            },
            Extension::Gain { channel: 1 },
            Extension::EScale,
            Extension::NodeRunout { output: 5 },
            Extension::Gain { channel: 5 },
            Extension::NodeRunout { output: 6 },
            Extension::FilmLaw,
            Extension::Spread {
                first: 10,
                last: 12,
            },
        ];
        let ped = vec![
            Extension::Pedestal {
                bearing: 0,
                split: false,
            },
            Extension::Gain { channel: 0 },
            Extension::Runout,
            Extension::Plane { node: 16 },
            Extension::EScale,
            Extension::FilmLaw,
        ];
        let two = vec![
            Extension::Pedestal {
                bearing: 1,
                split: true,
            },
            Extension::Plane { node: 16 },
            Extension::Pedestal {
                bearing: 0,
                split: false,
            },
        ];
        for (ext, relative) in [
            (plain, true),
            (ped.clone(), true),
            (ped, false),
            (two.clone(), true),
            (two, false),
        ] {
            let mut x = model_for(&m, ext);
            x.relative_probes = relative;
            jacobian_case(&m, &x);
        }
    }

    fn jacobian_case(m: &RotorModel, x: &ExtendedModel) {
        // Probes at an interior node and at a bearing node too.
        let terms =
            crate::diagnose::terms::build_with_probes(m, &[800.0], 1.0, true, &[9, 26]).unwrap();
        let st = &terms[0];
        let mut theta = nominal_theta(m, x);
        theta.extend((0..x.n_params() - theta.len()).map(|i| 0.3 + 0.1 * i as f64));
        let en = x.pr.entries(st.omega);
        let rows = x.n_outputs(st);
        assert_eq!(rows, 8);
        let mut jac = DMatrix::zeros(rows, x.n_params());
        let y = x.predict(st, &en, &theta, Some(&mut jac)).unwrap();
        // Some columns only (every third, from each start): the same
        // numbers, bit for bit, whatever the matrix held before.
        for start in 0..3 {
            let want: Vec<bool> = (0..x.n_params()).map(|i| i % 3 == start).collect();
            let mut part = DMatrix::from_element(rows, x.n_params(), Complex64::new(7.0, -3.0));
            let ev = x.evaluate(st, &en, &theta).unwrap();
            let yp = x
                .predict_columns(ev, st, &en, &theta, Some(&mut part), Some(&want))
                .unwrap();
            assert_eq!(yp, y);
            for i in (0..x.n_params()).filter(|&i| want[i]) {
                assert_eq!(part.column(i), jac.column(i), "{:?} column {i}", x.ext);
            }
        }
        for i in 0..x.n_params() {
            let h = 1e-6;
            let mut tp = theta.clone();
            let mut tm = theta.clone();
            tp[i] += h;
            tm[i] -= h;
            let fd = (x.predict(st, &en, &tp, None).unwrap()
                - x.predict(st, &en, &tm, None).unwrap())
                / Complex64::from(2.0 * h);
            for r in 0..rows {
                assert!(
                    (fd[r] - jac[(r, i)]).norm() <= 1e-6 * y.norm(),
                    "{:?} param {i} row {r}: {} vs {}",
                    x.ext,
                    fd[r],
                    jac[(r, i)]
                );
            }
        }
    }

    /// The Gauss-Jordan inverse equals nalgebra's cofactor inverse on
    /// random, ill-ordered (a zero leading pivot) and near-singular
    /// matrices, and refuses a singular one.
    #[test]
    fn invert_matches_nalgebra() {
        let mut x = 0.37_f64;
        let mut rnd = || {
            x = (x * 997.0 + 0.123).fract();
            x - 0.5
        };
        for n in 1..=6 {
            for case in 0..3 {
                let mut m = DMatrix::from_fn(n, n, |_, _| Complex64::new(rnd(), rnd()));
                if case == 1 && n > 1 {
                    m[(0, 0)] = Complex64::new(0.0, 0.0);
                }
                if case == 2 && n > 1 {
                    let r0 = m.row(0).into_owned();
                    m.row_mut(1).copy_from(&(r0 * Complex64::new(1.0, 1e-6)));
                    m[(1, 1)] += Complex64::new(1e-5, 0.0);
                }
                let ours = invert(m.clone()).unwrap();
                let check = &m * &ours - DMatrix::<Complex64>::identity(n, n);
                let scale = m.norm() * ours.norm();
                assert!(check.norm() <= 1e-13 * scale, "n {n} case {case}");
                if n <= 4 {
                    let theirs = m.clone().try_inverse().unwrap();
                    // Two backward-stable inverses differ by up to
                    // eps cond(m) |m^-1|, cond(m) = |m| |m^-1| = `scale`.
                    assert!(
                        (&ours - &theirs).norm() <= 1e-13 * scale * ours.norm(),
                        "n {n} case {case}"
                    );
                }
            }
        }
        let mut sing = DMatrix::from_fn(3, 3, |r, c| Complex64::new((r + c) as f64, 0.0));
        sing[(2, 2)] = Complex64::new(4.0, 0.0);
        assert!(invert(sing).is_none());
        assert!(invert(DMatrix::zeros(2, 2)).is_none());
    }
}
