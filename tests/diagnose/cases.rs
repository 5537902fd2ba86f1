//! Generated hidden-effect cases (`rotorid::diagnose::generator`): the test
//! does not tell `diagnose` what was hidden, then checks the name, the gain,
//! the identified size and the bearings against the answer key.
//!
//! Observability criterion (stated in the README): an effect that vanishes
//! at zero size (bow, extra plane, runout) is observable in a case when its
//! hidden size is at least twice the smallest detectable size computed by
//! `Diagnosis::min_detectable` at its node or channel (a bow of two
//! knots: when the smallest detectable multiple of its own shape,
//! `Diagnosis::min_detectable_bow`, is at most one half); the pedestal,
//! modulus and speed-law effects are drawn in ranges where they always are
//! (their resonance or critical-speed shift lies in the speed range). The
//! gain requirement applies where the effect is plainly visible at the
//! probes: a nominal misfit of at least 10x the noise.

use std::collections::BTreeMap;

use rotorid::diagnose::extended::Extension;
use rotorid::diagnose::generator::{generate, generate_form, Case, Form, Hidden};
use rotorid::diagnose::terms::StiffnessForm;
use rotorid::diagnose::{
    chi2_quantile_upper, diagnose, estimates, DiagnoseOptions, Diagnosis, Effect, Finding, FormFit,
};
use rotorid::io::measurement::Measurements;
use rotorid::model::RotorModel;
use rotorid::units::rpm_to_rad_s;

fn speeds() -> Vec<f64> {
    (1..=300).map(|i| 50.0 * i as f64).collect()
}

/// What a case showed.
pub(super) struct Outcome {
    pub(super) named: Effect,
    /// The named effect explains the data as well as the hidden one, and
    /// the observability analysis says so.
    pub(super) equivalent: bool,
    pub(super) observable: bool,
    visible: bool,
    gain: f64,
    /// (identified, hidden, std) of the main size, when comparable.
    pub(super) size: Option<(f64, f64, f64)>,
    /// RMS relative error of the bearing K and C of the extended and of
    /// the nominal model against the truth (generated cases, whose truth
    /// is a rotorid model).
    bearing_error: Option<(f64, f64)>,
}

fn bearing_error(d: &Diagnosis, case: &Case, c: &rotorid::diagnose::Candidate) -> f64 {
    let (b, _) = estimates(c, d.omega_report);
    let mut s = 0.0;
    let mut n = 0.0;
    for (i, br) in b.iter().enumerate() {
        let t = case.truth.bearings[i].law.at(d.omega_report);
        let k = [br.k.yy, br.k.yz, br.k.zy, br.k.zz];
        let cc = [br.c.yy, br.c.yz, br.c.zy, br.c.zz];
        for e in [0, 3] {
            s += ((k[e] - t.k[e]) / t.k[e]).powi(2) + ((cc[e] - t.c[e]) / t.c[e]).powi(2);
            n += 2.0;
        }
    }
    (s / n).sqrt()
}

fn run_case(
    m: &RotorModel,
    sp: &[f64],
    effect: Effect,
    seed: u64,
    noise: Option<f64>,
) -> (Case, Diagnosis, Outcome) {
    run_case_with_floor(m, sp, effect, seed, noise, 0.0)
}

/// [`run_case`] with a probe noise floor `floor` (m) added to the
/// generated data (SPEC section 7).
fn run_case_with_floor(
    m: &RotorModel,
    sp: &[f64],
    effect: Effect,
    seed: u64,
    noise: Option<f64>,
    floor: f64,
) -> (Case, Diagnosis, Outcome) {
    run_case_form(m, sp, effect, Form::Bank, seed, noise, floor)
}

/// [`run_case_with_floor`] with the effect in the form `form`.
fn run_case_form(
    m: &RotorModel,
    sp: &[f64],
    effect: Effect,
    form: Form,
    seed: u64,
    noise: Option<f64>,
    floor: f64,
) -> (Case, Diagnosis, Outcome) {
    let mut case = generate_form(m, effect, form, seed, sp, noise).unwrap();
    rotorid::simulate::add_floor_noise(&mut case.meas, floor, seed).unwrap();
    let d = diagnose(m, &case.meas, &DiagnoseOptions::default()).unwrap();
    let mut out = judge(&case.meas, &case.hidden, &d);
    if case.hidden.bow.len() > 1 {
        // A bow of two knots: observable when twice the smallest
        // detectable multiple of its own shape (module docs).
        out.observable = d
            .min_detectable_bow(m, &case.meas, &case.hidden.bow)
            .is_some_and(|c| c <= 0.5);
    }
    out.bearing_error = Some((
        bearing_error(&d, &case, d.extended()),
        bearing_error(&d, &case, &d.nominal),
    ));
    (case, d, out)
}

/// What the diagnosis `d` of `meas` showed against the answer `h`: the
/// name, whether the hidden effect was observable (the criterion of the
/// module docs), whether it was plainly visible, the gain and the
/// identified main size (no bearing error: see [`run_case_form`]).
pub(super) fn judge(meas: &Measurements, h: &Hidden, d: &Diagnosis) -> Outcome {
    let effect = h.effect;
    let observable = match effect {
        Effect::ShaftBow => {
            let node = h.node.unwrap();
            d.min_detectable(meas, Extension::Bow { node, line: false })
                .is_some_and(|s| h.size >= 2.0 * s)
        }
        Effect::ExtraUnbalancePlane => {
            let node = h.node.unwrap();
            d.min_detectable(meas, Extension::Plane { node })
                .is_some_and(|s| h.size >= 2.0 * s)
        }
        Effect::ProbeSensitivity => {
            let channel = h.channel.unwrap();
            d.min_detectable(meas, Extension::Gain { channel })
                .is_some_and(|s| (h.size - 1.0).abs() >= 2.0 * s)
        }
        _ => true,
    };
    let visible = effect != Effect::None
        && d.noise_level
            .is_some_and(|s| d.residual_nominal() >= 10.0 * s);
    let findings = d.findings();
    let size = findings.iter().find_map(|f| match (f, effect) {
        (
            Finding::ShaftBow {
                node,
                amplitude,
                amplitude_std,
                ..
            },
            Effect::ShaftBow,
        ) if Some(*node - 1) == h.node => Some((*amplitude, h.size, *amplitude_std)),
        (
            Finding::ExtraUnbalancePlane {
                node, me, me_std, ..
            },
            Effect::ExtraUnbalancePlane,
        ) if Some(*node - 1) == h.node => Some((*me, h.size, *me_std)),
        (Finding::ProbeRunout { channels }, Effect::ProbeRunout) => {
            let (ch, z) = h.runout[0];
            let c = &channels[ch];
            Some((c.amplitude, z.norm(), c.amplitude_std))
        }
        (
            Finding::ShaftStiffnessError {
                factor, factor_std, ..
            },
            Effect::ShaftStiffnessError,
        ) => {
            // The factor of the hidden form when it is the form found or
            // one the data cannot tell from it; else the form found's.
            let own = FormFit {
                form: d.extended().stiffness,
                factor: *factor,
                factor_std: *factor_std,
                s: 0.0,
            };
            let pick = h
                .stiffness
                .and_then(|want| {
                    std::iter::once(own)
                        .chain(d.stiffness_alike())
                        .find(|f| same_form(f.form, want))
                })
                .unwrap_or(own);
            Some((pick.factor - 1.0, h.size - 1.0, pick.factor_std))
        }
        (
            Finding::ProbeSensitivity {
                channel,
                gain,
                gain_std,
            },
            Effect::ProbeSensitivity,
        ) => {
            // The hidden channel, or its pair's other channel at 1 / g
            // (`diagnose::sensitivity`).
            let ch = h.channel.unwrap();
            let name = |c: usize| rotorid::model::extension::Channel::of_index(c).to_string();
            if *channel == name(ch) {
                Some((*gain - 1.0, h.size - 1.0, *gain_std))
            } else if *channel == name(ch ^ 1) {
                Some((1.0 / *gain - 1.0, h.size - 1.0, *gain_std / (gain * gain)))
            } else {
                None
            }
        }
        (
            Finding::FoundationFlexibility {
                natural_frequency_hz,
                natural_frequency_hz_std,
                ..
            },
            Effect::FoundationFlexibility,
        ) => Some((
            natural_frequency_hz[0],
            h.size / std::f64::consts::TAU,
            natural_frequency_hz_std[0],
        )),
        _ => None,
    });
    let equivalent = d
        .observability
        .iter()
        .any(|ob| ob.effect == effect && ob.indistinguishable_from.contains(&d.effect));
    Outcome {
        named: d.effect,
        equivalent,
        observable,
        visible,
        gain: d.residual_nominal() / d.residual_extended(),
        size,
        bearing_error: None,
    }
}

