//! Lock-step: what an unanswered sample leads to. The plant re-sends it while sim time stands
//! still; by default ([`OnSilence::Wait`]) it never steps without its answer, and ends the run
//! with an error once the controller is gone (its force publisher left the graph, or no answer
//! came for `lockstep_give_up_s` of wall time). [`OnSilence::ZeroForce`] is the old fallback,
//! asked for by name: after the command timeout the step runs at zero force, and the run then
//! depends on the wall clock.

use super::options::OnSilence;

/// What to do at a re-send tick.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Verdict {
    /// Send the sample again and keep waiting.
    Resend,
    /// Step at zero force (`--lockstep-on-silence zero-force`).
    ZeroForce,
    /// The controller is gone: end the run with this error.
    GiveUp(String),
}

/// How long a lock-step plant waits, and for what.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Silence {
    /// Wait or zero force.
    pub(super) on_silence: OnSilence,
    /// Before the first answer: how long to wait for one \[s\].
    pub(super) startup_s: f64,
    /// After it: how long without an answer is "gone" (wait), or the zero-force timeout \[s\].
    pub(super) give_up_s: f64,
    /// The command timeout (zero force only) \[s\].
    pub(super) command_timeout_s: f64,
}

/// Where the wait for the current sample stands.
#[derive(Debug, Clone, Copy)]
pub(super) struct Waiting {
    /// Sample seq.
    pub(super) seq: u64,
    /// Wall seconds since it went out (first time).
    pub(super) waited_s: f64,
    /// A command was ever accepted.
    pub(super) ever_commanded: bool,
    /// Matched publishers of the force topic now (`None`: in-process, no graph to ask).
    pub(super) publishers: Option<usize>,
}

impl Silence {
    /// A plant's, from its options and command timeout \[s\].
    pub(super) fn of(opts: &super::PlantOptions, command_timeout_s: f64) -> Silence {
        Silence {
            on_silence: opts.on_silence,
            startup_s: opts.startup_timeout.as_secs_f64(),
            give_up_s: opts.lockstep_give_up_s,
            command_timeout_s,
        }
    }

    /// The verdict for a sample unanswered as `w` says (an active plant's).
    pub(super) fn judge(&self, w: Waiting) -> Verdict {
        if self.on_silence == OnSilence::ZeroForce {
            let limit = if w.ever_commanded {
                self.command_timeout_s
            } else {
                self.startup_s
            };
            return if w.waited_s > limit {
                Verdict::ZeroForce
            } else {
                Verdict::Resend
            };
        }
        if !w.ever_commanded {
            return if w.waited_s > self.startup_s {
                Verdict::GiveUp(format!(
                    "lock-step: no controller answered seq {} within {} s (--startup-timeout-s): \
                     no step taken without its answer (--lockstep-on-silence zero-force steps at \
                     zero force instead)",
                    w.seq, self.startup_s
                ))
            } else {
                Verdict::Resend
            };
        }
        if w.publishers == Some(0) {
            return Verdict::GiveUp(format!(
                "lock-step: the controller is gone (no publisher of the force topic left in the \
                 graph) with seq {} unanswered after {:.3} s: the run ends here, at sim time \
                 frozen on that sample",
                w.seq, w.waited_s
            ));
        }
        if w.waited_s > self.give_up_s {
            return Verdict::GiveUp(format!(
                "lock-step: no answer to seq {} for {:.3} s (lockstep_give_up_s = {} s): the \
                 controller is taken as gone and the run ends here, at sim time frozen on that \
                 sample",
                w.seq, w.waited_s, self.give_up_s
            ));
        }
        Verdict::Resend
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn silence(on_silence: OnSilence) -> Silence {
        Silence {
            on_silence,
            startup_s: 30.0,
            give_up_s: 5.0,
            command_timeout_s: 0.1,
        }
    }

    fn waiting(waited_s: f64, ever_commanded: bool, publishers: Option<usize>) -> Waiting {
        Waiting {
            seq: 57,
            waited_s,
            ever_commanded,
            publishers,
        }
    }

    #[test]
    fn waiting_never_steps_and_gives_up_only_when_the_controller_is_gone() {
        let s = silence(OnSilence::Wait);
        // well past the command timeout: still re-sending
        assert_eq!(s.judge(waiting(1.0, true, Some(1))), Verdict::Resend);
        assert_eq!(s.judge(waiting(4.9, true, None)), Verdict::Resend);
        // the publisher left
        let Verdict::GiveUp(e) = s.judge(waiting(0.02, true, Some(0))) else {
            panic!("a controller that left the graph is gone");
        };
        assert!(e.contains("seq 57") && e.contains("gone"), "{e}");
        // silent too long (in-process: no graph to ask)
        let Verdict::GiveUp(e) = s.judge(waiting(5.1, true, None)) else {
            panic!("silent past lockstep_give_up_s");
        };
        assert!(e.contains("lockstep_give_up_s = 5 s"), "{e}");
        // before the first answer: the start-up wait, and no publisher is no reason yet
        assert_eq!(s.judge(waiting(29.0, false, Some(0))), Verdict::Resend);
        assert!(matches!(
            s.judge(waiting(31.0, false, Some(0))),
            Verdict::GiveUp(_)
        ));
    }

    #[test]
    fn zero_force_is_the_old_fallback_asked_for_by_name() {
        let s = silence(OnSilence::ZeroForce);
        assert_eq!(s.judge(waiting(0.05, true, Some(0))), Verdict::Resend);
        assert_eq!(s.judge(waiting(0.2, true, Some(1))), Verdict::ZeroForce);
        assert_eq!(s.judge(waiting(1.0, false, None)), Verdict::Resend);
        assert_eq!(s.judge(waiting(31.0, false, None)), Verdict::ZeroForce);
    }
}
