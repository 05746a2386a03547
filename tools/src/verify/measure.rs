//! What a verification check measures in a run's outputs, with the analysis the other commands
//! use: `series.csv` columns, `curve`'s load-curve summary, `crack`'s angle and speed,
//! `fragments`' statistics. Every measure gives one number in SI units.

use crate::body_motion::{least_squares_slope, motion_history, rates};
use crate::crossing::{CrossingLine, crack_band_width, crack_crossing};
use crate::{crack, fragments, plot};
use fractum_io::output::ParticleFrame;
use serde::Deserialize;
use std::path::Path;

/// A quantity measured on a run's outputs.
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub enum Measure {
    /// The largest value of a series column from time `from` on.
    SeriesPeak {
        /// The column.
        column: String,
        /// Rows before this time are left out (s).
        #[serde(default)]
        from: f64,
    },
    /// A column's value at the last row.
    SeriesFinal {
        /// The column.
        column: String,
    },
    /// A column's first value less its mean over the rows with time in `[from, to]` (to the
    /// end when `to` is absent): the drop of the total energy, say.
    SeriesDrop {
        /// The column.
        column: String,
        /// Start of the window (s).
        from: f64,
        /// End of the window (s).
        #[serde(default)]
        to: Option<f64>,
    },
    /// The least-squares slope of a column against time over `[from, to]` (a deceleration).
    SeriesSlope {
        /// The column.
        column: String,
        /// Start of the window (s).
        from: f64,
        /// End of the window (s).
        to: f64,
    },
    /// The energy the run dissipated by its end: the work of the loads less the rise of the
    /// total energy (`external_work − (total_energy − total_energy₀)` at the last row).
    Dissipated,
    /// The most energy the run created: the largest of `total_energy − total_energy₀ −
    /// external_work` over the rows, or zero when it never rises above the work done.
    EnergyCreated,
    /// The peak of `y` against `x` (`fractum curve`), points with `x < from` left out.
    CurvePeak {
        /// Column for x.
        x: String,
        /// Column for y.
        y: String,
        /// Smallest x considered.
        #[serde(default)]
        from: f64,
    },
    /// `x` at the peak of `y` (`fractum curve`).
    CurvePeakAt {
        /// Column for x.
        x: String,
        /// Column for y.
        y: String,
        /// Smallest x considered.
        #[serde(default)]
        from: f64,
    },
    /// The pre-peak slope of `y` against `x` (`fractum curve`).
    CurveSlope {
        /// Column for x.
        x: String,
        /// Column for y.
        y: String,
        /// Smallest x considered.
        #[serde(default)]
        from: f64,
    },
    /// The roughness of the rise of `y` against `x` (`fractum curve`): the RMS deviation of
    /// the pre-peak points from their straight line, as a fraction of the peak.
    CurveWiggle {
        /// Column for x.
        x: String,
        /// Column for y.
        y: String,
        /// Smallest x considered.
        #[serde(default)]
        from: f64,
    },
    /// How abruptly `y` drops after its peak (`fractum curve`): how far `x` runs past the peak
    /// before `y` first falls below 5% of it. An error when it never falls that far.
    CurveFall {
        /// Column for x.
        x: String,
        /// Column for y.
        y: String,
        /// Smallest x considered.
        #[serde(default)]
        from: f64,
    },
    /// The period of an oscillating column: twice the mean interval between its zero
    /// crossings.
    OscillationPeriod {
        /// The column.
        column: String,
    },
    /// The amplitude of an oscillating column: the mean of its largest magnitudes between
    /// consecutive zero crossings.
    OscillationAmplitude {
        /// The column.
        column: String,
    },
    /// The initial angle of a crack from a notch (degrees, `fractum crack`).
    CrackAngle(CrackAt),
    /// The mean speed of a crack from a notch (m/s, `fractum crack`).
    CrackSpeed(CrackAt),
    /// The number of fragments of more than one particle at the frame nearest `time`
    /// (`fractum fragments`; single-particle debris is left out).
    FragmentCount(FragmentsAt),
    /// The equivalent diameter of the largest fragment (m).
    LargestFragment(FragmentsAt),
    /// The mass-weighted mean speed of the fragments (m/s).
    FragmentSpeed(FragmentsAt),
    /// Where a crack crosses a line at the frame nearest `time` (the last when absent): the
    /// centre of its band there (m, [`crossing`](crate::crossing)).
    CrackCrossing(CrossingAt),
    /// The width of a crack's band where it crosses a line at the frame nearest `time` (the
    /// last when absent): from its lowest particle's lower edge to its highest's upper edge
    /// (m, [`crossing`](crate::crossing)).
    CrackBandWidth(CrossingAt),
    /// The least-squares acceleration of a body's centre of mass along a direction, over the
    /// particle frames from `from` on (m/s², [`body_motion`](crate::body_motion)).
    BodyAcceleration(BodyMotionAt),
    /// The least-squares angular acceleration of a body about the z axis through its centre
    /// of mass, counter-clockwise positive, over the particle frames from `from` on (rad/s²).
    BodySpinAcceleration(BodyMotionAt),
}

