//! Progress for a log that is not a terminal (output redirected to a file, a batch job, CI, `nohup`):
//! the bar draws only on a terminal, so without this nothing was said until the summary. Plain lines
//! instead, as Cycles' and Mitsuba's logs have them: one each tenth of the target, and one at least
//! every half minute in between (or, for a render bounded by time alone, every ten seconds).

use std::io::{IsTerminal, Write};

/// Longest silence between two lines.
const MAX_SILENCE: f64 = 30.0;
/// Between lines of a render without a target.
const UNBOUNDED_EVERY: f64 = 10.0;

/// Where the last line was.
pub struct ProgressLog {
    enabled: bool,
    /// Tenths of the target said so far.
    tenths: u32,
    /// Seconds into the render of the last line.
    last: f64,
    /// Progress the render started from (a resumed checkpoint's): not this run's work.
    started_at: f64,
}

impl ProgressLog {
    /// Lines on stderr unless `quiet` or stderr is a terminal (where the bar draws), for a render
    /// that starts at `started_at` (a resumed one: its rate and ETA count this run's work alone).
    pub fn new(quiet: bool, started_at: f64) -> Self {
        Self { enabled: !quiet && !std::io::stderr().is_terminal(), tenths: 0, last: 0.0, started_at }
    }

    /// Say where the render is, if a tenth was passed or the log has been silent too long.
    pub fn update(&mut self, progress: &caustica::Progress, seconds: f64) {
        if !self.enabled {
            return;
        }
        if let Some(line) = self.line(progress, seconds) {
            // A log that cannot be written stops nothing: the render and its summary go on.
            let _ = writeln!(std::io::stderr(), "{line}");
        }
    }

    fn line(&mut self, progress: &caustica::Progress, seconds: f64) -> Option<String> {
        let unit = progress.unit.name();
        let rate = (progress.done - self.started_at).max(0.0) / seconds.max(1e-9);
        if progress.target == u32::MAX {
            if seconds - self.last < UNBOUNDED_EVERY {
                return None;
            }
            self.last = seconds;
            return Some(format!(
                "progress    {:.1} {unit}, {rate:.2} {unit}/s, {seconds:.1} s",
                progress.done
            ));
        }
        let target = progress.target.max(1) as f64;
        let tenths = ((10.0 * progress.done / target).floor() as u32).min(10);
        if tenths <= self.tenths && seconds - self.last < MAX_SILENCE {
            return None;
        }
        (self.tenths, self.last) = (tenths.max(self.tenths), seconds);
        let eta = if rate > 0.0 {
            format!(", ETA {:.1} s", (target - progress.done).max(0.0) / rate)
        } else {
            String::new()
        };
        Some(format!(
            "progress    {:>3.0}%  {:.1}/{} {unit}, {rate:.2} {unit}/s, {seconds:.1} s{eta}",
            100.0 * progress.done / target,
            progress.done,
            progress.target
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use caustica::Progress;

    fn at(done: f64) -> Progress {
        Progress { unit: caustica::plan::Unit::Samples, done, target: 64 }
    }

    /// A line at each tenth passed (one for several passed at once), and one after half a minute of
    /// silence; none in between.
    #[test]
    fn a_line_each_tenth_and_after_half_a_minute_of_silence() {
        let mut log = ProgressLog { enabled: true, tenths: 0, last: 0.0, started_at: 0.0 };
        assert_eq!(log.line(&at(3.0), 1.0), None, "under a tenth");
        let line = log.line(&at(6.5), 2.0).expect("a tenth passed");
        assert!(line.contains("10%") && line.contains("6.5/64 spp"), "{line}");
        assert_eq!(log.line(&at(7.0), 3.0), None, "the same tenth");
        assert!(log.line(&at(33.0), 4.0).expect("several tenths at once").contains("52%"));
        assert_eq!(log.line(&at(33.5), 20.0), None);
        assert!(log.line(&at(34.0), 34.5).is_some(), "half a minute after the last line");
        assert!(log.line(&at(64.0), 40.0).expect("done").contains("100%"));
        assert_eq!(log.line(&at(64.0), 41.0), None, "said once");
    }

    /// Without a target (a time limit alone), every ten seconds.
    #[test]
    fn a_render_without_a_target_says_where_it_is_every_ten_seconds() {
        let mut log = ProgressLog { enabled: true, tenths: 0, last: 0.0, started_at: 0.0 };
        let unbounded = |done| Progress { target: u32::MAX, ..at(done) };
        assert_eq!(log.line(&unbounded(5.0), 9.0), None);
        assert!(log.line(&unbounded(6.0), 10.5).expect("ten seconds").contains("6.0 spp"));
        assert_eq!(log.line(&unbounded(7.0), 15.0), None);
    }

    /// A resumed render's rate and ETA count this run's samples, not the checkpoint's: resumed at
    /// 32 of 64 spp, 4 more in 2 s is 2 spp/s and 14 s to go (it said 18 spp/s and 0.9 s).
    #[test]
    fn a_resumed_render_counts_its_own_rate() {
        let mut log = ProgressLog { enabled: true, tenths: 3, last: 0.0, started_at: 32.0 };
        let line = log.line(&at(36.0), 2.0).expect("a tenth passed");
        assert!(line.contains("2.00 spp/s") && line.contains("ETA 14.0 s"), "{line}");
    }
}
