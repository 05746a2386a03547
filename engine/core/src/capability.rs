//! Capabilities: what one system promises that another system relies on, named by a type.
//!
//! A law that needs something of another stage (a damage law that degrades the stress needs a
//! stress recomputed from a potential every step) asks for a capability, never for a system by
//! name, so that a user's own system qualifies by declaring what it provides. A provider calls
//! `Installer::provide::<C>()`; a law calls `Installer::require_from::<C>(stage)`, which holds
//! when every pipeline entry of that stage has provided `C`. Entries install in stage order, so
//! a law can ask of any earlier stage.

use crate::stage::Stage;
use bevy_ecs::prelude::Resource;
use std::any::TypeId;

/// A promise a system can make, named by a marker type.
pub trait Capability: 'static {
    /// What the promise is, in words for messages (e.g. "a stress derived from a hyperelastic
    /// potential every step").
    const DESCRIPTION: &'static str;
}

/// The stress is the derivative of a hyperelastic potential of the deformation gradient,
/// computed afresh from `F` every step (never integrated from its previous value), and
/// `StrainEnergyDensity` holds that potential's energy per unit reference volume. A damage law
/// may then degrade the stress and the energy after the stress stage: the next step starts
/// again from the undamaged potential. `stress/neo_hookean` provides it.
#[derive(Clone, Copy, Debug)]
pub struct HyperelasticStress;

impl Capability for HyperelasticStress {
    const DESCRIPTION: &'static str = "a stress derived from a hyperelastic potential of F, \
                                       recomputed every step, with its energy density";
}

/// The entry leaves every output of its stage that later stages require something of (the
/// stress stage's stress, strain, deformation gradient, volume and energy density) as the other
/// entries of the stage made them, and writes only state of its own: a requirement of every
/// entry of a stage ([`Installer::require_from`](crate::registry::Installer::require_from))
/// passes it by. `stress/shock_viscosity` provides it: its viscous pressure acts in the
/// internal force alone.
#[derive(Clone, Copy, Debug)]
pub struct Bystander;

impl Capability for Bystander {
    const DESCRIPTION: &'static str = "nothing of its stage's outputs changed";
}

/// The entry takes each particle's velocity gradient from the transfer's reader
/// (`fractum_systems::transfer::VelocityGradients`), never from the connectivity directly: a
/// pipeline whose transfer builds no connectivity (`predictor/mls`, which gives each particle
/// `L_p = C_p`) then still gives it the particle's gradient. The stock stress systems provide it.
#[derive(Clone, Copy, Debug)]
pub struct ReadsTransferGradient;

impl Capability for ReadsTransferGradient {
    const DESCRIPTION: &'static str = "a velocity gradient read through the transfer's reader \
                                       (VelocityGradients), not the connectivity";
}

/// Which pipeline entries provided which capability, as they installed.
#[derive(Resource, Clone, Debug, Default)]
pub struct Capabilities {
    provided: Vec<(TypeId, Stage, usize)>,
}

impl Capabilities {
    /// Records that pipeline entry `entry`, of `stage`, provides `C`.
    pub fn provide<C: Capability>(&mut self, stage: Stage, entry: usize) {
        self.provided.push((TypeId::of::<C>(), stage, entry));
    }

    /// Whether pipeline entry `entry` provided `C`.
    pub fn provides<C: Capability>(&self, entry: usize) -> bool {
        self.provided
            .iter()
            .any(|&(c, _, e)| c == TypeId::of::<C>() && e == entry)
    }
}
