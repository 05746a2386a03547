//! The penalty contact law between particles of different contact groups: the pure kernels of
//! `contact/penalty`, with its parameters.
//!
//! - Stage: contact (used by the `contact/penalty` system; not a registration itself).
//! - Penalty contact in MPM on a smoothed surface. Each particle `q` spreads its material over
//!   the tensor-product quadratic B-spline `φ_q(r) = Π_i B((r)_i / ℓ_q)` of its spacing
//!   `ℓ_q = 2 r_q` (`r_q` the half-width of its domain): summed over a lattice of spacing `ℓ`,
//!   these kernels are exactly 1 inside the lattice and fall smoothly to 0 over 1.5 ℓ outside it,
//!   the same at every point along a face ([`kernel`]). Particle `p` measures how deep it is in
//!   the other groups' material by `S_p = Σ_q φ_q(x_p − x_q)` over the particles `q` of other
//!   groups. The energy is `U = Σ_p ½ K_p (S_p − s₀)₊²` with `s₀ = B(1) = 1/8` ([`TOUCH_LEVEL`]),
//!   the level of `S` at a particle whose domain just touches a flat face: a potential of the
//!   positions alone, zero until two bodies' particle domains meet.
//! - Why a smoothed surface: a potential on each pair's own overlap (soft spheres) also
//!   conserves energy, but the lattices of two bodies then interlock like gear teeth: a disk on
//!   a lattice substrate climbs from one valley between particles to the next, and a μ = 0.1
//!   disk on a 30° incline slides at a third to two thirds of `g (sin θ − μ cos θ)` while it
//!   spins twice as fast as friction allows. Summed over a face, `S` has no valleys.
//! - The force on `p` is `−∂U/∂x_p`, a sum over its partners `q` of
//!   `f_pq = −K_p (S_p − s₀)₊ ∇φ_q(x_p − x_q) + K_q (S_q − s₀)₊ ∇φ_p(x_q − x_p)`
//!   ([`pair_force`]), which is exactly `−f_qp` (to the bit): momentum is conserved to round-off.
//! - Stiffness ([`penalty_modulus`]): `K_p = 2 κ E_p ℓ_p^{d−1} t ℓ_p`, with `E_p` the Young's
//!   modulus of `p`'s material, `t` the scene thickness in 2D (1 in 3D) and `κ` the scene's
//!   `stiffness`. Near first touch `S` grows at `1/(2ℓ)` per unit of overlap, so two facing
//!   particles of one material press on each other with `κ E ℓ^{d−2} t δ`: with `κ = 1` a layer
//!   of contact is as stiff as one particle spacing of the material.
//! - Friction ([`pair_force`]): Coulomb, with the magnitude of `f_pq` as the pair's normal force
//!   and its direction as the normal: `‖f_t‖ ≤ μ ‖f_pq‖` against the pair's tangential relative
//!   velocity `v_t`, and never more than the force that stops `v_t` of the two particles alone
//!   over the integrator's force window `w` (`m_red ‖v_t‖ / w`): below the Coulomb limit the
//!   pair sticks, so a body can roll, and friction can only remove energy.
//! - Where friction acts ([`contact_point`], with the affine transfer only:
//!   [`PairLaw::at_contact_point`]). The pair's contact point is the point between
//!   the two particles where their domains meet, `c = x_p + (x_q − x_p) ℓ_p / (ℓ_p + ℓ_q)`.
//!   The slip is the relative velocity of the two particles' material at `c`,
//!   `v_p + L_p (c − x_p) − v_q − L_q (c − x_q)` with `L` the grid's velocity gradient at each
//!   particle, and the friction force acts at `c`: besides the force at `x_p` the particle
//!   carries its moment about `x_p`, `f_t ⊗ (c − x_p)` ([`PairContact::lever`]), which the
//!   system hands to the nodes as `(f_t ⊗ a) ∇N_Ip`. A rolling disk's rim then turns about its
//!   radius, not about the radius of its outermost particles (a quarter of a cell less with two
//!   particles per cell), and the pair's friction has no moment of its own: both particles
//!   take it at the same point. The normal force stays at the particles' centres, where the
//!   potential's gradient puts it (elsewhere it would do work the energy does not count).