/// Which body's rigid motion, and over which frames.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodyMotionAt {
    /// The body (index in the scene's order).
    pub body: u16,
    /// Frames before this time are left out (s).
    #[serde(default)]
    pub from: f64,
    /// The direction of the acceleration, 2 or 3 coordinates (x when absent).
    #[serde(default)]
    pub direction: Option<Vec<f64>>,
}

impl BodyMotionAt {
    /// The body's acceleration along the direction and its angular acceleration.
    fn rates(&self, dir: &Path) -> Result<(f64, f64), String> {
        let history = motion_history(dir, self.body, self.from)?;
        let along = self.direction.as_deref().unwrap_or(&[1.0, 0.0]);
        let direction = std::array::from_fn(|a| along.get(a).copied().unwrap_or(0.0));
        rates(&history, direction).ok_or_else(|| {
            format!(
                "{} frames from {} s on, or no direction: no rates",
                history.len(),
                self.from
            )
        })
    }
}

/// A crack's crossing of a line at one frame.
#[derive(Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CrossingAt {
    /// The time of the frame (s); the nearest written is used, the last when absent.
    #[serde(default)]
    pub time: Option<f64>,
    /// The line and the window on it.
    pub line: CrossingLine,
    /// Where the particles of that frame's crack stood in the first frame
    /// ([`undeformed`](crate::crossing::undeformed)): the path of a crack whose pieces have
    /// since moved apart, put back together as an experiment's traced crack is.
    #[serde(default)]
    pub undeformed: bool,
}

/// `undeformed` is printed only when set: a case's key is the debug text of its measures
/// (`verify::case_key`), and a crossing measured before the option existed keeps its key, and
/// so its result.
impl std::fmt::Debug for CrossingAt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut text = f.debug_struct("CrossingAt");
        text.field("time", &self.time).field("line", &self.line);
        if self.undeformed {
            text.field("undeformed", &self.undeformed);
        }
        text.finish()
    }
}

impl CrossingAt {
    /// The frame the crossing is measured on, put back undeformed when asked.
    fn frame(&self, dir: &Path) -> Result<ParticleFrame, String> {
        let frame = crate::snapshot::frame_near(dir, self.time)?;
        if self.undeformed {
            let first = crate::snapshot::frame_near(dir, Some(0.0))?;
            crate::crossing::undeformed(&frame, &first)
        } else {
            Ok(frame)
        }
    }
}

/// Where a crack starts (as `fractum crack` takes it).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CrackAt {
    /// The notch tip, 2 or 3 coordinates.
    pub notch: Vec<f64>,
    /// The notch's direction, from its mouth to its tip.
    pub direction: Vec<f64>,
    /// Particles damaged at least this much are crack.
    #[serde(default = "half")]
    pub damage_above: f64,
    /// Crack length at which the angle is taken (m) [default: 8 link lengths].
    #[serde(default)]
    pub angle_length: Option<f64>,
    /// The speed's time window `[from, to]` (s): the least-squares speed over the frames in it,
    /// as a paper reports a crack's speed over part of its growth; over the whole growth when
    /// absent.
    #[serde(default)]
    pub window: Option<[f64; 2]>,
}

/// Which fragments (as `fractum fragments` takes them).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FragmentsAt {
    /// The time of the frame (s); the nearest written is used.
    pub time: f64,
    /// Only these bodies (indices in the scene's order); all when empty.
    #[serde(default)]
    pub bodies: Vec<u16>,
    /// `time` counts from the split rather than the start: the first frame at which the
    /// second-largest fragment holds at least [`SPLIT_SHARE`] of the fragments' mass. Runs
    /// that split at different times are so compared at one time after their split.
    #[serde(default)]
    pub after_split: bool,
}

