//! `capsule_ros`: a small ROS client of the capsule graph (mode requests, move goals, the demo
//! run).

use std::time::{Duration, Instant};

use anyhow::{bail, Context as _, Result};
use capsule_args::{ranges, scene_file::SceneFile};
use capsule_controller::mode::Mode;
use capsule_msgs::{ControllerStatus, SetModeRequest, Time};
use capsule_ros_base::{
    node_main, ros_args,
    ros_options::{RosArgs, RosEnv, RosOptions},
};
use capsule_tools::client::{state_subscription, LifecycleClient, ModeClient, SegmentMeter};
use clap::{Parser, Subcommand};
use futures::StreamExt;

/// Talks to a running capsule graph: switch the controller's mode, or run the demo schedule
/// and report each segment's progression.
#[derive(Debug, Parser)]
#[command(name = "capsule_ros", version)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
    /// The controller's mode service
    #[arg(long, global = true, default_value = "/capsule_controller/set_mode")]
    service: String,
    #[command(flatten)]
    ros: RosArgs,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Call set_mode once and print the answer; exit status 3 when refused
    SetMode {
        /// off, forward, backward, chaos-control, custom, or a numeric code
        mode: String,
        /// Gain (see SetMode.srv; 0: the mode's default gain), [-1e12, 1e12]
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = ranges::finite())]
        gain: f64,
        /// Apply from this sim time [s] (0 = now)
        #[arg(long, default_value_t = 0.0)]
        at_s: f64,
        /// Give up after this long [s], (0, 1e6]
        #[arg(long, default_value_t = 10.0, value_parser = ranges::positive(ranges::MAX_SECONDS))]
        timeout_s: f64,
        #[command(flatten)]
        pulse: PulseArgs,
        /// Calls in a row on one client, each with its own timeout; a summary line after them,
        /// [1, 100000]
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100_000))]
        repeat: u32,
        /// Added to the gain at each repeat (answers of differing lengths), [-1e12, 1e12]
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = ranges::finite())]
        gain_step: f64,
    },
    /// Ask a managed node for a lifecycle transition and print whether it was taken, as
    /// `ros2 lifecycle set NODE TRANSITION`; exit status 3 when refused or failed
    LifecycleSet {
        /// The managed node, e.g. /capsule_plant
        node: String,
        /// configure, activate, deactivate, cleanup, shutdown
        #[arg(value_parser = ["configure", "activate", "deactivate", "cleanup", "shutdown"])]
        transition: String,
        /// Give up after this long [s], (0, 1e6]
        #[arg(long, default_value_t = 10.0, value_parser = ranges::positive(ranges::MAX_SECONDS))]
        timeout_s: f64,
    },
    /// Attractor switch, watched: wait until the plant's state shows a periodic orbit, request
    /// SWITCH_ATTRACTOR, follow the controller's status to the end of the switch, watch the
    /// state for more periods, and print the orbit's period before and after (from the state)
    /// with the status's tries and pulse stamps; exit status 3 when refused, 4 when the switch
    /// did not reach the target
    #[command(allow_negative_numbers = true)]
    SwitchAttractor {
        /// Scene (for the drive period and the physical scale)
        #[arg(long)]
        scene: String,
        /// Pulse gain k_p (within the controller's limit)
        #[arg(long, default_value_t = 0.3, value_parser = ranges::finite())]
        gain: f64,
        #[command(flatten)]
        pulse: PulseArgs,
        /// Drive periods of the state to watch before asking (the orbit must be periodic by then)
        #[arg(long, default_value_t = 30.0, value_parser = ranges::positive(1e9))]
        before_periods: f64,
        /// Drive periods of the state to watch after the switch ended
        #[arg(long, default_value_t = 30.0, value_parser = ranges::positive(1e9))]
        after_periods: f64,
        /// Give up after this long [s of wall time], (0, 1e6]
        #[arg(long, default_value_t = 600.0, value_parser = ranges::positive(ranges::MAX_SECONDS))]
        timeout_s: f64,
    },
    /// Print the sim time [s] that PERIODS drive periods of a scene take (plus 10 ms of margin)
    #[command(allow_negative_numbers = true)]
    Period {
        /// Scene (drive frequency and physical scale)
        #[arg(long)]
        scene: String,
        /// Number of drive periods, (0, 1e9]
        #[arg(long, default_value_t = 1.0, value_parser = ranges::positive(1e9))]
        periods: f64,
    },
    /// Send a Move goal to the controller (its `move` action), print the feedback and the
    /// result, as `ros2 action send_goal --feedback` does; Ctrl-C cancels the goal. Exit
    /// status 3 when refused, 4 when it ended without reaching the target
    #[command(allow_negative_numbers = true)]
    Move {
        /// Signed travel [m]: > 0 forward, < 0 backward, [-1e3, 1e3]
        #[arg(value_parser = ranges::within(-1e3, 1e3))]
        distance_m: f64,
        /// Landing tolerance [m] (0: the controller's default), [0, 1e3]
        #[arg(long, default_value_t = 0.0, value_parser = ranges::non_negative(1e3))]
        tolerance_m: f64,
        /// The goal's time limit [s] (0: none), [0, 1e6]
        #[arg(long, default_value_t = 0.0, value_parser = ranges::non_negative(ranges::MAX_SECONDS))]
        timeout_s: f64,
        /// The action
        #[arg(long, default_value = "/capsule_controller/move")]
        action: String,
        /// Give up waiting for the answer to the goal after this long [s], (0, 1e6]
        #[arg(long, default_value_t = 10.0, value_parser = ranges::positive(ranges::MAX_SECONDS))]
        answer_timeout_s: f64,
    },
    /// Schedule the segments (the controller must start in the first one), watch the state,
    /// and print each segment's mean progression per drive period
    #[command(allow_negative_numbers = true)]
    Demo {
        /// Scene (for the drive period and the length scale)
        #[arg(long)]
        scene: String,
        /// Segments MODE:PERIODS, in order
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "forward:60,backward:60,off:60"
        )]
        segments: Vec<String>,
        /// Drive periods skipped at the start of each segment before measuring, [0, 1e9]
        #[arg(long, default_value_t = 20.0, value_parser = ranges::non_negative(1e9))]
        settle_periods: f64,
        /// Give up after this long [s of wall time], (0, 1e6]
        #[arg(long, default_value_t = 600.0, value_parser = ranges::positive(ranges::MAX_SECONDS))]
        timeout_s: f64,
    },
}

