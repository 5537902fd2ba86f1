//! `rotorid tables`: precompute the bearing-level model tables (the
//! reduction of the FE model to the bearing DOFs) on a speed grid and write
//! them for firmware.
//!
//! ```text
//! rotorid tables --model MODEL --out FILE [--rpm-min 50] [--rpm-max 15000] [--rpm-step 50] [--f32] [--adaptive TOL]
//!                [--formulation physical|paper] [--order 1]
//! ```
//!
//! * The output format follows the extension of `--out`: `.rs` writes Rust
//!   source (`static TABLE: rotorid_core::table::Table<..>` and the node
//!   lists, for `include!` in firmware); anything else writes the binary
//!   blob (layout in `rotorid_core::table`).
//! * `--f32` stores single precision (default f64).
//! * `--adaptive TOL` replaces the uniform grid by an adaptive one on
//!   `[rpm-min, rpm-max]` whose worst relative interpolation error of `A`
//!   and `B`, on a 10x finer check grid, is at most `TOL` (`--rpm-step` is
//!   then unused); the achieved error is printed.
//! * `--formulation`, `--order` name the model structure the firmware will
//!   identify (default `physical` 1). Blob and source carry it, with the
//!   column scaling `rotorid::estimate::auto_scaling(model, top of the
//!   grid)`; the source also defines the identifier type `Id`.
//!
//! One summary line goes to stdout.

use clap::Args;

use super::{load_model_arg, CliError, FormulationArg, Io, RpmGridArgs};
use crate::core::parametrization::{Structure, MAX_ORDER};
use crate::tables::grid::AdaptiveOptions;
use crate::tables::{build, build_adaptive, Scalar};
use crate::units::{rad_s_to_rpm, rpm_to_rad_s};

/// Smallest `--adaptive` tolerance: the speeds of a linear-interpolation
/// grid grow like `TOL^-1/2` (about 4000 for 1e-6 and 13000 for 1e-7 on the
/// paper's rotor, each with ten reductions on the check grid); finer
/// tolerances would run for many minutes.
pub const MIN_ADAPTIVE_TOL: f64 = 1e-7;

/// Arguments of `rotorid tables`.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct TablesArgs {
    /// Model: `paper` or a model file (rotorid or ROSS TOML).
    #[arg(long, value_name = "MODEL")]
    pub model: String,
    /// Output file: Rust source if it ends in `.rs`, binary blob otherwise.
    #[arg(long, value_name = "FILE")]
    pub out: std::path::PathBuf,
    /// Speed grid.
    #[command(flatten)]
    pub grid: RpmGridArgs,
    /// Store the table in single precision.
    #[arg(long = "f32")]
    pub f32: bool,
    /// Adaptive grid on [rpm-min, rpm-max] with this relative interpolation
    /// tolerance (checked on a 10x finer grid) instead of the uniform grid.
    #[arg(long, value_name = "TOL")]
    pub adaptive: Option<f64>,
    /// Model structure the firmware identifies with (carried by the table).
    #[arg(long, value_enum, default_value_t = FormulationArg::Physical)]
    pub formulation: FormulationArg,
    /// Polynomial order P of the bearing dynamic stiffness in Omega.
    #[arg(long, default_value_t = 1, value_name = "P")]
    pub order: usize,
}