/// The share of the fragments' mass the second-largest must hold for a body to have split
/// ([`FragmentsAt::after_split`]).
pub const SPLIT_SHARE: f64 = 0.1;

fn half() -> f64 {
    0.5
}

impl Measure {
    /// Checks what can be checked without a run.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            Measure::CrackAngle(c) | Measure::CrackSpeed(c) => {
                let dims = (c.notch.len(), c.direction.len());
                if !matches!(dims, (2, 2) | (3, 3)) {
                    return Err("notch and direction take 2 or 3 coordinates each".into());
                }
                match c.window {
                    Some([from, to]) if to <= from || to.is_nan() || from.is_nan() => {
                        Err("the crack's window needs `to` after `from`".into())
                    }
                    _ => Ok(()),
                }
            }
            Measure::CrackCrossing(at) | Measure::CrackBandWidth(at) => at.line.validate(),
            Measure::BodyAcceleration(at) | Measure::BodySpinAcceleration(at) => {
                match at.direction.as_deref() {
                    Some(d) if !matches!(d.len(), 2 | 3) || d.iter().all(|x| *x == 0.0) => {
                        Err("the direction takes 2 or 3 coordinates, not all zero".into())
                    }
                    _ => Ok(()),
                }
            }
            Measure::SeriesSlope { from, to, .. } if to <= from || to.is_nan() || from.is_nan() => {
                Err("the window needs `to` after `from`".into())
            }
            _ => Ok(()),
        }
    }

    /// The measured value (SI) from the outputs in `dir`.
    pub fn measure(&self, dir: &Path) -> Result<f64, String> {
        match self {
            Measure::CrackAngle(at) => {
                let history = crack_history(dir, at)?.0;
                let options = crack_options(dir, at)?;
                crack::initial_angle(&history, &options).ok_or_else(|| {
                    format!(
                        "the crack never grew to {:e} m, where its angle is taken",
                        options.angle_length
                    )
                })
            }
            Measure::CrackSpeed(at) => {
                let history = crack_history(dir, at)?.0;
                match at.window {
                    Some([from, to]) => crack::crack_speed_between(&history, from, to)
                        .ok_or_else(|| format!("fewer than two frames from {from:e} to {to:e} s")),
                    None => crack::crack_speed(&history)
                        .map(|(mean, _)| mean)
                        .ok_or_else(|| "the crack did not grow between frames".into()),
                }
            }
            Measure::FragmentCount(at) => {
                let found = fragments_at(dir, at)?;
                Ok(found.iter().filter(|f| f.particles > 1).count() as f64)
            }
            Measure::LargestFragment(at) => Ok(fragments_at(dir, at)?
                .iter()
                .map(|f| f.diameter)
                .fold(0.0, f64::max)),
            Measure::FragmentSpeed(at) => Ok(fragments::mean_speed(&fragments_at(dir, at)?)),
            Measure::CrackCrossing(at) => crack_crossing(&at.frame(dir)?, &at.line),
            Measure::CrackBandWidth(at) => crack_band_width(&at.frame(dir)?, &at.line),
            Measure::BodyAcceleration(at) => at.rates(dir).map(|r| r.0),
            Measure::BodySpinAcceleration(at) => at.rates(dir).map(|r| r.1),
            series_measure => series_measure.of_series(&read_series(dir)?),
        }
    }

    /// The measures of `series.csv` alone.
    fn of_series(&self, series: &plot::Series) -> Result<f64, String> {
        let time = series.column("time")?;
        match self {
            Measure::SeriesPeak { column, from } => {
                let values = series.column(column)?;
                let peak = values
                    .iter()
                    .zip(&time)
                    .filter(|(_, t)| **t >= *from)
                    .map(|(v, _)| *v)
                    .fold(f64::NEG_INFINITY, f64::max);
                finite(peak, "no row at or after the window's start")
            }
            Measure::SeriesFinal { column } => {
                let values = series.column(column)?;
                values
                    .last()
                    .copied()
                    .ok_or_else(|| "series.csv has no rows".into())
            }
            Measure::SeriesDrop { column, from, to } => {
                let values = series.column(column)?;
                let window = window(&time, &values, *from, to.unwrap_or(f64::INFINITY));
                let first = *values.first().ok_or("series.csv has no rows")?;
                let mean = window.iter().map(|p| p.1).sum::<f64>() / window.len() as f64;
                finite(first - mean, "no row in the window")
            }
            Measure::SeriesSlope { column, from, to } => {
                let values = series.column(column)?;
                least_squares_slope(&window(&time, &values, *from, *to))
                    .ok_or_else(|| "fewer than two rows in the window".into())
            }
            Measure::Dissipated => energy_balance(series).map(|rows| {
                let last = rows.last().copied().unwrap_or_default();
                last.work - (last.total - rows[0].total)
            }),
            Measure::EnergyCreated => energy_balance(series).map(|rows| {
                rows.iter()
                    .map(|r| r.total - rows[0].total - r.work)
                    .fold(0.0, f64::max)
            }),
            Measure::CurvePeak { x, y, from } => curve(series, x, y, *from).map(|c| c.peak),
            Measure::CurvePeakAt { x, y, from } => curve(series, x, y, *from).map(|c| c.x_at_peak),
            Measure::CurveSlope { x, y, from } => curve(series, x, y, *from).map(|c| c.slope),
            Measure::CurveWiggle { x, y, from } => {
                curve(series, x, y, *from).map(|c| c.rms_deviation / c.peak)
            }
            Measure::CurveFall { x, y, from } => {
                curve(series, x, y, *from)?.fall.ok_or_else(|| {
                    format!(
                        "{y} never falls below {}% of its peak",
                        100.0 * plot::FALLEN_FRACTION
                    )
                })
            }
            Measure::OscillationPeriod { column } => {
                let crossings = zero_crossings(&time, &series.column(column)?);
                if crossings.len() < 3 {
                    return Err(format!("{column} crosses zero fewer than three times"));
                }
                let span = crossings[crossings.len() - 1] - crossings[0];
                Ok(2.0 * span / (crossings.len() - 1) as f64)
            }
            Measure::OscillationAmplitude { column } => {
                oscillation_amplitude(&time, &series.column(column)?)
            }
            _ => unreachable!("frame measures are taken in `measure`"),
        }
    }
}

