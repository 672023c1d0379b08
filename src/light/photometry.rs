//! The goniodiagram table both file formats parse into (paper section 5: "a 2-dimensional
//! non-uniform table"), the photometric-to-radiometric conversion, and the unfolding of
//! the formats' symmetries into a table over the full circle of planes.
//!
//! Angles are in degrees as in the files. For type C photometry the planes are C-planes
//! (azimuth about the luminaire's vertical axis, from its +x axis towards +y) and the
//! angle within a plane is gamma, from the nadir (0, straight down) to the zenith (180).
//! For types A and B see [`super::goniodiagram`].

use super::LightError;
use std::path::Path;

/// Watts per lumen at 555 nm, the peak of the photopic curve: a luminous intensity of
/// `I` candela is taken as a radiant intensity of `I * WATTS_PER_LUMEN` W/sr in each RGB
/// channel (times the light's colour). This is the only photometric-to-radiometric
/// conversion in the project.
pub const WATTS_PER_LUMEN: f32 = 1.0 / 683.0;

/// How the angles of a table are laid on the luminaire (IES LM-63 photometric types).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhotometricType {
    /// Planes about the vertical axis (C-planes), angles from the nadir: most luminaires.
    C,
    /// Planes about the luminaire's lateral (x) axis: floodlights.
    B,
    /// Planes about the luminaire's longitudinal (y) axis: automotive lamps.
    A,
}

/// A goniodiagram as read from a file: candela at the nodes of a (plane, angle) grid,
/// angles in degrees, increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct PhotometricTable {
    pub kind: PhotometricType,
    /// Plane angles: C (type C) or H/V (types B/A: the angle of the plane about the polar
    /// axis).
    pub planes: Vec<f32>,
    /// Angles within a plane: gamma (type C), or the angle from the plane through the aim
    /// axis (types B/A).
    pub angles: Vec<f32>,
    /// Candela, plane-major: `candela[plane * angles.len() + angle]`.
    pub candela: Vec<f32>,
}

impl PhotometricTable {
    /// The candela at node `(plane, angle)`.
    pub fn at(&self, plane: usize, angle: usize) -> f32 {
        self.candela[plane * self.angles.len() + angle]
    }

