//! EULUMDAT photometric files (`.ldt`; the goniodiagrams of section 5): the format only,
//! file text to [`PhotometricTable`]. One field per line; symmetry indicators 0 (none), 1
//! (about the vertical axis), 2 (about the C0-C180 plane), 3 (about the C90-C270 plane)
//! and 4 (about both), each storing the planes it needs. Decimal commas are accepted.
//!
//! The file gives cd per 1000 lm: candela in the table = value times the total luminous
//! flux of the lamp sets / 1000 times the conversion factor (`CFLI`, field 24). Errors name
//! the file, the line and the field.

use std::path::Path;

use super::LightError;
use super::photometry::{PhotometricTable, PhotometricType, quote, read_angles};

/// Reads and parses a EULUMDAT file (any 8-bit encoding: text fields are not used).
pub fn load(path: &Path) -> Result<PhotometricTable, LightError> {
    let bytes = std::fs::read(path).map_err(|source| LightError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&String::from_utf8_lossy(&bytes), path)
}

struct Lines<'a> {
    lines: Vec<&'a str>,
    next: usize,
    path: &'a Path,
}

impl Lines<'_> {
    /// A number that must not be negative.
    fn non_negative(&mut self, field: &str) -> Result<f64, LightError> {
        let (line, v) = self.number(field)?;
        if v < 0.0 {
            return Err(self.err(line, field, format!("{v} is negative")));
        }
        Ok(v)
    }

    fn err(&self, line: usize, field: &str, problem: String) -> LightError {
        LightError::Parse {
            path: self.path.to_path_buf(),
            line,
            field: field.to_owned(),
            problem,
        }
    }

    /// The next line (1-based number, text).
    fn text(&mut self, field: &str) -> Result<(usize, &str), LightError> {
        let Some(l) = self.lines.get(self.next) else {
            return Err(self.err(
                self.lines.len().max(1),
                field,
                "the file ends here (truncated?)".to_owned(),
            ));
        };
        self.next += 1;
        Ok((self.next, l.trim()))
    }

    fn number(&mut self, field: &str) -> Result<(usize, f64), LightError> {
        let (line, s) = self.text(field)?;
        let s = s.replace(',', ".");
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok((line, v)),
            _ => Err(self.err(line, field, format!("{} is not a number", quote(&s)))),
        }
    }

    fn int(&mut self, field: &str, lo: i64, hi: i64) -> Result<i64, LightError> {
        let (line, v) = self.number(field)?;
        if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
            return Err(self.err(
                line,
                field,
                format!("{v} is not a whole number from {lo} to {hi}"),
            ));
        }
        Ok(v as i64)
    }
}

