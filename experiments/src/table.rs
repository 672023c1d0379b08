//! CSV results as tables (paper section 7's tables): writing rows under an exact header,
//! reading them back with the header checked, and rendering Markdown for `results/README.md`,
//! including the paper's figures beside ours.
//!
//! The headers are the results contract (file names and columns that other tools read, listed
//! per experiment in docs/experiments.md): a CSV is only ever written and read
//! against the header its experiment declares, so a renamed column fails loudly.

use anyhow::{Context, anyhow, bail};
use std::fmt::Display;
use std::fs::File;
use std::path::{Path, PathBuf};

/// A CSV file being written. Rows go to `NAME.tmp` and [`CsvOut::finish`] renames it to
/// `NAME`, so a run that fails half-way leaves the previous results in place.
pub struct CsvOut {
    path: PathBuf,
    tmp: PathBuf,
    columns: usize,
    writer: Option<csv::Writer<File>>,
}

impl CsvOut {
    /// Creates `path` (through its `.tmp` twin) and writes `header`.
    pub fn create(path: &Path, header: &[&str]) -> anyhow::Result<CsvOut> {
        if header.is_empty() {
            bail!("{}: a CSV needs at least one column", path.display());
        }
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".tmp");
        let tmp = PathBuf::from(tmp);
        let file =
            File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut writer = csv::Writer::from_writer(file);
        writer
            .write_record(header)
            .with_context(|| format!("cannot write {}", tmp.display()))?;
        Ok(CsvOut {
            path: path.to_owned(),
            tmp,
            columns: header.len(),
            writer: Some(writer),
        })
    }

    /// Appends one row: one cell per header column, each written with `Display` (floats
    /// print in full precision; infinity as `inf`).
    pub fn row(&mut self, cells: &[&dyn Display]) -> anyhow::Result<()> {
        if cells.len() != self.columns {
            bail!(
                "{}: a row has {} cells, the header {} columns",
                self.path.display(),
                cells.len(),
                self.columns
            );
        }
        let writer = self
            .writer
            .as_mut()
            .ok_or_else(|| anyhow!("{}: already finished", self.path.display()))?;
        writer
            .write_record(cells.iter().map(|c| c.to_string()))
            .with_context(|| format!("cannot write {}", self.tmp.display()))
    }

    /// Flushes and moves the file into place.
    pub fn finish(mut self) -> anyhow::Result<PathBuf> {
        if let Some(mut writer) = self.writer.take() {
            writer
                .flush()
                .with_context(|| format!("cannot write {}", self.tmp.display()))?;
        }
        std::fs::rename(&self.tmp, &self.path)
            .with_context(|| format!("cannot move {} into place", self.tmp.display()))?;
        Ok(self.path.clone())
    }
}

