//! The sums over a row's nodes that the LME solve repeats, four nodes at a time: the pure
//! numerical core of `lme_kernel.rs` (not a system; stage: basis, for `basis/lme` on uniform
//! and graded grids).
//!
//! eigensoftening-lme-mpm.md §2.2: the approximants `N_I = exp(f_I) / Z` with
//! `f_I = −β|d_I|² + λ·d_I` and `d_I = x − x_I` (eq. 6), `Z = Σ exp(f_I)`, the residual
//! `r = Σ N_I d_I` (eq. 10) and its Jacobian `J = Σ N_I d_I ⊗ d_I − r ⊗ r` (eq. 9).
//!
//! **Why lanes.** A point has ten to thirty nodes in its support, and the solve evaluates these
//! sums once or twice per point and step; written node by node with the C library's `exp`
//! they were three fifths of the LME step on NL-PartSol's two-disk deck (the `exp` call alone
//! about 50 instructions a node). Here the offsets are kept coordinate by coordinate
//! ([`RowOffsets`], padded to a whole number of [`LANES`]), every pass runs over four nodes at
//! once with four partial sums, and the exponential is [`exp_lane`], a branch-free polynomial
//! the compiler vectorises. Run inside [`fractum_engine::vector_isa::vectorised`] the passes
//! are AVX2 instructions; the baseline build gives the same bits, as every operation is one
//! IEEE multiply, add, divide or comparison in a fixed order (no fused multiply-add).
//!
//! **What it changes.** The sums are taken in four partial sums, combined as
//! `(s₀ + s₁) + (s₂ + s₃)`, and `exp_lane` is within two units in the last place of the
//! correctly rounded exponential where the C library's is within one: the approximants differ
//! from the node-by-node sums by round-off, some 1e-16 relatively, far below the support's
//! truncation (1e-6) that bounds how exactly they are represented.

use fractum_engine::prelude::{Dim, MatrixOps, VectorOps};

/// Nodes summed at once: four `f64` lanes fill an AVX2 register.
pub const LANES: usize = 4;

/// Four `f64`, one per node of a block, with the arithmetic done lane by lane: written out
/// so that each operation is one AVX2 instruction in the wide copy of the kernel (the
/// compiler does not vectorise the same loops written over arrays indexed by lane).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Lanes(pub [f64; LANES]);

impl Lanes {
    const ZERO: Self = Self([0.0; LANES]);

    #[inline(always)]
    fn splat(v: f64) -> Self {
        Self([v; LANES])
    }

    /// The larger of each pair of lanes; a NaN in `self` never wins.
    #[inline(always)]
    fn max_of(self, other: Self) -> Self {
        let [a, b] = [self.0, other.0];
        Self([
            if a[0] > b[0] { a[0] } else { b[0] },
            if a[1] > b[1] { a[1] } else { b[1] },
            if a[2] > b[2] { a[2] } else { b[2] },
            if a[3] > b[3] { a[3] } else { b[3] },
        ])
    }

    /// The four lanes summed in a fixed order.
    #[inline(always)]
    fn total(self) -> f64 {
        (self.0[0] + self.0[1]) + (self.0[2] + self.0[3])
    }

    /// The largest lane (`f64::max`'s rule for NaN).
    #[inline(always)]
    fn largest(self) -> f64 {
        self.0[0].max(self.0[1]).max(self.0[2].max(self.0[3]))
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self([f(self.0[0]), f(self.0[1]), f(self.0[2]), f(self.0[3])])
    }
}

macro_rules! lane_operator {
    ($trait:ident, $method:ident, $op:tt) => {
        impl std::ops::$trait for Lanes {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                let [a, b] = [self.0, other.0];
                Self([a[0] $op b[0], a[1] $op b[1], a[2] $op b[2], a[3] $op b[3]])
            }
        }
    };
}
lane_operator!(Add, add, +);
lane_operator!(Sub, sub, -);
lane_operator!(Mul, mul, *);
lane_operator!(Div, div, /);

