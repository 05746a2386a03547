//! Scenes: reading a RON file with precise errors, validating it into a checked [`Spec`], and
//! building a [`fractum_engine::Simulation`] from the spec.
//!
//! A [`Spec`] is plain data (`spec/`); its verbs hand it to the phase that does the work, each
//! an object over the spec in its own files:
//! - `format/`: the file format, plain serde structs;
//! - `validate/`: the validator, file → [`Spec`] for the scene's dimension (coordinates,
//!   shapes and axes that fit the dimension; errors at file:line:col);
//! - `check.rs`: the checks that need no world (every value in range, every name resolved),
//!   for specs from files and from code alike;
//! - `seeder.rs`, `overlap.rs`: each body's seeds and the particles made from them;
//! - `estimate.rs`: the estimator, the memory and a distributed run's slabs from the seeds
//!   and a probe of the pipeline, before anything is spawned;
//! - `pipeline.rs`: the pipeline's systems chosen, checked and installed;
//! - `plausible.rs`: magnitudes no solid has (a modulus in GPa written as Pa), for `check`;
//! - `build/`: the world builder, split by what it builds: bodies, regions, outputs, ranks;
//!   `world_checks.rs` checks what only the built world can tell.
//!
//! Every error, wherever it is found, names the field path (`bodies[1].shape`); a spec read
//! from a file turns that path into a place in the text.

mod build;
mod check;
mod estimate;
mod format;
mod overlap;
mod pipeline;
mod plausible;
mod seed;
mod seeder;
mod spec;
mod validate;
mod world_checks;

pub use estimate::{Estimate, RankSlabs};
pub use format::*;
pub use fractum_engine::budget;
pub use fractum_engine::text::{Location, SceneError, locate, parse_fragment, scene_text};
pub use fractum_geometry::{FileError, Shape, image, mesh, points, shape, surface};
pub use plausible::{Implausible, implausible_magnitudes};
pub use seed::{cell_points, particles_in_shape};
pub use spec::{
    Body, Boundary, Built, Condition, InitialVelocity, Output, PipelineEntry, PipelineSummary,
    SceneSummary, Spec,
};

use fractum_engine::dim::Dimension;
use fractum_engine::registry::{Params, Registry};
use fractum_engine::with_dim;
use std::path::Path;

/// A scene file: its name, its text, and the parsed scene.
#[derive(Debug)]
pub struct SceneFile {
    /// File name as given by the user (used in messages).
    pub name: String,
    /// Full text.
    pub text: String,
    /// Parsed scene.
    pub scene: Scene,
}

impl SceneFile {
    /// Reads and parses a scene file.
    pub fn read(path: &Path) -> Result<Self, SceneError> {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| {
            SceneError::whole_file(&name, format!("cannot read the scene file: {e}"))
        })?;
        Self::parse(&name, scene_text(&name, bytes)?)
    }

    /// Parses scene text; `name` is used in messages.
    pub fn parse(name: &str, text: String) -> Result<Self, SceneError> {
        // Some editors start UTF-8 files with a byte-order mark; it is not part of the scene.
        let text = match text.strip_prefix('\u{feff}') {
            Some(rest) => rest.to_string(),
            None => text,
        };
        let scene = parse_fragment(name, &text, Location { line: 1, col: 1 }, "")?;
        Ok(Self {
            name: name.to_string(),
            text,
            scene,
        })
    }

    /// Where errors about this file point.
    pub fn source(&self) -> Source {
        Source::File {
            name: self.name.clone(),
            text: self.text.clone(),
        }
    }

    /// The scene's dimension, from the number of coordinates of the grid's lower corner.
    pub fn dimension(&self) -> Result<Dimension, SceneError> {
        let count = self.scene.grid.min.0.len();
        Dimension::of_count(count).ok_or_else(|| {
            self.source().error(
                "grid.min",
                format!("expected 2 coordinates (x, y) or 3 (x, y, z), found {count}"),
            )
        })
    }
}

/// Where a scene came from, so that an error about a field path can say where it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Source {
    /// A RON file: errors point at `name:line:col`.
    File {
        /// File name as given by the user.
        name: String,
        /// Its text.
        text: String,
    },
    /// Built in code: errors name the field only.
    Code {
        /// A name for messages, e.g. `<bench>`.
        name: String,
    },
}

impl Source {
    /// A scene built in code, named `name` in messages.
    pub fn code(name: &str) -> Self {
        Source::Code {
            name: name.to_string(),
        }
    }

    /// The name used in messages.
    pub fn name(&self) -> &str {
        match self {
            Source::File { name, .. } | Source::Code { name } => name,
        }
    }

    /// Location of the value at `field` (or its nearest ancestor) in the text.
    pub fn location_of(&self, field: &str) -> Option<Location> {
        match self {
            Source::File { text, .. } => {
                let offset = locate::locate(text, field).unwrap_or(0);
                Some(Location::of_offset(text, offset))
            }
            Source::Code { .. } => None,
        }
    }

