//! The plant's states and the force commands of a recording as time series on the sample
//! grid, SI: what `capsule identify` fits a twin to. One file or a split recording.
//!
//! The force after each sample, in a plant's recording (it has commands), is what acted over
//! the period: the next state's `actuator_force`, which the plant fills with the force applied
//! over the period before it (a device's report of its actuator, the simulator's held force).
//! A command says only what was asked, not when it arrived: a late answer (a device that runs
//! on its own clock, an emulator late in lock-step) acts over another period than the one it
//! answers, or not at all. Where a state has no applied force, the force is the command
//! answering the sample (`/capsule/actuator_force`, keyed by the state's `seq`; a sample
//! without an answer gets zero, as the plant answers it). A recording without commands
//! (`capsule simulate --record`) gives the force the states say was applied, the mean of two
//! consecutive samples' `actuator_force` (the simulator's law is continuous: the mean is its
//! value over the interval to second order).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use capsule_msgs::names::default_topics;
use capsule_msgs::{ActuatorForce, CapsuleState};

use crate::bag::bag_files;
use crate::{cdr, messages, RecordError};

/// Where the forces of a [`Series`] came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum ForceSource {
    /// The commands on `/capsule/actuator_force`, each held after the sample it answers.
    Commands,
    /// What the plant says acted over each period (the next state's `actuator_force`), after
    /// the actuator's limit, lag and dead band.
    Acted,
    /// The states' `actuator_force`, averaged over each interval.
    Applied,
}

impl ForceSource {
    /// What the forces are, in words.
    pub fn name(self) -> &'static str {
        match self {
            ForceSource::Commands => "commands",
            ForceSource::Acted => "force applied over each period",
            ForceSource::Applied => "applied force",
        }
    }

    /// Whether the forces are what acted on the mass, already through the actuator (the
    /// states' forces are; commands are what was asked).
    pub fn acted(self) -> bool {
        self != ForceSource::Commands
    }
}

/// A recording's samples, SI.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Sample spacing \[s\] (the median of the stamps' steps).
    pub h_s: f64,
    /// `x1 - x2` \[m\] (NaN: not measured).
    pub rel_m: Vec<f64>,
    /// `x2` \[m\] (NaN: not measured).
    pub x2_m: Vec<f64>,
    /// The force after each sample \[N\].
    pub command_n: Vec<f64>,
    /// Where the forces came from.
    pub forces: ForceSource,
    /// Samples dropped as repeats of the one before (a late device: the plant stepped on with
    /// the last measurement, and no applied force); the series is on the device's own sample
    /// grid.
    pub repeated: usize,
}

/// Why a recording gives no series.
#[derive(Debug, thiserror::Error)]
pub enum SeriesError {
    /// The recording could not be read.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// It holds no state.
    #[error("{}: no states ({} holds no capsule_msgs/msg/CapsuleState): record the plant's state topic", .0.display(), default_topics::STATE)]
    NoStates(PathBuf),
    /// It holds no force.
    #[error("{}: no forces: neither commands on {} nor an applied force in the states", .0.display(), default_topics::FORCE)]
    NoForces(PathBuf),
    /// The samples are not evenly spaced.
    #[error("{}: the states are not evenly spaced in time ({bad} of {n} steps differ from {h_s} s by over 10 %): identification needs a sampled run", path.display())]
    Uneven {
        /// The file.
        path: PathBuf,
        /// Steps off the grid.
        bad: usize,
        /// Steps.
        n: usize,
        /// The median step.
        h_s: f64,
    },
}

/// The files of a recording: a split recording's (its directory or `metadata.yaml`), or the
/// file itself.
fn files(path: &Path) -> Result<Vec<PathBuf>, RecordError> {
    if path.is_dir() || path.file_name().is_some_and(|n| n == "metadata.yaml") {
        bag_files(path)
    } else {
        Ok(vec![path.to_path_buf()])
    }
}

/// The device's own samples of a plant's recording (`commands`): a plant whose device was late
/// steps on with the last measurement and no applied force; such a sample is dropped where the
/// others say what acted. (Equal positions do not tell it: a sensor may send one reading
/// twice, the typical device one sample in four.)
fn device_samples(states: Vec<CapsuleState>, commands: bool) -> Vec<CapsuleState> {
    let reports = states.iter().skip(1).any(|s| s.actuator_force.is_finite());
    if !(reports && commands) {
        return states;
    }
    states
        .into_iter()
        .enumerate()
        .filter(|(i, s)| *i == 0 || s.actuator_force.is_finite())
        .map(|(_, s)| s)
        .collect()
}

