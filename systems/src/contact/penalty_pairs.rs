//! The particle pairs of `contact/penalty`: the bins that find each particle's partners in the
//! other contact groups, and each particle's summed force, energy and friction power over its
//! pairs.
//!
//! - Stage: contact (used by the `contact/penalty` system; not a registration itself).
//! - The law of one pair is `contact::penalty_law`; this file only finds the pairs and sums
//!   them, in a fixed order, so that the sums are the same for any thread count and on every
//!   rank of a distributed run ([`BinFrame`]).

pub use super::penalty_faces::{CrackFaces, FaceSides};
use super::penalty_law::{
    ContactParticle, KERNEL_REACH, PairLaw, PenaltyParams, depth_energy, depth_slope,
    face_touch_level, kernel, pair_force, penalty_modulus,
};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// What the contact gives each particle: the summed force of its pairs, its contact energy, and
/// its share of the pairs' friction power (half of each pair's, so that the sum over particles
/// is the pairs' sum).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ParticleContact<V> {
    /// Summed force of the particle's pairs on it.
    pub force: V,
    /// Its contact energy `½ K_p (S_p − s₀)₊²`.
    pub energy: f64,
    /// Half the friction power of its pairs.
    pub friction_power: f64,
    /// The moment of its pairs' friction about it, `Σ f_t ⊗ a` by columns (column `j` is
    /// `Σ f_t a_j`; the columns beyond the dimension zero): the nodes take `Σ_j col_j ∂_j N`.
    pub moment: [V; 3],
}

impl<V: VectorOps> ParticleContact<V> {
    /// The moment's share of node force for shape-function gradient `gradient`:
    /// `W ∇N` with `W = ½ (M − Mᵀ)` the skew part of `M = Σ f_t ⊗ a`, a pure moment (its
    /// symmetric part would be a stress on the particle, which a surface force is not).
    pub fn moment_force(&self, gradient: V) -> V {
        let g = gradient.to_3d();
        let by_columns = (0..3).fold(V::ZERO, |sum, j| sum + self.moment[j] * g[j]);
        let by_rows = V::from_fn(|i| {
            if i < 3 {
                self.moment[i]
                    .to_3d()
                    .iter()
                    .zip(g)
                    .map(|(m, g)| m * g)
                    .sum()
            } else {
                0.0
            }
        });
        (by_columns - by_rows) * 0.5
    }
}

/// The particles of the contact, in particle-row order.
pub struct ContactSet<'a, V> {
    /// Each particle's state for the law.
    pub particles: &'a [ContactParticle<V>],
    /// Each particle's contact group.
    pub groups: &'a [ContactGroup],
    /// The faces a partition opens within the groups, when the law acts on them.
    pub faces: Option<CrackFaces<'a, V>>,
}

/// Where the bins that find each particle's partners lie: their corner and the widest
/// particle, whose kernel reach is their side. Fixed by the scene (the grid's corner, the
/// scene's widest particle) rather than by the particles at hand, so that a rank of a
/// distributed run, holding some of them, visits an owned particle's partners in the order one
/// process does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BinFrame {
    /// The corner of bin (0, 0, 0) (x, y, z; unused axes zero).
    pub origin: [f64; 3],
    /// The widest particle's width.
    pub widest: f64,
}

impl BinFrame {
    /// The frame of `set` alone: its lowest corner and its widest particle.
    pub fn of<V: VectorOps>(set: &ContactSet<V>) -> Self {
        let mut origin = [f64::INFINITY; 3];
        for p in set.particles {
            let x = p.position.to_3d();
            for a in 0..3 {
                origin[a] = origin[a].min(x[a]);
            }
        }
        let widest = set.particles.iter().map(|p| p.width).fold(0.0, f64::max);
        Self { origin, widest }
    }
}

/// Bins of side the largest kernel reach: a particle's partners lie in its own bin or the
/// adjacent ones. Each bin lists its particles in row order and whether it holds more than one
/// contact group. The bins are found by key in a hash map with the Fx hash (a few integer
/// operations for three `i64`s; the standard library's SipHash took a quarter of a penalty
/// step), and their rows are one array sliced per bin, so a step allocates three arrays rather
/// than a list per bin.
struct Bins {
    side: f64,
    origin: [f64; 3],
    /// The index of each occupied bin in `bins`, by key.
    index: rustc_hash::FxHashMap<[i64; 3], u32>,
    bins: Vec<Bin>,
    /// The rows of every bin, bin after bin; bin `b`'s are `rows[bins[b].start..][..bins[b].len]`.
    rows: Vec<u32>,
}

struct Bin {
    start: u32,
    len: u32,
    group: u8,
    mixed: bool,
}

