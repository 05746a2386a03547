//! Dimension-specific math, in one place.
//!
//! Fractum runs in two dimensions (plane strain) and in three. Every algorithm is written once,
//! generic over [`Dim`], and instantiated for [`Two`] and [`Three`] when a scene is loaded (the
//! scene's grid decides which, see [`with_dim!`](crate::with_dim)); the hot loops are
//! monomorphic and never branch on the dimension. Everything that knows the number of space
//! dimensions lives in this module:
//!
//! - the vector, matrix and symmetric-tensor types of each dimension, and the operations the
//!   systems use on them ([`VectorOps`], [`MatrixOps`], [`SymOps`]), so that no system names
//!   `.x`/`.y` components or builds a tensor component by component;
//! - plane strain: in 2D the symmetric tensors keep the out-of-plane `zz` component (the
//!   out-of-plane strain is zero, the stress is not, and it enters the energy and the mean
//!   stress), and a deformation gradient has `F_zz = 1`;
//! - lattice coordinates of grid cells and nodes ([`Lattice`]);
//! - principal values: closed form for the in-plane 2×2 block, Jacobi's method for 3×3
//!   ([`eigen`]), always ordered largest first.

pub mod eigen;
mod numbers;
mod three;
mod two;

pub use numbers::Numbers;
pub use three::{SymTensor3, Three};
pub use two::{SymTensor2, Two};

use std::fmt::Debug;
use std::hash::Hash;
use std::iter::Sum;
use std::ops::{
    Add, AddAssign, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub, SubAssign,
};

/// The number of space dimensions of a loaded scene, as a run-time value.
///
/// Code that is generic over [`Dim`] is instantiated for one of these with
/// [`with_dim!`](crate::with_dim).
#[derive(bevy_ecs::prelude::Resource, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dimension {
    /// Two dimensions, plane strain.
    Two,
    /// Three dimensions.
    Three,
}

impl Dimension {
    /// Number of space dimensions.
    #[inline]
    pub fn count(self) -> usize {
        match self {
            Dimension::Two => 2,
            Dimension::Three => 3,
        }
    }

    /// The dimension with `count` coordinates, if there is one.
    #[inline]
    pub fn of_count(count: usize) -> Option<Self> {
        match count {
            2 => Some(Dimension::Two),
            3 => Some(Dimension::Three),
            _ => None,
        }
    }

    /// How `fractum check` and error messages name it.
    #[inline]
    pub fn describe(self) -> &'static str {
        match self {
            Dimension::Two => Two::NAME,
            Dimension::Three => Three::NAME,
        }
    }

    /// Names of the coordinate axes, `x, y` or `x, y, z`.
    #[inline]
    pub fn axes(self) -> &'static [&'static str] {
        match self {
            Dimension::Two => Two::AXES,
            Dimension::Three => Three::AXES,
        }
    }
}

/// Runs an expression generic over the dimension for a run-time [`Dimension`]: inside `$body`,
/// `$D` names [`Two`] or [`Three`].
///
/// ```
/// use fractum_engine::dim::{Dim, Dimension};
/// use fractum_engine::with_dim;
///
/// fn axes<D: Dim>() -> usize {
///     D::N
/// }
/// assert_eq!(with_dim!(Dimension::Three, D => axes::<D>()), 3);
/// ```
#[macro_export]
macro_rules! with_dim {
    ($dimension:expr, $D:ident => $body:expr) => {
        match $dimension {
            $crate::dim::Dimension::Two => {
                #[allow(dead_code)]
                type $D = $crate::dim::Two;
                $body
            }
            $crate::dim::Dimension::Three => {
                #[allow(dead_code)]
                type $D = $crate::dim::Three;
                $body
            }
        }
    };
}

