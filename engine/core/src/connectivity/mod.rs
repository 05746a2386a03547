//! Particle–node connectivity in compact CSR tables.
//!
//! The basis stage writes, for every particle row `p`, the nodes it influences with the shape
//! function value `N_Ip` and gradient `∇N_Ip`. Every transfer reads these tables.
//!
//! Each entry also names the velocity field (the node's slot, see
//! [`crate::components::NodeFields`]) the particle maps to at that node. The basis resets every
//! entry to slot 0; a partition rule then assigns the slots (see `crate::fields`). Every transfer
//! reads the slot from here and nowhere else.
//!
//! Grid-to-particle transfers gather over a particle's row. Particle-to-grid transfers gather over
//! the transposed table (node → entries, in particle order), so each node's sum is always
//! accumulated in the same order and the result is bitwise identical for any thread count.

use crate::dim::{Dim, MatrixOps, VectorOps};
use bevy_ecs::prelude::Resource;
use rayon::prelude::*;
use std::ops::AddAssign;
use transpose::running_sum;

mod transpose;

/// `count` default values, made on the pool's threads (a large buffer's pages are first
/// touched where its rows will be written).
fn default_values<T: Send + Default>(count: usize) -> Vec<T> {
    (0..count).into_par_iter().map(|_| T::default()).collect()
}

/// Shape-function connectivity for the current particle positions.
#[derive(Resource, Clone, Debug)]
pub struct Connectivity<D: Dim> {
    /// Row offsets: entries of particle row `p` are `row_offsets[p]..row_offsets[p + 1]`.
    pub row_offsets: Vec<usize>,
    /// Node index of each entry.
    pub nodes: Vec<u32>,
    /// Shape function value `N_Ip` of each entry.
    pub weights: Vec<f64>,
    /// Shape function gradient `∇N_Ip` of each entry, where the basis stores them; empty where
    /// they follow from [`Self::row_maps`] (read either way with [`Self::gradient`]).
    pub gradients: Vec<D::Vector>,
    /// Per particle row, the map its gradients follow instead of being stored (LME's eq. 8),
    /// filled by [`Self::fill_rows_mapped`]; empty where `gradients` holds them.
    pub row_maps: Vec<RowMap<D>>,
    /// Position of every node, for the gradients of [`Self::row_maps`].
    pub node_positions: Vec<D::Vector>,
    /// Velocity-field slot of each entry at its node (0 without partitioning).
    pub fields: Vec<u8>,
    /// Transposed offsets: entries touching node `I` are `node_offsets[I]..node_offsets[I + 1]`.
    pub node_offsets: Vec<usize>,
    /// For each transposed slot, the (entry, particle row) it refers to, in particle order.
    pub node_entries: Vec<(u32, u32)>,
}

impl<D: Dim> Connectivity<D> {
    /// Bytes of the whole table (rows, their nodes, weights, gradients and field slots, and the
    /// transposed index), for the traffic count of [`crate::traffic`].
    pub fn heap_bytes(&self) -> f64 {
        let bytes = |len: usize, size: usize| (len * size) as f64;
        bytes(self.row_offsets.len(), 8)
            + bytes(self.nodes.len(), 4)
            + bytes(self.weights.len(), 8)
            + bytes(self.gradients.len(), std::mem::size_of::<D::Vector>())
            + bytes(self.row_maps.len(), std::mem::size_of::<RowMap<D>>())
            + bytes(self.node_positions.len(), std::mem::size_of::<D::Vector>())
            + bytes(self.fields.len(), 1)
            + bytes(self.node_offsets.len(), 8)
            + bytes(self.node_entries.len(), 8)
    }
}

impl<D: Dim> Default for Connectivity<D> {
    fn default() -> Self {
        Self {
            row_offsets: Vec::new(),
            nodes: Vec::new(),
            weights: Vec::new(),
            gradients: Vec::new(),
            row_maps: Vec::new(),
            node_positions: Vec::new(),
            fields: Vec::new(),
            node_offsets: Vec::new(),
            node_entries: Vec::new(),
        }
    }
}

