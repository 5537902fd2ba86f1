//! The table-building workload of `cargo bench --bench tables`, one form a
//! run, for instruction counts: the paper rotor reduced to its bearings at
//! 1000 speeds from 15 to 15000 rpm, in modal form (`Reducer::modal`, what
//! `rotorid tables` uses), by a banded LU per speed (`Reducer::reduce`) or
//! by a dense LU per speed (`DenseReducer`).
//!
//! ```sh
//! cargo build --profile test --example reduction_workload
//! valgrind --tool=callgrind target/debug/examples/reduction_workload modal|banded|dense
//! ```

use rotorid::fe::assembly::FeModel;
use rotorid::model::RotorModel;
use rotorid::reduce::{DenseReducer, Reducer};
use rotorid::tables::grid::linspace;
use rotorid::units::rpm_to_rad_s;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let kind = std::env::args().nth(1).unwrap_or_else(|| "modal".into());
    let model = RotorModel::paper();
    let fe = FeModel::new(&model)?;
    let speeds = linspace(rpm_to_rad_s(15.0), rpm_to_rad_s(15000.0), 1000);
    let mut acc = 0.0;
    match kind.as_str() {
        "modal" => {
            let r = Reducer::new(&fe, &model)?.modal()?;
            for &w in &speeds {
                acc += r.reduce(w)?.a.norm();
            }
        }
        "banded" => {
            let r = Reducer::new(&fe, &model)?;
            for &w in &speeds {
                acc += r.reduce(w)?.a.norm();
            }
        }
        "dense" => {
            let r = DenseReducer::new(&fe, &model)?;
            for &w in &speeds {
                acc += r.reduce(w)?.a.norm();
            }
        }
        other => return Err(format!("no form {other}: modal, banded or dense").into()),
    }
    println!("{kind}: {} speeds, sum of |A|_F {acc:.6e}", speeds.len());
    Ok(())
}
