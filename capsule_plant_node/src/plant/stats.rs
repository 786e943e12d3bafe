//! Loop statistics (which samples were answered, when) and the run's one-line JSON summary.

use std::collections::VecDeque;

use capsule_msgs::CapsuleState;
use serde::Serialize;

use capsule_hardware::latency::LatencyHistogram;

/// Loop statistics: for every published sample, whether and when a command answering it
/// (same seq) arrived, also after the next sample went out.
#[derive(Debug, Clone, Default)]
pub struct LoopStats {
    /// Latencies from publishing a sample to receiving its first answer (constant memory).
    pub latencies: LatencyHistogram,
    /// Real time: how late each sample went out after its due time (`start + k / rate`).
    pub lateness: LatencyHistogram,
    /// Samples published.
    pub published: u64,
    /// Samples published before the first answer (discovery, controller start-up).
    pub before_first_answer: u64,
    /// Samples after the first answer that never got one: lost.
    pub unanswered: u64,
    /// Answers that arrived after the next sample was out (applied one sample late).
    pub late_answers: u64,
    /// Lock-step: samples sent again while unanswered (one per `retransmit`).
    pub resent: u64,
    /// Commands beyond the force limit, applied saturated at it.
    pub saturated_commands: u64,
    /// Graph conflicts seen (another plant, a foreign type on our topics): [`capsule_ros_base::conflicts`].
    pub graph_conflicts: u64,
    /// The emergency stop was engaged at the last step.
    pub emergency_stop: bool,
    /// How the device is doing after the last step (`None`: the simulator).
    pub device: Option<super::SourceHealth>,
    /// In-process transport: the state's DDS copies (`None` over DDS).
    pub dds_copies: Option<DdsCopyStats>,
    /// When the first and the last sample went out (the loop's clock, s).
    pub(super) published_span: Option<(f64, f64)>,
    pub(super) in_flight: VecDeque<(u64, f64, bool)>,
    pub(super) answered_any: bool,
}

/// What became of the state's DDS copies in a composed process ([`crate::intra_process`]).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct DdsCopyStats {
    /// Published on DDS.
    pub published: u64,
    /// Not published: no DDS reader had matched the state topic.
    pub unread: u64,
    /// Dropped: the publisher thread's queue was full.
    pub dropped: u64,
}

impl LoopStats {
    const WINDOW: usize = 4096;

    pub(super) fn retire_front(&mut self) {
        if let Some((_, _, answered)) = self.in_flight.pop_front() {
            if !answered {
                self.unanswered += 1;
            }
        }
    }

    /// Notes sample `seq` published at steady time `now`.
    pub fn on_publish(&mut self, seq: u64, now: f64) {
        self.published += 1;
        let first = self.published_span.map_or(now, |(first, _)| first);
        self.published_span = Some((first, now));
        self.in_flight.push_back((seq, now, false));
        while self.in_flight.len() > Self::WINDOW {
            self.retire_front();
        }
    }

    /// Notes a command answering `seq` at `now`, while sample `current` is the newest.
    pub fn on_answer(&mut self, seq: u64, now: f64, current: u64) {
        let Ok(i) = self.in_flight.binary_search_by_key(&seq, |e| e.0) else {
            return;
        };
        if self.in_flight[i].2 {
            return;
        }
        self.in_flight[i].2 = true;
        self.latencies.record(now - self.in_flight[i].1);
        if seq < current {
            self.late_answers += 1;
        }
        if !self.answered_any {
            self.answered_any = true;
            let before = self.in_flight.iter().take_while(|e| e.0 < seq).count();
            self.before_first_answer += before as u64;
            self.in_flight.drain(..before);
        }
    }

    /// Ends the run: the newest sample may still be in flight; every older one without an
    /// answer is lost (all of them count as start-up if nothing was ever answered).
    pub fn finish(&mut self) {
        self.in_flight.pop_back();
        if !self.answered_any {
            self.before_first_answer += self.in_flight.len() as u64;
            self.in_flight.clear();
        }
        while !self.in_flight.is_empty() {
            self.retire_front();
        }
    }

    /// `(p50, p99, max)` of the latencies \[s\] (to within [`LatencyHistogram::RELATIVE_ERROR`];
    /// max exact), `None` if none.
    pub fn percentiles(&self) -> Option<(f64, f64, f64)> {
        let l = &self.latencies;
        Some((l.quantile(0.5)?, l.quantile(0.99)?, l.max()?))
    }
}

