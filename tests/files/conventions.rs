//! Instrument conventions of the measurement file (SPEC section 7): the
//! `# conventions:` line and `identify`'s and `diagnose`'s options of the
//! same names.
//!
//! The data is realistic: the paper rotor at balance grade G6.3 with 0.5 %
//! relative probe noise and a 0.5 um noise floor, two node probes, `_std`
//! columns. The files in instrument conventions are written here with the
//! definitions alone (`A = |Y| / (c_k u)`, `phi = -arg Y mod 360` for a
//! lag), independently of the reader. The ROSS files are ROSS's own
//! `data_magnitude` / `data_phase` tables (`tests/data/ross/make.py`).

use std::fmt::Write as _;

use num_complex::Complex64;
use rotorid::estimate::{EstimateSet, Options};
use rotorid::io::measurement::{
    parse_csv, parse_csv_conventions, AmplitudeKind, AmplitudeUnit, Conventions, ConventionsError,
    CsvLayout, DeclaredConventions, MeasurementError, Measurements, PhaseConvention,
};
use rotorid::model::RotorModel;
use rotorid::simulate::{add_floor_noise, add_floor_noise_nodes, simulate_at_nodes, SimOptions};
use rotorid::units::{rad_s_to_rpm, rpm_to_rad_s};

use crate::common::{cli, tmp};

/// Relative probe noise `s` and noise floor `F` (m) of the sweep.
const S: f64 = 5e-3;
const FLOOR: f64 = 5e-7;

/// Node probes (0-based shaft nodes) besides the bearing channels.
const NODES: [usize; 2] = [7, 15];

/// A realistic sweep: the paper rotor at G6.3 (at 15000 rpm), 100..15000
/// rpm in steps of 100, noise `S` plus floor `FLOOR` on every channel, node
/// probes at [`NODES`], and per sample the standard deviation of that
/// noise model, `sqrt(F^2 + s^2 |q|^2)`, for every channel.
struct Sweep {
    model: RotorModel,
    meas: Measurements,
    std: Vec<Vec<f64>>,
}

fn sweep() -> Sweep {
    let model =
        rotorid::simulate::at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0))
            .expect("the paper rotor has unbalance");
    let opts = SimOptions {
        speeds_rpm: (1..=150).map(|k| 100.0 * k as f64).collect(),
        noise: S,
        seed: 11,
        ..SimOptions::default()
    };
    let (mut meas, mut node_q) = simulate_at_nodes(&model, &opts, &NODES).unwrap();
    add_floor_noise(&mut meas, FLOOR, 11).unwrap();
    add_floor_noise_nodes(&mut node_q, FLOOR, 11).unwrap();
    meas.node_probes = NODES.to_vec();
    meas.node_q = node_q;
    let std = meas
        .samples
        .iter()
        .zip(&meas.node_q)
        .map(|(s, n)| {
            s.q.iter()
                .chain(n)
                .map(|q| (FLOOR * FLOOR + S * S * q.norm_sqr()).sqrt())
                .collect()
        })
        .collect();
    Sweep { model, meas, std }
}

/// Every combination of the three keys (4 x 3 x 2).
fn all_conventions() -> Vec<Conventions> {
    let mut out = Vec::new();
    for amplitude_unit in AmplitudeUnit::ALL {
        for amplitude in AmplitudeKind::ALL {
            for phase in PhaseConvention::ALL {
                out.push(Conventions {
                    amplitude_unit,
                    amplitude,
                    phase,
                });
            }
        }
    }
    out
}

/// `x` (m, zero-to-peak) as written in `c`: `x / (c_k u)`, with `u` the
/// metres per unit and `c_k` = 1, 1/2, sqrt 2 for 0-pk, pk-pk, rms.
fn written(c: &Conventions, x: f64) -> f64 {
    let u = match c.amplitude_unit {
        AmplitudeUnit::M => 1.0,
        AmplitudeUnit::Mm => 1e-3,
        AmplitudeUnit::Um => 1e-6,
        AmplitudeUnit::Mil => 25.4e-6,
    };
    let k = match c.amplitude {
        AmplitudeKind::ZeroPeak => 1.0,
        AmplitudeKind::PeakPeak => 0.5,
        AmplitudeKind::Rms => std::f64::consts::SQRT_2,
    };
    x / u / k
}