/// A number of space dimensions and its math types.
///
/// Implemented by [`Two`] (plane strain) and [`Three`]. Components and resources that hold
/// vectors or tensors are generic over it (`Position<D>`, `Grid<D>`), and so are the systems.
pub trait Dim:
    'static + Send + Sync + Copy + Clone + Debug + Default + PartialEq + Eq + Hash
{
    /// Number of space dimensions.
    const N: usize;
    /// The run-time tag of this dimension.
    const DIMENSION: Dimension;
    /// How messages and `fractum check` name it.
    const NAME: &'static str;
    /// Names of the coordinate axes, used in column names (`momentum_x`).
    const AXES: &'static [&'static str];
    /// A position, velocity, force or gradient vector.
    type Vector: VectorOps + Numbers;
    /// A full (non-symmetric) second-order tensor: velocity gradient, deformation gradient.
    type Matrix: MatrixOps<Self::Vector> + Numbers;
    /// A symmetric second-order tensor: stress, strain (in 2D with the out-of-plane `zz`).
    type Sym: SymOps<Self::Vector, Self::Matrix> + Numbers;
    /// Lattice coordinates of a grid cell or node, `[usize; N]`.
    type Cell: Lattice;

    /// The left Cauchy–Green tensor `b = F Fᵀ` of the full deformation (plane strain:
    /// `F_zz = 1`, so `b_zz = 1`).
    fn left_cauchy_green(f: Self::Matrix) -> Self::Sym;

    /// `tr(Fᵀ F)` of the full deformation (plane strain adds `F_zz² = 1`).
    fn cauchy_green_trace(f: Self::Matrix) -> f64;
}

/// The vector type of dimension `D`.
pub type Vector<D> = <D as Dim>::Vector;
/// The full second-order tensor type of dimension `D`.
pub type Matrix<D> = <D as Dim>::Matrix;
/// The symmetric second-order tensor type of dimension `D`.
pub type SymTensor<D> = <D as Dim>::Sym;

/// Operations on vectors that generic code uses (implemented by glam's `DVec2` and `DVec3`).
///
/// Multiply by a scalar on the right (`v * s`): a bound cannot give `f64 * v` to generic code.
/// Floating-point products commute exactly, so the order does not change any result.
pub trait VectorOps:
    Copy
    + Clone
    + Debug
    + Default
    + PartialEq
    + Send
    + Sync
    + serde::Serialize
    + serde::de::DeserializeOwned
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
    + Mul<Self, Output = Self>
    + Div<Self, Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign<f64>
    + DivAssign<f64>
    + Index<usize, Output = f64>
    + IndexMut<usize>
    + Sum
    + for<'a> Sum<&'a Self>
{
    /// All zeros.
    const ZERO: Self;
    /// All ones.
    const ONE: Self;
    /// Every component `v`.
    fn splat(v: f64) -> Self;
    /// Component `a` is `f(a)`.
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    /// Dot product.
    fn dot(self, other: Self) -> f64;
    /// Euclidean length.
    fn length(self) -> f64;
    /// Squared length.
    fn length_squared(self) -> f64;
    /// True when every component is finite.
    fn is_finite(self) -> bool;
    /// Component-wise minimum.
    fn min(self, other: Self) -> Self;
    /// Component-wise maximum.
    fn max(self, other: Self) -> Self;
    /// Component-wise floor.
    fn floor(self) -> Self;
    /// Component-wise ceiling.
    fn ceil(self) -> Self;
    /// Component-wise rounding to the nearest integer.
    fn round(self) -> Self;
    /// Component-wise clamp.
    fn clamp(self, lo: Self, hi: Self) -> Self;
    /// The components, padded with zeros to three (for writers that always want 3D).
    fn to_3d(self) -> [f64; 3];
}

/// Operations on full second-order tensors (implemented by glam's `DMat2` and `DMat3`).
pub trait MatrixOps<V>:
    Copy
    + Clone
    + Debug
    + PartialEq
    + Send
    + Sync
    + serde::Serialize
    + serde::de::DeserializeOwned
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Mul<f64, Output = Self>
    + Mul<V, Output = V>
    + AddAssign
{
    /// All zeros.
    const ZERO: Self;
    /// The identity.
    const IDENTITY: Self;
    /// The outer product `a ⊗ b`, whose entry (i, j) is `a_i b_j`.
    fn outer(a: V, b: V) -> Self;
    /// Entry (row `i`, column `j`) is `f(i, j)`.
    fn from_fn(f: impl FnMut(usize, usize) -> f64) -> Self;
    /// Diagonal matrix.
    fn from_diagonal(diagonal: V) -> Self;
    /// Entry at row `i`, column `j`.
    fn get(&self, i: usize, j: usize) -> f64;
    /// Column `j`.
    fn col(&self, j: usize) -> V;
    /// Transpose.
    fn transpose(&self) -> Self;
    /// Determinant.
    fn determinant(&self) -> f64;
    /// Inverse (non-finite when singular).
    fn inverse(&self) -> Self;
    /// Trace.
    fn trace(&self) -> f64;
    /// True when every entry is finite.
    fn is_finite(&self) -> bool;
    /// The largest absolute entry.
    fn max_abs(&self) -> f64;
}

