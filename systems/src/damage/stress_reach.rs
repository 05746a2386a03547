//! Where the non-local equivalent stress can reach the strength (not a system).
//!
//! `damage/eigensoftening` needs the equivalent stress of eq. (15) of eigensoftening-lme-mpm.md
//! only for intact particles, and only to compare it with `f_t`. That stress is a mean of the
//! intact neighbours' largest principal stresses weighted by mass, over the mass of the whole
//! neighbourhood or of its intact part (`average: Intact`): either way it never exceeds the
//! largest of them, nor zero. [`StressReach`] bins the
//! particles in squares (cubes) of side slightly above ε over their bounding box. Every
//! neighbour of a particle lies within ε, so in the particle's bin or an adjacent one, and the
//! largest value over the 3^d bins around a particle bounds the largest over its neighbourhood.
//! Where that bound, widened by the rounding of the sum ([`StressReach::may_reach`]), is below
//! `f_t`, the computed sum would be too: skipping it changes no result, bit for bit.
//!
//! The bins are built from the positions at the damage stage, the lists from those at the
//! neighbour stage; in between no stock system moves particles (only advection does).

use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Bins are this much wider than ε, so that rounding in `(x − lo)/side` cannot put two
/// particles within ε two bins apart.
const SIDE_OVER_RADIUS: f64 = 1.01;

/// Above this many bins per particle (a few particles spread over a huge box with a tiny ε)
/// the bins would cost more than they save: every particle is then evaluated.
const MAX_BINS_PER_PARTICLE: usize = 4;

/// Per-bin bounds of the values within reach, rebuilt every step into reused buffers.
#[derive(Clone, Debug, Default)]
pub struct StressReach<D: Dim> {
    lo: D::Vector,
    side: f64,
    counts: [usize; 3],
    /// Per bin, over the 3^d bins around it: the largest value (at least 0) and the largest
    /// magnitude.
    bounds: Vec<(f64, f64)>,
    scratch: Vec<(f64, f64)>,
    /// Each particle's bin, found on the pool's threads before the bounds are gathered.
    particle_bins: Vec<usize>,
    active: bool,
}

impl<D: Dim> StressReach<D> {
    /// Rebuilds the bounds for particles at `positions` whose neighbours lie within `radius`,
    /// each carrying `values[p]` (the largest principal stress of an intact particle, 0 for a
    /// failed one, which adds nothing to the sum). Bounds are off (every particle may reach)
    /// when there is nothing to bin, the radius is not positive, a value or position is not
    /// finite, or the bins would outnumber the particles by far.
    pub fn refill(&mut self, positions: &[Position<D>], values: &[f64], radius: f64) {
        self.active =
            self.bin_layout(positions, radius) && values.par_iter().all(|v| v.is_finite());
        if !self.active {
            return;
        }
        let bins = self.counts.iter().product::<usize>();
        self.bounds.clear();
        self.bounds.resize(bins, (0.0, 0.0));
        // The bins on the pool's threads (a division and a floor per axis: most of the work);
        // the largest of each bin's values on one, since bins are shared (a max is exact in
        // any order, so the bounds are the same either way).
        let mut particle_bins = std::mem::take(&mut self.particle_bins);
        particle_bins.resize(positions.len(), 0);
        let this = &*self;
        (particle_bins.par_iter_mut())
            .zip(positions)
            .for_each(|(bin, x)| *bin = this.bin_of(x.0));
        for (&index, &value) in particle_bins.iter().zip(values) {
            let bin = &mut self.bounds[index];
            bin.0 = bin.0.max(value);
            bin.1 = bin.1.max(value.abs());
        }
        self.particle_bins = particle_bins;
        for axis in 0..D::N {
            self.dilate_along(axis);
        }
    }

    /// True unless the computed equivalent stress of a particle at `x` with `neighbours`
    /// neighbours is certainly below `strength`.
    ///
    /// With `M` the largest value and `A` the largest magnitude within reach, the exact sum is
    /// at most `M` times the total mass; recursive summation of `n` terms errs by at most
    /// `γ_n = n u/(1 − n u)` (u the unit round-off) times the sum of magnitudes, at most `A`
    /// times the total mass, and the division adds one rounding. So the computed stress is at
    /// most `(M + g A)(1 + 2g)` with `g = (n + 2)·2u ≥ 2γ_{n+1}`.
    pub fn may_reach(&self, x: D::Vector, neighbours: usize, strength: f64) -> bool {
        if !self.active {
            return true;
        }
        let (largest, magnitude) = self.bounds[self.bin_of(x)];
        let g = (neighbours as f64 + 2.0) * f64::EPSILON;
        (largest + g * magnitude) * (1.0 + 2.0 * g) >= strength
    }

    /// Sets the bins over the particles' bounding box; false when binning is off.
    fn bin_layout(&mut self, positions: &[Position<D>], radius: f64) -> bool {
        if positions.is_empty() || !(radius.is_finite() && radius > 0.0) {
            return false;
        }
        let first = (positions[0].0, positions[0].0);
        let (lo, hi) = positions
            .par_iter()
            .fold(|| first, |(lo, hi), x| (lo.min(x.0), hi.max(x.0)))
            .reduce(|| first, |a, b| (a.0.min(b.0), a.1.max(b.1)));
        if !(lo.is_finite() && hi.is_finite()) {
            return false;
        }
        self.lo = lo;
        self.side = SIDE_OVER_RADIUS * radius;
        self.counts = [1; 3];
        let mut bins = 1usize;
        for a in 0..D::N {
            let count = ((hi[a] - lo[a]) / self.side).floor() + 1.0;
            if count > (MAX_BINS_PER_PARTICLE * positions.len()) as f64 {
                return false;
            }
            self.counts[a] = count as usize;
            bins = bins.saturating_mul(self.counts[a]);
        }
        bins <= MAX_BINS_PER_PARTICLE * positions.len()
    }

