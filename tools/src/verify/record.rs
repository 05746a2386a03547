//! The results `fractum verify` keeps: `DOCS/verification/results.ron`, one record per case
//! (the measured values, the run's wall time, commit, date and machine, and the key of the run
//! they came from), and the status of each check against its reference.
//!
//! The record is committed with the generated pages, so a case whose scene, edits, checks and
//! solver are unchanged is not run again by the next `verify`, on any machine, unless
//! `--rerun` asks.

use super::catalogue::{Case, Catalogue, Check, Source};
use fractum_io::output::write_atomically;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// What became of a case's run.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub enum Outcome {
    /// The run reached its end and was measured.
    Completed,
    /// The case could not be run or measured: why.
    Error(String),
}

/// The last result of one case.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub struct CaseRecord {
    /// The key of the run (scene text after edits, checks, solver digest).
    pub key: String,
    /// What became of it.
    pub outcome: Outcome,
    /// Measured value per quantity, in the check's unit.
    pub values: BTreeMap<String, f64>,
    /// Why a quantity could not be measured.
    #[serde(default)]
    pub measure_errors: BTreeMap<String, String>,
    /// Wall time of the run (s), summed over the sittings it took.
    pub wall_s: f64,
    /// Threads it ran with.
    pub threads: usize,
    /// UTC date of the result.
    pub date: String,
    /// The commit of the sources (`+` when they differed from it).
    pub commit: String,
    /// The machine: processor, cores, and the load when the case started.
    pub machine: String,
    /// The figures on its page (file names beside the page).
    #[serde(default)]
    pub figures: Vec<String>,
}

/// Every case's last result.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
pub struct Results {
    /// By case name.
    pub cases: BTreeMap<String, CaseRecord>,
}

impl Results {
    /// Reads `path`; a missing file is an empty record.
    pub fn read(path: &Path) -> Result<Self, String> {
        match std::fs::read_to_string(path) {
            Ok(text) => ron::from_str(&text).map_err(|e| format!("{}: {e}", path.display())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Self::default()),
            Err(e) => Err(format!("cannot read {}: {e}", path.display())),
        }
    }

    /// Writes `path` atomically.
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let config = ron::ser::PrettyConfig::new().depth_limit(3);
        let text = ron::ser::to_string_pretty(self, config).map_err(|e| e.to_string())?;
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        write_atomically(path, format!("{text}\n").as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    }
}

/// A check's standing.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Within the tolerance.
    Pass,
    /// Outside the tolerance: by how much beyond it, in the check's unit.
    Fail(f64),
    /// Outside the tolerance, as the catalogue expects (a published number not reproduced).
    ExpectedMiss(f64),
    /// Within the tolerance although the catalogue expects a miss: the entry is out of date.
    UnexpectedPass,
    /// Not measured: the run failed or the measure could not be taken.
    Error(String),
    /// No result yet (or its reference case has none).
    Pending,
}

impl Status {
    /// A word for the tables.
    pub fn word(&self) -> &'static str {
        match self {
            Status::Pass => "pass",
            Status::Fail(_) => "FAIL",
            Status::ExpectedMiss(_) => "expected miss",
            Status::UnexpectedPass => "pass (expected a miss)",
            Status::Error(_) => "ERROR",
            Status::Pending => "not run",
        }
    }

    /// Whether `verify` exits non-zero for it.
    pub fn is_failure(&self) -> bool {
        matches!(self, Status::Fail(_) | Status::Error(_))
    }
}

/// A check evaluated: measured value, reference value, status.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluated {
    /// In the check's unit.
    pub measured: Option<f64>,
    /// In the check's unit.
    pub reference: Option<f64>,
    /// The standing.
    pub status: Status,
}

/// Evaluates `check` of `case` from the results.
pub fn evaluate(catalogue: &Catalogue, results: &Results, case: &Case, check: &Check) -> Evaluated {
    let reference = match &check.source {
        Source::Case(other) => results
            .cases
            .get(other)
            .filter(|r| catalogue.case(other).is_some() && r.outcome == Outcome::Completed)
            .and_then(|r| r.values.get(&check.quantity).copied()),
        _ => Some(check.reference),
    };
    let Some(record) = results.cases.get(&case.name) else {
        return Evaluated {
            measured: None,
            reference,
            status: Status::Pending,
        };
    };
    let measured = record.values.get(&check.quantity).copied();
    let status = match (&record.outcome, measured, reference) {
        (Outcome::Error(e), _, _) => Status::Error(e.clone()),
        (_, None, _) => Status::Error(
            record
                .measure_errors
                .get(&check.quantity)
                .cloned()
                .unwrap_or_else(|| "not measured".into()),
        ),
        (_, Some(_), None) => Status::Pending,
        (_, Some(m), Some(r)) => standing(check, m, r),
    };
    Evaluated {
        measured,
        reference,
        status,
    }
}

fn standing(check: &Check, measured: f64, reference: f64) -> Status {
    let beyond = (measured - reference).abs() - check.tolerance.allowed(reference);
    match (beyond <= 0.0, check.expected_miss.is_some()) {
        (true, false) => Status::Pass,
        (true, true) => Status::UnexpectedPass,
        (false, false) => Status::Fail(beyond),
        (false, true) => Status::ExpectedMiss(beyond),
    }
}

