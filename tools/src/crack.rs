//! `fractum crack`: the path of a crack from a notch, its tip against time, its initial angle
//! and its speed, from the damage field of a run's frames (for the DFG paper's §3.2
//! Kalthoff–Winkler test: crack angle and speed).
//!
//! - The crack at a frame: the particles damaged at or above `damage_above` (default 0.5) that
//!   were not damaged in the first frame (the notch itself, seeded as failed), and
//!   are connected, within the link length, to the particles nearest the notch tip.
//! - Its tip: the crack particle farthest from the notch tip, among those not behind it (more
//!   than one link length back along the notch direction: damage at the notch's faces or mouth
//!   is not the crack). The crack length is the path length: the tip positions at least one
//!   link apart joined in time order (a tip that only steps across the crack band, from one
//!   particle row to the next, adds nothing).
//! - Initial angle: the direction from the notch tip to the tip once the crack is longer than
//!   `angle_length` (default 4 link lengths), measured from the notch direction, positive
//!   counter-clockwise about z (2D; in 3D the angle between the two directions).
//! - Speed: the least-squares slope of the crack length against time over the frames where it
//!   grows, and the largest speed between two frames; printed beside the Rayleigh speed of the
//!   material, which a crack cannot exceed.

use crate::fragments::components;
use fractum_engine::output::{ParticleFrame, read_particle_frame, read_pvd};
use std::path::Path;

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
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The tip of the crack in `frame`, whose particles damaged in the first frame are `seeded`.
pub fn crack_tip(
    frame: &ParticleFrame,
    seeded: &[bool],
    options: &CrackOptions,
) -> Option<[f64; 3]> {
    let notch = options.notch_tip;
    // The seed of the crack: the particles nearest the notch tip, damaged at the start or now.
    let members: Vec<usize> = (0..frame.position.len())
        .filter(|&p| frame.damage[p] >= options.damage_above || seeded[p])
        .collect();
    if members.is_empty() {
        return None;
    }
    let labels = components(&members, &frame.position, options.link);
    let nearest = (0..members.len()).min_by(|&a, &b| {
        distance(frame.position[members[a]], notch)
            .total_cmp(&distance(frame.position[members[b]], notch))
    })?;
    let crack = labels[nearest];
    let n = options.notch_direction;
    let norm = distance(n, [0.0; 3]);
    let ahead =
        |x: [f64; 3]| (0..3).map(|k| (x[k] - notch[k]) * n[k]).sum::<f64>() / norm >= -options.link;
    (0..members.len())
        .filter(|&k| labels[k] == crack && !seeded[members[k]] && ahead(frame.position[members[k]]))
        .map(|k| frame.position[members[k]])
        .max_by(|a, b| distance(*a, notch).total_cmp(&distance(*b, notch)))
}

/// The tip at every frame of the run in `dir`.
pub fn crack_history(dir: &Path, options: &CrackOptions) -> Result<Vec<TipAt>, String> {
    let frames = read_pvd(&dir.join("particles.pvd"))?;
    let first = frames
        .first()
        .ok_or_else(|| format!("{}: the run wrote no particle frames", dir.display()))?;
    let start = read_particle_frame(&dir.join(&first.1))?;
    // Particles are matched by id: a frame lists them in table order, which can change.
    let seeded_ids: std::collections::HashSet<u32> = (0..start.id.len())
        .filter(|&p| start.damage[p] >= options.damage_above)
        .map(|p| start.id[p])
        .collect();
    let mut history: Vec<TipAt> = Vec::new();
    // The last tip that added to the path, and the path length to it.
    let mut accepted = (options.notch_tip, 0.0);
    for (time, file) in &frames {
        let frame = read_particle_frame(&dir.join(file))?;
        let seeded: Vec<bool> = frame.id.iter().map(|id| seeded_ids.contains(id)).collect();
        let tip = crack_tip(&frame, &seeded, options).unwrap_or(options.notch_tip);
        let step = distance(accepted.0, tip);
        if step >= options.link {
            accepted = (tip, accepted.1 + step);
        }
        history.push(TipAt {
            time: *time,
            tip,
            length: accepted.1,
        });
    }
    Ok(history)
}

/// The angle (degrees) from the notch direction to the direction from the notch tip to the
/// first tip farther than `angle_length` along the path, or `None` if the crack never got so
/// long. In 2D (z = 0 everywhere) signed, counter-clockwise positive.
pub fn initial_angle(history: &[TipAt], options: &CrackOptions) -> Option<f64> {
    let at = history.iter().find(|t| t.length >= options.angle_length)?;
    let (n, c) = (options.notch_direction, options.notch_tip);
    let d = [at.tip[0] - c[0], at.tip[1] - c[1], at.tip[2] - c[2]];
    let planar = n[2] == 0.0 && d[2] == 0.0;
    if planar {
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
    if growing.len() < 2 {
        return None;
    }
    let n = growing.len() as f64;
    let (mt, ml) = growing
        .iter()
        .fold((0.0, 0.0), |(a, b), t| (a + t.time / n, b + t.length / n));
    let (stl, stt) = growing.iter().fold((0.0, 0.0), |(a, b), t| {
        (
            a + (t.time - mt) * (t.length - ml),
            b + (t.time - mt).powi(2),
        )
    });
    let largest = growing
        .windows(2)
        .map(|w| (w[1].length - w[0].length) / (w[1].time - w[0].time))
        .fold(0.0, f64::max);
    Some((stl / stt, largest))
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

    /// A 2D lattice of spacing 1 with the notch (seeded) at (0..3, 10) and `k` crack particles
    /// from its tip (3, 10) down-right at 45°: (3, 10), (4, 9), …
    fn frame_with_crack(k: usize) -> (ParticleFrame, Vec<bool>) {
        let mut f = ParticleFrame::default();
        let mut seeded = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                f.id.push((i * 20 + j) as u32);
                f.position.push([i as f64, j as f64, 0.0]);
                let notch = i < 3 && j == 10;
                let cracked = i >= 3 && i < 3 + k && i + j == 13;
                f.damage.push(if notch || cracked { 1.0 } else { 0.0 });
                seeded.push(notch);
            }
        }
        (f, seeded)
    }

    #[test]
    fn the_tip_angle_and_speed_of_a_diagonal_crack() {
        let options = CrackOptions {
            notch_tip: [3.0, 10.0, 0.0],
            notch_direction: [1.0, 0.0, 0.0],
            damage_above: 1.0,
            link: 1.5,
            angle_length: 3.0,
        };
        let mut history = Vec::new();
        for k in 0..6 {
            let (frame, seeded) = frame_with_crack(k);
            let tip = crack_tip(&frame, &seeded, &options).unwrap_or(options.notch_tip);
            let length = history
                .last()
                .map_or(0.0, |p: &TipAt| p.length + distance(p.tip, tip));
            history.push(TipAt {
                time: k as f64 * 0.5,
                tip,
                length,
            });
        }
        // The tip after 5 steps of the crack: (7, 6).
        assert_eq!(history[5].tip, [7.0, 6.0, 0.0]);
        // Down-right at 45°, i.e. −45° from the notch's +x.
        let angle = initial_angle(&history, &options).unwrap();
        assert!((angle + 45.0).abs() < 1e-9, "{angle}");
        // One diagonal √2 per 0.5 s, steadily.
        let (mean, largest) = crack_speed(&history).unwrap();
        assert!((largest - 2.0 * 2f64.sqrt()).abs() < 1e-12, "{largest}");
        assert!((mean - 2.0 * 2f64.sqrt()).abs() < 1e-12, "{mean}");
    }
}