/// One block of [`LANES`] nodes: their offsets coordinate by coordinate, and which lanes hold
/// a node (the last block's padding does not).
#[derive(Clone, Copy, Debug)]
struct OffsetBlock {
    axes: [Lanes; 3],
    /// 0 on a node's lane, −∞ on the padding's: added to the exponents, it gives the padding
    /// no weight without a store into the block being summed (a store of one lane followed
    /// by a load of the four stalls the load).
    exponent_bias: Lanes,
    /// 1 on a node's lane, 0 on the padding's.
    live: Lanes,
}

/// The offsets `d_I = x − x_I` of one point's support nodes in blocks of [`LANES`] nodes,
/// coordinate by coordinate, the last block padded with zeros.
#[derive(Clone, Debug, Default)]
pub struct RowOffsets {
    blocks: Vec<OffsetBlock>,
    len: usize,
}

impl RowOffsets {
    /// The offsets of `nodes` from `x`, in `D::N` coordinates.
    pub fn fill<D: Dim>(&mut self, x: D::Vector, nodes: &[D::Vector]) {
        self.len = nodes.len();
        self.blocks.clear();
        self.blocks.extend(nodes.chunks(LANES).map(|group| {
            // Built whole in registers, then stored once.
            let mut axes = [[0.0; LANES]; 3];
            let (mut bias, mut live) = ([f64::NEG_INFINITY; LANES], [0.0; LANES]);
            for (l, &xi) in group.iter().enumerate() {
                let d = (x - xi).to_3d();
                for a in 0..3 {
                    axes[a][l] = d[a];
                }
                (bias[l], live[l]) = (0.0, 1.0);
            }
            OffsetBlock {
                axes: axes.map(Lanes),
                exponent_bias: Lanes(bias),
                live: Lanes(live),
            }
        }));
    }

