//! IES LM-63 photometric files (`.ies`; the goniodiagrams of section 5): the format only,
//! file text to [`PhotometricTable`]. Headers of LM-63-1986/1991 (no or `IESNA91` first
//! line), -1995 (`IESNA:LM-63-1995`), -2002 (`IESNA:LM-63-2002`) and -2019
//! (`IES:LM-63-2019`); keyword lines are skipped. `TILT=NONE` and `TILT=INCLUDE` (the tilt
//! table is read and checked, then not applied: the luminaire is taken as measured);
//! `TILT=<file>` and anything else is an error. Photometric types C, B and A.
//!
//! Candela in the table = file values times the candela multiplier times the ballast
//! factor. Numbers after the TILT line may be split over lines at will and separated by
//! blanks or commas. Errors name the file, the line and the field.

use std::path::Path;

use super::LightError;
use super::photometry::{PhotometricTable, PhotometricType, quote};

/// Reads and parses an IES file.
pub fn load(path: &Path) -> Result<PhotometricTable, LightError> {
    let bytes = std::fs::read(path).map_err(|source| LightError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&String::from_utf8_lossy(&bytes), path)
}

/// The numbers of the file after its TILT line, with their line numbers.
struct Tokens<'a> {
    items: Vec<(usize, &'a str)>,
    next: usize,
    path: &'a Path,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn err(&self, line: usize, field: &str, problem: String) -> LightError {
        LightError::Parse {
            path: self.path.to_path_buf(),
            line,
            field: field.to_owned(),
            problem,
        }
    }

    fn number(&mut self, field: &str) -> Result<(usize, f64), LightError> {
        let Some(&(line, tok)) = self.items.get(self.next) else {
            return Err(self.err(
                self.last_line,
                field,
                "the file ends here (truncated?)".to_owned(),
            ));
        };
        self.next += 1;
        match tok.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok((line, v)),
            _ => Err(self.err(line, field, format!("{} is not a number", quote(tok)))),
        }
    }

    /// A number that must not be negative.
    fn non_negative(&mut self, field: &str) -> Result<f64, LightError> {
        let (line, v) = self.number(field)?;
        if v < 0.0 {
            return Err(self.err(line, field, format!("{v} is negative")));
        }
        Ok(v)
    }

    /// `n` increasing angles in -360..360 degrees.
    fn angles(&mut self, n: usize, field: &str) -> Result<Vec<f32>, LightError> {
        let path = self.path;
        super::photometry::read_angles(path, n, field, |f| self.number(f))
    }

    /// Reads past `TILT=INCLUDE`'s tilt data (checked, not used: the lamp is not tilted).
    fn tilt_data(&mut self) -> Result<(), LightError> {
        let (line, geometry) = self.number("TILT lamp-to-luminaire geometry")?;
        if ![1.0, 2.0, 3.0].contains(&geometry) {
            return Err(self.err(
                line,
                "TILT lamp-to-luminaire geometry",
                format!("{geometry}: expected 1, 2 or 3"),
            ));
        }
        let n = self.count("TILT number of angles", 1 << 16)?;
        let mut prev = f64::NEG_INFINITY;
        for k in 0..n {
            let (line, a) = self.number("TILT angle")?;
            if a <= prev {
                return Err(self.err(
                    line,
                    "TILT angle",
                    format!("angle {} ({a}) does not increase", k + 1),
                ));
            }
            prev = a;
        }
        for _ in 0..n {
            self.non_negative("TILT multiplying factor")?;
        }
        Ok(())
    }

    fn count(&mut self, field: &str, max: usize) -> Result<usize, LightError> {
        let (line, v) = self.number(field)?;
        if v.fract() != 0.0 || v < 1.0 || v > max as f64 {
            return Err(self.err(line, field, format!("{v} is not a count from 1 to {max}")));
        }
        Ok(v as usize)
    }
}

