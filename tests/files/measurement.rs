//! Measurement CSV (SPEC section 4): round trips for both headers, and
//! every kind of bad row rejected with its line number and column.

use num_complex::Complex64;
use rotorid::io::measurement::{
    parse_csv, to_csv_string, CsvLayout, MeasurementError, Measurements, Sample,
};
use rotorid::units::rpm_to_rad_s;

fn sample_data() -> Measurements {
    // Awkward values: tiny, huge, negative, irrational, subnormal-ish.
    let vals = [
        Complex64::new(1.2e-9, -3.4e-10),
        Complex64::new(std::f64::consts::PI * 1e-7, -std::f64::consts::E * 1e-12),
        Complex64::new(-0.0, 1.0 / 3.0 * 1e-5),
        Complex64::new(1e-300, -7.77e-6),
    ];
    Measurements {
        comments: vec!["source: rig A".into(), "second comment".into()],
        n_bearings: 2,
        node_probes: Vec::new(),
        node_q: Vec::new(),
        samples: (0..7)
            .map(|i| Sample {
                omega: rpm_to_rad_s(10.0 + 1234.5 * i as f64),
                q: vals.iter().map(|v| v * (1.0 + i as f64 / 7.0)).collect(),
            })
            .collect(),
    }
}

#[test]
fn complex_layout_round_trips_exactly() {
    let m = sample_data();
    let text = to_csv_string(&m, CsvLayout::Complex).unwrap();
    assert!(text
        .contains("\nspeed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im\n"));
    let r = parse_csv(&text).unwrap();
    assert_eq!(r.comments, m.comments);
    assert_eq!(r.n_bearings, 2);
    assert_eq!(r.samples.len(), m.samples.len());
    for (a, b) in r.samples.iter().zip(&m.samples) {
        // Phasors bit for bit; speed through rpm within an ulp or two.
        assert_eq!(a.q, b.q);
        assert!((a.omega - b.omega).abs() <= 4.0 * f64::EPSILON * b.omega);
    }
    // Writing what was read gives the same text.
    assert_eq!(to_csv_string(&r, CsvLayout::Complex).unwrap(), text);
}

#[test]
fn amplitude_phase_layout_round_trips() {
    let m = sample_data();
    let text = to_csv_string(&m, CsvLayout::AmplitudePhase).unwrap();
    assert!(text.contains("speed_rpm,b1_y_amp,b1_y_phase_deg,b1_z_amp,b1_z_phase_deg,b2_y_amp"));
    let r = parse_csv(&text).unwrap();
    for (a, b) in r.samples.iter().zip(&m.samples) {
        for (x, y) in a.q.iter().zip(&b.q) {
            assert!((x - y).norm() <= 1e-15 * y.norm(), "{x} vs {y}");
        }
    }
}

#[test]
fn amplitude_phase_values_mean_what_they_say() {
    let text = "speed_rpm,b1_y_amp,b1_y_phase_deg,b1_z_amp,b1_z_phase_deg\n600,2e-6,90,1e-6,-180\n";
    let r = parse_csv(text).unwrap();
    let q = &r.samples[0].q;
    assert!((q[0] - Complex64::new(0.0, 2e-6)).norm() < 1e-20);
    assert!((q[1] - Complex64::new(-1e-6, 0.0)).norm() < 1e-20);
    assert!((r.samples[0].omega - 20.0 * std::f64::consts::PI).abs() < 1e-12);
}

#[test]
fn comments_blank_lines_spaces_and_crlf_are_accepted() {
    let text = "# a\r\n\r\n speed_rpm , b1_y_re,b1_y_im,b1_z_re,b1_z_im\r\n# mid\r\n10, 1e-9 ,0,0,0\r\n\r\n5,2e-9,0,0,0\r\n";
    let r = parse_csv(text).unwrap();
    assert_eq!(r.comments, vec!["a".to_string(), "mid".to_string()]);
    assert_eq!(r.samples.len(), 2);
    // A byte-order mark before the header is skipped.
    assert_eq!(parse_csv(&format!("\u{feff}{text}")).unwrap(), r);
    // A run-down (decreasing speed) is valid.
    assert!(r.samples[1].omega < r.samples[0].omega);
}

const HEAD: &str = "# c\nspeed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im\n10,1,2,3,4\n";

fn bad(row: &str) -> MeasurementError {
    parse_csv(&format!("{HEAD}{row}\n")).unwrap_err()
}

#[test]
fn bad_rows_carry_line_and_column() {
    let cases = [
        (
            "20,1,2,3",
            "line 4: expected 5 columns (from the header), found 4",
        ),
        (
            "20,1,2,3,4,5",
            "line 4: expected 5 columns (from the header), found 6",
        ),
        (
            "20,1,abc,3,4",
            "line 4, column 3 (b1_y_im): not a number: \"abc\"",
        ),
        (
            "20,1,2,NaN,4",
            "line 4, column 4 (b1_z_re): not finite: \"NaN\"",
        ),
        (
            "20,1,2,3,inf",
            "line 4, column 5 (b1_z_im): not finite: \"inf\"",
        ),
        (
            "20,-infinity,2,3,4",
            "line 4, column 2 (b1_y_re): not finite: \"-infinity\"",
        ),
        (
            "-5,1,2,3,4",
            "line 4, column 1 (speed_rpm): must be >= 0, got -5",
        ),
        (
            "x,1,2,3,4",
            "line 4, column 1 (speed_rpm): not a number: \"x\"",
        ),
        (
            "20,1,,3,4",
            "line 4, column 3 (b1_y_im): not a number: \"\"",
        ),
    ];
    for (row, msg) in cases {
        assert_eq!(bad(row).to_string(), msg, "row {row:?}");
    }
    // Negative amplitude in the amplitude/phase layout.
    let e = parse_csv(
        "speed_rpm,b1_y_amp,b1_y_phase_deg,b1_z_amp,b1_z_phase_deg\n1,1,0,0,0\n2,-1,0,0,0\n",
    )
    .unwrap_err()
    .to_string();
    assert_eq!(e, "line 3, column 2 (b1_y_amp): must be >= 0, got -1");
}

