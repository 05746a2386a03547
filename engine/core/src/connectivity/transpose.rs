//! The transposed table of [`Connectivity`]: for each node, its entries in particle order, built
//! in parallel over blocks of rows (a count of entries per node, a running sum, then each block
//! placing its entries), so that a node's sum is accumulated in one order for any thread count.

use super::Connectivity;
use crate::dim::Dim;
use rayon::prelude::*;

/// Replaces `values` by their running sums, in parallel over fixed blocks (integers, so the
/// same as a serial scan).
pub(super) fn running_sum(values: &mut [usize]) {
    const BLOCK: usize = 4096;
    let totals: Vec<usize> = values
        .par_chunks_mut(BLOCK)
        .map(|block| {
            let mut running = 0;
            for value in block.iter_mut() {
                running += *value;
                *value = running;
            }
            running
        })
        .collect();
    values
        .par_chunks_mut(BLOCK)
        .zip(block_bases(&totals))
        .for_each(|(block, base)| block.iter_mut().for_each(|value| *value += base));
}

/// Where each block starts in a running sum: the sum of the totals of the blocks before it.
fn block_bases(totals: &[usize]) -> Vec<usize> {
    let mut base = 0;
    totals
        .iter()
        .map(|total| {
            base += total;
            base - total
        })
        .collect()
}

/// Rows per block of the parallel transpose ([`Connectivity::rebuild_transpose`]).
const TRANSPOSE_BLOCK: usize = 2048;

/// The parallel transpose's split: node ranges of `range_len`, the row blocks, and for each
/// range the blocks whose entries touch it.
struct TransposePlan {
    range_len: usize,
    ranges: Vec<std::ops::Range<usize>>,
    blocks: Vec<BlockSpan>,
    touching: Vec<Vec<usize>>,
}

/// One block of rows of the parallel transpose: its rows, its entries, and the lowest and
/// highest node they touch.
struct BlockSpan {
    rows: std::ops::Range<usize>,
    entries: std::ops::Range<usize>,
    lowest: usize,
    highest: usize,
}

impl<D: Dim> Connectivity<D> {
    /// Rebuilds the node-major transpose from the particle-major tables: for every node its
    /// entries in particle order, so the result is one and the same whatever the threads.
    ///
    /// On one thread, or where the rows are in no spatial order, a serial counting sort. On
    /// several, a parallel one over ranges of nodes: rows go in fixed blocks, each block notes
    /// the range of nodes its entries touch, and each node range counts and places the entries
    /// of the blocks that touch it, block by block. Particles created row by row and moving
    /// little keep each block within a few node rows, so a block is read by one or two ranges;
    /// where blocks spread over many ranges the serial sort is cheaper and is used instead.
    pub fn rebuild_transpose(&mut self, node_count: usize) {
        match self.transpose_plan(node_count) {
            Some(plan) => {
                let (blocks, touching) = (&plan.blocks, &plan.touching);
                self.count_entries_per_node(node_count, plan.range_len, blocks, touching);
                self.place_entries(&plan.ranges, blocks, touching);
            }
            None => self.rebuild_transpose_serially(node_count),
        }
    }

    /// How the transpose splits over the threads of the current pool; `None` where the serial
    /// sort is the faster (one thread, few rows, or rows in no spatial order).
    fn transpose_plan(&self, node_count: usize) -> Option<TransposePlan> {
        let threads = rayon::current_num_threads();
        let particles = self.particle_count();
        if threads == 1 || particles < 2 * TRANSPOSE_BLOCK || node_count < 2 * threads {
            return None;
        }
        let blocks = self.block_spans();
        // Ranges about four per thread, for balance; the result does not depend on them.
        let range_len = node_count.div_ceil(4 * threads);
        let ranges: Vec<std::ops::Range<usize>> = (0..node_count)
            .step_by(range_len)
            .map(|start| start..(start + range_len).min(node_count))
            .collect();
        let touching: Vec<Vec<usize>> = ranges
            .iter()
            .map(|r| {
                let touches = |b: &&BlockSpan| b.lowest < r.end && b.highest >= r.start;
                let hits = blocks.iter().enumerate().filter(|(_, b)| touches(b));
                hits.map(|(k, _)| k).collect()
            })
            .collect();
        let reads: usize = touching.iter().map(Vec::len).sum();
        (reads <= 3 * blocks.len() + ranges.len()).then_some(TransposePlan {
            range_len,
            ranges,
            blocks,
            touching,
        })
    }

    /// `node_offsets` from the entries of each node, counted range by range in parallel.
    fn count_entries_per_node(
        &mut self,
        node_count: usize,
        range_len: usize,
        blocks: &[BlockSpan],
        touching: &[Vec<usize>],
    ) {
        let nodes = &self.nodes;
        let mut offsets = std::mem::take(&mut self.node_offsets);
        offsets.clear();
        offsets.resize(node_count + 1, 0);
        // offsets[n + 1] = entries of node n, then a running sum within each range.
        let totals: Vec<usize> = offsets[1..]
            .par_chunks_mut(range_len)
            .zip(touching)
            .enumerate()
            .map(|(k, (counts, touching))| {
                let start = k * range_len;
                for &b in touching {
                    for &node in &nodes[blocks[b].entries.clone()] {
                        if let Some(count) = (node as usize)
                            .checked_sub(start)
                            .and_then(|i| counts.get_mut(i))
                        {
                            *count += 1;
                        }
                    }
                }
                let mut running = 0;
                for count in counts.iter_mut() {
                    running += *count;
                    *count = running;
                }
                running
            })
            .collect();
        offsets[1..]
            .par_chunks_mut(range_len)
            .zip(block_bases(&totals))
            .for_each(|(ends, base)| ends.iter_mut().for_each(|end| *end += base));
        self.node_offsets = offsets;
    }

