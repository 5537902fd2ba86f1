//! Unit conversions at the edges (files, CLI, plots). Inside the code
//! everything is SI: speeds in rad/s.

use core::f64::consts::PI;

/// rev/min to rad/s: `Omega = 2 pi rpm / 60`.
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * PI / 30.0
}

/// rad/s to rev/min: `rpm = 60 Omega / (2 pi)`.
pub fn rad_s_to_rpm(omega: f64) -> f64 {
    omega * 30.0 / PI
}

/// rad/s to Hz.
pub fn rad_s_to_hz(omega: f64) -> f64 {
    omega / (2.0 * PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpm_round_trip() {
        assert!((rpm_to_rad_s(15000.0) - 1_570.796_326_794_896_6).abs() < 1e-9);
        assert!((rad_s_to_rpm(rpm_to_rad_s(6111.0)) - 6111.0).abs() < 1e-9);
    }
}
