//! The verification catalogue: every case `fractum verify` knows, each a declarative entry read
//! from a RON file (`tools/catalogue.ron` ships the published ones).
//!
//! A case is one run: a scene, textual edits to it (resolution, speed, a variant) and the
//! checks measured on its outputs. A check names the quantity, how it is measured
//! ([`Measure`]), the reference value and where it comes from ([`Source`]), the tolerance,
//! and, for a published number Fractum does not reproduce, the reason it is an expected miss.

use super::measure::Measure;
use fractum_engine::text::{Location, SceneError, parse_fragment};
use serde::Deserialize;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// How long a case takes: `quick` cases run in `cargo test`; `paper` cases are the release runs
/// at the published resolutions.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, clap::ValueEnum)]
pub enum Tier {
    /// Minutes in all; run by `cargo test`.
    Quick,
    /// The published resolutions; hours on two cores.
    Paper,
}

impl Tier {
    /// The tier's name as the command line writes it.
    pub fn name(self) -> &'static str {
        match self {
            Tier::Quick => "quick",
            Tier::Paper => "paper",
        }
    }
}

/// A textual edit of the scene: every occurrence of `find` becomes `replace` (as the scenes'
/// headers give their variants, `sed -e 's/find/replace/'`). An edit that finds nothing is an
/// error of the case, so a scene that changed under its catalogue entry is noticed.
#[derive(Clone, Debug, Deserialize, PartialEq, Eq, Hash)]
#[serde(deny_unknown_fields)]
pub struct Edit {
    /// Text to find.
    pub find: String,
    /// Its replacement.
    pub replace: String,
}

/// Where a reference value comes from.
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub enum Source {
    /// A published paper: which, and where in it.
    Paper(String),
    /// A closed-form solution: which.
    Analytic(String),
    /// Laboratory measurements: whose.
    Experiment(String),
    /// Another case's measured value of the same quantity (a convergence or consistency
    /// study): the case's name.
    Case(String),
}

impl Source {
    /// The kind, as the pages print it.
    pub fn kind(&self) -> &'static str {
        match self {
            Source::Paper(_) => "paper",
            Source::Analytic(_) => "analytic",
            Source::Experiment(_) => "experiment",
            Source::Case(_) => "case",
        }
    }

    /// The source's text.
    pub fn text(&self) -> &str {
        match self {
            Source::Paper(s) | Source::Analytic(s) | Source::Experiment(s) | Source::Case(s) => s,
        }
    }
}

/// How far a measured value may lie from its reference.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
pub enum Tolerance {
    /// |measured − reference| ≤ this fraction of |reference|.
    Relative(f64),
    /// |measured − reference| ≤ this, in the check's unit.
    Absolute(f64),
}

impl Tolerance {
    /// The allowed deviation from `reference`.
    pub fn allowed(self, reference: f64) -> f64 {
        match self {
            Tolerance::Relative(r) => r * reference.abs(),
            Tolerance::Absolute(a) => a,
        }
    }

    /// As the pages print it.
    pub fn describe(self, unit: &str) -> String {
        match self {
            Tolerance::Relative(r) => format!("±{}%", trim(100.0 * r)),
            Tolerance::Absolute(a) => format!("±{} {unit}", trim(a)).trim_end().to_string(),
        }
    }
}

/// A number printed without trailing zeros.
pub fn trim(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// One measured quantity of a case and what it is held against.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Check {
    /// The quantity, as the tables name it (unique within the case).
    pub quantity: String,
    /// Its unit in the tables ("" for a ratio).
    #[serde(default)]
    pub unit: String,
    /// How it is measured from the run's outputs (in SI units).
    pub measure: Measure,
    /// The SI value is multiplied by this for the tables (1e3 for mJ, 1e-3 for km/s).
    #[serde(default = "one")]
    pub scale: f64,
    /// The reference value, in the table's unit (ignored for a `Case` source, whose value is
    /// that case's measurement).
    #[serde(default)]
    pub reference: f64,
    /// Where the reference comes from.
    pub source: Source,
    /// How far from the reference the measurement may lie.
    pub tolerance: Tolerance,
    /// Why the tolerance is as wide as it is. Optional in a catalogue of your own; every check
    /// of Fractum's own catalogue states one (its pages print "not stated" otherwise).
    #[serde(default)]
    pub basis: Option<Basis>,
    /// A published number Fractum does not reproduce: why. The check is then reported as an
    /// expected miss, not a failure, while it stays outside the tolerance.
    #[serde(default)]
    pub expected_miss: Option<String>,
}

