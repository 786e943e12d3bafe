//! `capsule replay` refuses arguments that used to pass silently (issue 12, point 7): a NaN or
//! infinite `--tolerance` (which passed a tampered file), a `--start` beyond the file (which
//! replayed all of it), and `--topics T FILE` (which took FILE as a second topic). All refused
//! before any DDS starts, so no namespace is needed.

use capsule_msgs::names::{default_topics, type_names};
use std::path::Path;

use capsule_msgs::{ActuatorForce, CapsuleState, Header, Time};
use capsule_record::{cdr, types::OfferedQos, WriterOptions};

use crate::common::{capsule, TempDir};
use crate::record::scene_writer;
use crate::root;

/// One second at 1 kHz of the control-point scene with forces no controller would send
/// (a tampered file: `--check-controller` must fail on it).
fn tampered(path: &Path) {
    let toml = std::fs::read_to_string(root().join("scenes/control_point.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let go = || -> Result<(), capsule_record::RecordError> {
        let mut w = scene_writer(path, "control_point", toml, &WriterOptions::default())?;
        let q = OfferedQos::reliable(10);
        let s = w.add_topic(default_topics::STATE, type_names::STATE, &q)?;
        let f = w.add_topic(default_topics::FORCE, type_names::FORCE, &q)?;
        for i in 0..1000u64 {
            let t = 1_700_000_000_000_000_000 + i * 1_000_000;
            let header = Header {
                stamp: Time::from_nanos(i as i64 * 1_000_000),
                frame_id: "odom".into(),
            };
            let state = CapsuleState {
                header: header.clone(),
                seq: i,
                ..CapsuleState::default()
            };
            let force = ActuatorForce {
                header,
                state_seq: i,
                force: 5.0,
            };
            w.write(s, i as u32, t, t, &cdr::encode(&state)?)?;
            w.write(f, i as u32, t + 10, t + 10, &cdr::encode(&force)?)?;
        }
        w.finish()?;
        Ok(())
    };
    go().unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn non_finite_tolerance_start_beyond_the_file_and_topics_before_file_are_refused() {
    let dir = TempDir::new("replay_args");
    let f = dir.file("tampered.mcap");
    tampered(&f);
    let f = f.to_str().unwrap_or_default();
    // the tampered file fails the check with a finite tolerance ...
    let out = capsule(&["replay", "--check-controller", f]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    // ... and a tolerance that compares false with everything is refused, not a pass
    for tol in ["nan", "inf", "-1"] {
        let tol = format!("--tolerance={tol}");
        let out = capsule(&["replay", "--check-controller", &tol, f]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{tol}: {err}");
        assert!(
            err.contains("--tolerance") && err.contains("finite"),
            "{tol}: {err}"
        );
    }
    // --start beyond the file's 0.999 s
    let out = capsule(&["replay", "--start", "1e308", f]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--start 1e308: beyond the end"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // --topics T FILE: FILE stays the file (here T is not in it: named, refused)
    let out = capsule(&["replay", "--topics", "/nope", f]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--topics /nope: not in"), "{err}");
}
