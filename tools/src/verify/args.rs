//! The arguments of `fractum verify`, and where it reads its catalogue and writes its runs and
//! pages when the command line does not say.
//!
//! The defaults are those of the Fractum checkout the command runs in, found upwards from the
//! current folder (or from the binary's own, `target/release/fractum`), so `verify` works from
//! any folder of the checkout. The pages go under the runs' folder, starting from the published
//! record (docs/verification/results.ron) so that unchanged cases keep their results: a
//! `verify` leaves the published pages in docs/ as they are unless `--docs docs` asks for them.

use super::catalogue::Tier;
use std::path::{Path, PathBuf};

/// The arguments of `fractum verify`.
#[derive(Debug, clap::Args)]
pub struct VerifyArgs {
    /// The cases of this tier: `quick` (minutes, also run by `cargo test`) or `paper` (the
    /// published resolutions, hours) [default: quick, unless --case is given].
    #[arg(long, value_enum)]
    pub tier: Option<Tier>,
    /// Only these cases, by name (comma-separated or repeated).
    #[arg(long, value_delimiter = ',')]
    pub case: Vec<String>,
    /// List the cases with their tier, cost and last status, and run nothing.
    #[arg(long)]
    pub list: bool,
    /// Cases run at once.
    #[arg(long, default_value_t = 1, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=256))]
    pub jobs: usize,
    /// Threads for each case.
    #[arg(long, default_value_t = 1, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=crate::running::MAX_THREADS as u64))]
    pub threads: usize,
    /// Run the selected cases again even where their scene, checks and solver are unchanged.
    #[arg(long)]
    pub rerun: bool,
    /// The catalogue; scene paths in it are relative to its folder [default:
    /// tools/catalogue.ron of the checkout this runs in].
    #[arg(long)]
    pub catalogue: Option<PathBuf>,
    /// Where the cases' runs are kept, resumable and re-measurable [default: target/verify of
    /// the checkout].
    #[arg(long)]
    pub work: Option<PathBuf>,
    /// Where VERIFICATION.md and verification/ are written [default: WORK/docs, starting from
    /// the checkout's docs/verification/results.ron; `--docs docs` updates the published
    /// pages].
    #[arg(long)]
    pub docs: Option<PathBuf>,
}

/// The catalogue, the runs' folder and the pages' folder of one `verify`.
#[derive(Clone, Debug, PartialEq)]
pub struct Places {
    /// The catalogue file.
    pub catalogue: PathBuf,
    /// The runs' folder.
    pub work: PathBuf,
    /// The pages' folder (VERIFICATION.md, verification/).
    pub docs: PathBuf,
    /// The published pages' folder that seeds `docs`, when `docs` is the default.
    pub published: Option<PathBuf>,
}

impl VerifyArgs {
    /// Where this `verify` reads and writes.
    pub fn places(&self) -> Result<Places, String> {
        let root = checkout_root();
        let in_root = |relative: &str| root.as_ref().map(|r| r.join(relative));
        let catalogue = match (&self.catalogue, in_root("tools/catalogue.ron")) {
            (Some(file), _) => file.clone(),
            (None, Some(file)) => file,
            (None, None) => {
                return Err(
                    "`fractum verify` runs the catalogue of a Fractum checkout: run it \
                            inside one (any folder of it), or name a catalogue with --catalogue"
                        .into(),
                );
            }
        };
        let work = self
            .work
            .clone()
            .or_else(|| in_root("target/verify"))
            .unwrap_or_else(|| PathBuf::from("target/verify"));
        Ok(match &self.docs {
            Some(docs) => Places {
                catalogue,
                work,
                docs: docs.clone(),
                published: None,
            },
            None => Places {
                catalogue,
                docs: work.join("docs"),
                work,
                published: in_root("docs"),
            },
        })
    }
}

impl Places {
    /// The record of results to start from: the pages' own, or where they have none yet and
    /// are the default ones, the published record, so that unchanged cases keep their
    /// results (the record is written to the pages' folder).
    pub fn results_to_read(&self) -> PathBuf {
        let record = Path::new("verification").join("results.ron");
        let own = self.docs.join(&record);
        match &self.published {
            Some(published) if !own.exists() => published.join(&record),
            _ => own,
        }
    }

    /// The line that says where the pages went.
    pub fn where_the_pages_are(&self) -> String {
        let summary = self.docs.join("VERIFICATION.md");
        match &self.published {
            Some(published) => format!(
                "wrote {} and its pages; the published ones ({}) are as they were: `--docs {}` \
                 updates them",
                summary.display(),
                published.display(),
                published.display()
            ),
            None => format!("wrote {} and its pages", summary.display()),
        }
    }
}

/// The Fractum checkout around the current folder, or around the running binary.
fn checkout_root() -> Option<PathBuf> {
    let is_checkout =
        |dir: &Path| dir.join("tools/catalogue.ron").is_file() && dir.join("Cargo.toml").is_file();
    let from_here = std::env::current_dir().ok();
    let from_binary = std::env::current_exe().ok();
    [from_here, from_binary]
        .into_iter()
        .flatten()
        .find_map(|start| {
            start
                .ancestors()
                .find(|d| is_checkout(d))
                .map(Path::to_path_buf)
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(catalogue: Option<&str>, work: Option<&str>, docs: Option<&str>) -> VerifyArgs {
        VerifyArgs {
            tier: None,
            case: Vec::new(),
            list: false,
            jobs: 1,
            threads: 1,
            rerun: false,
            catalogue: catalogue.map(PathBuf::from),
            work: work.map(PathBuf::from),
            docs: docs.map(PathBuf::from),
        }
    }

    #[test]
    fn the_defaults_are_the_checkouts_and_leave_the_published_pages_alone() {
        // The tests run inside the checkout (tools/).
        let places = args(None, None, None).places().unwrap();
        let root = places
            .catalogue
            .parent()
            .unwrap()
            .parent()
            .unwrap()
            .to_path_buf();
        assert!(places.catalogue.ends_with("tools/catalogue.ron"));
        assert_eq!(places.work, root.join("target/verify"));
        assert_eq!(places.docs, root.join("target/verify/docs"));
        assert_eq!(places.published, Some(root.join("docs")));
        assert!(places.where_the_pages_are().contains("`--docs"));
        if !places.docs.join("verification/results.ron").exists() {
            let published = root.join("docs/verification/results.ron");
            assert_eq!(places.results_to_read(), published);
        }
    }

    #[test]
    fn what_the_command_line_names_wins() {
        let places = args(Some("c.ron"), Some("runs"), Some("pages"))
            .places()
            .unwrap();
        assert_eq!(places.catalogue, PathBuf::from("c.ron"));
        assert_eq!(places.work, PathBuf::from("runs"));
        assert_eq!(places.docs, PathBuf::from("pages"));
        assert_eq!(places.published, None);
        assert_eq!(
            places.results_to_read(),
            PathBuf::from("pages/verification/results.ron")
        );
    }
}
