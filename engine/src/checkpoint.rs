//! Checkpoints: the state a run carries from one step to the next, captured so that a run
//! continued from it takes bitwise the same steps as one that never stopped.
//!
//! What is state is declared, not guessed. [`CheckpointState`] lists every component and
//! resource a checkpoint carries:
//! - the engine registers the particles' own components and its running totals (the energy
//!   account and watch, the force probes' memory, the removed particles, the published
//!   columns) when it builds a scene;
//! - every component a system gives particles through
//!   [`crate::registry::Installer::add_particle_component`] is registered by that call, so a
//!   system cannot add per-particle data that a checkpoint forgets;
//! - a system's resource that carries values between steps (a warm start, a cached neighbour
//!   list, a running total) is installed with [`crate::registry::Installer::insert_state`] or
//!   [`crate::registry::Installer::init_state`].
//!
//! Everything else is rebuilt from the scene (grid, materials, parameters) or recomputed by
//! every step before it is read (nodal fields, connectivity, scratch buffers). Particles are
//! matched by [`ParticleId`]; particles removed on leaving the grid are removed again in the
//! order they went, so the storage order, and with it every sum's order, is the original.

use crate::components::{Particle, ParticleId};
use bevy_ecs::prelude::*;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// Data a checkpoint can carry: serde both ways, safe to share between threads, and stored
/// under an explicit [`State::KEY`].
pub trait State: Serialize + DeserializeOwned + Send + Sync + 'static {
    /// The name the value is stored under: stable across builds and compilers (never derived
    /// from the type's Rust path), unique among everything a run carries. Stock keys are
    /// `particle/…`, `engine/…` and `<system>/…`; a user's crate should prefix its own.
    const KEY: &'static str;
}

/// Implements [`State`] for types with explicit keys: `checkpoint_keys! { MyTotal => "my/total" }`.
/// A generic type is written out by hand (`impl<D: Dim> State for MyState<D> { … }`).
#[macro_export]
macro_rules! checkpoint_keys {
    ($($ty:ty => $key:literal),* $(,)?) => {
        $(impl $crate::checkpoint::State for $ty {
            const KEY: &'static str = $key;
        })*
    };
}

/// Implements [`State`] for generic-over-`D` engine types.
macro_rules! dim_keys {
    ($($ty:ident => $key:literal),* $(,)?) => {
        $(impl<D: crate::dim::Dim> State for crate::components::$ty<D> {
            const KEY: &'static str = $key;
        })*
    };
}

dim_keys! {
    Position => "particle/position",
    Velocity => "particle/velocity",
    Acceleration => "particle/acceleration",
    DeformationGradient => "particle/deformation_gradient",
    Stress => "particle/stress",
    Strain => "particle/strain",
    ExternalForce => "particle/external_force",
    DamageGradient => "particle/damage_gradient",
}

checkpoint_keys! {
    crate::components::Mass => "particle/mass",
    crate::components::Volume => "particle/volume",
    crate::components::InitialVolume => "particle/initial_volume",
    crate::components::StrainEnergyDensity => "particle/strain_energy_density",
    crate::components::WaveSpeed => "particle/wave_speed",
    crate::components::Damage => "particle/damage",
    crate::components::DamageHistory => "particle/damage_history",
    crate::components::MaterialId => "particle/material",
    crate::components::BodyId => "particle/body",
    crate::components::ContactGroup => "particle/contact_group",
    crate::components::Strength => "particle/strength",
    crate::components::CrackOpening => "particle/crack_opening",
    crate::components::SurfaceFlag => "particle/surface_flag",
    crate::loads::LoadShare => "particle/load_share",
    crate::resources::SimClock => "engine/clock",
    crate::energy::EnergyAccount => "engine/energy_account",
    crate::energy::EnergyWatch => "engine/energy_watch",
    crate::run::ForceProbeMemory => "engine/force_probes",
    crate::health::EscapedParticles => "engine/escaped_particles",
    crate::series::SeriesColumns => "engine/series_columns",
}

/// Why a checkpoint could not be written or restored.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// A value could not be encoded or decoded.
    #[error("cannot encode or decode {what}: {source}")]
    Codec {
        /// The component or resource.
        what: String,
        /// The cause.
        source: postcard::Error,
    },
    /// The checkpoint does not fit the world rebuilt from the scene.
    #[error("{0}")]
    Mismatch(String),
}