/// Runs `rotorid tables`.
pub fn run(args: &TablesArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    super::refuse_overwriting_inputs(Some(&args.model), &[], &[("--out", Some(&args.out))])?;
    if !(1..=MAX_ORDER).contains(&args.order) {
        return Err(CliError::new(format!(
            "tables: --order must be in 1..={MAX_ORDER}, got {}",
            args.order
        )));
    }
    let structure = match args.formulation {
        FormulationArg::Physical => Structure::physical(args.order),
        FormulationArg::Paper => Structure::paper(args.order),
    };
    let model = load_model_arg(&args.model)?.model;
    let scalar = if args.f32 { Scalar::F32 } else { Scalar::F64 };
    let (table, note) = match args.adaptive {
        None => {
            let speeds = args.grid.speeds_rad_s()?;
            if speeds.first().is_some_and(|&w| w <= 0.0) {
                return Err(CliError::new(
                    "tables: --rpm-min must be > 0 (B / Omega^2 is undefined at rest)",
                ));
            }
            (build(&model, &speeds)?, String::new())
        }
        Some(tol) => {
            let g = &args.grid;
            if !(g.rpm_min.is_finite() && g.rpm_max.is_finite() && g.rpm_min > 0.0) {
                return Err(CliError::new("tables: --rpm-min must be finite and > 0"));
            }
            if !(tol.is_finite() && (MIN_ADAPTIVE_TOL..1.0).contains(&tol)) {
                return Err(CliError::new(format!(
                    "tables: --adaptive must be in [{MIN_ADAPTIVE_TOL:e}, 1) (finer grids take too long: the speeds grow like TOL^-1/2), got {tol:e}"
                )));
            }
            let (t, s) = build_adaptive(
                &model,
                rpm_to_rad_s(g.rpm_min),
                rpm_to_rad_s(g.rpm_max),
                AdaptiveOptions::new(tol),
            )?;
            let note = format!(
                ", adaptive: worst check error {:.3e} at {:.2} rpm (tolerance {tol:e})",
                s.check.worst_error,
                rad_s_to_rpm(s.check.at_omega)
            );
            (t, note)
        }
    };
    // The scaling is the default's: auto_scaling at the top of the grid.
    let table = table.with_structure(structure);
    let is_rust = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("rs"));
    let bytes = if is_rust {
        table.to_rust_source(scalar)?.into_bytes()
    } else {
        table.to_blob(scalar)?
    };
    crate::io::output::write_atomic(&args.out, &bytes)?;
    writeln!(
        io.out,
        "wrote {} ({} bytes, {}, {}, {} {}): {} speeds {:.1}..{:.1} rpm, {} bearings, {} planes, poles of A at {:?} rpm, of B at {:?} rpm{note}",
        args.out.display(),
        bytes.len(),
        if is_rust { "Rust source" } else { "blob" },
        scalar.rust_name(),
        match structure.formulation {
            crate::core::Formulation::Physical => "physical",
            crate::core::Formulation::Paper => "paper",
        },
        structure.order,
        table.terms.len(),
        rad_s_to_rpm(table.terms.first().map_or(0.0, |t| t.omega)),
        rad_s_to_rpm(table.terms.last().map_or(0.0, |t| t.omega)),
        table.bearing_nodes.len(),
        table.plane_nodes.len(),
        rpm_list(&table.poles.a),
        rpm_list(&table.poles.b),
    )?;
    if !is_rust {
        // The blob carries no Rust: the line that gives a firmware the
        // same constants and `type Id` as the source output.
        writeln!(
            io.out,
            "firmware types for this blob: {}",
            identifier_types_line(
                scalar.rust_name(),
                structure,
                table.bearing_nodes.len(),
                table.plane_nodes.len()
            )
        )?;
    }
    Ok(())
}

/// The `rotorid_core::identifier_types!` invocation of a blob written for
/// `structure`, `nb` bearings and `np` planes in the scalar `scalar`.
fn identifier_types_line(
    scalar: &str,
    structure: crate::core::parametrization::Structure,
    nb: usize,
    np: usize,
) -> String {
    let form = match structure.formulation {
        crate::core::Formulation::Physical => "physical",
        crate::core::Formulation::Paper => "paper",
    };
    format!(
        "rotorid_core::identifier_types!({scalar}, {form}({}), bearings: {nb}, planes: {np});",
        structure.order
    )
}

/// Speeds in rad/s as rpm rounded to 0.01, for the summary line.
fn rpm_list(w: &[f64]) -> Vec<f64> {
    w.iter()
        .map(|&p| (rad_s_to_rpm(p) * 100.0).round() / 100.0)
        .collect()
}
