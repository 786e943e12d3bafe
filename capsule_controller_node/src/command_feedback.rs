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

/// The plant's verdict on our commands, judged per window of samples.
#[derive(Debug, Clone, Default)]
pub struct CommandFeedback {
    window_start: Option<u32>,
    samples: u32,
    stale: u32,
    refused: bool,
    taken_once: bool,
}

impl CommandFeedback {
    /// Samples per verdict.
    pub const WINDOW: u32 = 50;

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
            ..CommandFeedback::default()
        };
        changed.then_some(refused)
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
}