type SaveComponent = fn(&mut World, &[Entity]) -> Result<Vec<u8>, CheckpointError>;
type LoadComponent = fn(&mut World, &[Entity], &[u8]) -> Result<(), CheckpointError>;
type SaveResource = fn(&World) -> Result<Option<Vec<u8>>, CheckpointError>;
type LoadResource = fn(&mut World, &[u8]) -> Result<(), CheckpointError>;

#[derive(Clone, Copy)]
struct ComponentEntry {
    name: &'static str,
    type_id: std::any::TypeId,
    save: SaveComponent,
    load: LoadComponent,
}

#[derive(Clone, Copy)]
struct ResourceEntry {
    name: &'static str,
    type_id: std::any::TypeId,
    save: SaveResource,
    load: LoadResource,
}

/// The components and resources a checkpoint carries (see the module header).
#[derive(Resource, Clone, Default)]
pub struct CheckpointState {
    components: Vec<ComponentEntry>,
    resources: Vec<ResourceEntry>,
    /// Keys asked for by two different types (a scene with any is refused).
    collisions: Vec<&'static str>,
}

impl std::fmt::Debug for CheckpointState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CheckpointState")
            .field("components", &self.component_names())
            .field("resources", &self.resource_names())
            .finish()
    }
}

impl CheckpointState {
    /// Carries particle component `C` (once, however often it is asked).
    pub fn component<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(&mut self) {
        let (name, type_id) = (C::KEY, std::any::TypeId::of::<C>());
        if self.is_new(name, type_id) {
            self.components.push(ComponentEntry {
                name,
                type_id,
                save: save_component::<C>,
                load: load_component::<C>,
            });
        }
    }

    /// Carries resource `R` (once, however often it is asked).
    pub fn resource<R: Resource + State>(&mut self) {
        let (name, type_id) = (R::KEY, std::any::TypeId::of::<R>());
        if self.is_new(name, type_id) {
            self.resources.push(ResourceEntry {
                name,
                type_id,
                save: save_resource::<R>,
                load: load_resource::<R>,
            });
        }
    }

    /// Whether `name` is not carried yet; a key already taken by another type is recorded as
    /// a collision.
    fn is_new(&mut self, name: &'static str, type_id: std::any::TypeId) -> bool {
        let taken = self
            .components
            .iter()
            .map(|e| (e.name, e.type_id))
            .chain(self.resources.iter().map(|e| (e.name, e.type_id)))
            .find(|(n, _)| *n == name);
        match taken {
            None => true,
            Some((_, t)) if t == type_id => false,
            Some(_) => {
                self.collisions.push(name);
                false
            }
        }
    }

    /// Keys that two different types asked for.
    pub fn collisions(&self) -> &[&'static str] {
        &self.collisions
    }

    /// Names of the carried components.
    pub fn component_names(&self) -> Vec<&'static str> {
        self.components.iter().map(|e| e.name).collect()
    }

    /// Names of the carried resources.
    pub fn resource_names(&self) -> Vec<&'static str> {
        self.resources.iter().map(|e| e.name).collect()
    }
}

/// Registers particle component `C` with the world's [`CheckpointState`].
pub fn carry_component<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(
    world: &mut World,
) {
    world
        .get_resource_or_init::<CheckpointState>()
        .component::<C>();
}

/// Registers resource `R` with the world's [`CheckpointState`].
pub fn carry_resource<R: Resource + State>(world: &mut World) {
    world
        .get_resource_or_init::<CheckpointState>()
        .resource::<R>();
}

fn codec(what: &str) -> impl FnOnce(postcard::Error) -> CheckpointError + '_ {
    move |source| CheckpointError::Codec {
        what: what.to_string(),
        source,
    }
}

fn save_component<C: Component + State>(
    world: &mut World,
    particles: &[Entity],
) -> Result<Vec<u8>, CheckpointError> {
    let values: Vec<Option<&C>> = particles.iter().map(|&e| world.get::<C>(e)).collect();
    postcard::to_allocvec(&values).map_err(codec(C::KEY))
}