/// The two columns of phasor `y` (m, rotorid's convention) as an
/// instrument in conventions `c` writes them: amplitude and phase in
/// degrees (the phase `arg Y`, or the lag `-arg Y` in `[0, 360)`), or the
/// instrument's vector `W` (`Y`, or `conj Y` for a lag) as re, im.
fn columns(c: &Conventions, layout: CsvLayout, y: Complex64) -> (f64, f64) {
    match layout {
        CsvLayout::AmplitudePhase => {
            let arg = y.arg().to_degrees();
            let phase = match c.phase {
                PhaseConvention::Arg => arg,
                PhaseConvention::Lag => (-arg).rem_euclid(360.0),
            };
            (written(c, y.norm()), phase)
        }
        CsvLayout::Complex => {
            let w = match c.phase {
                PhaseConvention::Arg => y,
                PhaseConvention::Lag => y.conj(),
            };
            (written(c, w.re), written(c, w.im))
        }
    }
}

/// The sweep as a measurement file in conventions `c` (declared in its
/// `# conventions:` line when `line`), `_std` columns after every channel.
fn file_in(s: &Sweep, c: &Conventions, layout: CsvLayout, line: bool) -> String {
    let mut t = String::from("# source: rig A, run-up 2\n");
    if line {
        writeln!(t, "# conventions: {c}").unwrap();
    }
    t.push_str("# probes: Bently Nevada 3300 XL 8 mm\n");
    let (a, b) = match layout {
        CsvLayout::Complex => ("re", "im"),
        CsvLayout::AmplitudePhase => ("amp", "phase_deg"),
    };
    let mut names: Vec<String> = (1..=s.meas.n_bearings)
        .flat_map(|k| [format!("b{k}_y"), format!("b{k}_z")])
        .collect();
    for n in NODES {
        names.push(format!("n{}_y", n + 1));
        names.push(format!("n{}_z", n + 1));
    }
    t.push_str("speed_rpm");
    for n in &names {
        write!(t, ",{n}_{a},{n}_{b},{n}_std").unwrap();
    }
    t.push('\n');
    for ((smp, nq), std) in s.meas.samples.iter().zip(&s.meas.node_q).zip(&s.std) {
        write!(t, "{:e}", rad_s_to_rpm(smp.omega)).unwrap();
        for (q, sd) in smp.q.iter().chain(nq).zip(std) {
            let (v1, v2) = columns(c, layout, *q);
            write!(t, ",{v1:e},{v2:e},{:e}", written(c, *sd)).unwrap();
        }
        t.push('\n');
    }
    t
}

/// Largest `|a - b| / |b|` over every phasor of two sweeps (bearing and
/// node channels) and largest relative difference of their `_std` values.
fn disagreement(
    a: &Measurements,
    a_std: &[Vec<f64>],
    b: &Measurements,
    b_std: &[Vec<f64>],
) -> (f64, f64) {
    assert_eq!(a.samples.len(), b.samples.len());
    assert_eq!(a.node_probes, b.node_probes);
    let mut q = 0.0f64;
    for ((sa, sb), (na, nb)) in a
        .samples
        .iter()
        .zip(&b.samples)
        .zip(a.node_q.iter().zip(&b.node_q))
    {
        assert!((sa.omega - sb.omega).abs() <= 4.0 * f64::EPSILON * sb.omega);
        for (x, y) in sa.q.iter().chain(na).zip(sb.q.iter().chain(nb)) {
            q = q.max((x - y).norm() / y.norm());
        }
    }
    let mut sd = 0.0f64;
    for (ra, rb) in a_std.iter().zip(b_std) {
        assert_eq!(ra.len(), rb.len());
        for (x, y) in ra.iter().zip(rb) {
            sd = sd.max((x - y).abs() / y);
        }
    }
    (q, sd)
}

/// Largest relative difference of two identifications' final estimates:
/// per bearing `K` and `C` relative to the largest entry of that matrix,
/// per plane `|a - a'| / |a|`.
fn estimate_disagreement(a: &EstimateSet, b: &EstimateSet) -> f64 {
    let mut worst = 0.0f64;
    for (x, y) in a.bearings.iter().zip(&b.bearings) {
        for (u, v) in [(&x.k, &y.k), (&x.c, &y.c)] {
            let scale = v.iter().fold(0.0f64, |m, e| m.max(e.abs()));
            for (p, q) in u.iter().zip(v) {
                worst = worst.max((p - q).abs() / scale);
            }
        }
    }
    for (x, y) in a.unbalance.iter().zip(&b.unbalance) {
        worst = worst.max((x.a - y.a).norm() / y.a.norm());
    }
    worst
}

