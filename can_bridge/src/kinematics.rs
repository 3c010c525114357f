//! Differential-drive kinematics: twist ↔ wheel speeds ↔ motor speeds.
//!
//! Conventions: the robot frame is x forward, z up; positive angular speed
//! turns left (counter-clockwise). A wheel speed is the wheel's angular speed
//! in rad/s with positive = rolling the robot forward. A motor speed is what
//! the drive controls: the motor shaft's angular speed in rad/s in the
//! motor's own positive direction, `motor = direction × gear_ratio × wheel`.
//! The direction sign is −1 for a motor mounted mirrored (typically one side
//! of the robot).

use serde::Serialize;

/// A velocity command in the robot frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Twist {
    /// Forward speed (m/s).
    pub linear_mps: f64,
    /// Yaw rate, positive counter-clockwise (rad/s).
    pub angular_radps: f64,
}

impl Twist {
    /// Standing still.
    pub const ZERO: Twist = Twist {
        linear_mps: 0.0,
        angular_radps: 0.0,
    };

    /// A twist from its two components.
    pub fn new(linear_mps: f64, angular_radps: f64) -> Self {
        Self {
            linear_mps,
            angular_radps,
        }
    }

    /// Both components are finite numbers.
    pub fn is_finite(&self) -> bool {
        self.linear_mps.is_finite() && self.angular_radps.is_finite()
    }
}

/// Angular speeds of the two wheels, positive = rolling forward (rad/s at the wheel).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct WheelSpeeds {
    pub left_radps: f64,
    pub right_radps: f64,
}

impl WheelSpeeds {
    /// Both wheels stopped.
    pub const ZERO: WheelSpeeds = WheelSpeeds {
        left_radps: 0.0,
        right_radps: 0.0,
    };

    /// The larger magnitude of the two (rad/s).
    pub fn max_abs(&self) -> f64 {
        self.left_radps.abs().max(self.right_radps.abs())
    }

    /// Both speeds are finite.
    pub fn is_finite(&self) -> bool {
        self.left_radps.is_finite() && self.right_radps.is_finite()
    }

    /// Both speeds multiplied by `k`.
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            left_radps: self.left_radps * k,
            right_radps: self.right_radps * k,
        }
    }
}

/// Motor shaft speeds in each motor's own direction (rad/s at the motor).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct MotorSpeeds {
    pub left_radps: f64,
    pub right_radps: f64,
}

impl MotorSpeeds {
    /// Both motors stopped.
    pub const ZERO: MotorSpeeds = MotorSpeeds {
        left_radps: 0.0,
        right_radps: 0.0,
    };

    /// The speed of one side.
    pub fn get(&self, wheel: Wheel) -> f64 {
        match wheel {
            Wheel::Left => self.left_radps,
            Wheel::Right => self.right_radps,
        }
    }
}

/// One side of the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Wheel {
    Left,
    Right,
}

impl Wheel {
    /// Both sides, left first.
    pub const BOTH: [Wheel; 2] = [Wheel::Left, Wheel::Right];

    /// 0 for left, 1 for right (array index).
    pub fn index(self) -> usize {
        match self {
            Wheel::Left => 0,
            Wheel::Right => 1,
        }
    }

    /// `left` or `right`.
    pub fn name(self) -> &'static str {
        match self {
            Wheel::Left => "left",
            Wheel::Right => "right",
        }
    }
}

/// The geometry of a differential drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffDrive {
    /// Distance between the wheels' contact points, L (m).
    pub wheel_separation_m: f64,
    /// Wheel radius, r (m).
    pub wheel_radius_m: f64,
    /// Motor turns per wheel turn.
    pub gear_ratio: f64,
    /// +1 or −1: the sign from "left wheel forward" to "left motor positive".
    pub left_direction: f64,
    /// +1 or −1, for the right side.
    pub right_direction: f64,
}

impl DiffDrive {
    /// Inverse kinematics: ω_l = (v − ω·L/2)/r, ω_r = (v + ω·L/2)/r.
    pub fn wheel_speeds(&self, t: Twist) -> WheelSpeeds {
        let half = 0.5 * self.wheel_separation_m * t.angular_radps;
        WheelSpeeds {
            left_radps: (t.linear_mps - half) / self.wheel_radius_m,
            right_radps: (t.linear_mps + half) / self.wheel_radius_m,
        }
    }