fn load_component<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(
    world: &mut World,
    particles: &[Entity],
    bytes: &[u8],
) -> Result<(), CheckpointError> {
    let name = C::KEY;
    let values: Vec<Option<C>> = postcard::from_bytes(bytes).map_err(codec(name))?;
    if values.len() != particles.len() {
        return Err(CheckpointError::Mismatch(format!(
            "{name}: the checkpoint has {} particles, the scene {}",
            values.len(),
            particles.len()
        )));
    }
    for (&entity, value) in particles.iter().zip(values) {
        match (world.get_mut::<C>(entity), value) {
            (Some(mut slot), Some(value)) => *slot = value,
            (None, None) => {}
            _ => {
                return Err(CheckpointError::Mismatch(format!(
                    "{name}: the particles that have it differ between the checkpoint and the \
                     scene"
                )));
            }
        }
    }
    Ok(())
}

fn save_resource<R: Resource + State>(world: &World) -> Result<Option<Vec<u8>>, CheckpointError> {
    world
        .get_resource::<R>()
        .map(|r| postcard::to_allocvec(r).map_err(codec(R::KEY)))
        .transpose()
}

fn load_resource<R: Resource + State>(
    world: &mut World,
    bytes: &[u8],
) -> Result<(), CheckpointError> {
    let value: R = postcard::from_bytes(bytes).map_err(codec(R::KEY))?;
    world.insert_resource(value);
    Ok(())
}

/// Registers what the engine itself carries from step to step: every component particles are
/// spawned with (their id is the key, not carried), the clock, and the running totals.
pub fn carry_engine_state<D: crate::dim::Dim>(world: &mut World) {
    use crate::components::*;
    let mut state = world.get_resource_or_init::<CheckpointState>();
    state.component::<Position<D>>();
    state.component::<Velocity<D>>();
    state.component::<Acceleration<D>>();
    state.component::<Mass>();
    state.component::<Volume>();
    state.component::<InitialVolume>();
    state.component::<DeformationGradient<D>>();
    state.component::<Stress<D>>();
    state.component::<Strain<D>>();
    state.component::<StrainEnergyDensity>();
    state.component::<WaveSpeed>();
    state.component::<Damage>();
    state.component::<DamageHistory>();
    state.component::<MaterialId>();
    state.component::<BodyId>();
    state.component::<ContactGroup>();
    state.component::<ExternalForce<D>>();
    state.component::<crate::loads::LoadShare>();
    state.resource::<crate::resources::SimClock>();
    state.resource::<crate::energy::EnergyAccount>();
    state.resource::<crate::energy::EnergyWatch>();
    state.resource::<crate::run::ForceProbeMemory>();
    state.resource::<crate::health::EscapedParticles>();
    state.resource::<crate::series::SeriesColumns>();
}

/// The state of a world: its particles in storage order, those removed so far in the order
/// they went, and each carried component and resource, encoded.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorldState {
    /// The live particles' ids, in storage (query) order.
    pub particles: Vec<u32>,
    /// The removed particles' ids, in the order they were removed.
    pub removed: Vec<u32>,
    /// Component name and its values, one per live particle in `particles` order.
    pub components: Vec<(String, Vec<u8>)>,
    /// Resource name and its value (absent resources are not listed).
    pub resources: Vec<(String, Vec<u8>)>,
}

fn particles_in_order(world: &mut World) -> (Vec<Entity>, Vec<u32>) {
    let mut query = world.query_filtered::<(Entity, &ParticleId), With<Particle>>();
    query.iter(world).map(|(e, id)| (e, id.0)).unzip()
}

/// Captures the state of `world` that its [`CheckpointState`] lists.
pub fn capture(world: &mut World) -> Result<WorldState, CheckpointError> {
    let state = world
        .get_resource::<CheckpointState>()
        .cloned()
        .unwrap_or_default();
    let (entities, particles) = particles_in_order(world);
    let removed = world
        .get_resource::<crate::health::EscapedParticles>()
        .map(|e| e.removed.clone())
        .unwrap_or_default();
    let mut components = Vec::new();
    for entry in &state.components {
        components.push((entry.name.to_string(), (entry.save)(world, &entities)?));
    }
    let mut resources = Vec::new();
    for entry in &state.resources {
        if let Some(bytes) = (entry.save)(world)? {
            resources.push((entry.name.to_string(), bytes));
        }
    }
    Ok(WorldState {
        particles,
        removed,
        components,
        resources,
    })
}

