//! oldbf: the ROS-free core of the oldbf safety layer.
//!
//! For now it holds one module tree, [`config`]: the strict configuration
//! checks that `oldbf_ros` and `can_bridge` share (typed intervals, a checker
//! that collects every violation, errors that carry the dotted key as data,
//! and YAML loading that names the key of a wrong type). Everything here is
//! pure: no I/O beyond reading a named file, no clocks, no threads.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod config;