/// The SWITCH_ATTRACTOR fields of a request (sent as given: the controller checks them).
#[derive(Debug, Clone, Copy, clap::Args)]
struct PulseArgs {
    /// SWITCH_ATTRACTOR: pulse length [drive periods]
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pulse_periods: i32,
    /// SWITCH_ATTRACTOR: period of the orbit wanted [drive periods]
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    target_period: i32,
    /// SWITCH_ATTRACTOR: most pulses
    #[arg(long, default_value_t = 3, allow_negative_numbers = true)]
    max_tries: i32,
}

fn parse_mode(s: &str) -> Result<u8> {
    if let Ok(code) = s.parse::<u8>() {
        return Ok(code);
    }
    Mode::parse_name(s)
        .map(Mode::code)
        .with_context(|| format!("unknown mode {s:?}"))
}

async fn run(cli: Cli, settings: RosOptions) -> Result<()> {
    match cli.cmd {
        Cmd::LifecycleSet {
            node,
            transition,
            timeout_s,
        } => {
            let ask = Ask::Transition {
                managed: node,
                transition,
            };
            ask_once(&settings, ask, timeout_s).await
        }
        Cmd::SetMode {
            mode,
            gain,
            at_s,
            timeout_s,
            pulse,
            repeat,
            gain_step,
        } => {
            let req = SetModeRequest {
                mode: parse_mode(&mode)?,
                gain,
                effective_from: capsule_tools::client::effective_from(at_s)?,
                ..pulse.request()
            };
            let ask = Ask::SetMode {
                service: cli.service,
                req,
                repeat,
                gain_step,
            };
            ask_once(&settings, ask, timeout_s).await
        }
        Cmd::SwitchAttractor {
            scene,
            gain,
            pulse,
            before_periods,
            after_periods,
            timeout_s,
        } => {
            let scene = SceneFile::read(std::path::Path::new(&scene))?.scene;
            let req = SetModeRequest {
                mode: SetModeRequest::SWITCH_ATTRACTOR,
                gain,
                ..pulse.request()
            };
            let watch = SwitchWatch::new(&scene, before_periods, after_periods);
            switch_attractor(&settings, &cli.service, watch, req, timeout_s).await
        }
        Cmd::Move {
            distance_m,
            tolerance_m,
            timeout_s,
            action,
            answer_timeout_s,
        } => {
            let goal = capsule_msgs::actions::MoveGoal {
                distance_m,
                tolerance_m,
                timeout_s,
            };
            move_goal(&settings, &action, goal, answer_timeout_s).await
        }
        Cmd::Period { scene, periods } => {
            let sc = SceneFile::read(std::path::Path::new(&scene))?.scene;
            println!(
                "{:.6}",
                periods * sc.drive.period() * sc.physical.time_s() + 0.01
            );
            Ok(())
        }
        Cmd::Demo {
            scene,
            segments,
            settle_periods,
            timeout_s,
        } => {
            let sc = SceneFile::read(std::path::Path::new(&scene))?.scene;
            let demo = DemoPlan::new(&sc, &segments, settle_periods)?;
            demo.run(&settings, &cli.service, timeout_s).await
        }
    }
}