/// Whether the stiffness form `found` is the hidden `want`: the same form,
/// or a section that shares at least half of the shorter of the two with
/// the hidden one (the bank's sections run between the drawing's
/// features, a hidden one anywhere; with probes at the bearings the data
/// place a change of diameter only roughly along the shaft).
fn same_form(found: StiffnessForm, want: StiffnessForm) -> bool {
    match (found, want) {
        (
            StiffnessForm::Section { first: a, last: b },
            StiffnessForm::Section { first: c, last: e },
        ) => {
            let overlap = (b.min(e) + 1).saturating_sub(a.max(c));
            2 * overlap > (b - a).min(e - c)
        }
        (x, y) => x == y,
    }
}

/// Whether the diagnosis `d` named the variant of the hidden `form` (the
/// forms the bank has a variant for exactly: E and G, E alone, a
/// section's diameter, a pedestal with its masses apart, a bow of two
/// knots), among the forms the data cannot tell apart for a stiffness
/// error; `None` for the forms the bank only approximates (a film table,
/// a distributed unbalance: the report names the variant nearest) and
/// for the other bank forms.
pub(super) fn variant_named(form: Form, h: &Hidden, d: &Diagnosis) -> Option<bool> {
    let c = d.extended();
    match form {
        Form::Bank | Form::EOnly | Form::Diameter if h.effect == Effect::ShaftStiffnessError => {
            let want = h.stiffness?;
            Some(
                c.effects.contains(&Effect::ShaftStiffnessError)
                    && std::iter::once(c.stiffness)
                        .chain(d.stiffness_alike().iter().map(|f| f.form))
                        .any(|f| same_form(f, want)),
            )
        }
        Form::PedestalMasses => Some(
            c.model
                .ext
                .iter()
                .any(|e| matches!(e, Extension::Pedestal { split: true, .. })),
        ),
        Form::TwoKnotBow => Some(
            c.model
                .ext
                .iter()
                .filter(|e| matches!(e, Extension::Bow { .. }))
                .count()
                == 2,
        ),
        _ => None,
    }
}

/// `n` cases of `effect` at 0.1 % noise, all named right where observable,
/// with the gain, size and bearing checks.
fn check_effect(effect: Effect, n: u64) {
    check_effect_on(&RotorModel::paper(), &speeds(), effect, n);
}

fn check_effect_on(m: &RotorModel, sp: &[f64], effect: Effect, n: u64) {
    for seed in 0..n {
        let seed = 7919 * (effect as u64 + 1) + seed;
        let (case, d, o) = run_case(m, sp, effect, seed, Some(0.001));
        let bearings = o.bearing_error.expect("a generated case has its truth");
        let what = format!(
            "seed {seed}: hidden {} -> {} (nominal {:.2e}, extended {:.2e}, gain {:.1}, size {:?}, bearings {:.2e}/{:.2e})",
            case.hidden.description,
            o.named.name(),
            d.residual_nominal(),
            d.residual_extended(),
            o.gain,
            o.size,
            bearings.0,
            bearings.1
        );
        println!("{what}");
        // Another effect that explains the data equally well is a right
        // answer when the observability analysis says the two cannot be
        // told apart.
        let equivalent = o.equivalent;
        if !o.observable {
            assert!(
                matches!(o.named, Effect::None | Effect::Unexplained)
                    || o.named == effect
                    || equivalent,
                "{what}"
            );
            continue;
        }
        if o.named != effect && equivalent {
            println!("    (explains the data as well: accepted with the observability note)");
            continue;
        }
        assert_eq!(o.named, effect, "{what}");
        if o.visible {
            assert!(o.gain >= 10.0, "{what}");
            assert!(bearings.0 < bearings.1, "{what}");
        }
        // The extended model fits to the noise.
        if let Some(s) = d.noise_level {
            assert!(d.residual_extended() < 1.2 * s, "{what}");
        }
        if let Some((got, want, std)) = o.size {
            assert!((got - want).abs() <= 0.05 * want.abs(), "size: {what}");
            assert!((got - want).abs() <= 3.5 * std, "size vs std: {what}");
        }
    }
}

#[test]
fn none_is_not_named() {
    check_effect(Effect::None, 5);
}

#[test]
fn speed_dependent_bearing_is_named() {
    check_effect(Effect::SpeedDependentBearing, 5);
}

#[test]
fn foundation_flexibility_is_named() {
    check_effect(Effect::FoundationFlexibility, 5);
}

#[test]
fn shaft_bow_is_named() {
    check_effect(Effect::ShaftBow, 5);
}

#[test]
fn probe_runout_is_named() {
    check_effect(Effect::ProbeRunout, 5);
}

#[test]
fn extra_unbalance_plane_is_named() {
    check_effect(Effect::ExtraUnbalancePlane, 5);
}

#[test]
fn shaft_stiffness_error_is_named() {
    check_effect(Effect::ShaftStiffnessError, 5);
}

#[test]
fn probe_sensitivity_is_named() {
    check_effect(Effect::ProbeSensitivity, 5);
}

/// The second rotor: ROSS's stepped hollow shaft on two bearings (saved by
/// ROSS 3.1, `tests/data/ross/stepped_hollow.toml`; two disks, 24
/// elements, critical speeds 2878 and 9224 rpm), 300 speeds up to 11000
/// rpm, one case per effect.
#[test]
fn second_rotor_every_effect() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ross/stepped_hollow.toml");
    let m = rotorid::io::model_file::model_file_by_name_or_path(path.to_str().unwrap())
        .unwrap()
        .model;
    let sp: Vec<f64> = (1..=300).map(|i| 11000.0 * i as f64 / 300.0).collect();
    for effect in std::iter::once(Effect::None).chain(Effect::BANK) {
        check_effect_on(&m, &sp, effect, 1);
    }
}

/// The confusion matrix over 50 cases per effect (and `none`), noise drawn
/// in 0.1-1 %: printed for the README, with the accuracy bounds asserted.
#[test]
#[ignore]
fn confusion_matrix() {
    confusion(&RotorModel::paper(), &speeds(), None, 0.0);
}

