//! `capsule emulate-device`: a prototype on a pseudo-terminal. The scene's capsule, simulated
//! exactly, behind its `[device]` sensor and actuator models (or a typical device), speaking the
//! device protocol of `capsule_device` as a microcontroller would: a hello, then a measurement
//! per sample, the commanded force held until the next force frame, zero force after the
//! device's command timeout. The plant node's serial driver opens the printed path (or the
//! `--link`) as it would open `/dev/ttyUSB0`. Faults can be injected to rehearse them.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _, Result};
use capsule_args::{ranges, scene_file::SceneFile};
use capsule_device::{frame::VERSION, Decoded, Frame, Hello, Measurement};
use capsule_plant::device::prototype::Prototype;
use capsule_plant::device::sensor::Reading;
use capsule_plant::Simulator;
use capsule_serial::{open_pty, Link, LinkError};
use tracing::{info, warn};

use crate::Refused;

/// How the emulated device paces its samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Pacing {
    /// One sample per `1/rate` of wall time, as a microcontroller's timer gives them.
    Realtime,
    /// Each sample waits for the force frame answering it (re-sent every 50 ms until then):
    /// reproducible runs as fast as the loop allows, for tests and CI.
    Lockstep,
}

/// `capsule emulate-device`'s arguments.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene TOML: the capsule, its [physical] scale, node.rate_hz as the sample rate, and the
    /// [device] table (sensor, actuator, limits; a typical device when absent)
    #[arg(long)]
    scene: PathBuf,
    /// Also make PATH a symbolic link to the pseudo-terminal (replaced if it is one; removed at
    /// the end), so that a driver can be started with a fixed path
    #[arg(long, value_name = "PATH")]
    link: Option<PathBuf>,
    /// realtime: a sample per 1/rate of wall time; lockstep: each sample waits for its answer
    #[arg(long, value_enum, default_value = "realtime")]
    pacing: Pacing,
    /// Sample rate [Hz], 1e-3 to 1e6 (overrides the scene's node.rate_hz)
    #[arg(long, value_parser = ranges::within(ranges::RATE_HZ.0, ranges::RATE_HZ.1))]
    rate_hz: Option<f64>,
    /// Stop at this device time [s], (0, 1e9] (default: until Ctrl-C)
    #[arg(long, value_parser = ranges::positive(1e9))]
    until_s: Option<f64>,
    /// Fault: after every N-th measurement, write 7 bytes that are no frame, 1 to 1e9
    #[arg(long, value_name = "N", value_parser = ranges::count(1, 1_000_000_000))]
    garbage_every: Option<u64>,
    /// Fault: every N-th measurement frame has a byte flipped (its checksum fails), 1 to 1e9
    #[arg(long, value_name = "N", value_parser = ranges::count(1, 1_000_000_000))]
    corrupt_every: Option<u64>,
    /// Fault: every N-th measurement carries NaN as x1 - x2, 1 to 1e9
    #[arg(long, value_name = "N", value_parser = ranges::count(1, 1_000_000_000))]
    nan_every: Option<u64>,
    /// Fault: stop sending anything from this device time on [s] (the capsule runs on)
    #[arg(long, value_name = "S", value_parser = ranges::positive(1e9))]
    silent_after_s: Option<f64>,
    /// Fault: close the line at this device time [s] and exit (a cable pulled)
    #[arg(long, value_name = "S", value_parser = ranges::positive(1e9))]
    unplug_after_s: Option<f64>,
    /// Write every force frame received to this CSV file (wall clock [ns since the epoch],
    /// force [N], the frame it answers, microseconds since that measurement went out): what
    /// the device saw, and when (docs/hardware.md measures the emergency stop with it)
    #[arg(long, value_name = "FILE")]
    force_log: Option<PathBuf>,
}

