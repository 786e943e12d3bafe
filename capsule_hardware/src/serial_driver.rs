//! The plant's hardware driver: a [`CapsuleHardware`] that is a real capsule (or the device
//! emulator) on a serial line, speaking the protocol of `capsule_device`. The node around it
//! publishes, gates commands and records exactly as for the simulator.
//!
//! Threads: the line is read on a thread of its own (which also reopens a lost line), never on
//! the node's: what it reads goes through a channel to [`DeviceDriver::read`], and
//! [`CapsuleHardware::ready`] wakes the node's loop when something came. Forces are written by
//! the node's loop the moment the controller's answer arrives, and by the emergency stop's
//! [`CapsuleHardware::stopper`] from the service's thread, both under one lock on the writing
//! end; a write never waits for a read.
//!
//! Faults never stop the node: a line that goes away (a cable pulled, the emulator ended) is
//! reopened every half second; a device that stops sending, a measurement with NaN in a
//! measured field, or a mass beyond its travel all zero the force (a NaN or over-travel sample
//! is answered with zero; a silent or lost device zeroes its own force after its command
//! timeout) and are named in `/diagnostics`, the log (once per change) and the summary. Frames
//! that fail their checksum and garbage are skipped and counted. A measurement with the device
//! time of the one before is a re-send (a lock-step device repeats an unanswered sample): it
//! is answered, but is no new sample.
//!
//! What the device does not measure is published as NaN (velocities, friction and contact
//! forces); `in_contact` is derived from the measured `x1 - x2` and the scene's gap; `stuck` is
//! not measured and is false.

use std::fs::File;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use capsule_device::{frame::measured, Decoded, Force, Frame, Hello, Measurement};
use capsule_serial::{open_line, Line, Link};
use tracing::{info, warn};

use crate::latency::LatencyHistogram;
use crate::throttle::Throttle;
use crate::{CapsuleHardware, HardwareError, Reading, Ready, Sample, SourceHealth, Stopper};

/// The default baud rate of `serial:PATH`: a 1 kHz measurement stream needs 330 kbaud.
pub const DEFAULT_BAUD: u32 = 921_600;

/// How often a lost line is reopened.
const REOPEN_EVERY: Duration = Duration::from_millis(500);

/// Where the plant's samples come from: `sim` or `serial:PATH[,BAUD]`.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// The exact simulator of the scene.
    Sim,
    /// A device on a serial line.
    Serial {
        /// The line (`/dev/ttyUSB0`, a pseudo-terminal, the emulator's `--link`).
        path: PathBuf,
        /// Its baud rate (one of [`capsule_serial::BAUD_RATES`]).
        baud: u32,
    },
}

impl std::str::FromStr for Source {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Source, String> {
        if s == "sim" {
            return Ok(Source::Sim);
        }
        let Some(rest) = s.strip_prefix("serial:") else {
            return Err(format!("`{s}`: expected sim or serial:PATH[,BAUD]"));
        };
        let (path, baud) = match rest.rsplit_once(',') {
            Some((p, b)) => (
                p,
                b.parse::<u32>()
                    .ok()
                    .filter(|b| capsule_serial::BAUD_RATES.contains(b))
                    .ok_or_else(|| {
                        format!(
                            "`{b}`: not a baud rate this driver sets ({:?})",
                            capsule_serial::BAUD_RATES
                        )
                    })?,
            ),
            None => (rest, DEFAULT_BAUD),
        };
        if path.is_empty() {
            return Err("serial: needs the line's path (serial:/dev/ttyUSB0)".into());
        }
        Ok(Source::Serial {
            path: PathBuf::from(path),
            baud,
        })
    }
}

/// What is wrong with the device now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fault {
    /// The line could not be opened or went away.
    NoLine,
    /// The line is open but no hello has come (its limits are unknown).
    NoHello,
    /// No measurement for longer than the device's command timeout.
    Silent,
    /// The newest measurement has NaN or infinity in a quantity the device measures.
    NonFinite,
    /// `|x1 - x2|` beyond the travel limit.
    OverTravel,
}

impl Fault {
    fn describe(self) -> &'static str {
        match self {
            Fault::NoLine => "no line: the device is unplugged or its path does not exist",
            Fault::NoHello => "line open, waiting for the device's hello",
            Fault::Silent => "the device stopped sending measurements",
            Fault::NonFinite => "a measurement with NaN or infinity in a measured quantity",
            Fault::OverTravel => "the mass is beyond its travel limit",
        }
    }
}

/// The driver's settings.
#[derive(Debug, Clone)]
pub struct DriverOptions {
    /// The line.
    pub path: PathBuf,
    /// Its baud rate.
    pub baud: u32,
    /// The plant's sample rate \[Hz\] (how long a silent device is given).
    pub rate_hz: f64,
    /// The node's force limit \[N\] (the device's, if smaller, is enforced over it).
    pub max_force_n: f64,
    /// The node's travel limit on `|x1 - x2|` \[m\] (the device's, if smaller, is enforced).
    pub max_travel_m: f64,
    /// The scene's gap \[m\] (contact is `x1 - x2 >= gap`).
    pub gap_m: f64,
    /// Log the commands instead of sending them (zero force goes out).
    pub dry_run: bool,
}

