//! Bodies from particle files: `Points("rock.csv")`, a CSV file of one particle per row, as
//! other codes write them (a particle set exported from another MPM code, a sampled scan).
//!
//! Columns are found by their header names, in any order, case and surrounding spaces
//! ignored: `x`, `y` (and `z` in 3D) and `volume` are required; `vx`, `vy`, `vz` (or
//! `velocity_x`, ...), `damage` and `material` (a material's name in the scene) are optional,
//! and other columns are ignored. A missing volume is an error, never guessed. Lines starting
//! with `#` are comments. Errors name the line and the column.

use super::file_error::{FileError, fail, text_of};
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

/// A set of particles read from a file, with what the file gives of each.
#[derive(Clone, Debug)]
pub struct PointSet {
    /// The file, as the scene names it.
    pub file: String,
    positions: Vec<DVec3>,
    volumes: Vec<f64>,
    velocities: Option<Vec<DVec3>>,
    damage: Option<Vec<f64>>,
    /// Per point, an index into `material_names`.
    materials: Option<Vec<u16>>,
    material_names: Vec<String>,
    /// The file's line of each point, for messages.
    lines: Vec<u32>,
    by_position: HashMap<[u64; 3], u32>,
    three_d: bool,
    lo: DVec3,
    hi: DVec3,
}

impl PartialEq for PointSet {
    fn eq(&self, other: &Self) -> bool {
        self.file == other.file
            && self.positions == other.positions
            && self.volumes == other.volumes
    }
}

/// What the file gives of one point, beyond its position and volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointAttributes<'a> {
    /// Velocity, when the file has one.
    pub velocity: Option<DVec3>,
    /// Initial damage, when the file has it.
    pub damage: Option<f64>,
    /// The material's name, when the file has a `material` column.
    pub material: Option<&'a str>,
    /// The line of the file it was read from.
    pub line: u32,
}

fn key(x: DVec3) -> [u64; 3] {
    [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()]
}

/// The columns found in the header.
struct Columns {
    position: [Option<usize>; 3],
    volume: usize,
    velocity: [Option<usize>; 3],
    damage: Option<usize>,
    material: Option<usize>,
    count: usize,
}

fn columns(header: &str) -> Result<Columns, FileError> {
    let names: Vec<String> = header
        .split(',')
        .map(|n| n.trim().trim_matches('"').to_ascii_lowercase())
        .collect();
    let find = |options: &[&str]| names.iter().position(|n| options.contains(&n.as_str()));
    let Some(volume) = find(&["volume"]) else {
        return Err(fail(
            "line 1",
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
            "line 1",
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
            "line 1",
            "a velocity needs all its components: `vx` and `vy` (and `vz` in 3D)",
        ));
    }
    Ok(Columns {
        position,
        volume,
        velocity,
        damage: find(&["damage"]),
        material: find(&["material"]),
        count: names.len(),
    })
}

/// Reads the particle file at `path` (`file` is how the scene names it).
pub fn read_points(path: &Path, file: &str) -> Result<PointSet, FileError> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if extension.as_deref() != Some("csv") {
        return Err(fail("", "expected a .csv file, by its extension"));
    }
    let bytes = std::fs::read(path).map_err(|e| fail("", format!("cannot read it: {e}")))?;
    let text = text_of(&bytes)?;
    parse_csv(text, file)
}