fn finite(x: f64, otherwise: &str) -> Result<f64, String> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(otherwise.to_string())
    }
}

fn read_series(dir: &Path) -> Result<plot::Series, String> {
    plot::Series::read(&dir.join("series.csv"))
}

/// The (time, value) pairs with time in `[from, to]`.
fn window(time: &[f64], values: &[f64], from: f64, to: f64) -> Vec<(f64, f64)> {
    time.iter()
        .zip(values)
        .filter(|(t, _)| **t >= from && **t <= to)
        .map(|(t, v)| (*t, *v))
        .collect()
}

/// Times where `values` changes sign, by linear interpolation.
fn zero_crossings(time: &[f64], values: &[f64]) -> Vec<f64> {
    (1..values.len())
        .filter(|&k| values[k - 1] * values[k] < 0.0)
        .map(|k| {
            let (t0, t1, v0, v1) = (time[k - 1], time[k], values[k - 1], values[k]);
            t0 - v0 * (t1 - t0) / (v1 - v0)
        })
        .collect()
}

fn oscillation_amplitude(time: &[f64], values: &[f64]) -> Result<f64, String> {
    let crossings = zero_crossings(time, values);
    let peaks: Vec<f64> = crossings
        .windows(2)
        .map(|w| {
            time.iter()
                .zip(values)
                .filter(|(t, _)| **t > w[0] && **t < w[1])
                .map(|(_, v)| v.abs())
                .fold(0.0, f64::max)
        })
        .collect();
    if peaks.is_empty() {
        return Err("the column crosses zero fewer than twice".into());
    }
    Ok(peaks.iter().sum::<f64>() / peaks.len() as f64)
}

#[derive(Clone, Copy, Debug, Default)]
struct Balance {
    total: f64,
    work: f64,
}

fn energy_balance(series: &plot::Series) -> Result<Vec<Balance>, String> {
    let total = series.column("total_energy")?;
    let work = series.column("external_work")?;
    if total.is_empty() {
        return Err("series.csv has no rows".into());
    }
    Ok(total
        .iter()
        .zip(&work)
        .map(|(t, w)| Balance {
            total: *t,
            work: *w,
        })
        .collect())
}

fn curve(series: &plot::Series, x: &str, y: &str, from: f64) -> Result<plot::CurveSummary, String> {
    plot::curve_summary(&series.column(x)?, &series.column(y)?, from)
        .ok_or_else(|| format!("too few points of {y} before its peak"))
}