/// Opens the line (a serial port; a socket pair's end in tests).
pub type Opener<L> = Arc<dyn Fn() -> std::io::Result<L> + Send + Sync>;

/// The time now (the steady clock; a clock of the test's in tests).
pub type Clock = Arc<dyn Fn() -> Instant + Send + Sync>;

/// What the line's thread saw.
enum Event {
    /// The line is open (again).
    Opened,
    /// It could not be opened.
    OpenFailed(String),
    /// It went away.
    Gone(String),
    /// A frame, received at `at`.
    Frame {
        seq: u16,
        frame: Frame,
        lost: u16,
        at: Instant,
    },
    /// Bytes skipped (garbage, a failed checksum).
    Skipped(String),
}

/// The writing end and what decides the force: shared by the node's loop and the emergency
/// stop (one lock, held only to write one frame).
struct Out<L: Line> {
    link: Option<Link<L>>,
    /// The newest measurement's frame number while it is unanswered, and when it came.
    answers: Option<(u16, Instant)>,
    /// The newest measurement's frame number (what a stop frame answers).
    last_seen: u16,
    /// A fault: zero goes out.
    faulted: bool,
    /// Active (lifecycle): written forces go out; otherwise zero.
    active: bool,
    /// The force limit in force \[N\].
    limit_n: f64,
    dry_run: bool,
    dry_log: Throttle,
    /// The emergency stop's flag: zero goes out while it is set.
    stop: Arc<AtomicBool>,
    /// From a measurement's arrival to its answer's write, in this process \[s\].
    answer_latency: LatencyHistogram,
    /// Frames that could not be written (the line went away under them).
    write_errors: u64,
    /// Measurements answered with zero because no answer came before the next one.
    unanswered: u64,
}

impl<L: Line> Out<L> {
    /// Sends `force_n` (zero while faulted, inactive or stopped; saturated at the limit) as
    /// the answer to `answers`.
    fn send(&mut self, force_n: f64, answers: u16) {
        let zero = self.faulted || !self.active || self.stop.load(Ordering::SeqCst);
        let mut f = if zero {
            0.0
        } else {
            force_n.clamp(-self.limit_n, self.limit_n)
        };
        if self.dry_run {
            if f != 0.0 && self.dry_log.tick() {
                info!(
                    "dry run: would send {f} N (answering frame {answers}; {} so far)",
                    self.dry_log.seen()
                );
            }
            f = 0.0;
        }
        let frame = Frame::Force(Force {
            force_n: f as f32,
            answers,
        });
        if let Some(link) = self.link.as_mut() {
            if link.send(&frame).is_err() {
                // the line's thread sees it go and reopens it
                self.link = None;
                self.write_errors += 1;
            }
        }
    }

    /// A zero-force frame now (the emergency stop), whatever is unanswered.
    fn send_zero(&mut self) {
        let answers = self.answers.map_or(self.last_seen, |(seq, _)| seq);
        self.send(0.0, answers);
    }
}

fn lock<L: Line>(out: &Mutex<Out<L>>) -> MutexGuard<'_, Out<L>> {
    out.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The line's thread: opens it (again every [`REOPEN_EVERY`] while it fails or after it went
/// away), reads frames and hands them on, until `quit` or until the driver is gone.
fn read_line<L: Line>(
    open: Opener<L>,
    out: Arc<Mutex<Out<L>>>,
    tx: Sender<Event>,
    ready: Ready,
    quit: Arc<AtomicBool>,
) {
    let send = |e: Event| {
        let ok = tx.send(e).is_ok();
        ready.notify();
        ok
    };
    // how often `quit` is looked at while waiting
    const SLICE: Duration = Duration::from_millis(20);
    let mut link: Option<Link<L>> = None;
    let mut next_open = Instant::now();
    while !quit.load(Ordering::SeqCst) {
        let Some(l) = link.as_mut() else {
            if Instant::now() < next_open {
                std::thread::sleep(SLICE.min(next_open - Instant::now()));
                continue;
            }
            next_open = Instant::now() + REOPEN_EVERY;
            let opened = open().and_then(|f| {
                let l = Link::new(f);
                let w = l.try_clone()?;
                Ok((l, w))
            });
            let ok = match opened {
                Ok((l, w)) => {
                    lock(&out).link = Some(w);
                    link = Some(l);
                    send(Event::Opened)
                }
                Err(e) => send(Event::OpenFailed(e.to_string())),
            };
            if !ok {
                return;
            }
            continue;
        };
        let ok = match l.next(Instant::now() + SLICE) {
            Ok(Some(Decoded::Frame { seq, frame, lost })) => send(Event::Frame {
                seq,
                frame,
                lost,
                at: Instant::now(),
            }),
            Ok(Some(Decoded::Skipped(e))) => send(Event::Skipped(e.to_string())),
            Ok(None) => true,
            Err(e) => {
                link = None;
                lock(&out).link = None;
                send(Event::Gone(e.to_string()))
            }
        };
        if !ok {
            return;
        }
    }
}