use super::frictional_law::PairFriction;
use fractum_engine::prelude::*;
use serde::Deserialize;

/// Parameters of `contact/penalty`.
#[derive(Resource, Deserialize, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PenaltyParams {
    /// Stiffness factor κ of the contact (1: as stiff as one particle spacing).
    #[serde(default = "default_stiffness")]
    pub stiffness: f64,
    /// Coulomb coefficient μ.
    #[serde(default)]
    pub friction: f64,
    /// Coefficients for particular pairs of contact groups.
    #[serde(default)]
    pub pairs: Vec<PairFriction>,
    /// Which particles the contact acts between.
    #[serde(default)]
    pub between: PenaltyPairs,
    /// D̄_min of the separability condition (dfg-partitioning-mpm.md §2.3), published for the
    /// field assignment when this law acts on crack faces (`between: All`): the two sides of a
    /// body at a node stay separate fields, and meet through this law, only where both sides'
    /// mean damage exceeds it.
    #[serde(default = "default_separability")]
    pub separability: f64,
}

/// Which particles `contact/penalty` acts between (`between`).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum PenaltyPairs {
    /// Particles of different contact groups; under `partition/dfg` the sides of a crack within
    /// a group are left to `contact/frictional` with `between: CrackFaces`.
    #[default]
    Groups,
    /// Particles of different contact groups, and the particles of one group that a damage
    /// gradient partition puts on the two sides of a node (crack faces and self-contact
    /// surfaces), which then touch where they lay while the body was whole
    /// ([`face_touch_level`]).
    All,
}

fn default_separability() -> f64 {
    0.25
}

fn default_stiffness() -> f64 {
    1.0
}

impl Default for PenaltyParams {
    fn default() -> Self {
        Self {
            stiffness: default_stiffness(),
            friction: 0.0,
            pairs: Vec::new(),
            between: PenaltyPairs::Groups,
            separability: default_separability(),
        }
    }
}

impl PenaltyParams {
    /// The Coulomb coefficient between particles of groups `a` and `b`.
    pub fn friction_between(&self, a: u8, b: u8) -> f64 {
        self.pairs
            .iter()
            .find(|p| p.groups == (a, b) || p.groups == (b, a))
            .map_or(self.friction, |p| p.friction)
    }
}

/// What the law needs of one particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParticle<V> {
    /// Position at which the contact force is evaluated.
    pub position: V,
    /// Velocity for the friction (the grid's velocity at the particle).
    pub velocity: V,
    /// The grid's velocity gradient at the particle, by rows (`(L a)_i = rows[i] · a`; the
    /// rows beyond the dimension unused): the friction's slip is taken at the contact point.
    pub velocity_gradient: [V; 3],
    /// Spacing `ℓ = 2r` of the particle's domain, the width of its kernel.
    pub width: f64,
    /// Mass.
    pub mass: f64,
    /// Young's modulus of its material.
    pub modulus: f64,
}

/// How the law is applied: the stiffness factor κ, the friction coefficient, the scene
/// thickness (2D), the dimension, and the integrator's force window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairLaw {
    /// κ.
    pub stiffness: f64,
    /// μ.
    pub friction: f64,
    /// Out-of-plane thickness in 2D, 1 in 3D.
    pub thickness: f64,
    /// Spatial dimension.
    pub dimension: usize,
    /// The time over which the integrator applies a force to the end-of-step velocity.
    pub window: f64,
    /// Whether friction acts at the pair's contact point (the slip there, the moment about the
    /// particles): only where the transfers carry a moment to the particles (APIC); with FLIP
    /// the moment would be lost in the grid-to-particle transfer while the slip still read it.
    pub at_contact_point: bool,
}

/// `S` at a particle whose domain just touches a flat face of another body's lattice: the
/// spline one spacing from its centre, `B(1) = 1/8`.
pub const TOUCH_LEVEL: f64 = 0.125;

