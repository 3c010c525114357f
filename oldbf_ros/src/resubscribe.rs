//! When to make a subscription again that has carried nothing for a while.
//!
//! rosrust does not retry a connection to a publisher that failed: a
//! subscriber can stay unconnected ("Failed to connect to topic
//! '/robot1/odom'"), and a robot rightly stopped without odometry then
//! stands still for good. A subscription
//! that carries nothing for `quiet_s` is made again; while it stays quiet the
//! wait doubles, up to `max_quiet_s`, so a topic nobody publishes (odometry
//! when a planner sends cmd_vel_in) costs the master one registration every
//! half minute, not one a second. Pure timing, so it is tested without ROS.

/// The nodes' first wait: a topic quiet this long is subscribed again (s).
pub const QUIET_S: f64 = 3.0;
/// The nodes' longest wait between two resubscriptions of a quiet topic (s).
pub const MAX_QUIET_S: f64 = 30.0;

/// The resubscription schedule of one topic. Times in s on the node's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resubscribe {
    quiet_s: f64,
    max_quiet_s: f64,
    wait_s: f64,
    /// When the subscription was last made.
    subscribed_s: f64,
}

impl Resubscribe {
    /// A subscription made at `now_s`; first made again after `quiet_s`
    /// without a message, at most `max_quiet_s` apart after that.
    pub fn new(now_s: f64, quiet_s: f64, max_quiet_s: f64) -> Self {
        Self {
            quiet_s,
            max_quiet_s,
            wait_s: quiet_s,
            subscribed_s: now_s,
        }
    }

    /// The schedule the nodes use ([`QUIET_S`], [`MAX_QUIET_S`]).
    pub fn standard(now_s: f64) -> Self {
        Self::new(now_s, QUIET_S, MAX_QUIET_S)
    }

    /// Whether to subscribe again at `now_s`, the last message having arrived
    /// at `last_message_s` (`None`: never). When it says so it counts the
    /// subscription as made now.
    pub fn due(&mut self, now_s: f64, last_message_s: Option<f64>) -> bool {
        if now_s < self.subscribed_s {
            // The clock went back: start counting again.
            self.subscribed_s = now_s;
        }
        let heard_since = last_message_s.filter(|&t| t >= self.subscribed_s);
        if heard_since.is_some() {
            // It works: a later silence starts from the short wait again.
            self.wait_s = self.quiet_s;
        }
        let quiet_since_s = heard_since.unwrap_or(self.subscribed_s);
        if now_s - quiet_since_s < self.wait_s {
            return false;
        }
        self.subscribed_s = now_s;
        self.wait_s = (2.0 * self.wait_s).min(self.max_quiet_s);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_topic_that_never_connects_is_subscribed_again_with_a_growing_wait() {
        let mut r = Resubscribe::new(0.0, 3.0, 30.0);
        assert!(!r.due(2.9, None));
        assert!(r.due(3.0, None), "3 s without a message");
        // Then 6, 12, 24 s apart, capped at 30.
        let mut at = Vec::new();
        for tenths in 31..1300 {
            let t = f64::from(tenths) / 10.0;
            if r.due(t, None) {
                at.push(t);
            }
        }
        assert_eq!(at, [9.0, 21.0, 45.0, 75.0, 105.0]);
    }

    #[test]
    fn a_working_topic_is_left_alone_and_a_later_silence_waits_the_short_time() {
        let mut r = Resubscribe::new(0.0, 3.0, 30.0);
        // Messages at 10 Hz for 20 s: never due.
        for tenths in 1..200 {
            let t = f64::from(tenths) / 10.0;
            assert!(!r.due(t, Some(t)), "{t}");
        }
        // Silence from 19.9 s: due 3 s later, then after 6 s more.
        assert!(!r.due(22.8, Some(19.9)));
        assert!(r.due(22.9, Some(19.9)));
        assert!(!r.due(28.8, Some(19.9)));
        assert!(r.due(28.9, Some(19.9)));
        // Messages again, then silence: the short wait again.
        assert!(!r.due(30.0, Some(30.0)));
        assert!(r.due(33.0, Some(30.0)));
    }

    #[test]
    fn a_clock_jump_back_restarts_the_count() {
        let mut r = Resubscribe::new(100.0, 3.0, 30.0);
        assert!(!r.due(5.0, None));
        assert!(!r.due(7.9, None));
        assert!(r.due(8.0, None));
    }
}
