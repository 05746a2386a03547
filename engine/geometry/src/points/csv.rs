//! The CSV form of a particle file: a header line naming the columns, then one particle per
//! line. Columns are found by their header names, in any order, case and surrounding spaces
//! ignored: `x`, `y` (and `z` in 3D) and `volume` are required; `vx`, `vy`, `vz` (or
//! `velocity_x`, ...), `damage`, `strength_scale` and `material` (a material's name in the
//! scene) are optional,
//! and other columns are ignored. Lines starting with `#` are comments. Errors name the line
//! and the column.

use super::{OptionalColumns, PlaceKind, PointAttributes, PointSet};
use crate::file_error::{FileError, fail};
use glam::DVec3;

/// The columns found in the header.
struct Columns {
    position: [Option<usize>; 3],
    volume: usize,
    velocity: [Option<usize>; 3],
    damage: Option<usize>,
    strength_scale: Option<usize>,
    material: Option<usize>,
    count: usize,
}

/// The columns the header on line `line` names.
fn columns(header: &str, line: usize) -> Result<Columns, FileError> {
    let place = format!("line {line}");
    let names: Vec<String> = header
        .split(',')
        .map(|n| n.trim().trim_matches('"').to_ascii_lowercase())
        .collect();
    let find = |options: &[&str]| names.iter().position(|n| options.contains(&n.as_str()));
    let Some(volume) = find(&["volume"]) else {
        return Err(fail(
            place.clone(),
            format!(
                "no `volume` column among {}; a particle's volume is never guessed: add a \
                 `volume` column (m³; in 2D the area times the scene's thickness)",
                names.join(", ")
            ),
        ));
    };
    let position = [find(&["x"]), find(&["y"]), find(&["z"])];
    if position[0].is_none() || position[1].is_none() {
        return Err(fail(
            place.clone(),
            format!(
                "expected `x` and `y` columns (and `z` in 3D), found {}",
                names.join(", ")
            ),
        ));
    }
    let velocity = [
        find(&["vx", "velocity_x"]),
        find(&["vy", "velocity_y"]),
        find(&["vz", "velocity_z"]),
    ];
    if velocity[0].is_some() != velocity[1].is_some()
        || (velocity[2].is_some() && velocity[0].is_none())
    {
        return Err(fail(
            place.clone(),
            "a velocity needs all its components: `vx` and `vy` (and `vz` in 3D)",
        ));
    }
    Ok(Columns {
        position,
        volume,
        velocity,
        damage: find(&["damage"]),
        strength_scale: find(&["strength_scale"]),
        material: find(&["material"]),
        count: names.len(),
    })
}

