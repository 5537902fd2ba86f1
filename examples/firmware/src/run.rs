//! The identification run of the firmware, shared word for word with its
//! host check (`examples/firmware_host.rs`): the identifier `FwId` of the
//! enclosing module (the generated table's `type Id`, square-root-free block
//! filter, f32, or another filter of the same structure) folds in the measured
//! sweep and prints its estimates. Each value is printed as a fixed-point
//! decimal (integer arithmetic on the `f32`, truncated) followed by its
//! `f32` bit pattern in hex, so equal lines mean bit-identical estimates.
//! (Core's float formatting would add about 10 KiB of flash.)

use super::FwId as Id;
use crate::sweep::SWEEP;
use crate::table::{SCALING, STRUCTURE, TABLE};
use core::fmt::{self, Write};
use rotorid_core::identify::{Config, IdentifierError};
use rotorid_core::parametrization::COEFFICIENTS;

/// Hooks around each identifier update (stack painting, instruction-count
/// markers on the target; nothing on the host).
pub trait Probe {
    /// Right before `Id::update`.
    fn before_update(&mut self) {}
    /// Right after `Id::update`.
    fn after_update(&mut self) {}
}

/// `x` as a fixed-point decimal with `decimals` digits (truncated toward
/// zero; magnitudes beyond `i64` saturate) and its bit pattern, e.g.
/// `12.34 [0x414570a4]`.
pub struct Fixed(pub f32, pub u32);

impl fmt::Display for Fixed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let scale = 10i64.pow(self.1);
        let n = (self.0 * scale as f32) as i64;
        let sign = if n < 0 { "-" } else { "" };
        let (int, frac) = (
            n.unsigned_abs() / scale as u64,
            n.unsigned_abs() % scale as u64,
        );
        if self.1 == 0 {
            write!(f, "{sign}{int}")?;
        } else {
            write!(f, "{sign}{int}.{frac:0w$}", w = self.1 as usize)?;
        }
        write!(f, " [{:#010x}]", self.0.to_bits())
    }
}

/// One identifier update (table lookup, regression, block QRD/RLS), in a
/// frame of its own so that the stack it takes can be measured.
#[inline(never)]
pub fn update(
    id: &mut Id,
    omega: f32,
    q: &[rotorid_core::Complex<f32>; 4],
) -> Result<rotorid_core::identify::StepReport<f32>, IdentifierError> {
    id.update(&TABLE, omega, q)
}

/// Runs the sweep through the identifier and writes the estimates to `out`
/// (lines starting with `est `). Returns the number of updates folded in.
pub fn run<W: Write, P: Probe>(out: &mut W, probe: &mut P) -> Result<usize, IdentifierError> {
    let mut id = Id::new(Config::new(STRUCTURE, SCALING))?;
    let (mut used, mut last) = (0usize, 0.0f32);
    for (omega, q) in SWEEP.iter() {
        probe.before_update();
        let step = update(&mut id, *omega, q);
        probe.after_update();
        if step.is_ok() {
            used += 1;
            last = *omega;
        }
    }
    let est = id.estimates(last)?;
    // A failed write to the host cannot be reported anywhere else.
    let _ = writeln!(
        out,
        "est updates {} of {} at {} rad/s",
        used,
        SWEEP.len(),
        Fixed(last, 3)
    );
    for (m, b) in est.bearings.iter().enumerate() {
        for (j, name) in COEFFICIENTS.iter().enumerate() {
            let _ = writeln!(
                out,
                "est bearing {} k{} {} N/m c{} {} N s/m",
                m + 1,
                name,
                Fixed(b.k[j], 0),
                name,
                Fixed(b.c[j], 2)
            );
        }
    }
    // The unbalance phasor itself is compared; its magnitude and phase
    // (`hypot`, `atan2`) are printed as comments: the target's `libm` and
    // the host's C library may round those differently by an ulp.
    for (k, u) in est.unbalance.iter().enumerate() {
        let _ = writeln!(
            out,
            "est plane {} a {} {} g mm",
            k + 1,
            Fixed(u.a.re * 1e6, 3),
            Fixed(u.a.im * 1e6, 3)
        );
        let _ = writeln!(
            out,
            "# plane {} me {} g mm phase {} deg",
            k + 1,
            Fixed(u.me * 1e6, 3),
            Fixed(u.phase_deg(), 3)
        );
    }
    Ok(used)
}
