//! The picture around the particles: the title (the field with its unit, and the frame's time
//! and step), coordinate axes in the view's units, the colour bar with its unit, the scale bar
//! and an overlay's lines. A field whose range holds both signs is drawn with a diverging map
//! (blue, white at zero, red), so that tension and compression read apart; others with viridis.

use super::{Raster, SnapshotOptions, scale_length};
use crate::plot::tick_label;
use plotters::prelude::*;
use std::path::Path;

/// Room around the particles (pixels): above for the title, left and below for the axes.
pub(super) const MARGIN: u32 = 70;
/// Room right of the particles for the colour bar and its labels.
pub(super) const BAR: u32 = 190;

pub(super) type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// How values become colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Map {
    /// Viridis: one-signed fields.
    Sequential,
    /// Blue, white at the middle, red: fields of both signs, over a range centred on zero.
    Diverging,
}

impl Map {
    /// The map for values over `range`.
    pub(super) fn for_range(range: (f64, f64)) -> Self {
        if range.0 < 0.0 && range.1 > 0.0 {
            Map::Diverging
        } else {
            Map::Sequential
        }
    }

    /// The colour at `t` in [0, 1]; NaN (a value a law leaves undefined) is grey.
    pub(super) fn colour(self, t: f64) -> RGBColor {
        match self {
            Map::Sequential => colour(t),
            Map::Diverging => diverging(t),
        }
    }
}

/// Viridis, by five stops.
pub(super) fn colour(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    by_stops(&STOPS, t)
}

/// Blue through white to red (the stops of a cool-warm map), white at `t = 0.5`.
pub(super) fn diverging(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (33.0, 102.0, 172.0),
        (146.0, 197.0, 222.0),
        (247.0, 247.0, 247.0),
        (244.0, 165.0, 130.0),
        (178.0, 24.0, 43.0),
    ];
    by_stops(&STOPS, t)
}