impl Drop for CsvOut {
    fn drop(&mut self) {
        // Not finished: an error cut the run short. Leave the previous results alone.
        if self.writer.is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// A CSV file read back: its header and its rows as text.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Where it was read from (for error messages).
    pub file: PathBuf,
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// Reads `path`, which must have exactly `header` (same names, same order).
    pub fn read(path: &Path, header: &[&str]) -> anyhow::Result<Table> {
        let mut reader = csv::Reader::from_path(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let found: Vec<String> = reader
            .headers()
            .with_context(|| format!("{}: cannot read the header", path.display()))?
            .iter()
            .map(str::to_owned)
            .collect();
        if found != header {
            bail!(
                "{}: header is `{}`, expected `{}`",
                path.display(),
                found.join(","),
                header.join(",")
            );
        }
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.with_context(|| format!("{}: malformed row", path.display()))?;
            rows.push(record.iter().map(str::to_owned).collect());
        }
        Ok(Table {
            file: path.to_owned(),
            header: found,
            rows,
        })
    }

    /// Rows (without the header).
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The index of column `name`.
    pub fn col(&self, name: &str) -> anyhow::Result<usize> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| anyhow!("{}: no column `{name}`", self.file.display()))
    }

    /// The text of column `name` in row `row`.
    pub fn get(&self, row: usize, name: &str) -> anyhow::Result<&str> {
        let col = self.col(name)?;
        self.rows
            .get(row)
            .and_then(|r| r.get(col))
            .map(String::as_str)
            .ok_or_else(|| anyhow!("{}: no row {row}", self.file.display()))
    }

    /// Column `name` of row `row` as a number (`inf` and `NaN` accepted).
    pub fn f64(&self, row: usize, name: &str) -> anyhow::Result<f64> {
        let text = self.get(row, name)?;
        text.trim().parse().map_err(|_| {
            anyhow!(
                "{}: row {}, column `{name}`: `{text}` is not a number",
                self.file.display(),
                row + 1
            )
        })
    }

    /// The rows whose column `name` equals `value`, as row indices.
    pub fn rows_where(&self, name: &str, value: &str) -> anyhow::Result<Vec<usize>> {
        let col = self.col(name)?;
        Ok((0..self.rows.len())
            .filter(|&r| self.rows[r][col] == value)
            .collect())
    }

    /// The distinct values of column `name`, in order of first appearance.
    pub fn distinct(&self, name: &str) -> anyhow::Result<Vec<String>> {
        let col = self.col(name)?;
        let mut seen: Vec<String> = Vec::new();
        for row in &self.rows {
            if !seen.contains(&row[col]) {
                seen.push(row[col].clone());
            }
        }
        Ok(seen)
    }

    /// A cross table in Markdown: one row per value of column `rows`, one column per value of
    /// column `cols` (both in order of first appearance), cells from column `value` (numbers
    /// through [`fmt_num`]; `—` where no row matches). E.g. `pivot("kernel", "backend",
    /// "speedup")` gives kernels down, backends across.
    pub fn pivot(&self, rows: &str, cols: &str, value: &str) -> anyhow::Result<String> {
        let (r, c, v) = (self.col(rows)?, self.col(cols)?, self.col(value)?);
        let row_keys = self.distinct(rows)?;
        let col_keys = self.distinct(cols)?;
        let cell = |rk: &str, ck: &str| {
            self.rows
                .iter()
                .find(|row| row[r] == rk && row[c] == ck)
                .map_or_else(
                    || "—".to_owned(),
                    |row| match row[v].trim().parse::<f64>() {
                        Ok(x) if !is_integer(&row[v]) => fmt_num(x),
                        _ => row[v].clone(),
                    },
                )
        };
        let body: Vec<Vec<String>> = row_keys
            .iter()
            .map(|rk| {
                std::iter::once(rk.clone())
                    .chain(col_keys.iter().map(|ck| cell(rk, ck)))
                    .collect()
            })
            .collect();
        let header: Vec<&str> = std::iter::once(rows)
            .chain(col_keys.iter().map(String::as_str))
            .collect();
        Ok(markdown_table(&header, &body))
    }

    /// The whole table as Markdown. A column of numbers where any has a fraction (`0.5`,
    /// `1e-3`, `inf`) is printed with [`fmt_num`]; integer and text columns stay as written.
    pub fn to_markdown(&self) -> String {
        let numeric: Vec<bool> = (0..self.header.len())
            .map(|c| {
                let cells = || self.rows.iter().filter_map(|row| row.get(c));
                cells().all(|cell| cell.trim().parse::<f64>().is_ok())
                    && cells().any(|cell| !is_integer(cell))
            })
            .collect();
        let rows: Vec<Vec<String>> = self
            .rows
            .iter()
            .map(|row| {
                row.iter()
                    .enumerate()
                    .map(|(c, cell)| match cell.trim().parse::<f64>() {
                        Ok(v) if numeric.get(c) == Some(&true) => fmt_num(v),
                        _ => cell.clone(),
                    })
                    .collect()
            })
            .collect();
        let header: Vec<&str> = self.header.iter().map(String::as_str).collect();
        markdown_table(&header, &rows)
    }
}

/// Whether a cell is written as an integer (`400000`, `-3`).
fn is_integer(cell: &str) -> bool {
    let digits = cell.trim().trim_start_matches(['-', '+']);
    !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
}

/// A number for people: 3 significant digits (`0.137`, `3.17`, `145`), integers above 1000
/// whole (`24375`), `inf`, `NaN`.
pub fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    if v == 0.0 {
        return "0".to_owned();
    }
    let magnitude = v.abs().log10().floor() as i32;
    if magnitude >= 2 {
        format!("{v:.0}")
    } else if magnitude >= -4 {
        format!("{v:.*}", (2 - magnitude) as usize)
    } else {
        format!("{v:.2e}")
    }
}

