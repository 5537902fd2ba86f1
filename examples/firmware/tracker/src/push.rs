//! One sample through the streaming order tracker
//! (`rotorid_core::streamtrack::StreamTracker`, f32, 4 probes). The
//! tracker's generic code is instantiated here: in the firmware this is a
//! crate of its own, built at `opt-level = 3` (the rest at `"z"`), so that
//! the per-sample path is compiled for speed.

use rotorid_core::streamtrack::{StreamAverage, StreamTracker};

/// Probe channels (b1_y, b1_z, b2_y, b2_z).
pub const NC: usize = 4;

/// The order tracker of the firmware: f32, 4 probes, 16 samples of
/// history, no revolution buffer.
pub type Tracker = StreamTracker<f32, NC>;

/// One sampling instant (`kp` the keyphasor, `y` the probes) through
/// `tracker`; the average it completed, if any.
#[inline(never)]
pub fn push(tracker: &mut Tracker, kp: f32, y: &[f32; NC]) -> Option<StreamAverage<f32, NC>> {
    tracker.push(kp, y).and_then(|o| o.average)
}