/// Command-to-device latency as the device sees it: from sending a measurement to receiving
/// the force frame that answers it, in microseconds (1 us buckets up to 0.1 s; beyond, only
/// the count and the maximum).
struct DeviceLatency {
    counts: Vec<u64>,
    over: u64,
    max_us: u64,
    /// The measurement frames sent lately: (frame number, when).
    sent: std::collections::VecDeque<(u16, Instant)>,
}

impl DeviceLatency {
    const BUCKETS: usize = 100_000;

    fn new() -> DeviceLatency {
        DeviceLatency {
            counts: vec![0; Self::BUCKETS],
            over: 0,
            max_us: 0,
            sent: Default::default(),
        }
    }

    /// Measurement frame `seq` went out now.
    fn sent(&mut self, seq: u16) {
        if self.sent.len() == 256 {
            self.sent.pop_front();
        }
        self.sent.push_back((seq, Instant::now()));
    }

    /// A force frame answering `seq` came now: its latency in microseconds (the first answer
    /// to a frame only).
    fn answered(&mut self, seq: u16) -> Option<u64> {
        let i = self.sent.iter().position(|(s, _)| *s == seq)?;
        let (_, at) = self.sent.remove(i)?;
        let us = at.elapsed().as_micros() as u64;
        match self.counts.get_mut(us as usize) {
            Some(c) => *c += 1,
            None => self.over += 1,
        }
        self.max_us = self.max_us.max(us);
        Some(us)
    }

    /// The `q` quantile \[ms\] (`None`: no answer; beyond 0.1 s: the maximum).
    fn quantile_ms(&self, q: f64) -> Option<f64> {
        let total: u64 = self.counts.iter().sum::<u64>() + self.over;
        if total == 0 {
            return None;
        }
        let rank = ((q * total as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (us, c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return Some(us as f64 * 1e-3);
            }
        }
        Some(self.max_us as f64 * 1e-3)
    }

    fn summary(&self) -> String {
        match (self.quantile_ms(0.5), self.quantile_ms(0.99)) {
            (Some(p50), Some(p99)) => format!(
                "command-to-device latency p50 {p50:.3} ms p99 {p99:.3} ms max {:.3} ms",
                self.max_us as f64 * 1e-3
            ),
            _ => "no measurement answered".into(),
        }
    }
}

/// Re-sends in lock-step while no answer comes.
const RESEND: Duration = Duration::from_millis(50);

/// The measurement frame of a reading at device time `t_s`, with the mean force the actuator
/// applied over the sample period that ends at `t_s` (not the sensor's delayed reading of the
/// coil: the device knows what it applied without the sensor's latency).
fn measurement(r: &Reading, t_s: f64, applied_n: f64) -> Measurement {
    let (contact_measured, in_contact) = match r.contact {
        Some(c) => (1u8, u8::from(c) << 1),
        None => (0, 0),
    };
    Measurement {
        // the device's microsecond clock wraps as a u32 counter does
        t_us: ((t_s * 1e6).round() as u64 % (1u64 << 32)) as u32,
        relative_m: r.displacement_m as f32,
        capsule_m: r.capsule_m as f32,
        mass_velocity: r.mass_v as f32,
        capsule_velocity: r.capsule_v as f32,
        applied_force_n: applied_n as f32,
        flags: contact_measured | in_contact,
    }
}

/// Makes `link` a symbolic link to `target`; refuses to replace anything but a symbolic link.
fn make_link(link: &Path, target: &Path) -> Result<()> {
    match std::fs::symlink_metadata(link) {
        Ok(m) if m.file_type().is_symlink() => std::fs::remove_file(link)
            .with_context(|| format!("cannot replace the link {}", link.display()))?,
        Ok(_) => bail!(Refused(format!(
            "--link {}: exists and is not a symbolic link; not replaced",
            link.display()
        ))),
        Err(_) => {}
    }
    std::os::unix::fs::symlink(target, link)
        .with_context(|| format!("cannot create the link {}", link.display()))
}

/// How long until sample `k + 1` is due.
fn due_in(start: Instant, period: Duration, k: u64) -> Duration {
    (start + period.mul_f64((k + 1) as f64)).saturating_duration_since(Instant::now())
}

/// What the emulator counted.
struct Counts {
    samples: u64,
    /// Real time: samples that went out over half a period after their time (the host did
    /// not run the emulator in time; a real device's own clock does not slip so).
    behind: u64,
    forces: u64,
    timeouts: u64,
    bad_in: u64,
    latency: DeviceLatency,
    log: Option<std::io::BufWriter<std::fs::File>>,
}

impl Counts {
    fn new(log: Option<&Path>) -> Result<Counts> {
        let log = log
            .map(|p| {
                std::fs::File::create_new(p)
                    .with_context(|| format!("--force-log {}: cannot create it", p.display()))
                    .map(std::io::BufWriter::new)
            })
            .transpose()?;
        Ok(Counts {
            samples: 0,
            behind: 0,
            forces: 0,
            timeouts: 0,
            bad_in: 0,
            latency: DeviceLatency::new(),
            log,
        })
    }

