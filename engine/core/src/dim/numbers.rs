//! Values taken apart into their `f64`s and put back together bit for bit: how a distributed
//! run sends its ghosts' vectors and tensors ([`crate::checkpoint::State::NUMBERS`]), as plain
//! numbers rather than encoded value by value.

use super::{SymTensor2, SymTensor3};
use glam::{DMat2, DMat3, DVec2, DVec3};

/// A value made of a fixed count of `f64`s and of nothing else.
pub trait Numbers: Sized {
    /// How many numbers a value is made of.
    const COUNT: usize;

    /// Writes the value's [`Self::COUNT`] numbers into `out` (which holds at least as many).
    fn write_numbers(&self, out: &mut [f64]);

    /// The value whose numbers [`Self::write_numbers`] wrote into `numbers`.
    fn from_numbers(numbers: &[f64]) -> Self;
}

impl Numbers for f64 {
    const COUNT: usize = 1;

    #[inline]
    fn write_numbers(&self, out: &mut [f64]) {
        out[0] = *self;
    }

    #[inline]
    fn from_numbers(numbers: &[f64]) -> Self {
        numbers[0]
    }
}

/// `Numbers` for a glam type through its array of numbers.
macro_rules! glam_numbers {
    ($($ty:ty, $count:literal, $to:ident, $from:ident;)*) => {
        $(impl Numbers for $ty {
            const COUNT: usize = $count;

            #[inline]
            fn write_numbers(&self, out: &mut [f64]) {
                out[..$count].copy_from_slice(&self.$to());
            }

            #[inline]
            fn from_numbers(numbers: &[f64]) -> Self {
                Self::$from(&numbers[..$count])
            }
        })*
    };
}

glam_numbers! {
    DVec2, 2, to_array, from_slice;
    DVec3, 3, to_array, from_slice;
    DMat2, 4, to_cols_array, from_cols_slice;
    DMat3, 9, to_cols_array, from_cols_slice;
}

/// `Numbers` for a symmetric tensor through its components, in the order listed.
macro_rules! sym_numbers {
    ($($ty:ty: $($field:ident),+;)*) => {
        $(impl Numbers for $ty {
            const COUNT: usize = [$(stringify!($field)),+].len();

            #[inline]
            fn write_numbers(&self, out: &mut [f64]) {
                out[..Self::COUNT].copy_from_slice(&[$(self.$field),+]);
            }

            #[inline]
            fn from_numbers(numbers: &[f64]) -> Self {
                let mut numbers = numbers.iter().copied();
                let mut next = || numbers.next().expect("a value's numbers are all given");
                Self { $($field: next()),+ }
            }
        })*
    };
}

sym_numbers! {
    SymTensor2: xx, yy, zz, xy;
    SymTensor3: xx, yy, zz, xy, yz, xz;
}
