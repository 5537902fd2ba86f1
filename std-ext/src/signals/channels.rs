//! Measurement channel names of probe signals: `bK_y`, `bK_z` (bearing K,
//! 1-based) and `nN_y`, `nN_z` (shaft node N, 1-based), the names of the
//! measurement file's channels (SPEC sections 4 and 6).

use std::fmt;

/// The direction a probe measures: the shaft's displacement along +y or +z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Direction {
    /// Along +y.
    Y,
    /// Along +z.
    Z,
}

/// A measurement channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ChannelName {
    /// Bearing `K` (1-based), direction.
    Bearing(usize, Direction),
    /// Shaft node `N` (1-based), direction.
    Node(usize, Direction),
}

impl ChannelName {
    /// Parses `bK_y`, `bK_z`, `nN_y`, `nN_z` (K, N >= 1); `None` otherwise.
    pub fn parse(s: &str) -> Option<Self> {
        let s = s.trim();
        let (kind, rest) = (s.get(..1)?, s.get(1..)?);
        let (num, dir) = rest.split_once('_')?;
        let dir = match dir {
            "y" => Direction::Y,
            "z" => Direction::Z,
            _ => return None,
        };
        if num.is_empty() || !num.bytes().all(|b| b.is_ascii_digit()) || num.starts_with('0') {
            return None;
        }
        let n: usize = num.parse().ok()?;
        match kind {
            "b" => Some(ChannelName::Bearing(n, dir)),
            "n" => Some(ChannelName::Node(n, dir)),
            _ => None,
        }
    }
}

impl fmt::Display for ChannelName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (k, n, d) = match self {
            ChannelName::Bearing(n, d) => ('b', n, d),
            ChannelName::Node(n, d) => ('n', n, d),
        };
        let d = match d {
            Direction::Y => 'y',
            Direction::Z => 'z',
        };
        write!(f, "{k}{n}_{d}")
    }
}

/// The measurement file's column order of `channels` (the probes of a
/// recording): bearings 1..N_b, each `y` then `z`, then the node probes in
/// increasing node order, `y` then `z`. Returns, for each output channel,
/// the index of its column in `channels`. A measurement file needs both
/// directions of every bearing 1..N_b and of every node probe, and each
/// channel once: anything else is an error naming what is missing or
/// repeated.
pub fn measurement_order(channels: &[ChannelName]) -> Result<Vec<usize>, String> {
    if channels.is_empty() {
        return Err("no probe channels".into());
    }
    for (i, c) in channels.iter().enumerate() {
        if channels[..i].contains(c) {
            return Err(format!("probe channel {c} appears twice"));
        }
    }
    let mut sorted: Vec<(ChannelName, usize)> = channels.iter().copied().zip(0..).collect();
    sorted.sort();
    let n_b = channels
        .iter()
        .filter_map(|c| match c {
            ChannelName::Bearing(k, _) => Some(*k),
            ChannelName::Node(..) => None,
        })
        .max()
        .unwrap_or(0);
    if n_b == 0 {
        return Err(
            "no bearing probe channels (bK_y, bK_z): the measurement file needs them".into(),
        );
    }
    for k in 1..=n_b {
        for d in [Direction::Y, Direction::Z] {
            let c = ChannelName::Bearing(k, d);
            if !channels.contains(&c) {
                return Err(format!(
                    "probe channel {c} missing: the measurement file needs b1_y, b1_z .. b{n_b}_y, b{n_b}_z"
                ));
            }
        }
    }
    for c in channels {
        if let ChannelName::Node(n, d) = c {
            let other = match d {
                Direction::Y => Direction::Z,
                Direction::Z => Direction::Y,
            };
            let pair = ChannelName::Node(*n, other);
            if !channels.contains(&pair) {
                return Err(format!("probe channel {pair} missing beside {c}"));
            }
        }
    }
    Ok(sorted.into_iter().map(|(_, i)| i).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_order() {
        for s in ["b1_y", "b12_z", "n3_y", "n10_z"] {
            assert_eq!(ChannelName::parse(s).unwrap().to_string(), s);
        }
        for s in ["b0_y", "b1_x", "c1_y", "b_y", "b01_y", "b1y", "kp", ""] {
            assert!(ChannelName::parse(s).is_none(), "{s}");
        }
        let ch: Vec<ChannelName> = ["n4_z", "b2_y", "b1_z", "n4_y", "b1_y", "b2_z"]
            .iter()
            .map(|s| ChannelName::parse(s).unwrap())
            .collect();
        assert_eq!(measurement_order(&ch).unwrap(), vec![4, 2, 1, 5, 3, 0]);
        let missing: Vec<ChannelName> = ["b1_y", "b2_y", "b2_z"]
            .iter()
            .map(|s| ChannelName::parse(s).unwrap())
            .collect();
        assert!(measurement_order(&missing).unwrap_err().contains("b1_z"));
    }
}