/// Puts `saved` into `world`, a world freshly built from the same scene: removes the particles
/// removed before the checkpoint in their order, checks that the storage order is the saved
/// one, and overwrites every carried component and resource.
pub fn restore(world: &mut World, saved: &WorldState) -> Result<(), CheckpointError> {
    let state = world
        .get_resource::<CheckpointState>()
        .cloned()
        .unwrap_or_default();
    let (entities, ids) = particles_in_order(world);
    let by_id: std::collections::HashMap<u32, Entity> =
        ids.iter().copied().zip(entities.iter().copied()).collect();
    for id in &saved.removed {
        let entity = by_id.get(id).copied().ok_or_else(|| {
            CheckpointError::Mismatch(format!(
                "the checkpoint removed particle {id}, which the scene does not have"
            ))
        })?;
        world.despawn(entity);
    }
    let (entities, ids) = particles_in_order(world);
    if ids != saved.particles {
        return Err(CheckpointError::Mismatch(format!(
            "the scene's particles ({}) are not the checkpoint's ({}) in the same order",
            ids.len(),
            saved.particles.len()
        )));
    }
    let saved_names: Vec<&str> = saved.components.iter().map(|(n, _)| n.as_str()).collect();
    let names = state.component_names();
    if names != saved_names {
        return Err(CheckpointError::Mismatch(format!(
            "the pipeline carries the particle components {names:?}, the checkpoint \
             {saved_names:?}"
        )));
    }
    for (entry, (_, bytes)) in state.components.iter().zip(&saved.components) {
        (entry.load)(world, &entities, bytes)?;
    }
    for (name, bytes) in &saved.resources {
        let entry = state
            .resources
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| {
                CheckpointError::Mismatch(format!(
                    "the checkpoint carries {name}, which this scene's pipeline does not have"
                ))
            })?;
        (entry.load)(world, bytes)?;
    }
    Ok(())
}

/// The format of checkpoint files; a file of another format is refused. Format 2: the
/// postcard-encoded [`CheckpointFile`], then the FNV-1a digest of those bytes (8 bytes, little
/// endian), so that a damaged file is refused, not resumed with altered numbers.
pub const CHECKPOINT_FORMAT: u32 = 2;

/// Checkpoints kept by default.
pub const DEFAULT_KEEP: usize = 3;

/// The folder of an output folder that holds its checkpoints.
pub const CHECKPOINT_DIR: &str = "checkpoints";

/// How often checkpoints are written.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum CheckpointEvery {
    /// Every so many steps.
    Steps(u64),
    /// Every so much simulated time (s).
    Time(f64),
}

impl std::str::FromStr for CheckpointEvery {
    type Err = String;

    /// `1000` (steps) or `2.5e-5s` (simulated seconds).
    fn from_str(text: &str) -> Result<Self, String> {
        let text = text.trim();
        if let Some(seconds) = text.strip_suffix('s') {
            return match seconds.trim().parse::<f64>() {
                Ok(t) if t.is_finite() && t > 0.0 => Ok(CheckpointEvery::Time(t)),
                _ => Err(format!(
                    "`{text}`: expected a positive time in seconds such as `2.5e-5s`"
                )),
            };
        }
        match text.parse::<u64>() {
            Ok(n) if n > 0 => Ok(CheckpointEvery::Steps(n)),
            _ => Err(format!(
                "`{text}`: expected a number of steps such as `1000`, or a time such as `2.5e-5s`"
            )),
        }
    }
}

/// The scene a run was built from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneRecord {
    /// The scene file as given on the command line, made absolute where possible.
    pub path: String,
    /// Its text.
    pub text: String,
}

impl SceneRecord {
    /// A 64-bit FNV-1a digest of the text (to tell whether a file changed).
    pub fn digest(&self) -> u64 {
        fnv1a(self.text.as_bytes())
    }
}

