//! `fractum snapshot`: a headless picture of a frame's particles coloured by a field, with a
//! colour bar, the bodies' outlines and a scale bar, so that a crack pattern can be seen (and
//! put on a verification page) without ParaView.
//!
//! - Each particle is a rectangle at least its own size (the side of its volume) and stretched
//!   to its nearest neighbours along the two axes of the view, so a body reads as a solid and a
//!   crack as a gap or a band, on graded grids too, where particles in coarse cells stand
//!   farther apart along one axis than the other.
//! - 3D frames are seen along an axis (`--view xy`, `xz` or `yz`); nearer particles are drawn
//!   over farther ones.
//! - Outlines: a pixel is outline where its neighbour holds another body or nothing, so the
//!   edges of each body and of every opened crack are drawn.
//! - NaN values (a column a law leaves undefined) are drawn grey and left out of the range.

use crate::fragments::{frame_thickness, median_spacing, particle_size};
use crate::overlay::Overlay;
use crate::plot::register_font;
use fractum_engine::prelude::{DVec3, Three};
use fractum_io::output::{ParticleFrame, read_particle_frame};
use fractum_systems::spatial::Spatial;
use std::path::Path;

mod draw;
use draw::{BAR, MARGIN, draw};

/// The plane a frame is seen in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum View {
    /// Along z: x to the right, y up.
    #[default]
    Xy,
    /// Along y: x to the right, z up.
    Xz,
    /// Along x: y to the right, z up.
    Yz,
}

impl View {
    /// The names of the (horizontal, vertical) axes.
    fn names(self) -> (&'static str, &'static str) {
        match self {
            View::Xy => ("x", "y"),
            View::Xz => ("x", "z"),
            View::Yz => ("y", "z"),
        }
    }

    /// (horizontal, vertical, depth) axes; the depth grows towards the viewer.
    fn axes(self) -> (usize, usize, usize) {
        match self {
            View::Xy => (0, 1, 2),
            View::Xz => (0, 2, 1),
            View::Yz => (1, 2, 0),
        }
    }
}

/// What to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct SnapshotOptions {
    /// The field's name (`damage`, `velocity`, `stress_xy`, a system's column...).
    pub field: String,
    /// The plane of a 3D frame.
    pub view: View,
    /// Width of the particle area in pixels.
    pub width: u32,
    /// The colour range [default: the field's range in the frame].
    pub range: Option<(f64, f64)>,
    /// Lines drawn over the particles, in the view's coordinates (m).
    pub overlay: Option<Overlay>,
    /// When the frame is, for the title (`t = 1.2e-4 s, step 400`; [`frame_when`]).
    pub when: Option<String>,
}

impl Default for SnapshotOptions {
    fn default() -> Self {
        Self {
            field: "damage".into(),
            view: View::Xy,
            width: 900,
            range: None,
            overlay: None,
            when: None,
        }
    }
}

/// When the frame file `path` is, from its run's `particles.pvd` and its name
/// (`frames/particles_00000400.vtu`): `t = 1.2e-4 s, step 400`.
pub fn frame_when(path: &Path) -> Option<String> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    let step = name
        .trim_end_matches(".pvtu")
        .trim_end_matches(".vtu")
        .rsplit('_')
        .next()
        .and_then(|digits| digits.parse::<u64>().ok());
    let collection = path.parent()?.parent()?.join("particles.pvd");
    let time = fractum_io::output::read_pvd(&collection)
        .ok()?
        .into_iter()
        .find(|(_, file)| file.ends_with(&name))
        .map(|(t, _)| t);
    match (time, step) {
        (Some(t), Some(step)) => Some(format!(
            "t = {} s, step {step}",
            fractum_engine::text::readable(t)
        )),
        (Some(t), None) => Some(format!("t = {} s", fractum_engine::text::readable(t))),
        (None, Some(step)) => Some(format!("step {step}")),
        (None, None) => None,
    }
}

/// The frame of the run in `dir` nearest `time` (the last when `None`).
pub fn frame_near(dir: &Path, time: Option<f64>) -> Result<ParticleFrame, String> {
    read_particle_frame(&crate::fragments::frame_file_near(dir, time)?.1)
}

