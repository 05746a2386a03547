//! The command line's tests: one module per file beside this one, built as one test binary
//! (each built alone linked the whole workspace again). `tools/tests/mpi_run.rs` is a binary
//! of its own, built only with the `mpi` feature. `cargo test -p fractum-cli --test suite
//! <file>::` runs one file's tests.

mod support;

mod cli;
mod fuzz_scenes;
mod guide;
mod long_runs;
mod verify;