/// The line's thread while configured.
struct Reader {
    events: Receiver<Event>,
    quit: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<()>,
}

/// A capsule on a serial line (or, in tests, any [`Line`]).
pub struct DeviceDriver<L: Line = File> {
    settings: DriverOptions,
    label: String,
    open: Opener<L>,
    clock: Clock,
    out: Arc<Mutex<Out<L>>>,
    ready: Ready,
    reader: Option<Reader>,
    hello: Option<Hello>,
    /// The device time of the newest sample (a re-send repeats it).
    last_t_us: Option<u32>,
    last_measured: Instant,
    fault: Option<Fault>,
    health: SourceHealth,
    opened: u64,
    measurements: u64,
    non_finite: u64,
    skipped: u64,
    lost: u64,
    skipped_log: Throttle,
    fault_log: Throttle,
    /// Whether the current fault's start was logged (then so is its end).
    fault_log_on: bool,
}

impl DeviceDriver<File> {
    /// A driver for the serial line of `settings`; the line is opened at configure.
    pub fn new(settings: DriverOptions) -> DeviceDriver<File> {
        let (path, baud) = (settings.path.clone(), settings.baud);
        let open: Opener<File> = Arc::new(move || open_line(&path, baud));
        let label = format!(
            "serial {} at {} baud{}",
            settings.path.display(),
            settings.baud,
            if settings.dry_run { ", dry run" } else { "" }
        );
        DeviceDriver::over(settings, label, open, Arc::new(Instant::now))
    }
}

impl<L: Line> DeviceDriver<L> {
    /// A driver over the lines `open` gives, labelled `label`, timed by `clock`.
    pub fn over(settings: DriverOptions, label: String, open: Opener<L>, clock: Clock) -> Self {
        let out = Out {
            link: None,
            answers: None,
            last_seen: 0,
            faulted: true,
            active: false,
            limit_n: 0.0,
            dry_run: settings.dry_run,
            dry_log: Throttle::default(),
            stop: Arc::default(),
            answer_latency: LatencyHistogram::default(),
            write_errors: 0,
            unanswered: 0,
        };
        let now = clock();
        DeviceDriver {
            settings,
            health: SourceHealth {
                label: label.clone(),
                fault: Some(Fault::NoLine.describe().to_string()),
                values: Vec::new(),
            },
            label,
            open,
            clock,
            out: Arc::new(Mutex::new(out)),
            ready: Ready::default(),
            reader: None,
            hello: None,
            last_t_us: None,
            last_measured: now,
            fault: Some(Fault::NoLine),
            opened: 0,
            measurements: 0,
            non_finite: 0,
            skipped: 0,
            lost: 0,
            skipped_log: Throttle::default(),
            fault_log: Throttle::default(),
            fault_log_on: true,
        }
    }

    /// Moves to fault `f` (or none), logging the change: the first ten, then at powers of two
    /// (a NaN every few samples must not flood the log).
    fn set_fault(&mut self, f: Option<Fault>) {
        lock(&self.out).faulted = f.is_some();
        if f == self.fault {
            return;
        }
        match (self.fault, f) {
            (_, Some(now)) => {
                self.fault_log_on = self.fault_log.tick();
                if self.fault_log_on {
                    warn!(
                        "device {}: {}: zero force ({} faults so far)",
                        self.settings.path.display(),
                        now.describe(),
                        self.fault_log.seen()
                    );
                }
            }
            (Some(was), None) if self.fault_log_on => info!(
                "device {}: recovered ({} no more)",
                self.settings.path.display(),
                was.describe()
            ),
            _ => {}
        }
        self.fault = f;
    }

    /// The force limit in force: the smaller of the node's and the device's.
    fn max_force_n(&self) -> f64 {
        let device = self.hello.map_or(0.0, |h| f64::from(h.max_force_n));
        self.settings.max_force_n.min(device)
    }

    fn max_travel_m(&self) -> f64 {
        let device = self.hello.map_or(0.0, |h| f64::from(h.max_travel_m));
        self.settings.max_travel_m.min(device)
    }

