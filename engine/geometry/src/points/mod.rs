//! Bodies from particle files: `Points("rock.csv")` or `Points("frame.vtu")`, one particle
//! per row or per VTK point, as other codes write them (a particle set exported from another
//! MPM code, a sampled scan, a frame of an earlier run).
//!
//! Positions and volumes are required, a missing volume is an error and never guessed;
//! velocity, damage and material are optional and override the body's, and a strength scale
//! multiplies the tensile strength the pipeline's damage law gives the particle. Every particle
//! is checked as it is added (finite values, a positive volume and strength scale, damage from
//! 0 to 1, no two particles at one position), and errors name its line (CSV) or its point
//! number (VTU).

mod csv;
mod vtu;

pub use csv::parse_csv;
pub use vtu::parse_vtu;

use super::file_error::{FileError, fail, text_of};
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

/// How a file's particles are told apart in messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PlaceKind {
    /// By their 1-based line (CSV).
    Line,
    /// By their 0-based point number, as ParaView shows it (VTU).
    Point,
}

/// A set of particles read from a file, with what the file gives of each.
#[derive(Clone, Debug)]
pub struct PointSet {
    /// The file, as the scene names it.
    pub file: String,
    positions: Vec<DVec3>,
    volumes: Vec<f64>,
    velocities: Option<Vec<DVec3>>,
    damage: Option<Vec<f64>>,
    strength_scale: Option<Vec<f64>>,
    /// Per point, an index into `material_names`.
    materials: Option<Vec<u16>>,
    material_names: Vec<String>,
    /// Each point's line or number in the file, for messages.
    places: Vec<u32>,
    place_kind: PlaceKind,
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

/// Which of the optional values a file gives, for every point alike.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct OptionalColumns {
    pub velocity: bool,
    pub damage: bool,
    pub strength_scale: bool,
    pub material: bool,
}

/// What the file gives of one point, beyond its position and volume.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointAttributes<'a> {
    /// Velocity, when the file has one.
    pub velocity: Option<DVec3>,
    /// Initial damage, when the file has it.
    pub damage: Option<f64>,
    /// The factor on the particle's tensile strength, when the file has one.
    pub strength_scale: Option<f64>,
    /// The material's name (CSV) or its index in the scene's materials, as text (VTU), when
    /// the file has a `material` column.
    pub material: Option<&'a str>,
}

fn key(x: DVec3) -> [u64; 3] {
    [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()]
}

/// Reads the particle file at `path` (`file` is how the scene names it): `.csv` or `.vtu`,
/// by its extension.
pub fn read_points(path: &Path, file: &str) -> Result<PointSet, FileError> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let bytes = std::fs::read(path).map_err(|e| fail("", format!("cannot read it: {e}")))?;
    match extension.as_deref() {
        Some("csv") => parse_csv(text_of(&bytes)?, file),
        Some("vtu") => parse_vtu(text_of(&bytes)?, file),
        _ => Err(fail("", "expected a .csv or .vtu file, by its extension")),
    }
}

impl PointSet {
    /// An empty set that will hold the columns named.
    pub(crate) fn empty(
        file: &str,
        three_d: bool,
        columns: OptionalColumns,
        place_kind: PlaceKind,
    ) -> Self {
        PointSet {
            file: file.to_string(),
            positions: Vec::new(),
            volumes: Vec::new(),
            velocities: columns.velocity.then(Vec::new),
            damage: columns.damage.then(Vec::new),
            strength_scale: columns.strength_scale.then(Vec::new),
            materials: columns.material.then(Vec::new),
            material_names: Vec::new(),
            places: Vec::new(),
            place_kind,
            by_position: HashMap::new(),
            three_d,
            lo: DVec3::INFINITY,
            hi: DVec3::NEG_INFINITY,
        }
    }

    fn place(&self, at: u32) -> String {
        match self.place_kind {
            PlaceKind::Line => format!("line {at}"),
            PlaceKind::Point => format!("point {at}"),
        }
    }