/// A Markdown table. Cells are escaped (`|`); short rows are padded.
pub fn markdown_table(header: &[&str], rows: &[Vec<String>]) -> String {
    let escape = |s: &str| s.replace('|', "\\|").replace('\n', " ");
    let mut md = String::new();
    md.push_str(&format!(
        "| {} |\n",
        header
            .iter()
            .map(|h| escape(h))
            .collect::<Vec<_>>()
            .join(" | ")
    ));
    md.push_str(&format!("|{}\n", " --- |".repeat(header.len())));
    for row in rows {
        let cells: Vec<String> = (0..header.len())
            .map(|i| row.get(i).map_or(String::new(), |c| escape(c)))
            .collect();
        md.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    md
}

/// A table of the paper, kept as data in the experiment's module, to print beside ours.
#[derive(Clone, Copy, Debug)]
pub struct PaperTable {
    /// What the paper measured and on what, e.g. `Table 1: anisotropic BDF, Pentium 4 1.8 GHz`.
    pub caption: &'static str,
    /// The header of the key column, e.g. `calls`.
    pub key: &'static str,
    /// The compared quantities, e.g. `["scalar s", "SSE s", "speedup"]`.
    pub columns: &'static [&'static str],
    /// `(key, one value per column)`, e.g. `("100000", &[0.137, 0.040, 3.43])`.
    pub rows: &'static [(&'static str, &'static [f64])],
}

impl PaperTable {
    /// Markdown with, per column, the paper's value and ours side by side. `ours` holds
    /// `(key, one value per column)`; `None` where we have no figure. Rows follow the paper's
    /// order, then keys only we have.
    pub fn beside(&self, ours: &[(String, Vec<Option<f64>>)]) -> String {
        let mut header = vec![self.key.to_owned()];
        for c in self.columns {
            header.push(format!("{c} (paper)"));
            header.push(format!("{c} (ours)"));
        }
        let mut keys: Vec<&str> = self.rows.iter().map(|(k, _)| *k).collect();
        for (k, _) in ours {
            if !keys.contains(&k.as_str()) {
                keys.push(k);
            }
        }
        let show = |v: Option<f64>| v.map_or_else(|| "—".to_owned(), fmt_num);
        let rows: Vec<Vec<String>> = keys
            .iter()
            .map(|key| {
                let paper = self.rows.iter().find(|(k, _)| k == key).map(|(_, v)| *v);
                let mine = ours.iter().find(|(k, _)| k == key).map(|(_, v)| v);
                let mut row = vec![(*key).to_owned()];
                for c in 0..self.columns.len() {
                    row.push(show(paper.and_then(|p| p.get(c).copied())));
                    row.push(show(mine.and_then(|m| m.get(c).copied().flatten())));
                }
                row
            })
            .collect();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        format!("{}\n\n{}", self.caption, markdown_table(&header, &rows))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &[&str] = &["kernel", "backend", "lanes", "seconds", "speedup"];

    #[test]
    fn csv_round_trips_with_its_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("kernels.csv");
        let mut out = CsvOut::create(&path, HEADER).unwrap();
        out.row(&[&"exp", &"scalar", &1, &0.125, &1.0]).unwrap();
        out.row(&[&"exp, \"quoted\"", &"sse", &4, &0.03125, &f64::INFINITY])
            .unwrap();
        assert!(!path.exists(), "rows go to the .tmp file until finish");
        out.finish().unwrap();

        let table = Table::read(&path, HEADER).unwrap();
        assert_eq!(table.rows.len(), 2);
        assert_eq!(table.get(1, "kernel").unwrap(), "exp, \"quoted\"");
        assert_eq!(table.f64(0, "seconds").unwrap(), 0.125);
        assert_eq!(table.f64(1, "speedup").unwrap(), f64::INFINITY);
        assert_eq!(table.rows_where("backend", "sse").unwrap(), vec![1]);
        assert_eq!(table.distinct("lanes").unwrap(), vec!["1", "4"]);
        assert!(table.f64(0, "backend").is_err());
        assert!(table.col("nope").is_err());
    }

    #[test]
    fn wrong_header_or_row_length_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("kernels.csv");
        let mut out = CsvOut::create(&path, HEADER).unwrap();
        let e = out.row(&[&"exp", &"scalar"]).unwrap_err();
        assert!(e.to_string().contains("2 cells"), "{e}");
        out.finish().unwrap();

