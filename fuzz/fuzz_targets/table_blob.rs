//! Untrusted input: any byte string handed to the firmware table parser.
//! The parser must reject what is not a valid table with an error, never
//! panic, and a table it accepts must answer every lookup without panicking,
//! with finite terms whenever it answers `Ok`.
//!
//! Round trip: a blob the desktop reader accepts is written again, read
//! back and written once more: the two written blobs are identical.
//!
//! Each input is parsed twice: as given, and with its last four bytes
//! replaced by the CRC-32 of the rest, so that mutations reach the field
//! checks behind the CRC instead of all failing at the checksum.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rotorid_core::table::{BearingTable, TableView};

fn probe<T, const NQ: usize, const NP: usize>(view: &TableView<'_, T>, speeds: &[T])
where
    T: rotorid_core::table::TableScalar,
    TableView<'static, T>: Sized,
    for<'a> TableView<'a, T>: BearingTable<T, NQ, NP>,
{
    let (lo, hi) = BearingTable::<T, NQ, NP>::speed_range(view);
    let mut all = speeds.to_vec();
    all.push(lo);
    all.push(hi);
    for &s in &all {
        if let Ok(terms) = BearingTable::<T, NQ, NP>::terms(view, s) {
            for row in terms.a.iter() {
                for z in row {
                    assert!(z.re.is_finite() && z.im.is_finite());
                }
            }
            for row in terms.b.iter() {
                for z in row {
                    assert!(z.re.is_finite() && z.im.is_finite());
                }
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    // Speeds to look up come from the first bytes, the blob is the rest.
    let (head, blob) = data.split_at(data.len().min(16));
    let speeds64: Vec<f64> = head
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect();
    let speeds32: Vec<f32> = speeds64.iter().map(|&s| s as f32).collect();
    let mut fixed = blob.to_vec();
    if fixed.len() >= 4 {
        let body = fixed.len() - 4;
        let crc = rotorid_core::crc32::crc32(&fixed[..body]);
        fixed[body..].copy_from_slice(&crc.to_le_bytes());
    }
    for bytes in [blob, fixed.as_slice()] {
        if let Ok(view) = TableView::<f64>::parse(bytes) {
            probe::<f64, 4, 3>(&view, &speeds64);
            probe::<f64, 2, 1>(&view, &speeds64);
        }
        if let Ok(view) = TableView::<f32>::parse(bytes) {
            probe::<f32, 4, 3>(&view, &speeds32);
            probe::<f32, 2, 1>(&view, &speeds32);
        }
        if let Ok((table, scalar)) = rotorid::tables::ModelTable::from_blob(bytes) {
            let once = table
                .to_blob(scalar)
                .expect("a table read from a blob writes");
            let (again, scalar2) =
                rotorid::tables::ModelTable::from_blob(&once).expect("a written blob reads back");
            assert_eq!(scalar2, scalar);
            let twice = again.to_blob(scalar2).expect("a table read back writes");
            assert_eq!(once, twice, "blob round trip is not stable");
        }
    }
});
