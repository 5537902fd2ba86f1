//! Table blob: round trip in f32 and f64, lookup semantics, and rejection of
//! every corrupted or truncated blob (an error, never a panic). Uses a
//! synthetic table so that it checks the format alone; the physics is in
//! `tables/reduction.rs`.

use crate::common::rng;
use nalgebra::DMatrix;
use num_complex::Complex64;
use rand::Rng;
use rotorid::core::parametrization::Structure;
use rotorid::core::scaling::ColumnScaling;
use rotorid::core::table::{
    BearingTable, Table, TableError, TableSetup, TableView, Terms, FORMAT_VERSION, HEADER_LEN,
};
use rotorid::reduce::PoleSets;
use rotorid::reduce::ReducedTerms;
use rotorid::tables::{ModelTable, Scalar};

/// 2 bearings (nodes 1, 27 of 27), 3 planes, `n_s` speeds, one pole, with
/// entries of realistic size (A ~ 1e8 N/m, B ~ Omega^2).
fn synthetic(n_s: usize) -> ModelTable {
    let mut rng = rng(0x9E37_79B9_7F4A_7C15);
    let mut next = || rng.random_range(-1.0..1.0);
    let terms = (0..n_s)
        .map(|s| {
            let omega = 100.0 + 37.5 * s as f64;
            let a = DMatrix::from_fn(4, 4, |_, _| Complex64::new(1e8 * next(), 1e7 * next()));
            let b = DMatrix::from_fn(4, 3, |_, _| {
                Complex64::new(omega * omega * next(), omega * omega * next())
            });
            ReducedTerms { omega, a, b }
        })
        .collect();
    ModelTable {
        model_name: "synthetic".into(),
        structure: Structure::physical(1),
        scaling: ColumnScaling::new(2.1e7, 325.0, 3.4e-4).unwrap(),
        n_nodes: 27,
        bearing_nodes: vec![0, 26],
        plane_nodes: vec![4, 10, 20],
        poles: PoleSets {
            a: vec![719.4],
            b: vec![],
        },
        terms,
    }
}

fn rel(a: Complex64, b: Complex64) -> f64 {
    (a - b).norm() / b.norm().max(1e-300)
}

#[test]
fn f64_round_trip_is_exact() {
    let t = synthetic(7);
    let blob = t.to_blob(Scalar::F64).unwrap();
    let (back, sc) = ModelTable::from_blob(&blob).unwrap();
    assert_eq!(sc, Scalar::F64);
    assert_eq!(back.terms, t.terms);
    assert_eq!(back.poles, t.poles);
    assert_eq!(back.bearing_nodes, t.bearing_nodes);
    assert_eq!(back.plane_nodes, t.plane_nodes);
    assert_eq!(back.n_nodes, 27);
    // Same bytes when written again.
    assert_eq!(back.to_blob(Scalar::F64).unwrap(), blob);
}

#[test]
fn f32_round_trip_is_rounding_only() {
    let t = synthetic(7);
    let blob = t.to_blob(Scalar::F32).unwrap();
    let (back, sc) = ModelTable::from_blob(&blob).unwrap();
    assert_eq!(sc, Scalar::F32);
    for (x, y) in back.terms.iter().zip(&t.terms) {
        assert!((x.omega - y.omega).abs() <= 1e-7 * y.omega);
        for (p, q) in
            x.a.iter()
                .chain(x.b.iter())
                .zip(y.a.iter().chain(y.b.iter()))
        {
            assert!((p.re - q.re).abs() <= 6e-8 * q.re.abs());
            assert!((p.im - q.im).abs() <= 6e-8 * q.im.abs());
        }
    }
    // f32 -> f64 -> f32 is the identity.
    assert_eq!(back.to_blob(Scalar::F32).unwrap(), blob);
    // The f64 reader refuses an f32 blob and vice versa.
    assert_eq!(
        TableView::<f64>::parse(&blob).unwrap_err(),
        TableError::ScalarType {
            expected: 8,
            found: 4
        }
    );
    let blob64 = t.to_blob(Scalar::F64).unwrap();
    assert!(matches!(
        TableView::<f32>::parse(&blob64),
        Err(TableError::ScalarType { .. })
    ));
}

