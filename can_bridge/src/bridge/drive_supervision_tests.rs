//! The drive supervisor by hand: statuses and times chosen per test, no bus.

use super::*;
use crate::config::default_config;

/// The shipped timing: heartbeat 0.5 s, feedback 0.2 s, start-up 2 s.
const PERIOD: Duration = Duration::from_millis(20);
const WATCHDOG: u32 = 0x800;

fn t(ms: u64) -> Timestamp {
    Timestamp::ZERO + Duration::from_millis(ms)
}

fn sup() -> DriveSupervisor {
    DriveSupervisor::new(&default_config().timing, PERIOD)
}

fn state(error_code: u32, running: bool) -> DriveState {
    DriveState {
        error_code,
        running,
        estopped: false,
        raw_state: 0,
    }
}

/// A heartbeat from both wheels' drive at `ms`.
fn hear(s: &mut DriveSupervisor, ms: u64, error_code: u32, running: bool) {
    s.on_status(Wheels::Both, state(error_code, running), true, t(ms));
}

/// One update with `b`: (start-up now, events).
fn step(s: &mut DriveSupervisor, ms: u64, b: Blockers) -> (bool, Vec<BridgeEvent>) {
    let mut log = EventLog::new();
    let start = s.update(t(ms), b, |c| c == WATCHDOG, &mut log);
    (start, log.drain().into_iter().map(|e| e.event).collect())
}

fn quiet() -> Blockers {
    Blockers::default()
}

fn reasons(s: &DriveSupervisor, ms: u64) -> Vec<&'static str> {
    let mut r = Vec::new();
    s.latched_reasons(&mut r);
    s.link_reasons(t(ms), false, &mut r);
    r.iter().map(StopReason::name).collect()
}

/// Heard, started and confirmed by `ms`.
fn ready(s: &mut DriveSupervisor) {
    hear(s, 0, 0, false);
    assert!(step(s, 0, quiet()).0);
    hear(s, 10, 0, true);
    s.on_feedback(Wheel::Left, t(10));
    s.on_feedback(Wheel::Right, t(10));
    assert_eq!(step(s, 10, quiet()).1, [BridgeEvent::DriveReady]);
}

#[test]
fn starts_only_when_every_heartbeat_is_fresh_and_nothing_blocks() {
    let mut s = sup();
    assert!(!step(&mut s, 0, quiet()).0, "nothing heard");
    assert_eq!(reasons(&s, 0), ["no_heartbeat", "no_heartbeat", "drive_starting"]);
    s.on_status(Wheels::One(Wheel::Left), state(0, false), true, t(0));
    assert!(!step(&mut s, 0, quiet()).0, "the right drive is silent");
    hear(&mut s, 1, 0, false);
    for b in [
        Blockers { estop: true, ..quiet() },
        Blockers {
            bus_down: true,
            ..quiet()
        },
    ] {
        assert!(!step(&mut s, 2, b).0, "{b:?}");
    }
    assert!(step(&mut s, 3, quiet()).0);
    assert!(!step(&mut s, 4, quiet()).0, "sent once");
    assert_eq!(reasons(&s, 4), ["drive_starting"]);
}

#[test]
fn only_a_status_after_the_start_up_confirms_it() {
    let mut s = sup();
    hear(&mut s, 0, 0, true); // "running", from before the start-up
    assert!(step(&mut s, 5, quiet()).0);
    assert!(step(&mut s, 6, quiet()).1.is_empty(), "not confirmed by the old status");
    // A status at the start-up's own instant is not after it either.
    hear(&mut s, 5, 0, true);
    assert!(step(&mut s, 7, quiet()).1.is_empty());
    hear(&mut s, 8, 0, true);
    assert_eq!(step(&mut s, 8, quiet()).1, [BridgeEvent::DriveReady]);
    assert_eq!(
        reasons(&s, 8),
        ["feedback_lost", "feedback_lost"],
        "ready, no feedback yet"
    );
    s.on_feedback(Wheel::Left, t(8));
    s.on_feedback(Wheel::Right, t(8));
    assert!(reasons(&s, 208).is_empty(), "feedback exactly feedback_timeout old");
    assert_eq!(reasons(&s, 209), ["feedback_lost", "feedback_lost"]);
}

#[test]
fn an_unconfirmed_start_up_is_retried_after_the_startup_timeout() {
    let mut s = sup();
    hear(&mut s, 0, 0, false);
    assert!(step(&mut s, 0, quiet()).0);
    for ms in (100..=2000).step_by(100) {
        hear(&mut s, ms, 0, false);
        assert_eq!(step(&mut s, ms, quiet()), (false, vec![]), "{ms} ms: waiting");
    }
    hear(&mut s, 2001, 0, false);
    assert_eq!(step(&mut s, 2001, quiet()).1, [BridgeEvent::StartupTimeout]);
    assert!(step(&mut s, 2002, quiet()).0, "started again");
}

#[test]
fn an_error_at_boot_is_cleared_by_the_start_up_but_one_that_survives_it_latches() {
    let mut s = sup();
    hear(&mut s, 0, 0x20, false);
    assert!(step(&mut s, 0, quiet()).0, "boot: the start-up clears errors");
    for ms in (100..=2000).step_by(100) {
        hear(&mut s, ms, 0x20, false);
        assert_eq!(step(&mut s, ms, quiet()), (false, vec![]), "{ms} ms: waiting");
    }
    hear(&mut s, 2100, 0x20, false);
    let (_, ev) = step(&mut s, 2100, quiet());
    assert_eq!(
        ev,
        [BridgeEvent::DriveFaultLatched {
            wheel: Wheel::Left,
            error_code: 0x20,
            drive_estopped: false
        }]
    );
    assert_eq!(reasons(&s, 2100), ["drive_fault"]);
    hear(&mut s, 2200, 0, false);
    assert!(
        !step(&mut s, 2200, quiet()).0,
        "latched: the error went, the fault stays"
    );
    s.reset();
    assert!(step(&mut s, 2300, quiet()).0, "reset: started again");
}