    /// `node_entries` from `node_offsets`: each range of nodes places, in parallel with the
    /// others, the entries of the blocks that touch it, in block and row order.
    fn place_entries(
        &mut self,
        ranges: &[std::ops::Range<usize>],
        blocks: &[BlockSpan],
        touching: &[Vec<usize>],
    ) {
        self.node_entries.resize(self.nodes.len(), (0, 0));
        let (offsets, nodes, row_offsets) = (&self.node_offsets, &self.nodes, &self.row_offsets);
        let mut rest = &mut self.node_entries[..];
        let mut parts = Vec::with_capacity(ranges.len());
        for range in ranges {
            let (part, tail) = rest.split_at_mut(offsets[range.end] - offsets[range.start]);
            rest = tail;
            parts.push(part);
        }
        parts
            .into_par_iter()
            .zip(ranges)
            .zip(touching)
            .for_each(|((part, range), touching)| {
                let base = offsets[range.start];
                let mut cursor: Vec<usize> =
                    offsets[range.clone()].iter().map(|o| o - base).collect();
                for &b in touching {
                    for p in blocks[b].rows.clone() {
                        let first = row_offsets[p];
                        let row = &nodes[first..row_offsets[p + 1]];
                        for (entry, &node) in (first..).zip(row) {
                            let node = node as usize;
                            if range.contains(&node) {
                                let slot = &mut cursor[node - range.start];
                                part[*slot] = (entry as u32, p as u32);
                                *slot += 1;
                            }
                        }
                    }
                }
            });
    }

    /// The rows of each block of [`TRANSPOSE_BLOCK`], their entries and the nodes they touch.
    fn block_spans(&self) -> Vec<BlockSpan> {
        let particles = self.particle_count();
        (0..particles.div_ceil(TRANSPOSE_BLOCK))
            .into_par_iter()
            .map(|k| {
                let rows = k * TRANSPOSE_BLOCK..((k + 1) * TRANSPOSE_BLOCK).min(particles);
                let entries = self.row_offsets[rows.start]..self.row_offsets[rows.end];
                let touched = &self.nodes[entries.clone()];
                let lowest = touched.iter().copied().min().unwrap_or(u32::MAX) as usize;
                let highest = touched.iter().copied().max().unwrap_or(0) as usize;
                BlockSpan {
                    rows,
                    entries,
                    lowest,
                    highest,
                }
            })
            .collect()
    }

    /// The counting sort on the calling thread.
    fn rebuild_transpose_serially(&mut self, node_count: usize) {
        let mut counts = vec![0usize; node_count + 1];
        for &node in &self.nodes {
            counts[node as usize + 1] += 1;
        }
        for i in 0..node_count {
            counts[i + 1] += counts[i];
        }
        self.node_offsets.clone_from(&counts);
        // Every slot is overwritten below: only the length needs setting.
        self.node_entries.resize(self.nodes.len(), (0, 0));
        let mut cursor = counts;
        for p in 0..self.particle_count() {
            for entry in self.row(p) {
                let node = self.nodes[entry] as usize;
                self.node_entries[cursor[node]] = (entry as u32, p as u32);
                cursor[node] += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::connectivity::Connectivity;
    use crate::dim::Two;
    use glam::DVec2;

    /// Rows of a lattice of particles over a grid of `nx` nodes per row, in `order`.
    fn lattice_rows(nx: usize, order: impl Fn(usize) -> usize) -> Vec<Vec<(u32, f64, DVec2)>> {
        let particles = 4 * (nx - 1) * (nx - 1);
        (0..particles)
            .map(|k| {
                let p = order(k);
                let (i, j) = ((p % (2 * (nx - 1))) / 2, p / (4 * (nx - 1)));
                let corner = i + j * nx;
                [corner, corner + 1, corner + nx, corner + nx + 1]
                    .iter()
                    .map(|&n| (n as u32, 0.25, DVec2::ZERO))
                    .collect()
            })
            .collect()
    }

    fn transposed(
        rows: &[Vec<(u32, f64, DVec2)>],
        nodes: usize,
        threads: usize,
    ) -> Connectivity<Two> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut c = Connectivity::default();
            c.rebuild(rows, nodes);
            c
        })
    }

    #[test]
    fn the_parallel_transpose_is_the_serial_one() {
        let nx = 101;
        let nodes = nx * nx;
        // Row by row, as bodies are seeded; then scrambled, which takes the serial fallback.
        let seeded = lattice_rows(nx, |k| k);
        let particles = seeded.len();
        let scrambled = lattice_rows(nx, |k| (k * 7919) % particles);
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let plan =
            |rows| two.install(|| transposed(rows, nodes, 1).transpose_plan(nodes).is_some());
        assert!(plan(&seeded), "seeded rows go in parallel");
        assert!(!plan(&scrambled), "scrambled rows take the serial sort");
        for rows in [&seeded, &scrambled] {
            let one = transposed(rows, nodes, 1);
            for threads in [2, 3, 8] {
                let many = transposed(rows, nodes, threads);
                assert_eq!(many.node_offsets, one.node_offsets, "{threads} threads");
                assert_eq!(many.node_entries, one.node_entries, "{threads} threads");
            }
        }
        // Every node's entries in particle order.
        let c = transposed(&seeded, nodes, 4);
        for node in 0..nodes {
            let slots = &c.node_entries[c.node_offsets[node]..c.node_offsets[node + 1]];
            assert!(slots.windows(2).all(|w| w[0].1 < w[1].1));
            assert!(
                slots
                    .iter()
                    .all(|&(e, _)| c.nodes[e as usize] as usize == node)
            );
        }
    }
}