/// A plant's recording (with commands) whose states all say what acted over the period
/// before them: the force over each period, that of the state ending it (after the last
/// state, its command's).
fn acted(states: &[CapsuleState], answers: &BTreeMap<u64, f64>) -> Option<Vec<f64>> {
    let last = states.last()?;
    if answers.is_empty() || !states[1..].iter().all(|s| s.actuator_force.is_finite()) {
        return None;
    }
    let after = answers.get(&last.seq).copied().unwrap_or(0.0);
    Some(
        states[1..]
            .iter()
            .map(|s| s.actuator_force)
            .chain([after])
            .collect(),
    )
}

/// The series of the recording at `path`.
pub fn series(path: &Path) -> Result<Series, SeriesError> {
    let mut states: Vec<CapsuleState> = Vec::new();
    let mut answers: BTreeMap<u64, f64> = BTreeMap::new();
    for f in files(path)? {
        for m in messages(&f)? {
            if m.topic == default_topics::STATE {
                states.push(cdr::decode(&m.data)?);
            } else if m.topic == default_topics::FORCE {
                let c: ActuatorForce = cdr::decode(&m.data)?;
                answers.insert(c.state_seq, c.force);
            }
        }
    }
    if states.is_empty() {
        return Err(SeriesError::NoStates(path.to_path_buf()));
    }
    states.sort_by_key(|s| s.seq);
    states.dedup_by_key(|s| s.seq);
    let t_s: Vec<f64> = states
        .iter()
        .map(|s| s.header.stamp.as_secs_f64())
        .collect();
    let mut steps: Vec<f64> = t_s.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let h_s = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let bad = t_s
        .windows(2)
        .filter(|w| ((w[1] - w[0]) - h_s).abs() > 0.1 * h_s)
        .count();
    if h_s.is_nan() || h_s <= 0.0 || bad * 100 > steps.len() {
        return Err(SeriesError::Uneven {
            path: path.to_path_buf(),
            bad,
            n: steps.len(),
            h_s,
        });
    }
    let before = states.len();
    let states = device_samples(states, !answers.is_empty());
    let repeated = before - states.len();
    let (command_n, forces) = if let Some(acted) = acted(&states, &answers) {
        (acted, ForceSource::Acted)
    } else if !answers.is_empty() {
        let c = states
            .iter()
            .map(|s| answers.get(&s.seq).copied().unwrap_or(0.0))
            .collect();
        (c, ForceSource::Commands)
    } else {
        let f: Vec<f64> = states.iter().map(|s| s.actuator_force).collect();
        if !f.iter().any(|v| v.is_finite()) {
            return Err(SeriesError::NoForces(path.to_path_buf()));
        }
        let c = (0..f.len())
            .map(|k| {
                let next = f.get(k + 1).copied().unwrap_or(f[k]);
                let v = 0.5 * (f[k] + next);
                if v.is_finite() {
                    v
                } else {
                    0.0
                }
            })
            .collect();
        (c, ForceSource::Applied)
    };
    Ok(Series {
        h_s,
        rel_m: states
            .iter()
            .map(|s| s.mass_position - s.capsule_position)
            .collect(),
        x2_m: states.iter().map(|s| s.capsule_position).collect(),
        command_n,
        forces,
        repeated,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(seq: u64, actuator_force: f64) -> CapsuleState {
        CapsuleState {
            seq,
            actuator_force,
            ..CapsuleState::default()
        }
    }

    #[test]
    fn a_plant_s_states_say_which_force_acted_over_each_period() {
        // the answers were late: the force over period k is the one state k + 1 reports
        let states = [state(0, 0.0), state(1, 0.5), state(2, 0.25)];
        let answers = BTreeMap::from([(0, 0.7), (1, 0.3), (2, 0.1)]);
        assert_eq!(acted(&states, &answers), Some(vec![0.5, 0.25, 0.1]));
        // a state without its applied force, or no commands (not a plant's): not this way
        let unknown = [state(0, 0.0), state(1, f64::NAN), state(2, 0.25)];
        assert_eq!(acted(&unknown, &answers), None);
        assert_eq!(acted(&states, &BTreeMap::new()), None);
        assert!(ForceSource::Acted.acted() && !ForceSource::Commands.acted());
    }

    #[test]
    fn the_samples_a_late_device_left_without_a_measurement_are_dropped_not_its_repeats() {
        let mut repeat = state(2, 0.25);
        repeat.capsule_position = 1.0;
        let mut same = state(4, 0.5);
        same.capsule_position = 1.0;
        let states = vec![
            state(0, f64::NAN),
            state(1, 0.5),
            repeat,
            state(3, f64::NAN),
            same,
        ];
        let seqs = |v: Vec<CapsuleState>| v.iter().map(|s| s.seq).collect::<Vec<_>>();
        // the sensor's reading sent twice stays; the sample without a measurement goes
        assert_eq!(seqs(device_samples(states.clone(), true)), [0, 1, 2, 4]);
        // not a plant's recording (no commands): every state stays
        assert_eq!(seqs(device_samples(states, false)), [0, 1, 2, 3, 4]);
    }
}