    fn on_hello(&mut self, h: Hello) {
        if self.hello != Some(h) {
            info!(
                "device hello: protocol {}, measures {:#07b}, {} Hz, force limit {} N, travel {} m, \
                 timeout {} s",
                h.version,
                h.measured,
                h.sample_rate_hz,
                h.max_force_n,
                h.max_travel_m,
                h.command_timeout_s
            );
            let (node_f, node_t) = (self.settings.max_force_n, self.settings.max_travel_m);
            if f64::from(h.max_force_n) > node_f || !h.max_force_n.is_finite() {
                warn!(
                    "the device allows {} N, beyond the node's limit {node_f} N: the node's stands",
                    h.max_force_n
                );
            }
            if f64::from(h.max_travel_m) > node_t || !h.max_travel_m.is_finite() {
                warn!(
                    "the device allows a travel of {} m, beyond the node's {node_t} m: the node's stands",
                    h.max_travel_m
                );
            }
        }
        let valid = h.max_force_n > 0.0 && h.max_travel_m > 0.0;
        self.hello = valid.then_some(h);
        let limit = self.max_force_n();
        lock(&self.out).limit_n = if limit.is_finite() { limit } else { 0.0 };
        if self.fault == Some(Fault::NoHello) && valid {
            self.set_fault(None);
        }
    }

    /// A measurement: a new sample, a fault to answer with zero, or `None` for a re-send.
    fn on_measurement(
        &mut self,
        seq: u16,
        m: Measurement,
        at: Instant,
    ) -> Option<Result<Reading, HardwareError>> {
        self.last_measured = (self.clock)();
        let resend = self.last_t_us == Some(m.t_us);
        {
            let mut out = lock(&self.out);
            out.last_seen = seq;
            match out.answers {
                // a re-send of a sample not yet answered: the answer names the newest frame
                Some((_, first)) if resend => out.answers = Some((seq, first)),
                // a re-send of a sample answered already
                None if resend => {}
                // a new sample while the one before is unanswered: zero for that one, now
                Some((before, _)) => {
                    out.send(0.0, before);
                    out.unanswered += 1;
                    out.answers = Some((seq, at));
                }
                None => out.answers = Some((seq, at)),
            }
        }
        if resend {
            return None;
        }
        self.last_t_us = Some(m.t_us);
        if self.fault == Some(Fault::Silent) {
            self.set_fault(None);
        }
        let bits = self.hello.map_or(0, |h| h.measured);
        let needed = [
            (measured::RELATIVE_DISPLACEMENT, m.relative_m),
            (measured::CAPSULE_POSITION, m.capsule_m),
            (measured::MASS_VELOCITY, m.mass_velocity),
            (measured::CAPSULE_VELOCITY, m.capsule_velocity),
        ];
        if needed
            .iter()
            .any(|(bit, v)| bits & bit != 0 && !v.is_finite())
        {
            self.non_finite += 1;
            self.set_fault(Some(Fault::NonFinite));
            return Some(Ok(Reading::Fault(Fault::NonFinite.describe().into())));
        }
        self.measurements += 1;
        let rel = f64::from(m.relative_m);
        let x2 = f64::from(m.capsule_m);
        let in_contact = if m.flags & 1 != 0 {
            m.flags & 2 != 0
        } else {
            rel >= self.settings.gap_m
        };
        let over = rel.abs() > self.max_travel_m();
        self.set_fault(over.then_some(Fault::OverTravel));
        let sample = Sample {
            mass_position: rel + x2,
            mass_velocity: f64::from(m.mass_velocity),
            capsule_position: x2,
            capsule_velocity: f64::from(m.capsule_velocity),
            in_contact,
            friction_force: f64::NAN,
            contact_force: f64::NAN,
            actuator_force: f64::from(m.applied_force_n),
            ..Sample::default()
        };
        // beyond the travel the sample is still the truth: published, answered with zero
        Some(Ok(Reading::Sample(sample)))
    }

    /// One event from the line's thread; `Some` when it is what `read` returns.
    fn on_event(&mut self, e: Event) -> Option<Result<Reading, HardwareError>> {
        match e {
            Event::Opened => {
                info!("device line {} open", self.settings.path.display());
                self.hello = None;
                self.last_t_us = None;
                self.last_measured = (self.clock)();
                self.opened += 1;
                lock(&self.out).answers = None;
                self.set_fault(Some(Fault::NoHello));
            }
            Event::OpenFailed(e) => {
                if self.fault != Some(Fault::NoLine) {
                    warn!("device line {}: {e}", self.settings.path.display());
                }
                self.set_fault(Some(Fault::NoLine));
            }
            Event::Gone(e) => {
                warn!("device line {}: {e}", self.settings.path.display());
                self.hello = None;
                lock(&self.out).answers = None;
                self.set_fault(Some(Fault::NoLine));
            }
            Event::Skipped(e) => self.count_skipped(&e),
            Event::Frame {
                seq,
                frame,
                lost,
                at,
            } => {
                self.lost += u64::from(lost);
                match frame {
                    Frame::Hello(h) => self.on_hello(h),
                    Frame::Measurement(m) if self.hello.is_some() => {
                        return self.on_measurement(seq, m, at)
                    }
                    // a measurement before the hello: its limits are unknown
                    Frame::Measurement(_) => {}
                    Frame::Force(_) => self.count_skipped("a force frame from the device"),
                }
            }
        }
        None
    }