/// The map a row's shape-function gradients follow, `∇N_I = −N_I A (x − x_I)`: LME's eq. (8)
/// (eigensoftening-lme-mpm.md) with `A = J⁻¹` at the converged λ and `x` the particle's position
/// when the row was computed.
///
/// A row of `n` entries stores one map (a matrix and a point) instead of `n` gradients: 48 bytes
/// against 208 for a 2D LME row of 13 entries, 96 against about 790 in 3D, and the transfers that
/// walk the entries node by node read it with the particle's other data instead of one gradient
/// per entry from a table hundreds of megabytes long.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowMap<D: Dim> {
    /// `A` (LME: the inverse Hessian `J⁻¹`).
    pub matrix: D::Matrix,
    /// `x`, the point the row was computed at.
    pub point: D::Vector,
}

impl<D: Dim> Default for RowMap<D> {
    fn default() -> Self {
        Self {
            matrix: D::Matrix::ZERO,
            point: D::Vector::ZERO,
        }
    }
}

impl<D: Dim> RowMap<D> {
    /// `∇N_I = −N_I A (x − x_I)` for the node at `node` with value `weight`.
    #[inline]
    pub fn gradient(&self, node: D::Vector, weight: f64) -> D::Vector {
        -((self.matrix * (self.point - node)) * weight)
    }
}

impl<D: Dim> Connectivity<D> {
    /// Number of particle rows.
    pub fn particle_count(&self) -> usize {
        self.row_offsets.len().saturating_sub(1)
    }

    /// Entry range of particle row `p`.
    pub fn row(&self, p: usize) -> std::ops::Range<usize> {
        self.row_offsets[p]..self.row_offsets[p + 1]
    }

