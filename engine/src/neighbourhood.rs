//! ε-neighbourhoods of the particles, written by the neighbour stage, read by non-local damage.
//!
//! Lists are in compact CSR form over particle rows, sorted ascending, without duplicates, and
//! each particle's own row **is included** in its list (the sums of eqs. 11–15 of
//! eigensoftening-lme-mpm.md run over every particle within ε of `x_p`, `p` itself among them).

use bevy_ecs::prelude::Resource;
use rayon::prelude::*;

/// Rows per block of [`Neighbourhoods::fill_rows`]: fixed, so the work split (and so the
/// result) does not depend on the thread count.
const ROWS_PER_BLOCK: usize = 512;

/// Reusable per-block buffers of [`Neighbourhoods::fill_rows`], kept by the caller between
/// steps so that refilling the lists allocates nothing once they have reached their size.
#[derive(Clone, Debug, Default)]
pub struct RowBlocks {
    blocks: Vec<Vec<u32>>,
}

/// ε-neighbourhood of every particle row.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct Neighbourhoods {
    /// Radius ε the lists were filtered with.
    pub radius: f64,
    /// Row offsets: the neighbours of row `p` are `list[offsets[p]..offsets[p + 1]]`.
    pub offsets: Vec<usize>,
    /// Neighbour particle rows.
    pub list: Vec<u32>,
    /// Times the underlying search structure has been rebuilt (for cost reporting).
    pub rebuilds: u64,
}

impl Neighbourhoods {
    /// Number of particle rows.
    pub fn particle_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The neighbours of row `p` (itself included).
    pub fn of(&self, p: usize) -> &[u32] {
        &self.list[self.offsets[p]..self.offsets[p + 1]]
    }

    /// Replaces the lists from per-row lists (each sorted, self included).
    pub fn set_rows(&mut self, rows: &[Vec<u32>], radius: f64) {
        self.radius = radius;
        self.offsets.clear();
        self.offsets.push(0);
        self.list.clear();
        for row in rows {
            self.list.extend_from_slice(row);
            self.offsets.push(self.list.len());
        }
    }

    /// Replaces the lists with `rows` rows built in parallel: `row(p, out)` appends the
    /// neighbours of row `p` to `out` (sorted, self included) and must not touch what is
    /// already there. Rows are built in fixed blocks into `scratch`, then copied in place, so
    /// nothing is allocated per row and the result is the same for any thread count.
    pub fn fill_rows(
        &mut self,
        rows: usize,
        radius: f64,
        scratch: &mut RowBlocks,
        row: impl Fn(usize, &mut Vec<u32>) + Sync,
    ) {
        self.radius = radius;
        let blocks = rows.div_ceil(ROWS_PER_BLOCK);
        scratch.blocks.resize_with(blocks, Vec::new);
        let buffers = &mut scratch.blocks[..blocks];
        self.offsets.resize(rows + 1, 0);
        self.offsets[0] = 0;
        // Each block's row ends, relative to the block's own buffer.
        buffers
            .par_iter_mut()
            .zip(self.offsets[1..].par_chunks_mut(ROWS_PER_BLOCK))
            .enumerate()
            .for_each(|(b, (buffer, ends))| {
                buffer.clear();
                for (k, end) in ends.iter_mut().enumerate() {
                    row(b * ROWS_PER_BLOCK + k, buffer);
                    *end = buffer.len();
                }
            });
        let mut start = 0;
        for (buffer, ends) in buffers
            .iter()
            .zip(self.offsets[1..].chunks_mut(ROWS_PER_BLOCK))
        {
            ends.iter_mut().for_each(|end| *end += start);
            start += buffer.len();
        }
        self.list.resize(start, 0);
        let mut segments = Vec::with_capacity(blocks);
        let mut rest = self.list.as_mut_slice();
        for buffer in buffers.iter() {
            let (segment, tail) = rest.split_at_mut(buffer.len());
            segments.push(segment);
            rest = tail;
        }
        segments
            .into_par_iter()
            .zip(buffers.par_iter())
            .for_each(|(segment, buffer)| segment.copy_from_slice(buffer));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip() {
        let mut n = Neighbourhoods::default();
        n.set_rows(&[vec![0, 1], vec![0, 1, 2], vec![1, 2]], 0.5);
        assert_eq!(n.particle_count(), 3);
        assert_eq!(n.of(1), &[0, 1, 2]);
        assert_eq!(n.of(2), &[1, 2]);
    }

    /// Rows spanning several blocks, refilled with fewer and then more entries, equal the same
    /// rows set one by one.
    #[test]
    fn rows_filled_in_blocks_equal_rows_set_one_by_one() {
        let rows = 2 * ROWS_PER_BLOCK + 7;
        let expected = |p: usize, width: usize| -> Vec<u32> {
            (p.saturating_sub(width)..(p + width + 1).min(rows))
                .map(|q| q as u32)
                .collect()
        };
        let mut scratch = RowBlocks::default();
        let mut filled = Neighbourhoods::default();
        for width in [3, 0, 5] {
            filled.fill_rows(rows, 0.5, &mut scratch, |p, out| {
                out.extend(expected(p, width))
            });
            let mut reference = Neighbourhoods::default();
            let lists: Vec<Vec<u32>> = (0..rows).map(|p| expected(p, width)).collect();
            reference.set_rows(&lists, 0.5);
            assert_eq!(filled, reference, "half-width {width}");
        }
        filled.fill_rows(0, 0.5, &mut scratch, |_, _| unreachable!());
        assert_eq!(filled.particle_count(), 0);
        assert!(filled.list.is_empty());
    }
}
