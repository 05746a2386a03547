//! Where a distributed step's time goes on a rank: the scene's pipeline, the collectives (where
//! a rank waits for the slowest), the per-layer count, encoding the particles it sends, the
//! exchange, decoding what arrived, rebuilding its rows from what it kept and received, and
//! building its world afresh for re-cut slabs. [`super::distributed::step`] adds each step's phases to the rank's
//! [`RankClock`]; the run's summary gives the mean over ranks ([`super::RankReport::phase_seconds`])
//! and, for the pipeline and the waiting, the fastest and the slowest rank's
//! ([`super::RankReport::phase_range`]).

use bevy_ecs::prelude::*;
use std::time::{Duration, Instant};

/// A phase of a distributed step ([`super::distributed::step`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// The scene's pipeline on the particles the rank holds, owned and ghosts.
    Pipeline,
    /// The agreements after each part of the step and the least stable step over ranks: a
    /// rank that finishes its pipeline first waits here for the others.
    Collectives,
    /// Which particles the rank takes over, and their count per cell layer over every rank.
    Counting,
    /// Encoding the particles each peer holds.
    Encoding,
    /// Swapping the encoded particles with the peers.
    Exchange,
    /// Decoding the blocks that arrived into each particle's encoded components.
    Decoding,
    /// Writing the rows that arrived (and moving the kept ones where rows change), marking
    /// what the rank owns.
    Rebuilding,
    /// Building the rank's world afresh for re-cut slabs that moved its nodes.
    NewWorld,
}

impl Phase {
    /// Every phase, in the order the report lists them.
    pub const ALL: [Phase; 8] = [
        Phase::Pipeline,
        Phase::Collectives,
        Phase::Counting,
        Phase::Encoding,
        Phase::Exchange,
        Phase::Decoding,
        Phase::Rebuilding,
        Phase::NewWorld,
    ];

    /// The phase in the run's summary.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Pipeline => "pipeline",
            Phase::Collectives => "collectives and waiting",
            Phase::Counting => "counting",
            Phase::Encoding => "encoding",
            Phase::Exchange => "exchange",
            Phase::Decoding => "decoding",
            Phase::Rebuilding => "rebuilding rows",
            Phase::NewWorld => "new worlds",
        }
    }

    fn index(self) -> usize {
        Phase::ALL.iter().position(|&p| p == self).unwrap_or(0)
    }
}

/// The wall time a rank has spent in each [`Phase`] of its distributed steps since the run
/// began (a resumed run's from the resume). Not carried by checkpoints.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct RankClock {
    spent: [Duration; Phase::ALL.len()],
}

impl RankClock {
    /// Adds `elapsed` to `phase`.
    pub fn add(&mut self, phase: Phase, elapsed: Duration) {
        self.spent[phase.index()] += elapsed;
    }

    /// The time spent in `phase`.
    pub fn spent(&self, phase: Phase) -> Duration {
        self.spent[phase.index()]
    }

    /// Runs `f`, adding its wall time to `phase`.
    pub fn time<R>(&mut self, phase: Phase, f: impl FnOnce() -> R) -> R {
        let started = Instant::now();
        let result = f();
        self.add(phase, started.elapsed());
        result
    }
}

/// Each phase's least and greatest seconds over the ranks, from `every_rank`: the ranks'
/// seconds rank after rank, each in the order of [`Phase::ALL`].
pub fn ranges_over_ranks(every_rank: &[f64]) -> [(f64, f64); Phase::ALL.len()] {
    std::array::from_fn(|k| {
        every_rank
            .iter()
            .skip(k)
            .step_by(Phase::ALL.len())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(least, most), &s| {
                (least.min(s), most.max(s))
            })
    })
}

