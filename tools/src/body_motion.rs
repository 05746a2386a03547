//! The rigid motion of one body in a run's particle frames: its centre-of-mass velocity and its
//! spin about the centre, frame by frame, and their least-squares rates. What the verification
//! catalogue measures of a disk rolling or slipping down an incline.

use fractum_io::output::ParticleFrame;
use std::path::Path;

/// A body's rigid motion in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMotion {
    /// The frame's time (s).
    pub time: f64,
    /// Velocity of the centre of mass (m/s).
    pub velocity: [f64; 3],
    /// Angular velocity about the z axis through the centre of mass, counter-clockwise
    /// positive: the body's angular momentum about the centre over its polar moment of inertia
    /// about that axis (rad/s).
    pub spin: f64,
}

/// The rigid motion of body `body` in `frame`, or `None` when the frame holds none of its
/// particles.
pub fn rigid_motion(frame: &ParticleFrame, body: u16, time: f64) -> Option<RigidMotion> {
    let members: Vec<usize> = (0..frame.body.len())
        .filter(|&p| frame.body[p] == body)
        .collect();
    let mass: f64 = members.iter().map(|&p| frame.mass[p]).sum();
    if members.is_empty() || mass.is_nan() || mass <= 0.0 {
        return None;
    }
    let mean = |of: &[[f64; 3]]| -> [f64; 3] {
        std::array::from_fn(|a| {
            members
                .iter()
                .map(|&p| frame.mass[p] * of[p][a])
                .sum::<f64>()
                / mass
        })
    };
    let (centre, velocity) = (mean(&frame.position), mean(&frame.velocity));
    let (mut momentum, mut inertia) = (0.0, 0.0);
    for &p in &members {
        let r = [
            frame.position[p][0] - centre[0],
            frame.position[p][1] - centre[1],
        ];
        let v = [
            frame.velocity[p][0] - velocity[0],
            frame.velocity[p][1] - velocity[1],
        ];
        momentum += frame.mass[p] * (r[0] * v[1] - r[1] * v[0]);
        inertia += frame.mass[p] * (r[0] * r[0] + r[1] * r[1]);
    }
    let spin = if inertia > 0.0 {
        momentum / inertia
    } else {
        0.0
    };
    Some(RigidMotion {
        time,
        velocity,
        spin,
    })
}

/// The rigid motion of body `body` in every particle frame of the run in `dir` from time
/// `from` on.
pub fn motion_history(dir: &Path, body: u16, from: f64) -> Result<Vec<RigidMotion>, String> {
    let frames = fractum_io::output::read_pvd(&dir.join("particles.pvd"))?;
    let mut history = Vec::new();
    for (time, file) in frames.into_iter().filter(|(t, _)| *t >= from) {
        let path = dir.join(&file);
        let frame = fractum_io::output::read_particle_frame(&path)?;
        let motion = rigid_motion(&frame, body, time)
            .ok_or_else(|| format!("{}: no particle of body {body}", path.display()))?;
        history.push(motion);
    }
    Ok(history)
}

/// The least-squares slope of `y` against `x`, or `None` with fewer than two distinct `x`.
pub fn least_squares_slope(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The least-squares acceleration of the centre of mass along the unit vector of `direction`,
/// and the least-squares angular acceleration about z (counter-clockwise positive), over
/// `history`.
pub fn rates(history: &[RigidMotion], direction: [f64; 3]) -> Option<(f64, f64)> {
    let length = direction.iter().map(|d| d * d).sum::<f64>().sqrt();
    if length.is_nan() || length <= 0.0 {
        return None;
    }
    let along: Vec<(f64, f64)> = history
        .iter()
        .map(|m| {
            let v = (0..3).map(|a| m.velocity[a] * direction[a]).sum::<f64>() / length;
            (m.time, v)
        })
        .collect();
    let spin: Vec<(f64, f64)> = history.iter().map(|m| (m.time, m.spin)).collect();
    Some((least_squares_slope(&along)?, least_squares_slope(&spin)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ring of four particles of body 1 turning at ω about (1, 2) while the ring moves at
    /// (3, 0), beside a particle of body 0 that the measure leaves out.
    fn ring(omega: f64, time: f64) -> ParticleFrame {
        let centre = [1.0 + 3.0 * time, 2.0];
        let offsets = [[0.5, 0.0], [0.0, 0.5], [-0.5, 0.0], [0.0, -0.5]];
        let mut frame = ParticleFrame::default();
        for o in offsets {
            frame.body.push(1);
            frame.mass.push(2.0);
            frame
                .position
                .push([centre[0] + o[0], centre[1] + o[1], 0.0]);
            frame.velocity.push([3.0 - omega * o[1], omega * o[0], 0.0]);
        }
        frame.body.push(0);
        frame.mass.push(100.0);
        frame.position.push([9.0, 9.0, 0.0]);
        frame.velocity.push([-5.0, 7.0, 0.0]);
        frame
    }

    #[test]
    fn a_turning_ring_has_its_spin_and_velocity() {
        let motion = rigid_motion(&ring(4.0, 0.0), 1, 0.0).unwrap();
        assert!((motion.spin - 4.0).abs() < 1e-12, "{}", motion.spin);
        assert!((motion.velocity[0] - 3.0).abs() < 1e-12);
        assert!(motion.velocity[1].abs() < 1e-12);
        assert!(rigid_motion(&ring(4.0, 0.0), 7, 0.0).is_none());
    }

    #[test]
    fn rates_are_the_least_squares_slopes() {
        // Spin up at 2 rad/s² while the centre speeds up at 0.5 m/s² along (1, 1)/√2.
        let history: Vec<RigidMotion> = (0..5)
            .map(|k| {
                let t = 0.1 * k as f64;
                RigidMotion {
                    time: t,
                    velocity: [0.5 * t, 0.5 * t, 0.0],
                    spin: 1.0 + 2.0 * t,
                }
            })
            .collect();
        let (a, alpha) = rates(&history, [1.0, 1.0, 0.0]).unwrap();
        assert!((a - 0.5 * 2f64.sqrt()).abs() < 1e-12, "{a}");
        assert!((alpha - 2.0).abs() < 1e-12, "{alpha}");
        assert!(rates(&history[..1], [1.0, 0.0, 0.0]).is_none());
        assert!(rates(&history, [0.0; 3]).is_none());
    }
}
