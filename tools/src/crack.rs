//! `fractum crack`: the path of a crack from a notch, its tip against time, its initial angle
//! and its speed, from the damage field of a run's frames (for the DFG paper's §3.2
//! Kalthoff–Winkler test: crack angle and speed).
//!
//! - The crack at a frame: the particles damaged at or above `damage_above` (default 0.5) that
//!   were not damaged in the first frame (the notch itself, seeded as failed), and
//!   are connected, within the link length, to the particles nearest the notch tip; of them,
//!   those not behind the notch tip (more than one link length back along the notch direction:
//!   damage at the notch's faces or mouth is not the crack).
//! - Its tip lies on the band's centreline: a failed band is two or more particle rows wide,
//!   and its farthest particle from the notch tip sits in one row or the other from frame to
//!   frame. The front is the crack particles within one link of the farthest one's distance
//!   from the notch tip (and within two links of it, so another branch at the same distance is
//!   not averaged in); the tip is at the farthest distance, in the direction of the front's
//!   centroid.
//! - The crack length is the path length: the tips at least one link apart joined in time
//!   order, plus the straight distance from the last of them to the current tip (never less
//!   than at the frame before).
//! - Initial angle: the direction of the crack's first `angle_length` (default 8 link lengths,
//!   12 particle spacings) at the first frame where the crack is that long, measured from the
//!   notch direction, positive counter-clockwise about z (2D; in 3D the angle between the two
//!   directions). The direction is that of the chord from the notch tip to the crack's outer
//!   half, read as the principal axis through the notch tip of the crack particles between
//!   `angle_length / 2` and `angle_length` from it (the line through the tip that they lie
//!   closest to): every row of the band counts, not only the one its tip is in, and a kink in
//!   the crack's first half (a short run along the notch's end face) does not tilt it. A band
//!   sampled on a particle lattice has a jagged edge, which limits what any fit can read: over
//!   12 spacings, a band 1.5 spacings wide gives its direction within 1° at the angles of the
//!   unit tests and within 2° at any angle and offset to the lattice.
//! - Speed: the least-squares slope of the crack length against time over the frames where it
//!   grows, and the largest speed between two frames; printed beside the Rayleigh speed of the
//!   material, which a crack cannot exceed.

use crate::fragments::components;
use fractum_io::output::{ParticleFrame, read_particle_frame, read_pvd};
use std::path::Path;

/// The default crack length at which the initial angle is taken, in link lengths (12 particle
/// spacings at the default link of 1.5 spacings).
pub const DEFAULT_ANGLE_LINKS: f64 = 8.0;

/// What the crack analysis needs besides the frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrackOptions {
    /// The notch tip.
    pub notch_tip: [f64; 3],
    /// The notch's direction (from its mouth to its tip).
    pub notch_direction: [f64; 3],
    /// Particles damaged at least this much are crack.
    pub damage_above: f64,
    /// Link length joining crack particles (m).
    pub link: f64,
    /// Crack length at which the initial angle is taken (m).
    pub angle_length: f64,
}

/// The tip of the crack at one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TipAt {
    /// Time of the frame.
    pub time: f64,
    /// Tip position (the notch tip while there is no crack).
    pub tip: [f64; 3],
    /// Path length so far.
    pub length: f64,
    /// The direction (unit) of the crack's first `angle_length` from the notch tip: the
    /// principal axis through the notch tip of its particles between half that distance and
    /// that distance; zero while there are none.
    pub start_direction: [f64; 3],
}

/// The crack at one frame: its tip on the band's centreline and the direction of its start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrackAtFrame {
    /// The tip (see the module's notes).
    pub tip: [f64; 3],
    /// As [`TipAt::start_direction`].
    pub start_direction: [f64; 3],
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The crack particles of `frame` (positions), whose particles damaged in the first frame are
/// `seeded`: connected to the notch tip, not seeded, not behind the tip.
fn crack_particles(
    frame: &ParticleFrame,
    seeded: &[bool],
    options: &CrackOptions,
) -> Vec<[f64; 3]> {
    let notch = options.notch_tip;
    // The seed of the crack: the particles nearest the notch tip, damaged at the start or now.
    let members: Vec<usize> = (0..frame.position.len())
        .filter(|&p| frame.damage[p] >= options.damage_above || seeded[p])
        .collect();
    if members.is_empty() {
        return Vec::new();
    }
    let labels = components(&members, &frame.position, options.link);
    let Some(nearest) = (0..members.len()).min_by(|&a, &b| {
        distance(frame.position[members[a]], notch)
            .total_cmp(&distance(frame.position[members[b]], notch))
    }) else {
        return Vec::new();
    };
    let crack = labels[nearest];
    let n = options.notch_direction;
    let norm = distance(n, [0.0; 3]);
    let ahead =
        |x: [f64; 3]| (0..3).map(|k| (x[k] - notch[k]) * n[k]).sum::<f64>() / norm >= -options.link;
    (0..members.len())
        .filter(|&k| labels[k] == crack && !seeded[members[k]] && ahead(frame.position[members[k]]))
        .map(|k| frame.position[members[k]])
        .collect()
}