    /// Checks the shape, monotonic axes and non-negative finite values; errors name `path`.
    pub fn validate(&self, path: &Path) -> Result<(), LightError> {
        let bad = |problem: String| LightError::File {
            path: path.to_path_buf(),
            problem,
        };
        for (name, axis) in [("plane angles", &self.planes), ("angles", &self.angles)] {
            if axis.is_empty() {
                return Err(bad(format!("no {name}")));
            }
            if let Some(x) = axis.iter().find(|x| !x.is_finite()) {
                return Err(bad(format!("{name}: {x} is not a number")));
            }
            for (i, w) in axis.windows(2).enumerate() {
                if w[1] <= w[0] {
                    return Err(bad(format!(
                        "{name} must increase, but angle {} ({}) follows {}",
                        i + 2,
                        w[1],
                        w[0]
                    )));
                }
            }
        }
        if self.candela.len() != self.planes.len() * self.angles.len() {
            return Err(bad(format!(
                "{} candela values for {} planes x {} angles",
                self.candela.len(),
                self.planes.len(),
                self.angles.len()
            )));
        }
        if let Some((i, v)) = self
            .candela
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(bad(format!(
                "candela value {} (plane {}, angle {}) is {v}: negative or not a number",
                i + 1,
                i / self.angles.len() + 1,
                i % self.angles.len() + 1
            )));
        }
        Ok(())
    }

    /// The largest candela value.
    pub fn max_candela(&self) -> f32 {
        self.candela.iter().copied().fold(0.0, f32::max)
    }

    /// The table over the full range of planes (type C: 0 to 360 degrees; types A/B: -180
    /// to 180), unfolding the symmetry the plane angles imply:
    /// - type C: one plane (rotational symmetry), 0-90 (quadrants), 0-180 (bilateral about
    ///   the 0-180 plane), 90-270 (bilateral about the 90-270 plane), 0-360 (none);
    /// - types A/B: 0-90 (symmetric about the 0 plane), or already -90..90 or wider.
    ///
    /// Planes a type A/B file does not cover get zero (nothing lights behind a
    /// floodlight). Errors name `path` when the plane range fits no symmetry.
    pub fn full(&self, path: &Path) -> Result<PhotometricTable, LightError> {
        let bad = |problem: String| LightError::File {
            path: path.to_path_buf(),
            problem,
        };
        let (first, last) = (self.planes[0], *self.planes.last().unwrap());
        let n = self.angles.len();
        let plane_values = |i: usize| self.candela[i * n..(i + 1) * n].to_vec();
        // The plane of the file that gives plane angle `x` of the full table, if any.
        let mut planes: Vec<f32>;
        let fold: Box<dyn Fn(f32) -> Option<f32>>;
        match self.kind {
            PhotometricType::C => {
                if self.planes.len() == 1 {
                    planes = vec![0.0, 360.0];
                    fold = Box::new(move |_| Some(first));
                } else if first == 0.0 && last == 90.0 {
                    fold = Box::new(|c| {
                        let c = if c > 180.0 { 360.0 - c } else { c };
                        Some(if c > 90.0 { 180.0 - c } else { c })
                    });
                    planes = unfold(
                        &self.planes,
                        &[|c| 180.0 - c, |c| 180.0 + c, |c| 360.0 - c],
                        (0.0, 360.0),
                    );
                } else if first == 0.0 && last == 180.0 {
                    fold = Box::new(|c| Some(if c > 180.0 { 360.0 - c } else { c }));
                    planes = unfold(&self.planes, &[|c| 360.0 - c], (0.0, 360.0));
                } else if first == 90.0 && last == 270.0 {
                    // Mirror about the 90-270 plane: C -> 180 - C (mod 360).
                    fold = Box::new(|c| {
                        Some(if c < 90.0 {
                            180.0 - c
                        } else if c > 270.0 {
                            540.0 - c
                        } else {
                            c
                        })
                    });
                    planes = unfold(&self.planes, &[|c| 180.0 - c, |c| 540.0 - c], (0.0, 360.0));
                } else if first == 0.0 && last == 360.0 {
                    fold = Box::new(Some);
                    planes = self.planes.clone();
                } else if first == 0.0 && last > 180.0 && last < 360.0 {
                    // Full circle without the closing plane: 360 repeats 0.
                    fold = Box::new(move |c| Some(if c >= 360.0 { 0.0 } else { c }));
                    planes = self.planes.clone();
                    planes.push(360.0);
                } else {
                    return Err(bad(format!(
                        "C-planes from {first} to {last} degrees: expected one plane, 0-90, 0-180, 90-270 or 0-360"
                    )));
                }
            }
            PhotometricType::A | PhotometricType::B => {
                if first == 0.0 && last <= 90.0 && self.planes.len() > 1 {
                    fold = Box::new(|h| (h.abs() <= 90.0).then_some(h.abs()));
                    planes = unfold(&self.planes, &[|h| -h], (-180.0, 180.0));
                } else if first >= -180.0 && last <= 180.0 && self.planes.len() > 1 {
                    fold = Box::new(move |h| (h >= first && h <= last).then_some(h));
                    planes = self.planes.clone();
                } else {
                    return Err(bad(format!(
                        "horizontal angles from {first} to {last} degrees: expected 0 to at most 90, or within -180 to 180"
                    )));
                }
                // Zero planes just outside the covered range, and the ends of the circle.
                let (lo, hi) = (planes[0], *planes.last().unwrap());
                if lo > -180.0 {
                    planes.insert(0, -180.0);
                    if lo - 1e-3 > -180.0 {
                        planes.insert(1, lo - 1e-3);
                    }
                }
                if hi < 180.0 {
                    if hi + 1e-3 < 180.0 {
                        planes.push(hi + 1e-3);
                    }
                    planes.push(180.0);
                }
            }
        }
        let mut candela = Vec::with_capacity(planes.len() * n);
        for &p in &planes {
            match fold(p) {
                Some(src) => {
                    let i = self
                        .planes
                        .iter()
                        .position(|&x| (x - src).abs() <= 1e-3)
                        .ok_or_else(|| {
                            bad(format!(
                                "plane {src} of the symmetry is missing from the file"
                            ))
                        })?;
                    candela.extend(plane_values(i));
                }
                None => candela.extend(std::iter::repeat_n(0.0, n)),
            }
        }
        let full = PhotometricTable {
            kind: self.kind,
            planes,
            angles: self.angles.clone(),
            candela,
        };
        full.validate(path)?;
        Ok(full)
    }
}

/// The plane angles and their images under the given reflections within the circle,
/// sorted, duplicates
/// (within 1e-3 degree) removed.
/// `text` as an error message quotes it: in backticks, control and non-ASCII characters
/// escaped, cut to 40 characters (a binary file's "line" is otherwise kilobytes of bytes
/// that the terminal would interpret).
pub(crate) fn quote(text: &str) -> String {
    let mut q: String = text
        .chars()
        .flat_map(char::escape_default)
        .take(40)
        .collect();
    if text
        .chars()
        .flat_map(char::escape_default)
        .nth(40)
        .is_some()
    {
        q.push_str("...");
    }
    format!("`{q}`")
}

fn unfold(planes: &[f32], maps: &[fn(f32) -> f32], (lo, hi): (f32, f32)) -> Vec<f32> {
    let mut all: Vec<f32> = planes.to_vec();
    for m in maps {
        all.extend(planes.iter().map(|&c| m(c)));
    }
    all.retain(|c| (lo..=hi).contains(c));
    all.sort_by(f32::total_cmp);
    all.dedup_by(|a, b| (*a - *b).abs() <= 1e-3);
    all
}

