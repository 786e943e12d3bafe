//! The plant's hardware driver: a [`PlantSim`] that is a real capsule (or the device emulator)
//! on a serial line, speaking the protocol of `capsule_device`. Each step sends the force
//! answering the newest measurement and waits for the next one; the node around it publishes,
//! gates commands and records exactly as for the simulator.
//!
//! Faults never stop the node: a line that goes away (a cable pulled, the emulator ended) is
//! reopened every half second; a device that stops sending, a measurement with NaN in a
//! measured field, or a mass beyond its travel all zero the force (a NaN or over-travel sample
//! is answered with zero; a silent or lost device zeroes its own force after its command
//! timeout) and are named in `/diagnostics`, the log (once per change) and the summary. Frames
//! that fail their checksum and garbage are skipped and counted.
//!
//! What the device does not measure is published as NaN (velocities, friction and contact
//! forces); `in_contact` is derived from the measured `x1 - x2` and the scene's gap; `stuck` is
//! not measured and is false.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use capsule_device::{frame::measured, Decoded, Force, Frame, Hello, Measurement};
use capsule_plant::scene::PhysicalScale;
use capsule_plant::{Snapshot, State};
use capsule_ros_base::error::Result;
use capsule_ros_base::throttle::Throttle;
use capsule_serial::{open_line, Link};
use tracing::{info, warn};

use crate::plant::{PlantSim, SourceHealth};

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

/// What is wrong with the device now; the force is zero while it lasts.
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
    /// The plant's sample rate \[Hz\] (how long to wait for a measurement).
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

/// A capsule on a serial line.
pub struct DeviceDriver {
    settings: DriverOptions,
    scale: PhysicalScale,
    link: Option<Link>,
    next_open: Instant,
    hello: Option<Hello>,
    last: Snapshot,
    /// The newest measurement's frame number while it is unanswered.
    unanswered: Option<u16>,
    last_measured: Instant,
    fault: Option<Fault>,
    health: SourceHealth,
    measurements: u64,
    non_finite: u64,
    skipped: u64,
    lost: u64,
    reconnects: u64,
    skipped_log: Throttle,
    dry_log: Throttle,
    fault_log: Throttle,
    /// Whether the current fault's start was logged (then so is its end).
    fault_log_on: bool,
}

impl DeviceDriver {
    /// A driver for the line of `settings` at `scale`; the line is opened on the first step.
    pub fn new(settings: DriverOptions, scale: PhysicalScale) -> DeviceDriver {
        let nan = f64::NAN;
        let label = format!(
            "serial {} at {} baud{}",
            settings.path.display(),
            settings.baud,
            if settings.dry_run { ", dry run" } else { "" }
        );
        DeviceDriver {
            settings,
            scale,
            link: None,
            next_open: Instant::now(),
            hello: None,
            last: Snapshot {
                tau: 0.0,
                state: State {
                    x1: nan,
                    y1: nan,
                    x2: nan,
                    y2: nan,
                },
                stuck: false,
                contact: false,
                friction_force: nan,
                contact_force: nan,
                actuator_force: nan,
            },
            unanswered: None,
            last_measured: Instant::now(),
            fault: Some(Fault::NoLine),
            health: SourceHealth {
                label,
                fault: Some(Fault::NoLine.describe().to_string()),
                values: Vec::new(),
            },
            measurements: 0,
            non_finite: 0,
            skipped: 0,
            lost: 0,
            reconnects: 0,
            skipped_log: Throttle::default(),
            dry_log: Throttle::default(),
            fault_log: Throttle::default(),
            fault_log_on: true,
        }
    }

    /// Moves to fault `f` (or none), logging the change: the first ten, then at powers of two
    /// (a NaN every few samples must not flood the log).
    fn set_fault(&mut self, f: Option<Fault>) {
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

    fn open(&mut self) {
        if Instant::now() < self.next_open {
            return;
        }
        self.next_open = Instant::now() + REOPEN_EVERY;
        match open_line(&self.settings.path, self.settings.baud) {
            Ok(file) => {
                info!("device line {} open", self.settings.path.display());
                self.link = Some(Link::new(file));
                self.hello = None;
                self.unanswered = None;
                self.last_measured = Instant::now();
                self.reconnects += 1;
                self.set_fault(Some(Fault::NoHello));
            }
            Err(e) => {
                if self.fault != Some(Fault::NoLine) {
                    warn!("device line {}: {e}", self.settings.path.display());
                }
                self.set_fault(Some(Fault::NoLine));
            }
        }
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
        if self.fault == Some(Fault::NoHello) && valid {
            self.set_fault(None);
        }
    }

    fn on_measurement(&mut self, seq: u16, m: Measurement, tau: f64) {
        self.unanswered = Some(seq);
        self.last_measured = Instant::now();
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
            return;
        }
        self.measurements += 1;
        let (l, v, f) = (
            self.scale.length_m(),
            self.scale.velocity_m_per_s(),
            self.scale.force_n(),
        );
        let rel = f64::from(m.relative_m);
        let x2 = f64::from(m.capsule_m);
        let contact = if m.flags & 1 != 0 {
            m.flags & 2 != 0
        } else {
            rel >= self.settings.gap_m
        };
        self.last = Snapshot {
            tau,
            state: State {
                x1: (rel + x2) / l,
                y1: f64::from(m.mass_velocity) / v,
                x2: x2 / l,
                y2: f64::from(m.capsule_velocity) / v,
            },
            stuck: false,
            contact,
            friction_force: f64::NAN,
            contact_force: f64::NAN,
            actuator_force: f64::from(m.applied_force_n) / f,
        };
        let over = rel.abs() > self.max_travel_m();
        self.set_fault(over.then_some(Fault::OverTravel));
    }

