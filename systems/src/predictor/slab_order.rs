//! The particles' order for `predictor/mls`'s scatter (not a system): particle indices bucketed
//! by slab of node rows, each slab in index order (a stable counting sort), sorted by
//! `basis/mls` every step.
//!
//! - **Serial** below [`PARALLEL_SORT_MIN`] particles: one pass counts each slab, a prefix sum
//!   gives where each starts, a second pass places the indices.
//! - **Parallel** above it: the particles are cut into chunks of [`SORT_CHUNK`]; each chunk
//!   sorts its own indices by slab into a buffer, over the range of slabs it touches; then each
//!   slab gathers its pieces from the chunks that touch it, in chunk order. Each slab's list is
//!   then the serial sort's, index for index, whatever the number of threads. A chunk's counts
//!   span the slabs it touches, so particles in spatial order (seeded row by row, and they
//!   keep their order) cost a few counters a chunk. At a million particles the serial sort was
//!   the largest serial section of the MLS step (`benches/serial_share.py`).

use rayon::prelude::*;

/// Rows of base nodes (along the last axis) in one slab of `predictor/mls`'s scatter; two is
/// the least for which slabs two apart share no node.
pub const SLAB_ROWS: usize = 2;

/// Particles from which [`SlabOrder::sort`] runs in parallel.
pub const PARALLEL_SORT_MIN: usize = 1 << 16;

/// Particles per chunk of the parallel sort.
pub const SORT_CHUNK: usize = 4096;

/// The particles' order for the scatter: indices bucketed by slab (a stable counting sort)
/// and the bucket boundaries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SlabOrder {
    /// Particle indices, slab by slab, each slab in index order.
    pub order: Vec<u32>,
    /// `order[offsets[s]..offsets[s + 1]]` is slab `s`.
    pub offsets: Vec<usize>,
    /// The parallel sort's chunk-sorted indices (kept between steps, not part of the order).
    chunked: Vec<u32>,
}

/// One chunk's indices sorted by slab: the first slab it touches and where each touched slab
/// starts in the chunk's part of the buffer (`starts[k]..starts[k + 1]` is slab `first + k`).
#[derive(Debug)]
struct ChunkSlabs {
    first: usize,
    starts: Vec<u32>,
}

impl ChunkSlabs {
    /// The range, within the chunk, of slab `s` (empty where the chunk does not touch it).
    fn range(&self, s: usize) -> std::ops::Range<usize> {
        match s.checked_sub(self.first) {
            Some(k) if k + 1 < self.starts.len() => {
                self.starts[k] as usize..self.starts[k + 1] as usize
            }
            _ => 0..0,
        }
    }
}

/// The slab of a particle in row `row`, or `None` for one left out (`u32::MAX`).
#[inline]
fn slab_of(row: u32) -> Option<usize> {
    (row != u32::MAX).then_some(row as usize / SLAB_ROWS)
}

/// Sorts one chunk of particles (`rows`, the first with index `start`) by slab into `out`.
fn sort_chunk(rows: &[u32], start: usize, out: &mut [u32]) -> ChunkSlabs {
    let slabs = || rows.iter().filter_map(|&r| slab_of(r));
    let (Some(first), Some(last)) = (slabs().min(), slabs().max()) else {
        return ChunkSlabs {
            first: 0,
            starts: vec![0],
        };
    };
    let mut starts = vec![0u32; last - first + 2];
    for s in slabs() {
        starts[s - first + 1] += 1;
    }
    for k in 1..starts.len() {
        starts[k] += starts[k - 1];
    }
    let mut cursor = starts.clone();
    for (i, &row) in rows.iter().enumerate() {
        if let Some(s) = slab_of(row) {
            let at = &mut cursor[s - first];
            out[*at as usize] = (start + i) as u32;
            *at += 1;
        }
    }
    ChunkSlabs { first, starts }
}

impl SlabOrder {
    /// Buckets particles by `rows[p] / SLAB_ROWS` (`u32::MAX`: left out) into `slabs` slabs,
    /// in parallel from [`PARALLEL_SORT_MIN`] particles; the result is the same either way.
    pub fn sort(&mut self, rows: &[u32], slabs: usize) {
        if rows.len() < PARALLEL_SORT_MIN {
            self.sort_serial(rows, slabs);
        } else {
            self.sort_parallel(rows, slabs);
        }
    }