#[test]
fn lookup_is_exact_on_the_grid_and_matches_the_desktop_between() {
    let t = synthetic(7);
    let blob = t.to_blob(Scalar::F64).unwrap();
    let view = TableView::<f64>::parse(&blob).unwrap();
    assert_eq!(
        (view.n_bearings(), view.n_planes(), view.n_speeds()),
        (2, 3, 7)
    );
    assert_eq!(view.bearing_node(1), Some(27));
    assert_eq!(view.plane_node(2), Some(21));
    let owned = Table::<f64, 4, 3, 7>::from_view(&view).unwrap();
    owned.validate().unwrap();
    for g in &t.terms {
        let x: Terms<f64, 4, 3> = view.terms(g.omega).unwrap();
        let y: Terms<f64, 4, 3> = owned.terms(g.omega).unwrap();
        assert_eq!(x, y);
        for r in 0..4 {
            for c in 0..4 {
                assert_eq!(x.a[r][c], g.a[(r, c)]);
            }
            for c in 0..3 {
                assert_eq!(x.b[r][c], g.b[(r, c)]);
            }
        }
    }
    for k in 0..60 {
        let omega = 100.0 + 225.0 * k as f64 / 60.0 + 0.01;
        let x: Terms<f64, 4, 3> = view.terms(omega).unwrap();
        let y: Terms<f64, 4, 3> = owned.terms(omega).unwrap();
        let d = t.interpolate(omega).unwrap();
        for r in 0..4 {
            for c in 0..4 {
                assert!(rel(x.a[r][c], d.a[(r, c)]) < 1e-13);
                assert_eq!(x.a[r][c], y.a[r][c]);
            }
            for c in 0..3 {
                assert!(rel(x.b[r][c], d.b[(r, c)]) < 1e-13);
                assert_eq!(x.b[r][c], y.b[r][c]);
            }
        }
    }
    let (lo, hi) = BearingTable::<f64, 4, 3>::speed_range(&view);
    assert_eq!((lo, hi), (100.0, 325.0));
    let at = |w: f64| BearingTable::<f64, 4, 3>::terms(&view, w).map(|_| ());
    assert_eq!(at(99.9), Err(TableError::OutOfRange));
    assert_eq!(at(325.1), Err(TableError::OutOfRange));
    assert_eq!(at(f64::NAN), Err(TableError::NonFinite));
    assert_eq!(at(f64::INFINITY), Err(TableError::NonFinite));
    assert_eq!(
        BearingTable::<f64, 2, 3>::terms(&view, 200.0).map(|_| ()),
        Err(TableError::Dimension)
    );
    assert_eq!(
        BearingTable::<f64, 4, 2>::terms(&view, 200.0).map(|_| ()),
        Err(TableError::Dimension)
    );
    assert_eq!(
        Table::<f64, 4, 3, 6>::from_view(&view).unwrap_err(),
        TableError::Dimension
    );
    // f32 view agrees with the f64 one to f32 precision.
    let blob32 = t.to_blob(Scalar::F32).unwrap();
    let v32 = TableView::<f32>::parse(&blob32).unwrap();
    let x: Terms<f32, 4, 3> = v32.terms(200.0).unwrap();
    let y: Terms<f64, 4, 3> = view.terms(200.0).unwrap();
    let scale = y.a.iter().flatten().map(|z| z.norm()).fold(0.0, f64::max);
    for r in 0..4 {
        for c in 0..4 {
            let d = Complex64::new(x.a[r][c].re as f64, x.a[r][c].im as f64) - y.a[r][c];
            assert!(d.norm() < 1e-6 * scale);
        }
    }
}

