//! Progress and parallelism of long jobs (`batch`, `augment`, `reproduce`, `export`).

use std::io::IsTerminal;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Seconds between progress lines when stderr is not a terminal (a Slurm or CI log):
/// `$DEXWARP_PROGRESS_S` when set (at least 0.05), else 15.
pub fn log_interval() -> Duration {
    std::env::var("DEXWARP_PROGRESS_S")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite())
        .map_or(Duration::from_secs(15), |s| {
            Duration::from_secs_f64(s.clamp(0.05, 3600.0))
        })
}

/// Progress of a long job over `len` items, on stderr: a bar when stderr is a terminal, a
/// plain line every [`log_interval`] otherwise (`what: done/total (share), rate, time left,
/// last item`), so a log shows the job is alive; nothing when not `enabled`.
#[derive(Debug)]
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    log: Option<Arc<Log>>,
    ticker: Option<std::thread::JoinHandle<()>>,
}

#[derive(Debug)]
struct Log {
    what: String,
    len: u64,
    start: Instant,
    state: Mutex<LogState>,
    wake: Condvar,
}

#[derive(Debug, Default)]
struct LogState {
    done: u64,
    message: String,
    finished: bool,
    /// Lines written so far.
    printed: u64,
}

impl Progress {
    /// A bar or a log over `len` items of a job named `what` (`reproduce`, `augment`, ...).
    pub fn new(what: &str, len: u64, enabled: bool) -> Progress {
        Self::with_interval(
            what,
            len,
            enabled,
            std::io::stderr().is_terminal(),
            log_interval(),
        )
    }

    fn with_interval(
        what: &str,
        len: u64,
        enabled: bool,
        terminal: bool,
        every: Duration,
    ) -> Progress {
        if !enabled {
            return Progress {
                bar: None,
                log: None,
                ticker: None,
            };
        }
        if terminal {
            let bar = indicatif::ProgressBar::new(len);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {pos}/{len} {msg}",
                )
                .expect("static template")
                .progress_chars("=> "),
            );
            return Progress {
                bar: Some(bar),
                log: None,
                ticker: None,
            };
        }
        let log = Arc::new(Log {
            what: what.to_string(),
            len,
            start: Instant::now(),
            state: Mutex::new(LogState::default()),
            wake: Condvar::new(),
        });
        let ticking = log.clone();
        let ticker = std::thread::Builder::new()
            .name("progress".into())
            .spawn(move || ticking.tick(every))
            .ok();
        Progress {
            bar: None,
            log: Some(log),
            ticker,
        }
    }

    /// One more item done.
    pub fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
        }
        if let Some(l) = &self.log {
            l.lock().done += n;
        }
    }

    /// What was last done (shown beside the count).
    pub fn set_message(&self, message: impl Into<String>) {
        let message = message.into();
        if let Some(b) = &self.bar {
            b.set_message(message.clone());
        }
        if let Some(l) = &self.log {
            l.lock().message = message;
        }
    }

    /// A line above the bar, or in the log.
    pub fn println(&self, line: impl AsRef<str>) {
        if let Some(b) = &self.bar {
            b.println(line.as_ref());
        } else if self.log.is_some() {
            eprintln!("{}", line.as_ref());
        }
    }

    /// Ends the job: the bar is cleared, the log says the last count.
    pub fn finish_and_clear(&mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
        if let Some(l) = &self.log {
            l.lock().finished = true;
            l.wake.notify_all();
        }
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish_and_clear();
    }
}

impl Log {
    fn lock(&self) -> std::sync::MutexGuard<'_, LogState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Prints a line every `every` until finished, and a last one then.
    fn tick(&self, every: Duration) {
        let mut state = self.lock();
        let mut last_done = None;
        loop {
            let (next, _) = self
                .wake
                .wait_timeout_while(state, every, |s| !s.finished)
                .unwrap_or_else(|p| p.into_inner());
            state = next;
            if state.finished && last_done == Some(state.done) {
                return;
            }
            eprintln!("{}", self.line(&state));
            state.printed += 1;
            last_done = Some(state.done);
            if state.finished {
                return;
            }
        }
    }

    fn line(&self, s: &LogState) -> String {
        line(
            &self.what,
            s.done,
            self.len,
            self.start.elapsed(),
            &s.message,
        )
    }
}

/// `what: done/total (share), rate, time left[, last: message]`.
fn line(what: &str, done: u64, len: u64, elapsed: Duration, message: &str) -> String {
    let secs = elapsed.as_secs_f64();
    let share = if len == 0 {
        100.0
    } else {
        100.0 * done as f64 / len as f64
    };
    let mut text = format!("{what}: {done}/{len} ({share:.0} %) in {}", clock(secs));
    if done > 0 && secs > 0.0 {
        let rate = done as f64 / secs;
        if rate >= 1.0 {
            text.push_str(&format!(", {rate:.1} per s"));
        } else {
            text.push_str(&format!(", {:.2} per min", rate * 60.0));
        }
        if done < len {
            let left = (len - done) as f64 / rate;
            text.push_str(&format!(", about {} left", clock(left)));
        }
    }
    if !message.is_empty() {
        text.push_str(&format!(", last: {message}"));
    }
    text
}

/// `1 h 02 min`, `3 min 05 s`, `12 s`.
fn clock(secs: f64) -> String {
    let s = secs.round() as u64;
    match (s / 3600, s / 60 % 60, s % 60) {
        (0, 0, s) => format!("{s} s"),
        (0, m, s) => format!("{m} min {s:02} s"),
        (h, m, _) => format!("{h} h {m:02} min"),
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_says_count_share_rate_and_time_left() {
        let l = line(
            "reproduce",
            12,
            48,
            Duration::from_secs(125),
            "mug_pass_wall lm_3.5mm",
        );
        assert_eq!(
            l,
            "reproduce: 12/48 (25 %) in 2 min 05 s, 5.76 per min, about 6 min 15 s left, last: mug_pass_wall lm_3.5mm"
        );
        assert_eq!(line("x", 0, 0, Duration::ZERO, ""), "x: 0/0 (100 %) in 0 s");
        assert_eq!(
            line("x", 30, 30, Duration::from_secs(10), ""),
            "x: 30/30 (100 %) in 10 s, 3.0 per s"
        );
        assert_eq!(clock(3725.0), "1 h 02 min");
    }

    #[test]
    fn without_a_terminal_lines_come_while_items_take_long() {
        let mut p = Progress::with_interval("job", 3, true, false, Duration::from_millis(20));
        assert!(p.bar.is_none() && p.log.is_some());
        p.inc(1);
        // No item finishes for a while: the ticker still writes, a line an interval.
        let log = p.log.clone().unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        while log.lock().printed < 2 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
        let while_waiting = log.lock().printed;
        assert!(while_waiting >= 2, "{while_waiting} lines");
        p.inc(2);
        p.finish_and_clear();
        assert!(p.ticker.is_none());
        // And the last count once it finished.
        let state = log.lock();
        assert_eq!(state.done, 3);
        assert!(state.printed > while_waiting, "no line at the end");
    }
}
