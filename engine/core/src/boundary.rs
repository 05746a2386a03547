//! Essential boundary conditions on node regions, and the reaction forces they exert.
//!
//! A region holds some velocity components of its nodes: both (fixed), one (roller), or
//! prescribed functions of time. Integrators call [`BoundaryConditions::enforce`] wherever they
//! produce nodal velocities. When they pass a [`Reactions`] accumulator, the force needed to hold
//! each constraint, `m_I (v_held − v_free) / Δt`, is summed per region: that is the force the
//! boundary exerts on the body.

use crate::components::{MAX_FIELDS, NodeMass, NodeVelocity};
use crate::dim::{Dim, VectorOps};
use bevy_ecs::prelude::Resource;

/// A function of time, linear between points and constant beyond the first and last.
#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseLinear {
    points: Vec<(f64, f64)>,
}

impl PiecewiseLinear {
    /// Builds the function; times must be finite and strictly increasing, with at least one point.
    pub fn new(points: Vec<(f64, f64)>) -> Result<Self, String> {
        if points.is_empty() {
            return Err("at least one (time, value) point".into());
        }
        if points.iter().any(|(t, v)| !t.is_finite() || !v.is_finite()) {
            return Err("finite times and values".into());
        }
        if points.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err("strictly increasing times".into());
        }
        Ok(Self { points })
    }

    /// A constant function.
    pub fn constant(value: f64) -> Self {
        Self {
            points: vec![(0.0, value)],
        }
    }

    /// `∫₀ᵗ f(τ) dτ` (exact: trapezoids between the points, constant beyond them).
    pub fn integral(&self, t: f64) -> f64 {
        if t <= 0.0 {
            return 0.0;
        }
        // Break points inside (0, t), then integrate the linear pieces exactly.
        let mut knots = vec![0.0];
        knots.extend(
            self.points
                .iter()
                .map(|p| p.0)
                .filter(|&tk| tk > 0.0 && tk < t),
        );
        knots.push(t);
        knots
            .windows(2)
            .map(|w| 0.5 * (self.eval(w[0]) + self.eval(w[1])) * (w[1] - w[0]))
            .sum()
    }

    /// Value at time `t`.
    pub fn eval(&self, t: f64) -> f64 {
        let first = self.points[0];
        let last = self.points[self.points.len() - 1];
        if t <= first.0 {
            return first.1;
        }
        if t >= last.0 {
            return last.1;
        }
        let k = self.points.partition_point(|(tk, _)| *tk <= t);
        let (t0, v0) = self.points[k - 1];
        let (t1, v1) = self.points[k];
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    }
}

/// The most components a velocity has (three; a 2D region leaves the last one `None`).
pub const MAX_COMPONENTS: usize = 3;

/// One named region of nodes and the velocity components it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundaryRegion {
    /// Name from the scene, used for the `reaction_<name>_x/y/z` columns.
    pub name: String,
    /// Linear indices of the nodes in the region.
    pub nodes: Vec<u32>,
    /// Prescribed velocity per component (x, y, z); `None` leaves that component free. In 2D
    /// the z entry is always `None`.
    pub velocity: [Option<PiecewiseLinear>; MAX_COMPONENTS],
}

impl BoundaryRegion {
    /// A region holding every component of its nodes at rest.
    pub fn fixed(name: &str, nodes: Vec<u32>) -> Self {
        Self {
            name: name.to_string(),
            nodes,
            velocity: std::array::from_fn(|_| Some(PiecewiseLinear::constant(0.0))),
        }
    }
}

/// All boundary regions of the scene, applied in scene order.
#[derive(Resource, Clone, Debug, Default)]
pub struct BoundaryConditions {
    /// The regions.
    pub regions: Vec<BoundaryRegion>,
    /// The nodes whose reactions this process measures: a rank's owned nodes in a distributed
    /// run ([`crate::decomposition::Ownership::nodes`]), so that the ranks' reactions add up to
    /// the run's; every node when `None`. Velocities are held at every node either way.
    pub measured_nodes: Option<Vec<bool>>,
}

/// Reaction force of each region over the last step that measured it, in region order.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct Reactions<D: Dim>(pub Vec<D::Vector>);

impl<D: Dim> Default for Reactions<D> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl BoundaryConditions {
    /// For each of `node_count` nodes, which velocity components (x, y, z) some region holds.
    pub fn held_mask(&self, node_count: usize) -> Vec<[bool; MAX_COMPONENTS]> {
        let mut mask = Vec::new();
        self.fill_held_mask(node_count, &mut mask);
        mask
    }

    /// [`Self::held_mask`] into a reused buffer.
    pub fn fill_held_mask(&self, node_count: usize, mask: &mut Vec<[bool; MAX_COMPONENTS]>) {
        mask.clear();
        mask.resize(node_count, [false; MAX_COMPONENTS]);
        for region in &self.regions {
            for &node in &region.nodes {
                for (c, held) in region.velocity.iter().enumerate() {
                    mask[node as usize][c] |= held.is_some();
                }
            }
        }
    }

