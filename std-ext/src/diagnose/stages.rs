//! The wall-clock laps of the stages of
//! [`diagnose`](crate::diagnose::diagnose()) ([`Stages`]), reported in
//! [`Diagnosis::stages`](crate::diagnose::Diagnosis::stages).

/// Wall-clock laps of the stages of a diagnosis.
pub(crate) struct Stages {
    last: std::time::Instant,
    /// Each stage's name and duration (s), in order.
    pub laps: Vec<(&'static str, f64)>,
}

impl Stages {
    /// Starts the clock of the first stage.
    pub(crate) fn start() -> Self {
        Stages {
            last: std::time::Instant::now(),
            laps: Vec::new(),
        }
    }

    /// Records the time since the previous lap under `name`.
    pub(crate) fn lap(&mut self, name: &'static str) {
        let now = std::time::Instant::now();
        self.laps
            .push((name, now.duration_since(self.last).as_secs_f64()));
        self.last = now;
    }

    /// Records a stage timed by itself (`seconds`) and restarts the clock
    /// of the next lap.
    pub(crate) fn record(&mut self, name: &'static str, seconds: f64) {
        self.laps.push((name, seconds));
        self.last = std::time::Instant::now();
    }
}
