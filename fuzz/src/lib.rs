//! Fuzz target bodies, shared by the libFuzzer binaries in `fuzz_targets/`
//! (one per module) so a crash reproduces through the same code whichever
//! way an input is run. Each `run` takes raw bytes, never panics on any
//! input unless it found a bug, and asserts what the code under test
//! promises (finite commands inside the limits, validated configs, ...).

pub mod can_decode;
pub mod can_decode_cia402;
pub mod can_decode_generic;
pub mod can_decode_odrive;
pub mod carmen_parse;
pub mod config_parse;
pub mod input;
pub mod scan_pipeline;
