//! `capsule_replay FILE` (also `capsule replay FILE`): publish a recording back onto ROS 2 at its recorded pace (or
//! `--rate` times it), `/clock` included so `use_sim_time` nodes follow it; or, with
//! `--check-controller`, re-drive the controller library offline from the recorded states and
//! mode changes and compare its commands with the recorded ones.

use capsule_msgs::names::type_names;
use capsule_msgs::std_types::{Clock, DiagnosticArray};
use std::{
    collections::BTreeMap,
    path::PathBuf,
    time::{Duration, Instant},
};

use anyhow::{bail, Context as _, Result};
use capsule_args::ranges;
use capsule_controller::mode::Mode;
use capsule_controller_node::{
    controller_core::ControllerCore,
    controller_settings::{self, GainFlags},
};
use capsule_msgs::{ActuatorForce, CapsuleState, ControllerStatus};
use capsule_plant::scene::Scene;
use capsule_record::{
    cdr,
    messages::Message,
    types::{ServiceEventInfo, SetModeEvent},
};
use capsule_ros_base::{
    node_main, qos,
    ros_options::{RosArgs, RosEnv, RosOptions},
    signals,
};
use clap::{CommandFactory, FromArgMatches, Parser};

/// Publish a recording back onto ROS 2 at its pace (with /clock), or re-drive the controller
/// library offline against it (--check-controller).
#[derive(Debug, Parser)]
#[command(name = "capsule_replay", version, long_about = None)]
struct Args {
    /// The recording (.mcap)
    file: PathBuf,
    /// Playback speed: 2 = twice the recorded pace, [1e-3, 1e3]
    #[arg(long, default_value_t = 1.0, value_parser = ranges::within(1e-3, 1e3))]
    rate: f64,
    /// Start over at the end, until Ctrl-C
    #[arg(long = "loop")]
    looping: bool,
    /// Only these topics (repeatable, or comma-separated; default: all)
    #[arg(long, value_delimiter = ',')]
    topics: Vec<String>,
    /// Skip this many seconds from the first message
    #[arg(long, default_value_t = 0.0)]
    start: f64,
    /// Play at most this many seconds (from --start), (0, 1e9]
    #[arg(long, value_parser = ranges::positive(1e9))]
    duration: Option<f64>,
    /// Before publishing, wait until every publisher has this many subscribers (max 30 s),
    /// 0 to 1000
    #[arg(long, default_value_t = 0, value_parser = ranges::count_usize(0, ranges::MAX_SUBSCRIBERS as usize))]
    wait_subscribers: usize,
    /// Seconds to let discovery settle before the first message, [0, 1e6]
    #[arg(long, default_value_t = 0.5, value_parser = ranges::non_negative(ranges::MAX_SECONDS))]
    delay_s: f64,
    /// Re-drive the controller library offline and compare its commands (no ROS)
    #[arg(long)]
    check_controller: bool,
    /// --check-controller: largest accepted |command difference| [N]
    #[arg(long, default_value_t = 1e-9)]
    tolerance: f64,
    /// --check-controller: the controller's gain settings
    #[command(flatten)]
    gains: GainFlags,
    #[command(flatten)]
    ros: RosArgs,
}

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    // negative numbers are values (`--direction-gain -0.1`)
    let matches = Args::command().allow_negative_numbers(true).get_matches();
    let args = match Args::from_arg_matches(&matches) {
        Ok(args) => args,
        Err(e) => e.exit(),
    };
    match replay(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // the chain of causes, without a backtrace; exit 1 as the offline toolkit's work errors
            eprintln!("capsule_replay: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Replays or checks, as the flags say.
fn replay(args: Args) -> Result<()> {
    // --rate, --delay-s and --duration are range-checked by their parsers
    if !(args.start.is_finite() && args.start >= 0.0) {
        bail!("--start {}: must be finite and >= 0", args.start);
    }
    if args.check_controller && !(args.tolerance.is_finite() && args.tolerance >= 0.0) {
        // NaN compares false with everything: a NaN tolerance would pass any file
        bail!("--tolerance {}: must be finite and >= 0", args.tolerance);
    }
    let all = capsule_record::messages(&args.file)?;
    if args.check_controller {
        return check_controller(&args, &all);
    }
    let selected = select(&args, all)?;
    node_main::block_on(args.ros.cpu_affinity.as_ref(), publish(&args, selected))
}

fn select(args: &Args, all: Vec<Message>) -> Result<Vec<Message>> {
    let Some(first) = all.first().map(|m| m.log_time) else {
        bail!("{}: no messages to replay", args.file.display());
    };
    for t in &args.topics {
        if !all.iter().any(|m| &m.topic == t) {
            bail!("--topics {t}: not in {}", args.file.display());
        }
    }
    let last = all.last().map_or(first, |m| m.log_time);
    let span_s = (last - first) as f64 * 1e-9;
    if args.start > span_s {
        bail!(
            "--start {:?}: beyond the end of {} ({span_s:.3} s long)",
            args.start,
            args.file.display()
        );
    }
    let from = first + (args.start * 1e9) as u64;
    let to = args
        .duration
        .map(|d| from.saturating_add((d * 1e9) as u64))
        .unwrap_or(u64::MAX);
    let out: Vec<Message> = all
        .into_iter()
        .filter(|m| m.log_time >= from && m.log_time <= to)
        .filter(|m| args.topics.is_empty() || args.topics.contains(&m.topic))
        .collect();
    if out.is_empty() {
        bail!("nothing to replay in that window / topic selection");
    }
    Ok(out)
}

enum Pub {
    State(ros2_client::dds::Publisher<CapsuleState>),
    Force(ros2_client::dds::Publisher<ActuatorForce>),
    Status(ros2_client::dds::Publisher<ControllerStatus>),
    Clock(ros2_client::dds::Publisher<Clock>),
    Event(ros2_client::dds::Publisher<SetModeEvent>),
    Diagnostics(ros2_client::dds::Publisher<DiagnosticArray>),
}

/// `$body` with `$p` bound to the publisher, whatever its message type.
macro_rules! with_publisher {
    ($pub:expr, $p:ident => $body:expr) => {
        match $pub {
            Pub::State($p) => $body,
            Pub::Force($p) => $body,
            Pub::Status($p) => $body,
            Pub::Clock($p) => $body,
            Pub::Event($p) => $body,
            Pub::Diagnostics($p) => $body,
        }
    };
}

impl Pub {
    fn subscribers(&self, node: &ros2_client::dds::Node) -> usize {
        with_publisher!(self, p => p.get_subscription_count(node))
    }

    async fn publish(&self, data: &[u8]) -> Result<()> {
        let r = with_publisher!(self, p => p
            .async_publish(cdr::decode(data)?)
            .await
            .err()
            .map(|e| format!("{e:?}")));
        match r {
            Some(e) => bail!("publish failed: {e}"),
            None => Ok(()),
        }
    }
}

/// `msgs` without the actions' feedback, status and service events, an action server's to publish: a
/// replay stands in for the graph's topics, not for a server that clients could take for the
/// live one (said on stderr when there were some).
fn without_actions(msgs: Vec<Message>) -> Vec<Message> {
    let (actions, msgs): (Vec<Message>, Vec<Message>) = msgs
        .into_iter()
        .partition(|m| m.topic.contains("/_action/"));
    if !actions.is_empty() {
        eprintln!(
            "capsule replay: not replaying the actions' feedback, status and service events ({} messages)",
            actions.len()
        );
    }
    msgs
}

async fn publish(args: &Args, msgs: Vec<Message>) -> Result<()> {
    let msgs = without_actions(msgs);
    let settings = RosOptions::resolve(&args.ros, &RosEnv::from_process(), "capsule_replay")?;
    let context = settings.context()?;
    let mut node = settings.node(&context)?;
    let mut pubs: BTreeMap<String, Pub> = BTreeMap::new();
    for m in &msgs {
        if pubs.contains_key(&m.topic) {
            continue;
        }
        let (pkg, name) = match m.type_name.split_once("/msg/") {
            Some(x) => x,
            None => bail!("{}: type {} is not pkg/msg/Type", m.topic, m.type_name),
        };
        let q = if m.type_name == type_names::CLOCK {
            qos::clock()
        } else if m.type_name == type_names::SET_MODE_EVENT {
            qos::service_events()
        } else {
            qos::data()
        };
        let name_ros = settings.ros_name(&m.topic)?;
        let topic = node
            .create_topic(&name_ros, ros2_client::MessageTypeName::new(pkg, name), &q)
            .with_context(|| format!("topic {}", m.topic))?;
        let p = match m.type_name.as_str() {
            type_names::STATE => Pub::State(node.create_publisher(&topic, None)?),
            type_names::FORCE => Pub::Force(node.create_publisher(&topic, None)?),
            type_names::STATUS => Pub::Status(node.create_publisher(&topic, None)?),
            type_names::CLOCK => Pub::Clock(node.create_publisher(&topic, None)?),
            type_names::SET_MODE_EVENT => Pub::Event(node.create_publisher(&topic, None)?),
            type_names::DIAGNOSTIC_ARRAY => Pub::Diagnostics(node.create_publisher(&topic, None)?),
            other => bail!("{}: cannot replay type {other}", m.topic),
        };
        pubs.insert(m.topic.clone(), p);
    }
    if args.wait_subscribers > 0 {
        let deadline = Instant::now() + Duration::from_secs(30);
        while pubs
            .values()
            .any(|p| p.subscribers(&node) < args.wait_subscribers)
        {
            if Instant::now() > deadline {
                bail!(
                    "not every topic has {} subscribers after 30 s",
                    args.wait_subscribers
                );
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
    tokio::time::sleep(Duration::from_secs_f64(args.delay_s)).await;
    let first = msgs.first().map(|m| m.log_time).unwrap_or(0);
    let shutdown = signals::shutdown_signal();
    tokio::pin!(shutdown);
    let mut loops = 0u64;
    loop {
        let start = tokio::time::Instant::now();
        for m in &msgs {
            let offset = (m.log_time - first) as f64 * 1e-9 / args.rate;
            let at = start + Duration::from_secs_f64(offset);
            tokio::select! {
                sig = &mut shutdown => {
                    eprintln!("capsule replay: {}: stopping", sig?);
                    return Ok(());
                }
                _ = tokio::time::sleep_until(at) => {}
            }
            if let Some(p) = pubs.get(&m.topic) {
                p.publish(&m.data)
                    .await
                    .with_context(|| format!("{} at {} ns", m.topic, m.log_time))?;
            }
        }
        loops += 1;
        if !args.looping {
            break;
        }
    }
    // let reliable writers deliver the tail before the participant goes away
    tokio::time::sleep(Duration::from_millis(500)).await;
    println!(
        "capsule replay: published {} messages on {} topics ({loops} pass{})",
        msgs.len() as u64 * loops,
        pubs.len(),
        if loops == 1 { "" } else { "es" }
    );
    Ok(())
}

/// The result of `--check-controller`.
#[derive(Debug, Clone, PartialEq)]
struct Check {
    /// Recorded commands compared.
    pub compared: u64,
    /// Recorded commands for states the library did not answer (or vice versa).
    pub unmatched: u64,
    /// Largest |difference| [N], with the state seq where it happened.
    pub worst: Option<(f64, u64)>,
    /// Mode requests replayed, and how many got a different answer than recorded.
    pub requests: (u64, u64),
}

/// The controller as the recording started it: the attached scene's scale and drive, the
/// gain flags, and the mode in force at the start (the controller's first status, else the
/// scene's gain).
fn recorded_controller(args: &Args, msgs: &[Message]) -> Result<ControllerCore> {
    let file = args.file.display().to_string();
    let scene = capsule_record::info(&args.file)?
        .scene_toml
        .with_context(|| format!("{file}: no scene attached: cannot configure the controller"))?;
    let scene = Scene::from_toml_str(&scene, &format!("{file}:scene.toml"))?;
    let config = controller_settings::gain_config(&args.gains)?;
    let first_status = msgs
        .iter()
        .find(|m| m.type_name == type_names::STATUS)
        .map(|m| cdr::decode::<ControllerStatus>(&m.data))
        .transpose()?;
    let (mode, kp) = match &first_status {
        Some(s) if s.mode == Mode::SwitchAttractor.code() => anyhow::bail!(
            "{file}: the recording starts during an attractor switch (first status SWITCH_ATTRACTOR): its state before the recording is unknown, so the controller cannot be re-driven"
        ),
        Some(s) => (
            Mode::from_code(s.mode)
                .with_context(|| format!("{file}: first status has unknown mode {}", s.mode))?,
            s.gain,
        ),
        None if scene.control.kp != 0.0 => (Mode::Custom, scene.control.kp),
        None => (Mode::Off, 0.0),
    };
    Ok(ControllerCore::new(
        scene.physical,
        scene.drive.alpha,
        scene.drive.omega,
        mode,
        kp,
        config,
        f64::INFINITY,
    ))
}

/// Commands by state seq (the library's, the recording's) and mode requests (replayed, answered
/// differently).
type Redriven = (BTreeMap<u64, f64>, BTreeMap<u64, f64>, (u64, u64));

/// Feeds the recorded states and mode requests to `core` in log-time order. A scheduled switch
/// (`effective_from`, e.g. `capsule_ros set-mode --at-s`) replays exactly; an immediate one is
/// placed where the recorder saw the request, which in a loaded system can be a sample away
/// from where the controller applied it.
fn redrive(core: &mut ControllerCore, msgs: &[Message]) -> Result<Redriven> {
    let t0 = msgs.first().map(|m| m.log_time).unwrap_or(0);
    let mut ours: BTreeMap<u64, f64> = BTreeMap::new();
    let mut recorded: BTreeMap<u64, f64> = BTreeMap::new();
    let mut requests = (0u64, 0u64);
    let mut pending_answers: Vec<(([u8; 16], i64), capsule_msgs::SetModeResponse)> = Vec::new();
    for m in msgs {
        match m.type_name.as_str() {
            type_names::STATE => {
                let s: CapsuleState = cdr::decode(&m.data)?;
                let now = (m.log_time - t0) as f64 * 1e-9;
                if let Some(cmd) = core.on_state(&s, now) {
                    ours.entry(cmd.state_seq).or_insert(cmd.force);
                }
            }
            type_names::FORCE => {
                let f: ActuatorForce = cdr::decode(&m.data)?;
                recorded.entry(f.state_seq).or_insert(f.force);
            }
            type_names::SET_MODE_EVENT => {
                let e: SetModeEvent = cdr::decode(&m.data)?;
                let key = (e.info.client_gid, e.info.sequence_number);
                if e.info.event_type == ServiceEventInfo::REQUEST_RECEIVED {
                    if let Some(req) = e.request.first() {
                        requests.0 += 1;
                        let resp = core.set_mode(req);
                        pending_answers.push((key, resp));
                    }
                } else if e.info.event_type == ServiceEventInfo::RESPONSE_SENT {
                    if let (Some(rec), Some(i)) = (
                        e.response.first(),
                        pending_answers.iter().position(|(k, _)| *k == key),
                    ) {
                        let (_, ours) = pending_answers.remove(i);
                        if ours.accepted != rec.accepted
                            || ours.mode != rec.mode
                            || ours.gain != rec.gain
                        {
                            requests.1 += 1;
                            eprintln!(
                                "set_mode answer differs: recorded {} mode {} k_p {}, library {} mode {} k_p {}",
                                rec.accepted, rec.mode, rec.gain, ours.accepted, ours.mode, ours.gain
                            );
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok((ours, recorded, requests))
}

fn check_controller(args: &Args, msgs: &[Message]) -> Result<()> {
    let mut core = recorded_controller(args, msgs)?;
    let (ours, recorded, requests) = redrive(&mut core, msgs)?;
    let file = args.file.display().to_string();
    if recorded.is_empty() {
        bail!("{file}: no force commands recorded: nothing to compare");
    }
    let mut check = Check {
        compared: 0,
        unmatched: 0,
        worst: None,
        requests,
    };
    for (seq, f) in &recorded {
        match ours.get(seq) {
            Some(g) => {
                check.compared += 1;
                let d = (f - g).abs();
                if check.worst.is_none_or(|(w, _)| d > w) {
                    check.worst = Some((d, *seq));
                }
            }
            None => check.unmatched += 1,
        }
    }
    let (worst, at) = check.worst.unwrap_or((0.0, 0));
    println!(
        "checked {} recorded commands against the controller library ({} mode requests, {} answered differently; {} commands without a counterpart)",
        check.compared, check.requests.0, check.requests.1, check.unmatched
    );
    println!(
        "largest |difference|: {worst:e} N at state seq {at} (tolerance {:e} N)",
        args.tolerance
    );
    if worst.is_nan() || worst > args.tolerance || check.unmatched > 0 || check.requests.1 > 0 {
        bail!(
            "the controller library does not reproduce the recording: largest difference {worst:e} N at state seq {at}, {} unmatched commands, {} differing answers",
            check.unmatched,
            check.requests.1
        );
    }
    println!("ok: the controller reproduces the recorded commands");
    Ok(())
}