    /// Takes what arrives until `deadline`, then whatever else is already there; true if a
    /// measurement came.
    fn receive(&mut self, deadline: Instant, tau: f64) -> bool {
        let mut got = false;
        loop {
            let until = if got { Instant::now() } else { deadline };
            let Some(link) = self.link.as_mut() else {
                return got;
            };
            match link.next(until) {
                Ok(Some(Decoded::Frame { seq, frame, lost })) => {
                    self.lost += u64::from(lost);
                    match frame {
                        Frame::Hello(h) => self.on_hello(h),
                        Frame::Measurement(m) if self.hello.is_some() => {
                            self.on_measurement(seq, m, tau);
                            got = true;
                        }
                        // a measurement before the hello: its limits are unknown
                        Frame::Measurement(_) => {}
                        Frame::Force(_) => self.count_skipped("a force frame from the device"),
                    }
                }
                Ok(Some(Decoded::Skipped(e))) => self.count_skipped(&e.to_string()),
                Ok(None) => return got,
                Err(e) => {
                    warn!("device line {}: {e}", self.settings.path.display());
                    self.link = None;
                    self.hello = None;
                    self.unanswered = None;
                    self.set_fault(Some(Fault::NoLine));
                    return got;
                }
            }
        }
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

    fn send_force(&mut self, force_n: f64) {
        let Some(answers) = self.unanswered.take() else {
            return;
        };
        let zero = self.fault.is_some();
        let limit = self.max_force_n();
        let mut f = if zero {
            0.0
        } else {
            force_n.clamp(-limit, limit)
        };
        if self.settings.dry_run {
            if self.dry_log.tick() {
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
            if let Err(e) = link.send(&frame) {
                warn!("device line {}: {e}", self.settings.path.display());
                self.link = None;
                self.set_fault(Some(Fault::NoLine));
            }
        }
    }

    fn refresh_health(&mut self) {
        let hello = self.hello;
        let values = vec![
            (
                "device_line",
                if self.link.is_some() {
                    "open"
                } else {
                    "closed"
                }
                .into(),
            ),
            ("device_force_limit_n", format!("{}", self.max_force_n())),
            ("device_travel_limit_m", format!("{}", self.max_travel_m())),
            (
                "device_measures",
                hello.map_or("unknown".into(), |h| format!("{:#07b}", h.measured)),
            ),
            ("device_measurements", self.measurements.to_string()),
            ("device_faults", self.fault_log.seen().to_string()),
            ("device_non_finite", self.non_finite.to_string()),
            ("device_skipped", self.skipped.to_string()),
            ("device_frames_lost", self.lost.to_string()),
            ("device_opened", self.reconnects.to_string()),
        ];
        self.health.fault = self.fault.map(|f| f.describe().to_string());
        self.health.values = values;
    }
}

impl PlantSim for DeviceDriver {
    fn advance(&mut self, force: f64, tau_end: f64) -> Result<()> {
        if self.link.is_none() {
            self.open();
        }
        self.send_force(force * self.scale.force_n());
        // the next measurement comes within a sample period; allow two and a few ms, but do not
        // wait on a device that has gone silent (the loop would fall behind its rate)
        let wait = if self.fault == Some(Fault::Silent) {
            Duration::ZERO
        } else {
            Duration::from_secs_f64(2.0 / self.settings.rate_hz) + Duration::from_millis(5)
        };
        let got = self.link.is_some() && self.receive(Instant::now() + wait, tau_end);
        if !got && self.link.is_some() && self.hello.is_some() {
            let timeout = self.hello.map_or(0.1, |h| {
                f64::from(h.command_timeout_s).max(2.0 / self.settings.rate_hz)
            });
            if self.last_measured.elapsed().as_secs_f64() > timeout {
                self.set_fault(Some(Fault::Silent));
            }
        } else if got && self.fault == Some(Fault::Silent) {
            self.set_fault(None);
        }
        self.last.tau = tau_end;
        self.refresh_health();
        Ok(())
    }

    fn sample(&self) -> Snapshot {
        self.last
    }

    fn start(&mut self, timeout: Duration) {
        let until = Instant::now() + timeout;
        while Instant::now() < until {
            if self.link.is_none() {
                self.open();
            }
            let step = (Instant::now() + REOPEN_EVERY).min(until);
            if self.link.is_some() && self.receive(step, 0.0) && self.fault.is_none() {
                info!("device ready: first measurement taken");
                self.refresh_health();
                return;
            }
            if self.link.is_none() {
                std::thread::sleep(step.saturating_duration_since(Instant::now()));
            }
        }
        warn!(
            "no measurement from the device on {} within {:?}: starting without (zero force until one comes)",
            self.settings.path.display(),
            timeout
        );
        self.refresh_health();
    }

    fn health(&self) -> Option<&SourceHealth> {
        Some(&self.health)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