#[test]
fn an_error_while_ready_latches_at_once() {
    let mut s = sup();
    ready(&mut s);
    hear(&mut s, 20, WATCHDOG, false);
    let (start, ev) = step(&mut s, 20, quiet());
    assert!(!start);
    assert!(matches!(
        ev[..],
        [BridgeEvent::DriveFaultLatched {
            error_code: WATCHDOG,
            ..
        }]
    ));
    assert_eq!(reasons(&s, 20), ["drive_fault"], "a latched fault is not a start-up");
}

#[test]
fn after_a_link_loss_only_a_watchdog_error_is_cleared_by_the_restart() {
    for (code, cleared) in [(WATCHDOG, true), (0x20, false)] {
        let mut s = sup();
        ready(&mut s);
        s.lose_link();
        hear(&mut s, 100, code, false);
        let (start, ev) = step(&mut s, 100, quiet());
        assert_eq!(start, cleared, "0x{code:X}: {ev:?}");
        assert_eq!(reasons(&s, 100).contains(&"drive_fault"), !cleared);
    }
    // Without a loss the bridge believed its frames got through: a watchdog
    // error then is a fault.
    let mut s = sup();
    ready(&mut s);
    s.stop();
    hear(&mut s, 100, WATCHDOG, false);
    assert!(!step(&mut s, 100, quiet()).0);
    assert_eq!(reasons(&s, 100), ["drive_fault"]);
}

#[test]
fn a_drive_in_its_own_estop_is_never_cleared_after_a_loss() {
    let mut s = sup();
    ready(&mut s);
    s.lose_link();
    let estopped = DriveState {
        estopped: true,
        ..state(0, false)
    };
    s.on_status(Wheels::Both, estopped, true, t(100));
    assert!(!step(&mut s, 100, quiet()).0);
    let mut r = Vec::new();
    s.latched_reasons(&mut r);
    assert!(matches!(
        r[..],
        [StopReason::DriveFault {
            drive_estopped: true,
            ..
        }]
    ));
}

#[test]
fn a_heartbeat_lost_on_a_healthy_bus_latches_until_reset() {
    let mut s = sup();
    ready(&mut s);
    // Last heartbeat at 10 ms; timeout 0.5 s.
    assert!(step(&mut s, 510, quiet()).1.is_empty(), "exactly the timeout: fresh");
    let (_, ev) = step(&mut s, 511, quiet());
    assert_eq!(ev, [BridgeEvent::HeartbeatLostLatched { wheel: Wheel::Left }]);
    assert_eq!(reasons(&s, 511), ["heartbeat_lost", "no_heartbeat", "no_heartbeat"]);
    hear(&mut s, 600, 0, true);
    assert!(!step(&mut s, 600, quiet()).0, "back, but not trusted");
    assert_eq!(reasons(&s, 600), ["heartbeat_lost"]);
    s.reset();
    assert!(step(&mut s, 601, quiet()).0);
}

#[test]
fn a_heartbeat_lost_while_the_bus_was_troubled_is_the_bus_doing() {
    let troubled = Blockers {
        bus_troubled: true,
        ..quiet()
    };
    let mut s = sup();
    ready(&mut s);
    step(&mut s, 10, troubled);
    // Lost at 511, 0.501 s after the trouble: beyond the heartbeat timeout
    // but within it plus one period (the drive's next heartbeat was on its
    // way when the bus came back): not latched.
    assert!(step(&mut s, 511, quiet()).1.is_empty());
    assert!(!reasons(&s, 511).contains(&"heartbeat_lost"));
    // A loss 0.521 s after the trouble (0.5 s + one period + 1 ms): latched.
    let mut s = sup();
    ready(&mut s);
    step(&mut s, 10, troubled);
    assert_eq!(
        step(&mut s, 531, quiet()).1,
        [BridgeEvent::HeartbeatLostLatched { wheel: Wheel::Left }]
    );
}

#[test]
fn a_drive_never_heard_is_a_start_up_not_a_loss() {
    let mut s = sup();
    for ms in (0..5000).step_by(100) {
        assert!(step(&mut s, ms, quiet()).1.is_empty());
    }
    let mut r = Vec::new();
    s.link_reasons(t(5000), false, &mut r);
    assert!(matches!(r[0], StopReason::NoHeartbeat { ever_seen: false, .. }));
    r.clear();
    s.link_reasons(t(5000), true, &mut r);
    assert_eq!(r.len(), 2, "e-stop: not waiting for a start-up");
}

#[test]
fn a_drive_that_stops_running_is_started_again() {
    let mut s = sup();
    ready(&mut s);
    s.on_status(Wheels::One(Wheel::Right), state(0, false), true, t(20));
    assert_eq!(
        step(&mut s, 20, quiet()).1,
        [BridgeEvent::DriveStoppedRunning { wheel: Wheel::Right }]
    );
    assert!(step(&mut s, 21, quiet()).0);
}

#[test]
fn a_state_that_is_not_a_heartbeat_does_not_keep_the_link_alive() {
    let mut s = sup();
    ready(&mut s);
    for ms in (100..=600).step_by(100) {
        s.on_status(Wheels::Both, state(0, true), false, t(ms));
    }
    assert_eq!(
        step(&mut s, 600, quiet()).1,
        [BridgeEvent::HeartbeatLostLatched { wheel: Wheel::Left }]
    );
    let st = s.link_status(Wheel::Left, t(600));
    assert_eq!(st.heartbeat_age_s, Some(0.59));
    assert!(st.running);
}
