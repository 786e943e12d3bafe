//! What the capsule nodes need of the ROS graph, without ros2-client's `Spinner`.
//!
//! The `Spinner` also subscribes every node to `/clock` (whether or not it uses sim time), so
//! each node received every clock sample, and the plant its own: measured 5-6 % of a core per
//! node at 1 kHz. The nodes need only two things from it, both taken here straight from DDS:
//!
//! - [`Graph`]: which remote readers and writers matched our endpoints (discovery events of the
//!   participant), to wait for subscribers or publishers before starting;
//! - ROS time, from our own `/clock` subscription only under `use_sim_time`: [`RosClock`](crate::clock::RosClock)
//!   (in [`crate::clock`]).
//!
//! The Spinner's parameter services (hard-wired to the Enhanced mapping) go with it; the loop
//! nodes serve their own in either mapping ([`crate::param_services`]). The command-line tools
//! (`capsule_ros`, `capsule replay`) keep the Spinner.

use std::{
    collections::{HashMap, HashSet},
    sync::{Arc, Mutex, PoisonError},
    time::Duration,
};

use futures::StreamExt;
use rustdds::{DomainParticipant, DomainParticipantStatusEvent, RTPSEntity, StatusEvented, GUID};
use tokio::sync::watch;

#[derive(Debug, Default)]
struct Matches {
    /// local writer -> matched remote readers
    readers_of: HashMap<GUID, HashSet<GUID>>,
    /// local reader -> matched remote writers
    writers_of: HashMap<GUID, HashSet<GUID>>,
    /// this participant's GUID (its own endpoints, same prefix, are not remote)
    own: Option<GUID>,
    /// every remote endpoint discovered, matched or not
    remote: HashMap<GUID, Endpoint>,
}

/// A remote reader or writer as discovery announced it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// Its GUID.
    pub guid: GUID,
    /// True for a writer, false for a reader.
    pub writer: bool,
    /// DDS topic name (`rt/...`).
    pub topic: String,
    /// DDS type name.
    pub type_name: String,
}

impl Matches {
    /// Applies one discovery event; true if the matches changed.
    fn apply(&mut self, event: &DomainParticipantStatusEvent) -> bool {
        use DomainParticipantStatusEvent as E;
        match event {
            E::RemoteReaderMatched {
                local_writer,
                remote_reader,
            } => self
                .readers_of
                .entry(*local_writer)
                .or_default()
                .insert(*remote_reader),
            E::RemoteWriterMatched {
                local_reader,
                remote_writer,
            } => self
                .writers_of
                .entry(*local_reader)
                .or_default()
                .insert(*remote_writer),
            E::ReaderDetected { reader: d } => self.detected(d, false),
            E::WriterDetected { writer: d } => self.detected(d, true),
            E::ReaderLost { guid, .. } => {
                let r = self.remote.remove(guid).is_some();
                remove(&mut self.readers_of, |g| g == guid) || r
            }
            E::WriterLost { guid, .. } => {
                let r = self.remote.remove(guid).is_some();
                remove(&mut self.writers_of, |g| g == guid) || r
            }
            E::ParticipantLost { id, .. } => {
                let before = self.remote.len();
                self.remote.retain(|g, _| g.prefix != *id);
                let r = remove(&mut self.readers_of, |g| g.prefix == *id);
                let w = remove(&mut self.writers_of, |g| g.prefix == *id);
                r || w || self.remote.len() != before
            }
            _ => false,
        }
    }
}

impl Matches {
    fn detected(&mut self, d: &rustdds::EndpointDescription, writer: bool) -> bool {
        if self.own.is_some_and(|o| o.prefix == d.guid.prefix) {
            return false;
        }
        let e = Endpoint {
            guid: d.guid,
            writer,
            topic: d.topic_name.clone(),
            type_name: d.type_name.clone(),
        };
        self.remote.insert(d.guid, e.clone()) != Some(e)
    }
}

fn remove(map: &mut HashMap<GUID, HashSet<GUID>>, gone: impl Fn(&GUID) -> bool) -> bool {
    let mut changed = false;
    for set in map.values_mut() {
        let before = set.len();
        set.retain(|g| !gone(g));
        changed |= set.len() != before;
    }
    changed
}

/// Matched remote endpoints of this participant's readers and writers, kept current by a task
/// that follows the participant's discovery events.
#[derive(Clone)]
pub struct Graph {
    matches: Arc<Mutex<Matches>>,
    changed: watch::Receiver<u64>,
}

/// The graphs followed, one per participant: a participant's status events come through one
/// channel, so a second follower would take half of them from the first (nodes composed in
/// one process share the participant, and so its graph).
static FOLLOWED: Mutex<Vec<Followed>> = Mutex::new(Vec::new());