/// The fields a frame can be coloured by.
pub fn field_names(frame: &ParticleFrame) -> Vec<String> {
    let mut names: Vec<String> = [
        "damage",
        "strain_energy_density",
        "mass",
        "volume",
        "body",
        "material",
        "velocity",
        "velocity_x",
        "velocity_y",
        "velocity_z",
        "stress_xx",
        "stress_yy",
        "stress_zz",
        "stress_xy",
        "pressure",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    names.extend(frame.scalars.iter().map(|(n, _)| n.clone()));
    names.extend(frame.vectors.iter().map(|(n, _)| n.clone()));
    names
}

/// The values of `field` per particle (a vector's magnitude).
pub fn field_values(frame: &ParticleFrame, field: &str) -> Result<Vec<f64>, String> {
    let norm = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let stress = |k: usize| frame.stress.iter().map(|s| s[k]).collect();
    let values = match field {
        "damage" => frame.damage.clone(),
        "strain_energy_density" => frame.strain_energy_density.clone(),
        "mass" => frame.mass.clone(),
        "volume" => frame.volume.clone(),
        "body" => frame.body.iter().map(|b| f64::from(*b)).collect(),
        "material" => frame.material.iter().map(|m| f64::from(*m)).collect(),
        "velocity" => frame.velocity.iter().map(norm).collect(),
        "velocity_x" | "velocity_y" | "velocity_z" => {
            let k = usize::from(field.as_bytes()[9] - b'x');
            frame.velocity.iter().map(|v| v[k]).collect()
        }
        "stress_xx" => stress(0),
        "stress_yy" => stress(4),
        "stress_zz" => stress(8),
        "stress_xy" => stress(1),
        "pressure" => frame
            .stress
            .iter()
            .map(|s| -(s[0] + s[4] + s[8]) / 3.0)
            .collect(),
        other => {
            if let Some((_, v)) = frame.scalars.iter().find(|(n, _)| n == other) {
                v.clone()
            } else if let Some((_, v)) = frame.vectors.iter().find(|(n, _)| n == other) {
                v.iter().map(norm).collect()
            } else {
                return Err(format!(
                    "no field `{other}` in the frame; it has: {}",
                    field_names(frame).join(", ")
                ));
            }
        }
    };
    if values.len() != frame.position.len() {
        // The column the field is drawn from, which the run's `output.fields` left out.
        let column = match field {
            "velocity_x" | "velocity_y" | "velocity_z" => "velocity",
            "stress_xx" | "stress_yy" | "stress_zz" | "stress_xy" | "pressure" => "stress",
            other => other,
        };
        frame.require(&[column])?;
    }
    Ok(values)
}

/// The particles rasterised: per pixel the colour parameter (NaN: a NaN value) and the body
/// (`u32::MAX`: empty).
struct Raster {
    width: usize,
    height: usize,
    value: Vec<f64>,
    body: Vec<u32>,
    /// Metres per pixel.
    scale: f64,
    /// The view's coordinates (m) of the top left corner.
    origin: [f64; 2],
}

fn rasterise(
    frame: &ParticleFrame,
    values: &[f64],
    range: (f64, f64),
    view: View,
    width: u32,
) -> Result<Raster, String> {
    let (h, v, depth) = view.axes();
    let (planar, thickness) = frame_thickness(frame, None)?;
    let spacing = median_spacing(frame, planar, thickness);
    let bounds = |axis: usize| {
        frame
            .position
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p[axis]), b.max(p[axis]))
            })
    };
    let ((h0, h1), (v0, v1)) = (bounds(h), bounds(v));
    if !(h1 >= h0 && v1 >= v0 && spacing.is_finite()) {
        return Err("the frame has no particles to draw".into());
    }
    let (h0, h1, v0, v1) = (h0 - spacing, h1 + spacing, v0 - spacing, v1 + spacing);
    let scale = (h1 - h0) / f64::from(width);
    let height = (((v1 - v0) / scale).ceil() as usize).clamp(1, 4 * width as usize);
    let width = width as usize;
    let mut raster = Raster {
        width,
        height,
        value: vec![f64::NAN; width * height],
        body: vec![u32::MAX; width * height],
        scale,
        origin: [h0, v1],
    };
    let halves = half_extents(frame, (h, v), planar, thickness);
    let mut order: Vec<usize> = (0..frame.position.len()).collect();
    order.sort_by(|&a, &b| frame.position[a][depth].total_cmp(&frame.position[b][depth]));
    let span = (range.1 - range.0).max(f64::MIN_POSITIVE);
    for p in order {
        let x = (frame.position[p][h] - h0) / scale;
        let y = (v1 - frame.position[p][v]) / scale;
        let t = (values[p] - range.0) / span;
        let (half_x, half_y) = (
            (halves[p][0] / scale).max(0.5),
            (halves[p][1] / scale).max(0.5),
        );
        let (xa, xb) = (
            (x - half_x).floor().max(0.0) as usize,
            ((x + half_x).ceil() as usize).min(width),
        );
        let (ya, yb) = (
            (y - half_y).floor().max(0.0) as usize,
            ((y + half_y).ceil() as usize).min(raster.height),
        );
        for row in ya..yb {
            for col in xa..xb {
                raster.value[row * width + col] = t;
                raster.body[row * width + col] = u32::from(frame.body[p]);
            }
        }
    }
    Ok(raster)
}