/// The basis of a check's tolerance: where its width comes from, in words.
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub enum Basis {
    /// The experiments' own scatter (one standard deviation of the specimens, say).
    Scatter(String),
    /// The discretisation error expected, or measured, at the case's resolution.
    Discretisation(String),
    /// The spread of the published results themselves (between methods, or read off a
    /// figure).
    Paper(String),
    /// A criterion the check states for itself: an exact count, a share of the energy in play.
    Criterion(String),
}

impl Basis {
    /// The kind, as the summary table prints it.
    pub fn kind(&self) -> &'static str {
        match self {
            Basis::Scatter(_) => "experimental scatter",
            Basis::Discretisation(_) => "discretisation",
            Basis::Paper(_) => "the paper's spread",
            Basis::Criterion(_) => "criterion",
        }
    }

    /// The basis in words.
    pub fn text(&self) -> &str {
        match self {
            Basis::Scatter(t)
            | Basis::Discretisation(t)
            | Basis::Paper(t)
            | Basis::Criterion(t) => t,
        }
    }
}

fn one() -> f64 {
    1.0
}

/// A picture of the case on its page.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Figure {
    /// Series columns against another column (`x`, default `time`).
    Series {
        /// The horizontal axis.
        #[serde(default = "time_column")]
        x: String,
        /// The curves.
        columns: Vec<String>,
    },
    /// The particles of a frame coloured by a field (`fractum snapshot`), at the frame nearest
    /// `time` (the last when absent).
    Snapshot {
        /// The field.
        field: String,
        /// Time of the frame.
        #[serde(default)]
        time: Option<f64>,
        /// Lines drawn over it ([`Overlay`](crate::overlay::Overlay)'s CSV), relative to the
        /// catalogue's folder: an experiment's traced cracks, say.
        #[serde(default)]
        overlay: Option<String>,
        /// The frame's particles drawn where the first frame had them
        /// ([`undeformed`](crate::crossing::undeformed)): a broken specimen put back together.
        #[serde(default)]
        undeformed: bool,
    },
}

fn time_column() -> String {
    "time".to_string()
}

/// One verification case.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Unique name (letters, digits, `_` and `-`): the page's file name and `--case`'s value.
    pub name: String,
    /// One line for tables.
    pub title: String,
    /// What the case tests and how, for its page.
    pub about: String,
    /// The tier that runs it.
    pub tier: Tier,
    /// The scene, relative to the catalogue's folder.
    pub scene: String,
    /// Edits applied to the scene's text before it runs.
    #[serde(default)]
    pub edits: Vec<Edit>,
    /// Stop at this step instead of the scene's end.
    #[serde(default)]
    pub steps: Option<u64>,
    /// Estimated wall time on one thread of the development machine (s): the cost class
    /// printed by `--list`, and the order in which cases start (longest first).
    pub cost: f64,
    /// The quantities measured.
    pub checks: Vec<Check>,
    /// Pictures for the page.
    #[serde(default)]
    pub figures: Vec<Figure>,
}

impl Case {
    /// The cost class: seconds, minutes or hours.
    pub fn cost_class(&self) -> String {
        if self.cost < 90.0 {
            format!("{:.0} s", self.cost)
        } else if self.cost < 5400.0 {
            format!("{:.0} min", self.cost / 60.0)
        } else {
            format!("{:.1} h", self.cost / 3600.0)
        }
    }
}

/// The catalogue file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Catalogue {
    /// The cases, in the order the summary lists them.
    pub cases: Vec<Case>,
    /// Convergence studies over the cases (`verify::studies`).
    #[serde(default)]
    pub studies: Vec<Study>,
    /// The folder scene paths are relative to (the catalogue's own).
    #[serde(skip)]
    pub root: PathBuf,
}

