//! The transfers that read shape-function gradients, for connectivity rows that keep a
//! [`RowMap`] instead of gradients (`basis/lme` on a uniform grid), with the map's matrix
//! applied once per particle rather than once per entry (not a system; `transfer.rs` calls
//! these when [`Connectivity::row_maps`] holds the rows' maps).
//!
//! eigensoftening-lme-mpm.md eq. (8) gives a row's gradients as `∇N_I = −N_I A d_I` with
//! `A = J⁻¹` and `d_I = x_p − x_I`. So:
//!
//! - the velocity gradient (eq. 7, `transfer::velocity_gradient`) is
//!   `L_p = Σ_I v_I ⊗ ∇N_I = −(Σ_I N_I v_I ⊗ d_I) Aᵀ`: per entry one outer product, per
//!   particle one matrix product;
//! - the internal force of an entry (Appendix A step 7, `transfer::field_forces`) is
//!   `−(1 − D) V (σ − q I)·∇N_I = N_I B_p d_I` with `B_p = (1 − D) V (σ − q I) A`, formed once
//!   per particle beside `m b + f_ext` ([`ParticleForce`]): per entry one matrix–vector
//!   product and the weight, reading one record of the particle instead of seven columns.
//!
//! Both sums are the same as the entry-by-entry ones up to round-off (the products associate
//! differently). `d_I` is formed per entry from the two positions, never as `B x_p − B x_I`,
//! whose difference would lose digits far from the origin. Each node sums its entries in the
//! transpose's particle order, so results do not depend on the thread count.

use fractum_engine::connectivity::RowMap;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// `L_p = −(Σ_I N_I v_I ⊗ d_I) Aᵀ` over one row: its `nodes`, their velocity-field slots
/// `fields` and `weights`, with the row's `map` (`A` and `x_p`).
#[inline]
pub fn mapped_velocity_gradient<D: Dim>(
    map: RowMap<D>,
    (nodes, fields, weights): (&[u32], &[u8], &[f64]),
    node_positions: &[D::Vector],
    node_velocity: &[NodeVelocity<D>],
) -> D::Matrix {
    let entries = nodes.iter().zip(fields).zip(weights);
    let moment = entries.fold(D::Matrix::ZERO, |s, ((&node, &field), &n)| {
        let node = node as usize;
        let offset = map.point - node_positions[node];
        s + D::Matrix::outer(node_velocity[node].0[field as usize] * n, offset)
    });
    (moment * map.matrix.transpose()) * -1.0
}

/// What one particle adds to the force of each node of its row, per unit of the node's weight
/// `N_I`: `body + internal · (point − x_I)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleForce<D: Dim> {
    /// `m b + f_ext`.
    pub body: D::Vector,
    /// `B_p = (1 − D) V (σ − q I) A` (without `1 − D` where the damage sits in the stress).
    pub internal: D::Matrix,
    /// `x_p`, the point the row's map was computed at.
    pub point: D::Vector,
}

impl<D: Dim> Default for ParticleForce<D> {
    fn default() -> Self {
        Self {
            body: D::Vector::ZERO,
            internal: D::Matrix::ZERO,
            point: D::Vector::ZERO,
        }
    }
}

impl<D: Dim> ParticleForce<D> {
    /// The record of a particle with body and load force `body`, stress `stress` (with any
    /// viscous pressure taken off) scaled by `scale` (`(1 − D) V`, or `V`), and its row's `map`.
    #[inline]
    pub fn new(body: D::Vector, stress: D::Matrix, scale: f64, map: RowMap<D>) -> Self {
        Self {
            body,
            internal: (stress * map.matrix) * scale,
            point: map.point,
        }
    }
}

