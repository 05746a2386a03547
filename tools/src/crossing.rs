//! Where a crack crosses a line: a crack path reduced to numbers that two runs can be compared
//! by (the crack of one resolution against another's, or of one graded grid against a grid
//! refined over a wider zone).
//!
//! At one frame, the crack near the line `coordinate[across] = level` is the set of particles
//! damaged at least `damage_above` whose domains the line cuts (their centre within half their
//! own size of it, the size read from their volume) and whose coordinate `along` lies in
//! `between`, which picks one crack of several. Its crossing is their volume-weighted mean
//! coordinate `along`: the centre of the band where it crosses, whatever the band's width and
//! whatever the particle spacing, so runs on different grids give the same number for the same
//! path.
//!
//! A crack can be bridged by one row of particles less damaged than `damage_above` while the
//! rows on either side have failed: a partitioned crack opens across such a row, whose
//! particles each side of the gap move with their own face. When the line cuts no crack
//! particle, the band is taken from the crack particles within one of their sizes of it (the
//! rows next to the line's), so a crack bridged at the line still crosses it; a crack that ends
//! more than a particle short of the line does not.
//!
//! [`undeformed`] puts a frame's particles back where the first frame had them (matched by id):
//! the crack of a specimen broken into pieces that have since moved apart, put back together as
//! an experimenter puts the pieces together to trace it.

use crate::fragments::{frame_thickness, particle_size};
use fractum_io::output::ParticleFrame;
use fractum_scene::Axis;
use serde::Deserialize;

/// A line (a plane in 3D) and the window on it in which one crack is looked for.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CrossingLine {
    /// The coordinate held fixed on the line.
    pub across: Axis,
    /// Its value (m).
    pub level: f64,
    /// The coordinate measured along the line.
    pub along: Axis,
    /// The window of `along` (m) in which the crack is looked for.
    pub between: (f64, f64),
    /// Particles damaged at least this much are crack.
    #[serde(default = "half")]
    pub damage_above: f64,
}

fn half() -> f64 {
    0.5
}

/// How far from the line a particle's centre may lie, in its own sizes: half, and a hair more,
/// so that a line along the boundary between two rows of a lattice (where rounding would
/// otherwise decide) cuts both.
const ON_LINE_REACH: f64 = 0.5 * (1.0 + 1.0e-9);

/// How far from the line, in their own sizes, the particles of a crack bridged at the line may
/// lie: the rows next to the line's.
const BRIDGED_REACH: f64 = 1.0 + 1.0e-9;

impl CrossingLine {
    /// Checks what can be checked without a frame.
    pub fn validate(&self) -> Result<(), String> {
        if self.across == self.along {
            return Err("`across` and `along` name the same axis".into());
        }
        let (low, high) = self.between;
        if !(low.is_finite() && high.is_finite() && low < high) {
            return Err(format!(
                "between: ({low}, {high}): expected a window with its lower end first"
            ));
        }
        if !self.level.is_finite() {
            return Err("level: expected a finite coordinate".into());
        }
        Ok(())
    }
}

/// The crack's crossing of `line` in `frame` (m), or why there is none.
pub fn crack_crossing(frame: &ParticleFrame, line: &CrossingLine) -> Result<f64, String> {
    let band = crack_on_line(frame, line)?;
    let volume: f64 = band.iter().map(|p| p.volume).sum();
    Ok(band.iter().map(|p| p.volume * p.along).sum::<f64>() / volume)
}

/// The width of the crack's band where it crosses `line` in `frame` (m): from the lower edge
/// of its lowest particle to the upper edge of its highest, along the line, each edge half the
/// particle's size from its centre. A failed band's width, which a local law ties to the cell
/// and a non-local one to its radius.
pub fn crack_band_width(frame: &ParticleFrame, line: &CrossingLine) -> Result<f64, String> {
    let band = crack_on_line(frame, line)?;
    let low = band
        .iter()
        .map(|p| p.along - 0.5 * p.size)
        .fold(f64::INFINITY, f64::min);
    let high = band
        .iter()
        .map(|p| p.along + 0.5 * p.size)
        .fold(f64::NEG_INFINITY, f64::max);
    Ok(high - low)
}

