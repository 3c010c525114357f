//! `scan_pipeline`: arbitrary LaserScan fields, nominal twists, measured
//! speeds and odometry poses through `SafetyPipeline::step_with_pose`, a
//! short sequence of scans per input so the tracker and the DOAA latch carry
//! state from scan to scan (stamps may repeat or go backwards).
//!
//! Asserts: no panic; every command finite and inside the input box; a scan
//! that `check_scan` rejects, or a non-finite nominal, gives a zero command
//! with that cause.

use crate::input::{f32_of, f64_of};
use arbitrary::{Result, Unstructured};
use oldbf_ros::algo::dtcbf::InputBox;
use oldbf_ros::algo::scan::check_scan;
use oldbf_ros::algo::{LaserScan, Params, Pose2, SafetyPipeline, ScanHeader, StopCause, Twist};

/// Most scans per input.
const MAX_SCANS: usize = 8;
/// Most beams per scan (above the 2048 of the largest shipped LiDAR).
const MAX_BEAMS: usize = 4096;

/// Runs one input.
pub fn run(data: &[u8]) {
    let mut u = Unstructured::new(data);
    // Only `Unstructured` errors end an input early; that is not a failure.
    let _ = drive(&mut u);
}

/// Validated parameters: the shipped ones, with a few switches flipped.
fn params(u: &mut Unstructured<'_>) -> Result<Params> {
    let mut p = oldbf_ros::config::default_params();
    let flags = u.arbitrary::<u8>()?;
    p.control.allow_reverse = flags & 1 != 0;
    p.obstacles.enabled = flags & 2 == 0;
    if flags & 4 != 0 {
        p.dtcbf.prediction = oldbf_ros::algo::params::PredictionModel::Arc;
    }
    if flags & 8 != 0 {
        p.laser.max_beams = 64; // exercise TooManyBeams
    }
    if flags & 16 != 0 {
        p.laser.mount_yaw_deg = 180.0;
        p.laser.mount_x_m = -0.05;
    }
    if flags & 32 != 0 {
        p.obstacles.min_cluster_points = 1;
        p.obstacles.confirm_hits = 1;
        p.obstacles.moving_speed_mps = 0.01;
        p.obstacles.min_travel_m = 0.0;
    }
    Ok(if p.validate().is_ok() {
        p
    } else {
        oldbf_ros::config::default_params()
    })
}

/// The ranges of one scan: a pool of up to 8 values picked by the bytes,
/// optionally plus a smooth profile (walls and blobs for the clusterer).
fn ranges(u: &mut Unstructured<'_>, n: usize, out: &mut Vec<f32>) -> Result<()> {
    out.clear();
    let pool_len = 1 + usize::from(u.arbitrary::<u8>()? % 8);
    let mut pool = [0f32; 8];
    for v in pool.iter_mut().take(pool_len) {
        *v = f32_of(u)?;
    }
    let smooth = u.arbitrary::<bool>()?;
    let (base, amp, k) = (
        f32::from(u.arbitrary::<u8>()?) / 32.0,
        f32::from(u.arbitrary::<u8>()?) / 64.0,
        f32::from(u.arbitrary::<u8>()?) / 16.0,
    );
    let sel_len = 1 + usize::from(u.arbitrary::<u8>()?);
    let sel = u.bytes(sel_len.min(u.len())).unwrap_or(&[]);
    for i in 0..n {
        let s = sel.get(i % sel.len().max(1)).copied().unwrap_or(0) as usize;
        let v = if smooth && !s.is_multiple_of(4) {
            base + amp * (i as f32 * k / 64.0).sin()
        } else {
            pool[s % pool_len]
        };
        out.push(v);
    }
    Ok(())
}