    /// Linear index of the bin holding `x` (clamped into the box).
    fn bin_of(&self, x: D::Vector) -> usize {
        let mut index = 0;
        for a in (0..D::N).rev() {
            let k = ((x[a] - self.lo[a]) / self.side).floor().max(0.0) as usize;
            index = index * self.counts[a] + k.min(self.counts[a] - 1);
        }
        index
    }

    /// Replaces every bin's bounds by the largest over it and its two neighbours along `axis`.
    fn dilate_along(&mut self, axis: usize) {
        let stride: usize = self.counts[..axis].iter().product();
        let count = self.counts[axis];
        if count < 2 {
            return;
        }
        self.scratch.clone_from(&self.bounds);
        let widest = |a: (f64, f64), b: (f64, f64)| (a.0.max(b.0), a.1.max(b.1));
        for (bin, bound) in self.bounds.iter_mut().enumerate() {
            let k = (bin / stride) % count;
            if k > 0 {
                *bound = widest(*bound, self.scratch[bin - stride]);
            }
            if k + 1 < count {
                *bound = widest(*bound, self.scratch[bin + stride]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::eigensoftening::{Average, equivalent_stress};

    /// A small deterministic generator, so the test needs no extra crate.
    fn uniform(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Brute force: for random particles, every skipped particle's computed equivalent stress
    /// is below the strength, and the bound is not vacuous (it skips some).
    fn never_skips_a_particle_that_reaches<D: Dim>() {
        let mut state = 7;
        let n = 400;
        let radius = if D::N == 2 { 0.07 } else { 0.15 };
        let positions: Vec<Position<D>> = (0..n)
            .map(|_| Position(D::Vector::from_fn(|_| uniform(&mut state))))
            .collect();
        let mass: Vec<Mass> = (0..n).map(|_| Mass(0.5 + uniform(&mut state))).collect();
        let damage: Vec<Damage> = (0..n)
            .map(|_| Damage(if uniform(&mut state) < 0.1 { 1.0 } else { 0.0 }))
            .collect();
        // Stresses rising along x, with noise and some large compressions.
        let principal: Vec<f64> = positions
            .iter()
            .map(|x| {
                let noise = uniform(&mut state) - 0.5;
                if noise > 0.45 {
                    -1e3
                } else {
                    x.0[0] + 0.1 * noise
                }
            })
            .collect();
        let values: Vec<f64> = principal
            .iter()
            .zip(&damage)
            .map(|(s, d)| if d.0 < 1.0 { *s } else { 0.0 })
            .collect();
        let mut reach = StressReach::<D>::default();
        reach.refill(&positions, &values, radius);
        let strength = 0.6;
        let mut skipped = 0;
        for p in 0..n {
            let row: Vec<u32> = (0..n as u32)
                .filter(|&q| (positions[q as usize].0 - positions[p].0).length() <= radius)
                .collect();
            for average in [Average::Published, Average::Intact] {
                let sigma = equivalent_stress(&row, &mass, &principal, &damage, average);
                if !reach.may_reach(positions[p].0, row.len(), strength) {
                    skipped += 1;
                    assert!(sigma < strength, "particle {p}: {sigma} skipped");
                }
            }
        }
        assert!(skipped > n / 4, "only {skipped} of {n} skipped");
    }

    #[test]
    fn skipped_particles_never_reach_the_strength() {
        never_skips_a_particle_that_reaches::<Two>();
        never_skips_a_particle_that_reaches::<Three>();
    }

    #[test]
    fn the_rounding_margin_keeps_a_neighbourhood_exactly_at_the_bound() {
        let positions = [Position(DVec2::ZERO), Position(DVec2::new(0.1, 0.0))];
        let mut reach = StressReach::<Two>::default();
        reach.refill(&positions, &[2.0, 2.0], 0.2);
        assert!(reach.may_reach(DVec2::ZERO, 2, 2.0));
        assert!(!reach.may_reach(DVec2::ZERO, 2, 2.0 * (1.0 + 1e-12)));
    }

    #[test]
    fn binning_is_off_where_it_cannot_help() {
        let far = [Position(DVec2::ZERO), Position(DVec2::new(1e6, 0.0))];
        let mut reach = StressReach::<Two>::default();
        reach.refill(&far, &[0.0, 0.0], 1e-3);
        assert!(reach.may_reach(DVec2::ZERO, 1, 1e9), "too many bins");
        reach.refill(&far[..1], &[f64::NAN], 1.0);
        assert!(reach.may_reach(DVec2::ZERO, 1, 1e9), "non-finite value");
        reach.refill(&[], &[], 1.0);
        assert!(reach.may_reach(DVec2::ZERO, 1, 1e9), "no particles");
        reach.refill(&far[..1], &[0.0], 1.0);
        assert!(!reach.may_reach(DVec2::ZERO, 1, 1e9));
    }
}
