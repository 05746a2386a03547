//! [`Simulation`]: the world, the step schedule, the clock and the thread pool.

use crate::components::{MaterialId, Particle, ParticleId, Position, Velocity, WaveSpeed};
use crate::dim::{Dim, Dimension, VectorOps};
use crate::health::{Blowup, Health, healthy};
use crate::resources::{Grid, Materials, SimClock, TimeStepLimit};
use crate::stage::{Stage, StepSet, configure_step};
use crate::with_dim;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::{LogLevel, ScheduleBuildSettings, ScheduleLabel, SingleThreadedExecutor};

/// How the size of each step is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeStep {
    /// A fixed step in seconds; must not exceed the stable limit.
    Fixed(f64),
    /// A fraction in (0, 1] of the stable limit, re-evaluated every step.
    Cfl(f64),
}

/// When a run ends.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum End {
    /// Simulated time in seconds.
    Time(f64),
    /// Number of steps.
    Steps(u64),
}

/// Label of the one schedule that takes a step.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct StepSchedule;

/// An empty step schedule: single-threaded executor, ambiguities are errors, the step ordered
/// as [`crate::stage`] declares it, and every stage and window skipped after a failure. Add the health checks with
/// [`crate::engine_systems::add_stage_checks`] once the pipeline is installed.
pub fn step_schedule() -> Schedule {
    let mut schedule = Schedule::new(StepSchedule);
    schedule.set_executor(SingleThreadedExecutor::new());
    schedule.set_build_settings(ScheduleBuildSettings {
        ambiguity_detection: LogLevel::Error,
        ..Default::default()
    });
    configure_step(&mut schedule);
    for stage in Stage::ORDER {
        schedule.configure_sets(stage.run_if(healthy));
    }
    for window in StepSet::ALL {
        schedule.configure_sets(window.run_if(healthy));
    }
    schedule
}

/// Builds the schedule's executable form now, turning ordering problems into a message that
/// names the systems involved.
pub fn initialize_schedule(schedule: &mut Schedule, world: &mut World) -> Result<(), String> {
    world.init_resource::<Health>();
    world.init_resource::<crate::health::EscapedParticles>();
    schedule
        .initialize(world)
        .map(|_| ())
        .map_err(|e| e.to_string(schedule.graph(), world))
}

/// Scenes with fewer particles than this run their steps on one thread whatever the pool size
/// (2D, 3D): below it, the synchronisation of the 15–20 parallel sections of a step costs more
/// than the second thread gains. Measured with `fractum bench` on the 2-core machine
/// (BENCHMARKS.md): in 2D one and two threads break even near 2 000 particles for both stock
/// pipelines, in 3D between 1 000 and 1 700.
pub const SERIAL_BELOW: [usize; 2] = [2000, 1000];

thread_local! {
    /// A one-thread rayon pool whose one thread is this thread (built on first use).
    static THIS_THREAD: Option<rayon::ThreadPool> = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .use_current_thread()
        .build()
        .ok();
}

/// Runs `f` on the calling thread with every rayon parallel section inside it sequential.
///
/// A step on a separate one-thread pool hands the work to that pool's thread and sleeps until
/// it is done: two context switches per step, which on small scenes cost more than the step
/// (15% of a 400-particle LME run). Here the calling thread is itself the pool's one thread, so
/// `install` runs `f` in place. rayon keeps such a pool for the life of the thread, one per
/// thread; where it cannot be made (the thread already belongs to another pool) `f` runs in a
/// fresh one-thread pool instead.
pub fn on_this_thread<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    THIS_THREAD.with(|pool| match pool {
        Some(pool) => pool.install(f),
        None => match rayon::ThreadPoolBuilder::new().num_threads(1).build() {
            Ok(pool) => pool.install(f),
            Err(_) => f(),
        },
    })
}

/// A loaded scene ready to step.
pub struct Simulation {
    /// All entities and resources.
    pub world: World,
    dimension: Dimension,
    schedule: Schedule,
    pool: Option<rayon::ThreadPool>,
    /// Whether [`Simulation::set_threads`] was called: without it steps use rayon's global
    /// pool, and a small scene or a global pool of one thread steps on the calling thread;
    /// with it, one thread or a small scene steps on the calling thread.
    threads_set: bool,
    /// Particle count below which steps run on the calling thread alone.
    serial_below: usize,
    /// Particles when the simulation was made or its pools were (removals only make a scene
    /// smaller).
    particles_at_start: usize,
    time_step: TimeStep,
    end: End,
    /// A step the run stops at if it comes before the end (`--steps`).
    step_cap: Option<u64>,
    /// Kahan compensation of the clock's running sum of step sizes.
    time_compensation: f64,
}