    /// Adds the particle at `x` found at line or point `at`, checking what it carries; the
    /// optional values must be given exactly when the set holds their column.
    pub(crate) fn push(
        &mut self,
        at: u32,
        x: DVec3,
        volume: f64,
        given: PointAttributes<'_>,
    ) -> Result<(), FileError> {
        let PointAttributes {
            velocity,
            damage,
            strength_scale,
            material,
        } = given;
        let error = |message: String| Err(fail(self.place(at), message));
        for (value, name) in [(x.x, "x"), (x.y, "y"), (x.z, "z"), (volume, "volume")] {
            if !value.is_finite() {
                return error(format!("`{name}` is {value}; expected a finite number"));
            }
        }
        if volume <= 0.0 {
            return error(format!("`volume` is {volume}; expected a positive volume"));
        }
        if let Some(v) = velocity
            && !v.is_finite()
        {
            return error(format!("the velocity is {v}; expected finite components"));
        }
        if let Some(d) = damage
            && !(0.0..=1.0).contains(&d)
        {
            return error(format!("`damage` is {d}; expected 0 to 1"));
        }
        if let Some(s) = strength_scale
            && !(s.is_finite() && s > 0.0)
        {
            return error(format!(
                "`strength_scale` is {s}; expected a positive factor on the strength"
            ));
        }
        if let Some(first) = self.by_position.get(&key(x)) {
            let first = self.place(self.places[*first as usize]);
            return error(format!(
                "this particle sits at ({}, {}, {}), where the particle of {first} already is",
                x.x, x.y, x.z
            ));
        }
        self.by_position.insert(key(x), self.places.len() as u32);
        if let (Some(all), Some(v)) = (&mut self.velocities, velocity) {
            all.push(v);
        }
        if let (Some(all), Some(d)) = (&mut self.damage, damage) {
            all.push(d);
        }
        if let (Some(all), Some(s)) = (&mut self.strength_scale, strength_scale) {
            all.push(s);
        }
        if let (Some(all), Some(name)) = (&mut self.materials, material) {
            let index = match self.material_names.iter().position(|n| n == name) {
                Some(k) => k,
                None => {
                    self.material_names.push(name.to_string());
                    self.material_names.len() - 1
                }
            };
            all.push(index as u16);
        }
        self.positions.push(x);
        self.volumes.push(volume);
        self.places.push(at);
        self.lo = self.lo.min(x);
        self.hi = self.hi.max(x);
        Ok(())
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the set has no point (never, once read).
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// 3 when the file gives a `z` (CSV) or its points leave the plane z = 0 (VTU), else 2.
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

    /// The materials the `material` column uses, in order of first use: names (CSV) or
    /// indices into the scene's materials written as text (VTU, see
    /// [`Self::materials_by_index`]).
    pub fn material_names(&self) -> &[String] {
        &self.material_names
    }

    /// Whether the file gives each particle a strength scale.
    pub fn has_strength_scale(&self) -> bool {
        self.strength_scale.is_some()
    }

    /// Whether the `material` column holds indices into the scene's materials (as Fractum's
    /// frames write them) rather than names.
    pub fn materials_by_index(&self) -> bool {
        self.place_kind == PlaceKind::Point
    }

    /// What the file gives of the point at exactly `x`, if one is there.
    pub fn attributes(&self, x: DVec3) -> Option<PointAttributes<'_>> {
        let k = *self.by_position.get(&key(x))? as usize;
        Some(PointAttributes {
            velocity: self.velocities.as_ref().map(|v| v[k]),
            damage: self.damage.as_ref().map(|d| d[k]),
            strength_scale: self.strength_scale.as_ref().map(|s| s[k]),
            material: self
                .materials
                .as_ref()
                .map(|m| self.material_names[m[k] as usize].as_str()),
        })
    }
}