/// The tip on the band's centreline: at the farthest crack particle's distance from the notch
/// tip, in the direction of the centroid of the band's front.
fn centreline_tip(crack: &[[f64; 3]], options: &CrackOptions) -> Option<[f64; 3]> {
    let notch = options.notch_tip;
    let far = *crack
        .iter()
        .max_by(|a, b| distance(**a, notch).total_cmp(&distance(**b, notch)))?;
    let reach = distance(far, notch);
    let front: Vec<&[f64; 3]> = crack
        .iter()
        .filter(|x| {
            distance(**x, notch) >= reach - options.link && distance(**x, far) <= 2.0 * options.link
        })
        .collect();
    let mut centroid = [0.0; 3];
    for x in &front {
        for k in 0..3 {
            centroid[k] += x[k] / front.len() as f64;
        }
    }
    let along = distance(centroid, notch);
    if along == 0.0 {
        return Some(far);
    }
    Some(std::array::from_fn(|k| {
        notch[k] + (centroid[k] - notch[k]) * reach / along
    }))
}

/// The principal axis through the notch tip of the crack particles between half of
/// `angle_length` and `angle_length` from it: the unit `u` that maximises `Σ (d·u)²` over `d = x − notch tip` (power iteration on
/// `Σ d dᵀ` from the mean of `d`, whose sign it keeps). Zero when there are no such particles.
fn start_direction(crack: &[[f64; 3]], options: &CrackOptions) -> [f64; 3] {
    let notch = options.notch_tip;
    let offsets: Vec<[f64; 3]> = crack
        .iter()
        .filter(|x| {
            let r = distance(**x, notch);
            r >= 0.5 * options.angle_length && r <= options.angle_length
        })
        .map(|x| std::array::from_fn(|k| x[k] - notch[k]))
        .collect();
    let mut scatter = [[0.0; 3]; 3];
    let mut mean = [0.0; 3];
    for d in &offsets {
        for i in 0..3 {
            mean[i] += d[i];
            for j in 0..3 {
                scatter[i][j] += d[i] * d[j];
            }
        }
    }
    let unit = |v: [f64; 3]| {
        let n = distance(v, [0.0; 3]);
        (n > 0.0).then(|| v.map(|c| c / n))
    };
    let Some(mut u) = unit(mean) else {
        return [0.0; 3];
    };
    for _ in 0..200 {
        let next: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| scatter[i][j] * u[j]).sum());
        match unit(next) {
            Some(v) => u = v,
            None => break,
        }
    }
    let sign = if (0..3).map(|k| u[k] * mean[k]).sum::<f64>() < 0.0 {
        -1.0
    } else {
        1.0
    };
    u.map(|c| sign * c)
}

/// The crack in `frame`, whose particles damaged in the first frame are `seeded`: `None`
/// while there is none.
pub fn crack_at_frame(
    frame: &ParticleFrame,
    seeded: &[bool],
    options: &CrackOptions,
) -> Option<CrackAtFrame> {
    let crack = crack_particles(frame, seeded, options);
    Some(CrackAtFrame {
        tip: centreline_tip(&crack, options)?,
        start_direction: start_direction(&crack, options),
    })
}

/// Follows the crack frame by frame: the path of its tips and its length.
#[derive(Clone, Debug)]
pub struct CrackPath {
    /// The last tip that added to the path, and the path length to it.
    accepted: ([f64; 3], f64),
    /// The history so far.
    pub history: Vec<TipAt>,
}

