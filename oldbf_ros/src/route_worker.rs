//! The way-round planner beside the safety path (ALGORITHM.md §4c): a
//! thread of its own that takes each scan into the rolling local map and
//! plans at `unstuck.plan_period_s`, so a scan's command never waits for a
//! plan. The node hands it scans and what to plan for after every tick
//! ([`RouteWorker::feed`]) and offers the pipeline the newest route it has
//! made; the simulator plans in step instead (reproducible results), through
//! the same [`WayRound`].

use crate::algo::way_round::{MapScan, RouteAsk, RouteUpdate, WayRound};
use crate::algo::{Params, SafetyPipeline, Vec2};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The map's occupied cells are sent for display this often (s).
const MAP_SNAPSHOT_S: f64 = 1.0;

/// The planner times kept for reports: the newest this many plans (0.5 MiB;
/// about 9 h of plans at 2 Hz), so a node that runs for weeks does not grow.
pub const PLAN_TIMES_KEPT: usize = 65_536;

/// What the node sends the planner.
enum Job {
    Scan(MapScan),
    Ask(RouteAsk),
    Params(Box<Params>),
}

/// The planner thread and its channels. Dropping it stops the thread.
pub struct RouteWorker {
    jobs: Option<Sender<Job>>,
    /// Scans the planner has taken into its map, sent back so their buffers
    /// carry the next scans (no allocation per scan once warm).
    spares: Receiver<MapScan>,
    routes: Receiver<(RouteUpdate, Option<Vec<Vec2>>)>,
    /// The newest snapshot of the map's occupied cells (tracking frame, m),
    /// not yet taken ([`Self::take_map_cells`]).
    map_cells: Option<Vec<Vec2>>,
    thread: Option<JoinHandle<()>>,
    /// The last ask sent (an unchanged one is not sent again).
    last_ask: Option<RouteAsk>,
    /// The planner's own times (µs) of the newest [`PLAN_TIMES_KEPT`] plans
    /// received, in no particular order, for reports.
    pub plan_us: Vec<f64>,
    /// Plans received in all.
    pub plans: usize,
}

impl std::fmt::Debug for RouteWorker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RouteWorker").finish_non_exhaustive()
    }
}

impl RouteWorker {
    /// Starts the planner thread for `params`.
    pub fn start(params: &Params) -> std::io::Result<Self> {
        let (jobs, job_rx) = channel::<Job>();
        let (route_tx, routes) = channel::<(RouteUpdate, Option<Vec<Vec2>>)>();
        let (spare_tx, spares) = channel::<MapScan>();
        let params = params.clone();
        let thread = std::thread::Builder::new()
            .name("oldbf-route".into())
            .spawn(move || run(params, job_rx, route_tx, spare_tx))?;
        Ok(Self {
            jobs: Some(jobs),
            spares,
            routes,
            thread: Some(thread),
            last_ask: None,
            plan_us: Vec::new(),
            plans: 0,
            map_cells: None,
        })
    }

    /// After a tick: sends the pipeline's new scan for the map and what to
    /// plan for, and offers it the newest route made.
    pub fn feed(&mut self, pipeline: &mut SafetyPipeline) {
        let Some(jobs) = &self.jobs else { return };
        if let Some(scan) = pipeline.take_map_scan() {
            let mut copy = self.spares.try_recv().unwrap_or_default();
            copy.clone_from(scan);
            let _ = jobs.send(Job::Scan(copy));
        }
        if let Some(ask) = pipeline.route_ask() {
            if self.last_ask != Some(ask) {
                let _ = jobs.send(Job::Ask(ask));
                self.last_ask = Some(ask);
            }
        }
        let mut newest = None;
        while let Ok((u, cells)) = self.routes.try_recv() {
            self.record(u.plan_us);
            newest = Some(u);
            if cells.is_some() {
                self.map_cells = cells;
            }
        }
        if let Some(u) = newest {
            pipeline.offer_route(u);
        }
    }

    /// Keeps a plan's time, over the oldest kept once [`PLAN_TIMES_KEPT`] are.
    fn record(&mut self, plan_us: f64) {
        if self.plan_us.len() < PLAN_TIMES_KEPT {
            self.plan_us.push(plan_us);
        } else {
            self.plan_us[self.plans % PLAN_TIMES_KEPT] = plan_us;
        }
        self.plans += 1;
    }

