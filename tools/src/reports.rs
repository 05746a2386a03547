//! What `check`, `systems` and a finished run print.

use fractum_engine::dim::{Dim, Dimension};
use fractum_engine::energy::EnergyCreation;
use fractum_engine::quasi_static::{KineticExcess, QuasiStatic};
use fractum_engine::registry::Registry;
use fractum_engine::resources::{Grid, Materials, Thickness};
use fractum_engine::simulation::{End, TimeStep};
use fractum_engine::with_dim;
use fractum_io::run::RunSummary;
use fractum_scene::Built;
use std::fmt::Write as _;
use std::path::Path;

/// The `fractum systems` listing.
pub fn systems_report(registry: &Registry) -> String {
    let mut out = String::new();
    let mut stage = None;
    for r in registry.iter() {
        if r.stage() != stage {
            stage = r.stage();
            let name = stage.map(|s| s.name()).unwrap_or("?");
            let _ = writeln!(out, "\n[{name}]");
        }
        let _ = writeln!(out, "  {:<28} {}", r.name, r.summary);
        for p in r.params {
            // A default that starts with `none` is an optional parameter with no value.
            let default = match p.default {
                None => "required".to_string(),
                Some(d) => match d.strip_prefix("none") {
                    Some(why) => format!("optional{why}"),
                    None => format!("default {d}"),
                },
            };
            let _ = writeln!(out, "      {}: {} ({default}) - {}", p.name, p.ty, p.doc);
        }
        if !r.requires.is_empty() {
            let _ = writeln!(out, "      needs: {}", r.requires.join(", "));
        }
    }
    out.trim_start().to_string()
}

fn describe_step(step: TimeStep, limit: f64) -> String {
    match step {
        TimeStep::Fixed(dt) => format!("dt = {dt:e} s fixed (stable limit {limit:.4e} s)"),
        TimeStep::Cfl(f) => format!("CFL {f} of the stable limit (now dt = {:.4e} s)", f * limit),
    }
}

/// `(x, y)` or `(x, y, z)` with plain number formatting.
fn point<D: Dim>(v: D::Vector) -> String {
    use fractum_engine::dim::VectorOps;
    let parts: Vec<String> = v.to_3d()[..D::N].iter().map(|c| short(*c)).collect();
    format!("({})", parts.join(", "))
}

/// A coordinate computed from node coordinates, to 12 significant digits (`0.007`, not
/// `0.007000000000000006`).
fn short(x: f64) -> String {
    format!("{}", format!("{x:.11e}").parse::<f64>().unwrap_or(x))
}

/// The grid line of `fractum check`.
fn grid_line<D: Dim>(built: &mut Built) -> String {
    let grid = built.simulation.world.resource::<Grid<D>>().clone();
    let cells: Vec<String> = grid.cells.as_ref().iter().map(|c| c.to_string()).collect();
    let spacing = match &grid.graded {
        None => format!("h = {} m", grid.spacing),
        Some(axes) => {
            let largest = axes
                .coordinates
                .iter()
                .flat_map(|c| c.windows(2).map(|w| w[1] - w[0]))
                .fold(0.0, f64::max);
            format!(
                "graded, h = {} to {} m",
                short(grid.spacing),
                short(largest)
            )
        }
    };
    format!(
        "{} cells, {spacing}, {} nodes, box {} to {}",
        cells.join(" x "),
        grid.node_count(),
        point::<D>(grid.min),
        point::<D>(grid.max())
    )
}

