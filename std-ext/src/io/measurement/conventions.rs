//! Instrument conventions of a measurement file (SPEC section 7): the unit
//! and kind of the amplitudes and the meaning of the phase, declared by a
//! comment line before the header,
//!
//! ```text
//! # conventions: amplitude_unit=um amplitude=pk-pk phase=lag
//! ```
//!
//! and overridden key by key on the command line (`--amplitude-unit`,
//! `--amplitude`, `--phase`). rotorid's own convention ([`Conventions`]'s
//! `Default`: metres, zero-to-peak, `arg Y`) is the internal one; a file is
//! turned into it as it is read, so nothing after the reader knows how the
//! file was written.
//!
//! # The mapping
//!
//! With the phasor convention of SPEC section 2 a probe signal is
//!
//! ```text
//! x(t) = Re{ Y exp(j Omega t) } = |Y| cos(Omega t + arg Y)        (m)
//! ```
//!
//! with `t = 0` at the keyphasor event. A file value `A` (amplitude) or
//! `s_file` (a `_std` column) in unit `u` (metres per unit: `m` 1, `mm`
//! 1e-3, `um` 1e-6, `mil` 25.4e-6) and kind `k` becomes
//!
//! ```text
//! |Y| = c_k u A,     std = c_k u s_file,
//! c_k = 1 (0-pk),  1/2 (pk-pk: the peak-to-peak swing of x(t) is 2 |Y|),
//!       sqrt 2 (rms: the rms of x(t) over a revolution is |Y| / sqrt 2).
//! ```
//!
//! **Phase.** `phase=arg`: the written phase is `arg Y`. `phase=lag`: the
//! written phase `phi` is the lag from the keyphasor event to the next
//! positive peak of `x(t)`, the phase API 670 monitoring systems and ROSS
//! report. The peaks of `x(t)` are where `Omega t + arg Y = 2 pi n`, so the
//! first one at or after `t = 0` is at
//!
//! ```text
//! Omega t_peak = -arg Y  (mod 2 pi),   i.e.   phi = -arg Y  (mod 360 deg),
//! arg Y = -phi,          Y = c_k u A exp(-j phi).
//! ```
//!
//! A lag grows as the response falls behind the keyphasor (through a
//! resonance it rises by about 180 deg), where `arg Y` falls.
//!
//! **Layouts.** In the amplitude/phase layout the two rules above give `Y`
//! directly. In the re/im layout the written phasor `W = re + j im` is the
//! instrument's vector, `|W| = A` and `arg W` its phase, so
//!
//! ```text
//! phase=arg:  Y = c_k u W,        phase=lag:  Y = c_k u conj(W).
//! ```
//!
//! Node-probe columns follow the same rules, `_std` columns are scaled by
//! `c_k u` only.
//!
//! **ROSS.** `ForcedResponseResults.data_magnitude(probe)` and
//! `.data_phase(probe, phase_units="deg")` (ROSS 3.1,
//! `Orbit.calculate_amplitude`: amplitude `|P|`, phase
//! `2 pi - mod(arg P, 2 pi)` for the probe reading `P`) are read with
//! `amplitude_unit=m amplitude=0-pk phase=lag`; with
//! `amplitude_units="um pkpk"` that is `amplitude_unit=um amplitude=pk-pk`.
//! ROSS's raw complex response (`forced_resp`) is `arg`-convention:
//! `amplitude_unit=m amplitude=0-pk phase=arg`, rotorid's own.

use std::fmt;
use std::str::FromStr;

use num_complex::Complex64;
use thiserror::Error;

/// Metres per mil (a thousandth of an inch, exactly 25.4e-6 m).
pub const MIL_M: f64 = 25.4e-6;

/// The comment that declares a file's conventions: `# conventions: ...`
/// (after the `#` and any spaces).
pub const CONVENTIONS_PREFIX: &str = "conventions:";

