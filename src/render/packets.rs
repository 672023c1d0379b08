//! How the renderer traces a film tile's camera rays: packet by packet through the
//! accelerator's packet query (the paper's way), or the whole tile's packets at once through
//! its beam query (beyond the paper, after Reshetov et al. 2005: the BSP walks a coherent
//! group as one beam, see `coherent_bsp`'s `beam` module). Secondary and shadow rays stay
//! lane packets either way. The image is the same up to which of two triangles sharing an
//! edge a ray hits.

/// How camera rays are traced (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Packets {
    /// Each camera packet on its own (the default).
    #[default]
    Lanes,
    /// A tile's camera packets together, as one beam.
    Beam,
}

impl Packets {
    pub const ALL: [Packets; 2] = [Packets::Lanes, Packets::Beam];

    /// The name used on the command line and in results.
    pub fn name(self) -> &'static str {
        match self {
            Packets::Lanes => "lanes",
            Packets::Beam => "beam",
        }
    }
}

impl std::fmt::Display for Packets {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Packets {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("unknown packet mode `{s}`: lanes or beam"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for p in Packets::ALL {
            assert_eq!(p.name().parse::<Packets>().unwrap(), p);
        }
        let e = "beams".parse::<Packets>().unwrap_err();
        assert!(e.contains("lanes or beam"), "{e}");
    }
}
