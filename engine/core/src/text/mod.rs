//! Scene text: where a value sits in a file (line and column), the errors that point there,
//! and the parsing of RON fragments with messages in the scene's own terms.
//!
//! The ground floor of the scene format: the registry (a system's `params`) and the scene
//! reader both parse and place errors through it, and it depends on neither.

pub mod edit;
mod error;
pub mod locate;
pub mod suggest;

pub use error::{Location, SceneError};

use ron::extensions::Extensions;
use serde::de::DeserializeOwned;

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

/// `x` as a reader takes it in: four significant digits, plainly written between 0.001 and a
/// million (`0.03645`, `1250`) and in scientific notation outside (`6.667e-10`, `3e10`), for
/// messages and reports (files keep every digit).
pub fn readable(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let rounded: f64 = format!("{x:.3e}").parse().unwrap_or(x);
    if (1.0e-3..1.0e6).contains(&rounded.abs()) {
        return format!("{rounded}");
    }
    let scientific = format!("{rounded:.3e}");
    match scientific.split_once('e') {
        Some((mantissa, exponent)) if mantissa.contains('.') => {
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{mantissa}e{exponent}")
        }
        _ => scientific,
    }
}

#[cfg(test)]
mod readable_tests {
    use super::readable;

    #[test]
    fn four_significant_digits_plain_or_scientific() {
        assert_eq!(readable(3.645141116866203e-2), "0.03645");
        assert_eq!(readable(0.036000000000000004), "0.036");
        assert_eq!(readable(6.666666666666666e-10), "6.667e-10");
        assert_eq!(readable(30.0e9), "3e10");
        assert_eq!(readable(-1250.0), "-1250");
        assert_eq!(readable(1.0e-10), "1e-10");
        assert_eq!(readable(0.0), "0");
    }
}