/// The memory estimate and the materials, one line each, for `check`.
fn memory_and_materials(world: &fractum_engine::prelude::World, out: &mut String) {
    if let Some(memory) = world.get_resource::<fractum_engine::budget::MemoryUse>() {
        use fractum_engine::budget::describe_bytes;
        let _ = writeln!(
            out,
            "memory     about {} estimated, {}",
            describe_bytes(memory.needed),
            memory.available.describe()
        );
    }
    // A quasi-static run's world holds the scaled densities: the line shows the scene's too.
    let scaling = world
        .get_resource::<QuasiStatic>()
        .map_or(1.0, |q| q.mass_scaling);
    for m in &world.resource::<Materials>().0 {
        let density = if scaling > 1.0 {
            format!(
                "{} kg/m3 ({} scaled {scaling} times)",
                m.density,
                m.density / scaling
            )
        } else {
            format!("{} kg/m3", m.density)
        };
        let _ = writeln!(
            out,
            "material   {}: density {density}, E {} Pa, nu {}, wave speed {:.4e} m/s",
            m.name,
            m.youngs_modulus,
            m.poisson_ratio,
            m.wave_speed()
        );
    }
}

/// For each body, its particle count of each material it holds (`1234 steel`), in material
/// order: an image's phases or a particle file's materials make one body of several.
fn body_material_counts(world: &mut fractum_engine::prelude::World) -> Vec<Vec<String>> {
    use fractum_engine::components::{BodyId, MaterialId, Particle};
    let names: Vec<String> = world
        .get_resource::<Materials>()
        .map(|m| m.0.iter().map(|m| m.name.clone()).collect())
        .unwrap_or_default();
    let mut counts: Vec<Vec<usize>> = Vec::new();
    let mut query =
        world.query_filtered::<(&BodyId, &MaterialId), fractum_engine::prelude::With<Particle>>();
    for (body, material) in query.iter(world) {
        let (b, m) = (usize::from(body.0), usize::from(material.0));
        if counts.len() <= b {
            counts.resize(b + 1, Vec::new());
        }
        if counts[b].len() <= m {
            counts[b].resize(m + 1, 0);
        }
        counts[b][m] += 1;
    }
    counts
        .into_iter()
        .map(|per| {
            per.iter()
                .enumerate()
                .filter(|(_, n)| **n > 0)
                .map(|(m, n)| format!("{n} {}", names.get(m).map_or("?", String::as_str)))
                .collect()
        })
        .collect()
}

/// How long a run is: its steps, from the scene's end and the step size at the start, and
/// the wall time of one step, timed on the built simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunLength {
    /// Steps to the scene's end (at the starting step size, for a CFL step).
    pub steps: f64,
    /// Seconds one step took (the last of a few timed ones), if one could be taken.
    pub step_seconds: Option<f64>,
    /// Threads the step ran on.
    pub threads: usize,
}

impl RunLength {
    /// The estimated wall time of the whole run (s).
    pub fn wall_seconds(&self) -> Option<f64> {
        self.step_seconds.map(|s| s * self.steps)
    }
}

/// Times up to three steps of `sim` and counts the steps to its end. The first step builds what
/// later ones reuse, so the last timed is the one kept; a first step over a quarter of a second
/// is kept alone (a large scene's estimate errs long by its setup, and `check` stays quick).
/// `sim` is stepped: it is `check`'s, which throws it away.
pub fn run_length(sim: &mut fractum_engine::Simulation) -> RunLength {
    let dt = sim.planned_time_step();
    let steps = match sim.end() {
        End::Steps(n) => n as f64,
        End::Time(t) => ((t - sim.clock().time) / dt).ceil().max(1.0),
    };
    let started = std::time::Instant::now();
    let mut step_seconds = None;
    for _ in 0..3 {
        if sim.finished() || started.elapsed().as_secs_f64() > 0.25 {
            break;
        }
        let step = std::time::Instant::now();
        if sim.step().is_err() {
            break;
        }
        step_seconds = Some(step.elapsed().as_secs_f64());
    }
    RunLength {
        steps,
        step_seconds,
        threads: sim.threads(),
    }
}

