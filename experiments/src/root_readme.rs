//! The headline of the repository's README.md: the paper's Tables 1-5 against ours, a line
//! each, between two markers that `reproduce` rewrites whenever it writes the repository's
//! own `results/` folder (a run into any other folder leaves README.md alone).

use std::path::{Path, PathBuf};

use crate::ctx::Ctx;
use crate::experiment::Experiment;
use coherent::machine::Machine;

/// The line before the generated block.
pub const BEGIN: &str = "<!-- headline: written by `reproduce` from results/; do not edit -->";
/// The line after it.
pub const END: &str = "<!-- /headline -->";

/// Rewrites the headline block of the repository's README.md when `ctx.out` is the
/// repository's `results/`; returns the README's path when it did. A README without the
/// markers is left as it is.
pub fn update(ctx: &Ctx, registry: &[Experiment]) -> anyhow::Result<Option<PathBuf>> {
    let Some(root) = repository_root() else {
        return Ok(None);
    };
    if !is_repository_results(&ctx.out) {
        return Ok(None);
    }
    let path = root.join("README.md");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    let Some(new) = splice(&text, &block(ctx, registry)) else {
        return Ok(None);
    };
    if new != text {
        std::fs::write(&path, new)
            .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    }
    Ok(Some(path))
}

/// The root of the workspace this binary was built from.
fn repository_root() -> Option<&'static Path> {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent()
}

/// Whether `out` is the repository's own `results/` folder (the one README.md shows).
pub fn is_repository_results(out: &Path) -> bool {
    repository_results(out).is_some_and(|(out, results)| out == results)
}

/// Whether `out` is the repository's `results/` or a folder inside it (`results/native/`,
/// `results/manycore/`): what the repository publishes.
pub fn is_in_repository_results(out: &Path) -> bool {
    repository_results(out).is_some_and(|(out, results)| out.starts_with(results))
}

/// `out` and the repository's `results/`, both canonical, when both exist.
fn repository_results(out: &Path) -> Option<(PathBuf, PathBuf)> {
    let results = repository_root()?.join("results").canonicalize().ok()?;
    Some((out.canonicalize().ok()?, results))
}

/// The block: the first screen's table with its links made relative to the repository root,
/// and the machine it was measured on.
fn block(ctx: &Ctx, registry: &[Experiment]) -> String {
    let machine = std::fs::read_to_string(ctx.path("machine.json"))
        .ok()
        .and_then(|t| Machine::from_json(&t).ok());
    let emulated = machine.as_ref().is_some_and(Machine::is_emulated);
    let table = relink(&crate::headline::table(ctx, registry, emulated), "results/");
    let runs = crate::headline::runs_note(ctx);
    format!(
        "{table}\nSpeedups over our scalar backend in the same run, per lane-backend family; \
         the paper's over its non-SSE build. From [`results/`](results/README.md). {runs}\n"
    )
}

/// `md`'s relative Markdown links, written for a page in folder `dir`, rewritten for a page
/// one folder up: `](#a)` to `](dir/README.md#a)`, `](x)` to `](dir/x)`.
fn relink(md: &str, dir: &str) -> String {
    let mut out = String::with_capacity(md.len());
    let mut rest = md;
    while let Some(i) = rest.find("](") {
        out.push_str(&rest[..i + 2]);
        rest = &rest[i + 2..];
        if rest.starts_with('#') {
            out.push_str(dir);
            out.push_str("README.md");
        } else if !(rest.starts_with("http") || rest.starts_with('/')) {
            out.push_str(dir);
        }
    }
    out.push_str(rest);
    out
}

/// `text` with the lines between [`BEGIN`] and [`END`] replaced by `block`; `None` when the
/// markers are missing.
fn splice(text: &str, block: &str) -> Option<String> {
    let begin = text.find(BEGIN)? + BEGIN.len();
    let end = begin + text[begin..].find(END)?;
    Some(format!("{}\n{}{}", &text[..begin], block, &text[end..]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_are_rewritten_for_the_folder_above() {
        let md = "| [Table 1](#table1) | [t.csv](t.csv) | [x](https://a.b) |";
        assert_eq!(
            relink(md, "results/"),
            "| [Table 1](results/README.md#table1) | [t.csv](results/t.csv) | [x](https://a.b) |"
        );
    }

    #[test]
    fn the_block_between_the_markers_is_replaced_and_the_rest_kept() {
        let text = format!("intro\n{BEGIN}\nold\nlines\n{END}\nafter\n");
        let new = splice(&text, "new\n").unwrap();
        assert_eq!(new, format!("intro\n{BEGIN}\nnew\n{END}\nafter\n"));
        assert_eq!(splice(&new, "new\n").unwrap(), new);
        assert_eq!(splice("no markers", "new\n"), None);
    }
}