        let e = Table::read(&path, &["kernel", "backend"]).unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.contains("kernels.csv") && msg.contains("expected `kernel,backend`"),
            "{msg}"
        );

        std::fs::write(&path, "kernel,backend,lanes,seconds,speedup\nexp,scalar\n").unwrap();
        let e = Table::read(&path, HEADER).unwrap_err();
        assert!(format!("{e:#}").contains("malformed row"), "{e:#}");
        assert!(Table::read(&dir.path().join("missing.csv"), HEADER).is_err());
    }

    #[test]
    fn an_unfinished_csv_leaves_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        std::fs::write(&path, "a\nold\n").unwrap();
        {
            let mut out = CsvOut::create(&path, &["a"]).unwrap();
            out.row(&[&"new"]).unwrap();
        } // dropped: an error cut the run short
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a\nold\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn numbers_print_with_three_significant_digits() {
        assert_eq!(fmt_num(0.137), "0.137");
        assert_eq!(fmt_num(3.4321), "3.43");
        assert_eq!(fmt_num(24.375), "24.4");
        assert_eq!(fmt_num(145.252), "145");
        assert_eq!(fmt_num(0.000_123_4), "0.000123");
        assert_eq!(fmt_num(1.5e-7), "1.50e-7");
        assert_eq!(fmt_num(0.0), "0");
        assert_eq!(fmt_num(f64::INFINITY), "inf");
    }

    #[test]
    fn markdown_formats_fractional_columns_and_keeps_the_rest() {
        let table = Table {
            file: PathBuf::from("t.csv"),
            header: vec![
                "calls".into(),
                "backend".into(),
                "seconds".into(),
                "speedup".into(),
            ],
            rows: vec![
                vec![
                    "100000".into(),
                    "scalar".into(),
                    "0.1234567".into(),
                    "1".into(),
                ],
                vec!["200000".into(), "sse".into(), "0.03".into(), "inf".into()],
            ],
        };
        let md = table.to_markdown();
        assert!(md.contains("| 100000 | scalar | 0.123 | 1.00 |"), "{md}");
        assert!(md.contains("| 200000 | sse | 0.0300 | inf |"), "{md}");
    }

    #[test]
    fn paper_beside_ours_pairs_columns_and_keeps_the_paper_order() {
        let paper = PaperTable {
            caption: "Table 1",
            key: "calls",
            columns: &["scalar s", "speedup"],
            rows: &[("100000", &[0.137, 3.43]), ("200000", &[0.248, 3.17])],
        };
        let ours = vec![
            ("200000".to_owned(), vec![Some(0.01), Some(8.0)]),
            ("800000".to_owned(), vec![Some(0.04), None]),
        ];
        let md = paper.beside(&ours);
        let lines: Vec<&str> = md.lines().collect();
        assert_eq!(lines[0], "Table 1");
        assert_eq!(
            lines[2],
            "| calls | scalar s (paper) | scalar s (ours) | speedup (paper) | speedup (ours) |"
        );
        assert_eq!(lines[4], "| 100000 | 0.137 | — | 3.43 | — |");
        assert_eq!(lines[5], "| 200000 | 0.248 | 0.0100 | 3.17 | 8.00 |");
        assert_eq!(lines[6], "| 800000 | — | 0.0400 | — | — |");
    }

    #[test]
    fn pivot_puts_one_column_across() {
        let table = Table {
            file: PathBuf::from("k.csv"),
            header: vec!["kernel".into(), "backend".into(), "speedup".into()],
            rows: vec![
                vec!["exp".into(), "scalar".into(), "1".into()],
                vec!["exp".into(), "sse".into(), "3.912".into()],
                vec!["log".into(), "scalar".into(), "1".into()],
            ],
        };
        let md = table.pivot("kernel", "backend", "speedup").unwrap();
        assert_eq!(
            md,
            "| kernel | scalar | sse |\n| --- | --- | --- |\n| exp | 1 | 3.91 |\n| log | 1 | — |\n"
        );
        assert!(table.pivot("kernel", "nope", "speedup").is_err());
    }

    #[test]
    fn markdown_escapes_pipes_and_pads_rows() {
        let md = markdown_table(&["a", "b"], &[vec!["x|y".to_owned()]]);
        assert_eq!(md, "| a | b |\n| --- | --- |\n| x\\|y |  |\n");
    }
}