    /// The number of nodes (without the padding).
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the support has no node.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// `Z`'s scaled sum, the shift of the exponents, `r` and `J` at one λ: what
/// [`moments`] gives beside the values it writes.
#[derive(Clone, Copy, Debug)]
pub struct LaneMoments<D: Dim> {
    /// `Σ exp(f_I − largest)`.
    pub scaled_z: f64,
    /// The largest exponent `f_I`, by which they were shifted.
    pub largest: f64,
    /// `r = Σ N_I d_I`.
    pub r: D::Vector,
    /// `J = Σ N_I d_I ⊗ d_I − r ⊗ r`.
    pub j: D::Matrix,
}

/// Below this the exponential is taken as zero (`exp(−708.3)` is the smallest normal `f64`):
/// the scale `2^k` of [`exp_lane`] stays a normal number.
const LOWEST_EXPONENT: f64 = -708.0;
/// Above this `exp` overflows.
const HIGHEST_EXPONENT: f64 = 709.0;
/// `1.5 · 2⁵²`: added to `a·log₂e`, the sum's last bits are the nearest integer `k`.
const ROUNDING_SHIFT: f64 = 6_755_399_441_055_744.0;
/// ln 2 to its leading 32 bits, so that `k · LN2_HIGH` is exact for every `k` here.
const LN2_HIGH: f64 = f64::from_bits(0x3FE6_2E42_FEE0_0000);
/// ln 2 − [`LN2_HIGH`].
const LN2_LOW: f64 = f64::from_bits(0x3DEA_39EF_3579_3C76);
/// `1/n!` for n = 2 … 13: Taylor's series of `exp(r)` for `|r| ≤ ln 2 / 2`, whose remainder
/// `|r|¹⁴/14!` is below 5e-18, a twentieth of a unit in the last place.
const INVERSE_FACTORIALS: [f64; 12] = [
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

/// `exp(a)`, branch-free so that the compiler vectorises a block of it: `a = k ln 2 + r` with
/// `k` the nearest integer to `a / ln 2` (by the rounding shift, not a call) and
/// `|r| ≤ ln 2 / 2`, `exp(r)` by Horner's rule on Taylor's series to degree 13, and `2^k`
/// written into the exponent bits. Within two units in the last place for
/// `−708 ≤ a ≤ 709`; zero below (where the true value is subnormal, under 3.4e-308), `exp(709)`
/// above; NaN for NaN and for +∞ (the LME exponents, shifted by their largest, are never
/// positive).
#[inline(always)]
pub fn exp_lane(a: f64) -> f64 {
    // Selects, not branches: the compiler turns them into a lane-wise minimum and maximum.
    let clamped = if a < LOWEST_EXPONENT {
        LOWEST_EXPONENT
    } else {
        a
    };
    let clamped = if clamped > HIGHEST_EXPONENT {
        HIGHEST_EXPONENT
    } else {
        clamped
    };
    let shifted = clamped * std::f64::consts::LOG2_E + ROUNDING_SHIFT;
    let k = shifted - ROUNDING_SHIFT;
    let r = (clamped - k * LN2_HIGH) - k * LN2_LOW;
    let p = taylor_by_estrin(r);
    // `k` is the difference of the two shifts' bit patterns; `2^k` is `k + 1023` in the
    // exponent field.
    let k_bits = shifted.to_bits().wrapping_sub(ROUNDING_SHIFT.to_bits());
    let scale = f64::from_bits(k_bits.wrapping_add(1023) << 52);
    // `a − a` is zero, or NaN when `a` is NaN or infinite: the clamp does not hide a NaN.
    #[allow(clippy::eq_op)]
    let value = p * scale + (a - a);
    // All ones to keep the value, zero below the range (a NaN is kept): a mask, as a branch
    // here would stop the vectorisation.
    let keep = u64::from(a >= LOWEST_EXPONENT || a.is_nan()).wrapping_neg();
    f64::from_bits(value.to_bits() & keep)
}

/// `Σ rⁿ/n!` for n = 0 … 13 by Estrin's scheme: pairs `c₂ₖ + c₂ₖ₊₁ r`, combined with `r²`,
/// `r⁴` and `r⁸`. Four dependent multiply-adds instead of Horner's thirteen: the solve of one
/// point waits on its exponentials, so their latency, not their count, sets its time.
#[inline(always)]
fn taylor_by_estrin(r: f64) -> f64 {
    let c = |n: usize| {
        if n < 2 {
            1.0
        } else {
            INVERSE_FACTORIALS[n - 2]
        }
    };
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let pair = |k: usize| c(2 * k) + c(2 * k + 1) * r;
    let low = (pair(0) + pair(1) * r2) + (pair(2) + pair(3) * r2) * r4;
    let high = (pair(4) + pair(5) * r2) + pair(6) * r4;
    low + high * r8
}

/// The moments of the values in `values` (padding zero): `r` and `Σ N_I d_I ⊗ d_I`.
#[inline(always)]
fn first_and_second<const N: usize>(
    offsets: &RowOffsets,
    values: &[[f64; LANES]],
) -> ([f64; N], [[f64; N]; N]) {
    let mut r = [Lanes::ZERO; N];
    let mut second = [[Lanes::ZERO; N]; N];
    for (block, &v) in offsets.blocks.iter().zip(values) {
        let (d, v) = (&block.axes, Lanes(v));
        for a in 0..N {
            let weighted = d[a] * v;
            r[a] = r[a] + weighted;
            for b in a..N {
                second[a][b] = second[a][b] + weighted * d[b];
            }
        }
    }
    let mut full = [[0.0; N]; N];
    let mut first = [0.0; N];
    for a in 0..N {
        first[a] = r[a].total();
        for b in a..N {
            full[a][b] = second[a][b].total();
            full[b][a] = full[a][b];
        }
    }
    (first, full)
}

/// `J = second − r ⊗ r` and `r` as the dimension's types.
#[inline(always)]
fn as_moments<D: Dim, const N: usize>(
    (r, second): ([f64; N], [[f64; N]; N]),
    scaled_z: f64,
    largest: f64,
) -> LaneMoments<D> {
    LaneMoments {
        scaled_z,
        largest,
        r: D::Vector::from_fn(|a| r[a]),
        j: D::Matrix::from_fn(|a, b| second[a][b] - r[a] * r[b]),
    }
}

/// Evaluates the moments at `lambda` over `offsets`, writing `N_I` into `values` (padded with
/// zeros to the offsets' padded length).
#[inline(always)]
pub fn moments<D: Dim>(
    offsets: &RowOffsets,
    beta: f64,
    lambda: D::Vector,
    values: &mut Vec<f64>,
) -> LaneMoments<D> {
    match D::N {
        1 => moments_in::<D, 1>(offsets, beta, lambda, values),
        2 => moments_in::<D, 2>(offsets, beta, lambda, values),
        _ => moments_in::<D, 3>(offsets, beta, lambda, values),
    }
}

#[inline(always)]
fn moments_in<D: Dim, const N: usize>(
    offsets: &RowOffsets,
    beta: f64,
    lambda: D::Vector,
    values: &mut Vec<f64>,
) -> LaneMoments<D> {
    let lambda = lambda.to_3d();
    values.clear();
    values.resize(offsets.blocks.len() * LANES, 0.0);
    let (blocks, _) = values.as_chunks_mut::<LANES>();
    let minus_beta = Lanes::splat(-beta);
    let mut top = Lanes::splat(f64::NEG_INFINITY);
    for (block, f) in offsets.blocks.iter().zip(blocks.iter_mut()) {
        let d = &block.axes;
        let (mut squared, mut along) = (Lanes::ZERO, Lanes::ZERO);
        for a in 0..N {
            squared = squared + d[a] * d[a];
            along = along + Lanes::splat(lambda[a]) * d[a];
        }
        // The padding's exponents are −∞, so its weights are zero.
        let exponent = (minus_beta * squared + along) + block.exponent_bias;
        // A NaN never wins, as with `f64::max`; it spoils its own value below.
        top = exponent.max_of(top);
        *f = exponent.0;
    }
    let largest = top.largest();
    let mut z = Lanes::ZERO;
    let shift = Lanes::splat(largest);
    for f in blocks.iter_mut() {
        let v = (Lanes(*f) - shift).map(exp_lane);
        z = z + v;
        *f = v.0;
    }
    let scaled_z = z.total();
    let divisor = Lanes::splat(scaled_z);
    for f in blocks.iter_mut() {
        *f = (Lanes(*f) / divisor).0;
    }
    as_moments::<D, N>(first_and_second(offsets, blocks), scaled_z, largest)
}

/// The first-order update of the values for the Newton step `delta` from moments with
/// residual `r`: writes each value's relative change `δ·(d_I − r)` into `changes` and returns
/// the largest in magnitude (the padding's changes are zero).
#[inline(always)]
pub fn changes<D: Dim>(
    offsets: &RowOffsets,
    delta: D::Vector,
    r: D::Vector,
    changes: &mut Vec<f64>,
) -> f64 {
    match D::N {
        1 => changes_in::<1>(offsets, delta.to_3d(), r.to_3d(), changes),
        2 => changes_in::<2>(offsets, delta.to_3d(), r.to_3d(), changes),
        _ => changes_in::<3>(offsets, delta.to_3d(), r.to_3d(), changes),
    }
}

#[inline(always)]
fn changes_in<const N: usize>(
    offsets: &RowOffsets,
    delta: [f64; 3],
    r: [f64; 3],
    changes: &mut Vec<f64>,
) -> f64 {
    changes.clear();
    changes.resize(offsets.blocks.len() * LANES, 0.0);
    let (blocks, _) = changes.as_chunks_mut::<LANES>();
    let mut top = Lanes::ZERO;
    for (block, change) in offsets.blocks.iter().zip(blocks.iter_mut()) {
        let mut along = Lanes::ZERO;
        for a in 0..N {
            along = along + Lanes::splat(delta[a]) * (block.axes[a] - Lanes::splat(r[a]));
        }
        // The padding's changes are zero (its values are, too).
        let along = along * block.live;
        top = along.map(f64::abs).max_of(top);
        *change = along.0;
    }
    top.largest()
}

/// Applies `changes` to `values` (`N_I ← N_I (1 + change_I)`) and returns the moments of the
/// updated values (`scaled_z` and `largest` are not recomputed: they are left at zero).
#[inline(always)]
pub fn apply_changes<D: Dim>(
    offsets: &RowOffsets,
    changes: &[f64],
    values: &mut [f64],
) -> LaneMoments<D> {
    let (blocks, _) = values.as_chunks_mut::<LANES>();
    let (changes, _) = changes.as_chunks::<LANES>();
    for (v, &change) in blocks.iter_mut().zip(changes) {
        *v = (Lanes(*v) * (Lanes::splat(1.0) + Lanes(change))).0;
    }
    match D::N {
        1 => as_moments::<D, 1>(first_and_second(offsets, blocks), 0.0, 0.0),
        2 => as_moments::<D, 2>(first_and_second(offsets, blocks), 0.0, 0.0),
        _ => as_moments::<D, 3>(first_and_second(offsets, blocks), 0.0, 0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::prelude::{DVec2, DVec3, Three, Two};
    use fractum_engine::vector_isa::{VectorIsa, vectorised_with};

    /// Units in the last place between `a` and `b` (both positive and finite).
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn the_lane_exponential_is_within_two_ulps_of_the_library_one() {
        let mut worst = 0;
        for i in 0..=200_000 {
            let a = -708.0 + 1417.0 * i as f64 / 200_000.0;
            let a = a.min(HIGHEST_EXPONENT);
            worst = worst.max(ulps(exp_lane(a), a.exp()));
        }
        assert!(worst <= 2, "{worst} ulps");
        // Near zero, where the weights of the nearest nodes lie, and at the reduction's seams.
        for a in [-1e-300, -1e-17, -0.5 * std::f64::consts::LN_2, -1.0, -30.0] {
            assert!(ulps(exp_lane(a), a.exp()) <= 2, "{a}");
        }
        assert_eq!(exp_lane(0.0), 1.0);
        assert_eq!(exp_lane(-0.0), 1.0);
    }

    #[test]
    fn the_lane_exponential_is_zero_below_the_normal_range_and_keeps_nan() {
        assert_eq!(exp_lane(f64::NEG_INFINITY), 0.0);
        assert_eq!(exp_lane(-709.0), 0.0);
        assert!(exp_lane(-707.9) > 0.0);
        assert!(exp_lane(f64::NAN).is_nan());
        assert!(exp_lane(f64::INFINITY).is_nan());
        assert!(ulps(exp_lane(HIGHEST_EXPONENT), HIGHEST_EXPONENT.exp()) <= 2);
        assert!(ulps(LN2_HIGH + LN2_LOW, std::f64::consts::LN_2) == 0);
        // k · LN2_HIGH is exact: LN2_HIGH has 21 zero bits at the end of its significand.
        assert_eq!(LN2_HIGH.to_bits().trailing_zeros(), 21);
    }

    /// The moments against node-by-node sums with the library's `exp`.
    fn node_by_node<D: Dim>(x: D::Vector, nodes: &[D::Vector], beta: f64, lambda: D::Vector) {
        let exponents: Vec<f64> = nodes
            .iter()
            .map(|&xi| -beta * (x - xi).length_squared() + lambda.dot(x - xi))
            .collect();
        let largest = exponents.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let z: f64 = exponents.iter().map(|f| (f - largest).exp()).sum();
        let reference: Vec<f64> = exponents.iter().map(|f| (f - largest).exp() / z).collect();
        let mut offsets = RowOffsets::default();
        offsets.fill::<D>(x, nodes);
        let mut values = Vec::new();
        let m = moments::<D>(&offsets, beta, lambda, &mut values);
        assert_eq!(values.len() % LANES, 0);
        assert!(values[nodes.len()..].iter().all(|&v| v == 0.0));
        for (v, expected) in values.iter().zip(&reference) {
            assert!(
                (v - expected).abs() <= 1e-15 * expected.max(1e-300),
                "{v} {expected}"
            );
        }
        assert!((m.scaled_z - z).abs() <= 1e-15 * z);
        assert_eq!(m.largest, largest);
        let r: D::Vector = reference
            .iter()
            .zip(nodes)
            .map(|(&n, &xi)| (x - xi) * n)
            .sum();
        // Round-off of sums of offsets as long as the farthest node's.
        let reach = nodes
            .iter()
            .map(|&xi| (x - xi).length())
            .fold(0.0, f64::max);
        assert!((m.r - r).length() <= 1e-15 * reach);
        let second = reference
            .iter()
            .zip(nodes)
            .fold(D::Matrix::ZERO, |acc, (&n, &xi)| {
                acc + D::Matrix::outer(x - xi, x - xi) * n
            });
        let j = second - D::Matrix::outer(r, r);
        assert!((m.j - j).max_abs() <= 1e-15 * reach * reach);
    }

    #[test]
    fn the_moments_are_the_node_by_node_sums_to_round_off() {
        let h = 0.1;
        let nodes2: Vec<DVec2> = (0..36)
            .map(|i| DVec2::new((i % 6) as f64, (i / 6) as f64) * h)
            .collect();
        let x2 = DVec2::new(0.23, 0.31);
        for count in [3, 4, 5, 13, 36] {
            node_by_node::<Two>(x2, &nodes2[..count], 3.5 / (h * h), DVec2::new(12.0, -7.0));
        }
        let nodes3: Vec<DVec3> = (0..27)
            .map(|i| DVec3::new((i % 3) as f64, (i / 3 % 3) as f64, (i / 9) as f64) * h)
            .collect();
        node_by_node::<Three>(
            DVec3::new(0.11, 0.09, 0.12),
            &nodes3,
            3.5 / (h * h),
            DVec3::new(3.0, 1.0, -2.0),
        );
    }

    /// The wide instructions and the baseline give the same bits, including the lanes' sums.
    #[test]
    fn the_widest_instructions_give_the_baselines_moments() {
        let h = 0.1;
        let nodes: Vec<DVec3> = (0..27)
            .map(|i| DVec3::new((i % 3) as f64, (i / 3 % 3) as f64, (i / 9) as f64) * h)
            .collect();
        let x = DVec3::new(0.11, 0.09, 0.12);
        let mut offsets = RowOffsets::default();
        offsets.fill::<Three>(x, &nodes[..23]);
        let run = |isa| {
            let mut values = Vec::new();
            let mut change = Vec::new();
            vectorised_with(
                isa,
                #[inline(always)]
                || {
                    let m =
                        moments::<Three>(&offsets, 350.0, DVec3::new(3.0, 1.0, -2.0), &mut values);
                    let largest = changes::<Three>(&offsets, DVec3::splat(1e-6), m.r, &mut change);
                    let after = apply_changes::<Three>(&offsets, &change, &mut values);
                    (m.r, m.j, largest, after.r, after.j, values.clone())
                },
            )
        };
        let (baseline, widest) = (run(VectorIsa::Baseline), run(VectorIsa::Widest));
        assert_eq!(format!("{baseline:?}"), format!("{widest:?}"));
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&baseline.5), bits(&widest.5));
    }

    #[test]
    fn changes_ignore_the_padding_and_keep_the_partition_of_unity() {
        let h = 1.0;
        let nodes: Vec<DVec2> = (0..9)
            .map(|i| DVec2::new((i % 3) as f64, (i / 3) as f64) * h)
            .collect();
        let x = DVec2::new(1.1, 0.95);
        let mut offsets = RowOffsets::default();
        offsets.fill::<Two>(x, &nodes);
        let mut values = Vec::new();
        let m = moments::<Two>(&offsets, 2.0, DVec2::ZERO, &mut values);
        let mut change = Vec::new();
        let delta = -(m.j.inverse() * m.r);
        let largest = changes::<Two>(&offsets, delta, m.r, &mut change);
        let real = change[..9].iter().fold(0.0f64, |a, c| a.max(c.abs()));
        assert_eq!(largest, real);
        assert!(change[9..].iter().all(|&c| c == 0.0));
        let after = apply_changes::<Two>(&offsets, &change, &mut values);
        let unity: f64 = values.iter().sum();
        assert!((unity - 1.0).abs() < 1e-14);
        // One Newton step from λ = 0 at a point this close to the centre leaves a residual of
        // second order in the first one.
        assert!(after.r.length() < 0.1 * m.r.length());
    }
}
