//! Selection (ALGORITHM.md §5c): the one command sent, chosen inside the
//! base's dynamic window.

pub mod window;

pub use window::Window;
