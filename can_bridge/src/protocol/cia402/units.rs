//! Drive units ↔ SI at the motor shaft.
//!
//! CiA 402 leaves the units of velocity (0x60FF, 0x606C), acceleration
//! (0x6083–0x6085) and position (0x6064) to the drive. Here: positions in
//! encoder counts (`counts_per_motor_rev` per motor turn); velocities in rpm
//! or counts/s of the motor, in steps of `velocity_resolution` of that unit
//! (EPOS: rpm, 1; a drive in 0.1 counts/s: counts_per_s, 0.1); accelerations
//! in velocity units per second (EPOS: rpm/s).

use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// The unit of the drive's velocity objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VelocityUnit {
    /// Revolutions per minute of the motor.
    Rpm,
    /// Encoder counts per second.
    CountsPerS,
}

/// Conversions for one drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaling {
    /// Drive velocity units (LSB) per motor rad/s.
    units_per_radps: f64,
    /// Encoder counts per motor revolution.
    counts_per_rev: f64,
}

impl Scaling {
    /// `resolution`: the size of one velocity LSB in `unit` (> 0);
    /// `counts_per_rev` > 0.
    pub fn new(unit: VelocityUnit, resolution: f64, counts_per_rev: u32) -> Self {
        let per_rev_per_s = match unit {
            VelocityUnit::Rpm => 60.0,
            VelocityUnit::CountsPerS => f64::from(counts_per_rev),
        };
        Self {
            units_per_radps: per_rev_per_s / TAU / resolution,
            counts_per_rev: f64::from(counts_per_rev.max(1)),
        }
    }

    /// Drive velocity units per motor rad/s.
    pub fn units_per_radps(&self) -> f64 {
        self.units_per_radps
    }

    /// Encoder counts per motor revolution.
    pub fn counts_per_rev(&self) -> f64 {
        self.counts_per_rev
    }

    /// Motor rad/s → the drive's i32 velocity (rounded, saturated; NaN → 0).
    pub fn velocity_to_drive(&self, radps: f64) -> i32 {
        let u = radps * self.units_per_radps;
        if u.is_nan() {
            0
        } else {
            // `as` saturates at the i32 range (and maps ±inf there).
            u.round() as i32
        }
    }

    /// The drive's velocity → motor rad/s.
    pub fn velocity_from_drive(&self, units: i32) -> f64 {
        f64::from(units) / self.units_per_radps
    }

    /// Motor rad/s² → the drive's acceleration (velocity units per s);
    /// `None` if it rounds outside [1, u32::MAX].
    pub fn accel_to_drive(&self, radps2: f64) -> Option<u32> {
        let u = (radps2 * self.units_per_radps).round();
        (u >= 1.0 && u <= f64::from(u32::MAX)).then_some(u as u32)
    }

    /// Encoder counts (i32, wrapping) → motor angle in [0, modulus) rad.
    pub fn position_rad(&self, counts: i32) -> f64 {
        f64::from(counts as u32) * TAU / self.counts_per_rev
    }

    /// Positions wrap modulo 2³² counts.
    pub fn position_modulus_rad(&self) -> f64 {
        4_294_967_296.0 * TAU / self.counts_per_rev
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpm_by_hand() {
        let s = Scaling::new(VelocityUnit::Rpm, 1.0, 4096);
        // 1 rad/s = 60 / 2π rpm = 9.549296585513721.
        assert!((s.units_per_radps() - 9.549_296_585_513_721).abs() < 1e-12);
        assert_eq!(s.velocity_to_drive(100.0), 955); // 954.93
        assert_eq!(s.velocity_to_drive(-100.0), -955);
        assert!((s.velocity_from_drive(955) - 100.007_366_139_4).abs() < 1e-6);
        // 0.001 rpm resolution (EPOS4 with 0x60A9 set to milli-rpm).
        let m = Scaling::new(VelocityUnit::Rpm, 0.001, 4096);
        assert_eq!(m.velocity_to_drive(1.0), 9549);
        // Profile acceleration 1000 rad/s² = 9549.3 rpm/s.
        assert_eq!(s.accel_to_drive(1000.0), Some(9549));
    }

    #[test]
    fn counts_by_hand() {
        let s = Scaling::new(VelocityUnit::CountsPerS, 1.0, 4096);
        // 1 rad/s = 4096 / 2π counts/s = 651.898646.
        assert_eq!(s.velocity_to_drive(1.0), 652);
        assert_eq!(s.velocity_to_drive(10.0), 6519);
        let tenth = Scaling::new(VelocityUnit::CountsPerS, 0.1, 4096);
        assert_eq!(tenth.velocity_to_drive(1.0), 6519);
        // One turn is 4096 counts; −1 count wraps to just below the modulus.
        assert!((s.position_rad(4096) - TAU).abs() < 1e-12);
        assert!((s.position_rad(-1) - (s.position_modulus_rad() - TAU / 4096.0)).abs() < 1e-6);
        assert!((s.position_modulus_rad() - 1_048_576.0 * TAU).abs() < 1e-3);
    }

    #[test]
    fn never_a_nan_and_saturated() {
        let s = Scaling::new(VelocityUnit::Rpm, 1.0, 4096);
        assert_eq!(s.velocity_to_drive(f64::NAN), 0);
        assert_eq!(s.velocity_to_drive(f64::INFINITY), i32::MAX);
        assert_eq!(s.velocity_to_drive(-1e300), i32::MIN);
        assert_eq!(s.accel_to_drive(0.0), None);
        assert_eq!(s.accel_to_drive(f64::NAN), None);
        assert_eq!(s.accel_to_drive(1e12), None);
    }
}