impl Simulation {
    /// Wraps a world built for dimension `D` and its schedule; initialises the schedule (see
    /// [`initialize_schedule`]).
    pub fn new<D: Dim>(
        mut world: World,
        mut schedule: Schedule,
        time_step: TimeStep,
        end: End,
    ) -> Result<Self, String> {
        world.init_resource::<SimClock>();
        world.insert_resource(D::DIMENSION);
        initialize_schedule(&mut schedule, &mut world)?;
        if let Some(plan) = crate::health::plan_checks::<D>(&schedule, &world) {
            world.insert_resource(plan);
        }
        let mut simulation = Self {
            world,
            dimension: D::DIMENSION,
            schedule,
            pool: None,
            threads_set: false,
            serial_below: match D::DIMENSION {
                Dimension::Two => SERIAL_BELOW[0],
                Dimension::Three => SERIAL_BELOW[1],
            },
            particles_at_start: 0,
            time_step,
            end,
            step_cap: None,
            time_compensation: 0.0,
        };
        simulation.particles_at_start = simulation.particle_count();
        Ok(simulation)
    }

    /// Runs the parallel kernels on a pool of `threads` threads; a scene with fewer particles
    /// than [`SERIAL_BELOW`] steps on one thread (results are bitwise the same either way).
    /// One thread means the calling thread itself (see [`on_this_thread`]).
    pub fn set_threads(&mut self, threads: usize) -> Result<(), rayon::ThreadPoolBuildError> {
        self.pool = if threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()?,
            )
        } else {
            None
        };
        self.threads_set = true;
        self.particles_at_start = self.particle_count();
        Ok(())
    }

    /// Changes the particle count below which steps run on one thread (0: never), e.g. to test
    /// a small scene on several threads.
    pub fn set_serial_below(&mut self, particles: usize) {
        self.serial_below = particles;
    }

    /// Whether steps run on the calling thread alone: one thread asked, or a small scene.
    /// Without a thread count set, a small scene or rayon's global pool of one thread
    /// (`RAYON_NUM_THREADS=1`), unless the caller is itself a thread of a rayon pool (a
    /// simulation stepped inside a parallel section), whose pool its kernels then share.
    fn runs_serially(&self) -> bool {
        if self.threads_set {
            return self.pool.is_none() || self.particles_at_start < self.serial_below;
        }
        rayon::current_thread_index().is_none()
            && (rayon::current_num_threads() == 1 || self.particles_at_start < self.serial_below)
    }

    /// Runs `f` on this simulation where its steps run: on the calling thread alone, or in its
    /// pool (rayon's global pool when no thread count was set).
    fn in_pool<R: Send>(&mut self, f: impl FnOnce(&mut Self) -> R + Send) -> R {
        let serially = self.runs_serially();
        match self.pool.take() {
            Some(pool) if !serially => {
                let result = pool.install(|| f(self));
                self.pool = Some(pool);
                result
            }
            pool => {
                self.pool = pool;
                if serially {
                    on_this_thread(|| f(self))
                } else {
                    f(self)
                }
            }
        }
    }

    /// Times every stage of the following steps ([`crate::profile::StageClock`], a resource of
    /// the world): for profiling; the markers cost two clock reads per stage.
    pub fn profile_stages(&mut self) -> Result<(), String> {
        if self.world.contains_resource::<crate::profile::StageClock>() {
            return Ok(());
        }
        self.world.init_resource::<crate::profile::StageClock>();
        crate::profile::install_stage_clock(&mut self.schedule);
        initialize_schedule(&mut self.schedule, &mut self.world)
    }

    /// Takes the world and the step schedule of `fresh`, a simulation of the same scene built
    /// afresh (a rank's world for re-cut slabs, `fractum_io::run::distributed::step`), keeping
    /// this one's threads, end, step cap and clock compensation; the stage times of profiling
    /// go on adding up.
    pub fn adopt_world(&mut self, fresh: Simulation) -> Result<(), String> {
        let profiled = self.world.remove_resource::<crate::profile::StageClock>();
        self.world = fresh.world;
        self.schedule = fresh.schedule;
        if let Some(clock) = profiled {
            self.profile_stages()?;
            self.world.insert_resource(clock);
        }
        Ok(())
    }

    /// The bytes each system of the step reads and writes (see [`crate::traffic`]).
    pub fn traffic(&self) -> Vec<crate::traffic::SystemTraffic> {
        crate::traffic::schedule_traffic(&self.schedule, &self.world)
    }

    /// Threads asked for with [`Simulation::set_threads`] (rayon's default without it).
    pub fn threads_asked(&self) -> usize {
        match &self.pool {
            Some(pool) => pool.current_num_threads(),
            None if self.threads_set => 1,
            None => rayon::current_num_threads(),
        }
    }

    /// The particle count below which steps run on one thread.
    pub fn serial_below(&self) -> usize {
        self.serial_below
    }

    /// Threads a step runs on (one for a scene below [`SERIAL_BELOW`]).
    pub fn threads(&self) -> usize {
        if self.runs_serially() {
            1
        } else {
            self.threads_asked()
        }
    }

    /// The number of space dimensions of the scene.
    pub fn dimension(&self) -> Dimension {
        self.dimension
    }

    /// The clock.
    pub fn clock(&self) -> SimClock {
        *self.world.resource::<SimClock>()
    }

    /// The end of the run.
    pub fn end(&self) -> End {
        self.end
    }

    /// The compensation of the clock's running sum of step sizes (for checkpoints).
    pub fn time_compensation(&self) -> f64 {
        self.time_compensation
    }

    /// Restores the clock's compensation from a checkpoint.
    pub fn set_time_compensation(&mut self, compensation: f64) {
        self.time_compensation = compensation;
    }

    /// Replaces the end of the run (e.g. `--steps N`).
    pub fn set_end(&mut self, end: End) {
        self.end = end;
    }

    /// Stops the run at step `cap` (counted from the start of the run) if the end comes later;
    /// the end itself is never passed, and a time end keeps its last step shortened to land on
    /// it. `None` runs to the end.
    pub fn set_step_cap(&mut self, cap: Option<u64>) {
        self.step_cap = cap;
    }

    /// The step cap, if any ([`Simulation::set_step_cap`]).
    pub fn step_cap(&self) -> Option<u64> {
        self.step_cap
    }

    /// Fraction of the run done, in [0, 1].
    pub fn progress(&self) -> f64 {
        let clock = self.clock();
        let to_end = match self.end {
            End::Steps(n) if n > 0 => clock.step as f64 / n as f64,
            End::Time(t) if t > 0.0 => (clock.time / t).min(1.0),
            _ => 1.0,
        };
        match self.step_cap {
            Some(cap) if cap > 0 => to_end.max((clock.step as f64 / cap as f64).min(1.0)),
            Some(_) => 1.0,
            None => to_end,
        }
    }

    /// True once the end of the run is reached.
    pub fn at_end(&self) -> bool {
        let clock = self.clock();
        match self.end {
            End::Steps(n) => clock.step >= n,
            End::Time(t) => clock.time >= t * (1.0 - 1e-12) || t - clock.time <= 1e-9 * clock.dt,
        }
    }

    /// True once the end of the run or the step cap is reached.
    pub fn finished(&self) -> bool {
        self.at_end() || self.step_cap.is_some_and(|cap| self.clock().step >= cap)
    }

    /// Number of particles.
    pub fn particle_count(&mut self) -> usize {
        self.world
            .query_filtered::<(), With<Particle>>()
            .iter(&self.world)
            .count()
    }

    /// The largest stable step for the current state (see [`stable_time_step`]).
    pub fn stable_time_step(&mut self) -> f64 {
        self.stability().dt
    }

    /// The stable step for the current state and the particle that sets it.
    pub fn stability(&mut self) -> StableStep {
        with_dim!(self.dimension, D => stable_time_step::<D>(&mut self.world))
    }

    /// The size of the next step under the scene's rule, clipped to land on the end time.
    pub fn next_time_step(&mut self) -> f64 {
        let dt = match self.time_step {
            TimeStep::Fixed(dt) => dt,
            TimeStep::Cfl(factor) => factor * self.stable_time_step(),
        };
        match self.end {
            End::Time(t) => dt.min(t - self.clock().time).max(f64::MIN_POSITIVE),
            End::Steps(_) => dt,
        }
    }

    /// Takes one step. On failure the state is left as the failing stage produced it.
    pub fn step(&mut self) -> Result<(), Blowup> {
        let dt = self.planned_time_step();
        self.step_with_time_step(dt)
    }

    /// [`Simulation::next_time_step`], searched in the step's pool, whose threads share the
    /// stable-step search.
    pub fn planned_time_step(&mut self) -> f64 {
        self.in_pool(Self::next_time_step)
    }

    /// Takes one step of size `dt`: [`Simulation::step`] with the step chosen by the caller (a
    /// distributed run's ranks take the least of their [`Simulation::planned_time_step`]s).
    pub fn step_with_time_step(&mut self, dt: f64) -> Result<(), Blowup> {
        self.check_time_step(dt)?;
        let removed_before = self.removed_so_far();
        self.world.resource_mut::<SimClock>().dt = dt;
        if let Some(mut clock) = self.world.get_resource_mut::<crate::profile::StageClock>() {
            clock.start();
        }
        self.in_pool(|sim| sim.schedule.run(&mut sim.world));
        if let Some(failure) = self.world.resource::<Health>().failure.clone() {
            return Err(failure);
        }
        if let Some(mut clock) = self.world.get_resource_mut::<crate::profile::StageClock>() {
            clock.finish();
        }
        // Compensated summation keeps t = Σ dt exact to round-off over millions of steps, so
        // output times read as the user expects (3.0, not 2.9999999999997806).
        let mut clock = self.world.resource_mut::<SimClock>();
        let increment = dt - self.time_compensation;
        let time = clock.time + increment;
        self.time_compensation = (time - clock.time) - increment;
        clock.time = time;
        clock.step += 1;
        // Only removals empty a scene: count the particles when this step removed some.
        let removed = self.removed_so_far();
        if removed != removed_before && self.particle_count() == 0 {
            let escaped = self
                .world
                .get_resource::<crate::health::EscapedParticles>()
                .cloned()
                .unwrap_or_default();
            return Err(escaped.nothing_left(clock_step(&self.world)));
        }
        Ok(())
    }

    /// Particles removed on leaving the grid so far.
    fn removed_so_far(&self) -> u64 {
        self.world
            .get_resource::<crate::health::EscapedParticles>()
            .map_or(0, |e| e.count)
    }

    /// Stops a step whose size cannot advance the clock: not a positive normal number (a
    /// signal speed so large the stable step underflows), or below the clock's resolution at
    /// this time. Without this, such a run would never reach its end time.
    fn check_time_step(&mut self, dt: f64) -> Result<(), Blowup> {
        let clock = self.clock();
        if dt.is_normal() && dt > 0.0 && clock.time + dt > clock.time {
            return Ok(());
        }
        let stability = self.stability();
        let culprit = stability
            .particle
            .map_or(String::new(), |(id, _)| format!(" set by particle {id}"));
        Err(Blowup::new(
            clock.step + 1,
            Stage::PreStep,
            format!(
                "the time step {dt:e} s cannot advance the clock from t = {:e} s (stable limit \
                 {:e} s{culprit}, signal speed c + |v| = {:e} m/s)",
                clock.time, stability.dt, stability.speed
            ),
        ))
    }

    /// Runs `f` on this simulation's world where its steps run (its pool, or the calling thread
    /// alone), e.g. output that reads the world with rayon's parallel iterators.
    pub fn with_world_in_pool<R: Send>(&mut self, f: impl FnOnce(&mut World) -> R + Send) -> R {
        self.in_pool(|sim| f(&mut sim.world))
    }

    /// Runs `f` on this simulation's thread pool (e.g. output that uses rayon).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(pool) => pool.install(f),
            None if self.threads_set => on_this_thread(f),
            None => f(),
        }
    }
}