/// Parses the text of a EULUMDAT file; `path` names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<PhotometricTable, LightError> {
    let mut f = Lines {
        lines: text.lines().collect(),
        next: 0,
        path,
    };
    f.text("company identification")?;
    f.int("type indicator Ityp", 0, 3)?;
    let isym = f.int("symmetry indicator Isym", 0, 4)?;
    let mc = f.int("number of C-planes Mc", 1, 1 << 12)? as usize;
    f.number("distance between C-planes Dc")?;
    let ng = f.int("number of intensities per C-plane Ng", 1, 1 << 12)? as usize;
    f.number("distance between intensities Dg")?;
    for field in [
        "measurement report number",
        "luminaire name",
        "luminaire number",
        "file name",
        "date / user",
    ] {
        f.text(field)?;
    }
    for field in [
        "length / diameter of luminaire",
        "width of luminaire",
        "height of luminaire",
        "length / diameter of luminous area",
        "width of luminous area",
        "height of luminous area C0",
        "height of luminous area C90",
        "height of luminous area C180",
        "height of luminous area C270",
        "downward flux fraction",
        "light output ratio",
    ] {
        f.number(field)?;
    }
    let cfli = f.non_negative("conversion factor for luminous intensities CFLI")?;
    // Some writers leave CFLI at 0 meaning "no conversion".
    let cfli = if cfli == 0.0 { 1.0 } else { cfli };
    f.number("tilt of luminaire during measurement")?;
    let sets = f.int("number of standard sets of lamps n", 1, 20)? as usize;
    for _ in 0..sets {
        f.text("number of lamps")?;
    }
    for _ in 0..sets {
        f.text("type of lamps")?;
    }
    let mut flux = 0.0;
    for _ in 0..sets {
        flux += f.non_negative("total luminous flux of lamps")?;
    }
    for _ in 0..sets {
        f.text("colour temperature")?;
    }
    for _ in 0..sets {
        f.text("colour rendering index")?;
    }
    for _ in 0..sets {
        f.text("wattage including ballast")?;
    }
    for _ in 0..10 {
        f.number("direct ratios")?;
    }
    let c_angles = read_angles(path, mc, "C-plane angles", |field| f.number(field))?;
    let gammas = read_angles(path, ng, "gamma angles", |field| f.number(field))?;
    // The planes stored for each symmetry.
    let (first, count) = match isym {
        0 => (0, mc),
        1 => (0, 1),
        2 => (0, mc / 2 + 1),
        3 => (mc / 4, mc / 2 + 1),
        _ => (0, mc / 4 + 1),
    };
    if first + count > mc {
        return Err(f.err(
            f.next,
            "symmetry indicator Isym",
            format!(
                "Isym {isym} needs {} C-planes, the file has Mc = {mc}",
                first + count
            ),
        ));
    }
    let planes = c_angles[first..first + count].to_vec();
    let scale = flux / 1000.0 * cfli;
    let mut candela = Vec::with_capacity(count * ng);
    for p in 0..count {
        for g in 0..ng {
            let (line, v) = f.number("luminous intensities")?;
            if v < 0.0 {
                return Err(f.err(
                    line,
                    "luminous intensities",
                    format!(
                        "value {} of C-plane {} ({}) is negative: {v}",
                        g + 1,
                        p + 1,
                        planes[p]
                    ),
                ));
            }
            candela.push((v * scale) as f32);
        }
    }
    if let Some(rest) = f.lines[f.next..].iter().position(|l| !l.trim().is_empty()) {
        let line = f.next + rest + 1;
        return Err(f.err(
            line,
            "end of file",
            format!(
                "unexpected {} after the {} intensities",
                quote(f.lines[line - 1].trim()),
                count * ng
            ),
        ));
    }
    let table = PhotometricTable {
        kind: PhotometricType::C,
        planes,
        angles: gammas,
        candela,
    };
    table.validate(path)?;
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A EULUMDAT file with `isym`, 4 C-planes (0, 90, 180, 270), 3 gammas.
    fn example(isym: u32, values: &[f32]) -> String {
        let mut s = String::new();
        s.push_str(&format!(
            "Nobody\n1\n{isym}\n4\n90\n3\n45\nrep\nname\nno\nfile.ldt\ndate\n"
        ));
        s.push_str(
            "100\n0\n50\n80\n0\n0\n0\n0\n0\n100\n80\n1,0\n0\n1\n1\nLED\n2000\n3000\n80\n20\n",
        );
        for _ in 0..10 {
            s.push_str("0.5\n");
        }
        s.push_str("0\n90\n180\n270\n0\n45\n90\n");
        for v in values {
            s.push_str(&format!("{v}\n"));
        }
        s
    }

    #[test]
    fn every_symmetry_reads_the_planes_it_stores() {
        let p = Path::new("a.ldt");
        let full = parse(&example(0, &[1.0; 12]), p).unwrap();
        assert_eq!(full.planes, vec![0.0, 90.0, 180.0, 270.0]);
        let rot = parse(&example(1, &[100.0, 50.0, 10.0]), p).unwrap();
        assert_eq!(rot.planes, vec![0.0]);
        // cd/klm times 2000 lm.
        assert_eq!(rot.candela, vec![200.0, 100.0, 20.0]);
        assert_eq!(
            parse(&example(2, &[1.0; 9]), p).unwrap().planes,
            vec![0.0, 90.0, 180.0]
        );
        assert_eq!(
            parse(&example(3, &[1.0; 9]), p).unwrap().planes,
            vec![90.0, 180.0, 270.0]
        );
        let q = parse(&example(4, &[1.0; 6]), p).unwrap();
        assert_eq!(q.planes, vec![0.0, 90.0]);
        for isym in 0..=4 {
            let n = [12, 3, 9, 9, 6][isym as usize];
            let t = parse(&example(isym, &vec![1.0; n]), p).unwrap();
            let full = t.full(p).unwrap();
            assert_eq!(*full.planes.last().unwrap(), 360.0, "Isym {isym}");
        }
    }

    #[test]
    fn bad_files_are_errors_naming_file_line_and_field() {
        let p = Path::new("bad.ldt");
        let e = parse(&example(1, &[1.0, 2.0]), p).unwrap_err().to_string();
        assert!(
            e.contains("bad.ldt") && e.contains("luminous intensities") && e.contains("truncated"),
            "{e}"
        );
        let e = parse(&example(1, &[1.0, -2.0, 3.0]), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.ldt:51") && e.contains("negative"), "{e}");
        let e = parse(&example(5, &[1.0; 3]), p).unwrap_err().to_string();
        assert!(e.contains("bad.ldt:3") && e.contains("Isym"), "{e}");
        let e = parse(
            &example(1, &[1.0; 3]).replace("0\n45\n90\n1\n", "0\n90\n45\n1\n"),
            p,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("gamma angles") && e.contains("increase"), "{e}");
        let e = parse(&format!("{}9\n", example(1, &[1.0; 3])), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unexpected"), "{e}");
    }
}
