//! The host half of the Cortex-M4F firmware (`examples/firmware/`): runs the
//! firmware's identifications (`examples/firmware/src/run.rs` and the
//! coast-down generator `examples/firmware/src/coastdown.rs`, the same
//! sources) over the same generated f32 table and sweep on the host, from
//! the sweep's vectors and from the generated samples through the order
//! tracker, and prints the same `est` lines; `.ci/firmware.sh` checks that
//! the QEMU run prints them identically.
//!
//! ```sh
//! cargo run --release --example firmware_host
//! cargo run --release --example firmware_host -- --givens
//! cargo run --release --example firmware_host -- --write-sweep examples/firmware/src/sweep.rs
//! ```
//!
//! `--write-sweep` writes the firmware's measured sweep: the paper rotor
//! simulated at 1000..12000 rpm in steps of 100 rpm with 0.1 % noise
//! (seed 1), as f32 phasors. The table beside it comes from
//! `rotorid tables --model paper --rpm-min 1000 --rpm-max 12000 --rpm-step 250 --f32`.

/// The generated table (`TABLE`, `STRUCTURE`, `SCALING`, `type Id`).
#[allow(dead_code)]
mod table {
    include!("firmware/src/table.rs");
}

/// The measured sweep (`SWEEP`).
mod sweep {
    include!("firmware/src/sweep.rs");
}

/// The coast-down's sample generator (the firmware's source).
#[path = "firmware/src/coastdown.rs"]
mod coastdown;

#[path = "firmware/src/run.rs"]
mod run;

/// The order tracker's per-sample entry point (the firmware's crate
/// `tracker/`, the same source).
#[path = "firmware/tracker/src/push.rs"]
mod tracking;

/// The coast-down's deceleration (rad/s^2), the firmware's default.
const DECELERATION: f32 = 150.0;

/// The firmware's identifier type (the generated `type Id`, square-root-free
/// block filter).
type FwId = table::Id;

/// The same run with the Givens block filter (the firmware's `givens`
/// feature).
#[path = "firmware_host/givens.rs"]
mod givens;

use std::fmt::Write as _;

/// No hooks on the host.
struct NoProbe;

impl run::Probe for NoProbe {}
impl givens::run::Probe for NoProbe {}

/// Writes the sweep source (speeds in rad/s, phasors in m, f32).
fn write_sweep(path: &str) -> Result<(), Box<dyn std::error::Error>> {
    let model = rotorid::model::RotorModel::paper();
    let opts = rotorid::simulate::SimOptions {
        speeds_rpm: (10..=120).map(|i| 100.0 * i as f64).collect(),
        noise: 0.0,
        seed: 1,
        effects: Default::default(),
    };
    let mut meas = rotorid::simulate::simulate(&model, &opts)?;
    rotorid::simulate::add_noise(&mut meas, 0.001, 1)?;
    let mut s = String::new();
    writeln!(
        s,
        "// The paper rotor's 1X responses at its bearings (b1_y, b1_z, b2_y, b2_z), \
         1000..12000 rpm, 0.1 % noise, f32;\n// written by `cargo run --example firmware_host -- --write-sweep`: do not edit."
    )?;
    writeln!(s, "/// (speed in rad/s, phasors in m) per measurement.")?;
    writeln!(
        s,
        "pub static SWEEP: [(f32, [rotorid_core::Complex<f32>; 4]); {}] = [",
        meas.samples.len()
    )?;
    for smp in &meas.samples {
        let q: Vec<String> = smp
            .q
            .iter()
            .map(|z| {
                format!(
                    "rotorid_core::Complex {{ re: {:?}, im: {:?} }}",
                    z.re as f32, z.im as f32
                )
            })
            .collect();
        writeln!(s, "    ({:?}, [{}]),", smp.omega as f32, q.join(", "))?;
    }
    writeln!(s, "];")?;
    std::fs::write(path, s)?;
    println!("wrote {path} ({} measurements)", meas.samples.len());
    Ok(())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, path] = args.as_slice() {
        if flag == "--write-sweep" {
            if let Err(e) = write_sweep(path) {
                eprintln!("error: {e}");
                std::process::exit(2);
            }
            return;
        }
    }
    let mut out = String::new();
    let result = match args.as_slice() {
        [] => run::tracker()
            .map_err(run::RunError::from)
            .and_then(|t| Ok((t, run::identifier()?)))
            .and_then(|(t, id)| {
                run::run(&mut out, &mut NoProbe, &mut Box::new(t), &mut Box::new(id))
            })
            .map_err(|e| e.to_string()),
        [flag] if flag == "--givens" => givens::run::tracker()
            .map_err(givens::run::RunError::from)
            .and_then(|t| Ok((t, givens::run::identifier()?)))
            .and_then(|(t, id)| {
                givens::run::run(&mut out, &mut NoProbe, &mut Box::new(t), &mut Box::new(id))
            })
            .map_err(|e| e.to_string()),
        _ => {
            eprintln!("usage: firmware_host [--givens | --write-sweep PATH]");
            std::process::exit(2);
        }
    };
    match result {
        Ok(_) => print!("{out}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    }
}