/// The `run` line of `fractum check`.
fn run_length_line(length: &RunLength) -> String {
    let steps =
        format!("{:.3}", length.steps)
            .parse::<f64>()
            .map_or(length.steps.to_string(), |n| {
                if n >= 1.0e5 {
                    format!("{n:.2e}")
                } else {
                    format!("{n}")
                }
            });
    match (length.step_seconds, length.wall_seconds()) {
        (Some(step), Some(wall)) => format!(
            "run        {steps} steps; a step took {} on {} thread(s): about {} to the end",
            duration(step),
            length.threads,
            duration(wall)
        ),
        _ => format!("run        {steps} steps"),
    }
}

/// A duration in words a reader takes in at a glance: `0.8 ms`, `12 s`, `3.2 h`.
fn duration(seconds: f64) -> String {
    match seconds {
        s if s < 1.0e-3 => format!("{:.0} µs", s * 1.0e6),
        s if s < 1.0 => format!("{:.1} ms", s * 1.0e3),
        s if s < 120.0 => format!("{s:.0} s"),
        s if s < 7200.0 => format!("{:.0} min", s / 60.0),
        s if s < 3.0 * 86400.0 => format!("{:.1} h", s / 3600.0),
        s => format!("{:.1} days", s / 86400.0),
    }
}

/// The `fractum check` summary of a valid scene, with its implausible magnitudes as warnings,
/// and the run's length ([`run_length`]: the built simulation is stepped to time it).
pub fn check_report(
    built: &mut Built,
    implausible: &[fractum_scene::Implausible],
) -> (String, RunLength) {
    let summary = built.summary.clone();
    let sim = &mut built.simulation;
    let limit = sim.stable_time_step();
    let dimension = sim.dimension();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "scene      {}{}",
        summary.source,
        if summary.title.is_empty() {
            String::new()
        } else {
            format!(" - {}", summary.title)
        }
    );
    let thickness = match dimension {
        Dimension::Two => format!(", thickness {} m", sim.world.resource::<Thickness>().0),
        Dimension::Three => String::new(),
    };
    let _ = writeln!(out, "dimension  {}{thickness}", dimension.describe());
    let grid = with_dim!(dimension, D => grid_line::<D>(built));
    let sim = &mut built.simulation;
    let _ = writeln!(out, "grid       {grid}");
    let by_material = body_material_counts(&mut sim.world);
    let counts: Vec<String> = summary
        .bodies
        .iter()
        .enumerate()
        .map(|(b, (name, n))| match by_material.get(b) {
            Some(split) if split.len() > 1 => format!("{name}: {n} = {}", split.join(" + ")),
            _ => format!("{name}: {n}"),
        })
        .collect();
    let _ = writeln!(
        out,
        "particles  {} ({})",
        sim.particle_count(),
        counts.join(", ")
    );
    memory_and_materials(&sim.world, &mut out);
    let end = match sim.end() {
        End::Time(t) => format!("end at t = {t} s"),
        End::Steps(n) => format!("end after {n} steps"),
    };
    if let Some(step) = summary.time_step {
        let _ = writeln!(out, "time       {}; {end}", describe_step(step, limit));
    }
    if let Some(q) = sim.world.get_resource::<QuasiStatic>() {
        let _ = writeln!(out, "{}", quasi_static_line(q));
        if let Some(warning) = real_time_warning(&sim.world) {
            let _ = writeln!(out, "warning    {warning}");
        }
    }
    for (name, condition) in &summary.boundaries {
        let _ = writeln!(out, "boundary   {name}: {condition}");
    }
    let _ = writeln!(out, "pipeline");
    for (stage, names) in &built.pipeline.by_stage {
        let _ = writeln!(out, "  {:<10} {}", stage.name(), names.join(", "));
    }
    let frames = match built.output.vtu_every {
        0 => "no VTU frames".to_string(),
        n => format!("VTU frame every {n} steps"),
    };
    let _ = writeln!(
        out,
        "output     {frames}; series.csv columns: {}",
        built.output.columns().join(",")
    );
    let length = run_length(&mut built.simulation);
    out.push_str(&closing_lines(&length, implausible));
    (out, length)
}

