//! The step's stages, in the order they run. Before rapier's step: the plan of the pairs
//! between opted-in bodies (`pair_plan.rs`) and of each body near a ground (`plan.rs`). After
//! it: the clusters of impacts between bodies (`pair_reconstruct.rs`), each body's motion
//! through its ground impacts (`reconstruct.rs`), the one check of every end state
//! (`settle.rs`), and the one writer (`commit.rs`).

pub(crate) mod commit;
pub(crate) mod pair_plan;
pub(crate) mod pair_reconstruct;
pub(crate) mod plan;
pub(crate) mod reconstruct;
pub(crate) mod settle;