/// Every convention (4 units x 3 kinds x 2 phases) in both layouts, node
/// probes and `_std` columns included: the file read back is the sweep to
/// 2e-15 relative (a few roundings of the unit, the kind and the polar
/// form; measured 8.1e-16 for the phasors, 2.6e-16 for the standard
/// deviations), and `rotorid::identify` (the output-error estimate, same
/// iteration count) gives the estimates of the sweep itself to 1e-12
/// relative (measured 6.1e-13: per bearing `K`, `C` against the largest
/// entry, per plane `|a|`; the fit amplifies the reading's last-bit
/// differences about a thousandfold).
#[test]
fn every_convention_reads_back_the_sweep_and_its_estimates() {
    let s = sweep();
    let opts = Options::default();
    let reference = rotorid::identify(&s.model, &s.meas, &opts).unwrap();
    let (mut worst_q, mut worst_std, mut worst_id) = (0.0f64, 0.0f64, 0.0f64);
    for layout in [CsvLayout::Complex, CsvLayout::AmplitudePhase] {
        for c in all_conventions() {
            let text = file_in(&s, &c, layout, true);
            let (m, loc) = parse_csv_conventions(&text, None, &DeclaredConventions::default())
                .unwrap_or_else(|e| panic!("{c} ({layout:?}): {e}"));
            assert_eq!(loc.conventions, c);
            assert_eq!(loc.conventions_line, Some(2));
            assert_eq!(loc.layout, layout);
            // The line is applied, not kept as free text.
            assert_eq!(
                m.comments,
                [
                    "source: rig A, run-up 2",
                    "probes: Bently Nevada 3300 XL 8 mm"
                ]
            );
            let (dq, dstd) = disagreement(&m, &loc.sample_std, &s.meas, &s.std);
            assert!(dq <= 2e-15, "{c} ({layout:?}): phasors differ by {dq:e}");
            assert!(dstd <= 2e-15, "{c} ({layout:?}): std differ by {dstd:e}");
            let id = rotorid::identify(&s.model, &m, &opts).unwrap();
            let did = estimate_disagreement(&id.last, &reference.last);
            assert!(
                did <= 1e-12,
                "{c} ({layout:?}): estimates differ by {did:e}"
            );
            worst_q = worst_q.max(dq);
            worst_std = worst_std.max(dstd);
            worst_id = worst_id.max(did);
        }
    }
    eprintln!(
        "conventions: phasors {worst_q:.2e}, std {worst_std:.2e}, estimates {worst_id:.2e} (relative)"
    );
}

/// A file without the line reads bit for bit as rotorid's own, and so does
/// one that declares rotorid's own conventions; a lag is `-arg Y`.
#[test]
fn a_file_without_the_line_reads_as_before() {
    let s = sweep();
    let own = Conventions::default();
    for layout in [CsvLayout::Complex, CsvLayout::AmplitudePhase] {
        let plain = file_in(&s, &own, layout, false);
        let declared = file_in(&s, &own, layout, true);
        let (a, la) = parse_csv_conventions(&plain, None, &DeclaredConventions::default()).unwrap();
        let (b, lb) =
            parse_csv_conventions(&declared, None, &DeclaredConventions::default()).unwrap();
        assert_eq!(la.conventions_line, None);
        assert_eq!(lb.conventions_line, Some(2));
        assert_eq!(a, b, "{layout:?}");
        assert_eq!(la.sample_std, lb.sample_std);
        assert_eq!(parse_csv(&plain).unwrap(), a);
        // The values as they stand: the phasor of each written pair.
        let row = plain.lines().nth(3).unwrap();
        let f: Vec<f64> = row.split(',').map(|x| x.parse().unwrap()).collect();
        let expected = match layout {
            CsvLayout::Complex => Complex64::new(f[1], f[2]),
            CsvLayout::AmplitudePhase => Complex64::from_polar(f[1], f[2].to_radians()),
        };
        assert_eq!(a.samples[0].q[0], expected);
        if layout == CsvLayout::Complex {
            // Complex layout: the sweep itself, bit for bit.
            assert_eq!(a.samples[0].q, s.meas.samples[0].q);
        }
    }
    // `phase=lag` alone: the written 30 deg is arg Y = -30 deg.
    let text =
        "# conventions: phase=lag\nspeed_rpm,b1_y_amp,b1_y_phase_deg,b1_z_amp,b1_z_phase_deg\n\
                1000,2e-6,30,1e-6,270\n";
    let m = parse_csv(text).unwrap();
    let want = [
        Complex64::from_polar(2e-6, (-30f64).to_radians()),
        Complex64::from_polar(1e-6, 90f64.to_radians()),
    ];
    for (q, w) in m.samples[0].q.iter().zip(want) {
        assert!((q - w).norm() <= 1e-15 * w.norm(), "{q} vs {w}");
    }
}