/// The run's length, the warnings and `ok`: the last lines of `fractum check`.
fn closing_lines(length: &RunLength, implausible: &[fractum_scene::Implausible]) -> String {
    let mut out = format!("{}\n", run_length_line(length));
    for slip in implausible {
        let _ = writeln!(out, "warning    {slip}");
    }
    out.push_str("ok\n");
    out
}

/// The warning for a mass-scaled pipeline with laws that read the scene's real time, if any.
pub fn real_time_warning(world: &fractum_engine::prelude::World) -> Option<String> {
    use fractum_engine::quasi_static::RealTimeLaws;
    let scaling = world.get_resource::<QuasiStatic>()?.mass_scaling;
    world.get_resource::<RealTimeLaws>()?.warning(scaling)
}

/// The `fractum check` line of a quasi-static scene.
fn quasi_static_line(q: &QuasiStatic) -> String {
    let scaling = if q.mass_scaling > 1.0 {
        format!(
            "mass scaled {} times (densities, so the wave speeds fall and the stable step grows \
             {:.3} times; weights as the scene gives them)",
            q.mass_scaling,
            q.mass_scaling.sqrt()
        )
    } else {
        "no mass scaling".to_string()
    };
    format!(
        "quasi-static {scaling}; warns where kinetic_fraction passes {} near the peak of the \
         loading",
        q.kinetic_limit
    )
}

/// The warning printed when a quasi-static run's loading ends (the stored energy falls below
/// 90% of its peak) with a kinetic fraction past the limit over the upper half of the loading.
pub fn kinetic_warning(first: &KineticExcess, limit: f64) -> String {
    format!(
        "the loading has ended (the stored energy fell below 90% of its peak); near its peak, at \
         step {} (t = {:.4e} s), the kinetic energy was {:.1}% of the stored energy, past the \
         quasi-static limit of {:.1}% (kinetic_fraction in series.csv): inertia shaped this \
         run's answer. Load more slowly, ramp the load in over a longer time, or scale the mass \
         less (time.quasi_static.mass_scaling).",
        first.step,
        first.time,
        100.0 * first.fraction,
        100.0 * limit
    )
}

/// The warning printed when a run first creates more energy than the watch allows.
/// `cells_moved`: under `basis/linear`, the farthest any particle has moved, in cells; past one
/// cell the warning names cell crossing as a likely cause.
pub fn energy_warning(first: &EnergyCreation, cells_moved: Option<f64>) -> String {
    let crossing = match cells_moved {
        Some(cells) if cells > 1.0 => format!(
            " Likely cause here: cell crossing. Under basis/linear particles have moved up to \
             {cells:.1} cells, and a particle's weight gradients, so its internal force, jump at \
             every cell face it crosses; basis/bspline (or basis/gimp) has no such jump, and \
             stress/shock_viscosity damps a struck body's ringing (SCENES.md, \"Impact and \
             waves\")."
        ),
        _ => String::new(),
    };
    format!(
        "at step {} (t = {:.4e} s) the scheme has created {:.4e} J, {:.1}% of the energy in play \
         (the total energy above external_work in series.csv). An explicit run that creates energy is usually heading \
         for a blow-up: a smaller CFL factor, or a smoother basis (basis/bspline, basis/gimp) than \
         the linear tents where a stiff contact or a steep stress moves particles across cells, \
         usually cures it.{crossing}",
        first.step,
        first.time,
        first.created,
        100.0 * first.fraction
    )
}