impl PulseArgs {
    /// A request with these pulse fields, the rest default.
    fn request(&self) -> SetModeRequest {
        SetModeRequest {
            pulse_periods: self.pulse_periods,
            target_period: self.target_period,
            max_tries: self.max_tries,
            ..SetModeRequest::default()
        }
    }
}

/// Prints a set_mode answer as the subcommands do.
fn print_answer(resp: &capsule_msgs::SetModeResponse) {
    println!(
        "accepted={} mode={} gain={} reason={}",
        resp.accepted,
        capsule_msgs::mode_name(resp.mode).unwrap_or("?"),
        resp.gain,
        resp.reason
    );
}

/// What a one-shot subcommand asks for.
enum Ask {
    /// `set-mode`: a set_mode request to the controller's mode service, `repeat` times, the
    /// gain `gain_step` higher each time.
    SetMode {
        service: String,
        req: SetModeRequest,
        repeat: u32,
        gain_step: f64,
    },
    /// `lifecycle-set`: a lifecycle transition of a managed node.
    Transition { managed: String, transition: String },
}

/// The one-shot subcommands (`set-mode`, `lifecycle-set`): one call from a node of its own,
/// the answer printed; exit status 3 when it was refused or failed.
async fn ask_once(settings: &RosOptions, ask: Ask, timeout_s: f64) -> Result<()> {
    let context = settings.context()?;
    let mut node = settings.node(&context)?;
    let timeout = Duration::from_secs_f64(timeout_s);
    let taken = match ask {
        Ask::SetMode {
            service,
            req,
            repeat,
            gain_step,
        } => {
            let client = ModeClient::new(&mut node, settings, &service)?;
            let started = Instant::now();
            let (mut accepted, mut slowest) = (true, 0.0_f64);
            for i in 0..repeat {
                let req = SetModeRequest {
                    gain: req.gain + f64::from(i) * gain_step,
                    ..req.clone()
                };
                let asked = Instant::now();
                let resp = client
                    .call(&node, req, timeout)
                    .await
                    .with_context(|| format!("call {} of {repeat}", i + 1))?;
                slowest = slowest.max(asked.elapsed().as_secs_f64());
                print_answer(&resp);
                accepted &= resp.accepted;
            }
            if repeat > 1 {
                println!(
                    "answered {repeat} of {repeat} calls in {:.3} s, the slowest in {slowest:.3} s",
                    started.elapsed().as_secs_f64()
                );
            }
            accepted
        }
        Ask::Transition {
            managed,
            transition,
        } => {
            let client = LifecycleClient::new(&mut node, settings, &managed)?;
            let taken = client.set(&node, &transition, timeout).await?;
            let outcome = if taken {
                "Transitioning successful"
            } else {
                "Transitioning failed"
            };
            println!("{managed} {transition}: {outcome}");
            taken
        }
    };
    if !taken {
        std::process::exit(3);
    }
    Ok(())
}

/// The demo's schedule: each segment's mode, start and end \[s of sim time\].
struct DemoPlan {
    segments: Vec<(Mode, f64, f64)>,
    settle_periods: f64,
    period_s: f64,
    length_m: f64,
}

