//! Lines drawn over a snapshot: reference paths (an experiment's traced cracks, say) in the
//! scene's own frame, so a simulated crack and the measured one can be seen together.
//!
//! The file is a CSV with a header naming the columns `line`, `x` and `y` (in any order,
//! others ignored): `x` and `y` in metres, the view's horizontal and vertical coordinates
//! (for a 3D frame, the two axes of `--view`); consecutive rows with the same `line` form one
//! polyline. `docs/verification/traces/` holds such files, made from the experiments' drawings.

use std::path::Path;

/// Polylines to draw over a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overlay {
    /// What the legend calls the lines (the file's stem).
    pub label: String,
    /// The polylines, each its points (m) in the view's (horizontal, vertical) coordinates.
    pub lines: Vec<Vec<[f64; 2]>>,
}

impl Overlay {
    /// Reads an overlay file; an error names `file:line`, the column and what was expected.
    pub fn read(path: &Path) -> Result<Self, String> {
        let name = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
        let label = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let lines = parse(&text).map_err(|e| format!("{name}:{e}"))?;
        Ok(Self { label, lines })
    }
}

/// The polylines of an overlay file's text; an error starts with its line number.
fn parse(text: &str) -> Result<Vec<Vec<[f64; 2]>>, String> {
    let mut rows = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = rows.next() else {
        return Err("1: empty file: expected a header with the columns line, x and y".into());
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |wanted: &str| {
        names
            .iter()
            .position(|n| *n == wanted)
            .ok_or_else(|| format!("1: no column `{wanted}`: expected the columns line, x and y"))
    };
    let (line_at, x_at, y_at) = (column("line")?, column("x")?, column("y")?);
    let mut lines: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut current: Option<String> = None;
    for (index, row) in rows {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        let number = |at: usize, what: &str| -> Result<f64, String> {
            let field = fields.get(at).copied().unwrap_or("");
            field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "{}: column `{what}`: {field:?}: expected a finite number (m)",
                        index + 1
                    )
                })
        };
        let point = [number(x_at, "x")?, number(y_at, "y")?];
        let id = fields.get(line_at).copied().unwrap_or("").to_string();
        if current.as_deref() != Some(id.as_str()) {
            lines.push(Vec::new());
            current = Some(id);
        }
        if let Some(line) = lines.last_mut() {
            line.push(point);
        }
    }
    if lines.is_empty() {
        return Err("2: no rows: expected at least one point".into());
    }
    Ok(lines)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_with_one_line_id_form_one_polyline() {
        let lines = parse("y,line,x\n0.0,a,1.0\n0.5,a,1.5\n\n0.0,b,-1.0\n").unwrap();
        assert_eq!(lines, vec![vec![[1.0, 0.0], [1.5, 0.5]], vec![[-1.0, 0.0]]]);
    }

    #[test]
    fn a_bad_number_names_its_line_and_column() {
        let e = parse("line,x,y\n0,1.0,2.0\n0,oops,2.0\n").unwrap_err();
        assert!(e.starts_with("3: column `x`: \"oops\""), "{e}");
        let e = parse("line,x,y\n0,1.0\n").unwrap_err();
        assert!(e.starts_with("2: column `y`"), "{e}");
    }

    #[test]
    fn a_missing_column_or_an_empty_file_is_refused() {
        assert!(
            parse("line,x\n0,1\n")
                .unwrap_err()
                .contains("no column `y`")
        );
        assert!(parse("").unwrap_err().contains("empty file"));
        assert!(parse("line,x,y\n").unwrap_err().contains("no rows"));
    }

    #[test]
    fn the_shipped_traces_read() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/verification/traces");
        for angle in [0, 30, 60] {
            let overlay = Overlay::read(&dir.join(format!("scb_{angle}_traces.csv"))).unwrap();
            assert!(
                overlay.lines.len() >= 4,
                "{angle}°: {} traces",
                overlay.lines.len()
            );
            // Every trace lies inside the specimen (a half disc of radius 47.5 mm).
            for point in overlay.lines.iter().flatten() {
                assert!(
                    point[0].hypot(point[1]) < 0.05 && point[1] > -1.0e-3,
                    "{point:?}"
                );
            }
        }
    }
}
