//! # fractum-io
//!
//! What a Fractum run writes and reads, and the loop that writes it: VTU particle and grid
//! frames with PVTU pieces and a PVD collection for ParaView, the `series.csv` time series and
//! its probes ([`output`]), checkpoint files ([`checkpoint`]), and the run loop that steps a
//! [`fractum_engine::Simulation`], writes its outputs and checkpoints, and keeps ranks in step
//! ([`run`]). It knows no scene format: a scene builds the world and hands the loop an
//! [`output::OutputPlan`].

pub mod checkpoint;
pub mod output;
pub mod run;