impl DemoPlan {
    /// The schedule of `--segments` (MODE:PERIODS, in order) for a scene.
    fn new(
        sc: &capsule_plant::scene::Scene,
        segments: &[String],
        settle_periods: f64,
    ) -> Result<DemoPlan> {
        let period_s = sc.drive.period() * sc.physical.time_s();
        let mut plan = Vec::new();
        let mut t = 0.0;
        for seg in segments {
            let (m, n) = seg
                .split_once(':')
                .with_context(|| format!("--segments {seg:?}: expected MODE:PERIODS"))?;
            let mode =
                Mode::parse_name(m).with_context(|| format!("--segments {seg:?}: unknown mode"))?;
            let n: f64 = n.parse().ok().filter(|n: &f64| *n > settle_periods && *n <= 1e9).with_context(|| {
                format!("--segments {seg:?}: PERIODS must be a number above --settle-periods {settle_periods} and at most 1e9")
            })?;
            plan.push((mode, t, t + n * period_s));
            t += n * period_s;
        }
        if plan.is_empty() {
            bail!("--segments: nothing to run");
        }
        Ok(DemoPlan {
            segments: plan,
            settle_periods,
            period_s,
            length_m: sc.physical.length_m(),
        })
    }

    /// The set_mode requests that schedule every segment after the first, at its start.
    fn requests(&self) -> impl Iterator<Item = (Mode, f64, SetModeRequest)> + '_ {
        self.segments.iter().skip(1).map(|(mode, from, _)| {
            let req = SetModeRequest {
                mode: mode.code(),
                gain: 0.0,
                effective_from: Time::from_secs_f64(*from),
                ..SetModeRequest::default()
            };
            (*mode, *from, req)
        })
    }

    /// Says a segment is scheduled, or fails with the controller's reason.
    fn scheduled(mode: Mode, from: f64, resp: &capsule_msgs::SetModeResponse) -> Result<()> {
        if !resp.accepted {
            bail!("controller refused {mode} at {from:.3} s: {}", resp.reason);
        }
        println!(
            "scheduled {mode} from t = {from:.3} s (k_p = {})",
            resp.gain
        );
        Ok(())
    }

    /// Schedules the segments, measures them on the state topic, prints the table.
    async fn run(&self, settings: &RosOptions, service: &str, timeout_s: f64) -> Result<()> {
        #[cfg(feature = "zenoh")]
        if settings.middleware.is_zenoh() {
            return self.run_on_zenoh(settings, service, timeout_s).await;
        }
        let context = settings.context()?;
        let mut node = settings.node(&context)?;
        let client = ModeClient::new(&mut node, settings, service)?;
        let timeout = Duration::from_secs_f64(timeout_s);
        for (mode, from, req) in self.requests() {
            Self::scheduled(mode, from, &client.call(&node, req, timeout).await?)?;
        }
        let sub = state_subscription(&mut node, settings)?;
        let states = sub
            .async_stream()
            .map(|s| s.map(|(s, _)| s).map_err(|e| format!("{e:?}")));
        self.measure(settings, states, timeout_s).await
    }

    /// [`DemoPlan::run`] on Zenoh: the same requests and measurement, through a Zenoh node.
    #[cfg(feature = "zenoh")]
    async fn run_on_zenoh(
        &self,
        settings: &RosOptions,
        service: &str,
        timeout_s: f64,
    ) -> Result<()> {
        use capsule_msgs::SetModeResponse;
        use capsule_ros_base::{endpoints::Wire, qos, types};
        let context = settings.zenoh_context()?;
        let node = settings.zenoh_node(&context)?;
        let client = node
            .create_client::<Wire<SetModeRequest>, Wire<SetModeResponse>>(
                &settings.ros_name(service)?,
                &types::set_mode(),
            )
            .context("set_mode client on Zenoh")?;
        let started = Instant::now();
        for (mode, from, req) in self.requests() {
            // no reply while the controller's service is not there yet: asked again
            let resp = loop {
                match client.async_call(Wire(req.clone())).await {
                    Ok(Wire(resp)) => break resp,
                    Err(e) if started.elapsed().as_secs_f64() > timeout_s => {
                        bail!("{service} on Zenoh: no answer within {timeout_s} s: {e:?}")
                    }
                    Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
                }
            };
            Self::scheduled(mode, from, &resp)?;
        }
        let topic = node.create_topic(
            &settings.ros_name(capsule_msgs::names::topics::STATE)?,
            types::state(),
            &qos::data(),
        );
        let sub = node
            .create_subscription::<capsule_msgs::CapsuleState>(&topic, Some(qos::data_reader()))
            .context("state subscription on Zenoh")?;
        let states = sub
            .async_stream()
            .map(|s| s.map(|(s, _)| s).map_err(|e| format!("{e:?}")));
        self.measure(settings, states, timeout_s).await
    }

    /// Measures the segments on `states` (until every segment is over, or `timeout_s`),
    /// prints the table.
    async fn measure(
        &self,
        settings: &RosOptions,
        states: impl futures::Stream<Item = std::result::Result<capsule_msgs::CapsuleState, String>>,
        timeout_s: f64,
    ) -> Result<()> {
        let timeout = Duration::from_secs_f64(timeout_s);
        let windows = self
            .segments
            .iter()
            .map(|(m, from, to)| {
                let settled = from + self.settle_periods * self.period_s;
                (m.name().to_string(), settled, *to)
            })
            .collect();
        let mut meter = SegmentMeter::new(windows, self.period_s, self.length_m);
        tokio::pin!(states);
        let started = Instant::now();
        let (mut first_seq, mut last_seq) = (None, 0);
        while !meter.done() {
            let left = timeout.saturating_sub(started.elapsed());
            match tokio::time::timeout(left, states.next()).await {
                Err(_) => bail!(
                    "demo timed out after {timeout_s} s on {}",
                    settings.resolve_name(capsule_msgs::names::topics::STATE)
                ),
                Ok(None) => bail!("state stream ended"),
                Ok(Some(Err(e))) => tracing::warn!("bad state sample: {e}"),
                Ok(Some(Ok(s))) => {
                    first_seq.get_or_insert(s.seq);
                    last_seq = last_seq.max(s.seq);
                    meter.sample(&s);
                }
            }
        }
        let steps = last_seq - first_seq.unwrap_or(last_seq);
        self.report(&meter, started.elapsed().as_secs_f64(), steps);
        Ok(())
    }

    /// Prints each segment's progression and whether the directions came out right.
    fn report(&self, meter: &SegmentMeter, wall: f64, steps: u64) {
        let t = self.segments.last().map_or(0.0, |(_, _, to)| *to);
        println!("segment         periods  progression/period (non-dim)  progression/period [mm]");
        for r in meter.results() {
            println!(
                "{:<15} {:>7.1}  {:>28.6}  {:>23.6}",
                r.mode,
                r.periods,
                r.per_period,
                r.per_period_m * 1e3
            );
        }
        println!(
            "sim time {t:.3} s in {wall:.2} s wall: {steps} steps, {:.0} steps/s",
            steps as f64 / wall
        );
        let results = meter.results();
        let get = |m: &str| results.iter().find(|r| r.mode == m).map(|r| r.per_period);
        if let (Some(f), Some(b), Some(o)) = (get("FORWARD"), get("BACKWARD"), get("OFF")) {
            let yes = |ok: bool| if ok { "yes" } else { "NO" };
            println!(
                "forward > 0: {}, backward < 0: {}, off near 0 (under 5 % of forward): {}",
                yes(f > 0.0),
                yes(b < 0.0),
                yes(o.abs() < 0.05 * f.abs())
            );
        }
    }
}