    /// A force frame came.
    fn force(&mut self, f: &capsule_device::Force) -> Result<()> {
        self.forces += 1;
        let us = self.latency.answered(f.answers);
        if let Some(w) = self.log.as_mut() {
            let wall = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos());
            writeln!(
                w,
                "{wall},{},{},{}",
                f.force_n,
                f.answers,
                us.map_or(String::new(), |u| u.to_string())
            )
            .context("--force-log: cannot write")?;
        }
        Ok(())
    }
}

/// Runs the emulated device until `--until-s`, an unplug, or Ctrl-C.
pub fn main(args: Args) -> Result<()> {
    let file = SceneFile::read(&args.scene)?;
    let scene = &file.scene;
    let device = scene.device_or_typical();
    let rate = args.rate_hz.unwrap_or(file.node.rate_hz);
    let sim = Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver())
        .map_err(|e| anyhow::anyhow!("{}: cannot set up the simulation: {e}", file.stem))?;
    let mut proto = Prototype::new(sim, scene.physical, &device);
    let pty = open_pty().context("cannot open a pseudo-terminal")?;
    if let Some(link) = &args.link {
        make_link(link, &pty.path)?;
    }
    // the path alone on stdout's first line, for scripts; the rest goes to the log
    println!("{}", pty.path.display());
    std::io::stdout().flush().ok();
    info!(
        "device on {} ({}): {rate} Hz, measures {}, noise {} m, latency {} s, force limit {} N, {:?}",
        pty.path.display(),
        args.link
            .as_ref()
            .map_or("no link".to_string(), |l| format!("link {}", l.display())),
        device.measured.names().join(", "),
        device.noise_m,
        device.latency_s,
        device.max_force_n,
        args.pacing
    );
    let hello = Frame::Hello(Hello {
        version: VERSION,
        measured: device.measured.bits(),
        max_force_n: device.max_force_n as f32,
        max_travel_m: device.max_travel_m as f32,
        sample_rate_hz: rate as f32,
        command_timeout_s: device.command_timeout_s as f32,
    });
    let mut link = Link::new(pty.master.try_clone().context("pseudo-terminal")?);
    let counts = Counts::new(args.force_log.as_deref())?;
    crate::work::catch_ctrl_c();
    let result = serve(
        &args,
        &mut proto,
        &mut link,
        &hello,
        (rate, device.command_timeout_s),
        counts,
    );
    crate::work::release_ctrl_c();
    if let Some(l) = &args.link {
        let _ = std::fs::remove_file(l);
    }
    drop(pty);
    let mut counts = result?;
    if let Some(w) = counts.log.as_mut() {
        w.flush().context("--force-log: cannot write")?;
    }
    eprintln!(
        "emulate-device: {} samples ({} sent over half a period late), {} force frames, {} command timeouts, {} bad frames in; {}",
        counts.samples,
        counts.behind,
        counts.forces,
        counts.timeouts,
        counts.bad_in,
        counts.latency.summary()
    );
    Ok(())
}

