//! `rotorid vectors`: the SPEC's signals CSV with no option gives a
//! measurement CSV that `identify` reads, with its `_std` columns, the
//! sweep-rate line and the rejection counts; bad files exit 2 with one
//! line (a bad row names its line).

use crate::common::{cli, tmp};
use crate::files::signals::{recording, short_paper};

fn one_line_error(o: &crate::common::Output) -> String {
    assert_eq!(o.status, 2, "{o:?}");
    assert_eq!(o.stderr.lines().count(), 1, "{o:?}");
    o.stderr.clone()
}

#[test]
fn spec_csv_with_no_option() {
    let s = short_paper();
    let sig = tmp("signals.csv");
    std::fs::write(&sig, s.csv()).unwrap();
    let out = tmp("vectors.csv");
    let json = tmp("summary.json");
    let o = cli([
        "vectors",
        "--signals",
        sig.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.success(), "{o:?}");
    assert!(o.stdout.contains("rows: "), "{}", o.stdout);
    assert!(o.stdout.contains("revolutions: "), "{}", o.stdout);
    let text = std::fs::read_to_string(&out).unwrap();
    let rate_line = text
        .lines()
        .find(|l| l.starts_with("# sweep: rate_rpm_per_s="))
        .unwrap();
    let rate: f64 = rate_line["# sweep: rate_rpm_per_s=".len()..]
        .parse()
        .unwrap();
    assert!(
        (rate / s.rate_rpm_per_s() - 1.0).abs() < 1e-3,
        "{rate_line}"
    );
    assert!(
        text.contains("# rejected: no_reference=2 period_jump=0"),
        "{text}"
    );
    let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
    assert!(
        header.starts_with("speed_rpm,b1_y_re,b1_y_im,b1_y_std,b1_z_re"),
        "{header}"
    );
    // The measurement reader takes it, `_std` columns and all, and the
    // rows are the library's.
    let (m, loc) = rotorid::io::measurement::parse_csv_located(&text).unwrap();
    let v = rotorid::signals::extract(&recording(&s), &Default::default(), None).unwrap();
    assert_eq!(m.samples.len(), v.rows.len());
    assert_eq!(loc.sample_std.len(), v.rows.len());
    for ((a, b), std) in m.samples.iter().zip(&v.rows).zip(&loc.sample_std) {
        assert!((a.omega / b.omega - 1.0).abs() < 1e-12);
        for ((x, y), (s, t)) in a.q.iter().zip(&b.x1).zip(std.iter().zip(&b.std)) {
            assert!((x - y).norm() <= 1e-12 * y.norm(), "{x} {y}");
            assert!((s / t - 1.0).abs() < 1e-12);
        }
    }
    // Speeds as recorded: a run-down.
    assert!(m.samples.windows(2).all(|w| w[1].omega < w[0].omega));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(j["rows"].as_u64().unwrap() as usize, v.rows.len());
    assert_eq!(j["revolutions"]["rejected"]["no_reference"], 2);
    // identify takes the file as it is.
    let o = cli([
        "identify",
        "--model",
        "paper",
        "--measurements",
        out.to_str().unwrap(),
    ]);
    assert!(o.success(), "{o:?}");
}

#[test]
fn wav_through_the_command_line_and_config() {
    let s = short_paper();
    let wav = tmp("rec.wav");
    let spec = hound::WavSpec {
        channels: 5,
        sample_rate: s.fs as u32,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut w = hound::WavWriter::create(&wav, spec).unwrap();
    for i in 0..s.len() {
        // Keyphasor first, inverted (a notch: falling edge), then the probes
        // in volts at 7.87 V/mm, full scale 20 V.
        w.write_sample((-s.kp[i] / 20.0) as f32).unwrap();
        for c in 0..4 {
            w.write_sample((s.y[c][i] * 7870.0 / 20.0) as f32).unwrap();
        }
    }
    w.finalize().unwrap();
    let cfg = tmp("signals.toml");
    std::fs::write(
        &cfg,
        "[keyphasor]\nsource = 0\nedge = \"falling\"\n\n[probes]\nfull_scale_v = 20.0\nsensitivity_v_per_mm = 7.87\n\n[probes.channels]\nb1_y = 1\nb1_z = 2\nb2_y = 3\nb2_z = 4\n",
    )
    .unwrap();
    let out = tmp("v.csv");
    let plot = tmp("plots");
    let o = cli([
        "vectors",
        "--signals",
        wav.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert!(o.success(), "{o:?}");
    let m = rotorid::io::measurement::read_csv(&out).unwrap();
    let v = rotorid::signals::extract(&recording(&s), &Default::default(), None).unwrap();
    assert_eq!(m.samples.len(), v.rows.len());
    for (a, b) in m.samples.iter().zip(&v.rows) {
        for (x, y) in a.q.iter().zip(&b.x1) {
            assert!((x - y).norm() <= 1e-5 * y.norm() + 1e-11, "{x} {y}");
        }
    }
    for f in [
        "vectors_bode_b1_y.svg",
        "vectors_bode_b2_z.svg",
        "vectors_polar.svg",
    ] {
        let t = std::fs::read_to_string(plot.join(f)).unwrap();
        assert!(t.contains("<svg"), "{f}");
    }
    // Without the keyphasor's role the WAV is refused.
    let bare = tmp("bare.toml");
    std::fs::write(&bare, "[probes]\nsensitivity_v_per_mm = 7.87\n[probes.channels]\nb1_y = 1\nb1_z = 2\nb2_y = 3\nb2_z = 4\n").unwrap();
    let o = cli([
        "vectors",
        "--signals",
        wav.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--config",
        bare.to_str().unwrap(),
    ]);
    assert!(one_line_error(&o).contains("keyphasor channel"), "{o:?}");
}

#[test]
fn bad_signal_files_exit_2_with_one_line() {
    let out = tmp("v.csv");
    let run = |name: &str, text: &str| {
        let p = tmp(name);
        std::fs::write(&p, text).unwrap();
        cli([
            "vectors",
            "--signals",
            p.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let e = one_line_error(&run(
        "nokp.csv",
        "time_s,b1_y,b1_z\n0,1e-6,1e-6\n0.001,1e-6,1e-6\n",
    ));
    assert!(e.contains("no keyphasor column"), "{e}");
    let e = one_line_error(&run(
        "uneven.csv",
        "# x\ntime_s,kp,b1_y,b1_z\n0,0,1e-6,1e-6\n0.001,0,1e-6,1e-6\n0.0025,0,1e-6,1e-6\n0.003,0,1e-6,1e-6\n0.004,0,1e-6,1e-6\n",
    ));
    assert!(e.contains("line 5") && e.contains("not uniform"), "{e}");
    let e = one_line_error(&run(
        "back.csv",
        "time_s,kp,b1_y,b1_z\n0,0,1e-6,1e-6\n0.001,0,1e-6,1e-6\n0.0005,0,1e-6,1e-6\n",
    ));
    assert!(
        e.contains("line 4") && e.contains("does not increase"),
        "{e}"
    );
    let e = one_line_error(&run(
        "row.csv",
        "time_s,kp,b1_y,b1_z\n0,0,1e-6,1e-6\n0.001,0,1e-6,abc\n",
    ));
    assert!(e.contains("line 3") && e.contains("`abc`"), "{e}");
    let e = one_line_error(&run(
        "col.csv",
        "time_s,kp,b1_y,b1_z,b1_x\n0,0,1e-6,1e-6,0\n",
    ));
    assert!(e.contains("unknown column `b1_x`"), "{e}");
    let e = one_line_error(&run(
        "flat.csv",
        "time_s,kp,b1_y,b1_z\n0,1,1e-6,1e-6\n0.001,1,1e-6,1e-6\n",
    ));
    assert!(e.contains("keyphasor"), "{e}");
    let e = one_line_error(&cli([
        "vectors",
        "--signals",
        "/nonexistent/x.csv",
        "--out",
        out.to_str().unwrap(),
    ]));
    assert!(e.contains("file not found"), "{e}");
}

/// A keyphasor fault (one missing pulse) is counted in the file's
/// `# rejected:` line and on stdout.
#[test]
fn keyphasor_faults_are_counted_in_the_output() {
    let s = short_paper();
    let mut kp = s.kp.clone();
    let start = (kp.len() / 2..kp.len()).find(|&i| kp[i] > 2.5).unwrap();
    for k in &mut kp[start..start + 60] {
        *k = 0.0;
    }
    let mut text = String::from("time_s,kp,b1_y,b1_z,b2_y,b2_z\n");
    for i in 0..s.len() {
        use std::fmt::Write as _;
        let _ = write!(text, "{:.9},{}", i as f64 / s.fs, kp[i]);
        for c in &s.y {
            let _ = write!(text, ",{:e}", c[i]);
        }
        text.push('\n');
    }
    let sig = tmp("fault.csv");
    std::fs::write(&sig, text).unwrap();
    let out = tmp("v.csv");
    let o = cli([
        "vectors",
        "--signals",
        sig.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.success(), "{o:?}");
    assert!(o.stdout.contains("period_jump 3"), "{}", o.stdout);
    let t = std::fs::read_to_string(&out).unwrap();
    assert!(
        t.contains("# rejected: no_reference=2 period_jump=3 "),
        "{t}"
    );
}
