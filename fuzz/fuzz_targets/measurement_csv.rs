//! Untrusted input: any text as a measurement CSV. Either an error (with a
//! line number) or measurements whose every value is finite and whose
//! speeds are non-negative; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(m) = rotorid::io::measurement::parse_csv(text) {
        for s in &m.samples {
            assert!(s.omega.is_finite() && s.omega >= 0.0);
            assert_eq!(s.q.len(), 2 * m.n_bearings);
            assert!(s.q.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
        }
    }
});
