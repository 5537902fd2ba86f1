//! `simulate --plot` (Bode and polar plots), `simulate --nodes` (node-probe
//! columns), the plots of `identify --plot` and the error column of its
//! table.

use std::path::Path;

use num_complex::Complex64;

use crate::common::{cli, example, tmp, Output};
use rotorid::fe::assembly::{Dir, FeModel};
use rotorid::fe::response::{unbalance_response, Forcing};
use rotorid::io::measurement::{
    node_probe_columns, read_csv, to_csv_string, to_csv_string_with_node_probes, CsvLayout,
};
use rotorid::model::RotorModel;
use rotorid::report::simulate::{bode_series, channels, phase_with_breaks, polar_series};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Exit 2, one line on stderr containing every needle.
fn fails(args: &[&str], needles: &[&str]) {
    let Output { status, stderr, .. } = cli(args);
    assert_eq!(status, 2, "{args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr:?}");
    for n in needles {
        assert!(stderr.contains(n), "{stderr:?} lacks {n:?}");
    }
}

/// The polylines of `svg` drawn in colour `hex` (e.g. `#1F77B4`), each as
/// its list of points.
fn polylines(svg: &str, hex: &str) -> Vec<Vec<(f64, f64)>> {
    svg.split("<polyline")
        .skip(1)
        .filter(|p| p.contains(&format!("stroke=\"{hex}\"")))
        .map(|p| {
            let pts = p.split("points=\"").nth(1).unwrap();
            let pts = &pts[..pts.find('"').unwrap()];
            pts.split_whitespace()
                .map(|xy| {
                    let (x, y) = xy.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect()
        })
        .collect()
}

/// Texts of `svg` (the content of every `<text>` element, trimmed).
fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .map(|t| {
            let body = &t[t.find('>').unwrap() + 1..];
            body[..body.find("</text>").unwrap()].trim().to_string()
        })
        .collect()
}

#[test]
fn simulate_plot_writes_bode_and_polar_plots_of_the_written_data() {
    let csv = tmp("sweep.csv");
    let dir = tmp("plots");
    let o = cli([
        "simulate",
        "--model",
        "paper",
        "--out",
        s(&csv),
        "--rpm-max",
        "5000",
        "--plot",
        s(&dir),
    ]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    assert!(o.stderr.contains("simulate_bode.svg") && o.stderr.contains("simulate_polar.svg"));
    let m = read_csv(&csv).unwrap();
    let n = m.samples.len();
    assert_eq!(n, 100);
    let chans = channels(&m, &[], &[]);
    let names: Vec<&str> = chans.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["b1_y", "b1_z", "b2_y", "b2_z"]);

    // Bode: one amplitude and one phase series per channel, from the data.
    let (amp, phase) = bode_series(&m, &chans);
    assert_eq!(amp.len(), 4);
    assert_eq!(phase.len(), 4);
    for (c, (a, p)) in chans.iter().zip(amp.iter().zip(&phase)) {
        assert_eq!(a.label, c.name);
        for (k, smp) in m.samples.iter().enumerate() {
            assert_eq!(a.y[k], c.q[k].norm() * 1e6);
            assert!((a.x[k] - rotorid::units::rad_s_to_rpm(smp.omega)).abs() < 1e-9);
        }
        // Below the first critical speed the phase does not wrap.
        assert_eq!(p.y.len(), n);
        for (k, z) in c.q.iter().enumerate() {
            assert_eq!(p.y[k], z.arg().to_degrees());
        }
    }
    // Distinct colours, z dashed, y solid.
    for (i, a) in amp.iter().enumerate() {
        assert!(amp[..i].iter().all(|b| b.color != a.color), "{}", a.label);
        assert_eq!(a.dashed, a.label.ends_with("_z"));
    }
    let svg = std::fs::read_to_string(dir.join("simulate_bode.svg")).unwrap();
    let t = texts(&svg);
    for c in &names {
        assert_eq!(t.iter().filter(|x| x == c).count(), 1, "legend entry {c}");
    }
    // The solid y channels: one line in each panel (all speeds) and the
    // legend sample, in the series' own colour.
    for (a, hex) in [(&amp[0], "#1F77B4"), (&amp[2], "#2CA02C")] {
        let lines = polylines(&svg, hex);
        assert_eq!(lines.len(), 3, "{}", a.label);
        assert_eq!(lines[0].len(), n);
        assert_eq!(lines[1].len(), n);
        assert_eq!(lines[2].len(), 2);
        // The legend lies right of every data point.
        let data_right = lines[0].iter().map(|p| p.0).fold(0.0, f64::max);
        assert!(lines[2][0].0 > data_right, "{}", a.label);
    }

    // Polar: one curve per bearing channel, its points the phasors (um).
    let (polar, notes) = polar_series(&m, &chans);
    assert_eq!(polar.len(), 4);
    for (c, p) in chans.iter().zip(&polar) {
        assert_eq!(p.label, c.name);
        let re: Vec<f64> = c.q.iter().map(|z| z.re * 1e6).collect();
        let im: Vec<f64> = c.q.iter().map(|z| z.im * 1e6).collect();
        assert_eq!(p.x, re);
        assert_eq!(p.y, im);
    }
    // Round speeds 1000..5000 marked on each curve, at the phasor there.
    for rpm in ["1000", "2000", "3000", "4000", "5000"] {
        let at: Vec<_> = notes.iter().filter(|a| a.text == rpm).collect();
        assert_eq!(at.len(), 4, "{rpm}");
        let k = m
            .samples
            .iter()
            .position(|s| {
                (rotorid::units::rad_s_to_rpm(s.omega) - rpm.parse::<f64>().unwrap()).abs() < 1e-6
            })
            .unwrap();
        for (a, c) in at.iter().zip(&chans) {
            assert_eq!((a.x, a.y), (c.q[k].re * 1e6, c.q[k].im * 1e6));
        }
    }
    let svg = std::fs::read_to_string(dir.join("simulate_polar.svg")).unwrap();
    let lines = polylines(&svg, "#1F77B4");
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[0].len(), n);
    // Equal scales: the curve's pixel offsets are the phasors times one
    // factor on both axes (y pointing down).
    let first = lines[0][0];
    let (k, q) = chans[0]
        .q
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
        .unwrap();
    let q0 = chans[0].q[0];
    let (dx, dy) = (lines[0][k].0 - first.0, lines[0][k].1 - first.1);
    let (sx, sy) = (dx / ((q.re - q0.re) * 1e6), -dy / ((q.im - q0.im) * 1e6));
    assert!(
        (sx / sy - 1.0).abs() < 0.05,
        "x scale {sx} px/um, y scale {sy} px/um"
    );
    for f in ["simulate_bode.svg", "simulate_polar.svg"] {
        assert!(std::fs::read_to_string(dir.join(f))
            .unwrap()
            .starts_with("<svg"));
    }
}