/// The confusion matrix on data as machines give them: the paper rotor at
/// balance grade G6.3 (the generator draws each plane's unbalance around
/// it), 0.5 % relative noise plus a 0.5 um probe floor.
#[test]
#[ignore]
fn realistic_confusion_matrix() {
    let m = rotorid::simulate::at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0))
        .unwrap();
    confusion(&m, &speeds(), Some(0.005), 5e-7);
}

/// A rotor of the repository's data at G6.3 at its top speed `rpm_max`,
/// with 300 speeds up to it (the grids of the ROSS-made set). A model
/// without unbalance (a ROSS file) gets one at each plane, `1e-4` and
/// `0.6e-4` kg m in turn at 0.4 and 2.1 rad, before the scaling.
fn data_rotor(rel: &str, rpm_max: f64) -> (RotorModel, Vec<f64>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    let m = rotorid::diagnose::generator::with_plane_unbalance(
        rotorid::io::model_file::model_file_by_name_or_path(path.to_str().unwrap())
            .unwrap()
            .model,
    );
    let m = rotorid::simulate::at_balance_grade(&m, 6.3, rpm_to_rad_s(rpm_max)).unwrap();
    let sp = (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect();
    (m, sp)
}

/// [`realistic_confusion_matrix`] on the second rotor: ROSS's stepped
/// hollow shaft with its overhung disks (two bearings, critical speeds
/// 2878 and 9224 rpm), 40..12000 rpm.
#[test]
#[ignore = "350 diagnoses: cargo test --release --test lib diagnose::cases::realistic_confusion_matrix_stepped_hollow -- --ignored --nocapture"]
fn realistic_confusion_matrix_stepped_hollow() {
    let (m, sp) = data_rotor("tests/data/ross/stepped_hollow.toml", 12000.0);
    confusion(&m, &sp, Some(0.005), 5e-7);
}

/// On the stepped hollow shaft (outer diameters three times the inner),
/// the shaft stiffness hypothesis's rounds on a section of runout data ran
/// its factor down to 0.26, an outer diameter below the inner one, and the
/// diagnosis failed as a whole: the rounds now end at their last fit
/// there (the case of the matrix that found it, named right).
#[test]
fn a_section_too_thin_for_a_round_ends_the_rounds() {
    let (m, sp) = data_rotor("tests/data/ross/stepped_hollow.toml", 12000.0);
    let effect = Effect::ProbeRunout;
    let (_, d, o) = run_case_with_floor(
        &m,
        &sp,
        effect,
        1_000_003 * (effect as u64 + 1) + 23,
        Some(0.005),
        5e-7,
    );
    assert_eq!(o.named, effect, "{}", d.extended().label);
}

/// A material whose Young's modulus alone is off (realistic data on the
/// paper rotor: G6.3, 0.5 % + 0.5 um probe floor; `machine_forms`' case
/// `2000010`, E x 0.9065, G kept) is named `shaft_stiffness_error`; E
/// alone is the form found or one the report lists as alike; the forms
/// listed are exactly those fitted whose misfit lies within
/// `chi2_{2, 0.01} sigma^2` of the found form's (recomputed here from
/// every form's `S`); the factor of E alone is within 5 % and 3.5
/// reported standard deviations of the hidden one; and the text report
/// names the forms alike.
#[test]
fn a_modulus_error_names_the_forms_the_data_cannot_tell_apart() {
    let m = rotorid::simulate::at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0))
        .unwrap();
    let (case, d, o) = run_case_form(
        &m,
        &speeds(),
        Effect::ShaftStiffnessError,
        Form::EOnly,
        2_000_010,
        Some(0.005),
        5e-7,
    );
    println!("{} -> {}", case.hidden.description, d.extended().label);
    assert_eq!(d.effect, Effect::ShaftStiffnessError);
    assert_eq!(variant_named(Form::EOnly, &case.hidden, &d), Some(true));
    let c = d.extended();
    let own = c
        .stiffness_forms
        .iter()
        .find(|f| f.form == c.stiffness)
        .expect("the found form among those fitted");
    let tie = rotorid::diagnose::chi2_quantile_upper(2.0, 0.01) * d.sigma2;
    let mut want: Vec<StiffnessForm> = c
        .stiffness_forms
        .iter()
        .filter(|f| f.form != c.stiffness && (f.s - own.s).abs() < tie)
        .map(|f| f.form)
        .collect();
    let mut got: Vec<StiffnessForm> = d.stiffness_alike().iter().map(|f| f.form).collect();
    // (`examples/diagnose_case` prints every form's factor and misfit.)
    let key = |f: &StiffnessForm| f.describe();
    want.sort_by_key(key);
    got.sort_by_key(key);
    assert_eq!(got, want);
    // Every form fitted is no better than the one found.
    assert!(c.stiffness_forms.iter().all(|f| f.s >= own.s));
    assert_sized(&o);
    let nominal = rotorid::diagnose::predictions(&m, &d, &d.nominal).unwrap();
    let text = rotorid::report::diagnose::text(&d, &case.meas.samples, &nominal);
    if !d.stiffness_alike().is_empty() {
        assert!(text.contains("fitting as well within the noise"), "{text}");
    }
}

/// The identified size of `o` within 5 % and 3.5 reported standard
/// deviations of the hidden one.
fn assert_sized(o: &Outcome) {
    let (got, hidden, std) = o.size.expect("a size comparable with the hidden one");
    assert!(
        (got - hidden).abs() <= 0.05 * hidden.abs(),
        "{got} vs {hidden}"
    );
    assert!(
        (got - hidden).abs() <= 3.5 * std,
        "{got} +- {std} vs {hidden}"
    );
}

/// On the three-bearing rotor the reduced terms have poles in the speed
/// range (modes of the shaft with its bearing nodes held), and one moves
/// with the factor of E alone onto a measured speed near the hidden
/// factor (the three-bearing matrix's case `7000031`: E x 1.0868, G kept;
/// G6.3, 0.5 % + 0.5 um floor). A secant through that pole made the factor's
/// standard deviation 2e-10 and its misfit 8 noise variances lower than
/// the data allow. With the speeds at a pole left out of the step
/// (`terms::POLE_RATIO`), E alone is named with a deviation of the size of
/// that of E and G (the two forms differ by the shear deformation only),
/// the hidden factor within 5 % and 3.5 of it.
#[test]
fn a_pole_of_the_reduced_terms_leaves_the_factors_deviation_as_it_is() {
    let (m, sp) = data_rotor("tests/data/rotors/three_bearing.toml", 16500.0);
    let (case, d, o) = run_case_form(
        &m,
        &sp,
        Effect::ShaftStiffnessError,
        Form::EOnly,
        1_000_003 * (Effect::ShaftStiffnessError as u64 + 1) + 10,
        Some(0.005),
        5e-7,
    );
    println!("{} -> {}", case.hidden.description, d.extended().label);
    assert_eq!(d.effect, Effect::ShaftStiffnessError);
    let c = d.extended();
    let std_of = |form: StiffnessForm| {
        c.stiffness_forms
            .iter()
            .find(|f| f.form == form)
            .map(|f| f.factor_std)
            .expect("both global forms fitted")
    };
    let (alone, both) = (std_of(StiffnessForm::EAlone), std_of(StiffnessForm::EAndG));
    assert!(
        alone > 0.5 * both && alone < 2.0 * both,
        "{alone} vs {both}"
    );
    assert_sized(&o);
}

