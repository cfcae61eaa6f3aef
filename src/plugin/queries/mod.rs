//! Read-only questions the stages share: contact geometry along a flight and the time of
//! impact (`geometry.rs`), between two moving bodies (`body_contact.rs`), which grounds a body
//! may meet (`ground_index.rs`) and the tiled floors that are one box to it (`slabs.rs`),
//! rapier's own pair filtering (`filter.rs`), what the step reads of rapier (`observe.rs`),
//! and whether anything besides its grounds can reach a rolling ball (`reach.rs`, which keeps
//! what it read of each neighbouring ball for the rest of the plan). Nothing here writes rapier or the
//! plugin's state (the reach test keeps its memo).

pub(crate) mod body_contact;
pub(crate) mod filter;
pub(crate) mod geometry;
pub(crate) mod ground_index;
pub(crate) mod observe;
pub(crate) mod reach;
pub(crate) mod slabs;