/// The sample loop.
fn serve(
    args: &Args,
    proto: &mut Prototype,
    link: &mut Link,
    hello: &Frame,
    (rate, timeout_s): (f64, f64),
    mut counts: Counts,
) -> Result<Counts> {
    let period = Duration::from_secs_f64(1.0 / rate);
    let dt = 1.0 / rate;
    // a hello four times a second: a driver that (re)opens the line learns the limits quickly
    let hello_every = ((rate / 4.0).round() as u64).max(1);
    let start = Instant::now();
    let mut cmd = Commanded::default();
    link.send(hello).map_err(gone)?;
    for k in 0u64.. {
        let t = k as f64 * dt;
        if args.until_s.is_some_and(|u| t >= u) {
            info!("reached the end time {t:.3} s");
            break;
        }
        if crate::work::interrupted() {
            info!("interrupted at {t:.3} s");
            break;
        }
        if args.unplug_after_s.is_some_and(|u| t >= u) {
            info!("unplugging the line at {t:.3} s");
            break;
        }
        let silent = args.silent_after_s.is_some_and(|s| t >= s);
        let reading = proto.read();
        let mut m = measurement(&reading, t, proto.applied_n());
        let every = |n: Option<u64>| n.is_some_and(|n| (k + 1) % n == 0);
        if every(args.nan_every) {
            m.relative_m = f32::NAN;
        }
        let send_sample = |link: &mut Link| -> Result<u16> {
            if k > 0 && k % hello_every == 0 {
                link.send(hello).map_err(gone)?;
            }
            let (mut bytes, seq) = link.encode(&Frame::Measurement(m));
            if every(args.corrupt_every) {
                bytes[8] ^= 0x5A;
            }
            link.write_bytes(&bytes).map_err(gone)?;
            if every(args.garbage_every) {
                link.write_bytes(&[0x00, 0xCA, 0x13, 0x37, 0xFF, 0x95, 0x42])
                    .map_err(gone)?;
            }
            Ok(seq)
        };
        // a silent device takes no more force frames either: it has hung
        let first_seq = if silent {
            std::thread::sleep(due_in(start, period, k));
            proto
                .hold(0.0, dt)
                .map_err(|e| anyhow::anyhow!("simulation failed at {t:.3} s: {e}"))?;
            continue;
        } else {
            let behind = Instant::now().saturating_duration_since(start + period.mul_f64(k as f64));
            if args.pacing == Pacing::Realtime && behind > period / 2 {
                counts.behind += 1;
            }
            let seq = send_sample(link)?;
            counts.latency.sent(seq);
            seq
        };
        counts.samples += 1;
        let due = start + period.mul_f64((k + 1) as f64);
        let sample = Sample {
            measurement: m,
            first_seq,
            due,
        };
        let go_on = take_forces(args, link, hello, &sample, timeout_s, &mut counts, &mut cmd)?;
        if !go_on {
            return Ok(counts);
        }
        if cmd
            .last
            .is_some_and(|at| at.elapsed().as_secs_f64() > timeout_s)
        {
            if cmd.force_n != 0.0 {
                warn!("no force frame for {timeout_s} s at {t:.3} s: zero force");
                counts.timeouts += 1;
            }
            cmd.force_n = 0.0;
        }
        proto
            .hold(cmd.force_n, dt)
            .map_err(|e| anyhow::anyhow!("simulation failed at {t:.3} s: {e}"))?;
    }
    Ok(counts)
}

/// The force the device applies: the last command and when it came.
#[derive(Default)]
struct Commanded {
    force_n: f64,
    last: Option<Instant>,
}