    /// The newest snapshot of the map's occupied cells (tracking frame, m),
    /// once: sent about once a second, for display.
    pub fn take_map_cells(&mut self) -> Option<Vec<Vec2>> {
        self.map_cells.take()
    }

    /// New parameters (dynamic_reconfigure).
    pub fn set_params(&mut self, params: &Params) {
        if let Some(jobs) = &self.jobs {
            let _ = jobs.send(Job::Params(Box::new(params.clone())));
        }
    }

    /// Waits until the planner has made at least `n` plans in all, or
    /// `timeout` passes (tests); offers the newest to `pipeline`.
    pub fn wait_for_plans(&mut self, n: usize, timeout: Duration, pipeline: &mut SafetyPipeline) -> bool {
        let until = Instant::now() + timeout;
        while self.plans < n {
            let left = until.saturating_duration_since(Instant::now());
            match self.routes.recv_timeout(left) {
                Ok((u, cells)) => {
                    self.record(u.plan_us);
                    pipeline.offer_route(u);
                    if cells.is_some() {
                        self.map_cells = cells;
                    }
                }
                Err(_) => return false,
            }
        }
        true
    }
}

impl Drop for RouteWorker {
    fn drop(&mut self) {
        self.jobs = None; // the thread's receiver disconnects and it ends
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The planner thread: takes scans as they come; plans for the newest ask
/// whenever one is due; ends when the node drops its sender.
fn run(
    mut params: Params,
    jobs: Receiver<Job>,
    routes: Sender<(RouteUpdate, Option<Vec<Vec2>>)>,
    spares: Sender<MapScan>,
) {
    let mut way = WayRound::new(&params);
    let mut ask: Option<RouteAsk> = None;
    let mut last_snapshot_s = f64::NEG_INFINITY;
    let wait = Duration::from_secs_f64(params.unstuck.plan_period_s.clamp(0.01, 1.0) / 4.0);
    loop {
        match jobs.recv_timeout(wait) {
            Ok(job) => {
                let mut take = |job| match job {
                    Job::Scan(s) => {
                        way.insert(&s);
                        let _ = spares.send(s);
                    }
                    Job::Ask(a) => {
                        // A stuck flag stays until a plan has used it.
                        let stuck = a.stuck || ask.is_some_and(|o| o.stuck);
                        ask = Some(RouteAsk { stuck, ..a });
                    }
                    Job::Params(p) => {
                        params = *p;
                        way.reset(&params);
                    }
                };
                take(job);
                while let Ok(more) = jobs.try_recv() {
                    take(more);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
        if let Some(a) = ask.filter(|a| way.due(a, &params)) {
            let started = Instant::now();
            let mut update = way.plan(&a, &params);
            update.plan_us = started.elapsed().as_secs_f64() * 1e6;
            ask = Some(RouteAsk { stuck: false, ..a });
            let snapshot = (a.now_s - last_snapshot_s).abs() >= MAP_SNAPSHOT_S;
            let cells = snapshot.then(|| {
                last_snapshot_s = a.now_s;
                let mut cells = Vec::new();
                way.occupied_cells(a.now_s, &params, &mut cells);
                cells
            });
            if routes.send((update, cells)).is_err() {
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::algo::unstuck::Guidance;
    use crate::algo::{LaserScan, ScanHeader, Twist};
    use std::f32::consts::PI;

    /// 360 beams round the robot: a wall across x = 1.5 for |y| ≤ 1, nothing else.
    fn wall_scan() -> Vec<f32> {
        (0..360)
            .map(|k| {
                let a = -PI + k as f32 * 2.0 * PI / 360.0;
                let r = 1.5 / a.cos();
                if a.cos() > 0.0 && (r * a.sin()).abs() <= 1.0 {
                    r
                } else {
                    f32::INFINITY
                }
            })
            .collect()
    }

    fn step(pipe: &mut SafetyPipeline, ranges: &[f32], now_s: f64) {
        let header = ScanHeader {
            stamp_s: now_s,
            angle_min_rad: -PI,
            angle_increment_rad: 2.0 * PI / 360.0,
            range_min_m: 0.12,
            range_max_m: 3.5,
        };
        pipe.set_guidance(Some(Guidance {
            target: Vec2::new(0.5, 0.0),
            along_m: 0.5,
            ahead: Vec2::new(2.0, 0.0),
            end: Vec2::new(3.0, 0.0),
            at_end: false,
        }));
        let scan = LaserScan {
            header,
            ranges_m: ranges,
            intensities: &[],
        };
        pipe.step(&scan, now_s, Twist::new(0.1, 0.0), f64::NAN);
    }

    #[test]
    fn beside_the_safety_path_it_plans_the_same_route_as_in_step() {
        let p = Params::default();
        let ranges = wall_scan();
        // In step: the pipeline plans at its first scan.
        let mut in_step = SafetyPipeline::new(p.clone());
        step(&mut in_step, &ranges, 1.0);
        let expected = in_step.route().expect("planned in step").clone();
        assert!(expected.direct_margin_m < 0.0, "the wall blocks the straight way");
        // Beside: the step hands out the scan and the ask, and plans nothing itself.
        let mut beside = SafetyPipeline::new(p.clone());
        beside.plan_beside(true);
        let mut worker = RouteWorker::start(&p).unwrap();
        step(&mut beside, &ranges, 1.0);
        assert!(beside.route().is_none(), "the step does not wait for a plan");
        worker.feed(&mut beside);
        assert!(worker.wait_for_plans(1, Duration::from_secs(10), &mut beside));
        let got = beside.route().unwrap();
        assert_eq!(got.route, expected.route);
        assert_eq!((got.change, got.carrot), (expected.change, expected.carrot));
        assert!(got.plan_us > 0.0);
        // The first plan comes with the map's occupied cells: the wall, x = 1.5 m.
        let cells = worker.take_map_cells().expect("a snapshot with the first plan");
        assert!(
            !cells.is_empty() && cells.iter().all(|c| (c.x - 1.5).abs() <= 0.05),
            "{cells:?}"
        );
        assert!(worker.take_map_cells().is_none(), "taken once");
        // The thread ends when the worker is dropped.
        drop(worker);
    }

    #[test]
    fn plan_times_are_bounded_and_keep_the_newest() {
        let mut w = RouteWorker::start(&Params::default()).unwrap();
        for k in 0..PLAN_TIMES_KEPT + 10 {
            w.record(k as f64);
        }
        assert_eq!((w.plan_us.len(), w.plans), (PLAN_TIMES_KEPT, PLAN_TIMES_KEPT + 10));
        // The ten newest took the places of the ten oldest.
        let newest = PLAN_TIMES_KEPT as f64;
        assert_eq!(
            w.plan_us[..10],
            (0..10).map(|k| newest + k as f64).collect::<Vec<_>>()[..]
        );
        assert_eq!(w.plan_us[10], 10.0);
    }

    /// A fake clock for the tests below: each reading is 1000 µs after the last.
    fn ticking_clock_us() -> f64 {
        use std::sync::atomic::{AtomicU64, Ordering};
        static T: AtomicU64 = AtomicU64::new(0);
        (T.fetch_add(1000, Ordering::Relaxed) + 1000) as f64
    }

    #[test]
    fn in_step_planner_work_is_timed_by_the_callers_clock() {
        let p = Params::default();
        let ranges = wall_scan();
        let mut untimed = SafetyPipeline::new(p.clone());
        step(&mut untimed, &ranges, 1.0);
        assert!(untimed.route().is_some(), "planned in step");
        assert_eq!(untimed.planner_us_total(), 0.0, "no clock: nothing timed");
        // At the first scan the map takes the scan, then a plan is made: two blocks
        // of way-round work, each one tick (1000 µs) of the fake clock.
        let mut timed = SafetyPipeline::new(p.clone());
        timed.time_planner(ticking_clock_us);
        step(&mut timed, &ranges, 1.0);
        assert_eq!(timed.planner_us_total(), 2000.0);
        // Beside the safety path the step does none of that work.
        let mut beside = SafetyPipeline::new(p.clone());
        beside.plan_beside(true);
        beside.time_planner(ticking_clock_us);
        step(&mut beside, &ranges, 1.0);
        assert_eq!(beside.planner_us_total(), 0.0);
    }
}