impl Bins {
    fn new<V: VectorOps>(set: &ContactSet<V>, frame: BinFrame) -> Option<Self> {
        let side = KERNEL_REACH * frame.widest;
        if !(side > 0.0 && side.is_finite() && frame.origin.iter().all(|x| x.is_finite())) {
            return None;
        }
        let mut bins = Self {
            side,
            origin: frame.origin,
            index: rustc_hash::FxHashMap::default(),
            bins: Vec::new(),
            rows: vec![0; set.particles.len()],
        };
        // Each particle's bin, the bins numbered as first met; then each bin's count, its
        // start, and its rows placed in row order.
        let mut of_row = Vec::with_capacity(set.particles.len());
        for (p, group) in set.particles.iter().zip(set.groups) {
            let next = bins.bins.len() as u32;
            let b = *bins.index.entry(bins.key(p.position)).or_insert(next);
            if b == next {
                bins.bins.push(Bin {
                    start: 0,
                    len: 0,
                    group: group.0,
                    mixed: false,
                });
            }
            let bin = &mut bins.bins[b as usize];
            bin.mixed |= bin.group != group.0;
            bin.len += 1;
            of_row.push(b);
        }
        let mut start = 0;
        for bin in &mut bins.bins {
            bin.start = start;
            start += bin.len;
        }
        let mut filled = vec![0u32; bins.bins.len()];
        for (row, b) in of_row.into_iter().enumerate() {
            let bin = &bins.bins[b as usize];
            bins.rows[(bin.start + filled[b as usize]) as usize] = row as u32;
            filled[b as usize] += 1;
        }
        Some(bins)
    }

    fn key<V: VectorOps>(&self, x: V) -> [i64; 3] {
        let x = x.to_3d();
        std::array::from_fn(|a| ((x[a] - self.origin[a]) / self.side).floor() as i64)
    }

    /// The rows of `bin`, in row order.
    fn rows_of(&self, bin: &Bin) -> &[u32] {
        &self.rows[bin.start as usize..(bin.start + bin.len) as usize]
    }

    /// The bins around `x` (its own and the adjacent ones, in a fixed order).
    fn around<V: VectorOps>(&self, x: V, dimension: usize) -> impl Iterator<Item = &Bin> + '_ {
        let centre = self.key(x);
        let span = move |a: usize| if a < dimension { -1..=1 } else { 0..=0 };
        span(0)
            .flat_map(move |i| span(1).flat_map(move |j| span(2).map(move |k| [i, j, k])))
            .filter_map(move |d| {
                self.index
                    .get(&[centre[0] + d[0], centre[1] + d[1], centre[2] + d[2]])
                    .map(|&b| &self.bins[b as usize])
            })
    }
}

impl Bins {
    /// Calls `visit(q)` for every particle `q` within reach of `row` that is of another group,
    /// or of its own group across a face ([`FaceSides::across`]), in a fixed order.
    fn partners<V: VectorOps>(
        &self,
        set: &ContactSet<V>,
        row: usize,
        dimension: usize,
        mut visit: impl FnMut(usize),
    ) {
        let group = set.groups[row].0;
        let faces = set.faces.as_ref().filter(|f| !f.sides.of(row).is_empty());
        for bin in self.around(set.particles[row].position, dimension) {
            if faces.is_none() && !bin.mixed && bin.group == group {
                continue;
            }
            for &other in self.rows_of(bin) {
                let other = other as usize;
                if set.groups[other].0 != group || faces.is_some_and(|f| f.sides.across(row, other))
                {
                    visit(other);
                }
            }
        }
    }
}

