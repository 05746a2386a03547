//! One file per command of the `fractum` binary but `run` and `resume` (`crate::running`) and
//! `systems` (`crate::reports`); `check` is here, its report in `crate::reports`.

pub(crate) mod bench;
pub(crate) mod check;
pub(crate) mod crack;
pub(crate) mod curve;
pub(crate) mod fragments;
pub(crate) mod plot;
pub(crate) mod snapshot;
