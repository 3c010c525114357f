//! `log` records to the terminal and, once the node is connected, to /rosout.
//!
//! Our crates log with the `log` macros everywhere (core, simulator, nodes).
//! In a node those records also reach rosout through `rosrust::log`, which
//! prints them too. Records from other crates (rosrust's own included) only
//! go to the terminal: forwarding rosrust's records back into rosrust could
//! loop.

use log::{Level, LevelFilter, Log, Metadata, Record};

struct RosLogger {
    terminal: env_logger::Logger,
}

/// rosgraph_msgs/Log levels.
fn ros_level(level: Level) -> i8 {
    match level {
        Level::Error => 8,
        Level::Warn => 4,
        Level::Info => 2,
        Level::Debug | Level::Trace => 1,
    }
}

impl Log for RosLogger {
    fn enabled(&self, metadata: &Metadata) -> bool {
        self.terminal.enabled(metadata)
    }

    fn log(&self, record: &Record) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let ours = record.target().starts_with("oldbf") || record.target().starts_with("can_bridge");
        if ours && rosrust::is_initialized() {
            rosrust::log(
                ros_level(record.level()),
                record.args().to_string(),
                record.file().unwrap_or(""),
                record.line().unwrap_or(0),
            );
        } else {
            self.terminal.log(record);
        }
    }

    fn flush(&self) {
        self.terminal.flush();
    }
}

/// Installs the logger; RUST_LOG selects levels (default: info).
pub fn init() {
    let terminal = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info")).build();
    let max = terminal.filter();
    if log::set_boxed_logger(Box::new(RosLogger { terminal })).is_ok() {
        log::set_max_level(max.max(LevelFilter::Error));
    }
}
