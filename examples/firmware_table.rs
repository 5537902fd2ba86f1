//! Plays firmware: reads a bearing-level model table blob with nothing but
//! `rotorid_core` types (no heap in the lookup and identification path, no
//! FE model), prints `A` and `B` at a speed, then identifies the bearings
//! and the unbalance from a sweep with the identifier the blob sets up.
//!
//! ```sh
//! cargo run --release -- tables --model paper --out paper.tbl
//! cargo run --release --example firmware_table -- paper.tbl 6000 [sweep.csv]
//! ```
//!
//! Without a file argument the desktop side first builds the paper rotor's
//! table in memory (50..15000 rpm, step 50); without a measurement CSV it
//! simulates the paper rotor's sweep (50..15000 rpm, step 50, noise-free).
//! The example is compiled for 2 bearings (`NQ = 4` channels) and 3 planes,
//! as the paper rotor, and for the structures `physical` 1 and `paper` 1;
//! f32 and f64 blobs are both accepted.
//!
//! The identifier's type comes from the four numbers of the blob's header
//! that must be known at compile time (scalar type, structure, bearings,
//! planes), the rest of the set-up from the blob (structure and column
//! scaling):
//!
//! ```text
//! mod table {
//!     rotorid_core::identifier_types!(f32, physical(1), bearings: 2, planes: 3);
//! }
//! let view = TableView::<f32>::parse(blob)?;
//! let mut id = table::Id::from_table(&view)?;
//! id.update(&view, omega, &q)?;
//! let est = id.estimates(omega)?;
//! ```
//!
//! (With a generated Rust source instead of a blob, `include!` it: it
//! defines the same items and the data; see `rotorid_core::identify`.)

use rotorid::io::measurement::Sample;
use rotorid_core::factor::Factor;
use rotorid_core::identify::{IdField, Identifier};
use rotorid_core::table::{BearingTable, TableScalar, TableView, Terms};
use rotorid_core::Complex;

/// The identifier of a `physical` 1 blob for 2 bearings and 3 planes
/// (`Id<T>` for f32 and f64 blobs alike).
mod physical {
    rotorid_core::identifier_types!(<T>, physical(1), bearings: 2, planes: 3);
}

/// The same for a `paper` 1 blob.
mod paper {
    rotorid_core::identifier_types!(<T>, paper(1), bearings: 2, planes: 3);
}

const NQ: usize = physical::NQ;
const NP: usize = physical::NP;

type Error = Box<dyn std::error::Error>;

/// The firmware part: validate the blob, look up the terms, print them,
/// identify from the sweep.
fn firmware<T: TableScalar + IdField<T>>(
    blob: &[u8],
    rpm: f64,
    sweep: &[Sample],
) -> Result<(), Error> {
    let view = TableView::<T>::parse(blob)?;
    let (lo, hi) = BearingTable::<T, NQ, NP>::speed_range(&view);
    let sc = view.scaling();
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
    println!(
        "written for {:?} order {}, column scaling {:.4e} N/m, {:.4} rad/s, {:.4e} kg m",
        view.structure().formulation,
        view.structure().order,
        sc.stiffness.to_f64(),
        sc.omega_ref.to_f64(),
        sc.unbalance.to_f64(),
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
    // The identifier type is fixed at compile time; the blob names the
    // structure it was written for.
    match view.structure() {
        s if s == physical::STRUCTURE => {
            identify(physical::Id::<T>::from_table(&view)?, &view, sweep)
        }
        s if s == paper::STRUCTURE => identify(paper::Id::<T>::from_table(&view)?, &view, sweep),
        s => {
            println!("(this example is compiled for physical 1 and paper 1, not {s:?}: no identification)");
            Ok(())
        }
    }
}

/// Runs the sweep through the identifier and prints the estimates.
fn identify<T: TableScalar, F: IdField<T>, const M: usize, const N: usize, R: Factor<F>>(
    mut id: Identifier<T, F, NQ, NP, M, N, R>,
    view: &TableView<'_, T>,
    sweep: &[Sample],
) -> Result<(), Error> {
    let (mut used, mut last) = (0usize, T::zero());
    for s in sweep.iter().filter(|s| s.q.len() == NQ) {
        let omega = T::lit(s.omega);
        let q: [Complex<T>; NQ] =
            core::array::from_fn(|j| Complex::new(T::lit(s.q[j].re), T::lit(s.q[j].im)));
        // Speeds outside the table's grid (or on a pole) are skipped.
        if id.update(view, omega, &q).is_ok() {
            used += 1;
            last = omega;
        }
    }
    let est = id.estimates(last)?;
    println!(
        "identified from {used} of {} samples ({:?} order {}), at {:.1} rad/s:",
        sweep.len(),
        id.config().structure.formulation,
        id.config().structure.order,
        last.to_f64()
    );
    for (m, b) in est.bearings.iter().enumerate() {
        let k: Vec<String> = b.k.iter().map(|x| format!("{:.4e}", x.to_f64())).collect();
        let c: Vec<String> = b.c.iter().map(|x| format!("{:.2}", x.to_f64())).collect();
        println!(
            "  bearing {}: K = [{}] N/m, C = [{}] N s/m",
            m + 1,
            k.join(", "),
            c.join(", ")
        );
    }
    for (k, u) in est.unbalance.iter().enumerate() {
        println!(
            "  plane {}: m e = {:.4e} kg m, phase {:.2} deg",
            k + 1,
            u.me.to_f64(),
            u.phase_deg().to_f64()
        );
    }
    Ok(())
}

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next();
    let rpm: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(6000.0);
    let csv = args.next();
    let model = rotorid::model::RotorModel::paper();
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
            rotorid::tables::build(&model, &speeds)
                .and_then(|t| t.to_blob(rotorid::tables::Scalar::F64))
                .expect("paper table")
        }
    };
    let sweep = match &csv {
        Some(p) => match rotorid::io::measurement::read_csv(p) {
            Ok(m) => m.samples,
            Err(e) => {
                eprintln!("{p}: {e}");
                std::process::exit(2);
            }
        },
        None => {
            let opts = rotorid::simulate::SimOptions {
                speeds_rpm: (1..=300).map(|i| 50.0 * i as f64).collect(),
                noise: 0.0,
                seed: 0,
                effects: Default::default(),
            };
            rotorid::simulate::simulate(&model, &opts)
                .expect("paper sweep")
                .samples
        }
    };
    // Byte 10 of the header is the scalar type (4 = f32, 8 = f64).
    let result = match blob.get(10) {
        Some(&4) => firmware::<f32>(&blob, rpm, &sweep),
        _ => firmware::<f64>(&blob, rpm, &sweep),
    };
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}
