//! Wall time per stage of a step, for `fractum bench --profile`: the measure of where a step's
//! time goes and, run at one and at several threads, of which stages scale.
//!
//! [`install_stage_clock`] puts a marker after each stage's check (before the next stage): it
//! charges the time since the previous marker to its stage. The step starts the clock
//! ([`StageClock::start`]) and the engine's work after the last stage (the work of loads) is
//! charged to `post_step`. A stage's time includes its check and the windows before the check
//! (the field assignment is charged to the basis stage, the grid-update correction to the
//! predictor). The markers cost two clock reads per stage; they are only installed on request.

use crate::stage::{Stage, StageCheck};
use bevy_ecs::prelude::{ResMut, Resource, Schedule};
use bevy_ecs::schedule::IntoScheduleConfigs;
use std::time::Instant;

/// Seconds spent in each stage since the clock was installed (or reset).
#[derive(Resource, Clone, Debug)]
pub struct StageClock {
    last: Option<Instant>,
    /// Seconds per stage, in [`Stage::ORDER`].
    pub seconds: [f64; Stage::ORDER.len()],
    /// Steps timed.
    pub steps: u64,
}

impl Default for StageClock {
    fn default() -> Self {
        Self {
            last: None,
            seconds: [0.0; Stage::ORDER.len()],
            steps: 0,
        }
    }
}

impl StageClock {
    /// Marks the start of a step.
    pub fn start(&mut self) {
        self.last = Some(Instant::now());
    }

    /// Charges the time since the last mark to `stage` and marks now.
    pub fn mark(&mut self, stage: Stage) {
        let now = Instant::now();
        if let Some(last) = self.last {
            self.seconds[stage.position()] += (now - last).as_secs_f64();
        }
        self.last = Some(now);
    }

    /// Ends a step: the time since the last mark goes to the post-step stage.
    pub fn finish(&mut self) {
        self.mark(Stage::PostStep);
        self.last = None;
        self.steps += 1;
    }

    /// Forgets the times so far (after warm-up steps).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Each stage that took time, with its seconds per step.
    pub fn per_step(&self) -> Vec<(Stage, f64)> {
        let steps = self.steps.max(1) as f64;
        Stage::ORDER
            .iter()
            .zip(self.seconds)
            .filter(|(_, s)| *s > 0.0)
            .map(|(&stage, s)| (stage, s / steps))
            .collect()
    }
}

/// Adds the stage markers to `schedule` (which must be initialised again afterwards).
pub fn install_stage_clock(schedule: &mut Schedule) {
    for (i, &stage) in Stage::ORDER.iter().enumerate() {
        let marker = move |mut clock: ResMut<StageClock>| clock.mark(stage);
        let after_check = marker.after(StageCheck(stage));
        match Stage::ORDER.get(i + 1) {
            Some(&next) => schedule.add_systems(after_check.before(next)),
            None => schedule.add_systems(after_check),
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_charge_the_time_between_them_to_their_stage() {
        let mut clock = StageClock::default();
        clock.mark(Stage::Basis);
        assert_eq!(
            clock.seconds.iter().sum::<f64>(),
            0.0,
            "no start, nothing charged"
        );
        clock.start();
        std::thread::sleep(std::time::Duration::from_millis(2));
        clock.mark(Stage::Basis);
        clock.finish();
        let per_step = clock.per_step();
        assert_eq!(per_step[0].0, Stage::Basis);
        assert!(per_step[0].1 >= 0.002);
        assert_eq!(clock.steps, 1);
        clock.reset();
        assert!(clock.per_step().is_empty());
    }
}
