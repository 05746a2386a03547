//! `fractum plot`: PNG line plots of `series.csv` columns against time, optionally with the
//! analytic centre-of-mass velocity of the first axial mode of a bar for comparison.
//!
//! Text is drawn with the DejaVu Sans font compiled into the binary, so plotting needs no
//! system font libraries. The PNG is drawn to a temporary file and renamed into place.

use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// A time series read from `series.csv`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Column names.
    pub columns: Vec<String>,
    /// Rows of values.
    pub rows: Vec<Vec<f64>>,
}

impl Series {
    /// Reads a CSV written by `fractum run`.
    pub fn read(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let mut lines = text.lines();
        let columns: Vec<String> = lines
            .next()
            .ok_or_else(|| format!("{}: empty file", path.display()))?
            .split(',')
            .map(str::to_string)
            .collect();
        let mut rows = Vec::new();
        for (k, line) in lines.enumerate() {
            let row: Result<Vec<f64>, _> = line.split(',').map(str::parse::<f64>).collect();
            let row = row.map_err(|e| format!("{}:{}: {e}", path.display(), k + 2))?;
            if row.len() != columns.len() {
                return Err(format!(
                    "{}:{}: expected {} values",
                    path.display(),
                    k + 2,
                    columns.len()
                ));
            }
            rows.push(row);
        }
        Ok(Self { columns, rows })
    }

    /// Values of column `name`.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, String> {
        let i = self.columns.iter().position(|c| c == name).ok_or_else(|| {
            format!(
                "no column `{name}`; the file has: {}",
                self.columns.join(", ")
            )
        })?;
        Ok(self.rows.iter().map(|r| r[i]).collect())
    }
}

/// Parameters of the analytic bar solution: length, Young's modulus, density, peak velocity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarReference {
    /// Bar length L.
    pub length: f64,
    /// Young's modulus E.
    pub youngs_modulus: f64,
    /// Density ρ.
    pub density: f64,
    /// Peak initial velocity v0.
    pub v0: f64,
}

impl BarReference {
    /// `(2 v0 / π) cos(ω t)` with `ω = π/(2L) √(E/ρ)`.
    pub fn centre_of_mass_velocity(&self, t: f64) -> f64 {
        let omega = std::f64::consts::PI / (2.0 * self.length)
            * (self.youngs_modulus / self.density).sqrt();
        2.0 * self.v0 / std::f64::consts::PI * (omega * t).cos()
    }

    /// Parses `L,E,RHO,V0`.
    pub fn parse(text: &str) -> Result<Self, String> {
        let v: Result<Vec<f64>, _> = text.split(',').map(|s| s.trim().parse::<f64>()).collect();
        match v.map_err(|e| e.to_string())?.as_slice() {
            [l, e, rho, v0] => Ok(Self {
                length: *l,
                youngs_modulus: *e,
                density: *rho,
                v0: *v0,
            }),
            _ => Err("expected four numbers L,E,RHO,V0".into()),
        }
    }
}

pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bundled font is valid; a failure here would only lose the text.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// A tick label readable at any scale: plain for everyday magnitudes, scientific for very
/// small or large ones (microsecond runs, micrometre displacements, megapascal stresses).
pub(crate) fn tick_label(v: f64) -> String {
    let magnitude = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-2..1e5).contains(&magnitude) {
        format!("{v:.2e}")
    } else {
        format!("{v:.3}")
    }
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        lo.abs().max(1.0) * 0.05
    };
    (lo - pad, hi + pad)
}

/// Draws `columns` of `series` against the column `x` (usually `time`) into `output`, with the
/// bar reference curve (which is a function of time) when given. Returns the path written.
pub fn plot(
    series: &Series,
    x: &str,
    columns: &[String],
    bar: Option<BarReference>,
    output: &Path,
) -> Result<PathBuf, String> {
    plot_runs(&[(String::new(), series.clone())], x, columns, bar, output)
}

