//! The project's targets in `results/README.md`, condensed: many checks of one kind (a speedup
//! target per backend, say) on one scene or light become one row saying whether they were met
//! and the figure closest to its target (the nearest miss, or the narrowest pass when every
//! check is met). Used by the reports of Tables 2 and 3 (paper section 7).

use crate::table::markdown_table;

/// One target checked against one measured figure.
#[derive(Clone, Debug)]
pub struct Check {
    /// The row it is folded into, e.g. a scene or a light.
    pub group: String,
    /// The kind of target, e.g. `speedup over scalar (bsp)`.
    pub kind: String,
    /// The figure with its target, as the README shows it, e.g. `avx2 2.62x (>= 6x)`.
    pub figure: String,
    /// Whether the target is met.
    pub met: bool,
    /// Measured / target, oriented so that above 1 is better (for a `<=` target: target /
    /// measured). Picks the closest figure; `met` decides, not this.
    pub ratio: f64,
}

impl Check {
    /// A `measured >= target` check; `figure` is the text before `(>= target)`.
    pub fn at_least(group: &str, kind: &str, figure: String, measured: f64, target: f64) -> Check {
        Check {
            group: group.to_owned(),
            kind: kind.to_owned(),
            figure,
            met: measured >= target,
            ratio: measured / target,
        }
    }

    /// A `measured <= target` check.
    pub fn at_most(group: &str, kind: &str, figure: String, measured: f64, target: f64) -> Check {
        Check {
            group: group.to_owned(),
            kind: kind.to_owned(),
            figure,
            met: measured <= target,
            ratio: target / measured,
        }
    }
}

/// One Markdown row per (group, kind), in order of first appearance: `met`, `not met`, or
/// `k of n met`, and the closest figure (the not-met one nearest its target; when all are
/// met, the one with the least margin). `group_header` names the first column.
pub fn condensed(group_header: &str, checks: &[Check]) -> String {
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for c in checks {
        let key = (c.group.as_str(), c.kind.as_str());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let rows: Vec<Vec<String>> = keys
        .iter()
        .map(|&(group, kind)| {
            let these: Vec<&Check> = checks
                .iter()
                .filter(|c| c.group == group && c.kind == kind)
                .collect();
            let n = these.len();
            let met = these.iter().filter(|c| c.met).count();
            let verdict = match (met, n) {
                (m, n) if m == n && n == 1 => "met".to_owned(),
                (m, n) if m == n => format!("met ({n} of {n})"),
                (0, 1) => "not met".to_owned(),
                (0, n) => format!("not met (0 of {n})"),
                (m, n) => format!("{m} of {n} met"),
            };
            let by_ratio = |a: &&&Check, b: &&&Check| a.ratio.total_cmp(&b.ratio);
            let closest = if met == n {
                these
                    .iter()
                    .min_by(by_ratio)
                    .map(|c| format!("narrowest pass: {}", c.figure))
            } else {
                these
                    .iter()
                    .filter(|c| !c.met)
                    .max_by(by_ratio)
                    .map(|c| format!("nearest miss: {}", c.figure))
            };
            vec![
                group.to_owned(),
                kind.to_owned(),
                verdict,
                closest.unwrap_or_default(),
            ]
        })
        .collect();
    markdown_table(
        &[group_header, "target", "verdict", "closest figure"],
        &rows,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_fold_into_one_row_per_group_and_kind() {
        let speed = "speedup";
        let checks = vec![
            Check::at_least("car", speed, "sse 1.8x (>= 4x)".into(), 1.8, 4.0),
            Check::at_least("car", speed, "avx2 5.0x (>= 6x)".into(), 5.0, 6.0),
            Check::at_least("car", speed, "avx512 3.0x (>= 8x)".into(), 3.0, 8.0),
            Check::at_most("car", "time", "sse 1 s vs 2 s".into(), 1.0, 2.0),
            Check::at_most("car", "time", "avx2 1.9 s vs 2 s".into(), 1.9, 2.0),
            Check::at_least("room", speed, "sse 4.5x (>= 4x)".into(), 4.5, 4.0),
            Check::at_least("room", speed, "avx2 5.9x (>= 6x)".into(), 5.9, 6.0),
            Check::at_least("room", "psnr", "lowest 41 dB".into(), 41.0, 40.0),
            Check::at_least("hall", "psnr", "lowest 39 dB".into(), 39.0, 40.0),
        ];
        let md = condensed("scene", &checks);
        let lines: Vec<&str> = md.lines().collect();
        assert_eq!(
            lines[0], "| scene | target | verdict | closest figure |",
            "{md}"
        );
        assert_eq!(lines.len(), 2 + 5, "{md}");
        assert_eq!(
            lines[2],
            "| car | speedup | not met (0 of 3) | nearest miss: avx2 5.0x (>= 6x) |"
        );
        assert_eq!(
            lines[3],
            "| car | time | met (2 of 2) | narrowest pass: avx2 1.9 s vs 2 s |"
        );
        assert_eq!(
            lines[4],
            "| room | speedup | 1 of 2 met | nearest miss: avx2 5.9x (>= 6x) |"
        );
        assert_eq!(
            lines[5],
            "| room | psnr | met | narrowest pass: lowest 41 dB |"
        );
        assert_eq!(
            lines[6],
            "| hall | psnr | not met | nearest miss: lowest 39 dB |"
        );
    }
}
