//! Scenes: reading, parsing with precise errors, validating, and building a [`crate::Simulation`].

mod build;
mod error;
mod format;
pub mod locate;
mod seed;

pub use build::{Built, PipelineSummary, build_simulation};
pub use error::{Location, SceneError};
pub use format::*;
pub use seed::{particles_in_shape, point_in_shape};

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

impl SceneFile {
    /// Reads and parses a scene file.
    pub fn read(path: &Path) -> Result<Self, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| {
            SceneError::whole_file(&name, format!("cannot read the scene file: {e}"))
        })?;
        Self::parse(&name, text)
    }

    /// Parses scene text; `name` is used in messages.
    pub fn parse(name: &str, text: String) -> Result<Self, SceneError> {
        let scene = parse_fragment(name, &text, Location { line: 1, col: 1 }, "")?;
        Ok(Self {
            name: name.to_string(),
            text,
            scene,
        })
    }

    /// Location of the value at `field` (or its nearest ancestor) in the text.
    pub fn location_of(&self, field: &str) -> Location {
        let offset = locate::locate(&self.text, field).unwrap_or(0);
        Location::of_offset(&self.text, offset)
    }

    /// An error pointing at `field`.
    pub fn error(&self, field: &str, message: impl Into<String>) -> SceneError {
        SceneError::at(&self.name, self.location_of(field), field, message)
    }
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
    SceneError::at(file, origin.offset_by(inner), &field, e.code.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(err.message.contains("Unexpected field named `c`"), "{err}");
        let ok: Small = parse_fragment("s.ron", "(a: 1, b: 3)", origin, "").unwrap();
        assert_eq!(ok.b, Some(3));
    }
}
