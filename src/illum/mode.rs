//! How a generation's particle rays are grouped into packets (the paper's section 8: forward
//! rays are incoherent, and making them coherent is the open problem). Every mode traces the
//! same rays and gives the same map bit for bit; they differ only in which rays share a
//! packet, so in how much of each packet's traversal is shared.

use core::fmt;
use core::str::FromStr;

use super::IllumError;

/// The grouping of a generation's rays into packets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum Mode {
    /// Each ray traced alone: packets with one active lane (on the scalar backend, one ray
    /// at a time). The baseline.
    Single,
    /// A generation's live rays in particle order, cut into full packets (compacted, not
    /// sorted).
    #[default]
    Packets,
    /// Sorted streams after Áfra et al. 2016: each thread's buffer of a generation's rays
    /// sorted by direction octant, then a Morton code of the origin quantised to the scene's
    /// bounds, then a coarse direction, then cut into packets.
    Sorted,
    /// Boulos et al. 2008's cheap reordering: rays grouped by direction octant only (a
    /// stable counting sort, linear time), then cut into packets.
    Octant,
}

impl Mode {
    /// Every mode, in the order experiments report them.
    pub const ALL: [Mode; 4] = [Mode::Single, Mode::Packets, Mode::Sorted, Mode::Octant];

    /// The name used on the command line and in results files.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Single => "single",
            Mode::Packets => "packets",
            Mode::Sorted => "sorted",
            Mode::Octant => "octant",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = IllumError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Mode::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| IllumError::Options {
                what: "particle ray mode",
                problem: format!(
                    "unknown mode `{s}`; modes: {}",
                    Mode::ALL.map(Mode::name).join(", ")
                ),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_an_unknown_name_lists_them() {
        for m in Mode::ALL {
            assert_eq!(m.name().parse::<Mode>().unwrap(), m);
            assert_eq!(m.to_string(), m.name());
        }
        let e = "sortd".parse::<Mode>().unwrap_err().to_string();
        assert!(
            e.contains("sortd") && e.contains("single, packets, sorted, octant"),
            "{e}"
        );
    }
}
