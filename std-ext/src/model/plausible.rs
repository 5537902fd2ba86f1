//! Physically plausible ranges of a model's quantities, checked when a
//! model file (rotorid's own or ROSS) is loaded, so that a value such as
//! `1e300` or `1e-300` is refused with the name of its field instead of
//! surfacing later as a singular matrix or an overflow.
//!
//! The bounds are deliberately wide (a watch spindle to a turbine-generator
//! train, foams to tungsten): anything outside them is a typing or unit
//! error, not a rotor.

/// A closed range `[lo, hi]` with its unit, for messages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// Smallest accepted value.
    pub lo: f64,
    /// Largest accepted value.
    pub hi: f64,
    /// Unit of the quantity (for messages).
    pub unit: &'static str,
}

/// Shaft section or element length: 10 um to 1 km.
pub const LENGTH: Range = Range {
    lo: 1e-5,
    hi: 1e3,
    unit: "m",
};
/// Shaft or disk outer diameter, disk thickness: 10 um to 100 m.
pub const DIAMETER: Range = Range {
    lo: 1e-5,
    hi: 1e2,
    unit: "m",
};
/// Young's modulus: any positive value up to 10 TPa. A tiny modulus is
/// how ROSS models carry the mass of an impeller or a sleeve on the shaft
/// (a layer of a material of, e.g., 6.9 kPa, as in ROSS's compressor
/// example): valid, not a typing error.
pub const YOUNG: Range = Range {
    lo: f64::MIN_POSITIVE,
    hi: 1e13,
    unit: "Pa",
};
/// Shear modulus: any positive value up to 10 TPa (as [`YOUNG`]).
pub const SHEAR: Range = Range {
    lo: f64::MIN_POSITIVE,
    hi: 1e13,
    unit: "Pa",
};
/// Density: 1 kg/m^3 (foams) to 100000 kg/m^3.
pub const DENSITY: Range = Range {
    lo: 1.0,
    hi: 1e5,
    unit: "kg/m^3",
};
/// Disk or pedestal mass: 1 mg to 10000 t.
pub const MASS: Range = Range {
    lo: 1e-6,
    hi: 1e7,
    unit: "kg",
};
/// Disk moment of inertia: 1e-15 to 1e9 kg m^2, or exactly 0 (see
/// [`check_inertia`]).
pub const INERTIA: Range = Range {
    lo: 1e-15,
    hi: 1e9,
    unit: "kg m^2",
};
/// Magnitude of a bearing or pedestal stiffness: at most 1e14 N/m.
pub const STIFFNESS_MAX: f64 = 1e14;
/// Magnitude of a bearing or pedestal damping: at most 1e10 N s/m.
pub const DAMPING_MAX: f64 = 1e10;

/// `Ok(v)` if `v` lies in `range`, else the reason (naming the range).
pub fn check(v: f64, range: Range) -> Result<f64, String> {
    if v >= range.lo && v <= range.hi {
        Ok(v)
    } else if range.lo <= f64::MIN_POSITIVE {
        Err(format!(
            "{v:e} {} is not positive or beyond the physically plausible {:e} {}",
            range.unit, range.hi, range.unit
        ))
    } else {
        Err(format!(
            "{v:e} {} is outside the physically plausible range {:e}..={:e} {}",
            range.unit, range.lo, range.hi, range.unit
        ))
    }
}

/// `Ok(v)` if the disk moment of inertia `v` is exactly 0 or lies in
/// [`INERTIA`], else the reason. Zero is a mass without rotary inertia on
/// the shaft node (a lumped mass: ROSS's compressor example has a
/// `DiskElement` with `Id = Ip = 0`); a tiny non-zero value is still a
/// typing or unit error.
pub fn check_inertia(v: f64) -> Result<f64, String> {
    if v == 0.0 {
        Ok(0.0)
    } else {
        check(v, INERTIA).map_err(|e| format!("{e} (or exactly 0)"))
    }
}

/// `Ok(v)` if `|v| <= max`, else the reason.
pub fn check_magnitude(v: f64, max: f64, unit: &str) -> Result<f64, String> {
    if v.abs() <= max {
        Ok(v)
    } else {
        Err(format!(
            "{v:e} {unit} is beyond the physically plausible magnitude {max:e} {unit}"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_refuse_absurd_values() {
        assert!(check(1.3, LENGTH).is_ok());
        assert!(check(200e9, YOUNG).is_ok());
        assert!(check(7800.0, DENSITY).is_ok());
        for v in [1e300, 1e-300, 0.0, f64::NAN] {
            assert!(check(v, LENGTH).is_err());
        }
        let m = check(1e300, YOUNG).unwrap_err();
        assert!(m.contains("1e300 Pa") && m.contains("1e13 Pa"), "{m}");
        // A tiny modulus (ROSS's mass-carrying layers) is accepted; zero,
        // negative and non-finite values are not.
        assert!(check(6.89475e3, YOUNG).is_ok());
        assert!(check(1e-3, SHEAR).is_ok());
        for v in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(check(v, YOUNG).is_err());
        }
        // Disk inertia: exactly 0 (a lumped mass) or in the range.
        assert_eq!(check_inertia(0.0), Ok(0.0));
        assert_eq!(check_inertia(0.025), Ok(0.025));
        for v in [1e-300, -0.01, 1e12, f64::NAN] {
            let e = check_inertia(v).unwrap_err();
            assert!(e.contains("or exactly 0"), "{e}");
        }
        assert!(check_magnitude(-5e7, STIFFNESS_MAX, "N/m").is_ok());
        assert!(check_magnitude(1e300, STIFFNESS_MAX, "N/m").is_err());
        assert!(check_magnitude(f64::NAN, STIFFNESS_MAX, "N/m").is_err());
    }
}