/// As [`plot`], for several runs on one plot: each curve is labelled `<run>: <column>` (or
/// just the column when there is one run).
pub fn plot_runs(
    runs: &[(String, Series)],
    x: &str,
    columns: &[String],
    bar: Option<BarReference>,
    output: &Path,
) -> Result<PathBuf, String> {
    register_font();
    let mut curves: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut time = Vec::new();
    for (run, series) in runs {
        let xs = series.column(x)?;
        for name in columns {
            let values = series.column(name)?;
            let label = if runs.len() > 1 {
                format!("{run}: {name}")
            } else {
                name.clone()
            };
            curves.push((label, xs.iter().copied().zip(values).collect()));
        }
        time.extend(xs);
    }
    if let Some(bar) = bar {
        let t_end = time.iter().copied().fold(0.0, f64::max);
        let samples = (0..=2000).map(|k| t_end * k as f64 / 2000.0);
        curves.push((
            "analytic (2 v0/π) cos(ωt)".into(),
            samples
                .map(|t| (t, bar.centre_of_mass_velocity(t)))
                .collect(),
        ));
    }
    let x_desc = with_unit(x);
    let y_desc = columns_desc(columns);
    draw_curves(&curves, (&x_desc, &y_desc), output)
}

/// The unit of a series.csv column, by its name (empty for a count or a ratio).
pub fn column_unit(column: &str) -> &'static str {
    let has = |part: &str| column.contains(part);
    match column {
        "time" => "s",
        "step" => "",
        _ if has("energy") || has("work") => "J",
        _ if has("momentum") => "kg m/s",
        _ if has("reaction") || has("force") => "N",
        _ if has("velocity") => "m/s",
        _ if has("displacement") || has("position") || has("opening") => "m",
        _ if has("stress") || has("pressure") => "Pa",
        _ => "",
    }
}

/// `name (unit)`, or the name alone where it has none.
fn with_unit(column: &str) -> String {
    match column_unit(column) {
        "" => column.to_string(),
        unit => format!("{column} ({unit})"),
    }
}

