//! The hand-over between rapier's numbers and the model's: the conversions (`convert.rs`,
//! the one place rapier's types and the model's `f64` types meet) and the construction of the
//! model's input and of events from its output (`resolve.rs`).

pub(crate) mod convert;
pub(crate) mod resolve;