    fn count_skipped(&mut self, what: &str) {
        self.skipped += 1;
        if self.skipped_log.tick() {
            warn!(
                "device {}: skipped {what} ({} so far)",
                self.settings.path.display(),
                self.skipped
            );
        }
    }

    /// Silent: no measurement for longer than the device's command timeout (at least two
    /// sample periods).
    fn check_silence(&mut self) {
        let Some(h) = self.hello else { return };
        if self.fault.is_some() && self.fault != Some(Fault::Silent) {
            return;
        }
        let timeout = f64::from(h.command_timeout_s).max(2.0 / self.settings.rate_hz);
        let quiet = ((self.clock)() - self.last_measured).as_secs_f64();
        if quiet > timeout {
            self.set_fault(Some(Fault::Silent));
        }
    }

    fn refresh_health(&mut self) {
        let (line, latency, write_errors, unanswered) = {
            let out = lock(&self.out);
            (
                out.link.is_some(),
                out.answer_latency.clone(),
                out.write_errors,
                out.unanswered,
            )
        };
        let ms = |q: Option<f64>| q.map_or("none".into(), |s| format!("{:.3}", s * 1e3));
        let values = vec![
            ("device_line", if line { "open" } else { "closed" }.into()),
            ("device_force_limit_n", format!("{}", self.max_force_n())),
            ("device_travel_limit_m", format!("{}", self.max_travel_m())),
            (
                "device_measures",
                self.hello
                    .map_or("unknown".into(), |h| format!("{:#07b}", h.measured)),
            ),
            ("device_measurements", self.measurements.to_string()),
            ("device_faults", self.fault_log.seen().to_string()),
            ("device_non_finite", self.non_finite.to_string()),
            ("device_skipped", self.skipped.to_string()),
            ("device_frames_lost", self.lost.to_string()),
            ("device_opened", self.opened.to_string()),
            ("device_write_errors", write_errors.to_string()),
            ("device_unanswered", unanswered.to_string()),
            ("device_answer_p50_ms", ms(latency.quantile(0.5))),
            ("device_answer_p99_ms", ms(latency.quantile(0.99))),
            ("device_answer_max_ms", ms(latency.max())),
        ];
        self.health.fault = self.fault.map(|f| f.describe().to_string());
        self.health.values = values;
    }
}

impl<L: Line> CapsuleHardware for DeviceDriver<L> {
    fn label(&self) -> String {
        self.label.clone()
    }

    /// Opens the line (an error names it) and starts its thread.
    fn configure(&mut self) -> Result<(), HardwareError> {
        if self.reader.is_some() {
            return Ok(());
        }
        // the first open here, so that a line that cannot be opened fails the configure
        let first = (self.open)().map_err(|e| HardwareError::Open {
            device: self.label.clone(),
            reason: e.to_string(),
        })?;
        drop(first);
        let (tx, events) = mpsc::channel();
        let quit = Arc::new(AtomicBool::new(false));
        let (open, out, ready, q) = (
            self.open.clone(),
            self.out.clone(),
            self.ready.clone(),
            quit.clone(),
        );
        let thread = std::thread::Builder::new()
            .name("capsule_device".into())
            .spawn(move || read_line(open, out, tx, ready, q))
            .map_err(|e| HardwareError::Open {
                device: self.label.clone(),
                reason: format!("cannot start its thread: {e}"),
            })?;
        self.reader = Some(Reader {
            events,
            quit,
            thread,
        });
        self.hello = None;
        self.last_t_us = None;
        self.set_fault(Some(Fault::NoLine));
        self.refresh_health();
        Ok(())
    }

    fn activate(&mut self) -> Result<(), HardwareError> {
        lock(&self.out).active = true;
        Ok(())
    }

    fn deactivate(&mut self) -> Result<(), HardwareError> {
        lock(&self.out).active = false;
        Ok(())
    }

    /// Stops the line's thread (within 20 ms) and closes the line, after a last zero.
    fn cleanup(&mut self) -> Result<(), HardwareError> {
        let Some(r) = self.reader.take() else {
            return Ok(());
        };
        r.quit.store(true, Ordering::SeqCst);
        {
            let mut out = lock(&self.out);
            out.active = false;
            out.send_zero();
            out.link = None;
            out.answers = None;
        }
        drop(r.events);
        let _ = r.thread.join();
        self.hello = None;
        self.set_fault(Some(Fault::NoLine));
        self.refresh_health();
        Ok(())
    }

