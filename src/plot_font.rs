//! The font every drawn figure uses (the heat maps of `coherent render --aov`, the
//! experiments' plots): Ubuntu Light from `epaint_default_fonts`, embedded as bytes and drawn
//! through plotters' pure-Rust `ab_glyph` route, so drawing needs no system font libraries.

use std::sync::OnceLock;

use plotters::style::FontStyle;

/// The family name the figures ask for.
pub const FAMILY: &str = "sans-serif";

/// Registers the embedded font once per process; `Err` names the failure.
pub fn register() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(
            FAMILY,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the embedded plot font could not be loaded".to_owned())
    }
}