/// A one-line JSON summary of a run: loop statistics and the last sample (floats printed
/// round-trip exact, so two runs compare bit for bit; a value not measured is `null`).
pub fn summary_json(stats: &LoopStats, last: &CapsuleState, wall_s: f64) -> String {
    let (p50, p99, max) = match stats.percentiles() {
        Some((a, b, c)) => (Some(a), Some(b), Some(c)),
        None => (None, None, None),
    };
    let summary = Summary {
        samples: stats.published,
        before_first_answer: stats.before_first_answer,
        unanswered: stats.unanswered,
        late_answers: stats.late_answers,
        resent: stats.resent,
        latency_p50_s: p50,
        latency_p99_s: p99,
        latency_max_s: max,
        lateness_p99_s: stats.lateness.quantile(0.99),
        lateness_max_s: stats.lateness.max(),
        wall_s,
        loop_s: stats.published_span.map(|(first, last)| last - first),
        rejected_commands: last.rejected_commands,
        saturated_commands: stats.saturated_commands,
        graph_conflicts: stats.graph_conflicts,
        dds_copies: stats.dds_copies,
        device: stats.device.as_ref().map(|d| Device {
            label: d.label.clone(),
            fault: d.fault.clone(),
            values: d
                .values
                .iter()
                .map(|(k, v)| (k.to_string(), v.clone()))
                .collect(),
        }),
        last: LastSample {
            seq: last.seq,
            stamp_ns: last.header.stamp.to_nanos(),
            mass_position: last.mass_position,
            mass_velocity: last.mass_velocity,
            capsule_position: last.capsule_position,
            capsule_velocity: last.capsule_velocity,
            actuator_force: last.actuator_force,
            command_stale: last.command_stale,
        },
    };
    // plain numbers and booleans (a non-finite float becomes null): cannot fail
    serde_json::to_string(&summary).unwrap_or_default()
}

/// The summary's fields, in the order they are printed.
#[derive(Serialize)]
struct Summary {
    samples: u64,
    before_first_answer: u64,
    unanswered: u64,
    late_answers: u64,
    /// Lock-step: re-sends of unanswered samples.
    resent: u64,
    latency_p50_s: Option<f64>,
    latency_p99_s: Option<f64>,
    latency_max_s: Option<f64>,
    /// Real time: how late samples went out after their due time (`null` in lock-step).
    lateness_p99_s: Option<f64>,
    lateness_max_s: Option<f64>,
    wall_s: f64,
    /// From the first sample out to the last (the loop alone: no start-up, no shutdown).
    loop_s: Option<f64>,
    rejected_commands: u32,
    saturated_commands: u64,
    graph_conflicts: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    dds_copies: Option<DdsCopyStats>,
    #[serde(skip_serializing_if = "Option::is_none")]
    device: Option<Device>,
    last: LastSample,
}

/// How the device was doing at the end (a driver's plant only).
#[derive(Serialize)]
struct Device {
    label: String,
    fault: Option<String>,
    values: std::collections::BTreeMap<String, String>,
}

/// The last sample, SI.
#[derive(Serialize)]
struct LastSample {
    seq: u64,
    stamp_ns: i64,
    mass_position: f64,
    mass_velocity: f64,
    capsule_position: f64,
    capsule_velocity: f64,
    actuator_force: f64,
    command_stale: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_hardware::latency::LatencyHistogram;

    #[test]
    fn stats_split_startup_lost_and_late_answers() {
        let mut st = LoopStats::default();
        for k in 0..10 {
            st.on_publish(k, k as f64);
        }
        st.on_answer(3, 3.5, 3); // first answer: 0..3 were start-up
        st.on_answer(5, 6.2, 6); // late: sample 6 already out
        st.on_answer(5, 6.3, 6); // repeat: ignored
        st.on_answer(42, 7.0, 9); // unknown seq: ignored
        st.finish(); // 9 in flight; 4, 6, 7, 8 lost
        assert_eq!(st.before_first_answer, 3);
        assert_eq!(st.late_answers, 1);
        assert_eq!(st.unanswered, 4);
        assert_eq!(st.latencies.count(), 2);
        assert_eq!(st.latencies.max(), Some(1.2));
    }

    #[test]
    fn percentiles_are_order_statistics() {
        let mut stats = LoopStats::default();
        for k in 1..=100 {
            stats.latencies.record(f64::from(k) * 1e-3);
        }
        let (p50, p99, max) = stats.percentiles().unwrap_or_default();
        let close = |a: f64, b: f64| (a - b).abs() <= b * LatencyHistogram::RELATIVE_ERROR;
        assert!(close(p50, 51e-3) && close(p99, 99e-3), "{p50} {p99}");
        assert_eq!(max, 100e-3);
        assert_eq!(LoopStats::default().percentiles(), None);
    }

    #[test]
    fn the_summary_is_json_with_exact_floats_and_null_for_what_was_not_measured() {
        let last = CapsuleState {
            seq: 7,
            mass_position: 0.1 + 0.2,
            capsule_velocity: -1.0e-300,
            ..CapsuleState::default()
        };
        let text = summary_json(&LoopStats::default(), &last, 1.5);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        assert_eq!(v["samples"], 0, "{text}");
        assert!(v["latency_p99_s"].is_null(), "{text}");
        assert_eq!(v["last"]["seq"], 7, "{text}");
        assert_eq!(
            v["last"]["mass_position"].as_f64(),
            Some(0.1 + 0.2),
            "{text}"
        );
        assert_eq!(
            v["last"]["capsule_velocity"].as_f64(),
            Some(-1.0e-300),
            "{text}"
        );
        assert!(text.starts_with("{\"samples\""), "{text}");
    }
}