fn crack_options(dir: &Path, at: &CrackAt) -> Result<crack::CrackOptions, String> {
    let point = |v: &[f64]| [v[0], v[1], v.get(2).copied().unwrap_or(0.0)];
    let link = crate::crack::default_link(dir, None)?;
    Ok(crack::CrackOptions {
        notch_tip: point(&at.notch),
        notch_direction: point(&at.direction),
        damage_above: at.damage_above,
        link,
        angle_length: at.angle_length.unwrap_or(crack::DEFAULT_ANGLE_LINKS * link),
    })
}

fn crack_history(dir: &Path, at: &CrackAt) -> Result<(Vec<crack::TipAt>, f64), String> {
    let options = crack_options(dir, at)?;
    Ok((crack::crack_history(dir, &options)?, options.link))
}

fn fragments_at(dir: &Path, at: &FragmentsAt) -> Result<Vec<fragments::Fragment>, String> {
    let options = fragments::FragmentOptions {
        bodies: at.bodies.clone(),
        ..Default::default()
    };
    let time = if at.after_split {
        split_time(dir, &options)? + at.time
    } else {
        at.time
    };
    Ok(fragments::run_fragments(dir, Some(time), &options)?.fragments)
}

/// The time of the first particle frame at which the fragments have split
/// ([`FragmentsAt::after_split`]).
fn split_time(dir: &Path, options: &fragments::FragmentOptions) -> Result<f64, String> {
    let frames = fractum_io::output::read_pvd(&dir.join("particles.pvd"))?;
    for (time, file) in &frames {
        let frame = fractum_io::output::read_particle_frame(&dir.join(file))?;
        let (found, _) = fragments::find_fragments(&frame, options)?;
        if has_split(&found) {
            return Ok(*time);
        }
    }
    Err(format!(
        "{}: no frame shows a split (a second fragment of {}% of the mass)",
        dir.display(),
        100.0 * SPLIT_SHARE
    ))
}

