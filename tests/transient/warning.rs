//! The sweep-rate check: the measurement file's `# sweep:
//! rate_rpm_per_s=<value>` line is read (a bad one is an error naming its
//! line), and `identify` and `diagnose` warn, on stderr and in their JSON
//! `"warnings"`, when the sweep passed a forward critical speed inside the
//! measured range with a passage parameter `|alpha| / (zeta omega_n)^2`
//! above `rotorid::campbell::KAPPA_MAX`.

use rotorid::campbell::{sweep_rate_warnings, KAPPA_MAX};
use rotorid::io::measurement::{parse_csv_located, MeasurementError};
use rotorid::simulate::{add_floor_noise, add_noise};
use rotorid::units::rpm_to_rad_s;

use super::stepped_hollow_g63;
use crate::common::{self, cli, tmp};

const ROW: &str = "1000,1e-6,0,0,1e-6,1e-6,0,0,1e-6\n";
const HEADER: &str = "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im\n";

#[test]
fn the_sweep_line_is_read() {
    let text = format!("# source: rig\n# sweep: rate_rpm_per_s=-50.5\n{HEADER}{ROW}");
    let (m, l) = parse_csv_located(&text).unwrap();
    assert_eq!(l.sweep_rate_rpm_per_s, Some(-50.5));
    assert_eq!(m.samples.len(), 1);
    let (_, l) = parse_csv_located(&format!("# source: rig\n{HEADER}{ROW}")).unwrap();
    assert_eq!(l.sweep_rate_rpm_per_s, None);
    for (bad, what) in [
        ("# sweep: rate_rpm_per_s=fast", "not a finite number"),
        ("# sweep: rate_rpm_per_s=inf", "not a finite number"),
        ("# sweep: rate=5", "expected `rate_rpm_per_s=<value>`"),
        ("# sweep: rate_rpm_per_s 5", "expected `=`"),
    ] {
        let e = parse_csv_located(&format!("# a\n{bad}\n{HEADER}{ROW}")).unwrap_err();
        assert!(
            matches!(e, MeasurementError::Sweep { line: 2, .. }),
            "{bad}: {e}"
        );
        let msg = e.to_string();
        assert!(msg.starts_with("line 2:") && msg.contains(what), "{msg}");
    }
    let two = format!("# sweep: rate_rpm_per_s=1\n# sweep: rate_rpm_per_s=2\n{HEADER}{ROW}");
    let e = parse_csv_located(&two).unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("line 1"), "{e}");
}

/// The threshold against the Campbell analysis: at the stepped hollow
/// shaft's 9224 rpm forward critical (zeta 0.0088) the rate limit is
/// `KAPPA_MAX (zeta omega_n)^2` in rpm/s; backward critical speeds are
/// not checked.
#[test]
fn threshold_follows_the_modal_damping() {
    let m = stepped_hollow_g63();
    let fast = sweep_rate_warnings(&m, 8000.0, 10500.0, -100.0).unwrap();
    assert_eq!(fast.len(), 1, "{fast:?}");
    let f = fast[0];
    assert!((f.rpm - 9224.0).abs() < 2.0, "{}", f.rpm);
    let wn = rpm_to_rad_s(f.rpm);
    let limit = rotorid::units::rad_s_to_rpm(KAPPA_MAX * (f.damping_ratio * wn).powi(2));
    assert!((f.rate_max_rpm_per_s / limit - 1.0).abs() < 1e-12);
    assert!((f.kappa / (rpm_to_rad_s(100.0) / (f.damping_ratio * wn).powi(2)) - 1.0).abs() < 1e-12);
    assert!(
        (5.0..9.0).contains(&f.rate_max_rpm_per_s),
        "{}",
        f.rate_max_rpm_per_s
    );
    assert!(
        f.message(-100.0).contains("9224 rpm"),
        "{}",
        f.message(-100.0)
    );
    // Just below the limit: no warning; outside the range: none either.
    let slow = sweep_rate_warnings(&m, 8000.0, 10500.0, 0.9 * f.rate_max_rpm_per_s).unwrap();
    assert!(slow.is_empty(), "{slow:?}");
    assert!(sweep_rate_warnings(&m, 3500.0, 8000.0, -100.0)
        .unwrap()
        .is_empty());
}

/// A sweep of the stepped hollow shaft at G6.3 over 8000..10500 rpm with
/// 0.5 % noise and a 0.2 um floor, written with a `# sweep:` line.
fn sweep_file(rate: f64) -> std::path::PathBuf {
    let m = stepped_hollow_g63();
    let speeds: Vec<f64> = (0..=100)
        .map(|i| rpm_to_rad_s(10500.0 - 25.0 * i as f64))
        .collect();
    let mut meas = common::simulate(&m, &speeds);
    add_noise(&mut meas, 5e-3, 7).unwrap();
    add_floor_noise(&mut meas, 0.2e-6, 7).unwrap();
    meas.comments = vec![format!("sweep: rate_rpm_per_s={rate}")];
    let csv = tmp(&format!("sweep_{}.csv", rate.abs()));
    rotorid::io::measurement::write_csv(&meas, &csv, Default::default()).unwrap();
    csv
}

/// The model file (the unbalance is what `identify` and `diagnose` find).
fn model_path() -> String {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ross/stepped_hollow.toml")
        .to_str()
        .unwrap()
        .to_string()
}

#[test]
fn identify_and_diagnose_warn_on_a_fast_sweep_only() {
    for (rate, warn) in [(-5.0, false), (-100.0, true)] {
        let csv = sweep_file(rate);
        let json = tmp("out.json");
        for cmd in ["identify", "diagnose"] {
            let out = cli([
                cmd,
                "--model",
                &model_path(),
                "--measurements",
                csv.to_str().unwrap(),
                "--json",
                json.to_str().unwrap(),
            ]);
            assert!(out.success(), "{cmd}: {}", out.stderr);
            let said = out.stderr.contains("passes the critical speed at 9224 rpm");
            assert_eq!(said, warn, "{cmd} at {rate} rpm/s: {}", out.stderr);
            let j: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
            let in_json = j["warnings"]
                .as_array()
                .unwrap()
                .iter()
                .any(|w| w.as_str().unwrap().contains("critical speed at 9224 rpm"));
            assert_eq!(in_json, warn, "{cmd} at {rate} rpm/s: {}", j["warnings"]);
        }
    }
}
