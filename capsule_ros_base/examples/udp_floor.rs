//! What receiving one UDP datagram per message costs on this machine, with no DDS at all: the
//! floor under any DDS subscriber (RustDDS's event loop, the recorder node) that gets one
//! datagram per sample. A sender process (this example, started again with `--send`) paces
//! `RATE` datagrams/s of 160 bytes (a CapsuleState with its RTPS header) to 127.0.0.1, as the
//! plant and the controller do; the receiver thread reads them (a) blocking in recv,
//! (b) the way RustDDS does, woken by epoll (mio) and reading until WouldBlock. Prints the
//! receiver thread's CPU (user + system, from /proc/thread-self/stat).
//!
//!   cargo run --release -p capsule_ros_base --example udp_floor -- [RATE=30000] [SECONDS=10]
//!
//! Loopback only by construction (binds and sends to 127.0.0.1, no multicast).

use std::{
    net::UdpSocket,
    time::{Duration, Instant},
};

use anyhow::{bail, Context as _, Result};
use rustdds::mio1::{self, Events, Interest, Poll, Token};

/// CPU time [s] of the calling thread so far (utime + stime).
fn thread_cpu_s() -> Result<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat")
        .context("reading /proc/thread-self/stat (Linux only)")?;
    // fields after the parenthesised command name; utime and stime are fields 14 and 15
    let after = stat
        .rsplit_once(')')
        .map(|(_, rest)| rest)
        .context("unexpected /proc/thread-self/stat")?;
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f
        .get(11..13)
        .context("short /proc/thread-self/stat")?
        .iter()
        .map(|v| v.parse::<f64>().unwrap_or(0.0))
        .sum();
    // USER_HZ is 100 on Linux
    Ok(ticks / 100.0)
}

fn sender(port: u16, rate: f64, n: u64) -> Result<()> {
    let s = UdpSocket::bind("127.0.0.1:0").context("sender socket")?;
    let buf = [0u8; 160];
    let t0 = Instant::now();
    for k in 0..n {
        // on time to the microsecond (sleep short, then spin): a late sender would send bursts,
        // which the receiver reads in one wake-up, and the floor would look lower than it is
        let due = t0 + Duration::from_secs_f64(k as f64 / rate);
        if let Some(w) = due.checked_duration_since(Instant::now()) {
            if w > Duration::from_micros(200) {
                std::thread::sleep(w - Duration::from_micros(150));
            }
            while Instant::now() < due {
                std::hint::spin_loop();
            }
        }
        s.send_to(&buf, ("127.0.0.1", port)).context("send")?;
    }
    Ok(())
}

/// Receives up to `n` datagrams; returns (received, wall s from the first on, receiver CPU s).
fn receive(n: u64, rate: f64, with_epoll: bool) -> Result<(u64, f64, f64)> {
    let sock = UdpSocket::bind("127.0.0.1:0").context("receiver socket")?;
    let port = sock.local_addr()?.port();
    // another process, like the nodes: a thread of the same process wakes the receiver cheaper
    let mut send = std::process::Command::new(std::env::current_exe()?)
        .args([
            "--send",
            &port.to_string(),
            &rate.to_string(),
            &n.to_string(),
        ])
        .spawn()
        .context("starting the sender process")?;
    let mut buf = [0u8; 65536];
    let mut got = 0u64;
    let (mut t0, mut c0) = (Instant::now(), 0.0);
    let mut first = |got: u64| -> Result<()> {
        if got == 1 {
            t0 = Instant::now();
            c0 = thread_cpu_s()?;
        }
        Ok(())
    };
    if with_epoll {
        sock.set_nonblocking(true)?;
        let mut sock = mio1::net::UdpSocket::from_std(sock);
        let mut poll = Poll::new()?;
        poll.registry()
            .register(&mut sock, Token(0), Interest::READABLE)?;
        let mut events = Events::with_capacity(16);
        while got < n {
            poll.poll(&mut events, Some(Duration::from_secs(2)))?;
            if events.is_empty() {
                break; // the rest was dropped (receive buffer full): counted below
            }
            loop {
                match sock.recv(&mut buf) {
                    Ok(_) => {
                        got += 1;
                        first(got)?;
                    }
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                    Err(e) => return Err(e.into()),
                }
            }
        }
    } else {
        sock.set_read_timeout(Some(Duration::from_secs(2)))?;
        while got < n {
            match sock.recv(&mut buf) {
                Ok(_) => {
                    got += 1;
                    first(got)?;
                }
                // the rest was dropped (receive buffer full): counted below
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => break,
                Err(e) => return Err(e.into()),
            }
        }
    }
    // a timeout ended the loop: do not count its 2 s of waiting
    let wall = t0.elapsed().as_secs_f64().min(got as f64 / rate);
    let cpu = thread_cpu_s()? - c0;
    let status = send.wait()?;
    if !status.success() {
        bail!("sender process failed: {status}");
    }
    Ok((got, wall, cpu))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, port, rate, n] = args.as_slice() {
        if flag == "--send" {
            return sender(port.parse()?, rate.parse()?, n.parse()?);
        }
    }
    let rate: f64 = match args.first() {
        Some(a) => a
            .parse()
            .with_context(|| format!("RATE {a:?}: not a number"))?,
        None => 30_000.0,
    };
    let secs: f64 = match args.get(1) {
        Some(a) => a
            .parse()
            .with_context(|| format!("SECONDS {a:?}: not a number"))?,
        None => 10.0,
    };
    if !(rate > 0.0 && secs > 0.0) {
        bail!("RATE and SECONDS must be positive");
    }
    let n = (rate * secs).round() as u64;
    println!("udp_floor: {n} datagrams of 160 bytes at {rate:.0}/s over 127.0.0.1");
    for (name, with_epoll) in [("blocking recv", false), ("epoll (mio), as RustDDS", true)] {
        let (got, wall, cpu) = receive(n, rate, with_epoll)?;
        println!(
            "  {name:<26} receiver thread {:5.1} % of a core, {:5.2} us per datagram; {} of {n} received",
            100.0 * cpu / wall,
            1e6 * cpu / got.max(1) as f64,
            got
        );
    }
    Ok(())
}