    /// Every entry of particle row `p` with its `∇N_Ip` (as [`Self::gradient`] gives it), the
    /// row's map fetched once.
    #[inline]
    pub fn row_gradients(&self, p: usize) -> impl Iterator<Item = (usize, D::Vector)> + '_ {
        let range = self.row(p);
        let stored = self.gradients.get(range.clone()).unwrap_or(&[]);
        let map = stored.is_empty().then(|| self.row_maps[p]);
        let nodes = &self.nodes[range.clone()];
        let weights = &self.weights[range.clone()];
        range.enumerate().map(move |(k, e)| {
            let gradient = match map {
                Some(map) => map.gradient(self.node_positions[nodes[k] as usize], weights[k]),
                None => stored[k],
            };
            (e, gradient)
        })
    }

    /// `∇N_Ip` of entry `e` of particle row `p`: stored, or from the row's map (LME).
    #[inline]
    pub fn gradient(&self, e: usize, p: usize) -> D::Vector {
        match self.gradients.get(e) {
            Some(&gradient) => gradient,
            None => self.row_maps[p]
                .gradient(self.node_positions[self.nodes[e] as usize], self.weights[e]),
        }
    }

    /// Replaces the tables from per-particle rows of `(node, N, ∇N)` and rebuilds the transpose.
    ///
    /// `rows` must be in particle-row order. `node_count` is the number of grid nodes. The
    /// tables keep their capacity from step to step (see [`Self::fill_rows`]).
    pub fn rebuild<R: AsRef<[(u32, f64, D::Vector)]> + Sync>(
        &mut self,
        rows: &[R],
        node_count: usize,
    ) {
        self.fill_rows(
            rows.len(),
            node_count,
            |p| rows[p].as_ref().len(),
            || (),
            |_, p, nodes, weights, gradients| {
                for (k, &(node, weight, gradient)) in rows[p].as_ref().iter().enumerate() {
                    (nodes[k], weights[k], gradients[k]) = (node, weight, gradient);
                }
            },
        );
    }

    /// Refills the tables with exactly `width` entries per particle row, computed in parallel by
    /// `fill(p, nodes, weights, gradients)` on the row's slices, then rebuilds the transpose.
    pub fn fill_fixed_width<F>(
        &mut self,
        particles: usize,
        width: usize,
        node_count: usize,
        fill: F,
    ) where
        F: Fn(usize, &mut [u32], &mut [f64], &mut [D::Vector]) + Sync,
    {
        let entries = particles * width;
        self.row_offsets.resize(particles + 1, 0);
        self.row_offsets
            .par_iter_mut()
            .enumerate()
            .for_each(|(p, offset)| *offset = p * width);
        self.nodes.resize(entries, 0);
        self.weights.resize(entries, 0.0);
        self.gradients.resize(entries, D::Vector::ZERO);
        self.row_maps = Vec::new();
        self.nodes
            .par_chunks_mut(width)
            .zip(self.weights.par_chunks_mut(width))
            .zip(self.gradients.par_chunks_mut(width))
            .enumerate()
            .for_each(|(p, ((n, w), g))| fill(p, n, w, g));
        self.reset_fields();
        self.rebuild_transpose(node_count);
    }

    /// Refills the tables with rows of varying width and no intermediate row buffers:
    /// `width(p)` gives the number of entries of row `p` (in parallel), then
    /// `fill(scratch, p, nodes, weights, gradients)` writes exactly that many entries into the
    /// row's own slices of the tables and returns a per-row value, collected in row order.
    /// Rows go in fixed blocks, each with its own `init()` scratch, so the result does not
    /// depend on the thread count. Rebuilds the transpose.
    pub fn fill_rows<S, T, W, F>(
        &mut self,
        particles: usize,
        node_count: usize,
        width: W,
        init: impl Fn() -> S + Sync,
        fill: F,
    ) -> Vec<T>
    where
        T: Send + Default,
        W: Fn(usize) -> usize + Sync,
        F: Fn(&mut S, usize, &mut [u32], &mut [f64], &mut [D::Vector]) -> T + Sync,
    {
        let mut values = default_values(particles);
        self.fill_rows_into(node_count, width, init, &mut values, fill);
        values
    }

    /// [`Self::fill_rows`] with the per-row values written into `values`, one per particle row
    /// (its length is the particle count): a buffer the caller keeps from step to step, so that
    /// no step allocates, first-touches and gathers a new one on one thread.
    pub fn fill_rows_into<S, T, W, F>(
        &mut self,
        node_count: usize,
        width: W,
        init: impl Fn() -> S + Sync,
        values: &mut [T],
        fill: F,
    ) where
        T: Send,
        W: Fn(usize) -> usize + Sync,
        F: Fn(&mut S, usize, &mut [u32], &mut [f64], &mut [D::Vector]) -> T + Sync,
    {
        self.row_maps = Vec::new();
        let mut gradients = std::mem::take(&mut self.gradients);
        self.fill_rows_with((&width, true), &mut gradients, init, values, fill);
        self.gradients = gradients;
        self.rebuild_transpose(node_count);
    }

    /// [`Self::fill_rows`] for rows whose gradients follow a map ([`RowMap`], LME's eq. 8):
    /// `fill(scratch, p, nodes, weights, map)` writes the row's nodes and values and its map,
    /// and no gradient is stored. `node_positions` are the positions the rows' nodes index
    /// (kept in [`Self::node_positions`] for [`Self::gradient`]).
    pub fn fill_rows_mapped<S, T, W, F>(
        &mut self,
        particles: usize,
        node_positions: &[D::Vector],
        width: W,
        init: impl Fn() -> S + Sync,
        fill: F,
    ) -> Vec<T>
    where
        T: Send + Default,
        W: Fn(usize) -> usize + Sync,
        F: Fn(&mut S, usize, &mut [u32], &mut [f64], &mut RowMap<D>) -> T + Sync,
    {
        let mut values = default_values(particles);
        self.fill_rows_mapped_into(node_positions, width, init, &mut values, fill);
        values
    }

    /// [`Self::fill_rows_mapped`] with the per-row values written into `values`, one per
    /// particle row (as [`Self::fill_rows_into`]).
    pub fn fill_rows_mapped_into<S, T, W, F>(
        &mut self,
        node_positions: &[D::Vector],
        width: W,
        init: impl Fn() -> S + Sync,
        values: &mut [T],
        fill: F,
    ) where
        T: Send,
        W: Fn(usize) -> usize + Sync,
        F: Fn(&mut S, usize, &mut [u32], &mut [f64], &mut RowMap<D>) -> T + Sync,
    {
        self.gradients = Vec::new();
        if self.node_positions != node_positions {
            self.node_positions = node_positions.to_vec();
        }
        let mut maps = std::mem::take(&mut self.row_maps);
        self.fill_rows_with((&width, false), &mut maps, init, values, |s, p, n, w, m| {
            fill(s, p, n, w, &mut m[0])
        });
        self.row_maps = maps;
        self.rebuild_transpose(node_positions.len());
    }

    /// The loop of [`Self::fill_rows_into`] and [`Self::fill_rows_mapped_into`]: each row gets
    /// its slices of the nodes and weights, and its items of `extra`: one per entry (its
    /// gradients) where `per_entry`, else one (its map); its value goes to its place in
    /// `values`, block by block on the pool's threads.
    fn fill_rows_with<S, T, X, F>(
        &mut self,
        (width, per_entry): (&(impl Fn(usize) -> usize + Sync), bool),
        extra: &mut Vec<X>,
        init: impl Fn() -> S + Sync,
        values: &mut [T],
        fill: F,
    ) where
        T: Send,
        X: Default + Clone + Send,
        F: Fn(&mut S, usize, &mut [u32], &mut [f64], &mut [X]) -> T + Sync,
    {
        const BLOCK: usize = 1024;
        let particles = values.len();
        self.row_offsets.resize(particles + 1, 0);
        self.row_offsets[0] = 0;
        self.row_offsets[1..]
            .par_iter_mut()
            .enumerate()
            .for_each(|(p, end)| *end = width(p));
        running_sum(&mut self.row_offsets[1..]);
        let total = self.row_offsets[particles];
        self.nodes.resize(total, 0);
        self.weights.resize(total, 0.0);
        extra.resize(if per_entry { total } else { particles }, X::default());
        let offsets = &self.row_offsets;
        let extra_len = |rows: std::ops::Range<usize>| {
            if per_entry {
                offsets[rows.end] - offsets[rows.start]
            } else {
                rows.len()
            }
        };
        let mut blocks = Vec::with_capacity(particles.div_ceil(BLOCK));
        let (mut nodes, mut weights, mut extras, mut rest) = (
            &mut self.nodes[..],
            &mut self.weights[..],
            &mut extra[..],
            values,
        );
        for start in (0..particles).step_by(BLOCK) {
            let end = (start + BLOCK).min(particles);
            let len = offsets[end] - offsets[start];
            let (n, rest_n) = nodes.split_at_mut(len);
            let (w, rest_w) = weights.split_at_mut(len);
            let (x, rest_x) = extras.split_at_mut(extra_len(start..end));
            let (v, rest_v) = rest.split_at_mut(end - start);
            (nodes, weights, extras, rest) = (rest_n, rest_w, rest_x, rest_v);
            blocks.push((start..end, n, w, x, v));
        }
        blocks
            .into_par_iter()
            .for_each(|(rows, mut n, mut w, mut x, block_values)| {
                let mut scratch = init();
                for (p, value) in rows.zip(block_values) {
                    let len = offsets[p + 1] - offsets[p];
                    let (row_n, rest_n) = std::mem::take(&mut n).split_at_mut(len);
                    let (row_w, rest_w) = std::mem::take(&mut w).split_at_mut(len);
                    let (row_x, rest_x) = std::mem::take(&mut x).split_at_mut(extra_len(p..p + 1));
                    (n, w, x) = (rest_n, rest_w, rest_x);
                    *value = fill(&mut scratch, p, row_n, row_w, row_x);
                }
            });
        self.reset_fields();
    }

    /// Maps every entry to slot 0 (one velocity field per node).
    fn reset_fields(&mut self) {
        self.fields.resize(self.nodes.len(), 0);
        self.fields.par_iter_mut().for_each(|slot| *slot = 0);
    }

    /// Velocity-field slot of entry `e`.
    pub fn field(&self, e: usize) -> usize {
        self.fields[e] as usize
    }

    /// Particle-to-grid transfer into per-node accumulators: for every node, starting from
    /// `T::default()`, calls `add(&mut sum, entry, particle)` for each of its entries in particle
    /// order. In parallel over nodes, so the result does not depend on the number of threads.
    pub fn accumulate_to_nodes<T, F>(&self, out: &mut [T], add: F)
    where
        T: Default + Send,
        F: Fn(&mut T, usize, usize) + Sync,
    {
        out.par_iter_mut().enumerate().for_each(|(node, slot)| {
            let mut sum = T::default();
            for &(entry, particle) in self.entries_of_node(node) {
                add(&mut sum, entry as usize, particle as usize);
            }
            *slot = sum;
        });
    }

    /// The (entry, particle) pairs of node `node`'s transposed entries, in particle order;
    /// none for a node beyond the transpose (one no row reached when it was built).
    #[inline]
    pub fn entries_of_node(&self, node: usize) -> &[(u32, u32)] {
        let end = node
            .checked_add(1)
            .and_then(|next| self.node_offsets.get(next));
        match (self.node_offsets.get(node), end) {
            (Some(&start), Some(&end)) => &self.node_entries[start..end],
            _ => &[],
        }
    }

    /// Particle-to-grid transfer: `out[I] = Σ_(entries of I) contribution(entry, particle)`.
    ///
    /// Runs in parallel over nodes; each node sums its entries in particle order, so the result
    /// does not depend on the number of threads.
    pub fn scatter_to_nodes<T, F>(&self, out: &mut [T], contribution: F)
    where
        T: Default + AddAssign + Send,
        F: Fn(usize, usize) -> T + Sync,
    {
        out.par_iter_mut().enumerate().for_each(|(node, slot)| {
            let mut sum = T::default();
            for &(entry, particle) in self.entries_of_node(node) {
                sum += contribution(entry as usize, particle as usize);
            }
            *slot = sum;
        });
    }
}