/// The length unit of amplitudes (and `_std` columns) in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AmplitudeUnit {
    /// Metres (`m`), rotorid's own.
    #[default]
    M,
    /// Millimetres (`mm`, 1e-3 m).
    Mm,
    /// Micrometres (`um`, 1e-6 m).
    Um,
    /// Mils (`mil`, a thousandth of an inch: 25.4e-6 m).
    Mil,
}

/// What an amplitude measures: the swing of `x(t) = |Y| cos(Omega t + arg Y)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AmplitudeKind {
    /// Zero to peak (`0-pk`): `|Y|`, rotorid's own.
    #[default]
    ZeroPeak,
    /// Peak to peak (`pk-pk`): `2 |Y|`.
    PeakPeak,
    /// Root mean square over a revolution (`rms`): `|Y| / sqrt 2`.
    Rms,
}

/// What a written phase is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PhaseConvention {
    /// `arg Y` (`arg`), rotorid's own.
    #[default]
    Arg,
    /// The lag from the keyphasor event to the next positive peak (`lag`):
    /// `phi = -arg Y (mod 360 deg)`.
    Lag,
}

impl AmplitudeUnit {
    /// Every unit, in the order of the SPEC.
    pub const ALL: [AmplitudeUnit; 4] = [
        AmplitudeUnit::M,
        AmplitudeUnit::Mm,
        AmplitudeUnit::Um,
        AmplitudeUnit::Mil,
    ];

    /// The name in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            AmplitudeUnit::M => "m",
            AmplitudeUnit::Mm => "mm",
            AmplitudeUnit::Um => "um",
            AmplitudeUnit::Mil => "mil",
        }
    }

    /// Metres per unit `u`: 1, 1e-3, 1e-6, 25.4e-6.
    pub fn metres(self) -> f64 {
        match self {
            AmplitudeUnit::M => 1.0,
            AmplitudeUnit::Mm => 1e-3,
            AmplitudeUnit::Um => 1e-6,
            AmplitudeUnit::Mil => MIL_M,
        }
    }

    /// `v` (in this unit) in metres, `u v`. Millimetres and micrometres
    /// divide by the exact 1e3 and 1e6 (one rounding), metres are `v`
    /// itself.
    pub fn to_metres(self, v: f64) -> f64 {
        match self {
            AmplitudeUnit::M => v,
            AmplitudeUnit::Mm => v / 1e3,
            AmplitudeUnit::Um => v / 1e6,
            AmplitudeUnit::Mil => v * MIL_M,
        }
    }
}

impl AmplitudeKind {
    /// Every kind, in the order of the SPEC.
    pub const ALL: [AmplitudeKind; 3] = [
        AmplitudeKind::ZeroPeak,
        AmplitudeKind::PeakPeak,
        AmplitudeKind::Rms,
    ];

    /// The name in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            AmplitudeKind::ZeroPeak => "0-pk",
            AmplitudeKind::PeakPeak => "pk-pk",
            AmplitudeKind::Rms => "rms",
        }
    }

    /// The factor `c_k` from this kind to zero-to-peak: 1, 1/2, sqrt 2.
    pub fn to_zero_peak(self) -> f64 {
        match self {
            AmplitudeKind::ZeroPeak => 1.0,
            AmplitudeKind::PeakPeak => 0.5,
            AmplitudeKind::Rms => std::f64::consts::SQRT_2,
        }
    }
}

impl PhaseConvention {
    /// Both conventions.
    pub const ALL: [PhaseConvention; 2] = [PhaseConvention::Arg, PhaseConvention::Lag];

    /// The name in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PhaseConvention::Arg => "arg",
            PhaseConvention::Lag => "lag",
        }
    }
}

/// The conventions of a file's values, each of the three keys of the
/// `# conventions:` line. `Default` is rotorid's own (metres, 0-pk, `arg
/// Y`), which reads a file exactly as a file without the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Conventions {
    /// `amplitude_unit`: unit of amplitudes, re/im values and `_std`.
    pub amplitude_unit: AmplitudeUnit,
    /// `amplitude`: zero-to-peak, peak-to-peak or rms.
    pub amplitude: AmplitudeKind,
    /// `phase`: `arg Y` or the lag to the next positive peak.
    pub phase: PhaseConvention,
}

