//! `probe_sensitivity`: a probe channel whose scale factor is off by 10 %
//! (high on one rotor's channel, low on another's) is named, on the right
//! channel, with its gain within 3.5 reported standard deviations and, where
//! the Cramér-Rao bound allows it, within 2 % of the error (`|g - g_true|
//! <= 0.02 |g_true - 1|`), else within 2 % of the factor.
//!
//! Where the shaft is stiff against a bearing (the paper rotor), the
//! bearing's displacement scales like its compliance: a common gain on its
//! two channels is a scale of its coefficients, and only the ratio of the
//! pair's gains is seen. A gain `g` on `z` then fits as well as `1 / g` on
//! `y`; the diagnosis says so in its label, and the test takes either.
//!
//! Realistic data: unbalance at balance grade G6.3, 0.5 % relative noise
//! and a 0.5 um probe floor (SPEC section 7), constant bearings scattered
//! from the model's, on two rotors (the paper rotor and ROSS's stepped
//! hollow shaft); the gain is applied by the simulator to the probe's
//! reading, runout included, not by the hypothesis's form.

use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect, Finding};
use rotorid::model::extension::{Channel, Direction, Effects, ProbeGain};
use rotorid::model::{BearingCoefficients, BearingLaw, RotorModel};
use rotorid::simulate::{add_floor_noise, at_balance_grade, simulate, SimOptions};
use rotorid::units::rpm_to_rad_s;

use crate::transient::stepped_hollow_g63;

/// Relative noise and probe floor (m) of the data.
const NOISE: f64 = 0.005;
const FLOOR: f64 = 0.5e-6;

/// `model` with constant bearings (its laws at half the top speed, the
/// truth's scattered by up to 20 %), a probe reading `factor` times its
/// signal on `channel`, a small runout on every channel; 300 speeds up to
/// `rpm_max`. Returns the channel named and the gain found with its std.
fn case(
    model: &RotorModel,
    rpm_max: f64,
    channel: Channel,
    factor: f64,
    seed: u64,
) -> (Effect, String, Option<(String, f64, f64)>) {
    let mut nominal = model.clone();
    let omega_max = rpm_to_rad_s(rpm_max);
    for b in &mut nominal.bearings {
        let co = b.law.at(0.5 * omega_max);
        b.law = BearingLaw::Constant(BearingCoefficients { k: co.k, c: co.c });
    }
    let mut truth = nominal.clone();
    for (i, b) in truth.bearings.iter_mut().enumerate() {
        let co = b.law.at(0.0);
        let f = 1.0 + 0.2 * ((i as f64 + 1.0) * 0.7).sin();
        b.law = BearingLaw::Constant(BearingCoefficients {
            k: co.k.map(|v| v * f),
            c: co.c.map(|v| v / f),
        });
    }
    let effects = Effects {
        probe_gain: vec![ProbeGain { channel, factor }],
        ..Effects::default()
    };
    let opts = SimOptions {
        speeds_rpm: (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect(),
        noise: NOISE,
        seed,
        effects,
    };
    let mut meas = simulate(&truth, &opts).unwrap();
    add_floor_noise(&mut meas, FLOOR, seed).unwrap();
    let d = diagnose(&nominal, &meas, &DiagnoseOptions::default()).unwrap();
    let found = d.findings().into_iter().find_map(|f| match f {
        Finding::ProbeSensitivity {
            channel,
            gain,
            gain_std,
        } => Some((channel, gain, gain_std)),
        _ => None,
    });
    for h in &d.hypotheses {
        println!(
            "    {:<40} statistic {:10.1} threshold {:5.1} s {:.4e}",
            h.label, h.statistic, h.threshold, h.fit.s
        );
    }
    for o in &d.observability {
        println!("    {}", o.note);
    }
    println!(
        "{}: named {} ({}), nominal {:.2e}, extended {:.2e}, found {found:?}",
        model.name,
        d.effect.name(),
        d.extended().label,
        d.residual_nominal(),
        d.residual_extended()
    );
    (d.effect, d.extended().label.clone(), found)
}

/// Checks one case; `strict`: the gain within 2 % of the error, else
/// within 2 % of the factor.
fn check(model: &RotorModel, rpm_max: f64, channel: Channel, factor: f64, seed: u64, strict: bool) {
    let (named, label, found) = case(model, rpm_max, channel, factor, seed);
    assert_eq!(named, Effect::ProbeSensitivity);
    let (name, gain, std) = found.unwrap();
    let dir = |d: Direction| if d == Direction::Y { "y" } else { "z" };
    let b = channel.bearing + 1;
    let want = format!("b{b}_{}", dir(channel.direction));
    // The pair's other channel, at 1 / g, when the label says the data do
    // not tell the two apart.
    let (gain, std) = if name == want {
        (gain, std)
    } else {
        let other = if channel.direction == Direction::Y {
            "z"
        } else {
            "y"
        };
        assert_eq!(name, format!("b{b}_{other}"), "{label}");
        assert!(
            label.contains(&format!("on {want}: the data do not tell")),
            "{label}"
        );
        (1.0 / gain, std / (gain * gain))
    };
    let err = (gain - factor).abs();
    let bound = if strict {
        0.02 * (factor - 1.0).abs()
    } else {
        0.02 * factor
    };
    assert!(err <= bound, "gain {gain} vs {factor}");
    assert!(err <= 3.5 * std, "gain {gain} +- {std} vs {factor}");
}

#[test]
fn ten_percent_high_on_the_paper_rotor() {
    let m = at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap();
    let ch = Channel {
        bearing: 1,
        direction: Direction::Z,
    };
    // The gain's standard deviation here is about 1.1 % (the lower half
    // of the sweep lies near the probe floor): 2 % of the factor.
    check(&m, 15000.0, ch, 1.10, 31, false);
}

#[test]
fn ten_percent_low_on_the_stepped_hollow_shaft() {
    let ch = Channel {
        bearing: 0,
        direction: Direction::Y,
    };
    check(&stepped_hollow_g63(), 12000.0, ch, 0.90, 32, true);
}
