//! Writes a recording for the `rotorid vectors` benchmark: the paper rotor
//! at balance grade G6.3 run up from 1500 to 9000 rpm in 60 s, 4 probes
//! (b1_y, b1_z, b2_y, b2_z: channels 0..3, volts at 7.87 V/mm, a 1 mm
//! gap, 0.5 um sample noise) and a 0..5 V keyphasor (channel 4), 25.6 kHz,
//! 32-bit float samples of full scale 20 V; and the same as the SPEC's
//! signals CSV when a second path is given.
//!
//! `cargo run --release --example signals_wav -- OUT.wav [OUT.csv]`

use std::f64::consts::PI;
use std::io::Write;

use num_complex::Complex64;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let wav = args.next().ok_or("usage: signals_wav OUT.wav [OUT.csv]")?;
    let csv = args.next();
    let (fs, seconds) = (25_600.0, 60.0);
    let (rpm0, rpm1) = (1500.0, 9000.0);
    let paper = rotorid::RotorModel::paper();
    let model =
        rotorid::simulate::at_balance_grade(&paper, 6.3, rotorid::units::rpm_to_rad_s(15000.0))
            .ok_or("no unbalance")?;
    // The response on a grid of 1000 speeds, linear in between.
    let (w0, w1) = (
        rotorid::units::rpm_to_rad_s(rpm0),
        rotorid::units::rpm_to_rad_s(rpm1),
    );
    let grid: Vec<f64> = (0..1000)
        .map(|i| rotorid::units::rad_s_to_rpm(w0 + (w1 - w0) * i as f64 / 999.0))
        .collect();
    let m = rotorid::simulate(
        &model,
        &rotorid::SimOptions {
            speeds_rpm: grid,
            ..Default::default()
        },
    )?;
    let resp: Vec<Vec<Complex64>> = m.samples.iter().map(|s| s.q.clone()).collect();
    let alpha = (w1 - w0) / seconds;
    let n = (fs * seconds) as usize;
    let spec = hound::WavSpec {
        channels: 5,
        sample_rate: fs as u32,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut w = hound::WavWriter::create(&wav, spec)?;
    let mut c = match &csv {
        Some(p) => {
            let mut f = std::io::BufWriter::new(std::fs::File::create(p)?);
            writeln!(f, "time_s,kp,b1_y,b1_z,b2_y,b2_z")?;
            Some(f)
        }
        None => None,
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let noise = Normal::new(0.0, 0.5e-6)?;
    for i in 0..n {
        let t = i as f64 / fs;
        let omega = w0 + alpha * t;
        let theta = 0.3 + w0 * t + 0.5 * alpha * t * t;
        let u = (omega - w0) / (w1 - w0) * 999.0;
        let k = (u.floor() as usize).min(998);
        let f = u - k as f64;
        let phi = (theta + PI).rem_euclid(2.0 * PI) - PI;
        let kp = 5.0
            * ((phi / 0.1 + 0.5).clamp(0.0, 1.0)).min(((1.0 - phi) / 0.1 + 0.5).clamp(0.0, 1.0));
        let e = Complex64::from_polar(1.0, theta);
        let mut y = [0.0; 4];
        for (ch, yc) in y.iter_mut().enumerate() {
            let q = resp[k][ch] * (1.0 - f) + resp[k + 1][ch] * f;
            *yc = 1e-3 + (q * e).re + noise.sample(&mut rng);
        }
        for yc in &y {
            w.write_sample((yc * 7870.0 / 20.0) as f32)?;
        }
        w.write_sample((kp / 20.0) as f32)?;
        if let Some(c) = c.as_mut() {
            writeln!(c, "{t:.9},{kp},{:e},{:e},{:e},{:e}", y[0], y[1], y[2], y[3])?;
        }
    }
    w.finalize()?;
    Ok(())
}