/// Operations on symmetric second-order tensors.
///
/// Indices `(i, j)` always refer to the full 3×3 tensor, so that plane-strain `zz` is `(2, 2)`
/// in both dimensions; in 2D the `xz` and `yz` components are zero.
pub trait SymOps<V, M>:
    Copy
    + Clone
    + Debug
    + Default
    + PartialEq
    + Send
    + Sync
    + 'static
    + serde::Serialize
    + serde::de::DeserializeOwned
{
    /// The zero tensor.
    const ZERO: Self;
    /// The identity (in plane strain, including `zz = 1`).
    const IDENTITY: Self;
    /// `k I`.
    fn isotropic(k: f64) -> Self;
    /// The symmetric part `(A + Aᵀ)/2` of a matrix (plane strain: `zz = 0`).
    fn sym_of(a: M) -> Self;
    /// The tensor whose component `(i, j)`, `i ≤ j < 3`, is `f(i, j)` (in 2D only `xx`, `yy`,
    /// `zz` and `xy` are asked for).
    fn from_fn(f: impl FnMut(usize, usize) -> f64) -> Self;
    /// Component `(i, j)` of the full 3×3 tensor.
    fn get(&self, i: usize, j: usize) -> f64;
    /// Trace (with `zz` in plane strain).
    fn trace(&self) -> f64;
    /// Full contraction `A : B` (off-diagonal terms count twice).
    fn double_dot(&self, other: &Self) -> f64;
    /// `self + s · other`.
    fn add_scaled(&self, other: &Self, s: f64) -> Self;
    /// `s · self`.
    fn scaled(&self, s: f64) -> Self;
    /// Isotropic Hooke's law `λ tr(ε) I + 2μ ε` applied to `self` as a strain.
    fn hooke(&self, lambda: f64, mu: f64) -> Self;
    /// The deviator `A − tr(A)/3 I`.
    fn deviator(&self) -> Self;
    /// `A · v` (in plane strain the `zz` part does not act in the plane).
    fn dot(&self, v: V) -> V;
    /// The tensor as a `D × D` matrix (in plane strain, the in-plane block).
    fn to_matrix(&self) -> M;
    /// All three principal values, largest first (plane strain: the in-plane pair and `zz`).
    fn principal_values(&self) -> [f64; 3];
    /// The largest principal value a crack can open under: in 3D the largest eigenvalue; in
    /// plane strain the larger in-plane one (a plane-strain crack runs through the thickness,
    /// so `zz` cannot open it).
    fn largest_principal(&self) -> f64;
    /// True when every component is finite.
    fn is_finite(&self) -> bool;
    /// Components in the row-major 3×3 order VTK expects: xx xy xz yx yy yz zx zy zz.
    fn as_3x3(&self) -> [f64; 9];

    /// The tensor with `f` applied to each of its three principal values, the principal
    /// directions kept: `Σ f(σ_i) v_i ⊗ v_i` (in plane strain `zz` is a principal value on its
    /// own). Exact to round-off, whatever the spacing of the values (Jacobi, [`eigen`]).
    #[inline]
    fn map_principal(&self, f: impl Fn(f64) -> f64) -> Self
    where
        Self: Sized,
    {
        let a = std::array::from_fn(|i| std::array::from_fn(|j| self.get(i, j)));
        let (values, vectors) = eigen::symmetric_eigen(a);
        let mapped = values.map(f);
        Self::from_fn(|i, j| {
            (0..3)
                .map(|k| mapped[k] * vectors[k][i] * vectors[k][j])
                .sum()
        })
    }
}

