//! `fractum verify`: runs the verification catalogue (every published verification and
//! benchmark case), measures each case, holds it against its reference, and writes
//! `DOCS/VERIFICATION.md` (the summary) and `DOCS/verification/` (one page per case, its
//! figures, and `results.ron`, the record that lets an unchanged case keep its result).
//!
//! - A case's key is a digest of its scene text after the edits, its step cap and checks, and
//!   the solver (the engine's and stock systems' sources, `build.rs`). A case whose key matches
//!   its record is not run again unless `--rerun`; one whose work folder holds an interrupted
//!   run of the same key resumes from its checkpoint.
//! - Cases run as child `fractum` processes (the same executable, so a user's binary with extra
//!   systems verifies its own catalogue), longest first, up to `--jobs` at once.
//! - The exit code is [`crate::EXIT_VERIFY_FAILED`] when a selected case falls outside its
//!   tolerance (an expected miss does not count) or could not be run or measured, and
//!   [`crate::EXIT_INTERRUPTED`] when interrupted.

mod args;
pub mod catalogue;
pub mod measure;
mod pages;
mod provenance;
pub mod record;
mod runner;
pub mod studies;

use crate::{EXIT_BAD_SCENE, EXIT_INTERRUPTED, EXIT_IO, EXIT_USAGE, EXIT_VERIFY_FAILED};
use args::Places;
pub use args::VerifyArgs;
use catalogue::{Case, Catalogue, Figure, Tier, edited_scene};
use indicatif::{ProgressBar, ProgressStyle};
use provenance::Provenance;
use record::{CaseRecord, Outcome, Results};
use runner::{Plan, Running, WorkDir};
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// The digest of the solver sources this binary was built from.
pub const SOLVER_DIGEST: &str = env!("FRACTUM_SOLVER_DIGEST");

static SIGNALS: AtomicU32 = AtomicU32::new(0);

/// `fractum verify`.
pub fn verify_command(args: &VerifyArgs) -> i32 {
    let places = match args.places() {
        Ok(places) => places,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_USAGE;
        }
    };
    let catalogue = match Catalogue::read(&places.catalogue) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_BAD_SCENE;
        }
    };
    let selected = match select(&catalogue, args, &places) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_USAGE;
        }
    };
    let results_path = places.docs.join("verification").join("results.ron");
    let mut results = match Results::read(&places.results_to_read()) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_IO;
        }
    };
    if args.list {
        outln!("{}", pages::listing(&catalogue, &results, &selected));
        return 0;
    }
    let mut session = Session::new(&catalogue, args, &places, &mut results, &results_path);
    let interrupted = session.run(&selected);
    let written = pages::write_all(&catalogue, &results, &places.docs);
    if written.is_ok() {
        eprintln!("{}", places.where_the_pages_are());
    }
    finish(&catalogue, &results, &selected, interrupted, written)
}

/// The cases `--case` or `--tier` select, in catalogue order.
fn select<'a>(
    catalogue: &'a Catalogue,
    args: &VerifyArgs,
    places: &Places,
) -> Result<Vec<&'a Case>, String> {
    if !args.case.is_empty() {
        return args
            .case
            .iter()
            .map(|name| {
                catalogue.case(name).ok_or_else(|| {
                    format!(
                        "no case {name:?} in {}; it has: {}",
                        places.catalogue.display(),
                        catalogue.names().join(", ")
                    )
                })
            })
            .collect();
    }
    if args.list && args.tier.is_none() {
        return Ok(catalogue.cases.iter().collect());
    }
    let tier = args.tier.unwrap_or(Tier::Quick);
    Ok(catalogue.cases.iter().filter(|c| c.tier == tier).collect())
}

/// Prints each selected check's standing and returns the exit code.
fn finish(
    catalogue: &Catalogue,
    results: &Results,
    selected: &[&Case],
    interrupted: bool,
    written: Result<(), String>,
) -> i32 {
    let mut failures = 0;
    for case in selected {
        for check in &case.checks {
            let evaluated = record::evaluate(catalogue, results, case, check);
            if evaluated.status.is_failure() {
                failures += 1;
            }
            outln!(
                "{:<22} {:<13} {}",
                case.name,
                evaluated.status.word(),
                record::describe(check, &evaluated)
            );
        }
    }
    if let Err(e) = written {
        eprintln!("error: {e}");
        return EXIT_IO;
    }
    if interrupted {
        eprintln!("interrupted: run `fractum verify` again with the same selection to resume");
        return EXIT_INTERRUPTED;
    }
    if failures > 0 {
        eprintln!("{failures} check(s) failed or could not be measured");
        return EXIT_VERIFY_FAILED;
    }
    0
}