fn by_stops(stops: &[(f64, f64, f64); 5], t: f64) -> RGBColor {
    if !t.is_finite() {
        return RGBColor(200, 200, 200);
    }
    let s = t.clamp(0.0, 1.0) * 4.0;
    let k = (s.floor() as usize).min(3);
    let f = s - k as f64;
    let mix = |a: f64, b: f64| (a + f * (b - a)).round() as u8;
    let (a, b) = (stops[k], stops[k + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The SI unit of a frame field, by its name (empty for a dimensionless one).
pub(super) fn unit_of(field: &str) -> &'static str {
    let base = field
        .strip_suffix("_x")
        .or_else(|| field.strip_suffix("_y"))
        .or_else(|| field.strip_suffix("_z"))
        .unwrap_or(field);
    match base {
        f if f.starts_with("stress") => "Pa",
        "pressure" | "mises" | "von_mises" | "strength" | "viscous_pressure" => "Pa",
        "velocity" | "speed" => "m/s",
        "position" | "displacement" | "crack_opening" => "m",
        "strain_energy_density" => "J/m³",
        "mass" => "kg",
        "volume" => "m³",
        "damage_gradient" => "1/m",
        _ => "",
    }
}

/// Draws the raster and its decorations into the PNG at `path`.
pub(super) fn draw(
    raster: &Raster,
    options: &SnapshotOptions,
    range: (f64, f64),
    size: (u32, u32),
    path: &Path,
) -> DrawResult {
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    let (ox, oy) = (MARGIN as i32, MARGIN as i32);
    let map = Map::for_range(range);
    for row in 0..raster.height {
        for col in 0..raster.width {
            let k = row * raster.width + col;
            if raster.body[k] == u32::MAX {
                continue;
            }
            let c = if raster.outline(row, col) {
                RGBColor(30, 30, 30)
            } else {
                map.colour(raster.value[k])
            };
            root.draw_pixel((ox + col as i32, oy + row as i32), &c)?;
        }
    }
    draw_title(&root, options, range, (ox, 14))?;
    draw_axes(&root, raster, options, (ox, oy))?;
    draw_colour_bar(
        &root,
        range,
        map,
        unit_of(&options.field),
        (ox + raster.width as i32 + 30, oy),
        raster.height.min(400) as i32,
    )?;
    draw_scale_bar(&root, raster, (ox, oy + raster.height as i32 + 44))?;
    if let Some(overlay) = &options.overlay {
        draw_overlay(&root, raster, overlay, (ox, oy))?;
    }
    root.present()?;
    Ok(())
}

/// `damage at t = 1.2e-4 s, step 400 (0 to 1)`.
fn draw_title(
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    options: &SnapshotOptions,
    range: (f64, f64),
    at: (i32, i32),
) -> DrawResult {
    let unit = unit_of(&options.field);
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    let when = options
        .when
        .as_ref()
        .map(|w| format!(" at {w}"))
        .unwrap_or_default();
    let title = format!(
        "{}{when} ({} to {}{unit})",
        options.field,
        tick_label(range.0),
        tick_label(range.1)
    );
    root.draw(&Text::new(title, at, ("sans-serif", 22).into_font()))?;
    Ok(())
}

/// Ticks and coordinates along the bottom and left edges of the particle area, in m (mm for a
/// picture less than 10 cm across), and the axes' names.
fn draw_axes(
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    raster: &Raster,
    options: &SnapshotOptions,
    at: (i32, i32),
) -> DrawResult {
    let (width, height) = (raster.width as f64, raster.height as f64);
    let (across, up) = options.view.names();
    let millimetres = width * raster.scale < 0.1;
    let (factor, unit) = if millimetres {
        (1.0e3, "mm")
    } else {
        (1.0, "m")
    };
    let font = ("sans-serif", 14).into_font();
    let step = scale_length(width * raster.scale);
    let bottom = at.1 + raster.height as i32;
    let first = (raster.origin[0] / step).ceil() as i64;
    for k in first.. {
        let x = k as f64 * step;
        let col = (x - raster.origin[0]) / raster.scale;
        if col > width {
            break;
        }
        let px = at.0 + col as i32;
        root.draw(&PathElement::new(
            vec![(px, bottom), (px, bottom + 5)],
            BLACK,
        ))?;
        let label = tick_label(x * factor);
        root.draw(&Text::new(label, (px - 10, bottom + 8), font.clone()))?;
    }
    let top = raster.origin[1];
    let lowest = top - height * raster.scale;
    let first = (lowest / step).ceil() as i64;
    for k in first.. {
        let y = k as f64 * step;
        if y > top {
            break;
        }
        let py = at.1 + ((top - y) / raster.scale) as i32;
        root.draw(&PathElement::new(vec![(at.0 - 5, py), (at.0, py)], BLACK))?;
        let label = tick_label(y * factor);
        root.draw(&Text::new(label, (at.0 - 55, py - 7), font.clone()))?;
    }
    let name = |axis: &str| format!("{axis} ({unit})");
    root.draw(&Text::new(
        name(across),
        (at.0 + raster.width as i32 / 2, bottom + 24),
        font.clone(),
    ))?;
    root.draw(&Text::new(name(up), (4, at.1 - 20), font))?;
    Ok(())
}

fn draw_colour_bar(
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    range: (f64, f64),
    map: Map,
    unit: &str,
    at: (i32, i32),
    height: i32,
) -> DrawResult {
    let height = height.max(60);
    for k in 0..height {
        let t = 1.0 - f64::from(k) / f64::from(height - 1);
        root.draw(&Rectangle::new(
            [(at.0, at.1 + k), (at.0 + 20, at.1 + k + 1)],
            map.colour(t).filled(),
        ))?;
    }
    root.draw(&Rectangle::new(
        [(at.0, at.1), (at.0 + 20, at.1 + height)],
        BLACK,
    ))?;
    for k in 0..=4 {
        let t = f64::from(k) / 4.0;
        let y = at.1 + ((1.0 - t) * f64::from(height - 1)) as i32;
        let label = tick_label(range.0 + t * (range.1 - range.0));
        root.draw(&Text::new(
            label,
            (at.0 + 26, y - 8),
            ("sans-serif", 16).into_font(),
        ))?;
    }
    if !unit.is_empty() {
        root.draw(&Text::new(
            unit.to_string(),
            (at.0, at.1 + height + 8),
            ("sans-serif", 16).into_font(),
        ))?;
    }
    Ok(())
}

fn draw_scale_bar(
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    raster: &Raster,
    at: (i32, i32),
) -> DrawResult {
    let length = scale_length(raster.width as f64 * raster.scale);
    let pixels = (length / raster.scale).round() as i32;
    root.draw(&Rectangle::new(
        [(at.0, at.1), (at.0 + pixels, at.1 + 4)],
        BLACK.filled(),
    ))?;
    let label = if length < 1e-2 {
        format!("{} mm", tick_label(length * 1e3))
    } else {
        format!("{} m", tick_label(length))
    };
    root.draw(&Text::new(
        label,
        (at.0 + pixels + 10, at.1 - 6),
        ("sans-serif", 16).into_font(),
    ))?;
    Ok(())
}

/// The overlay's lines over the particles, and its name beside the scale bar.
fn draw_overlay(
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    raster: &Raster,
    overlay: &crate::overlay::Overlay,
    at: (i32, i32),
) -> DrawResult {
    let style = OVERLAY_COLOUR.stroke_width(2);
    let pixel = |p: &[f64; 2]| {
        let (col, row) = raster.pixel_of(*p);
        (at.0 + col, at.1 + row)
    };
    for line in &overlay.lines {
        root.draw(&PathElement::new(
            line.iter().map(pixel).collect::<Vec<_>>(),
            style,
        ))?;
    }
    let legend = (
        at.0 + raster.width as i32 / 2,
        at.1 + raster.height as i32 + 20,
    );
    root.draw(&PathElement::new(
        vec![legend, (legend.0 + 30, legend.1)],
        style,
    ))?;
    root.draw(&Text::new(
        overlay.label.clone(),
        (legend.0 + 40, legend.1 - 8),
        ("sans-serif", 16).into_font(),
    ))?;
    Ok(())
}

/// The overlay's colour: red, apart from every colour of the map.
const OVERLAY_COLOUR: RGBColor = RGBColor(230, 25, 25);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_ranges_take_the_diverging_map_white_at_zero() {
        assert_eq!(Map::for_range((-2.0, 3.0)), Map::Diverging);
        assert_eq!(Map::for_range((0.0, 1.0)), Map::Sequential);
        assert_eq!(Map::Diverging.colour(0.5), RGBColor(247, 247, 247));
        assert_eq!(diverging(0.0), RGBColor(33, 102, 172));
        assert_eq!(diverging(1.0), RGBColor(178, 24, 43));
    }

    #[test]
    fn fields_have_their_units() {
        assert_eq!(unit_of("stress_xy"), "Pa");
        assert_eq!(unit_of("velocity_x"), "m/s");
        assert_eq!(unit_of("pressure"), "Pa");
        assert_eq!(unit_of("damage"), "");
        assert_eq!(unit_of("strain_energy_density"), "J/m³");
    }
}