/// Each particle's half-extent along the view's two axes (m): half its own size (the side of its
/// volume), or half the distance to its nearest neighbour along that axis (an offset within
/// about 27° of it, at most four sizes away) where that is larger. Particles of a graded grid's
/// coarse cells, farther apart along one axis, then close up along it; an opened crack, wider
/// than the spacing, stays open.
fn half_extents(
    frame: &ParticleFrame,
    axes: (usize, usize),
    planar: bool,
    thickness: f64,
) -> Vec<[f64; 2]> {
    let points: Vec<DVec3> = frame
        .position
        .iter()
        .map(|p| DVec3::from_array(*p))
        .collect();
    let tree = Three::tree(&points);
    let mut found = Vec::new();
    (0..points.len())
        .map(|p| {
            let size = particle_size(frame.volume[p], planar, thickness);
            let mut nearest = [f64::INFINITY; 2];
            found.clear();
            Three::within(&tree, points[p], 4.0 * size, &mut found);
            for &q in &found {
                let offset = (points[q as usize] - points[p]).abs().to_array();
                let length = offset.iter().sum::<f64>();
                for (k, axis) in [axes.0, axes.1].into_iter().enumerate() {
                    // Mostly along the axis: the other components are small beside it.
                    if offset[axis] > 0.0 && 2.0 * (length - offset[axis]) <= offset[axis] {
                        nearest[k] = nearest[k].min(offset[axis]);
                    }
                }
            }
            nearest.map(|d| {
                if d.is_finite() {
                    0.5 * d.max(size)
                } else {
                    0.5 * size
                }
            })
        })
        .collect()
}

impl Raster {
    /// The (column, row) of the pixel at the view's coordinates `p` (m); outside the raster
    /// when `p` is.
    fn pixel_of(&self, p: [f64; 2]) -> (i32, i32) {
        (
            ((p[0] - self.origin[0]) / self.scale).floor() as i32,
            ((self.origin[1] - p[1]) / self.scale).floor() as i32,
        )
    }

    /// Whether the pixel is on a body's edge: a 4-neighbour holds another body or nothing.
    fn outline(&self, row: usize, col: usize) -> bool {
        let here = self.body[row * self.width + col];
        if here == u32::MAX {
            return false;
        }
        let other = |r: usize, c: usize| self.body[r * self.width + c] != here;
        row == 0
            || col == 0
            || row + 1 == self.height
            || col + 1 == self.width
            || other(row - 1, col)
            || other(row + 1, col)
            || other(row, col - 1)
            || other(row, col + 1)
    }
}

/// The field's range over its finite values.
fn finite_range(values: &[f64]) -> (f64, f64) {
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    }
}

/// A round length (1, 2 or 5 × 10ⁿ) near a fifth of `extent`.
fn scale_length(extent: f64) -> f64 {
    let target = extent / 5.0;
    let base = 10f64.powf(target.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * base)
        .find(|l| *l <= target)
        .unwrap_or(base)
}