/// `frame` with every particle at its position, and of its volume, in `first` (the run's first
/// frame), matched by id; its damage and the other columns stay `frame`'s.
pub fn undeformed(frame: &ParticleFrame, first: &ParticleFrame) -> Result<ParticleFrame, String> {
    frame.require(&["id", "volume"])?;
    first.require(&["id", "volume"])?;
    let mut row_of = std::collections::HashMap::with_capacity(first.id.len());
    for (row, id) in first.id.iter().enumerate() {
        row_of.insert(*id, row);
    }
    let mut placed = frame.clone();
    for (p, id) in frame.id.iter().enumerate() {
        let row = *row_of
            .get(id)
            .ok_or_else(|| format!("particle {id} is not in the first frame"))?;
        placed.position[p] = first.position[row];
        placed.volume[p] = first.volume[row];
    }
    Ok(placed)
}

/// A particle of the crack where it crosses a line.
struct OnLine {
    along: f64,
    volume: f64,
    size: f64,
}

/// The particles of the crack that `line` cuts in `frame` (at least one), or, where a row of
/// less damaged particles bridges the crack at the line, those of the rows next to it; or why
/// there are none.
fn crack_on_line(frame: &ParticleFrame, line: &CrossingLine) -> Result<Vec<OnLine>, String> {
    frame.require(&["damage", "volume"])?;
    let (planar, thickness) = frame_thickness(frame, None)?;
    for reach in [ON_LINE_REACH, BRIDGED_REACH] {
        let band = crack_within(frame, line, reach, (planar, thickness));
        if band.iter().any(|p| p.volume > 0.0) {
            return Ok(band);
        }
    }
    let (low, high) = line.between;
    Err(format!(
        "no particle damaged at least {} crosses {:?} = {} with {:?} in [{low}, {high}]",
        line.damage_above, line.across, line.level, line.along
    ))
}

