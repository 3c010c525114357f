//! Selection (ALGORITHM.md §5c): the one command sent, chosen inside the
//! base's dynamic window.
//!
//! [`window`] the commands the base can reach from the one last sent;
//! [`candidates`] a fine sample of it, the speed exact per yaw rate;
//! [`tiers`] the hard constraints as one ordered list of relaxations
//! ([`h_mean`]: h averaged over recent steps, which the first of them uses);
//! [`critics`] the soft preferences, one file each ([`slide`]: the heading
//! the progress critic aims at when the target's bearing is closed);
//! [`selector`] the decision that puts them together.

pub mod candidates;
pub mod critics;
pub mod h_mean;
pub mod selector;
pub mod slide;
pub mod tiers;
pub mod window;

pub use critics::{Critic, CriticCosts};
pub use selector::{Geometry, SelectInput, Selection, Selector};
pub use tiers::Tier;
pub use window::Window;