    /// An error about `field`.
    pub fn error(&self, field: &str, message: impl Into<String>) -> SceneError {
        match self.location_of(field) {
            Some(location) => SceneError::at(self.name(), location, field, message),
            None => SceneError::unplaced(self.name(), field, message),
        }
    }

    /// The params text `raw` of the pipeline entry whose params sit at `field`.
    pub fn params<'a>(&'a self, raw: Option<&'a str>, field: String) -> Params<'a> {
        let origin = self
            .location_of(&field)
            .unwrap_or(Location { line: 1, col: 1 });
        Params::new(raw, self.name(), origin, field)
    }
}

/// Validates `file` and builds its simulation with systems from `registry`, in the dimension
/// its grid gives.
pub fn build_simulation(file: &SceneFile, registry: &Registry) -> Result<Built, SceneError> {
    with_dim!(file.dimension()?, D => Spec::<D>::from_file(file)?.build(registry))
}

/// [`build_simulation`] for rank `rank` of a distributed run of `ranks` ([`Spec::build_rank`]).
pub fn build_rank_simulation(
    file: &SceneFile,
    registry: &Registry,
    rank: usize,
    ranks: usize,
) -> Result<Built, SceneError> {
    with_dim!(file.dimension()?, D => Spec::<D>::from_file(file)?.build_rank(registry, rank, ranks))
}

/// Validates `file` and estimates the memory its simulation needs from counts, spawning
/// nothing ([`Spec::estimate`]).
/// With `ranks`, also the slabs a distributed run of that many ranks would own.
pub fn estimate_memory(
    file: &SceneFile,
    registry: &Registry,
    ranks: Option<usize>,
) -> Result<Estimate, SceneError> {
    with_dim!(file.dimension()?, D => Spec::<D>::from_file(file)?.estimate(registry, ranks))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_that_are_not_utf8_are_refused_with_their_place() {
        let bytes = "(\n  tïme: ".bytes().chain([0xff, b')']).collect();
        let e = scene_text("s.ron", bytes).unwrap_err();
        // Line 2, after the two spaces and the five characters of `tïme:` and a space.
        assert_eq!(e.location, Some(Location { line: 2, col: 9 }));
        assert!(
            e.to_string()
                .starts_with("s.ron:2:9: the scene file is not UTF-8 text: byte 11 (0xff)"),
            "{e}"
        );
        assert_eq!(scene_text("s.ron", b"()".to_vec()).unwrap(), "()");
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Small {
        a: f64,
        #[serde(default)]
        b: Option<u32>,
    }

    #[test]
    fn fragment_errors_are_placed_in_the_enclosing_file() {
        let origin = Location { line: 5, col: 10 };
        let err = parse_fragment::<Small>("s.ron", "(a: 1.0, c: 2)", origin, "pipeline[1].params")
            .unwrap_err();
        assert_eq!(err.location, Some(Location { line: 5, col: 19 }));
        assert_eq!(err.field, "pipeline[1].params.c");
        // In the scene's terms: no Rust type name.
        assert_eq!(err.message, "unknown field `c`; expected one of `a`, `b`");
        let ok: Small = parse_fragment("s.ron", "(a: 1, b: 3)", origin, "").unwrap();
        assert_eq!(ok.b, Some(3));
    }

    #[test]
    fn regions_accept_rectangle_as_bodies_name_it() {
        let parse = |text: &str| {
            parse_fragment::<format::RegionSpec>("s.ron", text, Location::default(), "")
        };
        let rectangle = parse("Rectangle(min: (0.0, 0.0), max: (1.0, 0.5))").unwrap();
        assert_eq!(
            rectangle,
            parse("Box(min: (0.0, 0.0), max: (1.0, 0.5))").unwrap()
        );
        let e = parse("Square(min: (0.0, 0.0), max: (1.0, 0.5))").unwrap_err();
        assert_eq!(
            e.message,
            "unknown variant `Square`; expected one of `Box`, `Rectangle`, `Mesh`"
        );
    }

    #[test]
    fn coordinates_take_two_or_three_numbers() {
        let two: Coords = parse_fragment("s.ron", "(1, 2)", Location::default(), "").unwrap();
        assert_eq!(two.0, vec![1.0, 2.0]);
        let three: Coords =
            parse_fragment("s.ron", "(1, 2, 3.5)", Location::default(), "").unwrap();
        assert_eq!(three.0, vec![1.0, 2.0, 3.5]);
        for bad in ["(1)", "(1, 2, 3, 4)"] {
            let e = parse_fragment::<Coords>("s.ron", bad, Location::default(), "").unwrap_err();
            assert!(e.message.contains("(x, y, z)"), "{bad}: {e}");
        }
        let rows: Tuple<Coords> =
            parse_fragment("s.ron", "((1, 0), (0, 1))", Location::default(), "").unwrap();
        assert_eq!(rows.0.len(), 2);
    }

    #[test]
    fn code_sources_name_the_field_without_a_place() {
        let e = Source::code("<bench>").error("grid.spacing", "expected a positive spacing");
        assert_eq!(
            e.to_string(),
            "<bench>: `grid.spacing`: expected a positive spacing"
        );
    }
}