/// The crack particles within `reach` of their own sizes of `line`, in its window.
fn crack_within(
    frame: &ParticleFrame,
    line: &CrossingLine,
    reach: f64,
    (planar, thickness): (bool, f64),
) -> Vec<OnLine> {
    let (across, along) = (line.across.index(), line.along.index());
    let (low, high) = line.between;
    let mut band = Vec::new();
    for p in 0..frame.position.len() {
        let x = frame.position[p];
        let size = particle_size(frame.volume[p], planar, thickness);
        let near = (x[across] - line.level).abs() <= reach * size;
        if near && frame.damage[p] >= line.damage_above && (low..=high).contains(&x[along]) {
            band.push(OnLine {
                along: x[along],
                volume: frame.volume[p],
                size,
            });
        }
    }
    band
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2D frame of square particles of side `h` over [0, 1] × [0, 1], damaged where `band`
    /// says.
    fn lattice(h: f64, band: impl Fn(f64, f64) -> bool) -> ParticleFrame {
        let n = (1.0 / h).round() as usize;
        let mut frame = ParticleFrame {
            thickness: Some(1.0),
            ..Default::default()
        };
        for i in 0..n {
            for j in 0..n {
                let (x, y) = ((i as f64 + 0.5) * h, (j as f64 + 0.5) * h);
                frame.position.push([x, y, 0.0]);
                frame.volume.push(h * h);
                frame.damage.push(if band(x, y) { 1.0 } else { 0.0 });
            }
        }
        frame
    }

    fn line(level: f64, between: (f64, f64)) -> CrossingLine {
        CrossingLine {
            across: Axis::Y,
            level,
            along: Axis::X,
            between,
            damage_above: 0.5,
        }
    }

    #[test]
    fn an_inclined_band_crosses_where_its_centreline_does_at_any_spacing() {
        // A band 3 mm wide about x = 0.2 + y (45°): it crosses y = 0.3 at x = 0.5.
        let band = |x: f64, y: f64| ((x - 0.2 - y) / 2f64.sqrt()).abs() <= 1.5e-3;
        for h in [1.0e-3, 5.0e-4, 2.5e-4] {
            let crossing = crack_crossing(&lattice(h, band), &line(0.3, (0.3, 0.7))).unwrap();
            assert!((crossing - 0.5).abs() < 0.5 * h, "h {h}: {crossing}");
        }
    }

    #[test]
    fn a_vertical_band_is_as_wide_as_its_columns_of_particles() {
        // A band about 20 mm wide about x = 0.5: the columns of particles whose centres lie in
        // it, edge to edge, at any spacing.
        let band = |x: f64, _: f64| (x - 0.5).abs() < 0.01;
        for h in [1.0e-3, 2.0e-3, 4.0e-3] {
            let width = crack_band_width(&lattice(h, band), &line(0.3, (0.3, 0.7))).unwrap();
            let n = (1.0 / h).round() as usize;
            let inside = (0..n).filter(|&i| band((i as f64 + 0.5) * h, 0.0)).count();
            let columns = inside as f64 * h;
            assert!(inside >= 4, "h {h}: {inside} columns");
            assert!((width - columns).abs() < 1e-12, "h {h}: {width} {columns}");
        }
    }

    #[test]
    fn the_window_picks_one_crack_of_two() {
        // Two vertical bands at x = 0.25 and x = 0.75.
        let bands = |x: f64, _: f64| (x - 0.25).abs() < 2.0e-3 || (x - 0.75).abs() < 2.0e-3;
        let frame = lattice(1.0e-3, bands);
        let left = crack_crossing(&frame, &line(0.5, (0.0, 0.5))).unwrap();
        let right = crack_crossing(&frame, &line(0.5, (0.5, 1.0))).unwrap();
        assert!((left - 0.25).abs() < 1.0e-3 && (right - 0.75).abs() < 1.0e-3);
    }

    #[test]
    fn a_crack_bridged_at_the_line_crosses_it_and_one_that_stops_short_does_not() {
        // A vertical band about x = 0.5, 4 mm wide, on a 1 mm lattice, whose row at y = 0.3005
        // (the line's) is intact.
        let h = 1.0e-3;
        let bridged = |x: f64, y: f64| (x - 0.5).abs() < 2.0e-3 && (y - 0.3005).abs() > 0.25 * h;
        let crossing = crack_crossing(&lattice(h, bridged), &line(0.3005, (0.3, 0.7))).unwrap();
        assert!((crossing - 0.5).abs() < 0.5 * h, "{crossing}");
        // Intact for three rows about the line: the crack is not taken to cross it.
        let gap = |x: f64, y: f64| (x - 0.5).abs() < 2.0e-3 && (y - 0.3005).abs() > 1.25 * h;
        assert!(crack_crossing(&lattice(h, gap), &line(0.3005, (0.3, 0.7))).is_err());
    }

    #[test]
    fn undeformed_puts_the_pieces_back_where_the_first_frame_had_them() {
        // A vertical crack two particles wide about x = 0.5 whose right piece has since moved
        // 0.1 to the right: its band spans the gap in the frame, and lies back about x = 0.5
        // undeformed.
        let band = |x: f64, _: f64| (x - 0.5).abs() < 1.0e-2;
        let mut first = lattice(1.0e-2, band);
        first.id = (0..first.position.len() as u32).collect();
        let mut moved = first.clone();
        moved.id.reverse();
        moved.position.reverse();
        moved.damage.reverse();
        for x in moved.position.iter_mut().filter(|x| x[0] > 0.5) {
            x[0] += 0.1;
        }
        let at = line(0.3, (0.3, 0.7));
        let apart = crack_crossing(&moved, &at).unwrap();
        let together = crack_crossing(&undeformed(&moved, &first).unwrap(), &at).unwrap();
        assert!((apart - 0.5).abs() > 0.02, "{apart}");
        assert!((together - 0.5).abs() < 1.0e-9, "{together}");
        let mut stranger = moved.clone();
        stranger.id[0] = u32::MAX;
        let Err(e) = undeformed(&stranger, &first) else {
            panic!("a particle the first frame lacks was placed");
        };
        assert!(e.contains(&u32::MAX.to_string()), "{e}");
    }

    #[test]
    fn no_crack_on_the_line_is_an_error_that_says_where_it_looked() {
        let frame = lattice(1.0e-2, |_, y| y > 0.8);
        let error = crack_crossing(&frame, &line(0.5, (0.0, 1.0))).unwrap_err();
        assert!(error.contains("Y = 0.5"), "{error}");
        assert!(line(0.5, (1.0, 0.0)).validate().is_err());
        let mut same = line(0.5, (0.0, 1.0));
        same.along = Axis::Y;
        assert!(same.validate().is_err());
    }

    #[test]
    fn a_frame_without_volumes_is_refused_with_how_to_get_them() {
        let mut frame = lattice(1.0e-2, |_, y| y > 0.4);
        frame.keep_only(&["damage".into()]);
        let error = crack_crossing(&frame, &line(0.5, (0.0, 1.0))).unwrap_err();
        assert!(
            error.contains("volume") && error.contains("output.fields"),
            "{error}"
        );
    }
}