fn drive(u: &mut Unstructured<'_>) -> Result<()> {
    let p = params(u)?;
    let ibox = InputBox::from_params(&p);
    let mut pipeline = SafetyPipeline::new(p.clone());
    let mut now_s = f64_of(u)?;
    if !now_s.is_finite() && u.arbitrary::<bool>()? {
        now_s = 100.0;
    }
    let mut stamp_s = now_s;
    let mut rs = Vec::new();
    let mut intensities = Vec::new();
    let scans = 1 + usize::from(u.arbitrary::<u8>()?) % MAX_SCANS;
    for _ in 0..scans {
        if u.is_empty() {
            break;
        }
        let n = usize::from(u.arbitrary::<u16>()?) % (MAX_BEAMS + 1);
        ranges(u, n, &mut rs)?;
        intensities.clear();
        match u.arbitrary::<u8>()? % 4 {
            0 => intensities.resize(n, 1.0),
            1 => intensities.resize(n / 2, 1.0),
            _ => {}
        }
        // Geometry: usually plausible, sometimes anything.
        let plausible = u.arbitrary::<u8>()? % 4 != 0;
        let (angle_min_rad, angle_increment_rad, range_min_m, range_max_m) = if plausible {
            let span = f32::from(u.arbitrary::<u8>()?) / 255.0 * std::f32::consts::TAU;
            let inc = span / n.max(1) as f32 * if u.arbitrary::<bool>()? { -1.0 } else { 1.0 };
            (
                -span / 2.0,
                inc,
                f32::from(u.arbitrary::<u8>()?) / 512.0,
                1.0 + f32::from(u.arbitrary::<u8>()?) / 8.0,
            )
        } else {
            (f32_of(u)?, f32_of(u)?, f32_of(u)?, f32_of(u)?)
        };
        // Timing: forward by one period, repeated, backwards, or anything.
        match u.arbitrary::<u8>()? % 8 {
            0 => {}
            1 => stamp_s -= 0.1,
            2 => stamp_s = f64_of(u)?,
            _ => stamp_s += p.control.dt_s(),
        }
        now_s = match u.arbitrary::<u8>()? % 8 {
            0 => f64_of(u)?,
            1 => stamp_s + f64::from(u.arbitrary::<i8>()?) / 100.0,
            _ => stamp_s + 0.01,
        };
        let nominal = if u.arbitrary::<u8>()? % 4 == 0 {
            Twist::new(f64_of(u)?, f64_of(u)?)
        } else {
            Twist::new(
                f64::from(u.arbitrary::<i8>()?) / 200.0,
                f64::from(u.arbitrary::<i8>()?) / 200.0,
            )
        };
        let v_now = f64_of(u)?;
        let pose = if u.arbitrary::<bool>()? {
            Some(Pose2::new(f64_of(u)?, f64_of(u)?, f64_of(u)?))
        } else {
            None
        };
        let scan = LaserScan {
            header: ScanHeader {
                stamp_s,
                angle_min_rad,
                angle_increment_rad,
                range_min_m,
                range_max_m,
            },
            ranges_m: &rs,
            intensities: &intensities,
        };
        let rec = pipeline.step_with_pose(&scan, now_s, nominal, v_now, pose);
        check_command(rec.cmd, &ibox);
        let rejected = check_scan(&scan, now_s, &p.laser);
        if !nominal.is_finite() {
            assert_eq!(rec.stop_cause, Some(StopCause::BadNominal));
            assert_eq!(rec.cmd, Twist::ZERO);
        } else if let Err(reason) = rejected {
            // By code: the reasons carry the offending values, which may be NaN.
            let cause = rec.stop_cause.map(|c| c.code());
            assert_eq!(cause, Some(StopCause::Rejected(reason).code()), "{reason}");
            assert_eq!(
                rec.cmd,
                Twist::ZERO,
                "rejected scan ({reason}) must give a zero command"
            );
        } else {
            assert_eq!(rec.beams, n);
            assert!(rec.valid_beams <= n);
        }
        assert_eq!(pipeline.last_command(), rec.cmd);
    }
    Ok(())
}

/// The command is finite and inside the configured input box.
pub fn check_command(cmd: Twist, b: &InputBox) {
    assert!(cmd.is_finite(), "non-finite command {cmd:?}");
    assert!(
        cmd.v_mps >= b.v_lo && cmd.v_mps <= b.v_hi,
        "v {} m/s outside [{}, {}]",
        cmd.v_mps,
        b.v_lo,
        b.v_hi
    );
    assert!(
        cmd.omega_radps.abs() <= b.omega_max,
        "omega {} rad/s outside ±{}",
        cmd.omega_radps,
        b.omega_max
    );
}