/// One line saying how a check stands: for a failure, by how much.
pub fn describe(check: &Check, evaluated: &Evaluated) -> String {
    let unit = if check.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", check.unit)
    };
    let value = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{}{unit}", sig(v)));
    let against = format!(
        "{} against {} {}",
        value(evaluated.measured),
        value(evaluated.reference),
        check.tolerance.describe(&check.unit)
    );
    match &evaluated.status {
        Status::Fail(by) | Status::ExpectedMiss(by) => {
            let deviation = evaluated.measured.unwrap_or(0.0) - evaluated.reference.unwrap_or(0.0);
            format!(
                "{}: {against}: off by {}{unit}, {}{unit} beyond the tolerance",
                check.quantity,
                signed(deviation),
                sig(*by)
            )
        }
        Status::Error(e) => format!("{}: {e}", check.quantity),
        Status::Pending if evaluated.measured.is_some() => {
            format!(
                "{}: {against}: its reference case has no result",
                check.quantity
            )
        }
        _ => format!("{}: {against}", check.quantity),
    }
}

/// A value with four significant figures, without an exponent for everyday magnitudes.
pub fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let magnitude = v.abs().log10().floor() as i32;
    if (-3..6).contains(&magnitude) {
        let decimals = (3 - magnitude).max(0) as usize;
        trim_decimal(&format!("{v:.decimals$}"))
    } else {
        format!("{v:.3e}")
    }
}

fn trim_decimal(s: &str) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s.to_string()
    }
}

fn signed(v: f64) -> String {
    if v >= 0.0 {
        format!("+{}", sig(v))
    } else {
        sig(v)
    }
}

/// The tolerance as a phrase, for tables.
pub fn tolerance_text(check: &Check) -> String {
    check.tolerance.describe(&check.unit)
}

/// The tolerance with the kind of its basis, for the summary table: `±10% (discretisation)`.
pub fn tolerance_with_basis(check: &Check) -> String {
    match &check.basis {
        Some(basis) => format!("{} ({})", tolerance_text(check), basis.kind()),
        None => tolerance_text(check),
    }
}

/// The basis of the tolerance in full, for the case's page.
pub fn basis_text(check: &Check) -> String {
    match &check.basis {
        Some(basis) => format!("{}: {}", basis.kind(), basis.text()),
        None => "not stated".into(),
    }
}

/// A value and unit for tables.
pub fn with_unit(v: Option<f64>, unit: &str) -> String {
    match v {
        Some(v) if unit.is_empty() => sig(v),
        Some(v) => format!("{} {unit}", sig(v)),
        None => "—".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::catalogue::Tolerance;
    use super::super::measure::Measure;
    use super::*;

    fn check(tolerance: Tolerance, miss: Option<&str>) -> Check {
        Check {
            quantity: "angle".into(),
            unit: "°".into(),
            measure: Measure::Dissipated,
            scale: 1.0,
            reference: 60.0,
            source: Source::Paper("Table II".into()),
            tolerance,
            basis: None,
            expected_miss: miss.map(str::to_string),
        }
    }

    /// The summary prints the basis's kind beside the tolerance; the page prints it whole.
    #[test]
    fn a_tolerance_shows_its_basis() {
        use super::super::catalogue::Basis;
        let mut c = check(Tolerance::Absolute(5.0), None);
        assert_eq!(tolerance_with_basis(&c), "±5 °");
        assert_eq!(basis_text(&c), "not stated");
        c.basis = Some(Basis::Scatter("one SD of six specimens".into()));
        assert_eq!(tolerance_with_basis(&c), "±5 ° (experimental scatter)");
        assert_eq!(
            basis_text(&c),
            "experimental scatter: one SD of six specimens"
        );
    }

    #[test]
    fn a_value_outside_its_tolerance_fails_by_what_lies_beyond() {
        let c = check(Tolerance::Absolute(5.0), None);
        assert_eq!(standing(&c, 63.0, 60.0), Status::Pass);
        assert_eq!(standing(&c, 67.5, 60.0), Status::Fail(2.5));
        let evaluated = Evaluated {
            measured: Some(67.5),
            reference: Some(60.0),
            status: Status::Fail(2.5),
        };
        let text = describe(&c, &evaluated);
        assert!(text.contains("off by +7.5 °, 2.5 ° beyond"), "{text}");
        let relative = check(Tolerance::Relative(0.1), None);
        assert_eq!(standing(&relative, 54.0, 60.0), Status::Pass);
        assert!(standing(&relative, 53.0, 60.0).is_failure());
    }

    #[test]
    fn an_expected_miss_is_no_failure_and_a_pass_flags_the_entry() {
        let c = check(Tolerance::Absolute(1.0), Some("ordering not reproduced"));
        assert_eq!(standing(&c, 65.0, 60.0), Status::ExpectedMiss(4.0));
        assert!(!Status::ExpectedMiss(4.0).is_failure());
        assert_eq!(standing(&c, 60.5, 60.0), Status::UnexpectedPass);
    }

    #[test]
    fn values_print_with_four_figures() {
        assert_eq!(sig(59.4821), "59.48");
        assert_eq!(sig(0.0301234), "0.03012");
        assert_eq!(sig(1.23e-7), "1.230e-7");
        assert_eq!(sig(354.1), "354.1");
    }

    #[test]
    fn results_round_trip_through_their_file() {
        let dir = std::env::temp_dir().join(format!("fractum-results-{}", std::process::id()));
        let path = dir.join("verification/results.ron");
        assert_eq!(Results::read(&path).unwrap(), Results::default());
        let mut results = Results::default();
        results.cases.insert(
            "bar".into(),
            CaseRecord {
                key: "00ff".into(),
                outcome: Outcome::Completed,
                values: [("period".to_string(), 10.006)].into_iter().collect(),
                measure_errors: BTreeMap::new(),
                wall_s: 1.5,
                threads: 2,
                date: "2026-11-25".into(),
                commit: "abc1234".into(),
                machine: "2 cores".into(),
                figures: vec!["bar-1.png".into()],
            },
        );
        results.write(&path).unwrap();
        assert_eq!(Results::read(&path).unwrap(), results);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