impl CrackPath {
    /// A path that starts at the notch tip.
    pub fn new(options: &CrackOptions) -> Self {
        Self {
            accepted: (options.notch_tip, 0.0),
            history: Vec::new(),
        }
    }

    /// Takes in the crack found at the frame at `time` (`None`: no crack yet).
    pub fn push(&mut self, time: f64, found: Option<CrackAtFrame>, options: &CrackOptions) {
        let (tip, start_direction) = found.map_or((options.notch_tip, [0.0; 3]), |c| {
            (c.tip, c.start_direction)
        });
        let step = distance(self.accepted.0, tip);
        let before = self.history.last().map_or(0.0, |t| t.length);
        let length = (self.accepted.1 + step).max(before);
        if step >= options.link {
            self.accepted = (tip, self.accepted.1 + step);
        }
        self.history.push(TipAt {
            time,
            tip,
            length,
            start_direction,
        });
    }
}

/// 1.5 particle spacings of the run's first frame.
pub fn default_link(dir: &Path, thickness: Option<f64>) -> Result<f64, String> {
    let frames = read_pvd(&dir.join("particles.pvd"))?;
    let first = frames
        .first()
        .ok_or_else(|| format!("{}: the run wrote no particle frames", dir.display()))?;
    let path = dir.join(&first.1);
    let frame = read_particle_frame(&path)?;
    frame
        .require(&["volume"])
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let (planar, thickness) = crate::fragments::frame_thickness(&frame, thickness)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(1.5 * crate::fragments::median_spacing(&frame, planar, thickness))
}

/// The tip at every frame of the run in `dir`.
pub fn crack_history(dir: &Path, options: &CrackOptions) -> Result<Vec<TipAt>, String> {
    let frames = read_pvd(&dir.join("particles.pvd"))?;
    let first = frames
        .first()
        .ok_or_else(|| format!("{}: the run wrote no particle frames", dir.display()))?;
    let read = |file: &str| -> Result<ParticleFrame, String> {
        let path = dir.join(file);
        let frame = read_particle_frame(&path)?;
        frame
            .require(&["id", "damage"])
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(frame)
    };
    let start = read(&first.1)?;
    // Particles are matched by id: a frame lists them in table order, which can change.
    let seeded_ids: std::collections::HashSet<u32> = (0..start.id.len())
        .filter(|&p| start.damage[p] >= options.damage_above)
        .map(|p| start.id[p])
        .collect();
    let mut path = CrackPath::new(options);
    for (time, file) in &frames {
        let frame = read(file)?;
        let seeded: Vec<bool> = frame.id.iter().map(|id| seeded_ids.contains(id)).collect();
        path.push(*time, crack_at_frame(&frame, &seeded, options), options);
    }
    Ok(path.history)
}

/// The angle (degrees) from the notch direction to the crack's direction over its first
/// `angle_length` ([`TipAt::start_direction`]), at the first frame where the crack is that long,
/// or `None` if it never got so long. In 2D (z = 0 everywhere) signed, counter-clockwise
/// positive.
pub fn initial_angle(history: &[TipAt], options: &CrackOptions) -> Option<f64> {
    let at = history.iter().find(|t| t.length >= options.angle_length)?;
    angle_between(options.notch_direction, at.start_direction)
}

/// The angle (degrees) from `n` to `d`: signed counter-clockwise in the plane z = 0, else
/// unsigned; `None` when `d` is zero.
fn angle_between(n: [f64; 3], d: [f64; 3]) -> Option<f64> {
    if d == [0.0; 3] {
        return None;
    }
    if n[2] == 0.0 && d[2].abs() < 1e-12 {
        let cross = n[0] * d[1] - n[1] * d[0];
        let dot = n[0] * d[0] + n[1] * d[1];
        Some(cross.atan2(dot).to_degrees())
    } else {
        let dot: f64 = (0..3).map(|k| n[k] * d[k]).sum();
        let norms = distance(n, [0.0; 3]) * distance(d, [0.0; 3]);
        Some((dot / norms).clamp(-1.0, 1.0).acos().to_degrees())
    }
}