#[test]
fn phase_breaks_where_it_wraps() {
    let q = [
        Complex64::from_polar(1.0, 170f64.to_radians()),
        Complex64::from_polar(1.0, (-170f64).to_radians()),
        Complex64::new(0.0, 0.0),
        Complex64::from_polar(1.0, 10f64.to_radians()),
    ];
    let (x, y) = phase_with_breaks(&[1.0, 2.0, 3.0, 4.0], &q);
    assert_eq!(x, [1.0, 1.5, 2.0, 3.0, 4.0]);
    assert!((y[0] - 170.0).abs() < 1e-12 && y[1].is_nan() && (y[2] + 170.0).abs() < 1e-12);
    assert!(y[3].is_nan() && (y[4] - 10.0).abs() < 1e-12);
}

#[test]
fn simulate_nodes_writes_the_fe_response_at_those_nodes() {
    let plain = tmp("plain.csv");
    let with = tmp("with.csv");
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--model",
            "paper",
            "--out",
            s(out),
            "--rpm-min",
            "1000",
            "--rpm-max",
            "9000",
            "--rpm-step",
            "2000",
        ];
        args.extend_from_slice(extra);
        let o = cli(args);
        assert_eq!(o.status, 0, "{}", o.stderr);
        o
    };
    run(&plain, &[]);
    let o = run(&with, &["--nodes", "3,14"]);
    assert!(o.stderr.contains("5 speeds x 8 channels"), "{}", o.stderr);
    let text = std::fs::read_to_string(&with).unwrap();
    let header = text.lines().find(|l| l.starts_with("speed_rpm")).unwrap();
    assert_eq!(
        header,
        "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im,\
         n3_y_re,n3_y_im,n3_z_re,n3_z_im,n14_y_re,n14_y_im,n14_z_re,n14_z_im"
    );
    // The bearing columns are those of the file without node probes.
    let plain_text = std::fs::read_to_string(&plain).unwrap();
    let rows = |t: &str| -> Vec<Vec<String>> {
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect()
    };
    let (a, b) = (rows(&plain_text), rows(&text));
    assert_eq!(a.len(), 5);
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).unwrap();
    let omegas: Vec<f64> = [1000.0, 3000.0, 5000.0, 7000.0, 9000.0]
        .iter()
        .map(|&r| rotorid::units::rpm_to_rad_s(r))
        .collect();
    let resp = unbalance_response(&fe, &Forcing::from_model(&model), &omegas).unwrap();
    for ((ra, rb), r) in a.iter().zip(&b).zip(&resp) {
        assert_eq!(rb.len(), 17);
        assert_eq!(ra[..], rb[..9]);
        let v: Vec<f64> = rb[9..].iter().map(|x| x.parse().unwrap()).collect();
        for (k, node) in [2usize, 13].iter().enumerate() {
            for (d, dir) in [Dir::Y, Dir::Z].iter().enumerate() {
                let want = r.q[fe.dof(*node, *dir)];
                let got = Complex64::new(v[4 * k + 2 * d], v[4 * k + 2 * d + 1]);
                assert!(
                    (got - want).norm() <= 1e-12 * want.norm(),
                    "node {node}: {got} vs {want}"
                );
            }
        }
    }
    // With noise: the bearing columns are still those without node probes.
    run(&plain, &["--noise", "0.01", "--seed", "4"]);
    run(
        &with,
        &[
            "--noise",
            "0.01",
            "--seed",
            "4",
            "--nodes",
            "3,14",
            "--layout",
            "amp-phase",
        ],
    );
    let (a, b) = (
        rows(&std::fs::read_to_string(&plain).unwrap()),
        rows(&std::fs::read_to_string(&with).unwrap()),
    );
    let a_amp: Vec<f64> = a
        .iter()
        .map(|r| {
            let (re, im): (f64, f64) = (r[1].parse().unwrap(), r[2].parse().unwrap());
            re.hypot(im)
        })
        .collect();
    let b_amp: Vec<f64> = b.iter().map(|r| r[1].parse().unwrap()).collect();
    for (x, y) in a_amp.iter().zip(&b_amp) {
        assert!((x - y).abs() <= 1e-14 * x, "{x} vs {y}");
    }
    assert!(std::fs::read_to_string(&with)
        .unwrap()
        .contains(",n3_y_amp,n3_y_phase_deg,n3_z_amp"));
    // Bad nodes: exit 2, one line naming the flag.
    let bad = tmp("bad.csv");
    for (nodes, needle) in [
        ("0", "not on the shaft"),
        ("99", "nodes 1..=27"),
        ("3,3", "given twice"),
        ("x", "--nodes"),
    ] {
        fails(
            &[
                "simulate",
                "--model",
                "paper",
                "--out",
                s(&bad),
                "--nodes",
                nodes,
            ],
            &["--nodes", needle],
        );
        assert!(!bad.exists());
    }
}

