//! The accuracy measure of the progressive film (paper section 6.2): the relative
//! difference of two colour estimates, per channel, above a noise floor.

/// `max_c |a_c - b_c| / ((a_c + b_c) / 2 + floor)`: 0 for equal colours, about the relative
/// difference for bright ones; `floor` (5% of the pre-render's mean luminance)
/// keeps near-black channels from counting tiny absolute differences as large.
#[inline]
pub fn relative_difference(a: [f32; 3], b: [f32; 3], floor: f32) -> f32 {
    let mut d = 0.0f32;
    for c in 0..3 {
        let den = 0.5 * (a[c] + b[c]) + floor;
        let r = (a[c] - b[c]).abs() / den;
        d = d.max(if r.is_nan() { f32::INFINITY } else { r });
    }
    d
}