/// (mean speed: the least-squares slope of length against time over the frames from the first
/// growth to the last, largest speed between two frames).
pub fn crack_speed(history: &[TipAt]) -> Option<(f64, f64)> {
    let first = history
        .iter()
        .position(|t| t.length > 0.0)?
        .saturating_sub(1);
    let last = history.iter().rposition(|t| {
        t.length > history[first].length && t.length < history.last().map_or(0.0, |l| l.length)
    });
    let last = last.map_or(history.len() - 1, |l| (l + 1).min(history.len() - 1));
    let growing = &history[first..=last];
    let mean = least_squares_speed(growing)?;
    let largest = growing
        .windows(2)
        .map(|w| (w[1].length - w[0].length) / (w[1].time - w[0].time))
        .fold(0.0, f64::max);
    Some((mean, largest))
}

/// The least-squares slope of length against time over the frames from `from` to `to` (s),
/// ends included: the speed the literature reports for a window of the growth (Kalthoff and
/// Winkler's crack over 40–50 µs, dfg-partitioning-mpm.md §3.2). `None` with fewer than two
/// frames in the window.
pub fn crack_speed_between(history: &[TipAt], from: f64, to: f64) -> Option<f64> {
    let inside: Vec<TipAt> = history
        .iter()
        .filter(|t| t.time >= from && t.time <= to)
        .copied()
        .collect();
    least_squares_speed(&inside)
}

/// The least-squares slope of length against time; `None` below two frames.
fn least_squares_speed(frames: &[TipAt]) -> Option<f64> {
    if frames.len() < 2 {
        return None;
    }
    let n = frames.len() as f64;
    let (mt, ml) = frames
        .iter()
        .fold((0.0, 0.0), |(a, b), t| (a + t.time / n, b + t.length / n));
    let (stl, stt) = frames.iter().fold((0.0, 0.0), |(a, b), t| {
        (
            a + (t.time - mt) * (t.length - ml),
            b + (t.time - mt).powi(2),
        )
    });
    Some(stl / stt)
}

