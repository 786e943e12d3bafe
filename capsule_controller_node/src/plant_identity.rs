//! Which plant the controller serves, told apart by the DDS writer of its state samples.
//!
//! The controller ignores samples older than the newest it saw (a late sample must not rewind
//! it). Before this, a restarted plant, whose samples start again at seq 0 and t = 0, was
//! therefore ignored until it passed the dead plant's last sample (issue 12: 3,973 samples
//! uncommanded after a kill at sample 3,973). Now every sample is attributed to its writer:
//!
//! - the first writer seen is the plant;
//! - a sample from another writer after the plant has been silent for `handover_s` is a
//!   **new plant** (restarted, or replaced): the controller starts afresh with it at once;
//! - a sample from another writer while the plant still publishes is a **second plant** on
//!   the same topic: ignored (the controller stays with the first) and reported loudly, since
//!   both plants apply every command the controller sends.

/// What a state sample's writer means for the controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// The plant being served.
    Current,
    /// A new plant, adopted now: the first one (`None`), or one that follows a plant silent
    /// for the given seconds (restarted or replaced).
    Adopted(Option<f64>),
    /// Another plant publishing at the same time as the current one: ignore its sample.
    Second,
}

/// Follows the writers of the state topic.
#[derive(Debug, Clone)]
pub struct PlantIdentity<Id> {
    handover_s: f64,
    current: Option<(Id, f64)>,
    ignored: u64,
}

impl<Id: Copy + Eq> PlantIdentity<Id> {
    /// How long \[s\] the current plant must be silent before another writer takes over. Well
    /// above a sample period and a lock-step re-send (20 ms), well below a process restart.
    pub const DEFAULT_HANDOVER_S: f64 = 0.05;

    /// A tracker that hands over after `handover_s` of silence.
    pub fn new(handover_s: f64) -> Self {
        PlantIdentity {
            handover_s,
            current: None,
            ignored: 0,
        }
    }

    /// Attributes a sample from writer `id` received at steady time `now` \[s\].
    pub fn observe(&mut self, id: Id, now: f64) -> Source {
        match self.current {
            None => {
                self.current = Some((id, now));
                Source::Adopted(None)
            }
            Some((cur, _)) if cur == id => {
                self.current = Some((id, now));
                Source::Current
            }
            Some((_, last)) if now - last > self.handover_s => {
                self.current = Some((id, now));
                Source::Adopted(Some(now - last))
            }
            Some(_) => {
                self.ignored += 1;
                Source::Second
            }
        }
    }

    /// Samples of a second plant ignored so far.
    pub fn ignored(&self) -> u64 {
        self.ignored
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_writer_after_silence_is_a_new_plant_and_one_alongside_is_a_second() {
        let mut p = PlantIdentity::new(0.05);
        assert_eq!(p.observe(1u32, 0.0), Source::Adopted(None));
        assert_eq!(p.observe(1, 0.001), Source::Current);
        // a second plant while the first one publishes
        assert_eq!(p.observe(2, 0.0015), Source::Second);
        assert_eq!(p.observe(1, 0.002), Source::Current);
        assert_eq!(p.ignored(), 1);
        // the first one dies; the next writer after the handover time is adopted
        match p.observe(3, 0.8) {
            Source::Adopted(Some(silent)) => assert!((silent - 0.798).abs() < 1e-12),
            other => panic!("{other:?}"),
        }
        assert_eq!(p.observe(3, 0.801), Source::Current);
        assert_eq!(p.observe(1, 0.802), Source::Second);
        assert_eq!(p.ignored(), 2);
    }
}