#[test]
fn node_probe_writer_appends_columns_and_checks_shapes() {
    let m = rotorid::io::measurement::Measurements {
        comments: vec!["a comment".into()],
        n_bearings: 1,
        node_probes: Vec::new(),
        node_q: Vec::new(),
        samples: vec![
            rotorid::io::measurement::Sample {
                omega: 10.0,
                q: vec![Complex64::new(1e-6, 2e-6), Complex64::new(-3e-6, 0.0)],
            },
            rotorid::io::measurement::Sample {
                omega: 20.0,
                q: vec![Complex64::new(0.5e-6, 0.0), Complex64::new(0.0, 1e-6)],
            },
        ],
    };
    assert_eq!(
        node_probe_columns(&[4], CsvLayout::AmplitudePhase),
        ["n5_y_amp", "n5_y_phase_deg", "n5_z_amp", "n5_z_phase_deg"]
    );
    let nq = vec![
        vec![Complex64::new(1.5e-6, -2.5e-6), Complex64::new(0.0, 4e-6)],
        vec![Complex64::new(7e-7, 0.0), Complex64::new(-1e-7, 1e-7)],
    ];
    let text = to_csv_string_with_node_probes(&m, CsvLayout::Complex, &[4], &nq).unwrap();
    let base = to_csv_string(&m, CsvLayout::Complex).unwrap();
    assert_eq!(
        text,
        base.replace("b1_z_im\n", "b1_z_im,n5_y_re,n5_y_im,n5_z_re,n5_z_im\n")
            .replace("-3e-6,0e0\n", "-3e-6,0e0,1.5e-6,-2.5e-6,0e0,4e-6\n")
            .replace("0e0,1e-6\n", "0e0,1e-6,7e-7,0e0,-1e-7,1e-7\n")
    );
    assert_eq!(
        to_csv_string_with_node_probes(&m, CsvLayout::Complex, &[], &[]).unwrap(),
        base
    );
    // Shapes: rows per sample, phasors per node, distinct nodes, finite.
    assert!(to_csv_string_with_node_probes(&m, CsvLayout::Complex, &[4], &nq[..1]).is_err());
    assert!(to_csv_string_with_node_probes(&m, CsvLayout::Complex, &[4, 5], &nq).is_err());
    assert!(to_csv_string_with_node_probes(
        &m,
        CsvLayout::Complex,
        &[4, 4],
        &vec![vec![Complex64::new(0.0, 0.0); 4]; 2]
    )
    .is_err());
    let mut nan = nq.clone();
    nan[1][0].re = f64::NAN;
    assert!(to_csv_string_with_node_probes(&m, CsvLayout::Complex, &[4], &nan).is_err());
}