    /// Sets the held velocity components of every field with mass at time `time`.
    ///
    /// With `measure = Some((dt, reactions))`, also records the reaction of each region. A node
    /// in several regions is held by each in turn, so the last listed region wins and a component
    /// already held at the same value adds nothing to later regions.
    pub fn enforce<D: Dim>(
        &self,
        time: f64,
        masses: &[NodeMass],
        velocities: &mut [NodeVelocity<D>],
        mut measure: Option<(f64, &mut Reactions<D>)>,
    ) {
        if let Some((_, reactions)) = measure.as_mut() {
            reactions.0.clear();
            reactions.0.resize(self.regions.len(), D::Vector::ZERO);
        }
        for (r, region) in self.regions.iter().enumerate() {
            let held: [Option<f64>; MAX_COMPONENTS] =
                std::array::from_fn(|c| region.velocity[c].as_ref().map(|f| f.eval(time)));
            let held = &held[..D::N];
            let mut reaction = D::Vector::ZERO;
            for &node in &region.nodes {
                let node = node as usize;
                let measured = self
                    .measured_nodes
                    .as_ref()
                    .is_none_or(|m| m.get(node).copied().unwrap_or(false));
                for field in 0..MAX_FIELDS {
                    let mass = masses[node].0[field];
                    let v = &mut velocities[node].0[field];
                    for (c, target) in held.iter().enumerate() {
                        if let Some(target) = *target {
                            if measured {
                                reaction[c] += mass * (target - v[c]);
                            }
                            v[c] = target;
                        }
                    }
                }
            }
            if let Some((dt, reactions)) = measure.as_mut() {
                reactions.0[r] = reaction / *dt;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::slots;
    use crate::dim::{Three, Two};
    use glam::{DVec2, DVec3};

    #[test]
    fn piecewise_linear_interpolates_and_clamps() {
        let f = PiecewiseLinear::new(vec![(0.0, 0.0), (1.0, 2.0), (3.0, 2.0)]).unwrap();
        assert_eq!(f.eval(-1.0), 0.0);
        assert_eq!(f.eval(0.5), 1.0);
        assert_eq!(f.eval(2.0), 2.0);
        assert_eq!(f.eval(10.0), 2.0);
        assert!(PiecewiseLinear::new(vec![(1.0, 0.0), (1.0, 1.0)]).is_err());
        assert!(PiecewiseLinear::new(vec![]).is_err());
        // Ramp to 2 over 1 s then hold: 1 after the ramp, +2 per second after that.
        assert_eq!(f.integral(1.0), 1.0);
        assert_eq!(f.integral(2.5), 4.0);
        assert_eq!(f.integral(5.0), 9.0);
        assert_eq!(f.integral(-1.0), 0.0);
    }

    #[test]
    fn enforcing_a_fixed_region_measures_the_holding_force() {
        let bcs = BoundaryConditions {
            regions: vec![BoundaryRegion {
                name: "left".into(),
                nodes: vec![0],
                velocity: [Some(PiecewiseLinear::constant(0.0)), None, None],
            }],
            measured_nodes: None,
        };
        let masses = [NodeMass(slots(&[2.0])), NodeMass(slots(&[1.0]))];
        let mut velocities = [
            NodeVelocity::<Two>(slots(&[DVec2::new(-0.5, 0.3)])),
            NodeVelocity(slots(&[DVec2::new(-0.5, 0.3)])),
        ];
        let mut reactions = Reactions::default();
        bcs.enforce(0.0, &masses, &mut velocities, Some((0.1, &mut reactions)));
        assert_eq!(velocities[0].0[0], DVec2::new(0.0, 0.3));
        assert_eq!(velocities[1].0[0], DVec2::new(-0.5, 0.3));
        // Holding 2 kg moving at -0.5 m/s to rest over 0.1 s takes +10 N along x.
        assert_eq!(reactions.0, vec![DVec2::new(10.0, 0.0)]);
    }

    #[test]
    fn a_3d_region_holds_the_z_component_too() {
        let bcs = BoundaryConditions {
            regions: vec![BoundaryRegion {
                name: "lid".into(),
                nodes: vec![1],
                velocity: [None, None, Some(PiecewiseLinear::constant(-1.0))],
            }],
            measured_nodes: None,
        };
        let masses = [NodeMass(slots(&[1.0])), NodeMass(slots(&[4.0, 1.0]))];
        let v = DVec3::new(0.1, 0.2, 0.3);
        let mut velocities = [
            NodeVelocity::<Three>(slots(&[v, v])),
            NodeVelocity(slots(&[v, v])),
        ];
        let mut reactions = Reactions::default();
        bcs.enforce(0.0, &masses, &mut velocities, Some((0.5, &mut reactions)));
        assert_eq!(velocities[1].0[..2], [DVec3::new(0.1, 0.2, -1.0); 2]);
        assert_eq!(velocities[0].0[0], v);
        // (4 + 1) kg from +0.3 to −1 m/s over 0.5 s.
        assert!((reactions.0[0] - DVec3::new(0.0, 0.0, -13.0)).length() < 1e-12);
        assert_eq!(bcs.held_mask(2)[1], [false, false, true]);
    }
}
