//! OFF meshes (the CGAL demo meshes of the real-mesh set), read by hand: no maintained crate
//! reads OFF, and the format is a few lines of numbers.

use glam::Vec3;

use super::{fan, number};

type Parsed = Result<(Vec<Vec3>, Vec<[u32; 3]>), (usize, String)>;

/// OFF: `OFF`, `nv nf ne`, `nv` lines `x y z`, `nf` lines `n i0 .. i(n-1) [colour]`;
/// `#` comments and blank lines are skipped.
pub fn parse_off(text: &str) -> Parsed {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(n, l)| (n + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let (n, header) = lines.next().ok_or((1, "empty file".to_string()))?;
    let mut counts_line = if header == "OFF" {
        lines
            .next()
            .ok_or((n, "missing the counts line".to_string()))?
    } else if let Some(rest) = header.strip_prefix("OFF") {
        (n, rest.trim())
    } else {
        return Err((n, format!("expected the OFF header, found {header:?}")));
    };
    let mut c = counts_line.1.split_whitespace();
    let nv: usize = number(c.next(), "vertex count", counts_line.0)?;
    let nf: usize = number(c.next(), "face count", counts_line.0)?;
    counts_line.1 = "";
    // The counts come from the file: reserve no more than a large real mesh needs up front.
    let mut positions = Vec::with_capacity(nv.min(1 << 20));
    for k in 0..nv {
        let (n, l) = lines
            .next()
            .ok_or((counts_line.0, format!("file ends at vertex {k} of {nv}")))?;
        let mut w = l.split_whitespace();
        let x = number(w.next(), "x", n)?;
        let y = number(w.next(), "y", n)?;
        let z = number(w.next(), "z", n)?;
        positions.push(Vec3::new(x, y, z));
    }
    let mut indices = Vec::with_capacity(nf.min(1 << 20));
    for k in 0..nf {
        let (n, l) = lines
            .next()
            .ok_or((counts_line.0, format!("file ends at face {k} of {nf}")))?;
        let mut w = l.split_whitespace();
        let count: usize = number(w.next(), "face size", n)?;
        let poly = (0..count)
            .map(|_| {
                let i: usize = number(w.next(), "vertex index", n)?;
                if i >= nv {
                    return Err((n, format!("vertex index {i} out of range ({nv} vertices)")));
                }
                Ok(i as u32)
            })
            .collect::<Result<Vec<u32>, _>>()?;
        if poly.len() < 3 {
            return Err((n, format!("face with {} vertices", poly.len())));
        }
        fan(&poly, &mut indices);
    }
    Ok((positions, indices))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_with_comments_and_quads() {
        let text = "OFF\n# a quad\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n";
        let (p, i) = parse_off(text).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(i, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn off_errors_name_the_line() {
        assert!(parse_off("PLY\n").unwrap_err().1.contains("OFF header"));
        let e = parse_off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n").unwrap_err();
        assert_eq!(e.0, 6, "{e:?}");
        let e = parse_off("OFF\n3 1 0\n0 0 0\n").unwrap_err();
        assert!(e.1.contains("file ends"), "{e:?}");
    }
}
