//! Predictor stage: particle-to-grid transfer and the nodal velocity predictor.
pub mod mls;
pub mod mls_kernel;
pub mod newmark;
pub mod slab_order;
pub mod usl;
