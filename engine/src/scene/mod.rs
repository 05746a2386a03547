//! Scenes: reading a RON file with precise errors, validating it into a checked [`Spec`], and
//! building a [`crate::Simulation`] from the spec.
//!
//! Three layers, each in its own file:
//! - `format.rs`: the file format, plain serde structs;
//! - `validate.rs`: file → [`Spec`] for the scene's dimension (coordinates, shapes and axes
//!   that fit the dimension; errors at file:line:col);
//! - `spec.rs`: the checked, typed scene, with a builder for scenes made in code, and
//!   `Spec::build`, which checks values against each other and spawns the world and schedule.
//!
//! Every error, wherever it is found, names the field path (`bodies[1].shape`); a spec read
//! from a file turns that path into a place in the text.

pub mod budget;
mod check;
mod error;
mod format;
pub mod locate;
mod seed;
mod shape;
mod spawn;
mod spec;
mod validate;

pub use error::{Location, SceneError};
pub use format::*;
pub use seed::{cell_points, particles_in_shape};
pub use shape::Shape;
pub use spec::{
    Body, Boundary, Built, Condition, InitialVelocity, Output, PipelineEntry, PipelineSummary,
    SceneSummary, Spec,
};

use crate::dim::Dimension;
use crate::registry::{Params, Registry};
use crate::with_dim;
use ron::extensions::Extensions;
use serde::de::DeserializeOwned;
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

/// The text of a scene file's bytes; bytes that are not UTF-8 are refused with the line and
/// column (counted in characters) of the first bad byte and its byte offset.
pub fn scene_text(name: &str, bytes: Vec<u8>) -> Result<String, SceneError> {
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        // The text before the bad byte is valid UTF-8.
        let before = std::str::from_utf8(&bytes[..at]).unwrap_or_default();
        let location = Location::of_offset(before, before.len());
        SceneError::at(
            name,
            location,
            "",
            format!(
                "the scene file is not UTF-8 text: byte {at} (0x{:02x}) cannot start or continue \
                 a character; save the file as UTF-8",
                bytes[at]
            ),
        )
    })
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

/// Parses a RON fragment that starts at `origin` in `file`; `prefix` is the fragment's field
/// path in the scene. Errors carry the absolute location and the full field path.
pub fn parse_fragment<T: DeserializeOwned>(
    file: &str,
    text: &str,
    origin: Location,
    prefix: &str,
) -> Result<T, SceneError> {
    let options = ron::Options::default().with_default_extension(Extensions::IMPLICIT_SOME);
    let mut deserializer = ron::Deserializer::from_str_with_options(text, &options)
        .map_err(|e| spanned_error(file, origin, prefix, "", e))?;
    match serde_path_to_error::deserialize::<_, T>(&mut deserializer) {
        Ok(value) => match deserializer.end() {
            Ok(()) => Ok(value),
            Err(e) => {
                let e = deserializer.span_error(e);
                Err(spanned_error(file, origin, prefix, "", e))
            }
        },
        Err(e) => {
            let path = e.path().to_string();
            // serde_path_to_error writes `?` for a position it cannot name (e.g. a syntax error
            // between fields); the location still says where.
            let path = path.trim_end_matches('?').trim_end_matches('.').to_string();
            let path = if path == "." { String::new() } else { path };
            let e = deserializer.span_error(e.into_inner());
            Err(spanned_error(file, origin, prefix, &path, e))
        }
    }
}

fn spanned_error(
    file: &str,
    origin: Location,
    prefix: &str,
    path: &str,
    e: ron::error::SpannedError,
) -> SceneError {
    let inner = Location {
        line: e.span.start.line,
        col: e.span.start.col,
    };
    let field = match (prefix.is_empty(), path.is_empty()) {
        (true, _) => path.to_string(),
        (false, true) => prefix.to_string(),
        (false, false) => format!("{prefix}.{path}"),
    };
    let message = in_scene_terms(&e.code, &field);
    SceneError::at(file, origin.offset_by(inner), &field, message)
}

/// The parser's message in the scene's own terms: no Rust type names, no RON syntax a scene
/// never needs (raw identifiers).
fn in_scene_terms(code: &ron::Error, field: &str) -> String {
    use ron::Error;
    match code {
        Error::NoSuchEnumVariant {
            expected, found, ..
        } => format!(
            "unknown variant `{found}`; {}",
            one_of(expected, "variants")
        ),
        Error::NoSuchStructField {
            expected, found, ..
        } => format!("unknown field `{found}`; {}", one_of(expected, "fields")),
        Error::MissingStructField { field: missing, .. } => {
            format!("missing field `{missing}`")
        }
        Error::DuplicateStructField { field: twice, .. } => {
            format!("field `{twice}` is given twice")
        }
        Error::SuggestRawIdentifier(found) | Error::InvalidIdentifier(found) => {
            let hint = variant_hint(field).map_or(String::new(), |forms| format!(" ({forms})"));
            format!("expected a variant with its value here{hint}, found `{found}`")
        }
        other => other.to_string(),
    }
}

/// `expected `a``, or `expected one of `a`, `b``, or that there are none.
fn one_of(expected: &[&str], none: &str) -> String {
    let quoted: Vec<String> = expected.iter().map(|e| format!("`{e}`")).collect();
    match quoted.len() {
        0 => format!("there are no {none} here"),
        1 => format!("expected {}", quoted[0]),
        _ => format!("expected one of {}", quoted.join(", ")),
    }
}

/// The forms an enum-valued scene field takes, for messages.
fn variant_hint(field: &str) -> Option<&'static str> {
    const HINTS: [(&str, &str); 4] = [
        ("time.end", "`Time(seconds)` or `Steps(count)`"),
        ("time.step", "`Fixed(seconds)` or `Cfl(fraction)`"),
        (
            ".shape",
            "a shape such as `Rectangle(min: (x, y), max: (x, y))`",
        ),
        (".nodes", "`Box(min: …, max: …)`"),
    ];
    HINTS
        .iter()
        .find(|(suffix, _)| field.ends_with(suffix))
        .map(|(_, hint)| *hint)
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
            "unknown variant `Square`; expected one of `Box`, `Rectangle`"
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