impl Catalogue {
    /// Reads and checks a catalogue file; errors name `file:line:col` and the field.
    pub fn read(path: &Path) -> Result<Self, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| {
            SceneError::whole_file(&name, format!("cannot read the catalogue: {e}"))
        })?;
        let mut catalogue: Catalogue =
            parse_fragment(&name, &text, Location { line: 1, col: 1 }, "")?;
        catalogue.root = path.parent().map(Path::to_path_buf).unwrap_or_default();
        catalogue
            .check()
            .map_err(|(field, message)| SceneError::unplaced(&name, &field, message))?;
        Ok(catalogue)
    }

    /// Names unique and well formed, references to cases that exist, tolerances positive.
    fn check(&self) -> Result<(), (String, String)> {
        let mut names = BTreeSet::new();
        for (k, case) in self.cases.iter().enumerate() {
            let field = format!("cases[{k}]");
            let well_formed = !case.name.is_empty()
                && case
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
            if !well_formed {
                return Err((
                    format!("{field}.name"),
                    format!("{:?}: expected letters, digits, `_` or `-`", case.name),
                ));
            }
            if !names.insert(case.name.as_str()) {
                return Err((
                    format!("{field}.name"),
                    format!("{:?} names two cases", case.name),
                ));
            }
            case_checks_valid(case).map_err(|(f, m)| (format!("{field}.{f}"), m))?;
            self.overlays_readable(case)
                .map_err(|(f, m)| (format!("{field}.{f}"), m))?;
        }
        for (k, case) in self.cases.iter().enumerate() {
            for (j, check) in case.checks.iter().enumerate() {
                if let Source::Case(other) = &check.source {
                    let Some(target) = self.case(other) else {
                        return Err((
                            format!("cases[{k}].checks[{j}].source"),
                            format!("no case {other:?} in the catalogue"),
                        ));
                    };
                    if !target.checks.iter().any(|c| c.quantity == check.quantity) {
                        return Err((
                            format!("cases[{k}].checks[{j}].source"),
                            format!("case {other:?} measures no {:?}", check.quantity),
                        ));
                    }
                }
            }
        }
        check_studies(self)
    }

    /// Every figure's overlay file reads.
    fn overlays_readable(&self, case: &Case) -> Result<(), (String, String)> {
        for (k, figure) in case.figures.iter().enumerate() {
            if let Figure::Snapshot {
                overlay: Some(file),
                ..
            } = figure
            {
                crate::overlay::Overlay::read(&self.root.join(file))
                    .map_err(|e| (format!("figures[{k}].overlay"), e))?;
            }
        }
        Ok(())
    }

    /// The case named `name`.
    pub fn case(&self, name: &str) -> Option<&Case> {
        self.cases.iter().find(|c| c.name == name)
    }

    /// The scene file of `case`.
    pub fn scene_path(&self, case: &Case) -> PathBuf {
        self.root.join(&case.scene)
    }

    /// The known case names, for an error message.
    pub fn names(&self) -> Vec<&str> {
        self.cases.iter().map(|c| c.name.as_str()).collect()
    }
}

fn case_checks_valid(case: &Case) -> Result<(), (String, String)> {
    if case.checks.is_empty() {
        return Err(("checks".into(), "a case needs at least one check".into()));
    }
    if !(case.cost.is_finite() && case.cost > 0.0) {
        return Err((
            "cost".into(),
            "expected a positive number of seconds".into(),
        ));
    }
    let mut quantities = BTreeSet::new();
    for (j, check) in case.checks.iter().enumerate() {
        let field = format!("checks[{j}]");
        if !quantities.insert(check.quantity.as_str()) {
            return Err((
                format!("{field}.quantity"),
                format!("{:?} is measured twice", check.quantity),
            ));
        }
        let tolerance = match check.tolerance {
            Tolerance::Relative(t) | Tolerance::Absolute(t) => t,
        };
        if !(tolerance.is_finite() && tolerance >= 0.0) {
            return Err((
                format!("{field}.tolerance"),
                "expected a finite, non-negative tolerance".into(),
            ));
        }
        if !(check.scale.is_finite() && check.scale != 0.0) {
            return Err((
                format!("{field}.scale"),
                "expected a finite, non-zero factor".into(),
            ));
        }
        check
            .measure
            .validate()
            .map_err(|m| (format!("{field}.measure"), m))?;
    }
    Ok(())
}

/// The scene text of `case` with its edits applied; an error names the edit that found nothing.
pub fn edited_scene(text: &str, case: &Case) -> Result<String, String> {
    let mut edited = text.to_string();
    for (k, edit) in case.edits.iter().enumerate() {
        if edit.find.is_empty() || !edited.contains(&edit.find) {
            return Err(format!(
                "edits[{k}]: {:?} is not in the scene (was the scene changed?)",
                edit.find
            ));
        }
        edited = edited.replace(&edit.find, &edit.replace);
    }
    Ok(edited)
}