/// The end-of-run summary.
pub fn summary_report(s: &RunSummary, out_dir: &Path) -> String {
    let removed = if s.removed > 0 {
        format!("{} particles left the grid and were removed\n", s.removed)
    } else {
        String::new()
    };
    let threads = if s.threads < s.threads_asked {
        format!(
            "{} ({} asked: a scene this small steps faster on one)",
            s.threads, s.threads_asked
        )
    } else {
        s.threads.to_string()
    };
    let energy = s.energy_created.map_or(String::new(), |worst| {
        format!(
            "energy: the scheme created up to {:.4e} J ({:.1}% of the energy in play) at step {}, \
             t = {:.4e} s (the total energy above external_work in series.csv)\n",
            worst.created,
            100.0 * worst.fraction,
            worst.step,
            worst.time
        )
    });
    let balance = s.energy_balance.map_or(String::new(), |b| balance_line(&b));
    let kinetic = s.kinetic_excess.map_or(String::new(), |worst| {
        format!(
            "quasi-static: the kinetic energy reached {:.1}% of the stored energy near the peak \
             of the loading, at step {}, t = {:.4e} s (kinetic_fraction in series.csv)\n",
            100.0 * worst.fraction,
            worst.step,
            worst.time
        )
    });
    let never_split = if s.never_split {
        "partition: no node was split in this run (a node splits only where a particle has \
         failed and the damage on both sides passes the separability threshold, §2.3), so each \
         contact group moved as one velocity field\n"
    } else {
        ""
    };
    let ranks = s.ranks.map_or(String::new(), |r| {
        format!(
            "ranks {}: slabs re-cut {} times ({} worlds rebuilt for the nodes they moved), the \
             most loaded rank {:.1}% over the mean at the end; ghosts make {:.2}x the particles, \
             the nodes the ranks hold {:.2}x the grid's; {} sent per step per rank\n{}\n",
            r.ranks,
            r.rebalances,
            r.rebuilds,
            100.0 * r.imbalance,
            r.held_over_owned,
            r.held_nodes_over_grid,
            fractum_engine::budget::describe_bytes(r.sent_per_step),
            fractum_io::run::rank_clock::describe_phases(
                &r.phase_seconds,
                Some(&r.phase_range),
                s.wall.as_secs_f64()
            )
        )
    });
    format!(
        "steps {}, simulated time {:.6e} s, particles {}, threads {threads}\nwall time {:.3} s, {:.4e} particle-steps/s\n{} VTU frames, output in {}\n{ranks}{removed}{balance}{energy}{kinetic}{never_split}",
        s.steps,
        s.time,
        s.particles,
        s.wall.as_secs_f64(),
        s.particle_steps_per_second(),
        s.frames,
        out_dir.display()
    )
}

/// The summary's line on the last series row's energy account, `W_ext = ΔE + D + R`, with what
/// a residual past 2% of the energy in play means.
fn balance_line(b: &fractum_engine::energy::EnergyBalance) -> String {
    let fraction = b.residual_fraction();
    let meaning = if fraction < -0.02 {
        ": negative, so the account holds more than the loads put in (energy the scheme \
         created, or a law's dissipation account reading high)"
    } else if fraction > 0.02 {
        ": what the scheme itself dissipated (the transfers, contact, cell crossing)"
    } else {
        ""
    };
    format!(
        "energy     at t = {:.4e} s: external work {:.4e} J = change of kinetic and stored \
         {:.4e} J + dissipated {:.4e} J + residual {:.4e} J ({:+.2}% of the energy in \
         play{meaning})\n",
        b.time,
        b.external_work,
        b.energy_change,
        b.dissipated,
        b.residual,
        100.0 * fraction
    )
}