/// Reach of a kernel in units of its width: `B(t) = 0` for `|t| ≥ 1.5`.
pub const KERNEL_REACH: f64 = 1.5;

/// The quadratic B-spline `B(t)` of unit spacing: `¾ − t²` for `|t| < ½`, `½ (1.5 − |t|)²` for
/// `|t| < 1.5`, 0 beyond. Its translates by the integers sum to 1.
pub fn spline(t: f64) -> f64 {
    let a = t.abs();
    if a < 0.5 {
        0.75 - a * a
    } else if a < KERNEL_REACH {
        0.5 * (KERNEL_REACH - a) * (KERNEL_REACH - a)
    } else {
        0.0
    }
}

/// `dB/dt`, odd in `t` to the bit.
pub fn spline_slope(t: f64) -> f64 {
    let a = t.abs();
    let slope = if a < 0.5 {
        -2.0 * a
    } else if a < KERNEL_REACH {
        -(KERNEL_REACH - a)
    } else {
        0.0
    };
    if t < 0.0 { -slope } else { slope }
}

/// `φ(r) = Π_i B(r_i / ℓ)` over the `dimension` components of `r`, for kernel width `ℓ`.
pub fn kernel<V: VectorOps>(r: V, width: f64, dimension: usize) -> f64 {
    (0..dimension).map(|i| spline(r[i] / width)).product()
}

/// `∇φ(r)` for kernel width `ℓ`.
pub fn kernel_gradient<V: VectorOps>(r: V, width: f64, dimension: usize) -> V {
    V::from_fn(|i| {
        if i >= dimension {
            return 0.0;
        }
        (0..dimension)
            .map(|j| {
                if j == i {
                    spline_slope(r[j] / width) / width
                } else {
                    spline(r[j] / width)
                }
            })
            .product()
    })
}

/// The penalty modulus `K_p = 2 κ E_p ℓ_p^{d−1} t ℓ_p` of a particle (see the module header).
pub fn penalty_modulus<V>(p: &ContactParticle<V>, law: &PairLaw) -> f64 {
    let face = p.width.powi(law.dimension as i32 - 1) * law.thickness;
    2.0 * law.stiffness * p.modulus * face * p.width
}

/// A particle's contact energy `½ K (S − s)₊²` at depth `S`, for touch level `s` (`s₀`, or
/// [`face_touch_level`] for a particle on a crack face).
pub fn depth_energy(modulus: f64, depth: f64, touch: f64) -> f64 {
    let excess = (depth - touch).max(0.0);
    0.5 * modulus * excess * excess
}

/// `dU/dS = K (S − s)₊`.
pub fn depth_slope(modulus: f64, depth: f64, touch: f64) -> f64 {
    modulus * (depth - touch).max(0.0)
}

/// The touch level of a particle with partners across a crack face of its own body:
/// `max(s₀, S⁰)`, with `S⁰ = Σ_q φ_q(X_p − X_q)` its depth among those partners at their
/// positions `X` at the start of the run. The two faces of a crack were one material: where the
/// particles lay then, the faces touch, and a lattice split along a staircase (a crack inclined
/// to the particle rows) reaches deeper than a flat face's `s₀` without any overlap. The
/// potential so stays zero as a crack opens, and pushes back only once the faces press further
/// together than the body's particles were.
pub fn face_touch_level(reference_depth: f64) -> f64 {
    reference_depth.max(TOUCH_LEVEL)
}

/// The force of one pair on `p`, and the friction's power on the pair's relative motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairContact<V> {
    /// Force on `p` (normal and friction); `q` takes its negative.
    pub force: V,
    /// Power of the friction force on the pair's relative motion at the contact point,
    /// `f_t · (v_cp − v_cq)` (≤ 0).
    pub friction_power: f64,
    /// The friction part `f_t` of `force`.
    pub friction: V,
    /// The contact point's offset from `p`, `c − x_p`, where `friction` acts.
    pub lever: V,
}

