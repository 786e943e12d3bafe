//! The device protocol over a loopback line: a pseudo-terminal stands in for the serial cable.
//! The device's end introduces itself (hello) and sends measurements; the driver's end, opened
//! as a serial line in raw mode, decodes them and answers each with a force frame, which the
//! device decodes. Bytes of line noise and a frame with a flipped bit are sent on the way: the
//! decoder skips them, says why, and loses nothing else.
//!
//!   cargo run -p capsule_serial --example device_link
//!
//! Exit status 1 if any frame does not come back as it was sent.

use std::error::Error;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use capsule_device::frame::{measured, VERSION};
use capsule_device::{Decoded, Force, Frame, Hello, Measurement};
use capsule_serial::{open_line, open_pty, Link};

/// The next thing the link decodes within a second, or an error saying nothing came.
fn next(link: &mut Link, who: &str) -> Result<Decoded, Box<dyn Error>> {
    link.next(Instant::now() + Duration::from_secs(1))?
        .ok_or_else(|| format!("{who}: nothing within 1 s").into())
}

/// The next intact frame, printing what was skipped before it.
fn next_frame(link: &mut Link, who: &str) -> Result<(u16, Frame), Box<dyn Error>> {
    loop {
        match next(link, who)? {
            Decoded::Frame { seq, frame, lost } => {
                if lost > 0 {
                    println!("{who}: {lost} frame(s) lost before seq {seq}");
                }
                return Ok((seq, frame));
            }
            Decoded::Skipped(why) => println!("{who}: skipped: {why}"),
        }
    }
}

fn run() -> Result<(), Box<dyn Error>> {
    let pty = open_pty()?;
    let mut device = Link::new(pty.master.try_clone()?);
    let mut driver = Link::new(open_line(&pty.path, 115_200)?);
    println!(
        "line: {} (the driver's end), 115200 baud, raw",
        pty.path.display()
    );

    let hello = Frame::Hello(Hello {
        version: VERSION,
        measured: measured::RELATIVE_DISPLACEMENT | measured::CAPSULE_POSITION,
        max_force_n: 1.0,
        max_travel_m: 0.02,
        sample_rate_hz: 1000.0,
        command_timeout_s: 0.1,
    });
    device.send(&hello)?;
    let (_, got) = next_frame(&mut driver, "driver")?;
    println!("driver: {got:?}");
    if got != hello {
        return Err("the hello frame changed on the way".into());
    }

    for k in 0..3u16 {
        let m = Frame::Measurement(Measurement {
            t_us: 1000 * u32::from(k),
            relative_m: 0.001 * f32::from(k),
            capsule_m: 0.0005 * f32::from(k),
            mass_velocity: f32::NAN,
            capsule_velocity: f32::NAN,
            applied_force_n: 0.0,
            flags: 0,
        });
        if k == 1 {
            // line noise, then a measurement with one bit flipped in its payload
            device.write_bytes(&[0x00, 0xff, 0x13])?;
            let (mut bytes, _) = device.encode(&m);
            bytes[8] ^= 0x10;
            device.write_bytes(&bytes)?;
        }
        let seq = device.send(&m)?;
        let (got_seq, got) = next_frame(&mut driver, "driver")?;
        // NaN is not equal to itself: compare the encodings
        if got_seq != seq || got.encode(got_seq) != m.encode(seq) {
            return Err(format!("measurement {seq} came as {got_seq}: {got:?}").into());
        }
        println!(
            "driver: measurement seq {seq}: x1 - x2 = {} m",
            0.001 * f32::from(k)
        );
        let force = Frame::Force(Force {
            force_n: 0.1 * f32::from(k),
            answers: seq,
        });
        driver.send(&force)?;
        let (_, back) = next_frame(&mut device, "device")?;
        if back != force {
            return Err(format!("force {force:?} came as {back:?}").into());
        }
        println!("device: {back:?}");
    }
    println!("ok: every frame crossed the line intact; noise and the corrupted frame skipped");
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("device_link: {e}");
            ExitCode::from(1)
        }
    }
}