    fn read(&mut self, deadline: Instant) -> Result<Reading, HardwareError> {
        loop {
            let Some(r) = self.reader.as_ref() else {
                return Err(HardwareError::State(format!(
                    "{}: not configured",
                    self.label
                )));
            };
            let left = deadline.saturating_duration_since(Instant::now());
            let event = match r.events.recv_timeout(left) {
                Ok(e) => e,
                Err(RecvTimeoutError::Timeout) => {
                    self.check_silence();
                    self.refresh_health();
                    return Ok(Reading::Timeout);
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(HardwareError::State(format!(
                        "{}: the line's thread ended",
                        self.label
                    )))
                }
            };
            if let Some(reading) = self.on_event(event) {
                self.refresh_health();
                return reading;
            }
        }
    }

    /// Sends `force_n` answering the newest measurement (nothing if it was answered).
    fn write(&mut self, force_n: f64) -> Result<(), HardwareError> {
        let mut out = lock(&self.out);
        if let Some((seq, at)) = out.answers.take() {
            out.send(force_n, seq);
            out.answer_latency.record(at.elapsed().as_secs_f64());
        }
        Ok(())
    }

    fn ready(&self) -> Option<Ready> {
        Some(self.ready.clone())
    }

    fn zero_while(&mut self, engaged: Arc<AtomicBool>) {
        lock(&self.out).stop = engaged;
    }

    fn stopper(&self) -> Option<Stopper> {
        let out = self.out.clone();
        Some(Arc::new(move || lock(&out).send_zero()))
    }

    fn health(&self) -> Option<&SourceHealth> {
        Some(&self.health)
    }
}

