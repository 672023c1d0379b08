//! The accuracy measure of the progressive film (paper section 6.2): how far apart two
//! colour estimates look on the display. The paper tone-maps a sample's colour before
//! writing it to the screen matrices, so their difference is a difference of display values;
//! we keep HDR radiance in the matrices (for EXR output) and tone-map the two estimates when
//! comparing them, with the operator fixed by the pre-render.

use crate::tonemap::ToneMap;

/// `max_c |T(a)_c - T(b)_c|`: the largest channel difference of the tone-mapped colours, in
/// display units `[0, 1]` (`T` with `std` maths). With a black pre-render (nothing to adapt
/// to) display values say nothing, and any difference counts as infinite.
#[inline]
pub fn display_difference(t: &ToneMap, a: [f32; 3], b: [f32; 3]) -> f32 {
    if t.is_black() {
        return if a == b { 0.0 } else { f32::INFINITY };
    }
    let (x, y) = (t.apply_exact(a), t.apply_exact(b));
    let mut d = 0.0f32;
    for c in 0..3 {
        let r = (x[c] - y[c]).abs();
        d = d.max(if r.is_nan() { f32::INFINITY } else { r });
    }
    d
}
