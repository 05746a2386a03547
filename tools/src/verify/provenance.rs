//! Where and when verification results are made: the commit (marked when the solver's sources
//! differ from it), the UTC date, the processor and its load.

use super::record::{CaseRecord, Outcome};

/// Where and when results are made: commit, date, machine.
pub(super) struct Provenance {
    commit: String,
    date: String,
    processor: String,
}

impl Provenance {
    /// The provenance of results made now, here.
    pub(super) fn now() -> Self {
        Self {
            commit: commit(),
            date: utc_date(std::time::SystemTime::now()),
            processor: processor(),
        }
    }

    /// A completed record of case `key` run on `threads` threads, stamped with where and
    /// when, with the machine's load.
    pub(super) fn record(&self, key: &str, threads: usize) -> CaseRecord {
        let load = std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|l| l.split_whitespace().next().map(str::to_string))
            .map_or(String::new(), |l| format!(", load {l}"));
        CaseRecord {
            key: key.to_string(),
            outcome: Outcome::Completed,
            values: Default::default(),
            measure_errors: Default::default(),
            wall_s: 0.0,
            threads,
            date: self.date.clone(),
            commit: self.commit.clone(),
            machine: format!("{}{load}", self.processor),
            figures: Vec::new(),
        }
    }
}

/// The short commit, with `+` when the engine, systems or lock file differ from it.
fn commit() -> String {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let Some(head) = git(&["rev-parse", "--short", "HEAD"]) else {
        return "unknown".into();
    };
    let dirty = git(&[
        "status",
        "--porcelain",
        "--",
        "engine",
        "systems",
        "Cargo.lock",
    ])
    .is_some_and(|s| !s.is_empty());
    if dirty { format!("{head}+") } else { head }
}

/// The processor's model and the number of cores.
fn processor() -> String {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.split_whitespace().collect::<Vec<_>>().join(" "))
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    format!("{model}, {cores} cores")
}

/// `YYYY-MM-DD` (UTC) of `time`.
fn utc_date(time: std::time::SystemTime) -> String {
    let days = time
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400) as i64;
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn dates_are_civil_utc() {
        let at = |s: u64| utc_date(std::time::UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01");
        assert_eq!(at(951_782_400), "2000-02-29");
        assert_eq!(at(1_795_574_400), "2026-11-25");
    }
}