/// The smallest detectable multiple of a bow's own shape
/// (`Diagnosis::min_detectable_bow`), checked on realistic data of the
/// paper rotor (G6.3, 0.5 % + 0.5 um floor) against the one-knot size it
/// generalises: for one knot it is `min_detectable(node) / amplitude`
/// (worst phase, threshold of 2 parameters); a bow of two knots whose
/// second offset is the first knot's own shape there is that same bow,
/// its multiple larger by the square root of the ratio of the thresholds
/// of 4 and 2 parameters only; and the multiple of a pair of knots is
/// that of its worst common phase (the same for the pair turned as a
/// whole) and scales as one over the offsets.
#[test]
fn a_bows_detectable_multiple_generalises_the_one_knot_size() {
    let m = rotorid::simulate::at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0))
        .unwrap();
    let case = generate_form(
        &m,
        Effect::ShaftBow,
        Form::Bank,
        5_000_011,
        &speeds(),
        Some(0.005),
    )
    .unwrap();
    let mut meas = case.meas.clone();
    rotorid::simulate::add_floor_noise(&mut meas, 5e-7, 5_000_011).unwrap();
    let d = diagnose(&m, &meas, &DiagnoseOptions::default()).unwrap();
    let p = case.hidden.bow[0];
    let one = d
        .min_detectable(
            &meas,
            Extension::Bow {
                node: p.node,
                line: false,
            },
        )
        .unwrap();
    let c1 = d.min_detectable_bow(&m, &meas, &[p]).unwrap();
    assert!((c1 * p.amplitude / one - 1.0).abs() < 1e-9, "{c1} {one}");
    // The one-knot shape's offset at a node three away, as a second knot.
    let fe = rotorid::fe::assembly::FeModel::new(&m).unwrap();
    let shape = fe
        .bow_shape(&rotorid::model::ShaftBow { points: vec![p] })
        .unwrap();
    let other = if p.node + 3 < m.n_nodes() - 1 {
        p.node + 3
    } else {
        p.node - 3
    };
    let z = shape[fe.dof(other, rotorid::fe::assembly::Dir::Y)];
    let q = rotorid::model::BowPoint {
        node: other,
        amplitude: z.norm(),
        phase: z.arg(),
    };
    let c2 = d.min_detectable_bow(&m, &meas, &[p, q]).unwrap();
    let alternatives: usize = d
        .hypotheses
        .iter()
        .filter(|c| c.effects.len() == 1)
        .map(|c| c.alternatives)
        .sum::<usize>()
        .max(1);
    let a = d.false_alarm / alternatives as f64;
    let ratio = (chi2_quantile_upper(4.0, a) / chi2_quantile_upper(2.0, a)).sqrt();
    assert!((c2 / c1 / ratio - 1.0).abs() < 1e-6, "{c2} {c1} {ratio}");
    // Two knots of one sign and similar size three nodes apart: the
    // multiple is that of the worst common phase, so turning both
    // phasors together leaves it as it is, and it scales as one over the
    // offsets.
    let pair = |turn: f64, k: f64| {
        let at = |node: usize, amplitude: f64, phase: f64| rotorid::model::BowPoint {
            node,
            amplitude: k * amplitude,
            phase: phase + turn,
        };
        let knots = [
            at(p.node, p.amplitude, p.phase),
            at(other, 0.8 * p.amplitude, p.phase + 0.1),
        ];
        d.min_detectable_bow(&m, &meas, &knots).unwrap()
    };
    let c3 = pair(0.0, 1.0);
    for turn in [0.7, 2.0, -2.9] {
        let c = pair(turn, 1.0);
        assert!(
            (c / c3 - 1.0).abs() < 1e-9,
            "turned {turn}: {c} against {c3}"
        );
    }
    assert!((pair(0.0, 2.0) * 2.0 / c3 - 1.0).abs() < 1e-9);
    println!("one knot {c1:.3}, the same bow as two knots {c2:.3}, two knots of one sign {c3:.3}");
}

/// A bow of two knots (realistic data: G6.3, 0.5 % + 0.5 um probe floor)
/// is explained by the two-knot variant of `shaft_bow`: named, or (on two
/// bearings at the shaft ends, where at the bearing probes a bow that is
/// zero at the bearings acts as an unbalance distribution) tied with two
/// extra planes and reported indistinguishable from them. On the stepped
/// hollow shaft the bow hypothesis finds both knots with their offsets
/// within 5 % and 3.5 reported standard deviations (the offsets at the
/// knots, converted from the two one-knot amplitudes through
/// `Candidate::bow_coupling`). Before the variant the stepped case was
/// named `extra_unbalance_plane`, one knot's bow fitting worse.
#[test]
fn a_two_knot_bow_is_found_at_both_knots() {
    let effect = Effect::ShaftBow;
    // (rotor, top speed, seed of the realistic matrix's cases).
    for (rel, rpm, seed, knots_checked) in [
        (
            "tests/data/ross/stepped_hollow.toml",
            12000.0,
            4_000_013,
            true,
        ),
        (
            "tests/data/rotors/three_bearing.toml",
            16500.0,
            4_000_013,
            false,
        ),
    ] {
        let (m, sp) = data_rotor(rel, rpm);
        let (case, d, o) =
            run_case_form(&m, &sp, effect, Form::TwoKnotBow, seed, Some(0.005), 5e-7);
        assert_eq!(case.effects.bow.len(), 2);
        assert!(
            o.named == effect || o.equivalent,
            "{rel}: {}",
            d.extended().label
        );
        let bow = d
            .hypotheses
            .iter()
            .find(|c| c.effects == [effect])
            .expect("a bow hypothesis");
        assert_eq!(bow.model.ext.len(), 2, "{}", bow.label);
        if !knots_checked {
            continue;
        }
        let found: Vec<(usize, f64, f64, f64)> =
            rotorid::diagnose::findings(bow, &d.terms, &d.probe_nodes)
                .iter()
                .filter_map(|f| match f {
                    Finding::ShaftBow {
                        node,
                        amplitude,
                        amplitude_std,
                        phase_deg,
                        ..
                    } => Some((*node - 1, *amplitude, *amplitude_std, *phase_deg)),
                    _ => None,
                })
                .collect();
        assert_eq!(found.len(), 2);
        for p in &case.effects.bow {
            let &(_, a, sa, ph) = found
                .iter()
                .find(|f| f.0 == p.node)
                .unwrap_or_else(|| panic!("knot {} not found: {found:?}", p.node + 1));
            println!(
                "knot {}: {:.3} +- {:.3} um (hidden {:.3}), {ph:.1} deg (hidden {:.1})",
                p.node + 1,
                a * 1e6,
                sa * 1e6,
                p.amplitude * 1e6,
                p.phase.to_degrees()
            );
            assert!((a - p.amplitude).abs() <= 0.05 * p.amplitude);
            assert!((a - p.amplitude).abs() <= 3.5 * sa);
            let dphi = (ph.to_radians() - p.phase).sin().abs();
            assert!(dphi < 0.05, "phase {ph} deg against {} rad", p.phase);
        }
    }
}

