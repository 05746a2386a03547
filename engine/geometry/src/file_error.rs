//! What is wrong with a geometry file a scene names (a surface, a mesh): where in the file and
//! what, so that the scene error can say both.

/// A problem in a geometry file: where (a line, a byte offset, an element) and what.
#[derive(Clone, Debug, PartialEq)]
pub struct FileError {
    /// `line 12`, `byte 84`, `facet 7`, `element 31`, or empty for the file as a whole.
    pub place: String,
    /// What was found and what was expected.
    pub message: String,
}

impl std::fmt::Display for FileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.place.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.place, self.message)
        }
    }
}

impl std::error::Error for FileError {}

/// The file's bytes as text, or an error at the line of the first byte that is not UTF-8.
pub(crate) fn text_of(bytes: &[u8]) -> Result<&str, FileError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        fail(
            format!("line {line}"),
            "expected text; found bytes that are not UTF-8",
        )
    })
}

/// A [`FileError`] at `place`.
pub(crate) fn fail(place: impl Into<String>, message: impl Into<String>) -> FileError {
    FileError {
        place: place.into(),
        message: message.into(),
    }
}