/// What the outputs held at a checkpoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointOutputs {
    /// The length of `series.csv` then (bytes).
    pub series_bytes: u64,
    /// Particle frames written by then: (time, file relative to the output folder).
    pub frames: Vec<(f64, String)>,
    /// Grid frames written by then.
    pub grid_frames: Vec<(f64, String)>,
    /// The simulated time of the next checkpoint on a time schedule.
    pub next_checkpoint_time: Option<f64>,
}

/// One checkpoint file: who wrote it, from which scene, and everything the run needs to
/// continue.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointFile {
    /// [`CHECKPOINT_FORMAT`] when written.
    pub format: u32,
    /// The Fractum version that wrote it.
    pub version: String,
    /// A digest of the executable that wrote it ([`binary_identity`]).
    pub binary: u64,
    /// The scene.
    pub scene: SceneRecord,
    /// The run's end (the scene's, or `--steps`).
    pub end: crate::simulation::End,
    /// The clock's running-sum compensation.
    pub time_compensation: f64,
    /// The world.
    pub world: WorldState,
    /// The outputs.
    pub outputs: CheckpointOutputs,
}

fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &b| {
        (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// A digest of the running executable's bytes (0 where it cannot be read): two builds that
/// differ in any way, even one that would round a sum differently, differ here.
pub fn binary_identity() -> u64 {
    static IDENTITY: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *IDENTITY.get_or_init(|| {
        std::env::current_exe()
            .and_then(std::fs::read)
            .map_or(0, |bytes| fnv1a(&bytes))
    })
}

/// The file name of the checkpoint after `step`: never matched by `*.csv` or `*.vtu`.
pub fn checkpoint_name(step: u64) -> String {
    format!("checkpoint_{step:012}.bin")
}

/// The step a checkpoint file name is for.
fn step_of_name(name: &str) -> Option<u64> {
    name.strip_prefix("checkpoint_")?
        .strip_suffix(".bin")?
        .parse()
        .ok()
}

/// The checkpoints in `out_dir`, oldest first.
pub fn list_checkpoints(out_dir: &std::path::Path) -> Vec<(u64, std::path::PathBuf)> {
    let dir = out_dir.join(CHECKPOINT_DIR);
    let mut found: Vec<(u64, std::path::PathBuf)> = std::fs::read_dir(&dir)
        .map(|entries| {
            entries
                .flatten()
                .filter_map(|e| {
                    let step = step_of_name(&e.file_name().to_string_lossy())?;
                    Some((step, e.path()))
                })
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    found
}

/// Writes the checkpoint of `sim` after its current step into `out_dir/checkpoints`
/// atomically, and deletes all but the newest `keep`. Returns its path.
pub fn write_checkpoint(
    sim: &mut crate::Simulation,
    out_dir: &std::path::Path,
    scene: &SceneRecord,
    outputs: CheckpointOutputs,
    keep: usize,
) -> Result<std::path::PathBuf, crate::run::RunError> {
    let file = CheckpointFile {
        format: CHECKPOINT_FORMAT,
        version: env!("CARGO_PKG_VERSION").to_string(),
        binary: binary_identity(),
        scene: scene.clone(),
        end: sim.end(),
        time_compensation: sim.time_compensation(),
        world: capture(&mut sim.world)
            .map_err(|e| crate::run::RunError::Checkpoint(e.to_string()))?,
        outputs,
    };
    let bytes = sealed(
        postcard::to_allocvec(&file)
            .map_err(|e| crate::run::RunError::Checkpoint(e.to_string()))?,
    );
    let dir = out_dir.join(CHECKPOINT_DIR);
    let io = |path: &std::path::Path| {
        let path = path.to_path_buf();
        move |source| crate::run::RunError::Io { path, source }
    };
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    let path = dir.join(checkpoint_name(sim.clock().step));
    crate::output::write_atomically(&path, &bytes).map_err(io(&path))?;
    let all = list_checkpoints(out_dir);
    for (_, old) in all.iter().take(all.len().saturating_sub(keep.max(1))) {
        let _ = std::fs::remove_file(old);
    }
    Ok(path)
}

/// `payload` followed by its digest.
fn sealed(mut payload: Vec<u8>) -> Vec<u8> {
    let digest = fnv1a(&payload);
    payload.extend_from_slice(&digest.to_le_bytes());
    payload
}

/// The payload of sealed `bytes`, or `None` when the digest does not match (the file was cut
/// short, or any byte of it changed).
fn unsealed(bytes: &[u8]) -> Option<&[u8]> {
    let (payload, digest) = bytes.split_at_checked(bytes.len().checked_sub(8)?)?;
    (fnv1a(payload).to_le_bytes() == digest).then_some(payload)
}

/// Reads a checkpoint file and checks that it is whole and that this binary wrote it.
pub fn read_checkpoint(path: &std::path::Path) -> Result<CheckpointFile, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let Some(payload) = unsealed(&bytes) else {
        return Err(format!(
            "{} is damaged or not a checkpoint this version of Fractum can read: its digest \
             does not match its contents (cut short, or changed since it was written)",
            path.display()
        ));
    };
    let file: CheckpointFile = postcard::from_bytes(payload).map_err(|e| {
        format!(
            "{} is not a checkpoint this version of Fractum can read ({e})",
            path.display()
        )
    })?;
    if file.format != CHECKPOINT_FORMAT || file.version != env!("CARGO_PKG_VERSION") {
        return Err(format!(
            "{} was written by Fractum {} (checkpoint format {}), this is {} (format {}); \
             resume it with the binary that wrote it",
            path.display(),
            file.version,
            file.format,
            env!("CARGO_PKG_VERSION"),
            CHECKPOINT_FORMAT
        ));
    }
    if file.binary != binary_identity() {
        return Err(format!(
            "{} was written by another build of Fractum {} (executable digest {:016x}, this one \
             {:016x}); a different build can round differently, so the run would not continue \
             as it began. Resume it with the binary that wrote it, or start the run again",
            path.display(),
            file.version,
            file.binary,
            binary_identity()
        ));
    }
    Ok(file)
}

/// Puts a checkpoint into `sim`, freshly built from the checkpoint's scene, and winds the
/// outputs in `out_dir` back to it: `series.csv` is cut to its rows then, and frames written
/// after it are deleted. Returns the outputs for [`crate::run::run_with`] to continue.
pub fn resume_from(
    sim: &mut crate::Simulation,
    out_dir: &std::path::Path,
    file: &CheckpointFile,
) -> Result<crate::run::ResumedOutputs, String> {
    restore_checkpoint(sim, file)?;
    rewind_outputs(out_dir, file, sim.clock().step)
}

/// Puts a checkpoint into `sim`, freshly built from the checkpoint's scene: the world, the
/// clock's compensation and the run's end. The outputs are not touched.
pub fn restore_checkpoint(
    sim: &mut crate::Simulation,
    file: &CheckpointFile,
) -> Result<(), String> {
    restore(&mut sim.world, &file.world)
        .map_err(|e| format!("the checkpoint does not fit the world built from its scene: {e}"))?;
    sim.set_time_compensation(file.time_compensation);
    sim.set_end(file.end);
    Ok(())
}

/// Winds the outputs in `out_dir` back to checkpoint `file`, taken after `step`: the rows of
/// `series.csv` then (returned, for the run to rewrite), and no frame written after it. Call it
/// only once the run is sure to go on: it deletes those frames.
pub fn rewind_outputs(
    out_dir: &std::path::Path,
    file: &CheckpointFile,
    step: u64,
) -> Result<crate::run::ResumedOutputs, String> {
    let series_path = out_dir.join("series.csv");
    let mut series = std::fs::read_to_string(&series_path)
        .map_err(|e| format!("cannot read {}: {e}", series_path.display()))?;
    let kept = file.outputs.series_bytes as usize;
    if series.len() < kept || !series.is_char_boundary(kept) {
        return Err(format!(
            "{} holds {} bytes, fewer than the {kept} it held at the checkpoint of step {step}; \
             it was changed since",
            series_path.display(),
            series.len()
        ));
    }
    series.truncate(kept);
    let listed: std::collections::HashSet<&str> = file
        .outputs
        .frames
        .iter()
        .chain(&file.outputs.grid_frames)
        .map(|(_, f)| f.as_str())
        .collect();
    if let Ok(entries) = std::fs::read_dir(out_dir.join("frames")) {
        for entry in entries.flatten() {
            let name = format!("frames/{}", entry.file_name().to_string_lossy());
            if name.ends_with(".vtu") && !listed.contains(name.as_str()) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    for (collection, frames) in [
        ("particles.pvd", &file.outputs.frames),
        ("grid.pvd", &file.outputs.grid_frames),
    ] {
        if !frames.is_empty() {
            let path = out_dir.join(collection);
            crate::output::write_pvd(&path, frames)
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        }
    }
    Ok(crate::run::ResumedOutputs {
        series,
        frames: file.outputs.frames.clone(),
        grid_frames: file.outputs.grid_frames.clone(),
        next_checkpoint_time: file.outputs.next_checkpoint_time,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoint_schedules_read_as_steps_or_seconds() {
        assert_eq!("1000".parse(), Ok(CheckpointEvery::Steps(1000)));
        assert_eq!("2.5e-5s".parse(), Ok(CheckpointEvery::Time(2.5e-5)));
        assert!("0".parse::<CheckpointEvery>().is_err());
        assert!("-1s".parse::<CheckpointEvery>().is_err());
        assert!("often".parse::<CheckpointEvery>().is_err());
    }

    fn checkpoint_of(binary: u64, version: &str) -> CheckpointFile {
        CheckpointFile {
            format: CHECKPOINT_FORMAT,
            version: version.to_string(),
            binary,
            scene: SceneRecord {
                path: "scene.ron".into(),
                text: "()".into(),
            },
            end: crate::simulation::End::Steps(10),
            time_compensation: 0.0,
            world: WorldState::default(),
            outputs: CheckpointOutputs {
                series_bytes: 0,
                frames: Vec::new(),
                grid_frames: Vec::new(),
                next_checkpoint_time: None,
            },
        }
    }

    /// A checkpoint reads back as written from this binary, and is refused with the reason
    /// when another build or version wrote it, or when it is cut short.
    #[test]
    fn checkpoints_of_another_build_or_damaged_are_refused() {
        let dir = std::env::temp_dir().join(format!("fractum-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(checkpoint_name(10));
        let write = |file: &CheckpointFile| {
            std::fs::write(&path, sealed(postcard::to_allocvec(file).unwrap())).unwrap();
        };
        let ours = checkpoint_of(binary_identity(), env!("CARGO_PKG_VERSION"));
        write(&ours);
        assert_eq!(read_checkpoint(&path).unwrap(), ours);
        write(&checkpoint_of(
            binary_identity() ^ 1,
            env!("CARGO_PKG_VERSION"),
        ));
        let refused = read_checkpoint(&path).unwrap_err();
        assert!(refused.contains("another build"), "{refused}");
        write(&checkpoint_of(binary_identity(), "0.0.1"));
        let refused = read_checkpoint(&path).unwrap_err();
        assert!(refused.contains("written by Fractum 0.0.1"), "{refused}");
        let bytes = sealed(postcard::to_allocvec(&ours).unwrap());
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let refused = read_checkpoint(&path).unwrap_err();
        assert!(refused.contains("is damaged"), "{refused}");
        // One bit flipped anywhere, in a number the decoder would have taken as it is.
        for at in [0, 1, bytes.len() / 3, bytes.len() - 9, bytes.len() - 1] {
            let mut flipped = bytes.clone();
            flipped[at] ^= 0x10;
            std::fs::write(&path, &flipped).unwrap();
            let refused = read_checkpoint(&path).unwrap_err();
            assert!(
                refused.contains("digest does not match"),
                "byte {at}: {refused}"
            );
        }
        std::fs::write(&path, &bytes[..5]).unwrap();
        assert!(read_checkpoint(&path).is_err());
        std::fs::write(&path, b"").unwrap();
        assert!(read_checkpoint(&path).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn checkpoint_names_sort_by_step_and_match_no_output_glob() {
        let name = checkpoint_name(42);
        assert_eq!(step_of_name(&name), Some(42));
        assert!(!name.ends_with(".csv") && !name.ends_with(".vtu"));
        assert!(checkpoint_name(9) < checkpoint_name(10));
    }
}
