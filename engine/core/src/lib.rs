//! # fractum-engine
//!
//! The ECS core of Fractum, a Material Point Method engine for dynamic fracture and frictional
//! contact. It knows no algorithm and no file: it defines the data (components and resources),
//! the stages of a step, the registry that maps system names to installers, the simulation,
//! health and energy checks, the state a checkpoint carries, the rank decomposition, and test
//! helpers. Algorithms live in `fractum-systems` (or in a user's crate) and plug in through
//! [`registry::Registry`]; scenes are `fractum-scene`'s, files and the run loop `fractum-io`'s,
//! geometry import `fractum-geometry`'s.
//!
//! Everything is generic over the number of space dimensions ([`dim::Dim`]): one source serves
//! 2D plane strain and 3D, and a scene's grid decides which is instantiated.

pub mod boundary;
pub mod budget;
pub mod capability;
pub mod checkpoint;
pub mod columns;
pub mod communicator;
pub mod components;
pub mod connectivity;
pub mod decomposition;
pub mod diagnostics;
pub mod dim;
pub mod energy;
pub mod engine_systems;
pub mod fields;
pub mod health;
pub mod integration;
pub mod loads;
pub mod neighbourhood;
pub mod profile;
pub mod quasi_static;
pub mod registry;
pub mod resources;
pub mod series;
pub mod simulation;
pub mod stage;
pub mod storage;
pub mod strength;
pub mod testing;
pub mod text;
pub mod traffic;
pub mod vector_isa;

pub use simulation::Simulation;

/// What a system file usually needs.
pub mod prelude {
    pub use crate::boundary::{BoundaryConditions, Reactions};
    pub use crate::capability::{Capability, HyperelasticStress};
    pub use crate::components::*;
    pub use crate::connectivity::Connectivity;
    pub use crate::decomposition::{Owned, OwnedRows};
    pub use crate::dim::{
        Dim, Dimension, Lattice, Matrix, MatrixOps, SymOps, SymTensor, SymTensor2, SymTensor3,
        Three, Two, Vector, VectorOps, lattice_range,
    };
    pub use crate::integration::{GridIntegration, ImpulseWindow};
    pub use crate::neighbourhood::Neighbourhoods;
    pub use crate::registry::{
        Installer, MaterialFilter, ParamDoc, Params, Registration, Registry,
    };
    pub use crate::resources::{
        BodyForce, Grid, Material, Materials, NodeWindow, SimClock, Thickness,
    };
    pub use crate::series::SeriesColumns;
    pub use crate::stage::{Stage, StepSet};
    pub use crate::storage::{Untracked, single_table, single_table_mut};
    pub use crate::text::SceneError;
    pub use crate::vector_isa::{BLOCK_ROWS, vectorised};
    pub use crate::{generic_install, with_dim};
    pub use bevy_ecs::prelude::*;
    pub use glam::{DMat2, DMat3, DVec2, DVec3};
}
