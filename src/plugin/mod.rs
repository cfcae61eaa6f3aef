//! The rapier adapter: ground registry and materials, the `PhysicsHooks` implementation, the
//! per-step driver (snapshot, step, time of impact, impulse, write back) and the impact
//! events. The only module that touches rapier types; the impulses come from
//! [`crate::model`]. See [`crate::docs::integration`].

mod body_contact;
mod commit;
mod config;
mod convert;
mod events;
mod filter;
mod geometry;
mod ground_index;
mod handles;
mod hook_flags;
mod hooks;
mod impact_plugin;
mod install;
mod observe;
mod pair_plan;
mod pair_reconstruct;
mod plan;
mod policy;
mod reconstruct;
mod registry;
mod resolve;
mod settle;

pub use config::{ConfigError, GroundMaterial, ImpactConfig, TimingMode};
pub use events::{EventKind, ImpactEvent, ImpactTiming};
pub use impact_plugin::ImpactPlugin;