#[test]
fn identify_plots_have_one_entry_per_kind_and_the_model_under_the_estimate() {
    let csv = tmp("sweep.csv");
    let dir = tmp("plots");
    let o = cli([
        "simulate",
        "--model",
        "paper",
        "--out",
        s(&csv),
        "--rpm-step",
        "250",
        "--noise",
        "0.001",
    ]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let o = cli([
        "identify",
        "--model",
        "paper",
        "--measurements",
        s(&csv),
        "--plot",
        s(&dir),
    ]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let campbell = std::fs::read_to_string(dir.join("campbell_identified.svg")).unwrap();
    let t = texts(&campbell);
    assert_eq!(
        t.iter().filter(|x| *x == "identified rotor").count(),
        1,
        "{t:?}"
    );
    assert_eq!(t.iter().filter(|x| *x == "model rotor").count(), 1, "{t:?}");
    assert!(!campbell.contains("identified mode"));
    // The 1X line is dashed in the plot and in the legend: more than one
    // black piece in the legend column.
    let black = polylines(&campbell, "#000000");
    let legend_x = |l: &Vec<(f64, f64)>| l.iter().all(|p| p.0 > 700.0);
    assert!(black.iter().filter(|l| legend_x(l)).count() >= 2);
    // Unbalance: per plane the model as a pale wide band drawn first, the
    // QRD/RLS path over it in the full colour, the reported estimate with
    // its 95 % band; every label once in the legend.
    let me = std::fs::read_to_string(dir.join("unbalance_me.svg")).unwrap();
    let t = texts(&me);
    for node in [5, 11, 21] {
        for kind in ["QRD/RLS path", "model", "reported", "reported, 95 %"] {
            let label = format!("node {node} {kind}");
            assert_eq!(
                t.iter().filter(|x| **x == label).count(),
                1,
                "{label}: {t:?}"
            );
        }
    }
    let band_at = me.find("stroke-width=\"8\"").unwrap();
    let line_at = me.find("stroke=\"#1F77B4\" stroke-width=\"2\"").unwrap();
    assert!(band_at < line_at);
}

#[test]
fn identify_marks_absolute_errors_where_the_model_value_is_zero() {
    let model = tmp("zero.toml");
    let text = std::fs::read_to_string(example("paper.toml")).unwrap();
    let text = text.replacen(
        "c = [500.0, 50.0, 100.0, 700.0]",
        "c = [500.0, 0.0, 100.0, 700.0]",
        1,
    );
    assert!(text.contains("c = [500.0, 0.0, 100.0, 700.0]"));
    std::fs::write(&model, text).unwrap();
    let csv = tmp("zero.csv");
    let o = cli([
        "simulate",
        "--model",
        s(&model),
        "--out",
        s(&csv),
        "--rpm-step",
        "250",
        "--noise",
        "0.001",
    ]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let o = cli(["identify", "--model", s(&model), "--measurements", s(&csv)]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let row = o
        .stdout
        .lines()
        .find(|l| l.starts_with("b1@1 cyz"))
        .unwrap();
    // value, std, model 0, absolute error with its unit, RLS, its error.
    assert!(row.contains("0.000000e0"), "{row}");
    assert_eq!(row.matches("N s/m").count(), 2, "{row}");
    let row = o
        .stdout
        .lines()
        .find(|l| l.starts_with("b1@1 cyy"))
        .unwrap();
    assert!(!row.contains("N s/m"), "relative: a bare number: {row}");
    let row = o
        .stdout
        .lines()
        .find(|l| l.starts_with("n5 phase_deg"))
        .unwrap();
    assert_eq!(row.matches(" deg").count(), 2, "{row}");
    assert!(
        o.stdout.contains("where the model value is 0: absolute"),
        "{}",
        o.stdout
    );
}
