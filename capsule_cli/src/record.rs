//! `capsule record info|recover`: look into a recording (like `ros2 bag info`, from the
//! summary, no scan) and complete a recording whose writer was killed.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use capsule_record::{info::InfoSource, RecordingInfo};
use clap::{Args as ClapArgs, Subcommand};

/// `capsule record ...`
#[derive(Debug, ClapArgs)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Duration, start/end, topics with type, count and rate, mode changes, scene.
    Info {
        /// The recording (.mcap), or a split recording's directory or metadata.yaml
        file: PathBuf,
        /// Print the scene file that was run as well
        #[arg(long)]
        scene: bool,
    },
    /// Rebuild a complete file (summary, footer, ros2 profile) from a cut or damaged one:
    /// every intact chunk is kept, damaged ones are skipped. Writes FILE's stem +
    /// `.recovered.mcap` unless told otherwise; also rewrites schemas of older capsule files
    /// the way rosbag2 writes them (so Foxglove opens them).
    Recover {
        /// The recording (.mcap)
        file: PathBuf,
        /// Write here (must not exist)
        #[arg(short, long, conflicts_with = "in_place")]
        output: Option<PathBuf>,
        /// Replace FILE with the recovered file (written beside it first, then renamed)
        #[arg(long)]
        in_place: bool,
    },
}

/// Runs `capsule record`.
pub fn main(args: Args) -> Result<()> {
    match args.command {
        Command::Info { file, scene } => {
            // a split recording: its directory or its metadata.yaml
            let split = file.is_dir()
                || file
                    .file_name()
                    .is_some_and(|n| n == capsule_record::metadata_yaml::METADATA_YAML);
            let info = if split {
                capsule_record::bag::bag_info(&file)?
            } else {
                capsule_record::info(&file)?
            };
            print!("{}", format_info(&info));
            if scene {
                match &info.scene_toml {
                    Some(t) => print!("\n# scene.toml\n{t}"),
                    None => println!("\n(no scene attached)"),
                }
            }
            Ok(())
        }
        Command::Recover {
            file,
            output,
            in_place,
        } => recover(&file, output.as_deref(), in_place),
    }
}

/// `FILE` with `.mcap` (if any) replaced by `suffix`.
fn beside(file: &Path, suffix: &str) -> Result<PathBuf> {
    let stem = file
        .file_stem()
        .with_context(|| format!("{}: no file name", file.display()))?;
    let mut name = stem.to_os_string();
    name.push(suffix);
    Ok(file.with_file_name(name))
}

fn recover(file: &Path, output: Option<&Path>, in_place: bool) -> Result<()> {
    let target = match output {
        Some(o) => o.to_path_buf(),
        None if in_place => beside(file, ".recovering.mcap")?,
        None => beside(file, ".recovered.mcap")?,
    };
    if in_place {
        // a leftover from an interrupted recovery
        let _ = std::fs::remove_file(&target);
    } else if target.exists() {
        anyhow::bail!(
            "{} exists: not overwriting it (give -o OUT, or --in-place to replace {})",
            target.display(),
            file.display()
        );
    }
    let r = capsule_record::recover(file, &target).inspect_err(|_| {
        if in_place {
            let _ = std::fs::remove_file(&target);
        }
    })?;
    let out = if in_place {
        std::fs::rename(&target, file)
            .with_context(|| format!("replacing {} with {}", file.display(), target.display()))?;
        file.to_path_buf()
    } else {
        target
    };
    let span = r
        .bounds
        .map(|(a, b)| format!(" spanning {:.3} s", (b - a) as f64 * 1e-9))
        .unwrap_or_default();
    println!(
        "recovered {} messages{span} into {} ({} intact chunks kept)",
        r.messages,
        out.display(),
        r.chunks_kept
    );
    for (topic, n) in &r.per_topic {
        println!("  {topic}: {n}");
    }
    for name in &r.schemas_respelled {
        println!("  schema {name}: dependency blocks renamed as rosbag2 names them (Foxglove reads them now)");
    }
    if let Some(n) = r.summary_messages {
        println!("the input's summary lists {n} messages");
    }
    for d in &r.damage {
        println!("damaged: {d}");
    }
    if r.orphans > 0 {
        println!(
            "dropped {} messages whose channel definition was in damaged data",
            r.orphans
        );
    }
    match &r.cut {
        Some(cut) => println!("the input was cut: reading ended {cut}"),
        None if r.was_complete && r.damage.is_empty() => {
            println!("{}: the input was complete and intact", file.display())
        }
        None => {}
    }
    Ok(())
}

fn human_size(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.2} GiB", b / (1024.0 * 1024.0 * 1024.0))
    } else if b >= 1024.0 * 1024.0 {
        format!("{:.2} MiB", b / (1024.0 * 1024.0))
    } else if b >= 1024.0 {
        format!("{:.2} KiB", b / 1024.0)
    } else {
        format!("{bytes} B")
    }
}