/// The Rayleigh wave speed of an isotropic elastic material (E, ν, ρ): the root `ξ = c_R/c_s`
/// in (0, 1) of `(2 − ξ²)² = 4 √(1 − κ²ξ²) √(1 − ξ²)`, `κ = c_s/c_d` (bisection to round-off).
pub fn rayleigh_speed(youngs_modulus: f64, poisson_ratio: f64, density: f64) -> f64 {
    let mu = youngs_modulus / (2.0 * (1.0 + poisson_ratio));
    let lambda =
        youngs_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
    let (cs, cd) = (
        (mu / density).sqrt(),
        ((lambda + 2.0 * mu) / density).sqrt(),
    );
    let kappa2 = (cs / cd).powi(2);
    let residual = |x: f64| {
        let x2 = x * x;
        (2.0 - x2).powi(2) - 4.0 * (1.0 - kappa2 * x2).sqrt() * (1.0 - x2).sqrt()
    };
    // The residual is negative at ξ = 0.5 for every ν in [0, 0.5) and positive at ξ → 1 (where
    // it is 1), with the one root between.
    let (mut lo, mut hi) = (0.5, 0.999_999);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if residual(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi) * cs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rayleigh_speed_matches_the_classical_values() {
        // c_R / c_s in closed form where the cubic in ξ² factors: √(3 − √5) at ν = 0 (κ² = ½)
        // and √(2 − 2/√3) at ν = 0.25 (κ² = ⅓).
        let (e, rho): (f64, f64) = (200.0e9, 7800.0);
        for (nu, ratio) in [
            (0.25, (2.0 - 2.0 / 3f64.sqrt()).sqrt()),
            (0.0, (3.0 - 5f64.sqrt()).sqrt()),
        ] {
            let cs = (e / (2.0 * (1.0 + nu)) / rho).sqrt();
            let found = rayleigh_speed(e, nu, rho) / cs;
            assert!(
                (found - ratio).abs() < 1e-12,
                "ν {nu}: {found} against {ratio}"
            );
        }
    }

    /// A 2D lattice of spacing 1, 60 × 40, with a notch of two particle rows along +x ending
    /// at `notch_tip` (seeded, damage 1) and a failed band about 1.5 spacings wide running
    /// from the notch tip at `angle` degrees for `length`: the particles within 0.75 of its
    /// centreline.
    fn frame_with_band(notch_tip: [f64; 2], angle: f64, length: f64) -> (ParticleFrame, Vec<bool>) {
        let (sin, cos) = angle.to_radians().sin_cos();
        let mut f = ParticleFrame::default();
        let mut seeded = Vec::new();
        for i in 0..60 {
            for j in 0..40 {
                let (x, y) = (i as f64, j as f64);
                let (dx, dy) = (x - notch_tip[0], y - notch_tip[1]);
                let notch = dx < 0.0 && dy.abs() < 0.75;
                let (along, across) = (dx * cos + dy * sin, -dx * sin + dy * cos);
                let band = along >= 0.0 && along <= length && across.abs() < 0.75;
                f.id.push((i * 40 + j) as u32);
                f.position.push([x, y, 0.0]);
                f.damage.push(if notch || band { 1.0 } else { 0.0 });
                seeded.push(notch);
            }
        }
        (f, seeded)
    }

    fn options(notch_tip: [f64; 2]) -> CrackOptions {
        CrackOptions {
            notch_tip: [notch_tip[0], notch_tip[1], 0.0],
            notch_direction: [1.0, 0.0, 0.0],
            damage_above: 1.0,
            link: 1.5,
            angle_length: 12.0,
        }
    }

    /// The band grown by 0.7 spacings a frame, 0.5 s apart, to `end`.
    fn grown_band(notch_tip: [f64; 2], angle: f64, end: f64) -> Vec<TipAt> {
        let options = options(notch_tip);
        let mut path = CrackPath::new(&options);
        let frames = (end / 0.7).ceil() as usize;
        for k in 0..=frames {
            let length = (k as f64 * 0.7).min(end);
            let (frame, seeded) = frame_with_band(notch_tip, angle, length);
            path.push(
                k as f64 * 0.5,
                crack_at_frame(&frame, &seeded, &options),
                &options,
            );
        }
        path.history
    }

    /// A straight band two particle rows wide (the notch tip between the rows) and bands
    /// inclined across the lattice: their angles within 1° and lengths within one spacing.
    /// (The farthest particle alone, as the tip, reads the first two at −4.8° and 26.6° over
    /// 6 spacings.)
    #[test]
    fn the_tip_follows_the_centreline_of_a_band_two_rows_wide() {
        for (tip, angle, end) in [
            ([10.0, 20.5], 0.0, 40.0),
            ([10.0, 20.0], 30.0, 30.0),
            ([10.0, 30.0], -60.0, 25.0),
            ([10.0, 20.0], 45.0, 24.0),
            ([10.0, 20.0], 15.0, 40.0),
        ] {
            let history = grown_band(tip, angle, end);
            let measured = initial_angle(&history, &options(tip)).unwrap();
            assert!(
                (measured - angle).abs() < 1.0,
                "{angle}°: measured {measured}°"
            );
            let length = history.last().unwrap().length;
            assert!(
                (length - end).abs() < 1.0,
                "{angle}°: length {length} against {end}"
            );
            // The length never runs back, and the band grows at 1.4 spacings a second.
            assert!(history.windows(2).all(|w| w[1].length >= w[0].length));
            let (mean, _) = crack_speed(&history).unwrap();
            assert!((mean / 1.4 - 1.0).abs() < 0.05, "{angle}°: speed {mean}");
        }
    }

    /// A crack that runs at 1 m/s, then at 3 m/s from t = 10 s: its speed over a window of the
    /// second run is 3, over the whole growth between the two, and a window holding one frame
    /// gives none.
    #[test]
    fn the_speed_in_a_window_is_the_slope_there() {
        let history: Vec<TipAt> = (0..=20)
            .map(|i| {
                let time = f64::from(i);
                let length = if time <= 10.0 {
                    time
                } else {
                    10.0 + 3.0 * (time - 10.0)
                };
                TipAt {
                    time,
                    tip: [length, 0.0, 0.0],
                    length,
                    start_direction: [1.0, 0.0, 0.0],
                }
            })
            .collect();
        let late = crack_speed_between(&history, 12.0, 18.0).unwrap();
        assert!((late - 3.0).abs() < 1e-12, "{late}");
        let early = crack_speed_between(&history, 0.0, 10.0).unwrap();
        assert!((early - 1.0).abs() < 1e-12, "{early}");
        let (whole, largest) = crack_speed(&history).unwrap();
        assert!(whole > 1.0 && whole < 3.0 && largest == 3.0);
        assert_eq!(crack_speed_between(&history, 4.5, 5.5), None);
    }
}