/// The step being reported: completed steps (the clock has counted the one just taken).
fn clock_step(world: &World) -> u64 {
    world.resource::<SimClock>().step
}

/// The stable step and what limits it.
#[derive(Clone, Debug, PartialEq)]
pub struct StableStep {
    /// The largest stable step (s).
    pub dt: f64,
    /// Number of space dimensions `d` in `h / (√d (c + |v|))`.
    pub dimensions: usize,
    /// Grid spacing `h` (m): on a graded grid, the smallest cell width around the limiting
    /// particle.
    pub spacing: f64,
    /// The limiting particle's signal speed `c_p + |v_p|` (m/s): the fastest on a uniform grid.
    pub speed: f64,
    /// Id and material index of the limiting particle: the least `h_p / (c_p + |v_p|)`.
    pub particle: Option<(u32, u16)>,
    /// The fraction of the central-difference limit the installed systems allow (see
    /// [`TimeStepLimit`] for the reason).
    pub factor: f64,
}

/// The one rule for the stable step: [`TimeStepLimit::stable_step`] for the fastest particle
/// signal `max_p (c_p + |v_p|)`, with `c_p` the particle's current wave speed, or its material's
/// small-strain wave speed when no stress system has set one. On a graded grid each particle
/// counts with the smallest cell width its support touches ([`Grid::smallest_width_near`]),
/// and the limit is the least `h_p / (c_p + |v_p|)`. Validation checks a fixed step against it
/// and CFL steps follow it.
pub fn stable_time_step<D: Dim>(world: &mut World) -> StableStep {
    let grid = world.resource::<Grid<D>>().clone();
    let speeds: Vec<f64> = world
        .resource::<Materials>()
        .0
        .iter()
        .map(|m| m.wave_speed())
        .collect();
    let mut query = world.query_filtered::<(
        &ParticleId,
        &MaterialId,
        &WaveSpeed,
        &Velocity<D>,
        &Position<D>,
    ), With<Particle>>();
    let limiting = crate::storage::single_table(query.contiguous_iter(world), "particles")
        .and_then(|(ids, materials, waves, velocities, positions)| {
            let signal = |p: usize| {
                let c = waves[p].0;
                let c = if c > 0.0 {
                    c
                } else {
                    speeds.get(materials[p].0 as usize).copied().unwrap_or(0.0)
                };
                c + velocities[p].0.length()
            };
            let limiting = if grid.is_graded() {
                first_least(ids.len(), f64::INFINITY, |p| {
                    let speed = signal(p);
                    let h = grid.smallest_width_near(positions[p].0);
                    (speed > 0.0).then(|| h / speed)
                })
            } else {
                // One spacing: the fastest particle with a signal at all (a comparison of
                // speeds, not of quotients).
                first_least(ids.len(), 0.0, |p| Some(-signal(p)))
            };
            limiting.map(|p| {
                let speed = signal(p);
                let h = if grid.is_graded() {
                    grid.smallest_width_near(positions[p].0)
                } else {
                    grid.spacing
                };
                (h, speed, (ids[p].0, materials[p].0))
            })
        });
    let (h, speed, particle) = match limiting {
        Some((h, speed, particle)) => (h, speed, Some(particle)),
        None => (grid.spacing, 0.0, None),
    };
    let limit = world.get_resource_or_init::<TimeStepLimit>();
    StableStep {
        dt: limit.stable_step(D::N, h, speed),
        dimensions: D::N,
        spacing: h,
        speed,
        particle,
        factor: limit.factor,
    }
}