/// Lattice coordinates `[usize; N]` of a grid cell or node.
pub trait Lattice:
    Copy
    + Clone
    + Debug
    + Default
    + PartialEq
    + Eq
    + Hash
    + Send
    + Sync
    + 'static
    + Index<usize, Output = usize>
    + IndexMut<usize>
    + AsRef<[usize]>
{
    /// Coordinate `a` is `f(a)`.
    fn from_fn(f: impl FnMut(usize) -> usize) -> Self;
    /// Product of the coordinates (the number of cells of a box with these counts).
    #[inline]
    fn product(&self) -> usize {
        self.as_ref().iter().product()
    }
}

impl<const N: usize> Lattice for [usize; N]
where
    [usize; N]: Default,
{
    #[inline]
    fn from_fn(f: impl FnMut(usize) -> usize) -> Self {
        std::array::from_fn(f)
    }
}

/// Iterator over the lattice points `p` with `lo[a] <= p[a] < hi[a]` on every axis, the first
/// axis fastest (the order of node and cell indices).
#[derive(Clone, Debug)]
pub struct LatticeRange<C> {
    lo: C,
    hi: C,
    next: Option<C>,
}

/// The lattice points of the half-open box `[lo, hi)`, the first axis fastest.
pub fn lattice_range<C: Lattice>(lo: C, hi: C) -> LatticeRange<C> {
    let empty = (0..lo.as_ref().len()).any(|a| lo[a] >= hi[a]);
    LatticeRange {
        lo,
        hi,
        next: (!empty).then_some(lo),
    }
}

impl<C: Lattice> Iterator for LatticeRange<C> {
    type Item = C;

    #[inline]
    fn next(&mut self) -> Option<C> {
        let current = self.next?;
        let mut following = current;
        self.next = None;
        for a in 0..current.as_ref().len() {
            following[a] += 1;
            if following[a] < self.hi[a] {
                self.next = Some(following);
                break;
            }
            following[a] = self.lo[a];
        }
        Some(current)
    }
}

/// Volume of a cube of side `h` in `D` dimensions (area in 2D, times the thickness elsewhere).
pub fn cell_volume<D: Dim>(h: f64) -> f64 {
    h.powi(D::N as i32)
}

