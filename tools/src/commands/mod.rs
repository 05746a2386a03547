//! One file per command of the `fractum` binary but `run` and `resume` (`crate::running`) and
//! `check` and `systems` (`crate::reports`).

pub(crate) mod bench;
pub(crate) mod crack;
pub(crate) mod curve;
pub(crate) mod fragments;
pub(crate) mod plot;
pub(crate) mod snapshot;