/// `YYYY-MM-DD HH:MM:SS.nnnnnnnnn UTC` of nanoseconds since the epoch.
pub fn utc(ns: u64) -> String {
    let c = capsule_record::civil::civil(ns);
    format!(
        "{:04}-{:02}-{:02} {:02}:{:02}:{:02}.{:09} UTC ({}.{:09})",
        c.year,
        c.month,
        c.day,
        c.hour,
        c.minute,
        c.second,
        c.nanos,
        ns / 1_000_000_000,
        c.nanos
    )
}

/// The `capsule record info` text.
pub fn format_info(i: &RecordingInfo) -> String {
    let mut s = String::new();
    let dur = i.duration_ns() as f64 * 1e-9;
    s += &format!("File:              {}\n", i.path.display());
    s += &format!("Size:              {}\n", human_size(i.size));
    s += &format!(
        "Storage:           mcap (profile {}, written by {})\n",
        i.profile, i.library
    );
    s += &format!(
        "Read from:         {}\n",
        match i.source {
            InfoSource::Summary => "summary",
            InfoSource::Scan => "full scan (the file has no summary)",
        }
    );
    s += &format!(
        "Scene:             {}\n",
        i.scene_name.as_deref().unwrap_or("(not recorded)")
    );
    s += &format!("Duration:          {dur:.9} s\n");
    s += &format!("Start:             {}\n", utc(i.bounds.0));
    s += &format!("End:               {}\n", utc(i.bounds.1));
    s += &format!("Messages:          {}\n", i.messages);
    s += &format!("Chunks:            {}\n", i.chunks);
    if i.files > 1 {
        s += &format!(
            "Files:             {} (split, rosbag2 metadata.yaml)\n",
            i.files
        );
    }
    let width = i.topics.iter().map(|t| t.topic.len()).max().unwrap_or(0);
    for (k, t) in i.topics.iter().enumerate() {
        let rate = if dur > 0.0 && t.count > 1 {
            format!("{:.1} Hz", t.count as f64 / dur)
        } else {
            "-".to_string()
        };
        s += &format!(
            "{}{:width$} | {} | count {} | rate {}\n",
            if k == 0 {
                "Topics:            "
            } else {
                "                   "
            },
            t.topic,
            t.type_name,
            t.count,
            rate,
        );
    }
    if i.topics.is_empty() {
        s += "Topics:            (none)\n";
    }
    s += &mode_changes(i);
    s
}

/// The mode changes, one line per `set_mode` call: the request paired with its response by
/// sequence number.
fn mode_changes(i: &RecordingInfo) -> String {
    let mut s = String::new();
    let mut first = true;
    let call = |m: &capsule_record::info::ModeChange| {
        (m.event.info.client_gid, m.event.info.sequence_number)
    };
    let answered: Vec<_> = i
        .mode_changes
        .iter()
        .filter(|m| m.response().is_some())
        .map(call)
        .collect();
    for m in &i.mode_changes {
        let seq = call(m);
        let request = m.request().or_else(|| {
            i.mode_changes
                .iter()
                .filter(|o| call(o) == seq)
                .find_map(|o| o.request())
        });
        let asked = |q: &capsule_msgs::SetModeRequest| {
            let name = capsule_msgs::mode_name(q.mode).unwrap_or("?");
            // SetMode.srv: gain 0 asks FORWARD, BACKWARD and CHAOS_CONTROL for their default
            match name {
                "FORWARD" | "BACKWARD" | "CHAOS_CONTROL" if q.gain == 0.0 => {
                    format!("{name} (default gain)")
                }
                _ => format!("{name} (gain {})", q.gain),
            }
        };
        let what = match (request, m.response()) {
            (q, Some(r)) => format!(
                "set_mode {}: {} -> {} k_p {}: {}",
                q.map(asked).unwrap_or_else(|| "?".into()),
                if r.accepted { "accepted" } else { "refused" },
                capsule_msgs::mode_name(r.mode).unwrap_or("?"),
                r.gain,
                r.reason
            ),
            // the request line is shown with its answer
            (Some(_), None) if answered.contains(&seq) => continue,
            (Some(q), None) => format!("set_mode {}: no answer recorded", asked(q)),
            (None, None) => format!("service event {}", m.event.info.event_type),
        };
        let at = m.log_time.saturating_sub(i.bounds.0) as f64 * 1e-9;
        s += &format!(
            "{}+{at:.6} s  {what}\n",
            if first {
                "Mode changes:      "
            } else {
                "                   "
            }
        );
        first = false;
    }
    if first {
        s += "Mode changes:      (none)\n";
    }
    s
}

#[cfg(test)]
mod tests {
    use super::utc;

    #[test]
    fn utc_formats_known_instants() {
        assert!(utc(0).starts_with("1970-01-01 00:00:00.000000000"));
        // 2024-02-29 12:34:56.5 UTC
        assert!(utc(1_709_210_096_500_000_000).starts_with("2024-02-29 12:34:56.500000000"));
    }
}
