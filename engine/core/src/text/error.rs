//! Errors a user sees about a scene: where (file:line:col), which field, what was expected.

use std::fmt;

/// A line and column in a scene file, both starting at 1.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Location {
    /// Line, from 1.
    pub line: usize,
    /// Column in characters, from 1.
    pub col: usize,
}

impl Location {
    /// The location `inner`, given relative to a fragment that starts at `self`.
    pub fn offset_by(self, inner: Location) -> Location {
        if inner.line <= 1 {
            Location {
                line: self.line,
                col: self.col + inner.col.saturating_sub(1),
            }
        } else {
            Location {
                line: self.line + inner.line - 1,
                col: inner.col,
            }
        }
    }

    /// Location of byte `offset` in `text`.
    pub fn of_offset(text: &str, offset: usize) -> Location {
        let before = &text[..offset.min(text.len())];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        Location {
            line,
            col: before[line_start..].chars().count() + 1,
        }
    }
}

/// Something wrong with a scene: unreadable, malformed, or inconsistent.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    /// File name as given by the user.
    pub file: String,
    /// Where in the file, when known.
    pub location: Option<Location>,
    /// Path of the offending field, e.g. `bodies[1].material`; empty for the whole file.
    pub field: String,
    /// What is wrong and what was expected.
    pub message: String,
}

impl SceneError {
    /// An error at a known place.
    pub fn at(file: &str, location: Location, field: &str, message: impl Into<String>) -> Self {
        Self {
            file: file.to_string(),
            location: Some(location),
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// An error about `field` of a scene that has no text to point into (built in code).
    pub fn unplaced(source: &str, field: &str, message: impl Into<String>) -> Self {
        Self {
            file: source.to_string(),
            location: None,
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// An error about the file as a whole (e.g. it cannot be read).
    pub fn whole_file(file: &str, message: impl Into<String>) -> Self {
        Self {
            file: file.to_string(),
            location: None,
            field: String::new(),
            message: message.into(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(loc) = self.location {
            write!(f, ":{}:{}", loc.line, loc.col)?;
        }
        write!(f, ": ")?;
        if !self.field.is_empty() {
            write!(f, "`{}`: ", self.field)?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for SceneError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_compose_across_lines() {
        let origin = Location { line: 10, col: 20 };
        assert_eq!(
            origin.offset_by(Location { line: 1, col: 3 }),
            Location { line: 10, col: 22 }
        );
        assert_eq!(
            origin.offset_by(Location { line: 2, col: 3 }),
            Location { line: 11, col: 3 }
        );
        assert_eq!(
            Location::of_offset("ab\ncdé f", 7),
            Location { line: 2, col: 4 }
        );
    }

    #[test]
    fn display_names_file_place_and_field() {
        let e = SceneError::at(
            "s.ron",
            Location { line: 3, col: 7 },
            "grid.spacing",
            "must be > 0",
        );
        assert_eq!(e.to_string(), "s.ron:3:7: `grid.spacing`: must be > 0");
    }
}
