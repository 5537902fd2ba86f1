//! Shared data for the flight-solver comparison: a real identification
//! problem of the paper's real formulation size, 22 real unknowns and 8
//! real rows per speed step, in f32.
#![no_std]

/// Unknowns (real formulation of the paper rotor).
pub const M: usize = 22;
/// Real rows per speed step.
pub const N: usize = 8;
/// Forgetting factor per speed step.
pub const LAMBDA: f32 = 0.999;
/// Regularisation, `R(0) = sqrt(DELTA) I` (flight-solver: `P(0) = I / DELTA`).
pub const DELTA: f32 = 1e-3;

/// Block layout of the block-structured filter for this problem (physical
/// structure, order 1, `N_b = 2`, `N_p = 3`): 4 channel blocks of 4
/// bearing coefficients, then 6 shared unbalance unknowns.
pub const NB: usize = 4;
/// Columns per block.
pub const W: usize = 4;
/// Shared columns.
pub const S: usize = 6;

/// One speed step of data.
pub type Step = ([[f32; M]; N], [f32; N]);

/// Deterministic stream (splitmix64): rows uniform in [-1, 1), `d = U w + 1e-3 noise`.
pub fn stream(steps: usize, seed: u64) -> impl Iterator<Item = Step> {
    stream_with(steps, seed, false)
}

/// As [`stream`], with the rows of the identification: row `j` non-zero
/// only in the block of channel `j / 2` (columns `4 (j / 2) .. 4 (j / 2) +
/// 4`) and in the 6 shared columns, as the real regression has them.
pub fn stream_structured(steps: usize, seed: u64) -> impl Iterator<Item = Step> {
    stream_with(steps, seed, true)
}

fn stream_with(steps: usize, seed: u64, structured: bool) -> impl Iterator<Item = Step> {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0) as f32
    };
    let w: [f32; M] = core::array::from_fn(|_| next());
    (0..steps).map(move |_| {
        let u: [[f32; M]; N] = core::array::from_fn(|j| {
            core::array::from_fn(|k| {
                let b = j / 2;
                let active = !structured || (k >= b * W && k < (b + 1) * W) || k >= NB * W;
                let x = next();
                if active {
                    x
                } else {
                    0.0
                }
            })
        });
        let d: [f32; N] = core::array::from_fn(|j| {
            let mut acc = 1e-3 * next();
            for k in 0..M {
                acc += u[j][k] * w[k];
            }
            acc
        });
        (u, d)
    })
}
