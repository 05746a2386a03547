//! ε-neighbourhoods of the particles, written by the neighbour stage, read by non-local damage.
//!
//! Lists are sorted ascending, without duplicates, and each particle's own row **is included**
//! in its list (the sums of eqs. 11–15 of eigensoftening-lme-mpm.md run over every particle
//! within ε of `x_p`, `p` itself among them).
//!
//! Storage is compressed rows split into fixed blocks of rows, each block one buffer: the
//! builders fill the blocks in parallel, in place, and the buffers keep their capacity from
//! step to step, so refilling the lists neither allocates nor copies them.

use bevy_ecs::prelude::Resource;
use rayon::prelude::*;

/// Rows per block: fixed, so the work split (and so the result) does not depend on the thread
/// count.
const ROWS_PER_BLOCK: usize = 512;

/// ε-neighbourhood of every particle row.
#[derive(Resource, Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Neighbourhoods {
    /// Radius ε the lists were filtered with.
    pub radius: f64,
    /// End of each row's list inside its block's buffer (a row starts where the previous row
    /// of its block ends, or at 0).
    ends: Vec<u32>,
    /// One buffer per block of [`ROWS_PER_BLOCK`] rows.
    blocks: Vec<Vec<u32>>,
    /// Times the underlying search structure has been rebuilt (for cost reporting).
    pub rebuilds: u64,
}

impl PartialEq for Neighbourhoods {
    /// Same radius, rebuild count and lists (whatever capacity the buffers hold).
    fn eq(&self, other: &Self) -> bool {
        self.radius == other.radius
            && self.rebuilds == other.rebuilds
            && self.particle_count() == other.particle_count()
            && (0..self.particle_count()).all(|p| self.of(p) == other.of(p))
    }
}

impl Neighbourhoods {
    /// Bytes of the lists (row ends and entries), for the traffic count of
    /// [`crate::traffic`].
    pub fn heap_bytes(&self) -> f64 {
        let entries: usize = self.blocks.iter().map(Vec::len).sum();
        (4 * (self.ends.len() + entries)) as f64
    }

    /// Number of particle rows.
    pub fn particle_count(&self) -> usize {
        self.ends.len()
    }

    /// The neighbours of row `p` (itself included).
    pub fn of(&self, p: usize) -> &[u32] {
        let start = if p.is_multiple_of(ROWS_PER_BLOCK) {
            0
        } else {
            self.ends[p - 1] as usize
        };
        &self.blocks[p / ROWS_PER_BLOCK][start..self.ends[p] as usize]
    }

    /// Total number of entries over all rows.
    pub fn entry_count(&self) -> usize {
        self.blocks[..self.particle_count().div_ceil(ROWS_PER_BLOCK)]
            .iter()
            .map(Vec::len)
            .sum()
    }

    /// Replaces the lists from per-row lists (each sorted, self included).
    pub fn set_rows(&mut self, rows: &[Vec<u32>], radius: f64) {
        self.fill_rows(rows.len(), radius, |p, out| out.extend_from_slice(&rows[p]));
    }

    /// Replaces the lists with `rows` rows built in parallel: `row(p, out)` appends the
    /// neighbours of row `p` to `out` (sorted, self included) and must not touch what is
    /// already there. Each block of rows is filled into its own buffer, in place, so the
    /// result is the same for any thread count.
    pub fn fill_rows(
        &mut self,
        rows: usize,
        radius: f64,
        row: impl Fn(usize, &mut Vec<u32>) + Sync,
    ) {
        self.radius = radius;
        let blocks = rows.div_ceil(ROWS_PER_BLOCK);
        if self.blocks.len() < blocks {
            self.blocks.resize_with(blocks, Vec::new);
        }
        self.ends.resize(rows, 0);
        self.blocks[..blocks]
            .par_iter_mut()
            .zip(self.ends.par_chunks_mut(ROWS_PER_BLOCK))
            .enumerate()
            .for_each(|(b, (buffer, ends))| {
                buffer.clear();
                for (k, end) in ends.iter_mut().enumerate() {
                    row(b * ROWS_PER_BLOCK + k, buffer);
                    *end = u32::try_from(buffer.len())
                        .expect("a block of neighbour lists holds more than 2^32 entries");
                }
            });
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
        assert_eq!(n.entry_count(), 7);
    }

    /// Rows spanning several blocks, refilled with fewer and then more entries and rows, read
    /// back as given.
    #[test]
    fn rows_filled_in_blocks_read_back_as_given() {
        let expected = |p: usize, width: usize, rows: usize| -> Vec<u32> {
            (p.saturating_sub(width)..(p + width + 1).min(rows))
                .map(|q| q as u32)
                .collect()
        };
        let mut filled = Neighbourhoods::default();
        for (width, rows) in [
            (3, 2 * ROWS_PER_BLOCK + 7),
            (0, ROWS_PER_BLOCK),
            (5, 3 * ROWS_PER_BLOCK + 1),
        ] {
            filled.fill_rows(rows, 0.5, |p, out| out.extend(expected(p, width, rows)));
            assert_eq!(filled.particle_count(), rows);
            for p in 0..rows {
                assert_eq!(filled.of(p), expected(p, width, rows), "row {p}");
            }
            let total: usize = (0..rows).map(|p| expected(p, width, rows).len()).sum();
            assert_eq!(filled.entry_count(), total);
        }
        filled.fill_rows(0, 0.5, |_, _| unreachable!());
        assert_eq!(filled.particle_count(), 0);
        assert_eq!(filled.entry_count(), 0);
    }
}
