//! One sample through the streaming order tracker
//! (`rotorid_core::streamtrack::StreamTracker`, f32, 4 probes): its
//! per-sample half is instantiated here; in the firmware this is a crate
//! of its own, built at `opt-level = 2` (the rest at `"z"`), so that the
//! per-sample path is compiled for speed and the rest for size.

use rotorid_core::streamtrack::{SampleOutcome, StreamTracker, BLOCK};

/// Probe channels (b1_y, b1_z, b2_y, b2_z).
pub const NC: usize = 4;

/// The order tracker of the firmware: f32, 4 probes, 16 samples of
/// history, no revolution buffer.
pub type Tracker = StreamTracker<f32, NC>;

/// The per-sample half of one sampling instant (`kp` the keyphasor, `y`
/// the probes) through `tracker` (`StreamTracker::push_sample`); what it
/// brought (a few flags, in a register), for `StreamTracker::finish_sample`
/// when it is not quiet (about once a revolution, in the caller's crate,
/// optimised for size).
#[inline(never)]
pub fn push(tracker: &mut Tracker, kp: f32, y: &[f32; NC]) -> SampleOutcome<f32> {
    tracker.push_sample(kp, y)
}

/// Sampling instants per block ([`push_block`]): a DMA transfer's half.
pub const BLOCK_LEN: usize = BLOCK;

/// The per-sample half of a block of instants from `from` on (`kp` the
/// keyphasor, `y` the probes) through `tracker`
/// (`StreamTracker::push_block`): up to the first instant whose outcome is
/// not quiet; that outcome, for `StreamTracker::finish_sample` in the
/// caller's crate, and the index to go on from.
#[inline(never)]
pub fn push_block(
    tracker: &mut Tracker,
    kp: &[f32; BLOCK],
    y: &[[f32; NC]; BLOCK],
    from: usize,
) -> (SampleOutcome<f32>, usize) {
    tracker.push_block(kp, y, from)
}
