//! Read-only questions the stages share: contact geometry along a flight and the time of
//! impact (`geometry.rs`), between two moving bodies (`body_contact.rs`), which grounds a body
//! may meet (`ground_index.rs`) and the tiled floors that are one box to it (`slabs.rs`),
//! rapier's own pair filtering (`filter.rs`), what the step reads of rapier (`observe.rs`),
//! and whether anything besides its grounds can reach a rolling ball (`reach.rs`). Nothing
//! here writes rapier or the plugin's state, but for the reach test's memo of the
//! neighbouring balls it read in the current plan.

pub(crate) mod body_contact;
pub(crate) mod filter;
pub(crate) mod geometry;
pub(crate) mod ground_index;
pub(crate) mod observe;
pub(crate) mod reach;
pub(crate) mod slabs;
