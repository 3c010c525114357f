//! A blinded sensor (ALGORITHM.md §1): dust, a cover, a person pressed
//! against the LiDAR, or a driver that has failed and sends NaN.
//!
//! The front sector (`laser.blind_sector_deg` wide, centred ahead) is where
//! the robot drives. When more than `laser.blind_fraction` of its beams read
//! unknown (NaN or below range_min) for longer than `laser.blind_timeout_s`,
//! nothing the filter computes from that scan can be trusted: the robot
//! stops and reports `sensor_blind`. The first scan whose front is mostly
//! readable again ends it. Until the timeout, the unknown beams' held
//! readings stand in for what they last saw.

use super::params::LaserParams;

/// The blindness timer.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BlindDetector {
    /// Stamp (s) of the first scan of the current mostly-unknown stretch.
    since_s: Option<f64>,
}

/// One scan's verdict.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlindVerdict {
    /// Unknown fraction of the front sector's beams (0 when it has none).
    pub unknown_fraction: f64,
    /// Mostly unknown for longer than the timeout: stop.
    pub blind: bool,
}

impl BlindDetector {
    /// Forgets when the front went unknown (after a stop, reset or clock jump).
    pub fn reset(&mut self) {
        self.since_s = None;
    }

    /// A scan stamped `stamp_s` (s) with `unknown_front` unknown beams out of
    /// `front_beams` in the front sector.
    pub fn update(&mut self, unknown_front: usize, front_beams: usize, stamp_s: f64, p: &LaserParams) -> BlindVerdict {
        let unknown_fraction = if front_beams == 0 {
            0.0
        } else {
            unknown_front as f64 / front_beams as f64
        };
        if unknown_fraction <= p.blind_fraction {
            self.since_s = None;
            return BlindVerdict {
                unknown_fraction,
                blind: false,
            };
        }
        let since = match self.since_s {
            // A clock that went backwards starts the stretch again.
            Some(t) if t <= stamp_s => t,
            _ => stamp_s,
        };
        self.since_s = Some(since);
        BlindVerdict {
            unknown_fraction,
            // A nanosecond of slack: stamps 0.1 s apart do not add up exactly.
            blind: stamp_s - since >= p.blind_timeout_s - 1e-9,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mostly_unknown_for_longer_than_the_timeout_is_blind_and_one_good_scan_ends_it() {
        let p = LaserParams::default(); // fraction 0.5, timeout 0.3 s
        let mut d = BlindDetector::default();
        // Exactly half unknown is not "more than half".
        assert!(!d.update(50, 100, 0.0, &p).blind);
        assert_eq!(d, BlindDetector::default());
        let v = d.update(51, 100, 1.0, &p);
        assert!(!v.blind && (v.unknown_fraction - 0.51).abs() < 1e-12);
        assert!(!d.update(100, 100, 1.2, &p).blind);
        assert!(d.update(100, 100, 1.3, &p).blind);
        assert!(d.update(60, 100, 1.9, &p).blind);
        // A good scan resumes at once, and the timer starts over.
        assert!(!d.update(10, 100, 2.0, &p).blind);
        assert!(!d.update(100, 100, 2.1, &p).blind);
        assert!(d.update(100, 100, 2.4, &p).blind);
    }

    #[test]
    fn edge_cases() {
        let mut p = LaserParams::default();
        let mut d = BlindDetector::default();
        // No front beams at all: nothing to judge.
        assert_eq!(d.update(0, 0, 0.0, &p).unknown_fraction, 0.0);
        // Timeout 0: blind on the first such scan.
        p.blind_timeout_s = 0.0;
        assert!(d.update(3, 4, 0.0, &p).blind);
        // The clock steps back: the stretch starts again at the new stamp.
        p.blind_timeout_s = 0.3;
        let mut d = BlindDetector::default();
        d.update(4, 4, 100.0, &p);
        assert!(!d.update(4, 4, 5.0, &p).blind);
        assert!(d.update(4, 4, 5.3, &p).blind);
    }
}