impl Conventions {
    /// rotorid's own conventions (the `Default`).
    pub fn is_default(&self) -> bool {
        *self == Conventions::default()
    }

    /// A written amplitude (or `_std` value) `a` in metres, zero-to-peak:
    /// `c_k u a` (module docs). Exactly `a` for the default conventions.
    pub fn amplitude_to_metres(&self, a: f64) -> f64 {
        let m = self.amplitude_unit.to_metres(a);
        match self.amplitude {
            AmplitudeKind::ZeroPeak => m,
            AmplitudeKind::PeakPeak => 0.5 * m,
            AmplitudeKind::Rms => std::f64::consts::SQRT_2 * m,
        }
    }

    /// A written phase `phi` (degrees) as `arg Y` (degrees): `phi` itself
    /// for `arg`; for `lag`, `-phi` reduced to `(-180, 180]` (the reduction
    /// is exact in floating point: `phi mod 360` by `rem_euclid`, then
    /// `360 - r` for `r > 180`, exact by Sterbenz's lemma).
    pub fn arg_deg(&self, phi: f64) -> f64 {
        match self.phase {
            PhaseConvention::Arg => phi,
            PhaseConvention::Lag => {
                let r = phi.rem_euclid(360.0);
                if r > 180.0 {
                    360.0 - r
                } else {
                    -r
                }
            }
        }
    }

    /// The phasor `Y` (m, rotorid's convention) of a written amplitude `a`
    /// and phase `phi` (degrees): `Y = c_k u a exp(j arg_deg(phi))`.
    pub fn polar_to_internal(&self, a: f64, phi: f64) -> Complex64 {
        Complex64::from_polar(self.amplitude_to_metres(a), self.arg_deg(phi).to_radians())
    }

    /// The phasor `Y` (m, rotorid's convention) of a written re/im pair
    /// `w = re + j im`: `c_k u w` (`arg`) or `c_k u conj(w)` (`lag`).
    pub fn phasor_to_internal(&self, w: Complex64) -> Complex64 {
        let w = match self.phase {
            PhaseConvention::Arg => w,
            PhaseConvention::Lag => w.conj(),
        };
        Complex64::new(
            self.amplitude_to_metres(w.re),
            self.amplitude_to_metres(w.im),
        )
    }

    /// These conventions with the keys `declared` gives replaced.
    pub fn with(self, declared: &DeclaredConventions) -> Conventions {
        Conventions {
            amplitude_unit: declared.amplitude_unit.unwrap_or(self.amplitude_unit),
            amplitude: declared.amplitude.unwrap_or(self.amplitude),
            phase: declared.phase.unwrap_or(self.phase),
        }
    }
}

impl fmt::Display for Conventions {
    /// The text of a `# conventions:` line after the colon, every key:
    /// `amplitude_unit=m amplitude=0-pk phase=arg`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "amplitude_unit={} amplitude={} phase={}",
            self.amplitude_unit.name(),
            self.amplitude.name(),
            self.phase.name()
        )
    }
}

/// Conventions as a file's `# conventions:` line or the command line
/// declares them: any subset of the three keys (`None`: not given).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DeclaredConventions {
    /// `amplitude_unit=...`.
    pub amplitude_unit: Option<AmplitudeUnit>,
    /// `amplitude=...`.
    pub amplitude: Option<AmplitudeKind>,
    /// `phase=...`.
    pub phase: Option<PhaseConvention>,
}

impl DeclaredConventions {
    /// No key given.
    pub fn is_empty(&self) -> bool {
        *self == DeclaredConventions::default()
    }

    /// These keys, with those `over` gives replacing them (the command
    /// line over a file's line).
    pub fn overridden_by(self, over: &DeclaredConventions) -> DeclaredConventions {
        DeclaredConventions {
            amplitude_unit: over.amplitude_unit.or(self.amplitude_unit),
            amplitude: over.amplitude.or(self.amplitude),
            phase: over.phase.or(self.phase),
        }
    }