/// One quantity over runs that refine the cell.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Study {
    /// The heading of the study's table.
    pub title: String,
    /// The quantity, as each case's check names it.
    pub quantity: String,
    /// The cases, coarsest first.
    pub cases: Vec<String>,
    /// Each case's cell size, in `spacing_unit`, decreasing.
    pub spacings: Vec<f64>,
    /// The unit of the spacings in the table.
    pub spacing_unit: String,
}

/// Cases that exist and measure the quantity, as many spacings as cases (at least three), the
/// spacings decreasing.
fn check_studies(catalogue: &Catalogue) -> Result<(), (String, String)> {
    for (k, study) in catalogue.studies.iter().enumerate() {
        let field = format!("studies[{k}]");
        if study.cases.len() < 3 || study.cases.len() != study.spacings.len() {
            return Err((
                format!("{field}.spacings"),
                format!(
                    "expected at least three cases and one spacing for each, got {} cases and {} \
                     spacings",
                    study.cases.len(),
                    study.spacings.len()
                ),
            ));
        }
        if study
            .spacings
            .windows(2)
            .any(|w| !(w[1] < w[0] && w[1] > 0.0))
        {
            return Err((
                format!("{field}.spacings"),
                "expected positive spacings, coarsest first".into(),
            ));
        }
        for (j, name) in study.cases.iter().enumerate() {
            let measures = catalogue
                .case(name)
                .is_some_and(|c| c.checks.iter().any(|c| c.quantity == study.quantity));
            if !measures {
                return Err((
                    format!("{field}.cases[{j}]"),
                    format!("no case {name:?} measuring {:?}", study.quantity),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const ONE_CASE: &str = r#"(cases: [(
        name: "bar", title: "a bar", about: "it rings", tier: Quick,
        scene: "bar.ron", cost: 3.0,
        edits: [(find: "spacing: 1.0", replace: "spacing: 0.5")],
        checks: [(quantity: "peak", unit: "N", measure: SeriesPeak(column: "reaction_top_y"),
                  reference: 2.0, source: Analytic("F = k u"), tolerance: Relative(0.05))],
    )])"#;

    fn write(dir: &Path, text: &str) -> PathBuf {
        let path = dir.join("catalogue.ron");
        std::fs::write(&path, text).unwrap();
        path
    }

    /// A scratch folder removed when the test lets go of it.
    struct TempDir(PathBuf);

    impl std::ops::Deref for TempDir {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn temp_dir(name: &str) -> TempDir {
        let dir =
            std::env::temp_dir().join(format!("fractum-catalogue-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    /// Every check Fractum publishes says where its tolerance comes from; a catalogue of a
    /// user's own may leave it out.
    #[test]
    fn every_published_check_states_the_basis_of_its_tolerance() {
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("catalogue.ron");
        let catalogue = Catalogue::read(&shipped).unwrap_or_else(|e| panic!("{e}"));
        let unstated: Vec<String> = catalogue
            .cases
            .iter()
            .flat_map(|case| {
                case.checks
                    .iter()
                    .filter(|check| check.basis.is_none())
                    .map(move |check| format!("{}: {}", case.name, check.quantity))
            })
            .collect();
        assert!(unstated.is_empty(), "no basis: {unstated:?}");
        let dir = temp_dir("basis");
        let own = Catalogue::read(&write(&dir, ONE_CASE)).unwrap();
        assert_eq!(own.cases[0].checks[0].basis, None);
    }

    /// A convergence study needs three cases that measure its quantity, coarsest first.
    #[test]
    fn a_study_is_refused_unless_three_cases_measure_its_quantity() {
        let dir = temp_dir("studies");
        let study = |cases: &str, spacings: &str| {
            ONE_CASE.trim_end().trim_end_matches(')').to_string()
                + &format!(
                    ", studies: [(title: \"t\", quantity: \"peak\", cases: [{cases}], \
                     spacings: [{spacings}], spacing_unit: \"m\")])"
                )
        };
        for (cases, spacings, expected) in [
            ("\"bar\"", "1.0", "at least three cases"),
            (
                "\"bar\", \"bar\", \"none\"",
                "1.0, 0.5, 0.25",
                "no case \"none\"",
            ),
            (
                "\"bar\", \"bar\", \"bar\"",
                "1.0, 2.0, 0.5",
                "coarsest first",
            ),
        ] {
            let e = Catalogue::read(&write(&dir, &study(cases, spacings))).unwrap_err();
            assert!(e.to_string().contains(expected), "{e}");
        }
        let fine = Catalogue::read(&write(
            &dir,
            &study("\"bar\", \"bar\", \"bar\"", "1.0, 0.5, 0.25"),
        ));
        assert_eq!(fine.unwrap().studies.len(), 1);
    }

    /// A figure's overlay is read with the catalogue, relative to its folder, so a missing or
    /// malformed file is an error of the catalogue, not a figure lost after a long run.
    #[test]
    fn an_overlay_that_does_not_read_is_refused_with_the_catalogue() {
        let dir = temp_dir("overlay");
        let with = |file: &str| {
            ONE_CASE.replace(
                "cost: 3.0,",
                &format!(
                    "cost: 3.0, figures: [Snapshot(field: \"damage\", overlay: Some({file:?}))],"
                ),
            )
        };
        let e = Catalogue::read(&write(&dir, &with("traces.csv")))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("figures[0].overlay") && e.contains("traces.csv"),
            "{e}"
        );
        std::fs::write(dir.join("traces.csv"), "line,x,y\n0,0.0,zero\n").unwrap();
        let e = Catalogue::read(&write(&dir, &with("traces.csv")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("traces.csv:2: column `y`"), "{e}");
        std::fs::write(dir.join("traces.csv"), "line,x,y\n0,0.0,0.0\n0,0.0,1.0\n").unwrap();
        assert!(Catalogue::read(&write(&dir, &with("traces.csv"))).is_ok());
    }

    #[test]
    fn a_catalogue_reads_with_its_root() {
        let dir = temp_dir("reads");
        let catalogue = Catalogue::read(&write(&dir, ONE_CASE)).unwrap();
        assert_eq!(catalogue.names(), ["bar"]);
        assert_eq!(
            catalogue.scene_path(&catalogue.cases[0]),
            dir.join("bar.ron")
        );
        assert_eq!(catalogue.cases[0].checks[0].scale, 1.0);
    }

    #[test]
    fn errors_name_the_place_and_the_field() {
        let dir = temp_dir("errors");
        let unknown = ONE_CASE.replace("cost: 3.0", "cost: 3.0, colour: 1");
        let e = Catalogue::read(&write(&dir, &unknown))
            .unwrap_err()
            .to_string();
        assert!(e.contains(":3:38:") && e.contains("colour"), "{e}");
        let twice = ONE_CASE.replace("(cases: [(", "(cases: [(name: \"bar\", title: \"\", about: \"\", tier: Paper, scene: \"x\", cost: 1.0, checks: [(quantity: \"q\", measure: SeriesFinal(column: \"a\"), source: Paper(\"p\"), tolerance: Absolute(1.0))]), (");
        let e = Catalogue::read(&write(&dir, &twice))
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"bar\" names two cases"), "{e}");
        let dangling = ONE_CASE.replace("Analytic(\"F = k u\")", "Case(\"rod\")");
        let e = Catalogue::read(&write(&dir, &dangling))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no case \"rod\""), "{e}");
    }

    #[test]
    fn edits_replace_every_occurrence_and_refuse_a_missing_text() {
        let dir = temp_dir("edits");
        let catalogue = Catalogue::read(&write(&dir, ONE_CASE)).unwrap();
        let case = &catalogue.cases[0];
        let edited = edited_scene("a spacing: 1.0, b spacing: 1.0", case).unwrap();
        assert_eq!(edited, "a spacing: 0.5, b spacing: 0.5");
        let e = edited_scene("spacing: 2.0", case).unwrap_err();
        assert!(e.contains("edits[0]") && e.contains("spacing: 1.0"), "{e}");
    }

    #[test]
    fn tolerances_and_cost_classes_print_plainly() {
        assert_eq!(Tolerance::Relative(0.05).describe("N"), "±5%");
        assert_eq!(Tolerance::Absolute(2.5).describe("°"), "±2.5 °");
        assert_eq!(Tolerance::Relative(0.05).allowed(-40.0), 2.0);
        let mut case = Catalogue::read(&write(&temp_dir("cost"), ONE_CASE))
            .unwrap()
            .cases[0]
            .clone();
        case.cost = 600.0;
        assert_eq!(case.cost_class(), "10 min");
    }
}