#[test]
fn every_flipped_byte_and_bit_is_rejected() {
    for scalar in [Scalar::F64, Scalar::F32] {
        let blob = synthetic(5).to_blob(scalar).unwrap();
        let mut bad = blob.clone();
        for i in 0..blob.len() {
            bad[i] ^= 0xFF;
            let r64 = TableView::<f64>::parse(&bad);
            let r32 = TableView::<f32>::parse(&bad);
            assert!(r64.is_err() && r32.is_err(), "byte {i} flipped accepted");
            bad[i] = blob[i];
        }
        // Every bit of every 7th byte (and of the whole header).
        for i in (0..blob.len()).filter(|i| i % 7 == 0 || *i < HEADER_LEN + 16) {
            for bit in 0..8 {
                bad[i] ^= 1 << bit;
                assert!(TableView::<f64>::parse(&bad).is_err());
                assert!(TableView::<f32>::parse(&bad).is_err());
                bad[i] = blob[i];
            }
        }
        assert_eq!(bad, blob);
    }
}

#[test]
fn every_truncation_and_extension_is_rejected() {
    let blob = synthetic(5).to_blob(Scalar::F64).unwrap();
    for cut in 0..blob.len() {
        let e = TableView::<f64>::parse(&blob[..cut]).unwrap_err();
        if cut < HEADER_LEN {
            assert!(matches!(
                e,
                TableError::Truncated { .. } | TableError::BadMagic
            ));
        } else {
            assert!(matches!(e, TableError::Length { .. }), "{cut}: {e:?}");
        }
    }
    let mut longer = blob.clone();
    longer.push(0);
    assert!(matches!(
        TableView::<f64>::parse(&longer),
        Err(TableError::Length { .. })
    ));
    assert!(TableView::<f64>::parse(&blob).is_ok());
    assert!(TableView::<f64>::parse(&[]).is_err());
}

/// Re-seals a modified blob with a correct CRC, so the value checks behind
/// the CRC are exercised.
fn reseal(mut b: Vec<u8>) -> Vec<u8> {
    let n = b.len() - 4;
    let crc = rotorid::core::crc32::crc32(&b[..n]);
    b[n..].copy_from_slice(&crc.to_le_bytes());
    b
}