/// Draws `frame` coloured by `options.field` into the PNG `output` (written to a temporary
/// name and renamed).
pub fn snapshot(
    frame: &ParticleFrame,
    options: &SnapshotOptions,
    output: &Path,
) -> Result<(), String> {
    // Particles are drawn at their size and outlined by body.
    frame.require(&["volume", "body"])?;
    let values = field_values(frame, &options.field)?;
    // A field of both signs is drawn about zero, so that white is zero (the diverging map).
    let range = options
        .range
        .unwrap_or_else(|| match finite_range(&values) {
            (low, high) if low < 0.0 && high > 0.0 => {
                let reach = low.abs().max(high);
                (-reach, reach)
            }
            range => range,
        });
    let raster = rasterise(frame, &values, range, options.view, options.width.max(50))?;
    register_font();
    let size = (
        raster.width as u32 + MARGIN + BAR,
        raster.height as u32 + MARGIN + 90,
    );
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let temp = output.with_file_name(format!(".{name}.{}.tmp.png", std::process::id()));
    draw(&raster, options, range, size, &temp)
        .map_err(|e| format!("cannot draw {}: {e}", output.display()))?;
    std::fs::rename(&temp, output).map_err(|e| format!("cannot write {}: {e}", output.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::prelude::RGBColor;

    fn frame() -> ParticleFrame {
        // Two bodies of 4 × 4 particles, 0.1 apart, side by side with a gap of two spacings.
        let mut f = ParticleFrame {
            thickness: Some(1.0),
            ..Default::default()
        };
        for body in 0..2u16 {
            for i in 0..4 {
                for j in 0..4 {
                    f.id.push(f.id.len() as u32);
                    f.body.push(body);
                    f.material.push(0);
                    f.position.push([
                        f64::from(body) * 0.6 + 0.1 * f64::from(i),
                        0.1 * f64::from(j),
                        0.0,
                    ]);
                    f.velocity.push([1.0, 0.0, 0.0]);
                    f.mass.push(1.0);
                    f.volume.push(0.01);
                    f.stress.push([0.0; 9]);
                    f.damage.push(if body == 0 { 0.0 } else { 1.0 });
                    f.strain_energy_density.push(0.0);
                }
            }
        }
        f
    }

    #[test]
    fn particles_of_coarse_cells_stretch_to_their_neighbours_along_each_axis() {
        // Particles 0.1 apart in x and 0.4 apart in y, each covering 0.04 m² (its own size
        // 0.2), plus one particle alone far away.
        let mut f = ParticleFrame {
            thickness: Some(1.0),
            ..Default::default()
        };
        let mut place = |x: f64, y: f64| {
            f.position.push([x, y, 0.0]);
            f.volume.push(0.04);
        };
        for i in 0..6 {
            for j in 0..3 {
                place(0.1 * f64::from(i), 0.4 * f64::from(j));
            }
        }
        place(10.0, 10.0);
        let halves = half_extents(&f, (0, 1), true, 1.0);
        // Along x the own size (0.2) is larger than the spacing; along y the spacing.
        for h in &halves[..18] {
            assert!(
                (h[0] - 0.1).abs() < 1e-12 && (h[1] - 0.2).abs() < 1e-12,
                "{h:?}"
            );
        }
        assert_eq!(halves[18], [0.1, 0.1]);
    }

    #[test]
    fn colours_run_from_purple_to_yellow_and_nan_is_grey() {
        assert_eq!(draw::colour(0.0), RGBColor(68, 1, 84));
        assert_eq!(draw::colour(1.0), RGBColor(253, 231, 37));
        assert_eq!(draw::colour(f64::NAN), RGBColor(200, 200, 200));
    }

    #[test]
    fn the_raster_holds_both_bodies_with_their_values_and_edges() {
        let f = frame();
        let values = field_values(&f, "damage").unwrap();
        let raster = rasterise(&f, &values, (0.0, 1.0), View::Xy, 100).unwrap();
        let row = raster.height / 2;
        let bodies: Vec<u32> = (0..raster.width)
            .map(|c| raster.body[row * raster.width + c])
            .collect();
        assert!(bodies.contains(&0) && bodies.contains(&1) && bodies.contains(&u32::MAX));
        let first = bodies.iter().position(|b| *b == 0).unwrap();
        assert!(raster.outline(row, first) && !raster.outline(row, first + 3));
        let k = bodies.iter().position(|b| *b == 1).unwrap();
        assert_eq!(raster.value[row * raster.width + k], 1.0);
    }

    #[test]
    fn fields_are_found_by_name_and_unknown_ones_listed() {
        let f = frame();
        assert_eq!(field_values(&f, "velocity_x").unwrap()[0], 1.0);
        let e = field_values(&f, "colour").unwrap_err();
        assert!(
            e.contains("no field `colour`") && e.contains("damage"),
            "{e}"
        );
        assert_eq!(scale_length(1.0), 0.2);
        assert_eq!(scale_length(0.013), 2e-3);
    }

    #[test]
    fn overlay_points_land_on_the_pixels_of_the_particles_there() {
        let f = frame();
        let values = field_values(&f, "damage").unwrap();
        let raster = rasterise(&f, &values, (0.0, 1.0), View::Xy, 100).unwrap();
        for p in [0, 5, 16, 31] {
            let [x, y, _] = f.position[p];
            let (col, row) = raster.pixel_of([x, y]);
            let k = row as usize * raster.width + col as usize;
            assert_eq!(raster.body[k], u32::from(f.body[p]), "particle {p}");
        }
        // The middle of the gap between the bodies is empty.
        let (col, row) = raster.pixel_of([0.45, 0.15]);
        assert_eq!(
            raster.body[row as usize * raster.width + col as usize],
            u32::MAX
        );
    }

    #[test]
    fn a_snapshot_is_a_png() {
        let dir = std::env::temp_dir().join(format!("fractum-snapshot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("frame.png");
        snapshot(&frame(), &SnapshotOptions::default(), &path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let overlay = Overlay {
            label: "traces".into(),
            lines: vec![vec![[0.45, -0.1], [0.45, 0.4]]],
        };
        let options = SnapshotOptions {
            overlay: Some(overlay),
            ..Default::default()
        };
        snapshot(&frame(), &options, &path).unwrap();
        assert_eq!(&std::fs::read(&path).unwrap()[1..4], b"PNG");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