fn conventions_error(text: &str) -> (usize, ConventionsError, String) {
    match parse_csv(text) {
        Err(e @ MeasurementError::Conventions { .. }) => {
            let msg = e.to_string();
            let MeasurementError::Conventions { line, source } = e else {
                unreachable!()
            };
            (line, source, msg)
        }
        other => panic!("expected a conventions error, got {other:?}"),
    }
}

/// An unknown key or value, a key given twice, a word that is not
/// `key=value`, a second line or one after the header: an error naming it,
/// with its line.
#[test]
fn bad_conventions_lines_name_the_key_or_value_and_the_line() {
    let body = "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im\n1000,1e-6,0,0,1e-6\n";
    let with = |line: &str| format!("# source: rig A\n{line}\n{body}");

    let (line, e, msg) = conventions_error(&with("# conventions: amplitude_units=um"));
    assert_eq!(line, 2);
    assert_eq!(
        e,
        ConventionsError::UnknownKey {
            key: "amplitude_units".into()
        }
    );
    assert!(
        msg.starts_with("line 2: unknown key `amplitude_units`"),
        "{msg}"
    );

    let (line, e, msg) = conventions_error(&with("#conventions: amplitude_unit=um amplitude=peak"));
    assert_eq!(line, 2);
    assert!(matches!(
        e,
        ConventionsError::UnknownValue { key: "amplitude", ref value, .. } if value == "peak"
    ));
    assert!(
        msg.contains("unknown value `peak` for `amplitude` (expected one of: 0-pk, pk-pk, rms)"),
        "{msg}"
    );

    let (_, e, _) = conventions_error(&with("# conventions: amplitude_unit=inch"));
    assert!(matches!(
        e,
        ConventionsError::UnknownValue {
            key: "amplitude_unit",
            ..
        }
    ));
    let (_, e, _) = conventions_error(&with("# conventions: phase=lead"));
    assert!(matches!(
        e,
        ConventionsError::UnknownValue { key: "phase", .. }
    ));

    let (line, e, msg) =
        conventions_error(&with("# conventions: phase=lag amplitude=rms phase=lag"));
    assert_eq!(line, 2);
    assert_eq!(
        e,
        ConventionsError::DuplicateKey {
            key: "phase".into()
        }
    );
    assert!(msg.contains("`phase` is given twice"), "{msg}");

    let (_, e, _) = conventions_error(&with("# conventions: amplitude_unit = um"));
    assert!(matches!(e, ConventionsError::NotKeyValue { .. }));

    let two = format!("# conventions: phase=lag\n# conventions: amplitude_unit=um\n{body}");
    let (line, e, _) = conventions_error(&two);
    assert_eq!((line, e), (2, ConventionsError::SecondLine { first: 1 }));

    let after = format!("{body}# conventions: phase=lag\n");
    let (line, e, msg) = conventions_error(&after);
    assert_eq!((line, e), (3, ConventionsError::AfterHeader { header: 1 }));
    assert!(msg.contains("must come before the header"), "{msg}");

    // Other comments stay free text, even when they mention conventions.
    let free = format!(
        "# conventions of rig A: see the log book\n# API 670 conventions: phase=lag\n{body}"
    );
    let m = parse_csv(&free).unwrap();
    assert_eq!(m.comments.len(), 2);

    // The writer writes rotorid's own conventions: a comment that would
    // read back as the line is refused.
    let mut m = parse_csv(&with("# conventions: amplitude_unit=um")).unwrap();
    m.comments.push("conventions: amplitude_unit=um".into());
    assert!(matches!(
        rotorid::io::measurement::to_csv_string(&m, CsvLayout::Complex),
        Err(MeasurementError::ConventionsComment { index: 1 })
    ));
}

