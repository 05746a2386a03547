//! The workspace's integration tests: one module per file beside this one, built as one test
//! binary. Built one binary per file, each linked the engine, the systems and the CLI and
//! compiled their generic code again: 15 to 22 s of wall time per file on two cores, for 20
//! files, against 39 s for all of them here. `cargo test --test suite <file>::` runs one
//! file's tests.

mod affine;
mod bad_scenes;
mod blowup;
mod checkpoint;
mod contact;
mod crate_floors;
mod determinism;
mod distributed;
mod distributed_run;
mod energy_account;
mod fracture;
mod house_rules;
mod images;
mod materials;
mod meshes;
mod nonlocal;
mod out_of_tree;
mod overlap;
mod patch;
mod pipeline_order;
mod points;
mod quasi_static;
mod scene_reference;
mod scenes;
mod surfaces;
mod verification;
