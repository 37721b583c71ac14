//! Progress on stderr: a bar with ETA on a terminal, plain lines every few seconds otherwise.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;

/// Progress on stderr: a bar with ETA on a terminal, plain lines every few seconds otherwise.
/// Under a time limit (seconds) the fraction done is at least the fraction of the limit
/// spent, so the ETA never passes the limit.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    start: Instant,
    last: Mutex<f64>,
    limit: Option<f64>,
}

/// Steps of the terminal bar: it shows a fraction, not a sample count.
const BAR_STEPS: u64 = 1000;

impl Progress {
    pub fn new(limit: Option<f64>) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let b = indicatif::ProgressBar::new(0);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] [{wide_bar}] {percent:>3}% ETA {eta}",
            ) {
                b.set_style(style);
            }
            b
        });
        Progress {
            bar,
            start: Instant::now(),
            last: Mutex::new(0.0),
            limit,
        }
    }

    pub fn update(&self, done: usize, total: usize) {
        let t = self.start.elapsed().as_secs_f64();
        let mut frac = done as f64 / total.max(1) as f64;
        if let Some(limit) = self.limit.filter(|&l| l > 0.0) {
            frac = frac.max((t / limit).min(1.0));
        }
        if let Some(b) = &self.bar {
            b.set_length(BAR_STEPS);
            b.set_position((frac * BAR_STEPS as f64) as u64);
            return;
        }
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        if t - *last >= 5.0 && done < total {
            *last = t;
            let eta = if frac > 0.0 { t / frac - t } else { f64::NAN };
            eprintln!(
                "progress: {:5.1}% after {:.1} s, ETA {:.1} s",
                frac * 100.0,
                t,
                eta
            );
        }
    }

    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
