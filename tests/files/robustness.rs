//! Untrusted input: randomly mutated model files (own and ROSS) and
//! measurement CSVs give an error or a valid result, never a panic.

use crate::common::{example, rng};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

fn example_text(name: &str) -> String {
    std::fs::read_to_string(example(name)).unwrap()
}

/// Random byte-level and token-level edits.
fn mutate(rng: &mut ChaCha8Rng, text: &str) -> String {
    let tokens = [
        "",
        "0",
        "-1",
        "1e400",
        "nan",
        "inf",
        "\"x\"",
        "[",
        "]",
        "=",
        ",",
        "\n",
        "[[bearing]]",
        "node = 99",
        "18446744073709551615",
        "-0",
        "1e-320",
        "true",
        "{",
        "}",
        ".",
    ];
    let mut b: Vec<u8> = text.as_bytes().to_vec();
    for _ in 0..rng.random_range(1..6) {
        if b.is_empty() {
            break;
        }
        let i = rng.random_range(0..b.len());
        match rng.random_range(0..4) {
            0 => b[i] = rng.random_range(32..127),
            1 => {
                b.remove(i);
            }
            2 => {
                let t = tokens[rng.random_range(0..tokens.len())].as_bytes();
                let j = (i + rng.random_range(0..8)).min(b.len());
                b.splice(i..j, t.iter().copied());
            }
            _ => {
                let j = (i + rng.random_range(0..40)).min(b.len());
                b.drain(i..j);
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

#[test]
fn mutated_model_files_never_panic() {
    let mut rng = rng(11);
    let own = example_text("paper.toml");
    let ross = example_text("paper_ross.toml");
    let (mut ok, mut err) = (0, 0);
    for i in 0..3000 {
        let base = if i % 2 == 0 { &own } else { &ross };
        let text = mutate(&mut rng, base);
        let r = if rotorid::io::model_file::is_ross(&text) {
            rotorid::io::ross::parse_ross(&text).map_err(|e| e.to_string())
        } else {
            rotorid::io::model_file::parse_model_file(&text)
                .map(|f| f.model)
                .map_err(|e| e.to_string())
        };
        match r {
            Ok(m) => {
                assert!(m.validate().is_ok());
                ok += 1;
            }
            Err(e) => {
                assert!(!e.is_empty() && !e.contains('\n'), "{e:?}");
                err += 1;
            }
        }
    }
    assert!(ok > 0 && err > 0, "ok {ok} err {err}");
}

#[test]
fn mutated_csv_never_panics() {
    let mut rng = rng(12);
    let mut base = String::from(
        "# c\nspeed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im\n",
    );
    for i in 0..20 {
        base.push_str(&format!(
            "{},1.5e-6,-2e-7,3e-9,4e-6,5e-6,6e-7,-7e-6,8e-8\n",
            50 * (i + 1)
        ));
    }
    let (mut ok, mut err) = (0, 0);
    for _ in 0..5000 {
        let text = mutate(&mut rng, &base);
        match rotorid::io::measurement::parse_csv(&text) {
            Ok(m) => {
                for s in &m.samples {
                    assert!(s.omega.is_finite() && s.omega >= 0.0);
                    assert_eq!(s.q.len(), 2 * m.n_bearings);
                    assert!(s.q.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
                }
                ok += 1;
            }
            Err(e) => {
                let e = e.to_string();
                assert!(!e.contains('\n'), "{e:?}");
                err += 1;
            }
        }
    }
    assert!(ok > 0 && err > 0, "ok {ok} err {err}");
    // Extreme speed overflows rad/s: an error, not an infinite speed.
    let e = rotorid::io::measurement::parse_csv(
        "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im\n1e308,0,0,0,0\n",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("line 2, column 1 (speed_rpm): too large"),
        "{e}"
    );
}