/// The `fractum check --estimate` report: the scene's counts and its memory estimate part by
/// part, against what the process may use.
pub fn estimate_report(estimate: &fractum_scene::Estimate) -> String {
    use fractum_engine::budget::describe_bytes;
    let mut out = String::new();
    let _ = writeln!(out, "scene      {}", estimate.source);
    let _ = writeln!(out, "grid       {} nodes", estimate.nodes);
    let bodies: Vec<String> = estimate
        .bodies
        .iter()
        .map(|(name, n)| format!("{name}: {n}"))
        .collect();
    let total: usize = estimate.bodies.iter().map(|(_, n)| n).sum();
    let _ = writeln!(out, "particles  {total} ({})", bodies.join(", "));
    let _ = writeln!(out, "memory, from counts (nothing spawned):");
    for (what, bytes) in &estimate.estimate.parts {
        let _ = writeln!(out, "  {:>10}  {what}", describe_bytes(*bytes));
    }
    let parts: f64 = estimate.estimate.parts.iter().map(|(_, b)| b).sum();
    let _ = writeln!(
        out,
        "  {:>10}  working buffers of a step ({} x the above)",
        describe_bytes(estimate.estimate.working * parts),
        estimate.estimate.working
    );
    let _ = writeln!(
        out,
        "  {:>10}  in all; {}",
        describe_bytes(estimate.estimate.total()),
        estimate.available.describe()
    );
    if let Some(ranks) = &estimate.slabs {
        slabs_report(ranks, &mut out);
    }
    match &estimate.refusal {
        None => out.push_str("fits\n"),
        Some(refusal) => {
            let _ = writeln!(out, "does not fit: {refusal}");
        }
    }
    out
}

/// The slabs of `check --estimate --ranks N`: one line per rank and the imbalance.
fn slabs_report(ranks: &fractum_scene::RankSlabs, out: &mut String) {
    let slabs = &ranks.slabs;
    let axis = ["x", "y", "z"][slabs.axis.min(2)];
    let _ = writeln!(
        out,
        "ranks      {} slabs along {axis}, cut at cell faces; imbalance {:.1}% (the most \
         loaded rank over the mean, a node counted as {} of a particle)",
        slabs.layers.len(),
        100.0 * slabs.imbalance(),
        fractum_engine::decomposition::NODE_COST
    );
    let _ = writeln!(
        out,
        "  each rank also holds the particles within {} cell layers of its slab (ghosts, as \
         deep as a step reaches), and the nodes they reach",
        ranks.halo
    );
    // A face at the origin comes out of the node coordinates as a round-off (1.4e-17 m): a
    // coordinate within 1e-12 of the slabs' extent of zero is zero.
    let extent =
        (ranks.bounds.iter()).fold(0.0_f64, |e, (low, high)| e.max(low.abs()).max(high.abs()));
    let at = |x: f64| short(if x.abs() < 1e-12 * extent { 0.0 } else { x });
    for (rank, (((layers, particles), (low, high)), (held, nodes, bytes))) in slabs
        .layers
        .iter()
        .zip(&slabs.particles)
        .zip(&ranks.bounds)
        .zip(&ranks.held)
        .enumerate()
    {
        let _ = writeln!(
            out,
            "  rank {rank:<4} {axis} {} to {} m (cell layers {}..{}): {particles} particles, \
             {held} with ghosts, {} nodes, {}",
            at(*low),
            at(*high),
            layers.start,
            layers.end,
            fractum_engine::budget::describe_count(*nodes as f64),
            fractum_engine::budget::describe_bytes(*bytes)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The watch's warning names cell crossing only when the tents' particles have moved past
    /// a cell.
    #[test]
    fn the_energy_warning_names_cell_crossing_past_one_cell_under_the_tents() {
        let first = EnergyCreation {
            step: 120,
            time: 1.5e-3,
            created: 2.0,
            fraction: 0.08,
        };
        let crossing = "Likely cause here: cell crossing";
        assert!(energy_warning(&first, Some(2.5)).contains(crossing));
        assert!(energy_warning(&first, Some(2.5)).contains("up to 2.5 cells"));
        assert!(!energy_warning(&first, Some(0.4)).contains(crossing));
        assert!(!energy_warning(&first, None).contains(crossing));
        assert!(energy_warning(&first, None).contains("8.0% of the energy in play"));
    }
}
