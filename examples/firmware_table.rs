//! Plays firmware: reads a bearing-level model table blob with nothing but
//! `rotorid_core` types (no heap in the lookup path, no FE model) and prints
//! `A` and `B` at a speed.
//!
//! ```sh
//! cargo run --release -- tables --model paper --out paper.tbl
//! cargo run --release --example firmware_table -- paper.tbl 6000
//! ```
//!
//! Without a file argument the desktop side first builds the paper rotor's
//! table in memory (50..15000 rpm, step 50), then the firmware part reads it.
//! The example is compiled for 2 bearings (`NQ = 4` channels) and 3 planes,
//! as the paper rotor; f32 and f64 blobs are both accepted.

use rotorid_core::table::{BearingTable, TableError, TableScalar, TableView, Terms};

const NQ: usize = 4;
const NP: usize = 3;

/// The firmware part: validate the blob, look up the terms, print them.
fn firmware<T: TableScalar>(blob: &[u8], rpm: f64) -> Result<(), TableError> {
    let view = TableView::<T>::parse(blob)?;
    let (lo, hi) = BearingTable::<T, NQ, NP>::speed_range(&view);
    println!(
        "table: {} bearings at nodes {:?}, {} planes at nodes {:?}, {} speeds {:.2}..{:.2} rad/s, {} poles of A, {} of B",
        view.n_bearings(),
        (0..view.n_bearings()).filter_map(|i| view.bearing_node(i)).collect::<Vec<_>>(),
        view.n_planes(),
        (0..view.n_planes()).filter_map(|i| view.plane_node(i)).collect::<Vec<_>>(),
        view.n_speeds(),
        lo.to_f64(),
        hi.to_f64(),
        view.n_poles_a(),
        view.n_poles_b(),
    );
    let omega = T::lit(rpm * core::f64::consts::PI / 30.0);
    let t: Terms<T, NQ, NP> = view.terms(omega)?;
    println!("A at {rpm} rpm ({:.4} rad/s), N/m:", omega.to_f64());
    for row in &t.a {
        for z in row {
            print!("  {:>12.5e} {:+12.5e}j", z.re.to_f64(), z.im.to_f64());
        }
        println!();
    }
    println!("B at {rpm} rpm, N/(kg m):");
    for row in &t.b {
        for z in row {
            print!("  {:>12.5e} {:+12.5e}j", z.re.to_f64(), z.im.to_f64());
        }
        println!();
    }
    Ok(())
}

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next();
    let rpm: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(6000.0);
    let blob = match &path {
        Some(p) => match std::fs::read(p) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("cannot read {p}: {e}");
                std::process::exit(2);
            }
        },
        None => {
            // Desktop side, only to make the example self-contained.
            let speeds = rotorid::tables::grid::uniform_rad_s(50.0, 15000.0, 50.0).expect("grid");
            rotorid::tables::build(&rotorid::model::RotorModel::paper(), &speeds)
                .and_then(|t| t.to_blob(rotorid::tables::Scalar::F64))
                .expect("paper table")
        }
    };
    // Byte 10 of the header is the scalar type (4 = f32, 8 = f64).
    let result = match blob.get(10) {
        Some(&4) => firmware::<f32>(&blob, rpm),
        _ => firmware::<f64>(&blob, rpm),
    };
    if let Err(e) = result {
        eprintln!("table error: {e}");
        std::process::exit(2);
    }
}