    /// Parses the text after `conventions:`: `key=value` pairs separated by
    /// white space, each key at most once, any subset of `amplitude_unit`
    /// (`m`, `mm`, `um`, `mil`), `amplitude` (`0-pk`, `pk-pk`, `rms`) and
    /// `phase` (`arg`, `lag`). An empty text declares nothing.
    pub fn parse(text: &str) -> Result<DeclaredConventions, ConventionsError> {
        let mut d = DeclaredConventions::default();
        for token in text.split_whitespace() {
            let Some((key, value)) = token.split_once('=') else {
                return Err(ConventionsError::NotKeyValue {
                    token: crate::io::clip(token),
                });
            };
            let twice = || ConventionsError::DuplicateKey {
                key: key.to_string(),
            };
            match key {
                "amplitude_unit" => {
                    if d.amplitude_unit.is_some() {
                        return Err(twice());
                    }
                    d.amplitude_unit = Some(value.parse()?);
                }
                "amplitude" => {
                    if d.amplitude.is_some() {
                        return Err(twice());
                    }
                    d.amplitude = Some(value.parse()?);
                }
                "phase" => {
                    if d.phase.is_some() {
                        return Err(twice());
                    }
                    d.phase = Some(value.parse()?);
                }
                other => {
                    return Err(ConventionsError::UnknownKey {
                        key: crate::io::clip(other),
                    })
                }
            }
        }
        Ok(d)
    }
}

/// The declaration of a comment's text (the line after `#`), `None` when
/// it is not a `# conventions:` line (free text).
pub fn parse_conventions_comment(
    comment: &str,
) -> Option<Result<DeclaredConventions, ConventionsError>> {
    comment
        .trim_start()
        .strip_prefix(CONVENTIONS_PREFIX)
        .map(DeclaredConventions::parse)
}

/// What is wrong with a declared convention. In a file it comes with its
/// line ([`super::MeasurementError::Conventions`]).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ConventionsError {
    /// A key other than `amplitude_unit`, `amplitude`, `phase`.
    #[error("unknown key `{key}` in the `# conventions:` line (known: amplitude_unit, amplitude, phase)")]
    UnknownKey {
        /// The key as written (cut to 40 characters).
        key: String,
    },
    /// A value a key does not take.
    #[error("unknown value `{value}` for `{key}` (expected one of: {expected})")]
    UnknownValue {
        /// The key.
        key: &'static str,
        /// The value as written (cut to 40 characters).
        value: String,
        /// The values the key takes, comma-separated.
        expected: &'static str,
    },
    /// A key given twice in the line.
    #[error("`{key}` is given twice in the `# conventions:` line")]
    DuplicateKey {
        /// The key.
        key: String,
    },
    /// A word that is not `key=value`.
    #[error(
        "`{token}` in the `# conventions:` line is not `key=value` (e.g. `amplitude_unit=um`)"
    )]
    NotKeyValue {
        /// The word (cut to 40 characters).
        token: String,
    },
    /// A second `# conventions:` line.
    #[error("a second `# conventions:` line (the first is line {first}): a file declares its conventions once")]
    SecondLine {
        /// 1-based line of the first one.
        first: usize,
    },
    /// A `# conventions:` line after the header.
    #[error("the `# conventions:` line must come before the header (line {header})")]
    AfterHeader {
        /// 1-based line of the header.
        header: usize,
    },
}

impl FromStr for AmplitudeUnit {
    type Err = ConventionsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        AmplitudeUnit::ALL
            .into_iter()
            .find(|u| u.name() == s)
            .ok_or_else(|| ConventionsError::UnknownValue {
                key: "amplitude_unit",
                value: crate::io::clip(s),
                expected: "m, mm, um, mil",
            })
    }
}

impl FromStr for AmplitudeKind {
    type Err = ConventionsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        AmplitudeKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| ConventionsError::UnknownValue {
                key: "amplitude",
                value: crate::io::clip(s),
                expected: "0-pk, pk-pk, rms",
            })
    }
}