/// The options of the same names override the file's line key by key:
/// `identify` and `diagnose` on a file in micrometres peak-to-peak with
/// lags, whose line misstates the unit and the phase, give with
/// `--amplitude-unit um --phase lag` the results of the same sweep in
/// rotorid's own file (estimates to 1e-12 relative, measured 7.0e-13; the
/// same diagnosis, nominal residual to 1e-9). Bad values: exit 2, one line on stderr.
#[test]
fn command_line_options_override_the_file_line() {
    let s = sweep();
    let own = tmp("own.csv");
    std::fs::write(
        &own,
        file_in(
            &s,
            &Conventions::default(),
            CsvLayout::AmplitudePhase,
            false,
        ),
    )
    .unwrap();
    let truth = Conventions {
        amplitude_unit: AmplitudeUnit::Um,
        amplitude: AmplitudeKind::PeakPeak,
        phase: PhaseConvention::Lag,
    };
    let text = file_in(&s, &truth, CsvLayout::AmplitudePhase, false).replacen(
        "# probes:",
        "# conventions: amplitude_unit=mm amplitude=pk-pk phase=arg\n# probes:",
        1,
    );
    let inst = tmp("instrument.csv");
    std::fs::write(&inst, text).unwrap();

    let run = |cmd: &str, file: &std::path::Path, extra: &[&str], json: &str| {
        let out_json = tmp(json);
        let mut args = vec![
            cmd.to_string(),
            "--model".into(),
            "paper".into(),
            "--measurements".into(),
            file.display().to_string(),
            "--json".into(),
            out_json.display().to_string(),
        ];
        args.extend(extra.iter().map(|a| a.to_string()));
        let out = cli(&args);
        assert!(out.success(), "{cmd} {extra:?}: {}", out.stderr);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out_json).unwrap()).unwrap();
        v
    };
    // The paper model's own unbalance is 43 times G6.3: identify's table
    // compares with it, the estimates do not depend on it.
    let a = run("identify", &own, &[], "own.json");
    let b = run(
        "identify",
        &inst,
        &["--amplitude-unit", "um", "--phase", "lag"],
        "inst.json",
    );
    let mut worst = 0.0f64;
    for (x, y) in a["bearings"]
        .as_array()
        .unwrap()
        .iter()
        .zip(b["bearings"].as_array().unwrap())
    {
        for m in ["k", "c"] {
            let keys = ["yy", "yz", "zy", "zz"];
            let scale = keys
                .iter()
                .map(|k| x[m][k].as_f64().unwrap().abs())
                .fold(0.0, f64::max);
            for k in keys {
                let d = (x[m][k].as_f64().unwrap() - y[m][k].as_f64().unwrap()).abs();
                worst = worst.max(d / scale);
            }
        }
    }
    for (x, y) in a["unbalance"]
        .as_array()
        .unwrap()
        .iter()
        .zip(b["unbalance"].as_array().unwrap())
    {
        let (me, me2) = (x["me"].as_f64().unwrap(), y["me"].as_f64().unwrap());
        let (p, p2) = (
            x["phase_deg"].as_f64().unwrap(),
            y["phase_deg"].as_f64().unwrap(),
        );
        worst = worst.max((me - me2).abs() / me);
        worst = worst.max((p - p2).abs().to_radians());
    }
    eprintln!("identify through the options: estimates differ by {worst:.2e} (relative)");
    assert!(worst <= 1e-12, "estimates differ by {worst:e}");
    // Without the options the file's (wrong) line is what counts.
    let wrong = run("identify", &inst, &[], "wrong.json");
    let k = |v: &serde_json::Value| v["bearings"][0]["k"]["yy"].as_f64().unwrap();
    assert!((k(&wrong) - k(&a)).abs() > 1e-3 * k(&a).abs());

    let d1 = run("diagnose", &own, &[], "own-diag.json");
    let d2 = run(
        "diagnose",
        &inst,
        &["--phase", "lag", "--amplitude-unit", "um"],
        "inst-diag.json",
    );
    assert_eq!(d1["effect"], d2["effect"]);
    let (r1, r2) = (
        d1["residual_nominal"].as_f64().unwrap(),
        d2["residual_nominal"].as_f64().unwrap(),
    );
    assert!((r1 - r2).abs() <= 1e-9 * r1, "{r1} vs {r2}");

    // Bad input: exit 2, one line naming the value or the key and line.
    let out = cli([
        "identify",
        "--model",
        "paper",
        "--measurements",
        own.to_str().unwrap(),
        "--phase",
        "lead",
    ]);
    assert_eq!(out.status, 2);
    assert_eq!(out.stderr.lines().count(), 1, "{}", out.stderr);
    assert!(out.stderr.contains("lead"), "{}", out.stderr);
    let bad = tmp("bad.csv");
    std::fs::write(
        &bad,
        std::fs::read_to_string(&own).unwrap().replacen(
            "# probes:",
            "# conventions: amplitude=peak\n# probes:",
            1,
        ),
    )
    .unwrap();
    for cmd in ["identify", "diagnose"] {
        let out = cli([
            cmd,
            "--model",
            "paper",
            "--measurements",
            bad.to_str().unwrap(),
        ]);
        assert_eq!(out.status, 2);
        assert_eq!(out.stderr.lines().count(), 1, "{}", out.stderr);
        assert!(
            out.stderr
                .contains("line 2: unknown value `peak` for `amplitude`"),
            "{}",
            out.stderr
        );
    }
}