/// The y axis's name: the columns, with their unit where they share one.
fn columns_desc(columns: &[String]) -> String {
    let units: Vec<&str> = columns.iter().map(|c| column_unit(c)).collect();
    match units.first() {
        Some(first) if !first.is_empty() && units.iter().all(|u| u == first) => {
            format!("{} ({first})", columns.join(", "))
        }
        _ => columns
            .iter()
            .map(|c| with_unit(c))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// The corner of the chart whose quarter holds the fewest of the curves' points, for the
/// legend, so it covers as little of the curves as can be.
fn quietest_corner(
    curves: &[(String, Vec<(f64, f64)>)],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> SeriesLabelPosition {
    let mut counts = [0usize; 4];
    for (x, y) in curves.iter().flat_map(|(_, c)| c.iter()) {
        let right = (x - x0) / (x1 - x0) > 0.55;
        let upper = (y - y0) / (y1 - y0) > 0.55;
        let left_ = (x - x0) / (x1 - x0) < 0.45;
        let lower = (y - y0) / (y1 - y0) < 0.45;
        counts[0] += usize::from(upper && left_);
        counts[1] += usize::from(upper && right);
        counts[2] += usize::from(lower && left_);
        counts[3] += usize::from(lower && right);
    }
    let corners = [
        SeriesLabelPosition::UpperLeft,
        SeriesLabelPosition::UpperRight,
        SeriesLabelPosition::LowerLeft,
        SeriesLabelPosition::LowerRight,
    ];
    let quietest = (0..4).min_by_key(|&k| counts[k]).unwrap_or(1);
    corners[quietest].clone()
}

/// Draws labelled `curves` (x, y points) on one chart with the axes' names `(x, y)` into the
/// PNG `output`, written to a temporary name and renamed. Returns the path written.
pub fn draw_curves(
    curves: &[(String, Vec<(f64, f64)>)],
    (x_desc, y_desc): (&str, &str),
    output: &Path,
) -> Result<PathBuf, String> {
    register_font();
    let (x0, x1) = range(curves.iter().flat_map(|(_, c)| c.iter().map(|p| p.0)));
    let (y0, y1) = range(curves.iter().flat_map(|(_, c)| c.iter().map(|p| p.1)));
    // The encoder chooses the format from the extension, so the temporary name ends in .png.
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let temp = output.with_file_name(format!(".{name}.{}.tmp.png", std::process::id()));
    {
        let root = BitMapBackend::new(&temp, (1200, 700)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = ChartBuilder::on(&root)
            .margin(20)
            .x_label_area_size(60)
            .y_label_area_size(110)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(("sans-serif", 18))
            .axis_desc_style(("sans-serif", 20))
            .draw()
            .map_err(|e| e.to_string())?;
        for (k, (name, points)) in curves.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            chart
                .draw_series(LineSeries::new(
                    points.iter().copied(),
                    color.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?
                .label(name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(quietest_corner(curves, (x0, x1), (y0, y1)))
            .label_font(("sans-serif", 18))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    std::fs::rename(&temp, output)
        .map_err(|e| format!("cannot write {}: {e}", output.display()))?;
    Ok(output.to_path_buf())
}

/// Peak of a load curve and the roughness of its rising part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveSummary {
    /// Largest y.
    pub peak: f64,
    /// x at the peak.
    pub x_at_peak: f64,
    /// Slope of the least-squares line through the pre-peak points.
    pub slope: f64,
    /// RMS deviation of the pre-peak points from that line.
    pub rms_deviation: f64,
    /// How far x runs past the peak before y first falls below [`FALLEN_FRACTION`] of it: how
    /// abruptly the load drops. `None` when it never falls that far.
    pub fall: Option<f64>,
}

/// The fraction of its peak below which a load curve counts as fallen ([`CurveSummary::fall`]).
pub const FALLEN_FRACTION: f64 = 0.05;

/// Peak of `y` against `x`, and the RMS deviation from a straight line of the points with
/// `x` between `from` and 90% of the peak's x (the "wiggle" of a loading curve).
///
/// A curve loaded in the negative direction (a loader pushing down records a negative
/// displacement and reaction) is read with the signs of `x` and `y` taken from its point of
/// largest `|y|`, so the peak, its `x`, `from` and the slope are magnitudes either way.
pub fn curve_summary(x: &[f64], y: &[f64], from: f64) -> Option<CurveSummary> {
    let extreme = (0..y.len()).max_by(|&a, &b| y[a].abs().total_cmp(&y[b].abs()))?;
    let sign = |v: f64| if v < 0.0 { -1.0 } else { 1.0 };
    let (sx, sy) = (sign(x[extreme]), sign(y[extreme]));
    let x: Vec<f64> = x.iter().map(|v| sx * v).collect();
    let y: Vec<f64> = y.iter().map(|v| sy * v).collect();
    oriented_curve_summary(&x, &y, from)
}

/// [`curve_summary`] of a curve that rises in positive `x` and `y`.
fn oriented_curve_summary(x: &[f64], y: &[f64], from: f64) -> Option<CurveSummary> {
    let peak_index = (0..y.len()).max_by(|&a, &b| y[a].total_cmp(&y[b]))?;
    let (peak, x_at_peak) = (y[peak_index], x[peak_index]);
    let points: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(xi, _)| **xi >= from && **xi <= 0.9 * x_at_peak)
        .map(|(a, b)| (*a, *b))
        .collect();
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let slope = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
    let rms = (points
        .iter()
        .map(|p| (p.1 - (my + slope * (p.0 - mx))).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let fall = (peak_index..y.len())
        .find(|&k| y[k] < FALLEN_FRACTION * peak)
        .map(|k| x[k] - x_at_peak);
    Some(CurveSummary {
        peak,
        x_at_peak,
        slope,
        rms_deviation: rms,
        fall,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve_summary_finds_the_peak_and_the_roughness_of_the_rise() {
        let x: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
        let straight: Vec<f64> = x
            .iter()
            .map(|v| if *v <= 0.5 { 2.0 * v } else { 1.0 - (v - 0.5) })
            .collect();
        let s = curve_summary(&x, &straight, 0.0).unwrap();
        assert_eq!((s.peak, s.x_at_peak), (1.0, 0.5));
        assert!((s.slope - 2.0).abs() < 1e-12 && s.rms_deviation < 1e-12);
        // Down to 0.5 only: it never falls below 5% of the peak.
        assert_eq!(s.fall, None);
        // Down by 10 per unit of x: 0.1 at x = 0.59, below 0.05 (at 0) from x = 0.6.
        let abrupt: Vec<f64> = x
            .iter()
            .map(|v| {
                if *v <= 0.5 {
                    2.0 * v
                } else {
                    (1.0 - 10.0 * (v - 0.5)).max(0.0)
                }
            })
            .collect();
        let fall = curve_summary(&x, &abrupt, 0.0).unwrap().fall.unwrap();
        assert!((fall - 0.1).abs() < 1e-12, "{fall}");
        let wiggly: Vec<f64> = straight
            .iter()
            .enumerate()
            .map(|(i, v)| v + if i % 2 == 0 { 0.01 } else { -0.01 })
            .collect();
        let s = curve_summary(&x, &wiggly, 0.0).unwrap();
        assert!((s.rms_deviation - 0.01).abs() < 1e-3, "{}", s.rms_deviation);
    }

    #[test]
    fn a_curve_loaded_downwards_reads_as_its_mirror_image() {
        // A loader moving down: negative displacement and reaction, with a small positive
        // ringing spike after the peak that must not be taken for it.
        let x: Vec<f64> = (0..=100).map(|i| -(i as f64) / 100.0).collect();
        let mut y: Vec<f64> = x
            .iter()
            .map(|v| {
                if *v >= -0.5 {
                    2.0 * v
                } else {
                    -1.0 - (v + 0.5)
                }
            })
            .collect();
        y[80] = 0.3;
        let s = curve_summary(&x, &y, 0.0).unwrap();
        assert_eq!((s.peak, s.x_at_peak), (1.0, 0.5));
        assert!((s.slope - 2.0).abs() < 1e-12 && s.rms_deviation < 1e-12);
    }

    #[test]
    fn tick_labels_are_readable_at_any_scale() {
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(1.5e-6), "1.50e-6");
        assert_eq!(tick_label(-2.0e8), "-2.00e8");
        assert_eq!(tick_label(0.25), "0.250");
    }

    #[test]
    fn bar_reference_matches_the_analytic_period_and_amplitude() {
        let bar = BarReference::parse("25, 100, 1, 0.1").unwrap();
        let a = 0.2 / std::f64::consts::PI;
        assert!((bar.centre_of_mass_velocity(0.0) - a).abs() < 1e-15);
        assert!((bar.centre_of_mass_velocity(10.0) - a).abs() < 1e-12);
        assert!(bar.centre_of_mass_velocity(2.5).abs() < 1e-12);
        assert!(BarReference::parse("1,2").is_err());
    }

    #[test]
    fn plots_columns_into_a_png() {
        let dir = std::env::temp_dir().join(format!("fractum-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let csv = dir.join("series.csv");
        std::fs::write(
            &csv,
            "step,time,a,b\n0,0.0,1.0,2.0\n1,0.5,1.5,1.0\n2,1.0,0.5,0.0\n",
        )
        .unwrap();
        let series = Series::read(&csv).unwrap();
        assert!(
            series
                .column("c")
                .unwrap_err()
                .contains("the file has: step, time, a, b")
        );
        let out = plot(
            &series,
            "time",
            &["a".into(), "b".into()],
            None,
            &dir.join("ab.png"),
        )
        .unwrap();
        let bytes = std::fs::read(&out).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            2,
            "only the CSV and the PNG"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
