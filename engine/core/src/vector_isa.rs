//! The hot particle kernels compiled for the widest vector instructions the CPU has, chosen at
//! run time.
//!
//! A portable build targets the x86-64 baseline (SSE2): two `f64` lanes, no fused
//! multiply-add. The small-matrix arithmetic of a stress update or a transfer (2×2 and 3×3
//! tensors, glam's `DMat2`/`DMat3`) is then a sequence of shuffles, and `stress/linear_elastic`
//! on a million particles spends more time computing than moving its bytes. [`vectorised`] runs
//! a kernel through [`pulp`], which compiles it once more for AVX2 + FMA (x86-64-v3) and picks
//! that copy when the process starts if the CPU reports those extensions; the same binary
//! still runs on every x86-64 CPU, and on other targets the kernel runs as compiled.
//!
//! Not AVX-512: on this project's benchmark machine (an AMD EPYC, whose AVX-512 executes as two
//! 256-bit halves) the AVX-512 copy of `stress/linear_elastic` took 4.2–4.5 ms for 100k 3D
//! particles where the AVX2 copy took 3.2–3.6 ms and the baseline 3.7–4.0 ms, and the 2D MLS
//! step was no faster with it (`systems/benches/stress_systems.rs`, `fractum bench`); and many
//! Intel CPUs lower their clock while running it.
//!
//! **The results do not change.** The wider instructions compute each `f64` operation as the
//! baseline does (IEEE 754, rounded to nearest): Rust does not contract a multiply and an add
//! into one fused instruction unless the source asks for `mul_add`, whose result is the correctly
//! rounded one either way. So a kernel gives the same bits whichever set runs it (this
//! module's tests check a stress update both ways, and the shipped scenes' frames are
//! unchanged).
//!
//! **How a system uses it.** The wider code exists only where the kernel is inlined into the
//! dispatching function, so a system hands it whole blocks of rows, not one particle at a time:
//! split the columns into blocks of [`BLOCK_ROWS`] (`par_chunks_mut`), and in each block call
//! `vectorised(#[inline(always)] || for row in block { … })`. The attribute is needed: the
//! dispatch has a call site per instruction set, and without it the compiler keeps the closure
//! as one function, compiled for the baseline, which the wide code only calls
//! (`tests/house_rules.rs` checks every call). Functions the loop calls that are not small
//! need `#[inline(always)]` for the same reason.
//!
//! `FRACTUM_VECTOR_ISA=baseline` in the environment makes every kernel run the baseline code,
//! to measure what the wider instructions give (`fractum bench` under both).

use std::sync::LazyLock;

/// Rows a parallel task hands to one [`vectorised`] call: enough that the dispatch is nothing
/// beside the block's work, few enough that a million rows make hundreds of tasks for rayon to
/// balance.
pub const BLOCK_ROWS: usize = 1024;

/// The environment variable that selects the instruction set: `baseline` or `widest` (the
/// default).
pub const ISA_VARIABLE: &str = "FRACTUM_VECTOR_ISA";

/// Which instructions a kernel runs with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VectorIsa {
    /// What the build targets (SSE2 for a portable x86-64 build).
    Baseline,
    /// The widest set used that the CPU reports (AVX2 + FMA on x86-64).
    Widest,
}

impl VectorIsa {
    /// The set named by `FRACTUM_VECTOR_ISA` (`baseline` or `widest`; unset is `widest`).
    ///
    /// # Errors
    /// Any other value, with what was expected.
    pub fn from_environment() -> Result<Self, String> {
        match std::env::var(ISA_VARIABLE) {
            Err(_) => Ok(Self::Widest),
            Ok(value) => match value.trim() {
                "baseline" => Ok(Self::Baseline),
                "widest" | "" => Ok(Self::Widest),
                other => Err(format!(
                    "{ISA_VARIABLE}={other:?}: expected `baseline` or `widest`"
                )),
            },
        }
    }

    /// The instruction set the process runs its kernels with: the environment's choice, or the
    /// widest where the variable holds something else (the CLI refuses that before a run).
    pub fn selected() -> Self {
        *SELECTED
    }

    /// What the CPU gives under this choice, in words (`AVX2 + FMA`, `baseline`).
    pub fn describe(self) -> &'static str {
        match self.arch() {
            pulp::Arch::Scalar => "baseline",
            #[cfg(any(target_arch = "x86_64", target_arch = "x86"))]
            pulp::Arch::V3(_) => "AVX2 + FMA",
            _ => "the CPU's vector extension",
        }
    }

    fn arch(self) -> pulp::Arch {
        match self {
            Self::Baseline => pulp::Arch::Scalar,
            Self::Widest => *WIDEST,
        }
    }
}

static SELECTED: LazyLock<VectorIsa> =
    LazyLock::new(|| VectorIsa::from_environment().unwrap_or(VectorIsa::Widest));

static WIDEST: LazyLock<pulp::Arch> = LazyLock::new(pulp::Arch::new);

/// Runs `kernel` compiled for the process's instruction set ([`VectorIsa::selected`]).
#[inline(always)]
pub fn vectorised<R>(kernel: impl FnOnce() -> R) -> R {
    vectorised_with(VectorIsa::selected(), kernel)
}

/// Runs `kernel` compiled for `isa`: for tests and measurements that compare the two.
#[inline(always)]
pub fn vectorised_with<R>(isa: VectorIsa, kernel: impl FnOnce() -> R) -> R {
    isa.arch().dispatch(kernel)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::{SymOps, SymTensor3};
    use glam::DMat3;

    /// A strain-rate and stress update of the kind the stress systems run, over many rows.
    fn update(rows: &mut [(SymTensor3, DMat3)], l: DMat3, dt: f64) {
        for (row, (stress, f)) in rows.iter_mut().enumerate() {
            let scale = 1.0 + 1e-3 * row as f64;
            let increment = SymTensor3::sym_of(l * (dt * scale));
            *stress = stress.add_scaled(&increment.hooke(1.7e9, 2.3e9), 1.0);
            *f = (DMat3::IDENTITY + l * dt) * *f;
        }
    }

    #[test]
    fn the_widest_instructions_give_the_baselines_bits() {
        let l = DMat3::from_cols_array(&[0.3, -1.1, 0.7, 2.9, 0.01, -0.4, 1.3, 0.2, -2.2]);
        let start = (
            SymTensor3::sym_of(l),
            DMat3::from_diagonal(glam::DVec3::splat(1.1)),
        );
        let mut baseline = vec![start; 257];
        let mut widest = baseline.clone();
        for _ in 0..10 {
            vectorised_with(VectorIsa::Baseline, || update(&mut baseline, l, 1e-3));
            vectorised_with(VectorIsa::Widest, || update(&mut widest, l, 1e-3));
        }
        for (b, w) in baseline.iter().zip(&widest) {
            assert_eq!(
                b.0.as_3x3().map(f64::to_bits),
                w.0.as_3x3().map(f64::to_bits)
            );
            assert_eq!(
                b.1.to_cols_array().map(f64::to_bits),
                w.1.to_cols_array().map(f64::to_bits)
            );
        }
        assert_ne!(baseline[0], start, "the update changed nothing");
    }

    #[test]
    fn the_environment_names_baseline_or_widest() {
        // Only the parser: the process-wide choice is read once.
        assert!(VectorIsa::Widest.describe().len() > 3);
        assert_eq!(VectorIsa::Baseline.describe(), "baseline");
    }
}