/// The offsets from `p` and from `q` of the pair's contact point
/// `c = x_p + (x_q − x_p) ℓ_p / (ℓ_p + ℓ_q)`: where their domains meet when they touch.
pub fn contact_point<V: VectorOps>(p: &ContactParticle<V>, q: &ContactParticle<V>) -> (V, V) {
    let span = p.width + q.width;
    (
        (q.position - p.position) * (p.width / span),
        (p.position - q.position) * (q.width / span),
    )
}

/// The velocity of a particle's material at offset `a` from it, `v + L a`.
pub fn velocity_at<V: VectorOps>(p: &ContactParticle<V>, a: V) -> V {
    p.velocity
        + V::from_fn(|i| {
            if i < 3 {
                p.velocity_gradient[i].dot(a)
            } else {
                0.0
            }
        })
}

/// The force of the pair `(p, q)` on `p`, given each one's `dU/dS` (`slope_p`, `slope_q`,
/// [`depth_slope`]), or `None` when it exerts none.
pub fn pair_force<V: VectorOps>(
    (p, slope_p): (&ContactParticle<V>, f64),
    (q, slope_q): (&ContactParticle<V>, f64),
    law: &PairLaw,
) -> Option<PairContact<V>> {
    if slope_p == 0.0 && slope_q == 0.0 {
        return None;
    }
    let d = law.dimension;
    let r = p.position - q.position;
    let mut normal = V::ZERO;
    if slope_p != 0.0 {
        normal += kernel_gradient(r, q.width, d) * -slope_p;
    }
    if slope_q != 0.0 {
        normal += kernel_gradient(-r, p.width, d) * slope_q;
    }
    let magnitude = normal.length();
    if magnitude == 0.0 {
        return None;
    }
    let (lever, lever_q) = if law.at_contact_point {
        contact_point(p, q)
    } else {
        (V::ZERO, V::ZERO)
    };
    let mut contact = PairContact {
        force: normal,
        friction_power: 0.0,
        friction: V::ZERO,
        lever,
    };
    if law.friction > 0.0 {
        let n = normal / magnitude;
        let relative = velocity_at(p, lever) - velocity_at(q, lever_q);
        let slip = relative - n * relative.dot(n);
        let speed = slip.length();
        if speed > 0.0 {
            let reduced = p.mass * q.mass / (p.mass + q.mass);
            let limit = (law.friction * magnitude).min(reduced * speed / law.window);
            let friction = slip * (-limit / speed);
            contact.friction_power = friction.dot(relative);
            contact.friction = friction;
            contact.force += friction;
        }
    }
    Some(contact)
}