/// What `switch-attractor` watches: the orbit on the plant's state before and after the
/// switch, and the controller's status during it.
struct SwitchWatch {
    /// The orbit as the plant's state shows it (the controller's status reports its own).
    watch: capsule_controller::switch::OrbitWatch,
    scale: capsule_plant::scene::PhysicalScale,
    period_s: f64,
    before_periods: f64,
    after_periods: f64,
    first: Option<f64>,
    /// Sim time of the last state \[s\].
    t: f64,
    phase: SwitchPhase,
    before: Option<usize>,
    last_status: Option<ControllerStatus>,
    shown: (u8, i32),
}

/// Where `switch-attractor` is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SwitchPhase {
    /// Watching the orbit before asking.
    Before,
    /// The switch runs.
    Switching,
    /// The switch ended; watching the orbit until this sim time \[s\].
    After(f64),
}

impl SwitchWatch {
    fn new(sc: &capsule_plant::scene::Scene, before_periods: f64, after_periods: f64) -> Self {
        use capsule_controller::switch::{OrbitWatch, SwitchConfig};
        let period = sc.drive.period();
        SwitchWatch {
            watch: OrbitWatch::new(period, &SwitchConfig::DEFAULT),
            scale: sc.physical,
            period_s: period * sc.physical.time_s(),
            before_periods,
            after_periods,
            first: None,
            t: 0.0,
            phase: SwitchPhase::Before,
            before: None,
            last_status: None,
            shown: (u8::MAX, -1),
        }
    }