    /// The serial counting sort.
    pub fn sort_serial(&mut self, rows: &[u32], slabs: usize) {
        self.offsets.clear();
        self.offsets.resize(slabs + 2, 0);
        for s in rows.iter().filter_map(|&r| slab_of(r)) {
            self.offsets[s + 2] += 1;
        }
        for s in 2..self.offsets.len() {
            self.offsets[s] += self.offsets[s - 1];
        }
        self.order.resize(self.offsets[slabs + 1], 0);
        for (p, &row) in rows.iter().enumerate() {
            if let Some(s) = slab_of(row) {
                let cursor = &mut self.offsets[s + 1];
                self.order[*cursor] = p as u32;
                *cursor += 1;
            }
        }
        self.offsets.truncate(slabs + 1);
    }

    /// The parallel counting sort: chunks sorted on their own, then each slab gathered from
    /// the chunks in chunk order (see the module's header).
    pub fn sort_parallel(&mut self, rows: &[u32], slabs: usize) {
        self.chunked.resize(rows.len(), 0);
        let chunks: Vec<ChunkSlabs> = rows
            .par_chunks(SORT_CHUNK)
            .zip(self.chunked.par_chunks_mut(SORT_CHUNK))
            .enumerate()
            .map(|(c, (rows, out))| sort_chunk(rows, c * SORT_CHUNK, out))
            .collect();
        self.offsets.clear();
        self.offsets.resize(slabs + 1, 0);
        for chunk in &chunks {
            for k in 0..chunk.starts.len() - 1 {
                self.offsets[chunk.first + k + 1] +=
                    (chunk.starts[k + 1] - chunk.starts[k]) as usize;
            }
        }
        for s in 1..self.offsets.len() {
            self.offsets[s] += self.offsets[s - 1];
        }
        self.order.resize(self.offsets[slabs], 0);
        let mut pieces = Vec::with_capacity(slabs);
        let mut rest = &mut self.order[..];
        for s in 0..slabs {
            let (piece, tail) = rest.split_at_mut(self.offsets[s + 1] - self.offsets[s]);
            pieces.push(piece);
            rest = tail;
        }
        let chunked = &self.chunked;
        pieces.into_par_iter().enumerate().for_each(|(s, piece)| {
            let mut at = 0;
            for (c, chunk) in chunks.iter().enumerate() {
                let range = chunk.range(s);
                let from = &chunked[c * SORT_CHUNK..][range];
                piece[at..at + from.len()].copy_from_slice(from);
                at += from.len();
            }
        });
    }

    /// The particles of slab `s`.
    pub fn slab(&self, s: usize) -> &[u32] {
        &self.order[self.offsets[s]..self.offsets[s + 1]]
    }

    /// Number of slabs.
    pub fn slabs(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of `n` particles: mostly in spatial order with some scattered and some left out,
    /// over `rows` node rows.
    fn rows_of(n: usize, rows: u32) -> Vec<u32> {
        let mut state = 12345u64;
        (0..n)
            .map(|p| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                match state >> 60 {
                    0 => u32::MAX,
                    1 => (state >> 20) as u32 % rows,
                    _ => (p as u64 * rows as u64 / n as u64) as u32,
                }
            })
            .collect()
    }

    #[test]
    fn the_parallel_sort_is_the_serial_sort() {
        for (n, rows) in [
            (0, 4),
            (1, 4),
            (SORT_CHUNK + 7, 9),
            (3 * SORT_CHUNK, 300),
            (70_000, 500),
        ] {
            let rows = rows_of(n, rows);
            let slabs = 250;
            let (mut serial, mut parallel) = (SlabOrder::default(), SlabOrder::default());
            serial.sort_serial(&rows, slabs);
            parallel.sort_parallel(&rows, slabs);
            assert_eq!(parallel.order, serial.order, "{n} particles");
            assert_eq!(parallel.offsets, serial.offsets, "{n} particles");
        }
    }

    #[test]
    fn each_slab_holds_its_particles_in_index_order() {
        let rows = [6, 0, 2, u32::MAX, 5, 0, 3];
        let mut order = SlabOrder::default();
        order.sort(&rows, 4);
        assert_eq!(order.order, vec![1, 5, 2, 6, 4, 0]);
        assert_eq!(order.offsets, vec![0, 2, 4, 5, 6]);
        assert_eq!(order.slab(1), &[2, 6]);
        assert_eq!(order.slabs(), 4);
    }
}
