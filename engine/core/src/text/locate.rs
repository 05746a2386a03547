//! Finds where a field path (`bodies[1].shape.radius`) starts in a RON text.
//!
//! Serde reports type errors with a position, but checks made after parsing (unknown material,
//! body outside the grid, unstable time step) only know the field path. This small structural
//! scanner maps every path in a well-formed RON document to its byte offset so those errors can
//! point at the text too. It understands exactly what RON values look like: structs and tuples
//! in parentheses (optionally named), lists, maps, strings, comments and scalars.

/// Byte offset of every value in `text`, keyed by its path.
pub fn value_offsets(text: &str) -> Vec<(String, usize)> {
    value_spans(text)
        .into_iter()
        .map(|(path, span)| (path, span.start))
        .collect()
}

/// Byte range of every value in `text` (from its first character to just after its last),
/// keyed by its path, in the order the values start.
pub fn value_spans(text: &str) -> Vec<(String, std::ops::Range<usize>)> {
    let mut walker = Walker {
        s: text.as_bytes(),
        i: 0,
        out: Vec::new(),
    };
    walker.skip_trivia();
    // Skip `#![enable(...)]` attributes at the top.
    while walker.peek() == Some(b'#') {
        while let Some(c) = walker.peek() {
            walker.i += 1;
            if c == b']' {
                break;
            }
        }
        walker.skip_trivia();
    }
    walker.value("");
    walker.out
}

/// Offset of `path`, or of its longest recorded ancestor when the path itself is absent.
pub fn locate(text: &str, path: &str) -> Option<usize> {
    let offsets = value_offsets(text);
    let mut probe = path.to_string();
    loop {
        if let Some((_, at)) = offsets.iter().find(|(p, _)| *p == probe) {
            return Some(*at);
        }
        let cut = probe.rfind(['.', '['])?;
        probe.truncate(cut);
    }
}

fn join_field(path: &str, field: &str) -> String {
    if path.is_empty() {
        field.to_string()
    } else {
        format!("{path}.{field}")
    }
}

struct Walker<'a> {
    s: &'a [u8],
    i: usize,
    out: Vec<(String, std::ops::Range<usize>)>,
}

