//! Edits a RON scene text at a field path, keeping everything else of the text as it was
//! (comments, layout, the other values), so that a scene changed from code still reads as its
//! author wrote it and its errors still point at lines the author knows.
//!
//! A path is the one errors name: `grid.spacing`, `materials.steel.youngs_modulus`,
//! `pipeline[3].params.tensile_strength`, `time.end.0` (the first item of `Time(…)`).

use super::locate::value_spans;
use std::ops::Range;

/// The text of the value at exactly `path`, if the text has one there.
pub fn value_at<'t>(text: &'t str, path: &str) -> Option<&'t str> {
    span_of(text, path).map(|span| &text[span])
}

/// The names of the values directly inside the one at `path` (the fields of a struct, the keys
/// of a map, `[0]`, `[1]`, … of a list, `0`, `1`, … of a tuple), in the text's order.
pub fn children(text: &str, path: &str) -> Vec<String> {
    let prefix_dot = if path.is_empty() {
        String::new()
    } else {
        format!("{path}.")
    };
    let mut names: Vec<String> = Vec::new();
    for (child, _) in value_spans(text) {
        let rest = if let Some(rest) = child.strip_prefix(&prefix_dot) {
            rest.to_string()
        } else if let Some(rest) = child.strip_prefix(path).filter(|r| r.starts_with('[')) {
            rest.to_string()
        } else {
            continue;
        };
        let is_direct = !rest.is_empty()
            && match rest.strip_prefix('[') {
                Some(index) => index.find(']').is_some_and(|end| end + 1 == index.len()),
                None => !rest.contains(['.', '[']),
            };
        // A variant's fields are recorded twice, `shape.radius` and `shape.Disk.radius`: the
        // second is no direct child.
        if is_direct && !names.contains(&rest) {
            names.push(rest);
        }
    }
    names
}

/// `text` with the value at `path` replaced by the RON text `value`; a field that is absent is
/// added to its struct or map (and an absent struct on the way, as `field: (…)`). An error says
/// which part of the path is missing and why it cannot be added.
pub fn set_value(text: &str, path: &str, value: &str) -> Result<String, String> {
    if let Some(span) = span_of(text, path) {
        return Ok(splice(text, span, value));
    }
    let (parent, field) =
        split_last(path).ok_or_else(|| format!("`{path}` names no value of the scene"))?;
    if field.starts_with('[') {
        return Err(format!(
            "`{path}`: the list `{parent}` has no such item (items cannot be added by index)"
        ));
    }
    match span_of(text, parent) {
        Some(span) => insert_field(text, span, parent, field, value),
        None if parent.is_empty() => Err(format!("`{path}`: the text holds no scene value")),
        None => set_value(text, parent, &format!("({field}: {value})")),
    }
}

/// The byte range of the value at exactly `path`.
fn span_of(text: &str, path: &str) -> Option<Range<usize>> {
    value_spans(text)
        .into_iter()
        .find(|(p, _)| p == path)
        .map(|(_, span)| span)
}

fn splice(text: &str, span: Range<usize>, value: &str) -> String {
    let mut out = String::with_capacity(text.len() + value.len());
    out.push_str(&text[..span.start]);
    out.push_str(value);
    out.push_str(&text[span.end..]);
    out
}

/// `(parent, last)` of a path: `("a.b", "c")` for `a.b.c`, `("a", "[2]")` for `a[2]`.
fn split_last(path: &str) -> Option<(&str, &str)> {
    if let Some(open) = path.strip_suffix(']').and_then(|p| p.rfind('[')) {
        return Some((&path[..open], &path[open..]));
    }
    match path.rfind('.') {
        Some(dot) => Some((&path[..dot], &path[dot + 1..])),
        None if path.is_empty() => None,
        None => Some(("", path)),
    }
}

