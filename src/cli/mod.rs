//! The `coherent` binary's subcommands that need more than a few lines.

pub mod export;
pub mod render;
pub mod view;

use anyhow::bail;
use coherent::simd::Backend;

/// The most worker threads `--threads` accepts: far more than any machine of ours has cores
/// (rayon's pool with thousands of threads took minutes to start and stop for a 0.01 s frame).
const MAX_THREADS: usize = 1024;

/// `--backend NAME`, checked against this CPU; the widest usable backend without it.
pub fn backend_arg(name: Option<&str>) -> anyhow::Result<Backend> {
    match name {
        Some(b) => {
            let b: Backend = b.parse()?;
            if let Some(reason) = b.unavailable_reason() {
                bail!("backend `{}` cannot run here: {reason}", b.name());
            }
            Ok(b)
        }
        None => Ok(Backend::widest()),
    }
}

/// `--threads N`, checked: 1 to [`MAX_THREADS`].
pub fn threads_arg(threads: Option<usize>) -> anyhow::Result<Option<usize>> {
    match threads {
        Some(t) if !(1..=MAX_THREADS).contains(&t) => bail!(
            "--threads {t}: must be 1 to {MAX_THREADS} (this machine runs {} at once)",
            std::thread::available_parallelism().map_or(1, |n| n.get())
        ),
        t => Ok(t),
    }
}