impl Walker<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    fn skip_trivia(&mut self) {
        loop {
            match (self.peek(), self.s.get(self.i + 1).copied()) {
                (Some(c), _) if c.is_ascii_whitespace() => self.i += 1,
                (Some(b'/'), Some(b'/')) => {
                    while self.peek().is_some_and(|c| c != b'\n') {
                        self.i += 1;
                    }
                }
                (Some(b'/'), Some(b'*')) => {
                    self.i += 2;
                    while self.i < self.s.len() && !self.s[self.i..].starts_with(b"*/") {
                        self.i += 1;
                    }
                    self.i = (self.i + 2).min(self.s.len());
                }
                _ => return,
            }
        }
    }

    fn identifier(&mut self) -> &str {
        let start = self.i;
        while self
            .peek()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == b'_')
        {
            self.i += 1;
        }
        std::str::from_utf8(&self.s[start..self.i]).unwrap_or("")
    }

    fn string(&mut self) -> String {
        self.i += 1;
        let start = self.i;
        while let Some(c) = self.peek() {
            match c {
                b'\\' => self.i += 2,
                b'"' => break,
                _ => self.i += 1,
            }
        }
        let content = String::from_utf8_lossy(&self.s[start..self.i.min(self.s.len())]).into();
        self.i += 1;
        content
    }

    fn value(&mut self, path: &str) {
        self.skip_trivia();
        let entry = self.out.len();
        let start = self.i;
        self.out.push((path.to_string(), start..start));
        self.value_body(path);
        self.out[entry].1.end = self.i.min(self.s.len());
    }

    fn value_body(&mut self, path: &str) {
        match self.peek() {
            Some(b'(') => self.group(path, None),
            Some(b'[') => self.list(path),
            Some(b'{') => self.map(path),
            Some(b'"') => {
                self.string();
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let name = self.identifier().to_string();
                let after_name = self.i;
                self.skip_trivia();
                if self.peek() == Some(b'(') {
                    self.group(path, Some(&name));
                } else {
                    // A unit variant or a keyword ends with its name, not with what follows.
                    self.i = after_name;
                }
            }
            _ => {
                while self.peek().is_some_and(|c| {
                    !matches!(c, b',' | b')' | b']' | b'}') && !c.is_ascii_whitespace()
                }) {
                    self.i += 1;
                }
            }
        }
    }

    /// At `(`: a struct (named fields), a tuple, or an enum variant's contents.
    fn group(&mut self, path: &str, variant: Option<&str>) {
        let mut index = 0;
        self.items(b')', |w| {
            if let Some((field, after)) = w.field_name() {
                w.i = after;
                let field_path = join_field(path, &field);
                w.value(&field_path);
                if let Some(variant) = variant {
                    let span = w.out.iter().rev().find(|(p, _)| *p == field_path);
                    let span = span.map(|(_, span)| span.clone()).unwrap_or(w.i..w.i);
                    let alias = join_field(&join_field(path, variant), &field);
                    w.out.push((alias, span));
                }
            } else {
                w.value(&join_field(path, &index.to_string()));
                index += 1;
            }
        });
    }

    /// At an opening bracket: calls `item` for each comma-separated item up to `close`.
    fn items(&mut self, close: u8, mut item: impl FnMut(&mut Self)) {
        self.i += 1;
        loop {
            self.skip_trivia();
            match self.peek() {
                None => return,
                Some(c) if c == close => {
                    self.i += 1;
                    return;
                }
                _ => {}
            }
            item(self);
            self.skip_trivia();
            if self.peek() == Some(b',') {
                self.i += 1;
            }
        }
    }

    /// If an `identifier :` starts here, its name and the offset just after the colon.
    fn field_name(&mut self) -> Option<(String, usize)> {
        let save = self.i;
        let name = self.identifier().to_string();
        self.skip_trivia();
        let result = (!name.is_empty() && self.peek() == Some(b':')).then(|| (name, self.i + 1));
        self.i = save;
        result
    }

    fn list(&mut self, path: &str) {
        let mut index = 0;
        self.items(b']', |w| {
            w.value(&format!("{path}[{index}]"));
            index += 1;
        });
    }

    fn map(&mut self, path: &str) {
        self.items(b'}', |w| {
            let key = match w.peek() {
                Some(b'"') => w.string(),
                _ => w.identifier().to_string(),
            };
            w.skip_trivia();
            if w.peek() == Some(b':') {
                w.i += 1;
            }
            w.value(&join_field(path, &key));
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"// a scene
(
    materials: { "steel": (density: 7800.0) },
    bodies: [
        (shape: Disk(center: (0.5, 0.5), radius: 0.1), material: "steel"),
        /* second */ (shape: Rectangle(min: (0, 0), max: (1, 1)), material: "stel"),
    ],
)"#;

    fn at(path: &str) -> &str {
        let offset = locate(TEXT, path).unwrap();
        &TEXT[offset..offset + 12.min(TEXT.len() - offset)]
    }

    #[test]
    fn finds_fields_list_items_map_entries_and_variant_fields() {
        assert!(at("materials.steel.density").starts_with("7800.0"));
        assert!(at("bodies[1].material").starts_with("\"stel\""));
        assert!(at("bodies[0].shape.radius").starts_with("0.1"));
        assert!(at("bodies[0].shape.Disk.radius").starts_with("0.1"));
        assert!(at("bodies[1].shape").starts_with("Rectangle"));
        assert!(at("bodies[0].shape.center.1").starts_with("0.5)"));
    }

    #[test]
    fn falls_back_to_the_nearest_ancestor() {
        assert!(at("bodies[1].velocity").starts_with("(shape"));
        assert_eq!(locate(TEXT, "nothing"), None);
    }
}