/// [`realistic_confusion_matrix`] on the third rotor: a long stepped shaft
/// on three bearings with an overhung disk (`tests/data/rotors/three_bearing.toml`),
/// 55..16500 rpm.
#[test]
#[ignore = "350 diagnoses: cargo test --release --test lib diagnose::cases::realistic_confusion_matrix_three_bearing -- --ignored --nocapture"]
fn realistic_confusion_matrix_three_bearing() {
    let (m, sp) = data_rotor("tests/data/rotors/three_bearing.toml", 16500.0);
    confusion(&m, &sp, Some(0.005), 5e-7);
}

/// Prints the confusion table `table` ((hidden, named) -> count) as a
/// Markdown table: a row per effect of `hidden`, a column per effect of
/// `named`.
pub(super) fn print_confusion(
    hidden: &[Effect],
    named: &[Effect],
    table: &BTreeMap<(Effect, Effect), usize>,
) {
    print!("| hidden \\ named |");
    for e in named {
        print!(" {} |", e.name());
    }
    println!();
    for &h in hidden {
        print!("| {} |", h.name());
        for &e in named {
            print!(" {} |", table.get(&(h, e)).copied().unwrap_or(0));
        }
        println!();
    }
}

/// `ROTORID_CASES` (default 50) cases per effect of `m` at the speeds `sp`
/// (rpm), the effect's forms drawn in turn (the bank's, then those of
/// [`Form::MACHINE`]: E alone and a section's diameter, a film table,
/// pedestal masses apart, a two-knot bow, a distributed unbalance), with relative
/// noise `noise` (`None`: drawn) and probe floor `floor` (m); the table
/// printed, at least 95 % named right where observable and `none` named as
/// an effect at most 5 % asserted, and at least 95 % sized within 5 % and
/// 3.5 reported standard deviations of the cases named right in a form
/// the bank fits exactly where the data determine the size to 5 %.
fn confusion(m: &RotorModel, sp: &[f64], noise: Option<f64>, floor: f64) {
    let n: u64 = std::env::var("ROTORID_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(50);
    let mut table: BTreeMap<(Effect, Effect), usize> = BTreeMap::new();
    let (mut right, mut total, mut none_named) = (0, 0, 0);
    // Cases named right whose size is comparable, and those of them sized
    // within 5 % and 3.5 reported standard deviations.
    let (mut sized, mut sized_right) = (0, 0);
    // Of those, the ones within 3.5 reported standard deviations alone
    // (whether the deviation is honest, 5 % or not).
    let mut sized_sigmas = 0;
    let mut by_effect: BTreeMap<Effect, (usize, usize)> = BTreeMap::new();
    // The same by effect and form: the bank's own forms, which it fits
    // exactly, apart from those it approximates (a distributed unbalance
    // by a plane, a bow of two knots by one, a section of the shaft
    // anywhere by one between the drawing's features).
    let mut sized_by_form: BTreeMap<(Effect, String), (usize, usize)> = BTreeMap::new();
    // Of those in a form whose hidden size is the very parameter the bank
    // fits (its own forms, E alone, a pedestal with its masses apart) and
    // whose size the data determine to 5 % (3.5 reported standard
    // deviations within 5 % of it), those sized right.
    let (mut determined, mut determined_right) = (0, 0);
    // Named right of the observable cases, by effect and form.
    // (right, observable, with the form's variant, named with a variant
    // to check).
    let mut by_form: BTreeMap<(Effect, String), (usize, usize, usize, usize)> = BTreeMap::new();
    let all: Vec<Effect> = std::iter::once(Effect::None).chain(Effect::BANK).collect();
    for &effect in &all {
        for seed in 0..n {
            // Every form of the effect in turn: the bank's own, then the
            // forms machines have it in.
            let forms: Vec<Form> = std::iter::once(Form::Bank)
                .chain(
                    Form::MACHINE
                        .iter()
                        .filter(|(e, _)| *e == effect)
                        .map(|(_, f)| *f),
                )
                .collect();
            let form = forms[seed as usize % forms.len()];
            let (case, d, o) = run_case_form(
                m,
                sp,
                effect,
                form,
                1_000_003 * (effect as u64 + 1) + seed,
                noise,
                floor,
            );
            let variant = variant_named(form, &case.hidden, &d);
            if o.observable {
                let t = by_form
                    .entry((effect, format!("{form:?}")))
                    .or_insert((0, 0, 0, 0));
                t.0 += usize::from(o.named == effect || o.equivalent);
                t.1 += 1;
                if o.named == effect {
                    t.2 += usize::from(variant == Some(true));
                    t.3 += usize::from(variant.is_some());
                }
            }
            println!(
                "{} ({form:?}) seed {seed}: named {}{}{}",
                effect.name(),
                o.named.name(),
                if o.observable {
                    ""
                } else {
                    " (not observable)"
                },
                o.size.map_or(String::new(), |(got, want, std)| format!(
                    ", size {got:.4e} (hidden {want:.4e}, std {std:.1e})"
                ))
            );
            if let (true, Some((got, want, std))) = (o.named == effect, o.size) {
                sized += 1;
                let within = (got - want).abs() <= 0.05 * want.abs();
                let sigmas = (got - want).abs() <= 3.5 * std;
                sized_right += usize::from(within && sigmas);
                sized_sigmas += usize::from(sigmas);
                by_effect.entry(effect).or_insert((0, 0)).0 += usize::from(within && sigmas);
                by_effect.entry(effect).or_insert((0, 0)).1 += 1;
                let t = sized_by_form
                    .entry((effect, format!("{form:?}")))
                    .or_insert((0, 0));
                t.0 += usize::from(within && sigmas);
                t.1 += 1;
                if matches!(form, Form::Bank | Form::EOnly | Form::PedestalMasses)
                    && 3.5 * std <= 0.05 * want.abs()
                {
                    determined += 1;
                    determined_right += usize::from(within && sigmas);
                }
            }
            *table.entry((effect, o.named)).or_default() += 1;
            if o.observable {
                total += 1;
                right += usize::from(o.named == effect || o.equivalent);
            }
            if effect == Effect::None && o.named != Effect::None {
                none_named += 1;
            }
        }
    }
    let named: Vec<Effect> = all.iter().copied().chain([Effect::Unexplained]).collect();
    print_confusion(&all, &named, &table);
    let acc = right as f64 / total.max(1) as f64;
    println!("accuracy on observable cases: {right}/{total} = {acc:.3}; none named as an effect: {none_named}/{n}");
    println!("named right where observable, by form:");
    for ((e, f), (ok, of, v, vn)) in &by_form {
        if *vn > 0 {
            println!("  {} {f}: {ok}/{of} (its variant {v}/{vn})", e.name());
        } else {
            println!("  {} {f}: {ok}/{of}", e.name());
        }
    }
    println!("sized within 5 % and 3.5 std where named right: {sized_right}/{sized}");
    println!("within 3.5 reported std (5 % or not) where named right: {sized_sigmas}/{sized}");
    for (e, (ok, of)) in &by_effect {
        println!("  {}: {ok}/{of}", e.name());
    }
    println!("sized right by form:");
    for ((e, f), (ok, of)) in &sized_by_form {
        println!("  {} {f}: {ok}/{of}", e.name());
    }
    println!(
        "sized right in the forms the bank fits exactly, where 3.5 std is within 5 %: {determined_right}/{determined}"
    );
    assert!(acc >= 0.95);
    assert!(none_named as f64 <= 0.05 * n as f64);
    assert!(determined_right as f64 >= 0.95 * determined as f64);
}

#[test]
fn generator_is_deterministic() {
    let m = RotorModel::paper();
    let a = generate(&m, Effect::ShaftBow, 3, &speeds(), None).unwrap();
    let b = generate(&m, Effect::ShaftBow, 3, &speeds(), None).unwrap();
    assert_eq!(a.hidden, b.hidden);
    assert_eq!(a.meas.samples[10].q, b.meas.samples[10].q);
    assert!(a.noise >= 0.001 && a.noise <= 0.01);
    assert!(rpm_to_rad_s(15000.0) > 0.0);
}

/// Two effects at once (runout and an extra plane): no single effect
/// fits, the pair does, and both are named.
#[test]
fn a_pair_is_found() {
    let m = RotorModel::paper();
    let case = generate(&m, Effect::ProbeRunout, 5, &speeds(), Some(0.001)).unwrap();
    let mut effects = case.effects.clone();
    effects.extra_unbalance.push(rotorid::model::Unbalance {
        node: 15,
        me: 3e-3,
        phase: 1.0,
    });
    let meas = rotorid::simulate::simulate(
        &case.truth,
        &rotorid::simulate::SimOptions {
            speeds_rpm: speeds(),
            noise: 0.001,
            seed: 77,
            effects,
        },
    )
    .unwrap();
    let d = diagnose(&m, &meas, &DiagnoseOptions::default()).unwrap();
    println!(
        "{:?} {:.3e} -> {:.3e}",
        d.effects,
        d.residual_nominal(),
        d.residual_extended()
    );
    for h in &d.hypotheses {
        println!(
            "  {} {:.3e} {:.1} {}",
            h.label,
            h.residual(),
            h.statistic,
            h.significant
        );
    }
    assert!(d.effects.contains(&Effect::ProbeRunout), "{:?}", d.effects);
    assert!(
        d.effects.contains(&Effect::ExtraUnbalancePlane),
        "{:?}",
        d.effects
    );
    assert!(d.residual_extended() < 1.2 * d.noise_level.unwrap());
}

/// An effect outside the bank (every probe read through a first-order
/// low-pass at 150 Hz, a driver/cable fault): `unexplained`, with a
/// warning, never a forced name.
#[test]
fn an_effect_outside_the_bank_is_unexplained() {
    let m = RotorModel::paper();
    let mut case = generate(&m, Effect::None, 9, &speeds(), Some(0.001)).unwrap();
    let wc = std::f64::consts::TAU * 150.0;
    for s in &mut case.meas.samples {
        let g = num_complex::Complex64::new(1.0, s.omega / wc).inv();
        for q in &mut s.q {
            *q *= g;
        }
    }
    let d = diagnose(&m, &case.meas, &DiagnoseOptions::default()).unwrap();
    println!(
        "{:?} {:.3e} -> {:.3e}",
        d.effect,
        d.residual_nominal(),
        d.residual_extended()
    );
    assert_eq!(d.effect, Effect::Unexplained);
    assert!(!d.warnings.is_empty());
}

/// Observability: a bow that the bearing probes alone cannot tell from an
/// extra unbalance plane (a tenth of a drawn one: the bearings-only
/// diagnosis names the plane, its misfit at the noise) is named, placed and
/// sized once two probes between the disks (nodes 10 and 18, CSV column
/// groups `n10_y_re,...`) read the shaft; one probe at node 14 sees it
/// too but cannot place it.
#[test]
fn a_mid_span_probe_reveals_a_bow() {
    use rotorid::io::measurement::{parse_csv, to_csv_string, CsvLayout};
    use rotorid::simulate::{simulate_at_nodes, SimOptions};
    let m = RotorModel::paper();
    let seed = 11;
    let case = generate(&m, Effect::ShaftBow, seed, &speeds(), Some(0.001)).unwrap();
    // A tenth of the drawn bow: below what the bearing probes can see.
    let mut effects = case.effects.clone();
    effects.bow[0].amplitude *= 0.1;
    let size = effects.bow[0].amplitude;
    let opts = SimOptions {
        speeds_rpm: speeds(),
        noise: case.noise,
        seed,
        effects,
    };
    let (bearings_only, node_q) = simulate_at_nodes(&case.truth, &opts, &[9, 17]).unwrap();
    let d0 = diagnose(&m, &bearings_only, &DiagnoseOptions::default()).unwrap();
    // Through the file format, as a user would bring it.
    let mut with_probe = bearings_only.clone();
    with_probe.node_probes = vec![9, 17];
    with_probe.node_q = node_q;
    let text = to_csv_string(&with_probe, CsvLayout::Complex).unwrap();
    assert!(text.contains("b2_z_im,n10_y_re,n10_y_im,n10_z_re,n10_z_im,n18_y_re,"));
    let read = parse_csv(&text).unwrap();
    assert_eq!(read.node_probes, vec![9, 17]);
    let d1 = diagnose(&m, &read, &DiagnoseOptions::default()).unwrap();
    let h = &case.hidden;
    println!(
        "hidden bow {size:.3e} m at node {}: bearings only -> {} (residual {:.3e} -> {:.3e}); with probes at nodes 10 and 18 -> {} (residual {:.3e} -> {:.3e})",
        h.node.unwrap_or(0) + 1,
        d0.effect.name(),
        d0.residual_nominal(),
        d0.residual_extended(),
        d1.effect.name(),
        d1.residual_nominal(),
        d1.residual_extended()
    );
    assert_ne!(
        d0.effect,
        Effect::ShaftBow,
        "the example should need the probe"
    );
    assert_eq!(d1.effect, Effect::ShaftBow);
    let (amp, std, node) = d1
        .findings()
        .iter()
        .find_map(|f| match f {
            Finding::ShaftBow {
                node,
                amplitude,
                amplitude_std,
                ..
            } => Some((*amplitude, *amplitude_std, *node)),
            _ => None,
        })
        .unwrap();
    assert_eq!(Some(node - 1), h.node);
    assert!((amp - size).abs() <= 0.05 * size, "{amp} vs {size}");
    assert!((amp - size).abs() <= 3.5 * std, "{amp} +- {std} vs {size}");
    if let Some(s) = d1.noise_level {
        assert!(d1.residual_extended() < 1.2 * s);
    }
}

/// Pedestals under both bearings (the generator's pedestal under one, a
/// second one added under the other): no single effect fits, the pair of
/// pedestals does; named `foundation_flexibility` with a pedestal under
/// each bearing, each natural frequency within 5 %.
#[test]
fn pedestals_under_both_bearings() {
    let m = RotorModel::paper();
    let case = generate(&m, Effect::FoundationFlexibility, 2, &speeds(), Some(0.001)).unwrap();
    let mut truth = case.truth.clone();
    let b = case.hidden.bearing.unwrap();
    let other = 1 - b;
    let mass = 0.8 * rotorid::diagnose::rotor_mass(&m) / 2.0;
    let (wy, wz) = (0.55 * rpm_to_rad_s(15000.0), 0.6 * rpm_to_rad_s(15000.0));
    truth.bearings[other].pedestal = Some(rotorid::model::Pedestal {
        mass: [mass, mass],
        k: [mass * wy * wy, mass * wz * wz],
        c: [2.0 * 0.04 * mass * wy, 2.0 * 0.05 * mass * wz],
    });
    let meas = rotorid::simulate::simulate(
        &truth,
        &rotorid::simulate::SimOptions {
            speeds_rpm: speeds(),
            noise: 0.001,
            seed: 78,
            effects: case.effects.clone(),
        },
    )
    .unwrap();
    let d = diagnose(&m, &meas, &DiagnoseOptions::default()).unwrap();
    for h in &d.hypotheses {
        println!("  {} {:.3e} {:.1}", h.label, h.residual(), h.statistic);
    }
    assert_eq!(d.effect, Effect::FoundationFlexibility, "{:?}", d.effects);
    assert!(d.residual_extended() < 1.2 * d.noise_level.unwrap());
    let found: Vec<(usize, f64)> = d
        .findings()
        .iter()
        .filter_map(|f| match f {
            Finding::FoundationFlexibility {
                node,
                natural_frequency_hz,
                ..
            } => Some((*node, natural_frequency_hz[0])),
            _ => None,
        })
        .collect();
    assert_eq!(found.len(), 2, "{found:?}");
    let hidden = [(b, case.hidden.size), (other, wy)];
    for (bearing, w) in hidden {
        let node = m.bearings[bearing].node + 1;
        let (_, hz) = found.iter().find(|f| f.0 == node).unwrap();
        let want = w / std::f64::consts::TAU;
        assert!(
            (hz - want).abs() < 0.05 * want,
            "bearing {bearing}: {hz} Hz against {want}"
        );
    }
}

/// Each effect in the forms machines have it ([`Form::MACHINE`]: E alone,
/// a section's diameter, a fluid-film-like bearing table, a pedestal with
/// different masses in y and z, a bow of two knots, an extra unbalance
/// spread over three nodes), `ROTORID_CASES` (default 10) cases each on
/// realistic data (the paper rotor at G6.3, 0.5 % + 0.5 um probe floor):
/// named right where observable in at least 9 of 10, with its variant
/// where the bank has one ([`variant_named`]: E alone, a section, masses
/// apart, two knots; for a stiffness error, among the forms the data
/// cannot tell apart), and at least half of each form's cases observable.
#[test]
#[ignore = "60 diagnoses: cargo test --release --test lib diagnose::cases::machine_forms -- --ignored --nocapture"]
fn machine_forms() {
    let n: u64 = std::env::var("ROTORID_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let m = rotorid::simulate::at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0))
        .unwrap();
    let mut failed = Vec::new();
    for (k, (effect, form)) in Form::MACHINE.into_iter().enumerate() {
        let (mut right, mut total) = (0, 0);
        for seed in 0..n {
            let seed = 2_000_003 * (k as u64 + 1) + seed;
            let (case, d, o) = run_case_form(&m, &speeds(), effect, form, seed, Some(0.005), 5e-7);
            let variant = variant_named(form, &case.hidden, &d);
            let alike: Vec<String> = d
                .stiffness_alike()
                .iter()
                .map(|f| f.form.describe())
                .collect();
            println!(
                "{form:?} seed {seed}: {} -> {} ({}{}){}{}",
                case.hidden.description,
                o.named.name(),
                d.extended().label,
                if alike.is_empty() {
                    String::new()
                } else {
                    format!("; alike: {}", alike.join(", "))
                },
                if o.observable {
                    ""
                } else {
                    " (not observable)"
                },
                if o.named == effect && variant == Some(false) {
                    " (not its variant)"
                } else {
                    ""
                }
            );
            if o.observable {
                total += 1;
                // Named with its variant where the bank has one; a tie
                // with another effect counts as named.
                right += usize::from((o.named == effect && variant != Some(false)) || o.equivalent);
            }
        }
        println!("{form:?}: {right}/{total} named right (with its variant) where observable");
        // At least half the cases observable: a form drawn below what the
        // data show would pass without testing anything.
        if 10 * right < 9 * total || 2 * total < n as usize {
            failed.push((form, right, total));
        }
    }
    assert!(failed.is_empty(), "forms below 9 in 10: {failed:?}");
}

/// An extra unbalance spread equally over three neighbouring nodes (the
/// machine's form, [`Form::DistributedUnbalance`]), on realistic data
/// (G6.3, 0.5 % + 0.5 um probe floor) of the stepped hollow shaft and the
/// rotor on three bearings. The bank's variant of it, an unbalance shared
/// equally by a run of nodes (`Extension::Spread`), is named at the hidden
/// run in at least a third of the cases (8 of 18: it is kept only where it
/// fits better than one plane by more than a tie), and its total sized
/// within 5 % and 3.5 standard deviations of the hidden resultant in at
/// least nine of ten of those. Where one plane is named instead, at the
/// middle node, its `m e`
/// carries the part of its deviation that the runs of nodes it could be
/// spread over leave open (`Candidate::spread_std`, module docs of
/// `diagnose::bank::plane_spread`): the hidden resultant lies within 3.5
/// reported deviations in at least nine of ten such cases, where the
/// fit's deviation alone misses some (the plane's `m e` found lies up to
/// 13 of those from it), and the finding and the text report name the
/// runs at either end of those the data cannot tell apart (`spread`)
/// wherever the fit's deviation alone would miss.
#[test]
fn a_spread_unbalance_is_named_and_sized() {
    let rotors = [
        {
            let (m, sp) = data_rotor("tests/data/ross/stepped_hollow.toml", 12000.0);
            ("stepped", m, sp)
        },
        {
            let (m, sp) = data_rotor("tests/data/rotors/three_bearing.toml", 16500.0);
            ("three bearings", m, sp)
        },
    ];
    let n_seeds = 12u64;
    // (cases drawn spread over three nodes, named at their run, sized right).
    let (mut spread_cases, mut runs_named, mut runs_sized) = (0, 0, 0);
    // One plane at the middle node: (judged, within 3.5 reported
    // deviations, within 3.5 of the fit's alone).
    let (mut judged, mut within, mut within_fit) = (0, 0, 0);
    for (name, m, sp) in &rotors {
        for seed in 0..n_seeds {
            let seed = 9_100_011 + seed;
            let mut case = generate_form(
                m,
                Effect::ExtraUnbalancePlane,
                Form::DistributedUnbalance,
                seed,
                sp,
                Some(0.005),
            )
            .unwrap();
            rotorid::simulate::add_floor_noise(&mut case.meas, 5e-7, seed).unwrap();
            let node = case.hidden.node.unwrap();
            let shares: Vec<usize> = case
                .effects
                .extra_unbalance
                .iter()
                .map(|u| u.node)
                .collect();
            let run = (shares.len() == 3).then(|| (shares[0], shares[2]));
            spread_cases += usize::from(run.is_some());
            let d = diagnose(m, &case.meas, &DiagnoseOptions::default()).unwrap();
            let c = d.extended();
            if d.effect != Effect::ExtraUnbalancePlane {
                println!(
                    "{name} seed {seed}: {} -> {}",
                    case.hidden.description,
                    d.effect.name()
                );
                continue;
            }
            let (me, std, nodes, spread) = d
                .findings()
                .iter()
                .find_map(|f| match f {
                    Finding::ExtraUnbalancePlane {
                        me,
                        me_std,
                        nodes,
                        spread,
                        ..
                    } => Some((*me, *me_std, nodes.clone(), spread.clone())),
                    _ => None,
                })
                .expect("a plane finding");
            let hidden = case.hidden.size;
            let off = (me - hidden).abs();
            let fit_std = (std * std - c.spread_std * c.spread_std).max(0.0).sqrt();
            println!(
                "{name} seed {seed}: {} (shares at {shares:?}) -> {} ({nodes}): {me:.4e} +- {std:.1e} kg m (the fit's {fit_std:.1e}), {:+.2} %, {:.1} deviations, {:.1} of the fit's; spread {:?}",
                case.hidden.description,
                c.label,
                100.0 * (me / hidden - 1.0),
                off / std,
                off / fit_std,
                spread.iter().map(|r| (r.nodes.clone(), r.me)).collect::<Vec<_>>()
            );
            assert!(
                spread.is_empty() || (spread.len() == 2 && spread[0].me < spread[1].me),
                "{spread:?}"
            );
            match (c.model.ext.as_slice(), run) {
                ([Extension::Spread { first, last }], Some(r)) if (*first, *last) == r => {
                    runs_named += 1;
                    runs_sized += usize::from(off <= 0.05 * hidden && off <= 3.5 * std);
                    assert_eq!(nodes, format!("{}..{}", r.0 + 1, r.1 + 1));
                }
                ([Extension::Plane { node: found }], _) if *found == node => {
                    judged += 1;
                    within += usize::from(off <= 3.5 * std);
                    within_fit += usize::from(off <= 3.5 * fit_std);
                    if off > 3.5 * fit_std {
                        // The fit's deviation alone misses: the spread is
                        // named, in the finding and in the text report.
                        let [lo, hi] = &spread[..] else {
                            panic!("{name} seed {seed}: no spread named");
                        };
                        let nominal = rotorid::diagnose::predictions(m, &d, &d.nominal).unwrap();
                        let text =
                            rotorid::report::diagnose::text(&d, &case.meas.samples, &nominal);
                        assert!(
                            text.contains("the data do not fix where it lies")
                                && text.contains(&format!(
                                    "{:.4e} kg m spread over nodes {}",
                                    lo.me, lo.nodes
                                ))
                                && text.contains(&format!("{:.4e} over nodes {}", hi.me, hi.nodes)),
                            "{text}"
                        );
                    }
                }
                _ => {}
            }
        }
    }
    println!(
        "spread over three nodes: {spread_cases}; named at its run {runs_named}, sized right {runs_sized}; one plane at the middle node {judged}: within 3.5 deviations {within}, by the fit's alone {within_fit}"
    );
    assert!(
        3 * runs_named >= spread_cases,
        "{runs_named} of {spread_cases}"
    );
    assert!(
        10 * runs_sized >= 9 * runs_named,
        "{runs_sized} of {runs_named}"
    );
    assert!(
        judged >= 3,
        "{judged} cases named as one plane at the middle node"
    );
    assert!(10 * within >= 9 * judged, "{within} of {judged}");
    assert!(within_fit < judged, "{within_fit} of {judged}");
}

/// A diameter off on a section of elements drawn anywhere (the machine's
/// form, [`Form::Diameter`]), on realistic data (G6.3, 0.5 % + 0.5 um
/// probe floor) of the three rotors. With probes at the bearings the data
/// place the section's ends only roughly, and the factor's deviation
/// holds the part the ends leave open (`Candidate::ends_std`, module docs
/// of `diagnose::bank::section_ends`). Where the section found overlaps
/// the hidden one ([`same_form`]), the hidden factor lies within 3.5
/// reported deviations of the one found in at least two cases of three;
/// by the fit's deviation alone, in at most one of three (the factor
/// found lies up to hundreds of those off). The finding names the runs
/// at either end of those the data cannot tell apart (`ends`), in at
/// least half. Not every case: where the
/// data prefer another run of elements by far more than a tie (a run the
/// bank's sections do not hold, none of the linearised model's leading
/// runs), the spread around the section found misses it.
#[test]
fn a_sections_factor_deviation_holds_its_ends() {
    let paper =
        rotorid::simulate::at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0))
            .unwrap();
    let rotors = [
        ("paper", paper, speeds()),
        {
            let (m, sp) = data_rotor("tests/data/ross/stepped_hollow.toml", 12000.0);
            ("stepped", m, sp)
        },
        {
            let (m, sp) = data_rotor("tests/data/rotors/three_bearing.toml", 16500.0);
            ("three bearings", m, sp)
        },
    ];
    let (mut judged, mut within, mut within_fit, mut with_ends) = (0, 0, 0, 0);
    for (name, m, sp) in &rotors {
        let mut here = 0;
        for seed in 0..12u64 {
            if here == 4 {
                break;
            }
            let seed = 9_000_011 + seed;
            let mut case = generate_form(
                m,
                Effect::ShaftStiffnessError,
                Form::Diameter,
                seed,
                sp,
                Some(0.005),
            )
            .unwrap();
            rotorid::simulate::add_floor_noise(&mut case.meas, 5e-7, seed).unwrap();
            let d = diagnose(m, &case.meas, &DiagnoseOptions::default()).unwrap();
            let c = d.extended();
            let want = case.hidden.stiffness.unwrap();
            if d.effect != Effect::ShaftStiffnessError
                || !matches!(c.stiffness, StiffnessForm::Section { .. })
                || !same_form(c.stiffness, want)
            {
                continue;
            }
            let (factor, std, ends) = d
                .findings()
                .iter()
                .find_map(|f| match f {
                    Finding::ShaftStiffnessError {
                        factor,
                        factor_std,
                        ends,
                        ..
                    } => Some((*factor, *factor_std, ends.clone())),
                    _ => None,
                })
                .expect("a stiffness finding");
            let hidden = case.hidden.size;
            let fit_std = (std * std - c.ends_std * c.ends_std).max(0.0).sqrt();
            println!(
                "{name} seed {seed}: {} -> {} x {factor:.4} +- {std:.4} (the fit's {fit_std:.1e}): {:.1} deviations, {:.1} of the fit's",
                case.hidden.description,
                c.stiffness.describe(),
                (factor - hidden).abs() / std,
                (factor - hidden).abs() / fit_std
            );
            assert!(
                c.ends_std > 0.0,
                "{name} seed {seed}: no spread of the ends"
            );
            // The runs at either end of the tie, named in the finding.
            let ends: Vec<(String, f64)> = ends.into_iter().map(|e| (e.form, e.factor)).collect();
            println!("    ends: {ends:?}");
            assert!(
                ends.is_empty() || (ends.len() == 2 && ends[0].1 < ends[1].1),
                "{ends:?}"
            );
            if let [lo, hi] = &ends[..] {
                // The text report says so, with both runs.
                let nominal = rotorid::diagnose::predictions(m, &d, &d.nominal).unwrap();
                let text = rotorid::report::diagnose::text(&d, &case.meas.samples, &nominal);
                assert!(
                    text.contains("the data do not fix its ends")
                        && text.contains(&format!("{} x {:.4}", lo.0, lo.1))
                        && text.contains(&format!("{} x {:.4}", hi.0, hi.1)),
                    "{text}"
                );
            }
            with_ends += usize::from(!ends.is_empty());
            here += 1;
            judged += 1;
            within += usize::from((factor - hidden).abs() <= 3.5 * std);
            within_fit += usize::from((factor - hidden).abs() <= 3.5 * fit_std);
        }
        assert!(here >= 3, "{name}: {here} cases named on a section");
    }
    println!(
        "within 3.5 deviations: {within} of {judged}; by the fit's alone {within_fit}; ends named in {with_ends}"
    );
    assert!(3 * within >= 2 * judged, "{within} of {judged}");
    assert!(3 * within_fit <= judged, "{within_fit} of {judged}");
    assert!(
        2 * with_ends >= judged,
        "ends named in {with_ends} of {judged}"
    );
}