/// The first of `0..count` with the least `key` below `bound` (`None` keys and NaN never win),
/// in parallel over fixed blocks whose winners are compared in block order: the particle a
/// serial scan with a strict comparison finds, whatever the thread count.
fn first_least(
    count: usize,
    bound: f64,
    key: impl Fn(usize) -> Option<f64> + Sync,
) -> Option<usize> {
    use rayon::prelude::*;
    const BLOCK: usize = 4096;
    let better = |best: (Option<usize>, f64), p: usize, k: f64| {
        if k < best.1 { (Some(p), k) } else { best }
    };
    let winners: Vec<(Option<usize>, f64)> = (0..count.div_ceil(BLOCK))
        .into_par_iter()
        .map(|block| {
            let rows = block * BLOCK..((block + 1) * BLOCK).min(count);
            rows.fold((None, bound), |best, p| match key(p) {
                Some(k) => better(best, p, k),
                None => best,
            })
        })
        .collect();
    let best = winners
        .into_iter()
        .fold((None, bound), |best, (p, k)| match p {
            Some(p) => better(best, p, k),
            None => best,
        });
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    /// Work handed to `on_this_thread` runs on the caller, with rayon's parallel sections
    /// sequential in it (one thread), however often it is called.
    #[test]
    fn the_least_key_found_in_parallel_is_the_first_a_serial_scan_finds() {
        // Keys with many ties and some NaN and missing ones, over several blocks.
        let count = 20_000;
        let key = |p: usize| match p % 97 {
            0 => None,
            1 => Some(f64::NAN),
            _ => Some(((p * 7919) % 1013) as f64),
        };
        let serial = |bound: f64| {
            let mut best = (None, bound);
            for p in 0..count {
                if let Some(k) = key(p).filter(|&k| k < best.1) {
                    best = (Some(p), k);
                }
            }
            best.0
        };
        for bound in [f64::INFINITY, 500.0, 0.0] {
            for threads in [1, 2, 5] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let found = pool.install(|| first_least(count, bound, key));
                assert_eq!(found, serial(bound), "bound {bound}, {threads} threads");
            }
        }
        assert_eq!(first_least(0, f64::INFINITY, key), None);
    }

    #[test]
    fn serial_work_runs_on_the_calling_thread() {
        let caller = std::thread::current().id();
        for _ in 0..3 {
            let (thread, threads, sum) = on_this_thread(|| {
                let sum: u64 = (0..10_000u64).into_par_iter().sum();
                (
                    std::thread::current().id(),
                    rayon::current_num_threads(),
                    sum,
                )
            });
            assert_eq!(thread, caller);
            assert_eq!(threads, 1);
            assert_eq!(sum, 49_995_000);
        }
    }
}
