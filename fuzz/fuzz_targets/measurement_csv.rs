//! Untrusted input: any text as a measurement CSV. Either an error (with a
//! line number) or measurements whose every value is finite and whose
//! speeds are non-negative; never a panic. Round trip: what parses is
//! written again (complex layout) and read back with bit-identical
//! phasors and the same speeds (to the writer's 12 significant digits of
//! rpm); the amplitude/phase writer either refuses or writes a file that
//! reads back.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rotorid::io::measurement::{parse_csv, to_csv_string, CsvLayout};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(m) = parse_csv(text) else {
        return;
    };
    for s in &m.samples {
        assert!(s.omega.is_finite() && s.omega >= 0.0);
        assert_eq!(s.q.len(), 2 * m.n_bearings);
        assert!(s.q.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
    }
    let written = to_csv_string(&m, CsvLayout::Complex).expect("parsed measurements write");
    let back = parse_csv(&written).expect("written measurements read back");
    assert_eq!(back.n_bearings, m.n_bearings);
    assert_eq!(back.samples.len(), m.samples.len());
    for (a, b) in m.samples.iter().zip(&back.samples) {
        for (x, y) in a.q.iter().zip(&b.q) {
            assert_eq!(
                (x.re.to_bits(), x.im.to_bits()),
                (y.re.to_bits(), y.im.to_bits()),
                "phasor {x} read back as {y}"
            );
        }
        let tol = 1e-11 * a.omega.abs().max(f64::MIN_POSITIVE);
        assert!(
            (a.omega - b.omega).abs() <= tol,
            "speed {} read back as {}",
            a.omega,
            b.omega
        );
    }
    if let Ok(amp) = to_csv_string(&m, CsvLayout::AmplitudePhase) {
        let back = parse_csv(&amp).expect("amplitude/phase file reads back");
        assert_eq!(back.samples.len(), m.samples.len());
    }
});