/// A participant followed: its GUID, its matches (while the follower lives), its changes.
type Followed = (GUID, std::sync::Weak<Mutex<Matches>>, watch::Receiver<u64>);

impl Graph {
    /// Starts following `participant`'s discovery events (call before creating endpoints), or
    /// the graph already followed for it.
    pub fn follow(participant: DomainParticipant) -> Graph {
        let guid = participant.guid();
        let mut followed = FOLLOWED.lock().unwrap_or_else(PoisonError::into_inner);
        followed.retain(|(_, m, _)| m.strong_count() > 0);
        if let Some((matches, changed)) = followed
            .iter()
            .filter(|(g, _, _)| *g == guid)
            .find_map(|(_, m, c)| Some((m.upgrade()?, c.clone())))
        {
            return Graph { matches, changed };
        }
        let matches = Arc::new(Mutex::new(Matches {
            own: Some(guid),
            ..Matches::default()
        }));
        let (tx, changed) = watch::channel(0u64);
        followed.push((guid, Arc::downgrade(&matches), changed.clone()));
        let m = Arc::clone(&matches);
        tokio::spawn(async move {
            let listener = participant.status_listener();
            let events = listener.as_async_status_stream();
            futures::pin_mut!(events);
            while let Some(event) = events.next().await {
                let changed = m
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .apply(&event);
                if changed {
                    tx.send_modify(|v| *v += 1);
                }
            }
        });
        Graph { matches, changed }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Matches> {
        self.matches.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Remote readers matched by our writer `writer`.
    pub fn subscribers(&self, writer: GUID) -> usize {
        self.lock().readers_of.get(&writer).map_or(0, HashSet::len)
    }

    /// Remote writers matched by our reader `reader`.
    pub fn publishers(&self, reader: GUID) -> usize {
        self.lock().writers_of.get(&reader).map_or(0, HashSet::len)
    }

    /// Remote readers and writers on the DDS topic `topic` (`rt/...`), matched or not, of any
    /// type: what [`crate::conflicts`] checks.
    pub fn remote_endpoints(&self, topic: &str) -> Vec<Endpoint> {
        let mut v: Vec<Endpoint> = self
            .lock()
            .remote
            .values()
            .filter(|e| e.topic == topic)
            .cloned()
            .collect();
        v.sort_by_key(|e| e.guid);
        v
    }

    /// How many remote writers (`writers`) or readers on the DDS topic `topic`, of the
    /// participant whose GUID begins with `participant`, have matched our endpoints.
    pub fn matched_from(&self, topic: &str, participant: &[u8], writers: bool) -> usize {
        let m = self.lock();
        let matched = if writers {
            &m.writers_of
        } else {
            &m.readers_of
        };
        m.remote
            .values()
            .filter(|e| {
                e.writer == writers
                    && e.topic == topic
                    && e.guid.to_bytes().starts_with(participant)
                    && matched.values().any(|s| s.contains(&e.guid))
            })
            .count()
    }

    /// Waits until the participant whose GUID begins with `participant` has as many readers
    /// on `replies` as writers on `requests` matched, and at least one: each of its clients'
    /// reply readers, as far as the graph can tell ([`crate::service`]); false after `timeout`.
    pub async fn wait_client_readers(
        &self,
        requests: &str,
        replies: &str,
        participant: &[u8],
        timeout: Duration,
    ) -> bool {
        self.wait(1, timeout, |g| {
            let writers = g.matched_from(requests, participant, true);
            let readers = g.matched_from(replies, participant, false);
            usize::from(readers >= writers.max(1))
        })
        .await
    }

    /// A receiver that changes whenever the graph does.
    pub fn changes(&self) -> watch::Receiver<u64> {
        self.changed.clone()
    }

    /// Waits until `count()` reaches `n`; false after `timeout`.
    async fn wait(&self, n: usize, timeout: Duration, count: impl Fn(&Self) -> usize) -> bool {
        let mut changed = self.changed.clone();
        let reached = async {
            loop {
                changed.borrow_and_update();
                if count(self) >= n {
                    return;
                }
                if changed.changed().await.is_err() {
                    // the follower ended (participant gone): nothing will change any more
                    std::future::pending::<()>().await;
                }
            }
        };
        tokio::time::timeout(timeout, reached).await.is_ok()
    }

    /// Waits for `n` subscribers of our writer `writer`; false after `timeout`.
    pub async fn wait_subscribers(&self, writer: GUID, n: usize, timeout: Duration) -> bool {
        self.wait(n, timeout, |g| g.subscribers(writer)).await
    }

    /// Waits for `n` publishers of our reader `reader`; false after `timeout`.
    pub async fn wait_publishers(&self, reader: GUID, n: usize, timeout: Duration) -> bool {
        self.wait(n, timeout, |g| g.publishers(reader)).await
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh GUID (random prefix): stands for a remote endpoint.
    fn guid() -> GUID {
        GUID::new_participant_guid()
    }

    /// A discovery event announcing `guid` on `topic` (a writer or a reader).
    fn detected(guid: GUID, topic: &str, writer: bool) -> DomainParticipantStatusEvent {
        let d = rustdds::EndpointDescription {
            updated_time: chrono::Utc::now(),
            guid,
            topic_name: topic.to_string(),
            type_name: "T".to_string(),
            qos: rustdds::QosPolicies::qos_none(),
            user_data: Vec::new(),
        };
        if writer {
            DomainParticipantStatusEvent::WriterDetected { writer: d }
        } else {
            DomainParticipantStatusEvent::ReaderDetected { reader: d }
        }
    }

    #[test]
    fn a_participant_s_readers_and_writers_are_counted_once_matched() {
        use DomainParticipantStatusEvent as E;
        let (rq, rr) = ("rq/s/xRequest", "rr/s/xReply");
        let (our_reader, our_writer) = (guid(), guid());
        let client = guid();
        // one of the client's endpoints: its prefix, entity key `key`, a user writer (0x03) or
        // reader (0x04) without key
        let endpoint = |key: u8, writer: bool| {
            let mut b = client.to_bytes();
            b[12..].copy_from_slice(&[0, 0, key, if writer { 0x03 } else { 0x04 }]);
            GUID::from_bytes(b)
        };
        let graph = Graph {
            matches: Arc::new(Mutex::new(Matches::default())),
            changed: watch::channel(0).1,
        };
        let apply = |e: E| graph.lock().apply(&e);
        let prefix = &client.to_bytes()[..8];
        // the first client: its writer and reader, both matched
        let (w1, r1) = (endpoint(1, true), endpoint(2, false));
        apply(detected(w1, rq, true));
        apply(detected(r1, rr, false));
        assert_eq!(
            graph.matched_from(rr, prefix, false),
            0,
            "detected, not matched"
        );
        apply(E::RemoteWriterMatched {
            local_reader: our_reader,
            remote_writer: w1,
        });
        apply(E::RemoteReaderMatched {
            local_writer: our_writer,
            remote_reader: r1,
        });
        assert_eq!(graph.matched_from(rq, prefix, true), 1);
        assert_eq!(graph.matched_from(rr, prefix, false), 1);
        // the next client's writer has matched, its reader not yet: one reader for two writers
        let (w2, r2) = (endpoint(3, true), endpoint(4, false));
        apply(detected(w2, rq, true));
        apply(E::RemoteWriterMatched {
            local_reader: our_reader,
            remote_writer: w2,
        });
        assert_eq!(graph.matched_from(rq, prefix, true), 2);
        assert_eq!(graph.matched_from(rr, prefix, false), 1);
        apply(detected(r2, rr, false));
        apply(E::RemoteReaderMatched {
            local_writer: our_writer,
            remote_reader: r2,
        });
        assert_eq!(graph.matched_from(rr, prefix, false), 2);
        // another participant's endpoints, and other topics, are not counted
        assert_eq!(graph.matched_from(rr, &guid().to_bytes()[..8], false), 0);
        assert_eq!(graph.matched_from("rr/other", prefix, false), 0);
    }

    #[test]
    fn matches_follow_discovery_events() {
        use DomainParticipantStatusEvent as E;
        let mut m = Matches::default();
        let (w, r1, r2) = (guid(), guid(), guid());
        assert!(m.apply(&E::RemoteReaderMatched {
            local_writer: w,
            remote_reader: r1
        }));
        // a repeated match changes nothing
        assert!(!m.apply(&E::RemoteReaderMatched {
            local_writer: w,
            remote_reader: r1
        }));
        assert!(m.apply(&E::RemoteReaderMatched {
            local_writer: w,
            remote_reader: r2
        }));
        assert_eq!(m.readers_of[&w].len(), 2);
        assert!(m.apply(&E::ReaderLost {
            guid: r1,
            reason: rustdds::LostReason::Timeout {
                lease: rustdds::Duration::from_secs(1),
                elapsed: rustdds::Duration::from_secs(2),
            }
        }));
        assert_eq!(m.readers_of[&w].len(), 1);
        assert!(m.apply(&E::ParticipantLost {
            id: r2.prefix,
            reason: rustdds::LostReason::Disposed,
        }));
        assert!(m.readers_of[&w].is_empty());
    }
}