/// Implements [`VectorOps`] for a glam vector type by forwarding to its inherent methods;
/// `new` builds the vector from a function of the component index, spelled out per
/// dimension so that hot kernels see a plain constructor.
macro_rules! glam_vector_ops {
    ($t:ty, $n:expr, |$f:ident| $new:expr) => {
        impl $crate::dim::VectorOps for $t {
            const ZERO: Self = <$t>::ZERO;
            const ONE: Self = <$t>::ONE;
            #[inline]
            fn splat(v: f64) -> Self {
                <$t>::splat(v)
            }
            #[inline]
            fn from_fn(mut $f: impl FnMut(usize) -> f64) -> Self {
                $new
            }
            #[inline]
            fn dot(self, other: Self) -> f64 {
                <$t>::dot(self, other)
            }
            #[inline]
            fn length(self) -> f64 {
                <$t>::length(self)
            }
            #[inline]
            fn length_squared(self) -> f64 {
                <$t>::length_squared(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline]
            fn min(self, other: Self) -> Self {
                <$t>::min(self, other)
            }
            #[inline]
            fn max(self, other: Self) -> Self {
                <$t>::max(self, other)
            }
            #[inline]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            #[inline]
            fn ceil(self) -> Self {
                <$t>::ceil(self)
            }
            #[inline]
            fn round(self) -> Self {
                <$t>::round(self)
            }
            #[inline]
            fn clamp(self, lo: Self, hi: Self) -> Self {
                <$t>::clamp(self, lo, hi)
            }
            #[inline]
            fn to_3d(self) -> [f64; 3] {
                let mut out = [0.0; 3];
                for (a, slot) in out.iter_mut().enumerate().take($n) {
                    *slot = self[a];
                }
                out
            }
        }
    };
}
use glam_vector_ops;

/// Implements [`MatrixOps`] for a glam matrix type; `outer` gives the outer product `a ⊗ b`
/// column by column (column j is `a b_j`), spelled out per dimension.
macro_rules! glam_matrix_ops {
    ($m:ty, $v:ty, $n:expr, |$a:ident, $b:ident| $outer:expr) => {
        impl $crate::dim::MatrixOps<$v> for $m {
            const ZERO: Self = <$m>::ZERO;
            const IDENTITY: Self = <$m>::IDENTITY;
            #[inline]
            fn outer($a: $v, $b: $v) -> Self {
                $outer
            }
            #[inline]
            fn from_fn(mut f: impl FnMut(usize, usize) -> f64) -> Self {
                let mut m = <$m>::ZERO;
                for j in 0..$n {
                    for i in 0..$n {
                        m.col_mut(j)[i] = f(i, j);
                    }
                }
                m
            }
            #[inline]
            fn from_diagonal(diagonal: $v) -> Self {
                <$m>::from_diagonal(diagonal)
            }
            #[inline]
            fn get(&self, i: usize, j: usize) -> f64 {
                self.col(j)[i]
            }
            #[inline]
            fn col(&self, j: usize) -> $v {
                <$m>::col(self, j)
            }
            #[inline]
            fn transpose(&self) -> Self {
                <$m>::transpose(self)
            }
            #[inline]
            fn determinant(&self) -> f64 {
                <$m>::determinant(self)
            }
            #[inline]
            fn inverse(&self) -> Self {
                <$m>::inverse(self)
            }
            #[inline]
            fn trace(&self) -> f64 {
                (0..$n).map(|a| self.col(a)[a]).sum()
            }
            #[inline]
            fn is_finite(&self) -> bool {
                <$m>::is_finite(self)
            }
            #[inline]
            fn max_abs(&self) -> f64 {
                self.to_cols_array()
                    .iter()
                    .fold(0.0, |acc: f64, v| acc.max(v.abs()))
            }
        }
    };
}
use glam_matrix_ops;

#[cfg(test)]
mod tests {
    use super::*;

    fn generic_round_trip<D: Dim>() {
        let v = <Vector<D>>::from_fn(|a| a as f64 + 1.0);
        assert_eq!(v.to_3d()[D::N - 1], D::N as f64);
        let m = <Matrix<D>>::outer(v, <Vector<D>>::ONE);
        assert_eq!(m.get(D::N - 1, 0), D::N as f64);
        assert_eq!(m * <Vector<D>>::ONE, v * D::N as f64);
        let s = <SymTensor<D>>::sym_of(m);
        assert_eq!(s.get(0, D::N - 1), s.get(D::N - 1, 0));
        assert_eq!(<SymTensor<D>>::IDENTITY.trace(), 3.0);
        assert_eq!(<D::Cell as Lattice>::from_fn(|a| a + 2).product(), {
            (2..2 + D::N).product::<usize>()
        });
    }

    #[test]
    fn generic_operations_agree_in_both_dimensions() {
        generic_round_trip::<Two>();
        generic_round_trip::<Three>();
        assert_eq!(with_dim!(Dimension::Two, D => D::N), 2);
        assert_eq!(Dimension::of_count(3), Some(Dimension::Three));
        assert_eq!(Dimension::of_count(4), None);
    }

    fn hooke_and_deviator<D: Dim>() {
        let strain =
            <SymTensor<D>>::from_fn(|i, j| if i == j { 0.01 * (i + 1) as f64 } else { 0.002 });
        let (lambda, mu) = (3.0, 2.0);
        let stress = strain.hooke(lambda, mu);
        for i in 0..3 {
            for j in i..3 {
                let expected = if i == j { lambda * strain.trace() } else { 0.0 }
                    + 2.0 * mu * strain.get(i, j);
                assert!((stress.get(i, j) - expected).abs() < 1e-15, "({i}, {j})");
            }
        }
        assert!(strain.deviator().trace().abs() < 1e-16);
        let p = strain.principal_values();
        assert!(p[0] >= p[1] && p[1] >= p[2]);
        assert!((p.iter().sum::<f64>() - strain.trace()).abs() < 1e-15);
    }

    #[test]
    fn lattice_ranges_run_first_axis_fastest() {
        let points: Vec<[usize; 2]> = lattice_range([1, 0], [3, 2]).collect();
        assert_eq!(points, vec![[1, 0], [2, 0], [1, 1], [2, 1]]);
        assert_eq!(lattice_range([0, 0, 0], [2, 3, 4]).count(), 24);
        assert_eq!(lattice_range([0, 2], [3, 2]).count(), 0);
    }

    #[test]
    fn hooke_deviator_and_principal_values_in_both_dimensions() {
        hooke_and_deviator::<Two>();
        hooke_and_deviator::<Three>();
    }
}