#[cfg(test)]
mod fill_rows_tests {
    use super::*;
    use crate::dim::Two;
    use glam::{DMat2, DVec2};

    /// Rows filled with maps give eq. (8)'s gradients from them, in particle order and through
    /// the transpose, and rows filled with stored gradients afterwards drop the maps.
    #[test]
    fn mapped_rows_give_their_maps_gradients_until_rows_are_stored_again() {
        let node_positions = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(1.0, 1.0),
        ];
        let map = |p: usize| RowMap::<Two> {
            matrix: DMat2::from_cols(DVec2::new(2.0 + p as f64, 0.5), DVec2::new(0.5, 3.0)),
            point: DVec2::new(0.25 * p as f64, 0.5),
        };
        let mut c = Connectivity::<Two>::default();
        c.rebuild(&vec![vec![(0, 1.0, DVec2::new(9.0, 9.0))]; 5], 4);
        let values = c.fill_rows_mapped(
            3,
            &node_positions,
            |p| p + 2,
            || (),
            |_, p, nodes, weights, row_map| {
                for k in 0..nodes.len() {
                    (nodes[k], weights[k]) = (k as u32, 0.1 * (k + 1) as f64);
                }
                *row_map = map(p);
                p * 10
            },
        );
        assert_eq!(values, vec![0, 10, 20]);
        assert!(c.gradients.is_empty(), "no gradient is stored");
        for p in 0..3 {
            assert_eq!(c.row(p).len(), p + 2);
            for e in c.row(p) {
                let x_i = node_positions[c.nodes[e] as usize];
                let expected = -((map(p).matrix * (map(p).point - x_i)) * c.weights[e]);
                assert_eq!(c.gradient(e, p), expected);
            }
        }
        let through_transpose: usize = (0..4)
            .map(|node| c.node_offsets[node + 1] - c.node_offsets[node])
            .sum();
        assert_eq!(through_transpose, 2 + 3 + 4);
        c.rebuild(&vec![vec![(1, 1.0, DVec2::new(7.0, 7.0))]; 2], 4);
        assert!(c.row_maps.is_empty(), "stored rows drop the maps");
        assert_eq!(c.gradient(1, 1), DVec2::new(7.0, 7.0));
    }

    /// Rows of varying width over several blocks land in row order, each in its own range.
    #[test]
    fn rows_filled_in_place_land_in_row_order() {
        let particles = 2500;
        let width = |p: usize| p % 5;
        let entry = |p: usize, k: usize| {
            let node = ((p * 7 + k * 3) % 50) as u32;
            (node, (p + k) as f64, DVec2::new(k as f64, -(p as f64)))
        };
        let flat: Vec<(u32, f64, DVec2)> = (0..particles)
            .flat_map(|p| (0..width(p)).map(move |k| entry(p, k)))
            .collect();
        let mut offsets = vec![0];
        for p in 0..particles {
            offsets.push(offsets[p] + width(p));
        }
        let mut filled = Connectivity::<Two>::default();
        let values = filled.fill_rows(
            particles,
            50,
            width,
            || 0usize,
            |calls, p, n, w, g| {
                *calls += 1;
                for k in 0..n.len() {
                    (n[k], w[k], g[k]) = entry(p, k);
                }
                (p, *calls)
            },
        );
        assert_eq!(filled.row_offsets, offsets);
        assert_eq!(filled.nodes, flat.iter().map(|e| e.0).collect::<Vec<_>>());
        assert_eq!(filled.weights, flat.iter().map(|e| e.1).collect::<Vec<_>>());
        assert_eq!(
            filled.gradients,
            flat.iter().map(|e| e.2).collect::<Vec<_>>()
        );
        assert_eq!(filled.node_offsets[50], flat.len());
        // One value per row in row order; each block starts from a fresh scratch.
        assert_eq!(values.len(), particles);
        assert!(values.iter().enumerate().all(|(p, v)| v.0 == p));
        assert_eq!(values[1024].1, 1);
    }

    /// A kept buffer takes each fill's values in row order, every row overwritten, over
    /// several blocks and thread counts, as the tables do; the mapped rows the same.
    #[test]
    fn rows_filled_into_a_kept_buffer_overwrite_it_in_row_order() {
        let particles = 2100;
        let node_positions = [DVec2::ZERO, DVec2::X, DVec2::Y];
        let mut values = vec![(usize::MAX, 0usize); particles];
        for (fill, threads) in [(1usize, 1usize), (2, 3)] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut c = Connectivity::<Two>::default();
            pool.install(|| {
                c.fill_rows_into(
                    3,
                    |p| (p + fill) % 3,
                    || 0usize,
                    &mut values,
                    |calls, p, n, w, g| {
                        *calls += 1;
                        for k in 0..n.len() {
                            (n[k], w[k], g[k]) = (k as u32, fill as f64, DVec2::ZERO);
                        }
                        (p * fill, *calls)
                    },
                )
            });
            assert!(values.iter().enumerate().all(|(p, v)| v.0 == p * fill));
            // Each block of 1 024 rows starts from a fresh scratch.
            assert_eq!((values[1023].1, values[1024].1), (1024, 1));
            assert_eq!(c.node_offsets[3], c.nodes.len());
            assert_eq!(c.row(5).len(), (5 + fill) % 3);
            pool.install(|| {
                c.fill_rows_mapped_into(
                    &node_positions,
                    |p| 1 + p % 2,
                    || (),
                    &mut values,
                    |_, p, n, w, map| {
                        for k in 0..n.len() {
                            (n[k], w[k]) = (k as u32, 1.0 / n.len() as f64);
                        }
                        map.point = DVec2::splat(p as f64);
                        (p + fill, 0)
                    },
                )
            });
            assert!(values.iter().enumerate().all(|(p, v)| *v == (p + fill, 0)));
            assert_eq!(c.row_maps.len(), particles);
            assert_eq!(c.row_maps[7].point, DVec2::splat(7.0));
            assert!(c.gradients.is_empty());
        }
    }

    /// The transpose lists each node's entries in particle order, whatever the thread count.
    #[test]
    fn the_transpose_lists_each_nodes_entries_in_particle_order() {
        let (particles, nodes) = (3000, 97);
        let rows: Vec<Vec<(u32, f64, DVec2)>> = (0..particles)
            .map(|p| {
                (0..1 + p % 6)
                    .map(|k| (((p / 7 + k * 13) % nodes) as u32, 1.0, DVec2::ZERO))
                    .collect()
            })
            .collect();
        let mut expected = Vec::new();
        for node in 0..nodes as u32 {
            let mut entry = 0u32;
            for (p, row) in rows.iter().enumerate() {
                for &(n, _, _) in row {
                    if n == node {
                        expected.push((entry, p as u32));
                    }
                    entry += 1;
                }
            }
        }
        for threads in 1..=5 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut c = Connectivity::<Two>::default();
            pool.install(|| c.rebuild(&rows, nodes));
            assert_eq!(c.node_entries, expected, "{threads} threads");
            assert_eq!(c.node_offsets.len(), nodes + 1);
            assert_eq!(c.node_offsets[nodes], expected.len());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::Two;
    use glam::DVec2;

    fn sample() -> Connectivity<Two> {
        let mut c = Connectivity::default();
        let g = DVec2::ZERO;
        c.rebuild(
            &[
                vec![(0, 0.5, g), (2, 0.5, g)],
                vec![(2, 1.0, g)],
                vec![(1, 0.25, g), (0, 0.75, g)],
            ],
            3,
        );
        c
    }

    #[test]
    fn transpose_lists_entries_per_node_in_particle_order() {
        let c = sample();
        assert_eq!(c.node_offsets, vec![0, 2, 3, 5]);
        assert_eq!(c.node_entries, vec![(0, 0), (4, 2), (3, 2), (1, 0), (2, 1)]);
        assert_eq!(c.entries_of_node(1), &[(3, 2)]);
        assert_eq!(c.entries_of_node(2), &[(1, 0), (2, 1)]);
        // A node beyond the transpose (the grid grew, no row reached it) has no entries.
        assert!(c.entries_of_node(3).is_empty());
        assert!(c.entries_of_node(usize::MAX).is_empty());
    }

    #[test]
    fn scatter_sums_weighted_particle_values() {
        let c = sample();
        let masses = [2.0, 4.0, 8.0];
        let mut node_mass = vec![0.0; 3];
        c.scatter_to_nodes(&mut node_mass, |e, p| c.weights[e] * masses[p]);
        assert_eq!(
            node_mass,
            vec![0.5 * 2.0 + 0.75 * 8.0, 0.25 * 8.0, 0.5 * 2.0 + 4.0]
        );
        assert_eq!(node_mass.iter().sum::<f64>(), masses.iter().sum::<f64>());
    }
}
