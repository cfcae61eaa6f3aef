//! What the plugin keeps: the registry of grounds and managed bodies (`registry.rs`), the
//! memory one step leaves for the next (`memory.rs`), the step's own data carried from the
//! plan to the stages after rapier's step (`step.rs`), and the tables everything else is
//! built from (`handles.rs`, `small_list.rs`).

pub(crate) mod handles;
pub(crate) mod memory;
pub(crate) mod registry;
pub(crate) mod small_list;
pub(crate) mod step;
pub(crate) mod writes;