/// Parses the CSV text of a particle file.
pub fn parse_csv(text: &str, file: &str) -> Result<PointSet, FileError> {
    let mut rows = text
        .lines()
        .enumerate()
        .map(|(k, l)| (k + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((_, header)) = rows.next() else {
        return Err(fail(
            "",
            "the file is empty; expected a header line and one line per particle",
        ));
    };
    let c = columns(header)?;
    let mut set = PointSet {
        file: file.to_string(),
        positions: Vec::new(),
        volumes: Vec::new(),
        velocities: c.velocity[0].map(|_| Vec::new()),
        damage: c.damage.map(|_| Vec::new()),
        materials: c.material.map(|_| Vec::new()),
        material_names: Vec::new(),
        lines: Vec::new(),
        by_position: HashMap::new(),
        three_d: c.position[2].is_some(),
        lo: DVec3::INFINITY,
        hi: DVec3::NEG_INFINITY,
    };
    for (line, row) in rows {
        read_row(&mut set, &c, line, row)?;
    }
    if set.positions.is_empty() {
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
        let value: f64 = text
            .parse()
            .map_err(|_| fail(place(), format!("`{name}` is `{text}`; expected a number")))?;
        if !value.is_finite() {
            return Err(fail(
                place(),
                format!("`{name}` is {value}; expected a finite number"),
            ));
        }
        Ok(value)
    };
    let axes = ["x", "y", "z"];
    let mut x = DVec3::ZERO;
    for a in 0..3 {
        if let Some(column) = c.position[a] {
            x[a] = number(column, axes[a])?;
        }
    }
    let volume = number(c.volume, "volume")?;
    if volume <= 0.0 {
        return Err(fail(
            place(),
            format!("`volume` is {volume}; expected a positive volume"),
        ));
    }
    if let Some(first) = set.by_position.insert(key(x), set.lines.len() as u32) {
        return Err(fail(
            place(),
            format!(
                "this particle sits at ({}, {}, {}), where the particle of line {} already is",
                x.x, x.y, x.z, set.lines[first as usize]
            ),
        ));
    }
    if let Some(velocities) = &mut set.velocities {
        let names = ["vx", "vy", "vz"];
        let mut v = DVec3::ZERO;
        for a in 0..3 {
            if let Some(column) = c.velocity[a] {
                v[a] = number(column, names[a])?;
            }
        }
        velocities.push(v);
    }
    if let (Some(damage), Some(column)) = (&mut set.damage, c.damage) {
        let d = number(column, "damage")?;
        if !(0.0..=1.0).contains(&d) {
            return Err(fail(place(), format!("`damage` is {d}; expected 0 to 1")));
        }
        damage.push(d);
    }
    if let (Some(materials), Some(column)) = (&mut set.materials, c.material) {
        let name = fields[column].trim_matches('"');
        let index = match set.material_names.iter().position(|n| n == name) {
            Some(k) => k,
            None => {
                set.material_names.push(name.to_string());
                set.material_names.len() - 1
            }
        };
        materials.push(index as u16);
    }
    set.positions.push(x);
    set.volumes.push(volume);
    set.lines.push(line as u32);
    set.lo = set.lo.min(x);
    set.hi = set.hi.max(x);
    Ok(())
}

impl PointSet {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the set has no point (never, once read).
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// 3 when the file gives a `z` column, else 2.
    pub fn dimension(&self) -> usize {
        if self.three_d { 3 } else { 2 }
    }

    /// The bounding box of the points.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.lo, self.hi)
    }

    /// Every point with its volume, in file order.
    pub fn particles(&self) -> Vec<(DVec3, f64)> {
        self.positions
            .iter()
            .copied()
            .zip(self.volumes.iter().copied())
            .collect()
    }

    /// The material names the `material` column uses, in order of first use.
    pub fn material_names(&self) -> &[String] {
        &self.material_names
    }

    /// What the file gives of the point at exactly `x`, if one is there.
    pub fn attributes(&self, x: DVec3) -> Option<PointAttributes<'_>> {
        let k = *self.by_position.get(&key(x))? as usize;
        Some(PointAttributes {
            velocity: self.velocities.as_ref().map(|v| v[k]),
            damage: self.damage.as_ref().map(|d| d[k]),
            material: self
                .materials
                .as_ref()
                .map(|m| self.material_names[m[k] as usize].as_str()),
            line: self.lines[k],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(a.line, 3);
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