#[test]
fn bad_headers_and_empty_files() {
    assert!(matches!(
        parse_csv(""),
        Err(MeasurementError::MissingHeader)
    ));
    assert!(matches!(
        parse_csv("# only\n\n"),
        Err(MeasurementError::MissingHeader)
    ));
    assert!(matches!(
        parse_csv("speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im\n"),
        Err(MeasurementError::NoData)
    ));
    let e = parse_csv("# x\nspeed_rpm,b1_y_re,b1_y_im\n")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("line 2: bad header"), "{e}");
    let e = parse_csv("rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im\n")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("line 1: bad header: first column"), "{e}");
    let e =
        parse_csv("speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b3_y_re,b2_y_im,b2_z_re,b2_z_im\n")
            .unwrap_err()
            .to_string();
    assert!(e.contains("`b2_y_re`"), "{e}");
    // Mixed layouts are rejected.
    let e = parse_csv("speed_rpm,b1_y_amp,b1_y_phase_deg,b1_z_re,b1_z_im\n").unwrap_err();
    assert!(matches!(e, MeasurementError::Header { .. }));
}

#[test]
fn writer_refuses_inconsistent_data() {
    let mut m = sample_data();
    m.samples[3].q.pop();
    assert!(to_csv_string(&m, CsvLayout::Complex).is_err());
    let mut m = sample_data();
    m.samples[1].q[0].re = f64::NAN;
    assert!(to_csv_string(&m, CsvLayout::Complex).is_err());
    let mut m = sample_data();
    m.samples[1].omega = -1.0;
    assert!(to_csv_string(&m, CsvLayout::Complex).is_err());
}

/// Grid speeds are written as the rpm a person typed (1000, not
/// 999.9999999999999 from the rad/s round trip), and read back within 1e-12.
#[test]
fn grid_speeds_are_written_as_round_rpm() {
    use num_complex::Complex64;
    use rotorid::io::measurement::{parse_csv, to_csv_string, CsvLayout, Measurements, Sample};
    use rotorid::units::rpm_to_rad_s;
    let m = Measurements {
        comments: vec![],
        n_bearings: 1,
        node_probes: Vec::new(),
        node_q: Vec::new(),
        samples: [1000.0, 6111.0, 15000.0]
            .iter()
            .map(|&rpm| Sample {
                omega: rpm_to_rad_s(rpm),
                q: vec![Complex64::new(1e-6, -2e-6), Complex64::new(3e-7, 0.0)],
            })
            .collect(),
    };
    let text = to_csv_string(&m, CsvLayout::Complex).unwrap();
    let speeds: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(speeds, ["1000", "6111", "15000"]);
    let back = parse_csv(&text).unwrap();
    for (a, b) in back.samples.iter().zip(&m.samples) {
        assert!((a.omega - b.omega).abs() <= 1e-12 * b.omega);
        assert_eq!(a.q, b.q);
    }
}

#[test]
fn a_last_row_without_line_break_is_refused_as_cut_short() {
    let text = "# c\nspeed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im\n10,1,2,3,4\n20,1,2,3,-3.8";
    let e = parse_csv(text).unwrap_err();
    assert!(
        matches!(e, MeasurementError::Truncated { line: 4 }),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .starts_with("line 4: the last row has no line break"),
        "{e}"
    );
    // Complete with its line break (or CRLF), or followed by a blank or
    // comment line without one: accepted.
    for tail in ["\n", "\r\n", "\n\n", "\n# end"] {
        assert_eq!(
            parse_csv(&format!("{text}{tail}")).unwrap().samples.len(),
            2
        );
    }
}

#[test]
fn long_fields_are_cut_in_messages() {
    let f = "9".repeat(100_000) + "x";
    let e = parse_csv(&format!("{HEAD}20,1,{f},3,4\n"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("line 4, column 3 (b1_y_im): not a number: \"9999"),
        "{e}"
    );
    assert!(e.len() < 120 && e.contains('…'), "{e}");
}

#[test]
fn huge_phasors_round_trip_and_the_amplitude_writer_never_writes_inf() {
    let m = Measurements {
        comments: vec![],
        n_bearings: 1,
        node_probes: Vec::new(),
        node_q: Vec::new(),
        samples: vec![Sample {
            omega: 100.0,
            q: vec![
                Complex64::new(1.5e308, -1.5e308),
                Complex64::new(f64::MIN_POSITIVE / 8.0, 0.0),
            ],
        }],
    };
    let text = to_csv_string(&m, CsvLayout::Complex).unwrap();
    let back = parse_csv(&text).unwrap();
    assert_eq!(back.samples[0].q, m.samples[0].q);
    let e = to_csv_string(&m, CsvLayout::AmplitudePhase).unwrap_err();
    assert!(
        e.to_string().starts_with("sample 1 (counting from 1)"),
        "{e}"
    );
    assert!(e.to_string().contains("amplitude"), "{e}");
    // Just below the largest number: written and read back.
    let mut ok = m.clone();
    ok.samples[0].q[0] = Complex64::new(1e308, -1e308);
    let text = to_csv_string(&ok, CsvLayout::AmplitudePhase).unwrap();
    assert!(!text.contains("inf"));
    let back = parse_csv(&text).unwrap();
    let (a, b) = (back.samples[0].q[0], ok.samples[0].q[0]);
    assert!((a - b).norm() <= 1e-15 * b.norm(), "{a} vs {b}");
}