/// Whether the second-largest of `fragments` (largest first) holds [`SPLIT_SHARE`] of their
/// mass.
fn has_split(fragments: &[fragments::Fragment]) -> bool {
    let total: f64 = fragments.iter().map(|f| f.mass).sum();
    fragments
        .get(1)
        .is_some_and(|second| second.mass >= SPLIT_SHARE * total)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(columns: &[&str], rows: Vec<Vec<f64>>) -> plot::Series {
        plot::Series {
            columns: columns.iter().map(|c| c.to_string()).collect(),
            rows,
        }
    }

    /// A body has split once its second-largest fragment holds a tenth of the mass; debris
    /// does not count.
    #[test]
    fn a_split_is_a_second_fragment_of_a_tenth_of_the_mass() {
        let fragment = |mass: f64| fragments::Fragment {
            particles: 10,
            mass,
            volume: mass,
            diameter: 1.0,
            centroid: [0.0; 3],
            velocity: [0.0; 3],
        };
        assert!(!has_split(&[fragment(10.0)]));
        assert!(!has_split(&[fragment(10.0), fragment(0.5), fragment(0.5)]));
        assert!(has_split(&[fragment(6.0), fragment(4.0)]));
        assert!(has_split(&[fragment(8.0), fragment(1.0), fragment(1.0)]));
    }

    #[test]
    fn a_cosine_has_its_period_and_amplitude() {
        let rows = (0..=3000)
            .map(|k| {
                let t = k as f64 * 0.01;
                vec![t, 0.2 * (std::f64::consts::TAU * t / 10.0).cos()]
            })
            .collect();
        let s = series(&["time", "v"], rows);
        let period = Measure::OscillationPeriod { column: "v".into() };
        assert!((period.of_series(&s).unwrap() - 10.0).abs() < 1e-6);
        let amplitude = Measure::OscillationAmplitude { column: "v".into() };
        assert!((amplitude.of_series(&s).unwrap() - 0.2).abs() < 1e-5);
    }

    #[test]
    fn energy_measures_follow_the_balance() {
        // Work 3 J done, total energy up by 1 J: 2 J dissipated; at t = 1 the total rose 0.5 J
        // above the work then done: created.
        let s = series(
            &["time", "total_energy", "external_work"],
            vec![
                vec![0.0, 10.0, 0.0],
                vec![1.0, 11.5, 1.0],
                vec![2.0, 11.0, 3.0],
            ],
        );
        assert_eq!(Measure::Dissipated.of_series(&s).unwrap(), 2.0);
        assert_eq!(Measure::EnergyCreated.of_series(&s).unwrap(), 0.5);
        let drop = Measure::SeriesDrop {
            column: "total_energy".into(),
            from: 1.0,
            to: None,
        };
        assert_eq!(drop.of_series(&s).unwrap(), -1.25);
    }

    #[test]
    fn slopes_peaks_and_finals_read_their_columns() {
        let s = series(
            &["time", "v"],
            vec![
                vec![0.0, 5.0],
                vec![1.0, 3.0],
                vec![2.0, 1.0],
                vec![3.0, 9.0],
            ],
        );
        let slope = Measure::SeriesSlope {
            column: "v".into(),
            from: 0.0,
            to: 2.0,
        };
        assert_eq!(slope.of_series(&s).unwrap(), -2.0);
        let peak = Measure::SeriesPeak {
            column: "v".into(),
            from: 0.5,
        };
        assert_eq!(peak.of_series(&s).unwrap(), 9.0);
        let last = Measure::SeriesFinal { column: "v".into() };
        assert_eq!(last.of_series(&s).unwrap(), 9.0);
        let missing = Measure::SeriesFinal { column: "w".into() };
        assert!(missing.of_series(&s).unwrap_err().contains("no column `w`"));
    }

    /// A load curve rising at 2 per unit of u to 1 at u = 0.5, with ±0.01 of noise on the
    /// rise, then dropping by 10 per unit: its wiggle is the noise over the peak, its fall 0.1.
    #[test]
    fn a_load_curve_has_its_wiggle_and_its_fall() {
        let rows = (0..=100)
            .map(|k| {
                let u = k as f64 / 100.0;
                let noise = if k % 2 == 0 { 0.01 } else { -0.01 };
                let r = if u <= 0.5 {
                    2.0 * u + noise
                } else {
                    (1.0 - 10.0 * (u - 0.5)).max(0.0)
                };
                vec![u, u, r]
            })
            .collect();
        let s = series(&["time", "u", "r"], rows);
        let (x, y, from) = ("u".to_string(), "r".to_string(), 0.0);
        let wiggle = Measure::CurveWiggle {
            x: x.clone(),
            y: y.clone(),
            from,
        };
        let measured = wiggle.of_series(&s).unwrap();
        assert!((measured - 0.01 / 1.01).abs() < 1e-3, "{measured}");
        let fall = Measure::CurveFall { x, y, from };
        assert!((fall.of_series(&s).unwrap() - 0.1).abs() < 1e-12);
        let flat = series(
            &["time", "u", "r"],
            (0..=10)
                .map(|k| vec![k as f64, k as f64, k.min(5) as f64])
                .collect(),
        );
        assert!(fall.of_series(&flat).unwrap_err().contains("never falls"));
    }
    #[test]
    fn a_crack_needs_matching_coordinates() {
        let bad = Measure::CrackAngle(CrackAt {
            notch: vec![0.0, 1.0],
            direction: vec![1.0, 0.0, 0.0],
            damage_above: 0.5,
            angle_length: None,
            window: None,
        });
        assert!(bad.validate().is_err());
        let backwards = Measure::CrackSpeed(CrackAt {
            notch: vec![0.0, 1.0],
            direction: vec![1.0, 0.0],
            damage_above: 0.5,
            angle_length: None,
            window: Some([50e-6, 40e-6]),
        });
        assert!(
            backwards
                .validate()
                .unwrap_err()
                .contains("`to` after `from`")
        );
    }

    /// A crossing without `undeformed` prints as it did before the option existed, so the keys
    /// of the cases measured then still hold their runs.
    #[test]
    fn a_crossing_keeps_its_key_text_unless_it_is_undeformed() {
        let text = "(time: Some(5.0e-4), line: (across: Y, level: 0.06, along: X, between: \
                    (0.12, 0.21)))";
        let at: CrossingAt = ron::from_str(text).unwrap();
        assert_eq!(
            format!("{at:?}"),
            "CrossingAt { time: Some(0.0005), line: CrossingLine { across: Y, level: 0.06, \
             along: X, between: (0.12, 0.21), damage_above: 0.5 } }"
        );
        let put_back: CrossingAt =
            ron::from_str(&text.replace(")))", ")), undeformed: true)")).unwrap();
        assert!(format!("{put_back:?}").ends_with("damage_above: 0.5 }, undeformed: true }"));
    }
}