/// `n` increasing angles in -360..360 degrees for a photometric file's `field`, each read by
/// `number` with its line; an error names `path`, the line and the field.
pub(crate) fn read_angles(
    path: &std::path::Path,
    n: usize,
    field: &str,
    mut number: impl FnMut(&str) -> Result<(usize, f64), super::LightError>,
) -> Result<Vec<f32>, super::LightError> {
    let err = |line: usize, problem: String| super::LightError::Parse {
        path: path.to_path_buf(),
        line,
        field: field.to_owned(),
        problem,
    };
    let mut v: Vec<f32> = Vec::with_capacity(n);
    for k in 0..n {
        let (line, a) = number(field)?;
        if !(-360.0..=360.0).contains(&a) {
            return Err(err(
                line,
                format!("angle {} is {a}, outside -360..360 degrees", k + 1),
            ));
        }
        if let Some(&p) = v.last()
            && a as f32 <= p
        {
            return Err(err(
                line,
                format!(
                    "angle {} ({a}) is not above the one before ({p}): angles must increase",
                    k + 1
                ),
            ));
        }
        v.push(a as f32);
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_text_is_escaped_and_cut() {
        assert_eq!(quote("12a"), "`12a`");
        assert_eq!(quote("\u{1b}[2J"), "`\\u{1b}[2J`");
        let long = quote(&"x".repeat(100));
        assert_eq!(long, format!("`{}...`", "x".repeat(40)));
    }

    fn table(kind: PhotometricType, planes: Vec<f32>) -> PhotometricTable {
        let angles = vec![0.0, 45.0, 90.0];
        let candela = (0..planes.len() * 3).map(|i| i as f32).collect();
        PhotometricTable {
            kind,
            planes,
            angles,
            candela,
        }
    }

    fn value_at(t: &PhotometricTable, plane: f32, angle: usize) -> f32 {
        let i = t
            .planes
            .iter()
            .position(|&p| (p - plane).abs() < 1e-3)
            .unwrap();
        t.at(i, angle)
    }

    #[test]
    fn symmetries_unfold_to_the_full_circle() {
        let p = Path::new("test.ies");
        // Quadrant symmetry: 0, 45, 90 -> 0..360 in steps of 45.
        let q = table(PhotometricType::C, vec![0.0, 45.0, 90.0])
            .full(p)
            .unwrap();
        assert_eq!(
            q.planes,
            vec![0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0, 360.0]
        );
        assert_eq!(value_at(&q, 135.0, 1), value_at(&q, 45.0, 1));
        assert_eq!(value_at(&q, 315.0, 2), value_at(&q, 45.0, 2));
        assert_eq!(value_at(&q, 360.0, 0), value_at(&q, 0.0, 0));
        // Bilateral about 0-180.
        let b = table(PhotometricType::C, vec![0.0, 60.0, 180.0])
            .full(p)
            .unwrap();
        assert_eq!(b.planes, vec![0.0, 60.0, 180.0, 300.0, 360.0]);
        assert_eq!(value_at(&b, 300.0, 1), value_at(&b, 60.0, 1));
        // Bilateral about 90-270.
        let c = table(PhotometricType::C, vec![90.0, 180.0, 270.0])
            .full(p)
            .unwrap();
        assert_eq!(c.planes, vec![0.0, 90.0, 180.0, 270.0, 360.0]);
        assert_eq!(value_at(&c, 0.0, 1), value_at(&c, 180.0, 1));
        assert_eq!(value_at(&c, 360.0, 1), value_at(&c, 180.0, 1));
        // Rotational.
        let r = table(PhotometricType::C, vec![0.0]).full(p).unwrap();
        assert_eq!(r.planes, vec![0.0, 360.0]);
        assert_eq!(r.at(1, 2), r.at(0, 2));
        // Type B, symmetric: 0..90 -> -90..90, zero beyond.
        let h = table(PhotometricType::B, vec![0.0, 30.0, 90.0])
            .full(p)
            .unwrap();
        assert_eq!(value_at(&h, -30.0, 1), value_at(&h, 30.0, 1));
        assert_eq!(value_at(&h, -180.0, 1), 0.0);
        assert_eq!(*h.planes.last().unwrap(), 180.0);
        // No symmetry fits.
        let e = table(PhotometricType::C, vec![10.0, 20.0])
            .full(p)
            .unwrap_err();
        assert!(
            e.to_string().contains("test.ies") && e.to_string().contains("C-planes"),
            "{e}"
        );
    }

    #[test]
    fn negative_or_unsorted_values_are_errors() {
        let p = Path::new("x.ldt");
        let mut t = table(PhotometricType::C, vec![0.0, 90.0]);
        t.candela[4] = -1.0;
        let e = t.validate(p).unwrap_err().to_string();
        assert!(e.contains("x.ldt") && e.contains("negative"), "{e}");
        let t = table(PhotometricType::C, vec![90.0, 0.0]);
        assert!(t.validate(p).unwrap_err().to_string().contains("increase"));
    }
}