    /// A state sample; true when it is time to request the switch.
    fn on_state(&mut self, s: &capsule_msgs::CapsuleState) -> Result<bool> {
        let (v, l) = (self.scale.velocity_m_per_s(), self.scale.length_m());
        let t = s.header.stamp.as_secs_f64();
        self.t = t;
        let t0 = *self.first.get_or_insert(t);
        let x = [
            s.mass_position / l,
            s.mass_velocity / v,
            s.capsule_position / l,
            s.capsule_velocity / v,
        ];
        self.watch.sample(t / self.scale.time_s(), x);
        if self.phase != SwitchPhase::Before || t - t0 < self.before_periods * self.period_s {
            return Ok(false);
        }
        let Some(p) = self.watch.period() else {
            bail!(
                "the state shows no periodic orbit after {} periods: nothing to switch from",
                self.before_periods
            );
        };
        self.before = Some(p);
        println!("before: orbit period {p} (state, t = {t:.3} s)");
        self.phase = SwitchPhase::Switching;
        Ok(true)
    }

    /// True once the orbit has been watched long enough after the switch.
    fn done(&self) -> bool {
        matches!(self.phase, SwitchPhase::After(until) if self.t >= until)
    }

    /// A status of the controller: each new phase or try of the switch printed.
    fn on_status(&mut self, st: ControllerStatus) {
        if self.phase == SwitchPhase::Switching
            && st.switch_state != ControllerStatus::SWITCH_NONE
            && (st.switch_state, st.switch_tries) != self.shown
        {
            self.shown = (st.switch_state, st.switch_tries);
            println!(
                "status: switch {} tries {} orbit period {} k_p {} pulse {:.4}..{:.4} s (t = {:.3} s)",
                switch_name(st.switch_state),
                st.switch_tries,
                st.orbit_period,
                st.gain,
                st.switch_pulse_start.as_secs_f64(),
                st.switch_pulse_end.as_secs_f64(),
                st.header.stamp.as_secs_f64()
            );
            if st.switch_state >= ControllerStatus::SWITCH_SUCCEEDED {
                self.phase = SwitchPhase::After(self.t + self.after_periods * self.period_s);
            }
        }
        self.last_status = Some(st);
    }

    /// The result line; exit status 4 when the switch did not reach the target.
    fn report(&self) -> Result<()> {
        let Some(st) = &self.last_status else {
            bail!("no controller status received");
        };
        println!(
            "SWITCH result={} tries={} max_tries={} target={} before={} after={} status_orbit_period={} mode={} gain={} pulse_start_s={:.6} pulse_end_s={:.6} t={:.3}",
            switch_name(st.switch_state),
            st.switch_tries,
            st.switch_max_tries,
            st.switch_target_period,
            self.before.map_or(0, |p| p as i32),
            self.watch.period().map_or(0, |p| p as i32),
            st.orbit_period,
            st.mode_name,
            st.gain,
            st.switch_pulse_start.as_secs_f64(),
            st.switch_pulse_end.as_secs_f64(),
            self.t,
        );
        if st.switch_state != ControllerStatus::SWITCH_SUCCEEDED {
            std::process::exit(4);
        }
        Ok(())
    }
}