    /// Forward kinematics: v = r(ω_l + ω_r)/2, ω = r(ω_r − ω_l)/L.
    pub fn twist(&self, w: WheelSpeeds) -> Twist {
        let r = self.wheel_radius_m;
        Twist {
            linear_mps: 0.5 * r * (w.left_radps + w.right_radps),
            angular_radps: r * (w.right_radps - w.left_radps) / self.wheel_separation_m,
        }
    }

    fn direction(&self, wheel: Wheel) -> f64 {
        match wheel {
            Wheel::Left => self.left_direction,
            Wheel::Right => self.right_direction,
        }
    }

    /// Motor-side factor of one side: direction × gear ratio.
    pub fn motor_per_wheel(&self, wheel: Wheel) -> f64 {
        self.direction(wheel) * self.gear_ratio
    }

    /// Wheel speeds → motor speeds (through the gear, in each motor's direction).
    pub fn to_motor(&self, w: WheelSpeeds) -> MotorSpeeds {
        MotorSpeeds {
            left_radps: w.left_radps * self.motor_per_wheel(Wheel::Left),
            right_radps: w.right_radps * self.motor_per_wheel(Wheel::Right),
        }
    }

    /// Motor angle or speed of one side → the wheel's (rad or rad/s).
    pub fn motor_to_wheel(&self, wheel: Wheel, motor: f64) -> f64 {
        motor / self.motor_per_wheel(wheel)
    }

    /// Motor speeds → wheel speeds.
    pub fn to_wheel(&self, m: MotorSpeeds) -> WheelSpeeds {
        WheelSpeeds {
            left_radps: self.motor_to_wheel(Wheel::Left, m.left_radps),
            right_radps: self.motor_to_wheel(Wheel::Right, m.right_radps),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// TurtleBot3-like: L = 0.16 m, r = 0.033 m.
    fn tb3() -> DiffDrive {
        DiffDrive {
            wheel_separation_m: 0.16,
            wheel_radius_m: 0.033,
            gear_ratio: 1.0,
            left_direction: 1.0,
            right_direction: 1.0,
        }
    }

    #[test]
    fn inverse_kinematics_by_hand() {
        // v = 0.2, ω = 0.5: ω·L/2 = 0.04; left (0.2 − 0.04)/0.033, right (0.2 + 0.04)/0.033.
        let w = tb3().wheel_speeds(Twist::new(0.2, 0.5));
        assert!((w.left_radps - 4.848_484_848_484_849).abs() < 1e-12, "{w:?}");
        assert!((w.right_radps - 7.272_727_272_727_273).abs() < 1e-12, "{w:?}");
        // Turning in place: equal and opposite.
        let w = tb3().wheel_speeds(Twist::new(0.0, 1.0));
        assert!((w.left_radps + 0.08 / 0.033).abs() < 1e-12);
        assert!((w.right_radps - 0.08 / 0.033).abs() < 1e-12);
    }

    #[test]
    fn forward_kinematics_inverts_inverse() {
        let k = tb3();
        for (v, om) in [(0.2, 0.5), (-0.1, 2.0), (0.0, -1.0), (0.3, 0.0)] {
            let t = k.twist(k.wheel_speeds(Twist::new(v, om)));
            assert!((t.linear_mps - v).abs() < 1e-12 && (t.angular_radps - om).abs() < 1e-12);
        }
    }

    #[test]
    fn gear_and_direction_reach_the_motor() {
        let k = DiffDrive {
            gear_ratio: 20.0,
            left_direction: 1.0,
            right_direction: -1.0,
            ..tb3()
        };
        let m = k.to_motor(WheelSpeeds {
            left_radps: 2.0,
            right_radps: 3.0,
        });
        assert_eq!(m.left_radps, 40.0);
        assert_eq!(m.right_radps, -60.0);
        let w = k.to_wheel(m);
        assert_eq!((w.left_radps, w.right_radps), (2.0, 3.0));
        assert_eq!(k.motor_to_wheel(Wheel::Right, -20.0), 1.0);
    }
}
