//! The controllers the paper compares OLDBF against (ALGORITHM.md §8), on the
//! same perception: the pipeline's scan points, their one-step prediction,
//! clusters and tracks. Pure like the core; the simulator and the batch
//! evaluation select them with `--controller dcbf|vo`.
//!
//! * [`dcbf`]: the standard discrete-time CBF-QP safety filter, solved by
//!   clarabel.
//! * [`vo`]: ORCA velocity obstacles (dodgy_2d), mapped to the unicycle.

pub mod dcbf;
pub mod vo;

pub use dcbf::{DcbfFilter, DcbfOutcome};
pub use vo::{vo_command, VoOutcome, VoScene};