/// The `switch-attractor` subcommand (see its help).
async fn switch_attractor(
    settings: &RosOptions,
    service: &str,
    mut sw: SwitchWatch,
    req: SetModeRequest,
    timeout_s: f64,
) -> Result<()> {
    let context = settings.context()?;
    let mut node = settings.node(&context)?;
    let client = ModeClient::new(&mut node, settings, service)?;
    let state_sub = state_subscription(&mut node, settings)?;
    let status_sub = capsule_tools::client::status_subscription(&mut node, settings, service)?;
    let states = state_sub.async_stream();
    tokio::pin!(states);
    let statuses = status_sub.async_stream();
    tokio::pin!(statuses);
    let timeout = Duration::from_secs_f64(timeout_s);
    let started = Instant::now();
    while !sw.done() {
        let left = timeout.saturating_sub(started.elapsed());
        if left.is_zero() {
            bail!(
                "switch-attractor timed out after {timeout_s} s (sim time {:.3} s)",
                sw.t
            );
        }
        tokio::select! {
            _ = tokio::time::sleep(left) => continue,
            s = states.next() => match s {
                None => bail!("state stream ended"),
                Some(Err(e)) => tracing::warn!("bad state sample: {e:?}"),
                Some(Ok((s, _))) => {
                    if sw.on_state(&s)? {
                        let resp = client.call(&node, req.clone(), Duration::from_secs(10)).await?;
                        print_answer(&resp);
                        if !resp.accepted {
                            std::process::exit(3);
                        }
                    }
                }
            },
            st = statuses.next() => match st {
                None => bail!("status stream ended"),
                Some(Err(e)) => tracing::warn!("bad status: {e:?}"),
                Some(Ok((st, _))) => sw.on_status(st),
            },
        }
    }
    sw.report()
}

/// The name of a `ControllerStatus.SWITCH_*` value.
fn switch_name(state: u8) -> &'static str {
    ControllerStatus::constant_name(state).map_or("?", |n| n.trim_start_matches("SWITCH_"))
}

/// `capsule_ros move`: the goal, its feedback and its result.
async fn move_goal(
    settings: &RosOptions,
    action: &str,
    goal: capsule_msgs::actions::MoveGoal,
    answer_s: f64,
) -> Result<()> {
    use capsule_msgs::actions::GoalStatus;
    use capsule_tools::move_client::{MoveClient, MoveEnded};
    let context = settings.context()?;
    let mut node = settings.node(&context)?;
    let client = MoveClient::new(&mut node, settings, action)?;
    // no goal limit: wait as long as a goal can take; Ctrl-C cancels it
    let result_wait = if goal.timeout_s > 0.0 {
        goal.timeout_s + 30.0
    } else {
        ranges::MAX_SECONDS
    };
    let cancel = async {
        let _ = tokio::signal::ctrl_c().await;
        eprintln!("Ctrl-C: canceling the goal");
    };
    let ended = client
        .run(
            &node,
            goal,
            Duration::from_secs_f64(answer_s),
            Duration::from_secs_f64(result_wait),
            |f| {
                println!(
                    "feedback: travelled_m={:.6} remaining_m={:.6} speed_m_per_s={:.6} mode={}",
                    f.travelled_m,
                    f.remaining_m,
                    f.speed_m_per_s,
                    capsule_msgs::mode_name(f.mode).unwrap_or("?")
                )
            },
            cancel,
        )
        .await?;
    match ended {
        MoveEnded::Refused => {
            println!("Goal refused (the controller's log says why)");
            std::process::exit(3);
        }
        MoveEnded::Ended(status, r) => {
            println!(
                "result: status={} reached={} travelled_m={:.6} error_m={:.6} elapsed_s={:.3} message={}",
                GoalStatus::name(status),
                r.reached,
                r.travelled_m,
                r.error_m,
                r.elapsed_s,
                r.message
            );
            if status != GoalStatus::STATUS_SUCCEEDED {
                std::process::exit(4);
            }
        }
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let cli = match ros_args::parse_cli_without_params::<Cli>("capsule_ros", |c| &mut c.ros) {
        Ok(cli) => cli,
        Err(e) => return node_main::exit_code("capsule_ros", Err(e)),
    };
    let settings = match RosOptions::resolve(&cli.ros, &RosEnv::from_process(), "capsule_ros") {
        Ok(settings) => settings,
        Err(e) => return node_main::exit_code("capsule_ros", Err(e)),
    };
    // Zenoh wants a multi-threaded runtime (Middleware::runtime)
    let middleware = settings.middleware.clone();
    let cpus = cli.ros.cpu_affinity.clone();
    node_main::exit_code(
        "capsule_ros",
        node_main::block_on_with(cpus.as_ref(), &middleware, run(cli, settings)),
    )
}