/// Parses the text of an IES file; `path` names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<PhotometricTable, LightError> {
    let err = |line: usize, field: &str, problem: String| LightError::Parse {
        path: path.to_path_buf(),
        line,
        field: field.to_owned(),
        problem,
    };
    let lines: Vec<&str> = text.lines().collect();
    // The TILT line ends the header.
    let Some(tilt_at) = lines
        .iter()
        .position(|l| l.trim_start().to_ascii_uppercase().starts_with("TILT"))
    else {
        return Err(err(
            lines.len().max(1),
            "TILT",
            "no TILT= line: not an IES LM-63 file".to_owned(),
        ));
    };
    let tilt_line = lines[tilt_at].trim();
    let tilt = tilt_line
        .split_once('=')
        .map(|(_, v)| v.trim())
        .ok_or_else(|| {
            err(
                tilt_at + 1,
                "TILT",
                format!("{}: expected TILT=NONE or TILT=INCLUDE", quote(tilt_line)),
            )
        })?;
    let mut items = Vec::new();
    for (i, l) in lines.iter().enumerate().skip(tilt_at + 1) {
        for tok in l.split(|c: char| c.is_whitespace() || c == ',') {
            if !tok.is_empty() {
                items.push((i + 1, tok));
            }
        }
    }
    let mut t = Tokens {
        items,
        next: 0,
        path,
        last_line: lines.len().max(1),
    };
    match tilt.to_ascii_uppercase().as_str() {
        "NONE" => {}
        "INCLUDE" => t.tilt_data()?,
        _ => {
            return Err(err(
                tilt_at + 1,
                "TILT",
                format!(
                    "TILT={tilt}: only TILT=NONE and TILT=INCLUDE are supported (tilt data in another file is not)"
                ),
            ));
        }
    }
    let _lamps = t.number("number of lamps")?;
    let _lumens = t.number("lumens per lamp")?;
    let multiplier = t.non_negative("candela multiplier")?;
    let n_vertical = t.count("number of vertical angles", 1 << 14)?;
    let n_horizontal = t.count("number of horizontal angles", 1 << 14)?;
    let (line, kind) = t.number("photometric type")?;
    let kind = match kind as i64 {
        1 if kind == 1.0 => PhotometricType::C,
        2 if kind == 2.0 => PhotometricType::B,
        3 if kind == 3.0 => PhotometricType::A,
        _ => {
            return Err(err(
                line,
                "photometric type",
                format!("{kind}: expected 1 (C), 2 (B) or 3 (A)"),
            ));
        }
    };
    let _units = t.number("units type")?;
    let _width = t.number("luminous width")?;
    let _length = t.number("luminous length")?;
    let _height = t.number("luminous height")?;
    let ballast = t.non_negative("ballast factor")?;
    let _future = t.number("ballast-lamp factor / file generation type")?;
    let _watts = t.number("input watts")?;
    let angles = t.angles(n_vertical, "vertical angles")?;
    let planes = t.angles(n_horizontal, "horizontal angles")?;
    let scale = multiplier * ballast;
    let mut candela = Vec::with_capacity(n_vertical * n_horizontal);
    for h in 0..n_horizontal {
        for v in 0..n_vertical {
            let (line, c) = t.number("candela values")?;
            if c < 0.0 {
                return Err(err(
                    line,
                    "candela values",
                    format!(
                        "value {} of horizontal angle {} ({}) is negative: {c}",
                        v + 1,
                        h + 1,
                        planes[h]
                    ),
                ));
            }
            candela.push((c * scale) as f32);
        }
    }
    if let Some(&(line, tok)) = t.items.get(t.next) {
        return Err(err(
            line,
            "end of file",
            format!("unexpected {} after the candela values", quote(tok)),
        ));
    }
    let table = PhotometricTable {
        kind,
        planes,
        angles,
        candela,
    };
    table.validate(path)?;
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = "IESNA:LM-63-2002
[TEST] made up
[MANUFAC] nobody
TILT=NONE
1 1000 2.0 3 2 1 2 0.5 0.5 0.2
1.0 1.0 50
0 45 90
0 90
100 80 10
120, 70, 5
";

    #[test]
    fn a_small_file_parses_with_multiplier_and_symmetry() {
        let t = parse(EXAMPLE, Path::new("a.ies")).unwrap();
        assert_eq!(t.kind, PhotometricType::C);
        assert_eq!(t.angles, vec![0.0, 45.0, 90.0]);
        assert_eq!(t.planes, vec![0.0, 90.0]);
        assert_eq!(t.candela, vec![200.0, 160.0, 20.0, 240.0, 140.0, 10.0]);
        let full = t.full(Path::new("a.ies")).unwrap();
        assert_eq!(full.planes, vec![0.0, 90.0, 180.0, 270.0, 360.0]);
    }

    #[test]
    fn tilt_include_is_read_and_older_headers_parse() {
        let text = EXAMPLE
            .replace("IESNA:LM-63-2002", "IESNA91")
            .replace("TILT=NONE", "TILT=INCLUDE\n1\n3\n0 45 90\n1.0 0.9 0.8");
        let t = parse(&text, Path::new("b.ies")).unwrap();
        assert_eq!(t.candela.len(), 6);
        let t = parse(
            &EXAMPLE.replace("IESNA:LM-63-2002", "IES:LM-63-2019"),
            Path::new("c.ies"),
        )
        .unwrap();
        assert_eq!(t.planes.len(), 2);
    }

    fn error(text: &str) -> String {
        parse(text, Path::new("bad.ies")).unwrap_err().to_string()
    }

    #[test]
    fn bad_files_are_errors_naming_file_line_and_field() {
        let e = error(&EXAMPLE.replace("TILT=NONE", "TILT=lamp.tlt"));
        assert!(
            e.contains("bad.ies:4") && e.contains("TILT=lamp.tlt"),
            "{e}"
        );
        let e = error(&EXAMPLE.replace("TILT=NONE\n", ""));
        assert!(e.contains("bad.ies") && e.contains("TILT"), "{e}");
        let e = error(&EXAMPLE.replace("120, 70, 5\n", "120, 70\n"));
        assert!(
            e.contains("bad.ies") && e.contains("candela values") && e.contains("truncated"),
            "{e}"
        );
        let e = error(&EXAMPLE.replace("0 45 90\n", "0 90 45\n"));
        assert!(
            e.contains("bad.ies:7") && e.contains("vertical angles") && e.contains("increase"),
            "{e}"
        );
        let e = error(&EXAMPLE.replace("120, 70, 5", "120, -70, 5"));
        assert!(e.contains("bad.ies:10") && e.contains("negative"), "{e}");
        let e = error(&EXAMPLE.replace("1.0 1.0 50", "1.0 x 50"));
        assert!(
            e.contains("bad.ies:6") && e.contains("`x` is not a number"),
            "{e}"
        );
        let e = error(&EXAMPLE.replace("2 1 2 0.5", "2 7 2 0.5"));
        assert!(e.contains("photometric type"), "{e}");
        let e = error(&format!("{EXAMPLE}7\n"));
        assert!(e.contains("bad.ies:11") && e.contains("unexpected"), "{e}");
    }
}
