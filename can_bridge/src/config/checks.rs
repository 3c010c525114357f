//! Every value of a [`BridgeConfig`] against its allowed range or rule;
//! each violation names the key to change.

use super::cia402::check_cia402;
use super::BridgeConfig;
use crate::protocol::generic::{MAX_BASE_ID, VEL_LIMIT_RADPS};
use crate::protocol::odrive::MAX_NODE_ID;
use crate::protocol::ProtocolKind;
use oldbf::config::{Checker, Interval, Validate};

/// A timeout or a rate-derived time (s).
const TIMEOUT_S: Interval = Interval::open_closed(0.0, 10.0).unit("s");
/// A wheel acceleration limit (rad/s²).
const WHEEL_ACCEL: Interval = Interval::open_closed(0.0, 100_000.0).unit("rad/s²");
/// ODrive CANSimple node ids (6 bits).
const ODRIVE_NODE_ID: Interval = Interval::closed(0.0, MAX_NODE_ID as f64);

impl Validate for BridgeConfig {
    fn check(&self, c: &mut Checker) {
        let name = &self.interface;
        c.rule(
            !name.is_empty() && name.len() <= 15 && !name.contains('/') && !name.chars().any(char::is_whitespace),
            "interface",
            format_args!("{name:?}"),
            "1-15 characters, no '/' or whitespace",
        );
        let t = &self.timing;
        c.range(
            "timing.tx_rate_hz",
            t.tx_rate_hz,
            Interval::open_closed(0.0, 1000.0).unit("Hz"),
        );
        c.range("timing.cmd_timeout_s", t.cmd_timeout_s, TIMEOUT_S);
        if t.tx_rate_hz.is_finite() && t.tx_rate_hz > 0.0 {
            c.rule(
                t.cmd_timeout_s.is_nan() || t.cmd_timeout_s >= 1.0 / t.tx_rate_hz,
                "timing.cmd_timeout_s",
                t.cmd_timeout_s,
                "at least one tx period, 1/timing.tx_rate_hz",
            );
        }
        c.range("timing.feedback_timeout_s", t.feedback_timeout_s, TIMEOUT_S);
        c.range("timing.heartbeat_timeout_s", t.heartbeat_timeout_s, TIMEOUT_S);
        c.range(
            "timing.startup_timeout_s",
            t.startup_timeout_s,
            Interval::open_closed(0.0, 60.0).unit("s"),
        );
        c.range(
            "timing.bus_recovery_s",
            t.bus_recovery_s,
            Interval::closed(0.0, 60.0).unit("s"),
        );

        let k = &self.kinematics;
        c.range(
            "kinematics.wheel_separation_m",
            k.wheel_separation_m,
            Interval::open_closed(0.0, 10.0).unit("m"),
        );
        c.range(
            "kinematics.wheel_radius_m",
            k.wheel_radius_m,
            Interval::open_closed(0.0, 5.0).unit("m"),
        );
        c.range(
            "kinematics.gear_ratio",
            k.gear_ratio,
            Interval::open_closed(0.0, 1000.0),
        );
        for (key, v) in [
            ("kinematics.left_direction", k.left_direction),
            ("kinematics.right_direction", k.right_direction),
        ] {
            c.rule(v == 1 || v == -1, key, v, "-1 or 1");
        }

        let l = &self.limits;
        c.range(
            "limits.v_max_mps",
            l.v_max_mps,
            Interval::open_closed(0.0, 20.0).unit("m/s"),
        );
        c.range(
            "limits.omega_max_radps",
            l.omega_max_radps,
            Interval::open_closed(0.0, 50.0).unit("rad/s"),
        );
        c.range(
            "limits.max_wheel_speed_radps",
            l.max_wheel_speed_radps,
            Interval::open_closed(0.0, 2000.0).unit("rad/s"),
        );
        c.range("limits.wheel_accel_radps2", l.wheel_accel_radps2, WHEEL_ACCEL);
        c.range("limits.wheel_decel_radps2", l.wheel_decel_radps2, WHEEL_ACCEL);
        if self.protocol == ProtocolKind::Generic {
            let motor_max = l.max_wheel_speed_radps * k.gear_ratio;
            c.rule(
                motor_max.is_nan() || motor_max <= VEL_LIMIT_RADPS,
                "limits.max_wheel_speed_radps",
                l.max_wheel_speed_radps,
                "times kinematics.gear_ratio at most 21474.83647 rad/s (the generic Vel_Cmd range)",
            );
        }

        c.rule(
            self.generic.base_id <= MAX_BASE_ID,
            "generic.base_id",
            format_args!("0x{:X}", self.generic.base_id),
            "[0, 0x7ED] (base + 0x12 must be a standard id)",
        );
        let o = &self.odrive;
        c.range("odrive.left_node_id", o.left_node_id, ODRIVE_NODE_ID);
        c.range("odrive.right_node_id", o.right_node_id, ODRIVE_NODE_ID);
        c.rule(
            o.left_node_id != o.right_node_id,
            "odrive.right_node_id",
            o.right_node_id,
            "different from odrive.left_node_id",
        );
        c.range(
            "odrive.torque_ff_nm",
            o.torque_ff_nm,
            Interval::closed(-100.0, 100.0).unit("Nm"),
        );
        check_cia402(self, c);
        self.odometry.check(c);
    }
}