/// A sample sent: the measurement, its first sequence number, when the next one is due.
struct Sample {
    measurement: Measurement,
    first_seq: u16,
    due: Instant,
}

fn gone(e: LinkError) -> anyhow::Error {
    anyhow::anyhow!("{e}")
}

/// Takes force frames until the sample is due (realtime) or answered (lockstep, re-sending
/// it while unanswered); false when interrupted meanwhile.
fn take_forces(
    args: &Args,
    link: &mut Link,
    hello: &Frame,
    sample: &Sample,
    timeout_s: f64,
    counts: &mut Counts,
    cmd: &mut Commanded,
) -> Result<bool> {
    let mut waited_from = Instant::now();
    loop {
        let deadline = match args.pacing {
            Pacing::Realtime => sample.due,
            Pacing::Lockstep => Instant::now() + RESEND,
        };
        match link.next(deadline).map_err(gone)? {
            Some(Decoded::Frame {
                frame: Frame::Force(f),
                ..
            }) => {
                counts.force(&f)?;
                cmd.force_n = f64::from(f.force_n);
                cmd.last = Some(Instant::now());
                let answers_this = f.answers.wrapping_sub(sample.first_seq) < 0x8000;
                if args.pacing == Pacing::Lockstep && answers_this {
                    break;
                }
            }
            Some(Decoded::Frame { .. }) | Some(Decoded::Skipped(_)) => counts.bad_in += 1,
            None => match args.pacing {
                Pacing::Realtime => break,
                Pacing::Lockstep => {
                    if crate::work::interrupted() {
                        return Ok(false);
                    }
                    let commanded = cmd.last.is_some();
                    if commanded && waited_from.elapsed().as_secs_f64() > timeout_s {
                        break;
                    }
                    // re-send the sample (with a hello: a driver may have just opened)
                    link.send(hello).map_err(gone)?;
                    let seq = link
                        .send(&Frame::Measurement(sample.measurement))
                        .map_err(gone)?;
                    counts.latency.sent(seq);
                    if !commanded {
                        waited_from = Instant::now();
                    }
                }
            },
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_device::frame::measured;
    use capsule_plant::device::Measured;

    #[test]
    fn the_scene_s_measured_quantities_are_the_protocol_s_bits() {
        let one = |f: fn(&mut Measured)| {
            let mut m = Measured::from_bits(0);
            f(&mut m);
            m.bits()
        };
        assert_eq!(
            one(|m| m.displacement = true),
            measured::RELATIVE_DISPLACEMENT
        );
        assert_eq!(
            one(|m| m.capsule_position = true),
            measured::CAPSULE_POSITION
        );
        assert_eq!(one(|m| m.mass_velocity = true), measured::MASS_VELOCITY);
        assert_eq!(
            one(|m| m.capsule_velocity = true),
            measured::CAPSULE_VELOCITY
        );
        assert_eq!(one(|m| m.contact = true), measured::CONTACT);
    }

    #[test]
    fn a_reading_becomes_a_measurement_frame_with_nan_where_not_measured() {
        let r = Reading {
            t_s: 0.5,
            displacement_m: 1e-3,
            capsule_m: 2e-3,
            mass_v: f64::NAN,
            capsule_v: f64::NAN,
            contact: None,
            force_n: 0.25,
        };
        let m = measurement(&r, 4295.0, 0.125);
        // the microsecond clock wraps at 2^32 us (4294.967296 s)
        assert_eq!(m.t_us, 32_704);
        assert!(m.mass_velocity.is_nan() && m.capsule_velocity.is_nan());
        assert_eq!((m.relative_m, m.capsule_m, m.flags), (1e-3, 2e-3, 0));
        // the applied force is the period's mean the device was given, not the reading's
        assert_eq!(m.applied_force_n, 0.125);
        let touching = measurement(
            &Reading {
                contact: Some(true),
                ..r
            },
            0.0,
            0.0,
        );
        assert_eq!(touching.flags, 0b11);
    }
}