/// Per-field force sums `Σ N_I (m b + f_ext + B_p d_I)` of every node into `forces` (one slot
/// per node, each overwritten), from the particles' records, formed first into `records` by
/// `record(p, map)` for every row.
pub fn mapped_field_forces<D: Dim>(
    c: &Connectivity<D>,
    record: impl Fn(usize, RowMap<D>) -> ParticleForce<D> + Sync,
    records: &mut Vec<ParticleForce<D>>,
    forces: &mut [[D::Vector; MAX_FIELDS]],
) {
    records.resize(c.row_maps.len(), ParticleForce::default());
    records
        .par_iter_mut()
        .zip(c.row_maps.par_iter())
        .enumerate()
        .for_each(|(p, (slot, &map))| *slot = record(p, map));
    let records = &*records;
    forces.par_iter_mut().enumerate().for_each(|(node, slot)| {
        let mut sum = [D::Vector::ZERO; MAX_FIELDS];
        let entries = c.entries_of_node(node);
        if !entries.is_empty() {
            // The node's position once, for all its entries.
            let x_i = c.node_positions[node];
            for &(e, p) in entries {
                let (e, record) = (e as usize, &records[p as usize]);
                let per_weight = record.body + record.internal * (record.point - x_i);
                sum[c.fields[e] as usize] += per_weight * c.weights[e];
            }
        }
        *slot = sum;
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat2, DVec2};

    /// Three particles' rows over a 3 × 3 patch of nodes, each row keeping a map, the middle
    /// particle's entries split over two fields.
    fn mapped_rows() -> Connectivity<Two> {
        let node_positions: Vec<DVec2> = (0..9)
            .map(|i| DVec2::new(10.0 + 0.5 * (i % 3) as f64, -3.0 + 0.5 * (i / 3) as f64))
            .collect();
        let maps = [
            (
                DMat2::from_cols_array(&[2.0, 0.4, 0.4, 3.0]),
                DVec2::new(10.3, -2.8),
            ),
            (
                DMat2::from_cols_array(&[1.5, -0.2, -0.2, 1.0]),
                DVec2::new(10.6, -2.4),
            ),
            (
                DMat2::from_cols_array(&[0.7, 0.1, 0.1, 0.9]),
                DVec2::new(10.9, -2.1),
            ),
        ];
        let mut c = Connectivity::default();
        c.fill_rows_mapped(
            3,
            &node_positions,
            |p| 4 + p,
            || (),
            |_, p, nodes, weights, map| {
                for (k, (node, weight)) in nodes.iter_mut().zip(weights.iter_mut()).enumerate() {
                    (*node, *weight) = ((2 * p + k) as u32 % 9, 0.1 + 0.05 * (k + p) as f64);
                }
                let (matrix, point) = maps[p];
                *map = RowMap { matrix, point };
            },
        );
        c.fields = (0..c.nodes.len())
            .map(|e| u8::from(e % 3 == 1 && e > 4))
            .collect();
        c
    }

    /// `−(Σ N v ⊗ d) Aᵀ` equals `Σ v ⊗ ∇N` with each entry's gradient from the map, to
    /// round-off, field by field.
    #[test]
    fn the_velocity_gradient_equals_the_entry_by_entry_sum() {
        let c = mapped_rows();
        let velocity: Vec<NodeVelocity<Two>> = (0..9)
            .map(|i| {
                NodeVelocity(std::array::from_fn(|k| {
                    DVec2::new(1.0 + i as f64 - k as f64, 0.3 * (i * i) as f64 + k as f64)
                }))
            })
            .collect();
        for p in 0..3 {
            let row = c.row(p);
            let columns = (
                &c.nodes[row.clone()],
                &c.fields[row.clone()],
                &c.weights[row],
            );
            let folded =
                mapped_velocity_gradient(c.row_maps[p], columns, &c.node_positions, &velocity);
            let by_entries = c.row_gradients(p).fold(DMat2::ZERO, |l, (e, gradient)| {
                l + DMat2::outer(velocity[c.nodes[e] as usize].0[c.field(e)], gradient)
            });
            let scale = by_entries.max_abs();
            assert!(scale > 0.1, "a non-trivial gradient");
            assert!(
                (folded - by_entries).max_abs() <= 1e-14 * scale,
                "row {p}: {folded:?} against {by_entries:?}"
            );
        }
    }

    /// The node sums equal `Σ N_I body − scale σ·∇N_I` with each entry's gradient from the
    /// row's map, to round-off; an entry adds only to its own field and a node no row reaches
    /// gets zeros.
    #[test]
    fn the_node_forces_equal_the_entry_by_entry_sums() {
        let c = mapped_rows();
        let body = |p: usize| DVec2::new(5.0 - p as f64, -9.81 * (p + 1) as f64);
        let stress = |p: usize| {
            let s = 1.0e6 * (p as f64 + 1.0);
            DMat2::from_cols_array(&[3.0 * s, 0.5 * s, 0.5 * s, -s])
        };
        let scale = |p: usize| 0.2 - 0.05 * p as f64;
        let record = |p: usize, map| ParticleForce::new(body(p), stress(p), scale(p), map);
        let mut forces = vec![[DVec2::splat(f64::NAN); MAX_FIELDS]; 10];
        mapped_field_forces(&c, record, &mut Vec::new(), &mut forces);
        let mut expected = vec![[DVec2::ZERO; MAX_FIELDS]; 10];
        for p in 0..3 {
            for e in c.row(p) {
                let (n, gradient) = (c.weights[e], c.gradient(e, p));
                expected[c.nodes[e] as usize][c.field(e)] +=
                    body(p) * n - stress(p) * gradient * scale(p);
            }
        }
        let largest = expected
            .iter()
            .flatten()
            .map(|f| f.length())
            .fold(0.0, f64::max);
        for (node, (got, want)) in forces.iter().zip(&expected).enumerate() {
            for k in 0..MAX_FIELDS {
                let gap = (got[k] - want[k]).length();
                assert!(
                    gap <= 1e-14 * largest,
                    "node {node} field {k}: {:?}",
                    got[k]
                );
            }
        }
        assert_eq!(
            forces[9],
            [DVec2::ZERO; MAX_FIELDS],
            "a node no row reaches"
        );
        assert!(
            expected.iter().any(|f| f[1] != DVec2::ZERO),
            "two fields in play"
        );
    }
}