#[test]
fn value_checks_behind_a_valid_crc() {
    let t = synthetic(5);
    let blob = t.to_blob(Scalar::F64).unwrap();
    let parse = |b: &[u8]| TableView::<f64>::parse(b).map(|_| ());
    // Layout: header 56, planes 3*2, bearings 2*2 -> poles at 66, speeds at 74,
    // data at 114.
    let mut b = blob.clone();
    b[0] = b'X';
    assert_eq!(parse(&reseal(b)), Err(TableError::BadMagic));
    let mut b = blob.clone();
    b[8] = 3;
    assert_eq!(
        parse(&reseal(b)),
        Err(TableError::UnsupportedVersion {
            found: 3,
            expected: 2
        })
    );
    let mut b = blob.clone();
    b[11] = 1;
    assert_eq!(parse(&reseal(b)), Err(TableError::Reserved));
    for i in 26..32 {
        let mut b = blob.clone();
        b[i] = 0x40;
        assert_eq!(parse(&reseal(b)), Err(TableError::Reserved), "byte {i}");
    }
    let mut b = blob.clone();
    b[10] = 2;
    assert!(matches!(
        parse(&reseal(b)),
        Err(TableError::ScalarType { found: 2, .. })
    ));
    // Formulation codes other than 1 (paper) and 2 (physical), orders
    // outside 1..=MAX_ORDER.
    for (off, val) in [
        (24usize, 0u8),
        (24, 3),
        (24, 255),
        (25, 0),
        (25, 9),
        (25, 255),
    ] {
        let mut b = blob.clone();
        b[off] = val;
        assert_eq!(
            parse(&reseal(b)),
            Err(TableError::BadStructure),
            "{off} {val}"
        );
    }
    // Scaling: not finite, zero, negative; too large for f32.
    for off in [32usize, 40, 48] {
        for x in [f64::NAN, f64::INFINITY, 0.0, -1.0] {
            let mut b = blob.clone();
            b[off..off + 8].copy_from_slice(&x.to_le_bytes());
            assert_eq!(parse(&reseal(b)), Err(TableError::BadScaling), "{off} {x}");
        }
    }
    let b32 = t.to_blob(Scalar::F32).unwrap();
    for x in [1e300, 1e-300] {
        let mut b = b32.clone();
        b[32..40].copy_from_slice(&f64::to_le_bytes(x));
        let b = reseal(b);
        assert_eq!(
            TableView::<f32>::parse(&b).map(|_| ()),
            Err(TableError::BadScaling)
        );
    }
    // Plane node 0, node beyond the shaft, repeated plane, bearings out of order.
    for (off, val) in [(56usize, 0u16), (56, 28), (58, 5), (62, 27)] {
        let mut b = blob.clone();
        b[off..off + 2].copy_from_slice(&val.to_le_bytes());
        assert_eq!(parse(&reseal(b)), Err(TableError::BadNode), "{off} {val}");
    }
    // Zero bearings, too many poles of A, of B, zero speeds.
    for (off, val) in [(14usize, 0u16), (18, 17), (18, 17 << 8)] {
        let mut b = blob.clone();
        b[off..off + 2].copy_from_slice(&val.to_le_bytes());
        assert_eq!(parse(&reseal(b)), Err(TableError::BadSize));
    }
    let mut b = blob.clone();
    b[20..24].copy_from_slice(&0u32.to_le_bytes());
    assert_eq!(parse(&reseal(b)), Err(TableError::BadSize));
    // A huge speed count is a size error or a length error, never an overflow.
    let mut b = blob.clone();
    b[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(parse(&reseal(b)).is_err());
    // Negative pole, NaN speed, decreasing speeds, NaN and infinite entries.
    let put =
        |b: &mut Vec<u8>, off: usize, x: f64| b[off..off + 8].copy_from_slice(&x.to_le_bytes());
    let mut b = blob.clone();
    put(&mut b, 66, -1.0);
    assert_eq!(parse(&reseal(b)), Err(TableError::BadPole));
    let mut b = blob.clone();
    put(&mut b, 82, f64::NAN);
    assert_eq!(parse(&reseal(b)), Err(TableError::NonFinite));
    let mut b = blob.clone();
    put(&mut b, 82, 90.0);
    assert_eq!(parse(&reseal(b)), Err(TableError::SpeedsNotIncreasing));
    let mut b = blob.clone();
    put(&mut b, 74, 0.0);
    assert_eq!(parse(&reseal(b)), Err(TableError::SpeedsNotIncreasing));
    for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut b = blob.clone();
        let off = blob.len() - 4 - 8;
        put(&mut b, off, x);
        assert_eq!(parse(&reseal(b)), Err(TableError::NonFinite));
    }
    // The writer refuses what the reader would refuse.
    let mut t2 = t.clone();
    t2.terms[1].a[(0, 0)].re = f64::NAN;
    assert!(t2.to_blob(Scalar::F64).is_err());
    let mut t2 = t.clone();
    t2.terms.swap(0, 1);
    assert!(t2.to_blob(Scalar::F64).is_err());
    let mut t2 = t.clone();
    t2.terms[0].a[(0, 0)].re = 1e39;
    assert!(t2.to_blob(Scalar::F32).is_err());
    assert!(t2.to_blob(Scalar::F64).is_ok());
    let t2 = t.clone().with_structure(Structure::paper(0));
    assert!(t2.to_blob(Scalar::F64).is_err());
    assert!(t2.to_rust_source(Scalar::F64).is_err());
    let mut t2 = t.clone();
    t2.scaling.unbalance = 1e-60; // fine in f64, 0 in f32
    assert!(t2.to_blob(Scalar::F64).is_ok());
    assert!(t2.to_blob(Scalar::F32).is_err());
    assert!(t2.to_rust_source(Scalar::F32).is_err());
    t2.scaling.unbalance = -1.0;
    assert!(t2.to_blob(Scalar::F64).is_err());
}

/// The same blob in format version 1: without the structure and scaling
/// (bytes 24..56), version 1, CRC resealed.
fn as_version_1(v2: &[u8]) -> Vec<u8> {
    let mut b = v2[..24].to_vec();
    b[8..10].copy_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&v2[HEADER_LEN..]);
    reseal(b)
}