/// The law of the penalty tests: κ 1, frictionless, 2D at unit thickness, a 1 ms window, the
/// friction at the particles' centres.
#[cfg(test)]
pub(crate) fn plane_test_law() -> PairLaw {
    PairLaw {
        stiffness: 1.0,
        friction: 0.0,
        thickness: 1.0,
        dimension: 2,
        window: 1e-3,
        at_contact_point: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAW: PairLaw = PairLaw {
        stiffness: 1.0,
        friction: 0.0,
        thickness: 0.1,
        dimension: 2,
        window: 0.01,
        at_contact_point: true,
    };

    fn particle(x: DVec2, v: DVec2) -> ContactParticle<DVec2> {
        ContactParticle {
            position: x,
            velocity: v,
            velocity_gradient: [DVec2::ZERO; 3],
            width: 1.0,
            mass: 2.0,
            modulus: 100.0,
        }
    }

    /// The kernels of a lattice sum to 1 inside it, to `B(1) = 1/8` one spacing outside a face
    /// wherever along the face, and to 0 from 1.5 spacings out.
    #[test]
    fn a_lattice_of_kernels_is_flat_along_its_faces() {
        let lattice: Vec<DVec2> = (-6..=6)
            .flat_map(|i| (-6..=0).map(move |j| DVec2::new(i as f64, j as f64)))
            .collect();
        let depth = |x: DVec2| lattice.iter().map(|q| kernel(x - *q, 1.0, 2)).sum::<f64>();
        for along in [0.0, 0.13, 0.5, 0.77] {
            assert!((depth(DVec2::new(along, -3.0)) - 1.0).abs() < 1e-14);
            assert!((depth(DVec2::new(along, 1.0)) - TOUCH_LEVEL).abs() < 1e-14);
            assert_eq!(depth(DVec2::new(along, 1.5)), 0.0);
        }
        // A gradient by central differences.
        let (x, h) = (DVec2::new(0.31, 0.62), 1e-6);
        let numeric = DVec2::new(
            kernel(x + DVec2::X * h, 1.3, 2) - kernel(x - DVec2::X * h, 1.3, 2),
            kernel(x + DVec2::Y * h, 1.3, 2) - kernel(x - DVec2::Y * h, 1.3, 2),
        ) / (2.0 * h);
        assert!((kernel_gradient(x, 1.3, 2) - numeric).length() < 1e-8);
    }

    /// The pair force is `−∂U/∂x_p` of `U = ½K_p (S_p − s₀)₊² + ½K_q (S_q − s₀)₊²`.
    #[test]
    fn the_pair_force_is_the_gradient_of_the_energy() {
        let q = particle(DVec2::new(0.9, 0.2), DVec2::ZERO);
        let energy = |x: DVec2| {
            let p = particle(x, DVec2::ZERO);
            let (kp, kq) = (penalty_modulus(&p, &LAW), penalty_modulus(&q, &LAW));
            depth_energy(kp, kernel(x - q.position, q.width, 2), TOUCH_LEVEL)
                + depth_energy(kq, kernel(q.position - x, p.width, 2), TOUCH_LEVEL)
        };
        let x = DVec2::new(0.05, -0.1);
        let p = particle(x, DVec2::ZERO);
        let k = penalty_modulus(&p, &LAW);
        let slope_p = depth_slope(k, kernel(x - q.position, 1.0, 2), TOUCH_LEVEL);
        let slope_q = depth_slope(k, kernel(q.position - x, 1.0, 2), TOUCH_LEVEL);
        let force = pair_force((&p, slope_p), (&q, slope_q), &LAW)
            .unwrap()
            .force;
        let h = 1e-7;
        let gradient = DVec2::new(
            energy(x + DVec2::X * h) - energy(x - DVec2::X * h),
            energy(x + DVec2::Y * h) - energy(x - DVec2::Y * h),
        ) / (2.0 * h);
        assert!(
            (force + gradient).length() < 1e-6 * force.length(),
            "{force} {gradient}"
        );
        // Two facing rows of one lattice, δ closer than touching: each particle is pushed with
        // κ E ℓ^{d−2} t δ to first order in δ.
        let delta = 1e-4;
        let row = |y: f64| -> Vec<ContactParticle<DVec2>> {
            (-3..=3)
                .map(|i| particle(DVec2::new(i as f64, y), DVec2::ZERO))
                .collect()
        };
        let (upper, lower) = (row(1.0 - delta), row(0.0));
        let depth = |x: DVec2, others: &[ContactParticle<DVec2>]| {
            others
                .iter()
                .map(|o| kernel(x - o.position, o.width, 2))
                .sum::<f64>()
        };
        let p = &upper[3];
        let slope_p = depth_slope(k, depth(p.position, &lower), TOUCH_LEVEL);
        let push: DVec2 = lower
            .iter()
            .filter_map(|q| {
                let slope_q = depth_slope(k, depth(q.position, &upper), TOUCH_LEVEL);
                pair_force((p, slope_p), (q, slope_q), &LAW)
            })
            .map(|c| c.force)
            .sum();
        let expected = 100.0 * 0.1 * delta;
        assert!((push.y - expected).abs() < 1e-3 * expected, "{push}");
        assert!(push.x.abs() < 1e-15 * expected);
    }

    /// Swapping the pair negates the force to the bit, friction included.
    #[test]
    fn the_pair_forces_are_equal_and_opposite_to_the_bit() {
        let law = PairLaw {
            friction: 0.3,
            ..LAW
        };
        let p = particle(DVec2::new(0.1, 0.2), DVec2::new(0.3, -0.7));
        let mut q = particle(DVec2::new(0.83, 0.71), DVec2::new(-0.11, 0.05));
        q.width = 0.9;
        let on_p = pair_force((&p, 3.7), (&q, 1.3), &law).unwrap();
        let on_q = pair_force((&q, 1.3), (&p, 3.7), &law).unwrap();
        assert_eq!(on_p.force, -on_q.force);
        assert_eq!(on_p.friction_power, on_q.friction_power);
        assert!(on_p.friction_power < 0.0);
    }

    /// Fast slip is resisted by μ times the normal force; slow slip by the force that stops it
    /// within the window, so the pair sticks.
    #[test]
    fn friction_is_capped_by_coulomb_and_by_sticking() {
        let law = PairLaw {
            friction: 0.5,
            ..LAW
        };
        let q = particle(DVec2::new(0.9, 0.0), DVec2::ZERO);
        let fast = particle(DVec2::ZERO, DVec2::new(0.0, 1.0));
        let frictionless = pair_force((&fast, 10.0), (&q, 10.0), &LAW).unwrap().force;
        let normal = frictionless.length();
        assert!(frictionless.y.abs() < 1e-15 && frictionless.x < 0.0);
        let slipping = pair_force((&fast, 10.0), (&q, 10.0), &law).unwrap();
        assert!((slipping.force.y + 0.5 * normal).abs() < 1e-12);
        assert!((slipping.friction_power + 0.5 * normal).abs() < 1e-12);
        let slow = particle(DVec2::ZERO, DVec2::new(0.0, 1e-6));
        let stick = pair_force((&slow, 10.0), (&q, 10.0), &law).unwrap();
        // m_red v_t / w = 1 · 1e-6 / 0.01.
        assert!((stick.force.y + 1e-4).abs() < 1e-16);
    }
    /// Friction takes the slip at the contact point: a particle whose material there moves
    /// with its partner's (a rim turning as it rolls) is not resisted, though the centres slip;
    /// and both particles take the friction at that one point, so the pair's friction has no
    /// moment.
    #[test]
    fn friction_acts_at_the_contact_point() {
        let law = PairLaw {
            friction: 0.5,
            ..LAW
        };
        let q = particle(DVec2::new(0.9, 0.0), DVec2::ZERO);
        // The contact point is halfway, 0.45 from each; v + ω × a = 0 there for ω = −v/0.45.
        let (v, omega) = (0.2, -0.2 / 0.45);
        let mut rolling = particle(DVec2::ZERO, DVec2::new(0.0, v));
        rolling.velocity_gradient = [DVec2::new(0.0, -omega), DVec2::new(omega, 0.0), DVec2::ZERO];
        let stuck = pair_force((&rolling, 10.0), (&q, 10.0), &law).unwrap();
        assert_eq!(stuck.friction, DVec2::ZERO);
        assert_eq!(stuck.lever, DVec2::new(0.45, 0.0));
        let sliding = particle(DVec2::ZERO, DVec2::new(0.0, v));
        let resisted = pair_force((&sliding, 10.0), (&q, 10.0), &law).unwrap();
        assert!(resisted.friction.y < 0.0);
        // An oblique pair, both sides: the friction's moments about the origin cancel.
        let p = particle(DVec2::new(0.1, 0.2), DVec2::new(0.3, -0.7));
        let mut q = particle(DVec2::new(0.83, 0.71), DVec2::new(-0.11, 0.05));
        q.width = 0.9;
        let on_p = pair_force((&p, 3.7), (&q, 1.3), &law).unwrap();
        let on_q = pair_force((&q, 1.3), (&p, 3.7), &law).unwrap();
        let moment = (p.position + on_p.lever).perp_dot(on_p.friction)
            + (q.position + on_q.lever).perp_dot(on_q.friction);
        assert!(moment.abs() < 1e-15, "{moment}");
        assert!((p.position + on_p.lever - q.position - on_q.lever).length() < 1e-15);
    }
}
