//! What the plugin keeps between calls: the registry of grounds and managed bodies
//! (`registry.rs`) and the handle-keyed tables everything else is built from (`handles.rs`).

pub(crate) mod handles;
pub(crate) mod memory;
pub(crate) mod registry;
pub(crate) mod small_list;
pub(crate) mod step;