impl FromStr for PhaseConvention {
    type Err = ConventionsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        PhaseConvention::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| ConventionsError::UnknownValue {
                key: "phase",
                value: crate::io::clip(s),
                expected: "arg, lag",
            })
    }
}

impl fmt::Display for AmplitudeUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl fmt::Display for AmplitudeKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl fmt::Display for PhaseConvention {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lag_is_minus_arg_and_the_reduction_is_exact() {
        let lag = Conventions {
            phase: PhaseConvention::Lag,
            ..Conventions::default()
        };
        for (phi, arg) in [
            (0.0, 0.0),
            (30.0, -30.0),
            (330.0, 30.0),
            (360.0, 0.0),
            (180.0, -180.0),
            (-90.0, 90.0),
            (725.0, -5.0),
        ] {
            assert_eq!(lag.arg_deg(phi), arg, "lag {phi}");
        }
        // x(t) = |Y| cos(Omega t + arg Y) peaks first at Omega t = lag.
        let y = lag.polar_to_internal(1.0, 100.0);
        let x = |wt: f64| (y * Complex64::from_polar(1.0, wt)).re;
        let peak = 100f64.to_radians();
        assert!((x(peak) - 1.0).abs() < 1e-15);
        assert!(x(peak - 1e-3) < x(peak) && x(peak + 1e-3) < x(peak));
    }

    #[test]
    fn keys_values_and_errors() {
        let d = DeclaredConventions::parse(" amplitude_unit=mil  phase=lag ").unwrap();
        assert_eq!(d.amplitude_unit, Some(AmplitudeUnit::Mil));
        assert_eq!(d.amplitude, None);
        assert_eq!(d.phase, Some(PhaseConvention::Lag));
        assert!(DeclaredConventions::parse("").unwrap().is_empty());
        assert!(matches!(
            DeclaredConventions::parse("unit=um"),
            Err(ConventionsError::UnknownKey { .. })
        ));
        assert!(matches!(
            DeclaredConventions::parse("amplitude=peak"),
            Err(ConventionsError::UnknownValue {
                key: "amplitude",
                ..
            })
        ));
        assert!(matches!(
            DeclaredConventions::parse("phase=lag phase=arg"),
            Err(ConventionsError::DuplicateKey { .. })
        ));
        assert!(matches!(
            DeclaredConventions::parse("phase"),
            Err(ConventionsError::NotKeyValue { .. })
        ));
        assert_eq!(parse_conventions_comment(" source: rig A"), None);
        let all = Conventions {
            amplitude_unit: AmplitudeUnit::Um,
            amplitude: AmplitudeKind::PeakPeak,
            phase: PhaseConvention::Lag,
        };
        let text = all.to_string();
        assert_eq!(text, "amplitude_unit=um amplitude=pk-pk phase=lag");
        assert_eq!(
            Conventions::default().with(&DeclaredConventions::parse(&text).unwrap()),
            all
        );
    }

    #[test]
    fn scale_factors() {
        let c = |u, k| Conventions {
            amplitude_unit: u,
            amplitude: k,
            phase: PhaseConvention::Arg,
        };
        assert_eq!(
            c(AmplitudeUnit::Um, AmplitudeKind::PeakPeak).amplitude_to_metres(50.0),
            25e-6
        );
        assert_eq!(
            c(AmplitudeUnit::Mil, AmplitudeKind::ZeroPeak).amplitude_to_metres(2.0),
            50.8e-6
        );
        let rms = c(AmplitudeUnit::Mm, AmplitudeKind::Rms).amplitude_to_metres(1.0);
        assert!((rms - 2f64.sqrt() * 1e-3).abs() < 1e-18);
        // The default reads every value as it stands, bit for bit.
        for v in [1.2e-9, -3.4e-10, 5e-324, 1.0] {
            assert_eq!(
                Conventions::default().amplitude_to_metres(v).to_bits(),
                v.to_bits()
            );
        }
    }
}