/// Parses the CSV text of a particle file.
pub fn parse_csv(text: &str, file: &str) -> Result<PointSet, FileError> {
    let mut rows = text
        .lines()
        .enumerate()
        .map(|(k, l)| (k + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((header_line, header)) = rows.next() else {
        return Err(fail(
            "",
            "the file is empty; expected a header line and one line per particle",
        ));
    };
    let c = columns(header, header_line)?;
    let columns = OptionalColumns {
        velocity: c.velocity[0].is_some(),
        damage: c.damage.is_some(),
        strength_scale: c.strength_scale.is_some(),
        material: c.material.is_some(),
    };
    let mut set = PointSet::empty(file, c.position[2].is_some(), columns, PlaceKind::Line);
    for (line, row) in rows {
        read_row(&mut set, &c, line, row)?;
    }
    if set.is_empty() {
        return Err(fail("", "the file has a header but no particle"));
    }
    Ok(set)
}

fn read_row(set: &mut PointSet, c: &Columns, line: usize, row: &str) -> Result<(), FileError> {
    let place = || format!("line {line}");
    let fields: Vec<&str> = row.split(',').map(str::trim).collect();
    if fields.len() != c.count {
        return Err(fail(
            place(),
            format!("{} fields where the header names {}", fields.len(), c.count),
        ));
    }
    let number = |column: usize, name: &str| -> Result<f64, FileError> {
        let text = fields[column];
        text.parse()
            .map_err(|_| fail(place(), format!("`{name}` is `{text}`; expected a number")))
    };
    let vector = |columns: &[Option<usize>; 3], names: [&str; 3]| -> Result<DVec3, FileError> {
        let mut v = DVec3::ZERO;
        for a in 0..3 {
            if let Some(column) = columns[a] {
                v[a] = number(column, names[a])?;
            }
        }
        Ok(v)
    };
    let x = vector(&c.position, ["x", "y", "z"])?;
    let volume = number(c.volume, "volume")?;
    let velocity = match c.velocity[0] {
        Some(_) => Some(vector(&c.velocity, ["vx", "vy", "vz"])?),
        None => None,
    };
    let optional = |column: Option<usize>, name: &str| column.map(|k| number(k, name)).transpose();
    let given = PointAttributes {
        velocity,
        damage: optional(c.damage, "damage")?,
        strength_scale: optional(c.strength_scale, "strength_scale")?,
        material: c.material.map(|column| fields[column].trim_matches('"')),
    };
    set.push(line as u32, x, volume, given)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn columns_are_found_by_name_in_any_order() {
        let text = "# from another code\nVolume, y, x, damage, vx, vy, material, id\n\
                    1e-6, 0.2, 0.1, 0.5, 1, -1, rock, 7\n2e-6, 0.3, 0.1, 0, 0, 0, \"glue\", 8\n";
        let set = parse_csv(text, "p.csv").unwrap();
        assert_eq!(set.len(), 2);
        assert_eq!(set.dimension(), 2);
        assert_eq!(
            set.particles(),
            vec![
                (DVec3::new(0.1, 0.2, 0.0), 1e-6),
                (DVec3::new(0.1, 0.3, 0.0), 2e-6)
            ]
        );
        let a = set.attributes(DVec3::new(0.1, 0.2, 0.0)).unwrap();
        assert_eq!(a.velocity, Some(DVec3::new(1.0, -1.0, 0.0)));
        assert_eq!(a.damage, Some(0.5));
        assert_eq!(a.material, Some("rock"));
        assert_eq!(
            set.attributes(DVec3::new(0.1, 0.3, 0.0)).unwrap().material,
            Some("glue")
        );
        assert!(set.attributes(DVec3::new(0.1, 0.25, 0.0)).is_none());
    }

    #[test]
    fn a_missing_volume_and_bad_rows_are_refused_with_their_line() {
        let e = parse_csv("x,y\n0,0\n", "p.csv").unwrap_err();
        assert!(e.message.contains("never guessed"), "{e}");
        assert_eq!(e.place, "line 1");
        // The header's own line, after comments and blank lines.
        let e = parse_csv("# from a CT scan\n\nx,y,vol\n0,0,1\n", "p.csv").unwrap_err();
        assert_eq!(e.place, "line 3", "{e}");
        let e = parse_csv("x,y,volume\n0,0,1\n0,1\n", "p.csv").unwrap_err();
        assert_eq!(e.place, "line 3");
        let e = parse_csv("x,y,volume\n0,0,1\n0,nan,1\n", "p.csv").unwrap_err();
        assert!(e.to_string().starts_with("line 3: `y` is NaN"), "{e}");
        let e = parse_csv("x,y,volume\n0,0,-1\n", "p.csv").unwrap_err();
        assert!(e.message.contains("positive"), "{e}");
        let e = parse_csv("x,y,volume\n0,0,1\n0,0,2\n", "p.csv").unwrap_err();
        assert!(e.message.contains("line 2 already is"), "{e}");
        let e = parse_csv("x,y,volume,damage\n0,0,1,2\n", "p.csv").unwrap_err();
        assert!(e.message.contains("0 to 1"), "{e}");
        let e = parse_csv("x,y,volume,vx\n0,0,1,2\n", "p.csv").unwrap_err();
        assert!(e.message.contains("all its components"), "{e}");
    }
}