#[test]
fn version_1_blobs_are_refused_with_a_clear_error() {
    assert_eq!(FORMAT_VERSION, 2);
    for scalar in [Scalar::F64, Scalar::F32] {
        let v1 = as_version_1(&synthetic(5).to_blob(scalar).unwrap());
        let want = TableError::UnsupportedVersion {
            found: 1,
            expected: 2,
        };
        assert_eq!(TableView::<f64>::parse(&v1).unwrap_err(), want);
        assert_eq!(TableView::<f32>::parse(&v1).unwrap_err(), want);
        // Whatever its length: the version is read before the length checks.
        assert_eq!(TableView::<f32>::parse(&v1[..12]).unwrap_err(), want);
        assert_eq!(
            want.to_string(),
            "table blob format version 1 is no longer read; rebuild it with `rotorid tables`"
        );
        let e = ModelTable::from_blob(&v1).unwrap_err();
        assert!(
            e.to_string().contains("rebuild it with `rotorid tables`"),
            "{e}"
        );
    }
}

#[test]
fn structure_and_scaling_round_trip_through_the_header() {
    for structure in [
        Structure::physical(1),
        Structure::paper(1),
        Structure::paper(2),
        Structure::physical(8),
    ] {
        let t = synthetic(3)
            .with_structure(structure)
            .with_scaling(ColumnScaling::new(3.7e7, 1571.0, 2.9e-4).unwrap());
        // f64: exact.
        let blob = t.to_blob(Scalar::F64).unwrap();
        assert_eq!(blob[24], if structure.is_complex() { 1 } else { 2 });
        assert_eq!(blob[25] as usize, structure.order);
        let view = TableView::<f64>::parse(&blob).unwrap();
        assert_eq!(view.structure(), structure);
        assert_eq!(view.scaling(), t.scaling);
        assert_eq!(TableSetup::scaling(&view), t.scaling);
        let (back, _) = ModelTable::from_blob(&blob).unwrap();
        assert_eq!((back.structure, back.scaling), (structure, t.scaling));
        let own = Table::<f64, 4, 3, 3>::from_view(&view).unwrap();
        assert_eq!((own.structure, own.scaling), (structure, t.scaling));
        // f32: the references are stored in f64 and rounded once when read.
        let blob = t.to_blob(Scalar::F32).unwrap();
        let view = TableView::<f32>::parse(&blob).unwrap();
        let want32 = ColumnScaling::<f32>::new(
            t.scaling.stiffness,
            t.scaling.omega_ref,
            t.scaling.unbalance,
        )
        .unwrap();
        assert_eq!(view.structure(), structure);
        assert_eq!(view.scaling(), want32);
        assert_eq!(view.stored_scaling(), t.scaling);
        let (back, sc) = ModelTable::from_blob(&blob).unwrap();
        assert_eq!(sc, Scalar::F32);
        assert_eq!((back.structure, back.scaling), (structure, t.scaling));
        assert_eq!(back.to_blob(Scalar::F32).unwrap(), blob);
        let own = Table::<f32, 4, 3, 3>::from_view(&view).unwrap();
        assert_eq!((own.structure, own.scaling), (structure, want32));
    }
}

#[test]
fn owned_table_lookup_never_panics_on_bad_contents() {
    let z = Complex64::new(0.0, 0.0);
    let mut t = Table::<f64, 2, 1, 3> {
        structure: Structure::physical(1),
        scaling: ColumnScaling::identity(),
        poles_a: [0.0; 16],
        n_poles_a: 99,
        poles_b: [0.0; 16],
        n_poles_b: 0,
        speeds: [1.0, 3.0, 2.0],
        a: [[[z; 2]; 2]; 3],
        b: [[[z; 1]; 2]; 3],
    };
    assert_eq!(t.terms(1.5).map(|_| ()), Err(TableError::Corrupt));
    assert!(t.validate().is_err());
    t.n_poles_a = 0;
    assert_eq!(t.validate(), Err(TableError::SpeedsNotIncreasing));
    // Unsorted speeds give some answer or an error, never a panic.
    for w in [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, f64::NAN] {
        let _ = t.terms(w);
    }
    t.speeds = [1.0, 2.0, 3.0];
    t.n_poles_b = 1;
    t.poles_b[0] = 1.5;
    t.validate().unwrap();
    assert_eq!(t.terms(1.5).map(|_| ()), Err(TableError::Pole));
    assert!(t.terms(1.7).is_ok());
}
