//! Progress and parallelism of long jobs (`batch`, `reproduce`).

use std::io::IsTerminal;

/// A progress bar over `len` items on stderr when `enabled` and stderr is a terminal;
/// otherwise a hidden bar, so logs and pipes stay quiet.
pub fn bar(len: u64, enabled: bool) -> indicatif::ProgressBar {
    if !(enabled && std::io::stderr().is_terminal()) {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar
}

/// Runs `work` on a pool of `jobs` threads (0 = rayon's global pool, one per core).
pub fn with_jobs<T: Send>(
    jobs: usize,
    work: impl FnOnce() -> T + Send,
) -> Result<T, rayon::ThreadPoolBuildError> {
    if jobs == 0 {
        return Ok(work());
    }
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()?
        .install(work))
}