/// ROSS's probe tables (`tests/data/ross/rotor_example.probes_*.csv`,
/// written by ROSS 3.1.0's `data_magnitude` / `data_phase` in `make.py`)
/// read with the documented settings are the same run's complex response
/// (`rotor_example.probes_complex.csv`, ROSS's `forced_resp`, rotorid's own
/// convention): metres 0-pk with lags given as overrides (`m 0-pk lag`; the
/// file has no line) and the `um pkpk` table by its own `# conventions:`
/// line, to 1e-14 relative (measured 8.1e-16 for both). The complex
/// response is the fixture's `results.json` to 1e-9 (measured 7.2e-12:
/// ROSS run on another machine's BLAS). Read as `arg`, the phases come out
/// mirrored.
#[test]
fn ross_probe_tables_read_with_the_documented_settings() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ross");
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap();
    let reference = parse_csv(&read("rotor_example.probes_complex.csv")).unwrap();
    let compare = |m: &Measurements, want: &[Vec<Complex64>]| -> f64 {
        assert_eq!(m.samples.len(), want.len());
        let mut worst = 0.0f64;
        for (s, (r, w)) in m.samples.iter().zip(reference.samples.iter().zip(want)) {
            assert!((s.omega - r.omega).abs() <= 1e-13 * r.omega);
            for (q, y) in s.q.iter().zip(w) {
                worst = worst.max((q - y).norm() / y.norm());
            }
        }
        worst
    };
    let want: Vec<Vec<Complex64>> = reference.samples.iter().map(|s| s.q.clone()).collect();
    let lag_0pk = DeclaredConventions {
        amplitude_unit: Some(AmplitudeUnit::M),
        amplitude: Some(AmplitudeKind::ZeroPeak),
        phase: Some(PhaseConvention::Lag),
    };
    let m_text = read("rotor_example.probes_m_0pk_lag.csv");
    let (m, loc) = parse_csv_conventions(&m_text, None, &lag_0pk).unwrap();
    assert_eq!(loc.conventions_line, None);
    let d_m = compare(&m, &want);
    let um = parse_csv(&read("rotor_example.probes_um_pkpk_lag.csv")).unwrap();
    let d_um = compare(&um, &want);

    // The complex response against the fixture's results (ROSS's x, y at
    // the bearing nodes 0 and 6 are rotorid's y, z).
    let results: serde_json::Value =
        serde_json::from_str(&read("rotor_example.results.json")).unwrap();
    let r = &results["unbalance_response"];
    let floats = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let mut json: Vec<Vec<Complex64>> = vec![Vec::new(); want.len()];
    for node in [0, 6] {
        let p = r["probes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["node"] == node)
            .unwrap();
        for axis in ["x", "y"] {
            let re = floats(&p[format!("{axis}_re")]);
            let im = floats(&p[format!("{axis}_im")]);
            for (k, (a, b)) in re.into_iter().zip(im).enumerate() {
                json[k].push(Complex64::new(a, b));
            }
        }
    }
    let d_json = compare(&reference, &json);
    eprintln!(
        "ROSS probe tables: m 0-pk lag {d_m:.2e}, um pk-pk lag {d_um:.2e}; complex vs results.json {d_json:.2e} (relative)"
    );
    assert!(d_m <= 1e-14, "m 0-pk lag: {d_m:e}");
    assert!(d_um <= 1e-14, "um pk-pk lag: {d_um:e}");
    assert!(
        d_json <= 1e-9,
        "complex response vs results.json: {d_json:e}"
    );
    // Read in rotorid's own convention the phase comes out mirrored.
    let as_arg = parse_csv(&m_text).unwrap();
    assert!(compare(&as_arg, &want) > 0.1);
}
