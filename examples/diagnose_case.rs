//! One generated diagnosis case in full: the hidden effect, then the
//! diagnosis's text with its stages (as `rotorid diagnose` prints it). The
//! cases are those of the confusion matrices
//! (`rotorid::diagnose::generator`): 300 speeds up to RPM_MAX.
//!
//! ```sh
//! cargo run --release --example diagnose_case -- shaft_bow 3 draw
//! cargo run --release --example diagnose_case -- EFFECT [SEED [NOISE [MODEL [RPM_MAX [FLOOR_UM GRADE [FORM]]]]]]
//! # a case of the machine-form cases (form FilmTable, its seed 2_000_003 (k + 1) + n):
//! cargo run --release --example diagnose_case -- speed_dependent_bearing 6000012 0.005 paper 15000 0.5 6.3 FilmTable
//! # a case of the realistic confusion matrix (seed 1_000_003 (effect + 1) + k):
//! cargo run --release --example diagnose_case -- foundation_flexibility 3000010 0.005 paper 15000 0.5 6.3
//! ```
//!
//! EFFECT is an effect's name (`none`, `shaft_bow`, ...); SEED the case's
//! seed (0); NOISE a relative level (0.001) or `draw` for the generator's
//! own draw, as the confusion matrix does; MODEL `paper` or a model file;
//! RPM_MAX the top speed (15000); FLOOR_UM a probe noise floor (um, SPEC
//! section 7) added to the case, and GRADE a balance grade (mm/s) the
//! model's unbalance is scaled to, as the realistic confusion matrix does;
//! FORM one of `generator::Form` (`Bank`, `EOnly`, `Diameter`,
//! `FilmTable`, `PedestalMasses`, `TwoKnotBow`, `DistributedUnbalance`).

use rotorid::diagnose::generator::{generate_form, Form};
use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let effect = match arg(0) {
        Some(name) => Effect::from_name(name).ok_or(format!("no effect named {name}"))?,
        None => Effect::None,
    };
    let seed: u64 = arg(1).map_or(Ok(0), str::parse)?;
    let noise = match arg(2) {
        Some("draw") => None,
        Some(s) => Some(s.parse()?),
        None => Some(0.001),
    };
    // A model without unbalance (a ROSS file) gets one at each plane, as
    // the realistic confusion matrices give it, before the scaling to GRADE.
    let model = rotorid::diagnose::generator::with_plane_unbalance(
        rotorid::io::model_file::model_file_by_name_or_path(arg(3).unwrap_or("paper"))?.model,
    );
    let rpm_max: f64 = arg(4).map_or(Ok(15000.0), str::parse)?;
    let floor: f64 = arg(5).map_or(Ok(0.0), str::parse)? * 1e-6;
    let model = match arg(6) {
        Some(g) => rotorid::simulate::at_balance_grade(
            &model,
            g.parse()?,
            rotorid::units::rpm_to_rad_s(rpm_max),
        )
        .ok_or("the model has no unbalance to scale")?,
        None => model,
    };
    let speeds: Vec<f64> = (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect();

    let form = match arg(7) {
        None => Form::Bank,
        Some(name) => [Form::Bank]
            .into_iter()
            .chain(Form::MACHINE.map(|(_, f)| f))
            .find(|f| format!("{f:?}") == name)
            .ok_or(format!("no form named {name}"))?,
    };
    let mut case = generate_form(&model, effect, form, seed, &speeds, noise)?;
    rotorid::simulate::add_floor_noise(&mut case.meas, floor, seed)?;
    let d = diagnose(&model, &case.meas, &DiagnoseOptions::default())?;
    println!("hidden {} (noise {})", case.hidden.description, case.noise);
    let nominal = rotorid::diagnose::predictions(&model, &d, &d.nominal)?;
    println!(
        "{}",
        rotorid::report::diagnose::text(&d, &case.meas.samples, &nominal)
    );
    // Every form of the stiffness hypothesis fitted, with its misfit
    // above the best in noise variances.
    if let Some(c) = d
        .hypotheses
        .iter()
        .find(|c| c.effects == [rotorid::diagnose::Effect::ShaftStiffnessError])
    {
        let best = c
            .stiffness_forms
            .iter()
            .map(|f| f.s)
            .fold(f64::INFINITY, f64::min);
        println!("stiffness forms fitted (S above the best, in noise variances):");
        for f in &c.stiffness_forms {
            println!(
                "  {} x {:.4} +- {:.4}: {:.1}",
                f.form.describe(),
                f.factor,
                f.factor_std,
                (f.s - best) / d.sigma2
            );
        }
    }
    Ok(())
}