impl<L: Line> Drop for DeviceDriver<L> {
    fn drop(&mut self) {
        let _ = self.cleanup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::net::UnixStream;

    /// The device's end of a socket pair, and what the driver sends it.
    struct Device {
        link: Link<UnixStream>,
    }

    impl Device {
        fn send(&mut self, f: Frame) -> u16 {
            self.link
                .send(&f)
                .unwrap_or_else(|e| panic!("device send: {e}"))
        }

        fn hello(&mut self, max_force_n: f32, max_travel_m: f32) {
            self.send(Frame::Hello(Hello {
                version: capsule_device::frame::VERSION,
                measured: measured::RELATIVE_DISPLACEMENT | measured::CAPSULE_POSITION,
                max_force_n,
                max_travel_m,
                sample_rate_hz: 1000.0,
                command_timeout_s: 0.1,
            }));
        }

        fn measure(&mut self, t_us: u32, relative_m: f32) -> u16 {
            self.send(Frame::Measurement(Measurement {
                t_us,
                relative_m,
                capsule_m: 0.25,
                mass_velocity: f32::NAN,
                capsule_velocity: f32::NAN,
                applied_force_n: 0.0,
                flags: 0,
            }))
        }

        /// The force frames the driver sent within `wait`.
        fn forces(&mut self, wait: Duration) -> Vec<Force> {
            let until = Instant::now() + wait;
            let mut got = Vec::new();
            while let Ok(Some(d)) = self.link.next(until) {
                if let Decoded::Frame {
                    frame: Frame::Force(f),
                    ..
                } = d
                {
                    got.push(f);
                }
            }
            got
        }
    }

    fn pair() -> (UnixStream, Device) {
        let (a, b) = UnixStream::pair().unwrap_or_else(|e| panic!("socketpair: {e}"));
        for s in [&a, &b] {
            s.set_nonblocking(true)
                .unwrap_or_else(|e| panic!("non-blocking: {e}"));
        }
        (a, Device { link: Link::new(b) })
    }

    /// A test clock: `now()` is the steady clock plus what the test added.
    #[derive(Clone, Default)]
    struct TestClock(Arc<Mutex<Duration>>);

    impl TestClock {
        fn clock(&self) -> Clock {
            let skew = self.0.clone();
            Arc::new(move || Instant::now() + *skew.lock().unwrap_or_else(|e| e.into_inner()))
        }
        fn advance(&self, by: Duration) {
            *self.0.lock().unwrap_or_else(|e| e.into_inner()) += by;
        }
    }

    fn options(dry_run: bool) -> DriverOptions {
        DriverOptions {
            path: "/test/line".into(),
            baud: DEFAULT_BAUD,
            rate_hz: 1000.0,
            max_force_n: 0.5,
            max_travel_m: 0.02,
            gap_m: 0.01,
            dry_run,
        }
    }

    /// A configured, active driver over socket pairs (a new pair at every open, as a cable
    /// plugged in again), the device's first end, and the test clock.
    fn driver(dry_run: bool) -> (DeviceDriver<UnixStream>, Receiver<Device>, TestClock) {
        let (devices_tx, devices) = mpsc::channel();
        let devices_tx = Mutex::new(devices_tx);
        let open: Opener<UnixStream> = Arc::new(move || {
            let (ours, theirs) = pair();
            let _ = lock_sender(&devices_tx).send(theirs);
            Ok(ours)
        });
        let clock = TestClock::default();
        let mut d = DeviceDriver::over(options(dry_run), "test line".into(), open, clock.clock());
        assert!(d.configure().is_ok() && d.activate().is_ok());
        // configure opens once to check the line, and the line's thread opens it again
        let _checked = devices.recv_timeout(Duration::from_secs(2));
        (d, devices, clock)
    }

    fn lock_sender<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
        m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn device(devices: &Receiver<Device>) -> Device {
        devices
            .recv_timeout(Duration::from_secs(2))
            .unwrap_or_else(|e| panic!("the driver did not open the line: {e}"))
    }

    /// Reads until something other than a timeout comes (2 s at most).
    fn next(d: &mut DeviceDriver<UnixStream>) -> Reading {
        let until = Instant::now() + Duration::from_secs(2);
        loop {
            match d.read(Instant::now() + Duration::from_millis(20)) {
                Ok(Reading::Timeout) if Instant::now() < until => {}
                Ok(r) => return r,
                Err(e) => panic!("{e}"),
            }
        }
    }

    fn value<'a>(d: &'a DeviceDriver<UnixStream>, key: &str) -> &'a str {
        d.health()
            .and_then(|h| h.values.iter().find(|(k, _)| *k == key))
            .map_or("", |(_, v)| v.as_str())
    }

    fn fault(d: &DeviceDriver<UnixStream>) -> Option<String> {
        d.health().and_then(|h| h.fault.clone())
    }

    const SOON: Duration = Duration::from_millis(100);

    #[test]
    fn without_a_hello_nothing_is_a_sample_and_the_stop_still_reaches_the_device() {
        let (mut d, devices, _) = driver(false);
        let mut dev = device(&devices);
        // a measurement before the hello: its limits are unknown, it is no sample
        dev.measure(1, 0.001);
        assert_eq!(d.read(Instant::now() + SOON).ok(), Some(Reading::Timeout));
        assert_eq!(
            fault(&d).as_deref(),
            Some("line open, waiting for the device's hello")
        );
        // the emergency stop's zero goes out at once, with nothing to answer
        let stop = d
            .stopper()
            .unwrap_or_else(|| panic!("a device has a stopper"));
        stop();
        let f = dev.forces(SOON);
        assert_eq!(f.len(), 1, "{f:?}");
        assert_eq!(f[0].force_n, 0.0);
    }

    #[test]
    fn measurements_are_si_samples_and_forces_go_out_at_once_within_the_node_s_limits() {
        let (mut d, devices, _) = driver(false);
        let mut dev = device(&devices);
        // the device allows 10 N and 1 m: the node's 0.5 N and 0.02 m stand
        dev.hello(10.0, 1.0);
        let seq = dev.measure(1000, 0.005);
        let Reading::Sample(s) = next(&mut d) else {
            panic!("no sample")
        };
        assert!((s.capsule_position - 0.25).abs() < 1e-9);
        assert!((s.mass_position - 0.255).abs() < 1e-7);
        assert!(s.mass_velocity.is_nan(), "not measured");
        assert!(!s.in_contact, "x1 - x2 below the gap");
        assert_eq!(value(&d, "device_force_limit_n"), "0.5");
        assert!(d.write(3.0).is_ok());
        assert!(d.write(0.1).is_ok(), "a second write answers nothing");
        let f = dev.forces(SOON);
        assert_eq!(f.len(), 1, "{f:?}");
        assert_eq!((f[0].force_n, f[0].answers), (0.5, seq));
        // deactivated: zero from the next sample on
        assert!(d.deactivate().is_ok());
        dev.measure(2000, 0.005);
        assert!(matches!(next(&mut d), Reading::Sample(_)));
        assert!(d.write(0.3).is_ok());
        assert_eq!(dev.forces(SOON)[0].force_n, 0.0);
    }

    #[test]
    fn nan_over_travel_garbage_and_unanswered_samples_are_answered_with_zero() {
        let (mut d, devices, _) = driver(false);
        let mut dev = device(&devices);
        dev.hello(10.0, 1.0);
        // NaN in a measured quantity: a fault, answered with zero
        dev.measure(1000, f32::NAN);
        assert!(matches!(next(&mut d), Reading::Fault(_)));
        assert!(d.write(0.4).is_ok());
        assert_eq!(dev.forces(SOON)[0].force_n, 0.0);
        assert_eq!(value(&d, "device_non_finite"), "1");
        // beyond the node's travel of 0.02 m: a sample (the truth), answered with zero
        dev.measure(2000, 0.03);
        assert!(matches!(next(&mut d), Reading::Sample(_)));
        assert_eq!(
            fault(&d).as_deref(),
            Some("the mass is beyond its travel limit")
        );
        assert!(d.write(0.4).is_ok());
        assert_eq!(dev.forces(SOON)[0].force_n, 0.0);
        // garbage is skipped and counted; the frame after it is found
        assert!(dev.link.write_bytes(&[0x00, 0xCA, 0x13, 0x37]).is_ok());
        let first = dev.measure(3000, 0.001);
        assert!(matches!(next(&mut d), Reading::Sample(_)));
        assert_eq!(fault(&d), None, "recovered");
        assert_ne!(value(&d, "device_skipped"), "0");
        // no answer before the next measurement: the driver answers the first with zero
        let second = dev.measure(4000, 0.001);
        assert!(matches!(next(&mut d), Reading::Sample(_)));
        assert!(d.write(0.2).is_ok());
        let f = dev.forces(SOON);
        assert_eq!(
            f.iter().map(|f| (f.answers, f.force_n)).collect::<Vec<_>>(),
            [(first, 0.0), (second, 0.2)]
        );
        assert_eq!(value(&d, "device_unanswered"), "1");
        // a re-send (the same device time) is no new sample
        dev.measure(4000, 0.001);
        assert_eq!(d.read(Instant::now() + SOON).ok(), Some(Reading::Timeout));
    }

    /// A driver whose device has said hello and sent a first measurement, taken.
    fn measuring(dry_run: bool) -> (DeviceDriver<UnixStream>, Device, TestClock) {
        let (mut d, devices, clock) = driver(dry_run);
        let mut dev = device(&devices);
        dev.hello(10.0, 1.0);
        dev.measure(1000, 0.001);
        assert!(matches!(next(&mut d), Reading::Sample(_)));
        (d, dev, clock)
    }

    #[test]
    fn a_silent_device_is_named_on_the_test_clock_and_recovers() {
        let (mut d, mut dev, clock) = measuring(false);
        assert_eq!(
            d.read(Instant::now() + Duration::from_millis(5)).ok(),
            Some(Reading::Timeout)
        );
        assert_eq!(fault(&d), None, "0.1 s of silence have not passed");
        clock.advance(Duration::from_millis(150));
        assert_eq!(
            d.read(Instant::now() + Duration::from_millis(5)).ok(),
            Some(Reading::Timeout)
        );
        assert_eq!(
            fault(&d).as_deref(),
            Some("the device stopped sending measurements")
        );
        dev.measure(2000, 0.001);
        assert!(matches!(next(&mut d), Reading::Sample(_)));
        assert_eq!(fault(&d), None);
    }

    #[test]
    fn a_line_that_goes_away_is_reopened_and_the_device_is_back_after_its_hello() {
        let (mut d, devices, _) = driver(false);
        let dev = device(&devices);
        drop(dev);
        // the line's thread sees it go, and opens a new one within half a second
        let mut dev = device(&devices);
        let until = Instant::now() + Duration::from_secs(2);
        while value(&d, "device_opened") != "2" && Instant::now() < until {
            let _ = d.read(Instant::now() + Duration::from_millis(20));
        }
        assert_eq!(value(&d, "device_opened"), "2");
        dev.hello(10.0, 1.0);
        dev.measure(1000, 0.001);
        assert!(matches!(next(&mut d), Reading::Sample(_)));
        assert_eq!(fault(&d), None);
        assert!(d.cleanup().is_ok());
        assert!(d.read(Instant::now()).is_err(), "closed after a cleanup");
    }

    #[test]
    fn a_dry_run_and_an_engaged_stop_send_zero() {
        let (mut d, mut dev, _) = measuring(true);
        assert!(d.write(0.4).is_ok());
        assert_eq!(dev.forces(SOON)[0].force_n, 0.0, "dry run");
        let (mut d, mut dev, _) = measuring(false);
        let stop = Arc::new(AtomicBool::new(false));
        d.zero_while(stop.clone());
        stop.store(true, Ordering::SeqCst);
        assert!(d.write(0.4).is_ok());
        assert_eq!(dev.forces(SOON)[0].force_n, 0.0, "stopped");
    }

    #[test]
    fn a_configure_that_cannot_open_names_the_line() {
        let mut d = DeviceDriver::new(DriverOptions {
            path: "/nonexistent/capsule0".into(),
            ..options(false)
        });
        let e = d
            .configure()
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.starts_with("cannot open serial /nonexistent/capsule0 at 921600 baud: "),
            "{e}"
        );
    }

    #[test]
    fn sources_parse_and_bad_ones_are_named() {
        assert_eq!("sim".parse(), Ok(Source::Sim));
        assert_eq!(
            "serial:/dev/ttyUSB0".parse(),
            Ok(Source::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: DEFAULT_BAUD
            })
        );
        assert_eq!(
            "serial:/tmp/a,b,115200".parse(),
            Ok(Source::Serial {
                path: "/tmp/a,b".into(),
                baud: 115_200
            })
        );
        let e = "serial:/dev/ttyUSB0,12345".parse::<Source>().err();
        assert!(e.is_some_and(|e| e.contains("`12345`: not a baud rate")));
        assert!("udp:1".parse::<Source>().is_err());
        assert!("serial:".parse::<Source>().is_err());
    }
}
