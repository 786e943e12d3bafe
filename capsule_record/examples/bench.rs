//! Recording benchmarks that print figures (not timed tests):
//!
//! 1. writer cost at 10 kHz for 60 s of log time: state + force + clock per sample (1.8 M
//!    messages), as the recorder writes them: CPU time per second of recording.
//! 2. `info` on a large file (default 1 GiB, made once in the given directory): wall time
//!    of the summary-based read, against a full scan of the same file.
//!
//!     cargo run --release -p capsule_record --example bench -- [DIR] [SIZE_MIB]

use capsule_msgs::names::{default_topics, type_names};
use capsule_msgs::std_types::Clock;
use std::{
    path::{Path, PathBuf},
    time::Instant,
};

use capsule_msgs::{ActuatorForce, CapsuleState, Header, Time};
use capsule_record::{cdr, types::OfferedQos, RecordError, RecordWriter, WriterOptions};

fn cpu_s() -> f64 {
    // user + system time of this process, from /proc (Linux)
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let tick = 100.0; // USER_HZ
    let get = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (get(11) + get(12)) / tick
}

fn write(
    path: &Path,
    rate_hz: u64,
    seconds: u64,
    stop_at_bytes: Option<u64>,
) -> Result<u64, RecordError> {
    let mut w = RecordWriter::create(
        path,
        WriterOptions {
            overwrite: true,
            ..WriterOptions::default()
        },
    )?;
    let q = OfferedQos::reliable(16);
    let s = w.add_topic(default_topics::STATE, type_names::STATE, &q)?;
    let f = w.add_topic(default_topics::FORCE, type_names::FORCE, &q)?;
    let c = w.add_topic(default_topics::CLOCK, type_names::CLOCK, &q)?;
    let t0 = 1_700_000_000_000_000_000u64;
    let dt = 1_000_000_000 / rate_hz;
    let mut bytes = 0u64;
    for i in 0..rate_hz * seconds {
        let t = t0 + i * dt;
        let stamp = Time::from_nanos((i * dt) as i64);
        let header = Header {
            stamp,
            frame_id: "odom".into(),
        };
        let state = CapsuleState {
            header: header.clone(),
            seq: i,
            mass_position: (i as f64 * 1e-3).sin(),
            capsule_position: i as f64 * 1e-6,
            ..CapsuleState::default()
        };
        let force = ActuatorForce {
            header,
            state_seq: i,
            force: (i as f64 * 1e-3).cos(),
        };
        let (a, b, d) = (
            cdr::encode(&Clock { clock: stamp })?,
            cdr::encode(&state)?,
            cdr::encode(&force)?,
        );
        bytes += (a.len() + b.len() + d.len()) as u64;
        w.write(c, i as u32, t, t, &a)?;
        w.write(s, i as u32, t, t, &b)?;
        w.write(f, i as u32, t + 1, t + 1, &d)?;
        if stop_at_bytes.is_some_and(|m| bytes >= m) {
            break;
        }
    }
    Ok(w.finish()?.messages)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(
        args.next()
            .unwrap_or_else(|| std::env::temp_dir().display().to_string()),
    );
    let mib: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1024);

    let small = dir.join("capsule_bench_10khz.mcap");
    let (c0, w0) = (cpu_s(), Instant::now());
    let n = write(&small, 10_000, 60, None)?;
    let (cpu, wall) = (cpu_s() - c0, w0.elapsed().as_secs_f64());
    println!(
        "writer, 10 kHz x 60 s (state + force + clock): {n} messages, {:.2} s CPU, {:.2} s wall = {:.2} % of a core while recording ({:.0} ns per message), {:.1} MiB",
        cpu,
        wall,
        100.0 * cpu / 60.0,
        1e9 * cpu / n as f64,
        std::fs::metadata(&small)?.len() as f64 / 1048576.0
    );
    let _ = std::fs::remove_file(&small);

    let big = dir.join(format!("capsule_bench_{mib}mib.mcap"));
    let want = mib << 20;
    if std::fs::metadata(&big)
        .map(|m| m.len() + (64 << 20) < want)
        .unwrap_or(true)
    {
        let w0 = Instant::now();
        // 10 kHz log time; as many seconds as the size needs
        let n = write(&big, 10_000, 1_000_000, Some(want))?;
        println!(
            "made {} ({n} messages, {:.1} MiB) in {:.1} s",
            big.display(),
            std::fs::metadata(&big)?.len() as f64 / 1048576.0,
            w0.elapsed().as_secs_f64()
        );
    }
    let w0 = Instant::now();
    let info = capsule_record::info(&big)?;
    let t_info = w0.elapsed().as_secs_f64();
    println!(
        "info from the summary on {:.2} GiB: {:.3} s wall ({} messages, {} chunks, {:.0} s of log time)",
        info.size as f64 / (1u64 << 30) as f64,
        t_info,
        info.messages,
        info.chunks,
        info.duration_ns() as f64 * 1e-9
    );
    let w0 = Instant::now();
    let bytes = std::fs::read(&big)?;
    let scan = capsule_record::scan::scan(&bytes)?;
    println!(
        "for comparison, a full scan: {:.3} s wall ({} messages)",
        w0.elapsed().as_secs_f64(),
        scan.messages.len()
    );
    Ok(())
}
