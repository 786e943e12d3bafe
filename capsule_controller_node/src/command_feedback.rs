//! Whether the plant takes the controller's commands, read from what every state sample says
//! (`rejected_commands`, the plant's running count of refused commands, and `command_stale`,
//! its watchdog), so the controller does not claim to command a plant that refuses it (issue
//! 12: after one command stamped in the far future, the plant refused every later one and the
//! controller still reported `commanding = true`).
//!
//! Judged per window of [`CommandFeedback::WINDOW`] new samples: the plant refuses us if
//! at least half of them added a refusal, or if, having taken our commands before, it reported
//! a stale command on every one of them although we answered each. (Before its first command a
//! plant is stale by definition; on a loaded host the first answer can take more than a window.)
//!
//! Whether the plant applies the commands it takes, read from `actuator_force`: an inactive
//! plant (its lifecycle configured, not active) takes and counts our commands, says it is not
//! stale, and applies zero force. [`CommandFeedback::INACTIVE_RUN`] new samples in a row applying
//! exactly zero while our command answering the sample before was not zero mean inactive (an
//! engaged emergency stop looks the same); one sample applying a force (or not saying, NaN: a
//! device that does not report it) means active. Only new samples count: a lock-step plant that
//! is inactive stands still, re-sending one sample, and cannot be told from a paused one.

/// The plant's verdict on our commands, judged per window of samples.
#[derive(Debug, Clone, Default)]
pub struct CommandFeedback {
    window_start: Option<u32>,
    samples: u32,
    stale: u32,
    refused: bool,
    taken_once: bool,
    /// New samples in a row applying zero force while we commanded one.
    zeros: u32,
    inactive: bool,
}

impl CommandFeedback {
    /// Samples per verdict.
    pub const WINDOW: u32 = 50;
    /// New samples in a row applying zero force that mean an inactive plant (20 ms at 1 kHz).
    pub const INACTIVE_RUN: u32 = 20;

    /// Notes a new sample answered by a command; returns the new verdict when it changed.
    pub fn sample(&mut self, rejected_commands: u32, command_stale: bool) -> Option<bool> {
        let start = *self.window_start.get_or_insert(rejected_commands);
        self.samples += 1;
        self.stale += u32::from(command_stale);
        self.taken_once |= !command_stale;
        if self.samples < Self::WINDOW {
            return None;
        }
        let added = rejected_commands.wrapping_sub(start);
        let refused = 2 * added >= Self::WINDOW || (self.taken_once && self.stale == self.samples);
        let changed = refused != self.refused;
        *self = CommandFeedback {
            window_start: Some(rejected_commands),
            refused,
            taken_once: self.taken_once,
            zeros: self.zeros,
            inactive: self.inactive,
            ..CommandFeedback::default()
        };
        changed.then_some(refused)
    }

    /// Notes the force a new sample says was applied (`applied_n`, NaN: not said) after our
    /// command `commanded_n` answered the sample before (`None`: none did); returns the new
    /// verdict on whether the plant is inactive when it changed.
    pub fn applied(
        &mut self,
        applied_n: f64,
        commanded_n: Option<f64>,
        command_stale: bool,
    ) -> Option<bool> {
        // a stale plant applies zero by its watchdog, and a zero command proves nothing
        if command_stale || commanded_n.is_none_or(|f| f == 0.0) {
            return None;
        }
        let inactive = if applied_n == 0.0 {
            self.zeros = self.zeros.saturating_add(1);
            self.zeros >= Self::INACTIVE_RUN
        } else {
            self.zeros = 0;
            false
        };
        let changed = inactive != self.inactive;
        self.inactive = inactive;
        changed.then_some(inactive)
    }

    /// True while the plant applies none of our commands (inactive, or its emergency stop).
    pub fn inactive(&self) -> bool {
        self.inactive
    }

    /// True while the plant refuses our commands.
    pub fn refused(&self) -> bool {
        self.refused
    }

    /// Forgets everything (a new plant).
    pub fn reset(&mut self) {
        *self = CommandFeedback::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_on_half_the_window_or_a_stale_plant_mean_refused() {
        let w = CommandFeedback::WINDOW;
        let mut f = CommandFeedback::default();
        // a plant not yet commanded is stale: not a refusal
        let changes: Vec<bool> = (0..2 * w).filter_map(|_| f.sample(0, true)).collect();
        assert!(changes.is_empty() && !f.refused());
        // accepted: a few refusals (say NaN from elsewhere) do not count as refused
        let changes: Vec<bool> = (0..w).filter_map(|k| f.sample(k / 10, false)).collect();
        assert!(changes.is_empty() && !f.refused());
        // every command refused as late
        let mut rejected = 5;
        let mut changes = Vec::new();
        for _ in 0..2 * w {
            rejected += 1;
            changes.extend(f.sample(rejected, false));
        }
        assert_eq!(changes, [true]);
        assert!(f.refused());
        // taken again
        let changes: Vec<bool> = (0..w).filter_map(|_| f.sample(rejected, false)).collect();
        assert_eq!(changes, [false]);
        // a plant that keeps saying its command is stale though we answer every sample
        let changes: Vec<bool> = (0..w).filter_map(|_| f.sample(rejected, true)).collect();
        assert_eq!(changes, [true]);
        f.reset();
        assert!(!f.refused());
    }

    #[test]
    fn a_plant_applying_zero_force_on_a_run_of_samples_is_inactive() {
        let run = CommandFeedback::INACTIVE_RUN;
        let mut f = CommandFeedback::default();
        // zero applied while stale, or after a zero command or none: no evidence
        assert_eq!(f.applied(0.0, Some(0.1), true), None);
        assert_eq!(f.applied(0.0, Some(0.0), false), None);
        assert_eq!(f.applied(0.0, None, false), None);
        assert!(!f.inactive());
        // zero applied on a run of samples after non-zero commands: inactive, once
        let changes: Vec<bool> = (0..2 * run)
            .filter_map(|_| f.applied(0.0, Some(0.1), false))
            .collect();
        assert_eq!(changes, [true]);
        assert!(f.inactive());
        // the refusal windows leave the verdict alone
        for _ in 0..CommandFeedback::WINDOW {
            f.sample(0, false);
        }
        assert!(f.inactive());
        // one force applied (activated): active at once
        assert_eq!(f.applied(0.09, Some(0.1), false), Some(false));
        // a run one short of the length is not enough; a device that does not say (NaN) is
        // taken as applying
        let changes: Vec<bool> = (0..run - 1)
            .filter_map(|_| f.applied(0.0, Some(0.1), false))
            .collect();
        assert!(changes.is_empty());
        assert_eq!(f.applied(f64::NAN, Some(0.1), false), None);
        let changes: Vec<bool> = (0..run - 1)
            .filter_map(|_| f.applied(0.0, Some(0.1), false))
            .collect();
        assert!(changes.is_empty() && !f.inactive());
        f.reset();
        assert!(!f.inactive());
    }
}