/// Each particle's contact with the particles of other groups (see [`ParticleContact`]), with
/// the friction coefficient of each pair of groups from `params`: first each particle's depth
/// `S_p` in the other groups' material, then the pair forces. Partners are visited from both
/// sides, each side in a fixed order (bins placed by `frame`, rows in order), so the sums are the
/// same for any thread count.
pub fn particle_contacts<V: VectorOps>(
    set: &ContactSet<V>,
    params: &PenaltyParams,
    law: &PairLaw,
    frame: BinFrame,
) -> Vec<ParticleContact<V>> {
    let Some(bins) = Bins::new(set, frame) else {
        return vec![ParticleContact::default(); set.particles.len()];
    };
    let d = law.dimension;
    let particles = set.particles;
    // K_p, the depth S_p and the touch level of every particle.
    let depths: Vec<(f64, f64, f64)> = (0..particles.len())
        .into_par_iter()
        .map(|row| {
            let (me, group) = (&particles[row], set.groups[row].0);
            let (mut depth, mut reference_depth) = (0.0, 0.0);
            bins.partners(set, row, d, |q| {
                let width = particles[q].width;
                depth += kernel(me.position - particles[q].position, width, d);
                if let Some(faces) = set.faces.as_ref().filter(|_| set.groups[q].0 == group) {
                    let r = faces.reference[row] - faces.reference[q];
                    reference_depth += kernel(r, width, d);
                }
            });
            let touch = face_touch_level(reference_depth);
            (penalty_modulus(me, law), depth, touch)
        })
        .collect();
    let slopes: Vec<f64> = depths
        .iter()
        .map(|&(k, s, touch)| depth_slope(k, s, touch))
        .collect();
    (0..particles.len())
        .into_par_iter()
        .map(|row| {
            let (me, group) = (&particles[row], set.groups[row].0);
            let (modulus, depth, touch) = depths[row];
            let mut sum = ParticleContact {
                energy: depth_energy(modulus, depth, touch),
                ..ParticleContact::default()
            };
            bins.partners(set, row, d, |q| {
                let pair = PairLaw {
                    friction: params.friction_between(group, set.groups[q].0),
                    ..*law
                };
                if let Some(c) = pair_force((me, slopes[row]), (&particles[q], slopes[q]), &pair) {
                    sum.force += c.force;
                    sum.friction_power += 0.5 * c.friction_power;
                    let lever = c.lever.to_3d();
                    for (column, a) in sum.moment.iter_mut().zip(lever) {
                        *column += c.friction * a;
                    }
                }
            });
            sum
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 6 × 6 lattice of unit spacing in one group, cut into two sides by `side(i, j)`, every
    /// particle sharing node 0, moved by `shift(side)` from the lattice; each particle's contact
    /// for start-of-run positions `reference(x)`.
    fn cut_lattice(
        side: impl Fn(usize, usize) -> u8,
        shift: impl Fn(u8) -> DVec2,
        reference: impl Fn(DVec2) -> DVec2,
    ) -> (Vec<u8>, Vec<ParticleContact<DVec2>>) {
        let (mut particles, mut sides, mut references) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..6 {
            for j in 0..6 {
                let x = DVec2::new(i as f64, j as f64);
                let s = side(i, j);
                particles.push(ContactParticle {
                    position: x + shift(s),
                    velocity: DVec2::ZERO,
                    velocity_gradient: [DVec2::ZERO; 3],
                    width: 1.0,
                    mass: 1.0,
                    modulus: 1.0,
                });
                sides.push(s);
                references.push(reference(x));
            }
        }
        let rows = sides.iter().map(|&s| vec![(0, s)]).collect();
        let face_sides = FaceSides::from_rows(rows);
        let groups = vec![ContactGroup(0); particles.len()];
        let set = ContactSet {
            particles: &particles,
            groups: &groups,
            faces: Some(CrackFaces {
                sides: &face_sides,
                reference: &references,
            }),
        };
        let contacts = particle_contacts(
            &set,
            &PenaltyParams::default(),
            &crate::contact::penalty_law::plane_test_law(),
            BinFrame::of(&set),
        );
        (sides, contacts)
    }

    fn energy(contacts: &[ParticleContact<DVec2>]) -> f64 {
        contacts.iter().map(|c| c.energy).sum()
    }

    /// Crack faces touch where the body's particles lay. A lattice cut between two rows is a
    /// flat face: its particles sit at `s₀` whatever the reference. Cut along a staircase (a
    /// crack at 45° to the rows), the faces reach deeper than `s₀` with no overlap at all: the
    /// touch level taken from the start-of-run positions keeps that lattice at rest, where
    /// `s₀` alone would push it apart.
    #[test]
    fn a_cut_lattice_rests_at_its_reference() {
        let none = |_| DVec2::ZERO;
        let far = |x: DVec2| x * 10.0;
        let flat = |i: usize, _: usize| u8::from(i >= 3);
        let stair = |i: usize, j: usize| u8::from(i + j >= 6);
        assert_eq!(energy(&cut_lattice(flat, none, far).1), 0.0);
        assert_eq!(energy(&cut_lattice(stair, none, |x| x).1), 0.0);
        assert!(
            cut_lattice(stair, none, |x| x)
                .1
                .iter()
                .all(|c| c.force == DVec2::ZERO)
        );
        assert!(energy(&cut_lattice(stair, none, far).1) > 0.0);
    }

    /// Pressed together, the two sides of a cut push apart, equal and opposite.
    #[test]
    fn pressed_faces_push_apart() {
        let stair = |i: usize, j: usize| u8::from(i + j >= 6);
        let press = |s: u8| DVec2::new(-0.1, -0.1) * f64::from(s);
        let (sides, contacts) = cut_lattice(stair, press, |x| x);
        assert!(energy(&contacts) > 0.0);
        let mut on_side = [DVec2::ZERO; 2];
        for (s, c) in sides.iter().zip(&contacts) {
            on_side[usize::from(*s)] += c.force;
        }
        assert!((on_side[0] + on_side[1]).length() < 1e-12, "{on_side:?}");
        assert!(on_side[1].x > 0.0 && on_side[1].y > 0.0, "{on_side:?}");
    }
}