/// Where a rank's time went, for the run's summary: each phase's seconds (the mean over ranks,
/// `seconds` in the order of [`Phase::ALL`]) and share of the run's `wall` time, phases that
/// took no time left out, and what the steps leave (outputs, the run's bookkeeping). With
/// `ranges` (each phase's least and greatest over the ranks, [`ranges_over_ranks`]), the
/// pipeline and the waiting give their spread too: a rank whose pipeline takes longer makes
/// the others wait, which the particle and node counts do not show.
pub fn describe_phases(seconds: &[f64], ranges: Option<&[(f64, f64)]>, wall: f64) -> String {
    let share = |s: f64| 100.0 * s / wall.max(1e-12);
    let spread = |k: usize| match (Phase::ALL[k], ranges.and_then(|r| r.get(k))) {
        (Phase::Pipeline | Phase::Collectives, Some((least, most))) => {
            format!("; ranks {least:.2}-{most:.2} s")
        }
        _ => String::new(),
    };
    let mut parts: Vec<String> = Phase::ALL
        .iter()
        .zip(seconds)
        .enumerate()
        .filter(|(_, (_, s))| share(**s) >= 0.05)
        .map(|(k, (phase, s))| {
            format!("{} {s:.2} s ({:.1}%{})", phase.name(), share(*s), spread(k))
        })
        .collect();
    let rest = wall - seconds.iter().sum::<f64>();
    if rest > 0.0 {
        parts.push(format!(
            "outputs and the rest {rest:.2} s ({:.1}%)",
            share(rest)
        ));
    }
    format!("a rank's time, the mean over ranks: {}", parts.join(", "))
}

/// Adds `elapsed` to `phase` of the world's [`RankClock`], inserting one when it has none.
pub(crate) fn record(world: &mut World, phase: Phase, elapsed: Duration) {
    world
        .get_resource_or_insert_with(RankClock::default)
        .add(phase, elapsed);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phases_add_up_apart() {
        let mut clock = RankClock::default();
        clock.add(Phase::Exchange, Duration::from_millis(3));
        clock.add(Phase::Exchange, Duration::from_millis(4));
        let value = clock.time(Phase::Encoding, || 5);
        assert_eq!(value, 5);
        assert_eq!(clock.spent(Phase::Exchange), Duration::from_millis(7));
        assert_eq!(clock.spent(Phase::Pipeline), Duration::ZERO);
        let names: Vec<&str> = Phase::ALL.iter().map(|p| p.name()).collect();
        assert_eq!(names.len(), 8);
        let mut world = World::new();
        record(&mut world, Phase::NewWorld, Duration::from_millis(2));
        record(&mut world, Phase::NewWorld, Duration::from_millis(2));
        let spent = world.resource::<RankClock>().spent(Phase::NewWorld);
        assert_eq!(spent, Duration::from_millis(4));
    }

    #[test]
    fn the_description_gives_shares_of_the_wall_time_and_the_rest() {
        let text = describe_phases(&[6.0, 1.0, 0.0, 0.5, 0.5, 0.0, 1.0, 0.0], None, 10.0);
        assert_eq!(
            text,
            "a rank's time, the mean over ranks: pipeline 6.00 s (60.0%), collectives and \
             waiting 1.00 s (10.0%), encoding 0.50 s (5.0%), exchange 0.50 s (5.0%), rebuilding \
             rows 1.00 s (10.0%), outputs and the rest 1.00 s (10.0%)"
        );
    }

    #[test]
    fn the_pipeline_and_the_waiting_give_their_spread_over_the_ranks() {
        // Two ranks: rank 1's pipeline takes a second longer, so rank 0 waits for it.
        let every_rank = [
            5.5, 1.5, 0.0, 0.5, 0.5, 0.0, 1.0, 0.0, //
            6.5, 0.5, 0.0, 0.5, 0.5, 0.0, 1.0, 0.0,
        ];
        let ranges = ranges_over_ranks(&every_rank);
        assert_eq!(ranges[0], (5.5, 6.5));
        assert_eq!(ranges[1], (0.5, 1.5));
        assert_eq!(ranges[6], (1.0, 1.0));
        let text = describe_phases(
            &[6.0, 1.0, 0.0, 0.5, 0.5, 0.0, 1.0, 0.0],
            Some(&ranges),
            10.0,
        );
        assert_eq!(
            text,
            "a rank's time, the mean over ranks: pipeline 6.00 s (60.0%; ranks 5.50-6.50 s), \
             collectives and waiting 1.00 s (10.0%; ranks 0.50-1.50 s), encoding 0.50 s (5.0%), \
             exchange 0.50 s (5.0%), rebuilding rows 1.00 s (10.0%), outputs and the rest 1.00 \
             s (10.0%)"
        );
    }
}
