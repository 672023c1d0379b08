//! Scenes written for another renderer, so that its frames can be set beside ours on the
//! same input: [`mitsuba`] writes Mitsuba 3's scene description, [`matched`] reduces a scene
//! to what both renderers compute the same way and names everything it leaves out, and
//! [`peer`] drives the installed Mitsuba through `scripts/mitsuba_peer.py`.
//!
//! Nothing is approximated silently: a feature with no equal on the other side is a
//! [`Skip`], with the reason, in the export's report.

pub mod matched;
pub mod mitsuba;
pub mod peer;

/// A feature of the scene left out of an export, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Skip {
    /// What was left out, e.g. `material floor: Phong lobe (specular 0.2, exponent 20)`.
    pub what: String,
    /// Why the other renderer cannot compute it the same way.
    pub why: String,
}

impl std::fmt::Display for Skip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.what, self.why)
    }
}