/// Adds `field: value` first in the struct (or `"field": value` in the map) at `span`.
fn insert_field(
    text: &str,
    span: Range<usize>,
    parent: &str,
    field: &str,
    value: &str,
) -> Result<String, String> {
    let body = &text[span.clone()];
    let open = body
        .find(['(', '{'])
        .filter(|&at| {
            body[..at]
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_')
        })
        .ok_or_else(|| {
            format!(
                "`{parent}.{field}`: `{parent}` is `{body}`, which holds no fields to add \
                 `{field}` to"
            )
        })?;
    let is_map = body.as_bytes()[open] == b'{';
    let key = if is_map {
        format!("{field:?}")
    } else {
        field.to_string()
    };
    let inside = &body[open + 1..];
    let is_empty = inside.trim_start().starts_with([')', '}']);
    let entry = if is_empty {
        format!("{key}: {value}")
    } else {
        format!("{key}: {value}, ")
    };
    // After the layout that opens the struct, so a multi-line struct gains a line's start.
    let layout = inside.len() - inside.trim_start().len();
    let at = span.start + open + 1 + if is_empty { 0 } else { layout };
    Ok(splice(text, at..at, &entry))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"// a scene
(
    time: (step: Cfl(0.4), end: Time(3.0e-4)), // ends early
    materials: { "steel": (density: 7800.0, youngs_modulus: 2.0e11) },
    bodies: [(shape: Disk(center: (0.5, 0.5), radius: 0.1), material: "steel")],
    pipeline: [
        (system: "basis/linear"),
        (system: "damage/rankine", params: (tensile_strength: 1.0e9, degradation: Spectral)),
    ],
)"#;

    #[test]
    fn reads_values_by_path() {
        assert_eq!(value_at(TEXT, "time.end"), Some("Time(3.0e-4)"));
        assert_eq!(value_at(TEXT, "time.end.0"), Some("3.0e-4"));
        assert_eq!(value_at(TEXT, "materials.steel.density"), Some("7800.0"));
        assert_eq!(
            value_at(TEXT, "pipeline[1].params.degradation"),
            Some("Spectral")
        );
        assert_eq!(value_at(TEXT, "pipeline[0].params"), None);
    }

    #[test]
    fn lists_a_values_children_without_variant_aliases() {
        assert_eq!(children(TEXT, "materials"), ["steel"]);
        assert_eq!(children(TEXT, "pipeline"), ["[0]", "[1]"]);
        assert_eq!(children(TEXT, "bodies[0].shape"), ["center", "radius"]);
        assert_eq!(children(TEXT, "time"), ["step", "end"]);
    }

    #[test]
    fn replaces_a_value_and_keeps_the_rest_of_the_text() {
        let edited = set_value(TEXT, "time.end.0", "1.0e-3").unwrap();
        assert!(edited.contains("end: Time(1.0e-3)), // ends early"));
        assert_eq!(edited.len(), TEXT.len());
        let edited = set_value(TEXT, "pipeline[1].params.degradation", "Published").unwrap();
        assert_eq!(
            value_at(&edited, "pipeline[1].params.degradation"),
            Some("Published")
        );
        assert!(edited.starts_with("// a scene\n"));
    }

    #[test]
    fn adds_absent_fields_and_structs() {
        let edited = set_value(TEXT, "materials.steel.poisson_ratio", "0.3").unwrap();
        assert_eq!(
            value_at(&edited, "materials.steel.poisson_ratio"),
            Some("0.3")
        );
        assert_eq!(value_at(&edited, "materials.steel.density"), Some("7800.0"));
        let edited = set_value(TEXT, "pipeline[0].params.kernel", "Tent").unwrap();
        assert_eq!(
            value_at(&edited, "pipeline[0].params"),
            Some("(kernel: Tent)")
        );
        let edited = set_value(TEXT, "materials.glass", "(density: 2500.0)").unwrap();
        assert_eq!(value_at(&edited, "materials.glass.density"), Some("2500.0"));
        assert!(edited.contains(r#"{ "glass": (density: 2500.0), "steel""#));
        let edited = set_value(TEXT, "output.vtu_every", "10").unwrap();
        assert_eq!(value_at(&edited, "output.vtu_every"), Some("10"));
    }

    #[test]
    fn says_what_cannot_be_added() {
        let e = set_value(TEXT, "pipeline[5].system", "\"x\"").unwrap_err();
        assert!(e.contains("no such item"), "{e}");
        let e = set_value(TEXT, "pipeline[1].params.degradation.kind", "1").unwrap_err();
        assert!(e.contains("holds no fields"), "{e}");
    }
}
