//! ε-neighbourhoods of the particles, written by the neighbour stage, read by non-local damage.
//!
//! Lists are in compact CSR form over particle rows, sorted ascending, without duplicates, and
//! each particle's own row **is included** in its list (the sums of eqs. 11–15 of
//! eigensoftening-lme-mpm.md run over every particle within ε of `x_p`, `p` itself among them).

use bevy_ecs::prelude::Resource;

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
}