/// What one invocation knows while it runs cases.
struct Session<'a> {
    catalogue: &'a Catalogue,
    args: &'a VerifyArgs,
    places: &'a Places,
    results: &'a mut Results,
    results_path: &'a Path,
    provenance: Provenance,
}

/// A case ready to run.
struct Job<'a> {
    case: &'a Case,
    key: String,
    work: WorkDir,
    plan: Plan,
}

impl<'a> Session<'a> {
    fn new(
        catalogue: &'a Catalogue,
        args: &'a VerifyArgs,
        places: &'a Places,
        results: &'a mut Results,
        results_path: &'a Path,
    ) -> Self {
        Self {
            catalogue,
            args,
            places,
            results,
            results_path,
            provenance: Provenance::now(),
        }
    }

    /// Runs the selection; whether it was interrupted.
    fn run(&mut self, selected: &[&'a Case]) -> bool {
        let mut jobs = Vec::new();
        for case in selected {
            match self.prepare(case) {
                Ok(Some(job)) if job.plan == Plan::Measure => self.measure(&job, 0.0),
                Ok(Some(job)) => jobs.push(job),
                Ok(None) => {}
                Err(e) => self.record_error(case, String::new(), e, 0.0),
            }
        }
        // Longest first: the last to finish starts first.
        jobs.sort_by(|a, b| b.case.cost.total_cmp(&a.case.cost));
        self.schedule(jobs)
    }

    /// The job for `case`, or `None` when its record stands (unchanged, nothing to measure).
    fn prepare(&mut self, case: &'a Case) -> Result<Option<Job<'a>>, String> {
        let path = self.catalogue.scene_path(case);
        let text = std::fs::read_to_string(&path)
            .map_err(|e| format!("cannot read the scene {}: {e}", path.display()))?;
        let scene = edited_scene(&text, case)?;
        let key = case_key(case, &scene);
        let work = WorkDir::new(&self.places.work, &case.name);
        let standing = self
            .results
            .cases
            .get(&case.name)
            .is_some_and(|r| r.key == key);
        if standing && !self.args.rerun {
            if work.finished(&key) {
                return Ok(Some(Job {
                    case,
                    key,
                    work,
                    plan: Plan::Measure,
                }));
            }
            outln!(
                "{:<22} unchanged since its last result; --rerun runs it again",
                case.name
            );
            return Ok(None);
        }
        let plan = if self.args.rerun {
            Plan::Fresh
        } else {
            work.plan(&key)
        };
        if plan == Plan::Fresh {
            work.prepare_fresh(&key, &scene)?;
        }
        Ok(Some(Job {
            case,
            key,
            work,
            plan,
        }))
    }

    /// Runs `jobs` up to `--jobs` at once; whether interrupted.
    fn schedule(&mut self, jobs: Vec<Job<'a>>) -> bool {
        if jobs.is_empty() {
            return false;
        }
        handle_signals();
        let exe = match std::env::current_exe() {
            Ok(exe) => exe,
            Err(e) => {
                for job in &jobs {
                    self.record_error(
                        job.case,
                        job.key.clone(),
                        format!("cannot find the fractum executable: {e}"),
                        0.0,
                    );
                }
                return false;
            }
        };
        let bar = progress_bar(jobs.len());
        let mut queue: std::collections::VecDeque<usize> = (0..jobs.len()).collect();
        let mut running: Vec<Running> = Vec::new();
        let mut interrupted = false;
        loop {
            if SIGNALS.load(Ordering::SeqCst) > 0 && !interrupted {
                interrupted = true;
                queue.clear();
                running
                    .iter_mut()
                    .for_each(|r| runner::interrupt(&mut r.child));
            }
            while running.len() < self.args.jobs && !interrupted {
                let Some(index) = queue.pop_front() else {
                    break;
                };
                if let Some(r) = self.start(&exe, &jobs[index], index, &bar) {
                    running.push(r);
                }
            }
            if running.is_empty() {
                break;
            }
            self.reap(&exe, &jobs, &mut running, &bar, interrupted);
            bar.set_message(running_message(&jobs, &running));
            std::thread::sleep(Duration::from_millis(200));
        }
        bar.finish_and_clear();
        interrupted
    }

    fn start(
        &mut self,
        exe: &Path,
        job: &Job<'a>,
        index: usize,
        bar: &ProgressBar,
    ) -> Option<Running> {
        let resuming = job.plan == Plan::Resume;
        let verb = if resuming { "resuming" } else { "starting" };
        bar.suspend(|| {
            outln!(
                "{:<22} {verb} ({}, about {})",
                job.case.name,
                job.case.title,
                job.case.cost_class()
            )
        });
        match runner::spawn(exe, &job.work, resuming, self.args.threads, job.case.steps) {
            Ok(child) => Some(Running {
                index,
                child,
                started: Instant::now(),
                resuming,
            }),
            Err(e) => {
                self.record_error(job.case, job.key.clone(), e, 0.0);
                bar.inc(1);
                None
            }
        }
    }

    /// Collects the children that ended: measures finished runs, records failures, and starts
    /// afresh a resume the checkpoint refused (written by another build).
    fn reap(
        &mut self,
        exe: &Path,
        jobs: &[Job<'a>],
        running: &mut Vec<Running>,
        bar: &ProgressBar,
        interrupted: bool,
    ) {
        let mut k = 0;
        while k < running.len() {
            let status = match running[k].child.try_wait() {
                Ok(Some(status)) => status,
                Ok(None) => {
                    k += 1;
                    continue;
                }
                Err(e) => {
                    let job = &jobs[running[k].index];
                    self.record_error(job.case, job.key.clone(), format!("lost the run: {e}"), 0.0);
                    running.swap_remove(k);
                    continue;
                }
            };
            let done = running.swap_remove(k);
            let job = &jobs[done.index];
            let wall = done.started.elapsed().as_secs_f64();
            job.work.add_wall(wall);
            let code = status.code().unwrap_or(-1);
            if code == 0 {
                bar.suspend(|| {
                    if let Err(e) = job.work.mark_done() {
                        eprintln!("warning: {e}");
                    }
                    self.measure(job, job.work.earlier_wall());
                });
                bar.inc(1);
            } else if code == EXIT_INTERRUPTED || interrupted {
                bar.suspend(|| {
                    outln!(
                        "{:<22} interrupted; its checkpoint is in {}",
                        job.case.name,
                        job.work.run_dir().display()
                    )
                });
            } else if done.resuming && (code == EXIT_IO || code == EXIT_BAD_SCENE) {
                bar.suspend(|| {
                    outln!(
                        "{:<22} its checkpoint cannot be resumed ({}); starting afresh",
                        job.case.name,
                        job.work.failure()
                    )
                });
                let fresh = std::fs::read_to_string(job.work.scene())
                    .map_err(|e| e.to_string())
                    .and_then(|scene| job.work.prepare_fresh(&job.key, &scene))
                    .and_then(|()| {
                        runner::spawn(exe, &job.work, false, self.args.threads, job.case.steps)
                    });
                match fresh {
                    Ok(child) => running.push(Running {
                        index: done.index,
                        child,
                        started: Instant::now(),
                        resuming: false,
                    }),
                    Err(e) => self.record_error(job.case, job.key.clone(), e, wall),
                }
            } else {
                let message = format!("the run exited with code {code}: {}", job.work.failure());
                bar.suspend(|| self.record_error(job.case, job.key.clone(), message, wall));
                bar.inc(1);
            }
        }
    }

    /// Measures the finished run of `job`, draws its figures and records the result.
    fn measure(&mut self, job: &Job<'a>, wall: f64) {
        let run_dir = job.work.run_dir();
        let mut record = self.provenance.record(&job.key, self.args.threads);
        let earlier = self
            .results
            .cases
            .get(&job.case.name)
            .filter(|r| r.key == job.key);
        // A re-measure of a standing result keeps its run's wall time, date and machine.
        if let (Some(old), true) = (earlier, wall == 0.0) {
            record = CaseRecord {
                values: Default::default(),
                measure_errors: Default::default(),
                figures: Vec::new(),
                ..old.clone()
            };
        } else {
            record.wall_s = wall;
        }
        for check in &job.case.checks {
            match check.measure.measure(&run_dir) {
                Ok(v) if v.is_finite() => {
                    record
                        .values
                        .insert(check.quantity.clone(), v * check.scale);
                }
                Ok(v) => {
                    record
                        .measure_errors
                        .insert(check.quantity.clone(), format!("measured {v}"));
                }
                Err(e) => {
                    record.measure_errors.insert(check.quantity.clone(), e);
                }
            }
        }
        record.figures = self.draw_figures(job.case, &run_dir);
        outln!(
            "{:<22} measured ({:.0} s of run)",
            job.case.name,
            record.wall_s
        );
        self.store(&job.case.name, record);
    }

    fn draw_figures(&self, case: &Case, run_dir: &Path) -> Vec<String> {
        let folder = self.places.docs.join("verification");
        if let Err(e) = std::fs::create_dir_all(&folder) {
            eprintln!("warning: cannot create {}: {e}", folder.display());
            return Vec::new();
        }
        let mut names = Vec::new();
        for (k, figure) in case.figures.iter().enumerate() {
            let name = format!("{}-{}.png", case.name, k + 1);
            match draw_figure(figure, run_dir, &self.catalogue.root, &folder.join(&name)) {
                Ok(()) => names.push(name),
                Err(e) => eprintln!("warning: {}: figure {}: {e}", case.name, k + 1),
            }
        }
        names
    }

    fn record_error(&mut self, case: &Case, key: String, message: String, wall: f64) {
        outln!("{:<22} ERROR {message}", case.name);
        let mut record = self.provenance.record(&key, self.args.threads);
        record.outcome = Outcome::Error(message);
        record.wall_s = wall;
        self.store(&case.name, record);
    }

    /// Keeps `record` and writes the results file at once, so an interruption loses nothing
    /// measured.
    fn store(&mut self, name: &str, record: CaseRecord) {
        self.results.cases.insert(name.to_string(), record);
        if let Err(e) = self.results.write(self.results_path) {
            eprintln!("warning: {e}");
        }
    }
}

fn draw_figure(
    figure: &Figure,
    run_dir: &Path,
    catalogue_root: &Path,
    output: &Path,
) -> Result<(), String> {
    match figure {
        Figure::Series { x, columns } => {
            let series = crate::plot::Series::read(&run_dir.join("series.csv"))?;
            crate::plot::plot(&series, x, columns, None, output).map(|_| ())
        }
        Figure::Snapshot {
            field,
            time,
            overlay,
            undeformed,
        } => {
            let mut frame = crate::snapshot::frame_near(run_dir, *time)?;
            if *undeformed {
                let first = crate::snapshot::frame_near(run_dir, Some(0.0))?;
                frame = crate::crossing::undeformed(&frame, &first)?;
            }
            let overlay = overlay
                .as_ref()
                .map(|file| crate::overlay::Overlay::read(&catalogue_root.join(file)))
                .transpose()?;
            let options = crate::snapshot::SnapshotOptions {
                field: field.clone(),
                overlay,
                ..Default::default()
            };
            crate::snapshot::snapshot(&frame, &options, output)
        }
    }
}

fn progress_bar(cases: usize) -> ProgressBar {
    let bar = ProgressBar::new(cases as u64);
    let style = ProgressStyle::with_template("[{elapsed_precise}] {pos}/{len} cases {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar
}

fn running_message(jobs: &[Job], running: &[Running]) -> String {
    let parts: Vec<String> = running
        .iter()
        .map(|r| {
            let job = &jobs[r.index];
            let t = job
                .work
                .simulated_time()
                .map_or(String::new(), |t| format!(" t = {t:.3e} s"));
            format!(
                "{} {:.0} s{t}",
                job.case.name,
                r.started.elapsed().as_secs_f64()
            )
        })
        .collect();
    format!("running: {}", parts.join("; "))
}

/// A digest of what decides a case's result besides the analysis: the edited scene, the step
/// cap, the checks' measures and scales, and the solver.
fn case_key(case: &Case, scene: &str) -> String {
    let measures: Vec<String> = case
        .checks
        .iter()
        .map(|c| format!("{:?}*{}", c.measure, c.scale))
        .collect();
    let text = format!(
        "{scene}\0{:?}\0{}\0{SOLVER_DIGEST}",
        case.steps,
        measures.join("\0")
    );
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for byte in text.bytes() {
        hash ^= u64::from(byte);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{hash:016x}")
}

/// Installs the SIGINT/SIGTERM handler: a first signal stops starting cases and passes one
/// interrupt to each child; a second exits at once (the children's checkpoints stand).
fn handle_signals() {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            if SIGNALS.fetch_add(1, Ordering::SeqCst) >= 1 {
                eprintln!("\nsecond interrupt: exiting now");
                std::process::exit(crate::EXIT_ABANDONED);
            }
            eprintln!("\ninterrupt: the running cases finish their step and write a checkpoint");
        });
    });
}
