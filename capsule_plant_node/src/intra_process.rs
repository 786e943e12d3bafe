//! The state and force transport of plant and controller composed in one process
//! (`capsule_container`, issue 31): ROS 2's composition with intra-process delivery.
//!
//! Each node takes its transport from outside ([`Transport`]): over DDS (separate processes,
//! the default of the node binaries), or in-process through a [`Link`]. In-process, the plant's
//! loop hands each state sample to the controller's state handler and takes its command back,
//! on the loop's own thread: no serialisation, no DDS round trip, no thread wake-up on the
//! loop's critical path (a hand-off to another thread costs two wake-ups per step, which is
//! what holds lock-step through DDS to a few thousand steps per second). The DDS copies of state
//! and force still go out for the rest of the graph (recorder, Foxglove, RViz, rclcpp peers),
//! from a publisher thread of their own fed by a bounded queue ([`DdsCopies`]): what does not
//! fit is dropped and counted, never silently.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TryRecvError, TrySendError};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use capsule_msgs::{ActuatorForce, CapsuleState};
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::graph::Graph;
use ros2_client::dds::Publisher;
use ros2_client::Gid;
use serde::Serialize;
use tracing::{error, warn};

/// Where a node's state and force go and come from.
#[derive(Clone, Default)]
pub enum Transport {
    /// DDS topics (the node on its own, as any ROS 2 node).
    #[default]
    Dds,
    /// The [`Link`] to the other node of the process; DDS copies for everyone else.
    InProcess(Link),
}

/// The controller's state handler as the link calls it: the command answering a state sample
/// from the plant `Gid`, or `None` (not answered).
pub type Answer = dyn Fn(&CapsuleState, Gid) -> Option<ActuatorForce> + Send + Sync;

/// A watcher of the link (the composed Foxglove bridge): each state sample handed over and the
/// controller's answer to it, on the loop's thread (so it must cost next to nothing).
pub type Watch = dyn Fn(&CapsuleState, Option<&ActuatorForce>) + Send + Sync;

/// The in-process link between a plant and a controller: the controller attaches its state
/// handler, the plant calls it with each sample it publishes.
#[derive(Clone, Default)]
pub struct Link {
    controller: Arc<OnceLock<Box<Answer>>>,
    /// Set when the controller's handler panicked: no answer from then on.
    broken: Arc<AtomicBool>,
    watcher: Arc<OnceLock<Box<Watch>>>,
}

impl Link {
    /// A link without a controller yet.
    pub fn new() -> Link {
        Link::default()
    }

    /// Attaches the controller's state handler (once; a second one is refused).
    pub fn attach(&self, answer: Box<Answer>) -> Result<()> {
        if self.controller.set(answer).is_err() {
            capsule_ros_base::error::bail!("a second controller on one in-process link");
        }
        Ok(())
    }

    /// Attaches a watcher of every sample and answer (once; a second one is refused).
    pub fn watch(&self, watcher: Box<Watch>) -> Result<()> {
        if self.watcher.set(watcher).is_err() {
            capsule_ros_base::error::bail!("a second watcher on one in-process link");
        }
        Ok(())
    }

    /// Whether a controller is attached.
    pub fn is_attached(&self) -> bool {
        self.controller.get().is_some()
    }

    /// The controller's answer to `state` from the plant `plant`; `None` while no controller
    /// is attached, when it does not answer, and after it panicked (named in the log once: the
    /// plant then applies zero force after its command timeout).
    /// The watcher, if any, sees the sample and the answer.
    pub fn answer(&self, state: &CapsuleState, plant: Gid) -> Option<ActuatorForce> {
        let answer = self.controller_answer(state, plant);
        if let Some(watch) = self.watcher.get() {
            watch(state, answer.as_ref());
        }
        answer
    }

    fn controller_answer(&self, state: &CapsuleState, plant: Gid) -> Option<ActuatorForce> {
        if self.broken.load(Ordering::Relaxed) {
            return None;
        }
        let handler = self.controller.get()?;
        match catch_unwind(AssertUnwindSafe(|| handler(state, plant))) {
            Ok(answer) => answer,
            Err(_) => {
                self.broken.store(true, Ordering::Relaxed);
                error!(
                    "the controller panicked on state seq {}: it answers nothing from now on; the plant applies zero force after its command timeout",
                    state.seq
                );
                None
            }
        }
    }
}

/// What became of the DDS copies of one topic.
#[derive(Debug, Default)]
pub struct CopyCounts {
    /// Published on DDS.
    pub published: AtomicU64,
    /// Not published because no DDS reader had matched the topic (nobody to send to).
    pub unread: AtomicU64,
    /// Dropped because the queue was full (the publisher thread fell behind).
    pub dropped: AtomicU64,
}

impl CopyCounts {
    /// `published / unread / dropped` for the log.
    pub fn describe(&self) -> String {
        format!(
            "{} published, {} with no DDS reader, {} DROPPED (queue full)",
            self.published.load(Ordering::Relaxed),
            self.unread.load(Ordering::Relaxed),
            self.dropped.load(Ordering::Relaxed)
        )
    }
}

/// The DDS copies of an in-process topic: a bounded queue the loop pushes to without waiting,
/// and a thread that publishes what it holds every [`COPIES_PERIOD`] (polled, so a push
/// never wakes it: no wake-up per sample on the loop's CPU).
pub struct DdsCopies<M> {
    /// The queue (`None` once dropped: the thread publishes the rest and ends).
    tx: Option<SyncSender<M>>,
    /// Says when the thread has ended (in a mutex: the controller's copies are shared).
    ended: std::sync::Mutex<Receiver<()>>,
    counts: Arc<CopyCounts>,
    topic: String,
}

/// How long the end of a run waits for the copies still queued to go out.
const COPIES_END_WAIT: Duration = Duration::from_secs(2);

impl<M> Drop for DdsCopies<M> {
    /// Closes the queue and waits (at most 2 s) until the thread has published
    /// what it held, so that the counts are final.
    fn drop(&mut self) {
        self.tx.take();
        let ended = self
            .ended
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if ended.recv_timeout(COPIES_END_WAIT).is_err() {
            warn!(
                "DDS copies of {}: the publisher thread had not ended {COPIES_END_WAIT:?} after the run ({})",
                self.topic,
                self.counts.describe()
            );
        }
    }
}

/// How often a [`DdsCopies`] publisher thread takes what its queue holds.
pub const COPIES_PERIOD: Duration = Duration::from_millis(1);
/// Copies a [`DdsCopies`] queue holds (at 50,000 samples/s, 160 ms of them).
pub const COPIES_CAPACITY: usize = 8192;

impl<M: Serialize + Send + 'static> DdsCopies<M> {
    /// Starts the publisher thread of `publisher` (on `topic`, for the logs); it publishes only
    /// while `graph` says a reader matched it.
    pub fn start(topic: &str, publisher: Publisher<M>, graph: Graph) -> Result<DdsCopies<M>> {
        let (tx, rx) = sync_channel(COPIES_CAPACITY);
        let (done, ended) = std::sync::mpsc::channel();
        let counts = Arc::new(CopyCounts::default());
        let c = counts.clone();
        std::thread::Builder::new()
            .name("dds_copies".into())
            .spawn(move || {
                publish_copies(rx, &publisher, &graph, &c);
                let _ = done.send(());
            })
            .with_context(|| format!("cannot start the DDS publisher thread of {topic}"))?;
        Ok(DdsCopies {
            tx: Some(tx),
            ended: std::sync::Mutex::new(ended),
            counts,
            topic: topic.to_string(),
        })
    }

    /// Queues a copy; dropped and counted if the queue is full (logged at the first drop and
    /// then at powers of two).
    pub fn push(&self, msg: M) {
        let sent = match &self.tx {
            Some(tx) => tx.try_send(msg),
            None => Err(TrySendError::Disconnected(msg)),
        };
        match sent {
            Ok(()) => {}
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                let n = self.counts.dropped.fetch_add(1, Ordering::Relaxed) + 1;
                if n.is_power_of_two() {
                    warn!(
                        "DDS copies of {} DROPPED: {n} so far (the publisher thread falls behind the loop; in-process delivery is not affected)",
                        self.topic
                    );
                }
            }
        }
    }

    /// The counts so far.
    pub fn counts(&self) -> Arc<CopyCounts> {
        self.counts.clone()
    }
}

/// The publisher thread: every period, everything queued, published if anyone reads it; ends
/// when the queue's sender is gone (after publishing the rest).
fn publish_copies<M: Serialize>(
    rx: Receiver<M>,
    publisher: &Publisher<M>,
    graph: &Graph,
    counts: &CopyCounts,
) {
    let guid = publisher.guid();
    loop {
        std::thread::sleep(COPIES_PERIOD);
        let wanted = graph.subscribers(guid) > 0;
        loop {
            match rx.try_recv() {
                Ok(msg) if wanted => {
                    match publisher.publish(msg) {
                        Ok(()) => counts.published.fetch_add(1, Ordering::Relaxed),
                        Err(_) => counts.dropped.fetch_add(1, Ordering::Relaxed),
                    };
                }
                Ok(_) => {
                    counts.unread.fetch_add(1, Ordering::Relaxed);
                }
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(seq: u64) -> CapsuleState {
        CapsuleState {
            seq,
            ..CapsuleState::default()
        }
    }

    #[test]
    fn a_link_answers_through_the_attached_controller_only() {
        let link = Link::new();
        let gid = Gid::from([7; 16]);
        assert!(link.answer(&state(1), gid).is_none(), "no controller yet");
        link.attach(Box::new(|s: &CapsuleState, _| {
            Some(ActuatorForce {
                state_seq: s.seq,
                force: 2.0 * s.seq as f64,
                ..ActuatorForce::default()
            })
        }))
        .expect("first controller");
        let cmd = link.answer(&state(3), gid).expect("an answer");
        assert_eq!((cmd.state_seq, cmd.force), (3, 6.0));
        assert!(
            link.attach(Box::new(|_, _| None)).is_err(),
            "a second controller"
        );
    }

    #[test]
    fn a_watcher_sees_every_sample_and_its_answer() {
        let link = Link::new();
        let gid = Gid::from([7; 16]);
        let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
        let s = seen.clone();
        link.watch(Box::new(
            move |st: &CapsuleState, a: Option<&ActuatorForce>| {
                if let Ok(mut v) = s.lock() {
                    v.push((st.seq, a.map(|c| c.force)));
                }
            },
        ))
        .expect("first watcher");
        assert!(link.answer(&state(1), gid).is_none(), "no controller yet");
        link.attach(Box::new(|s: &CapsuleState, _| {
            Some(ActuatorForce {
                force: s.seq as f64,
                ..ActuatorForce::default()
            })
        }))
        .expect("attach");
        assert!(link.answer(&state(2), gid).is_some());
        assert!(link.watch(Box::new(|_, _| {})).is_err(), "a second watcher");
        let seen = seen.lock().map(|v| v.clone()).unwrap_or_default();
        assert_eq!(seen, [(1, None), (2, Some(2.0))]);
    }

    #[test]
    fn a_panicking_controller_is_named_and_answers_nothing_after() {
        let link = Link::new();
        let gid = Gid::from([7; 16]);
        let calls = Arc::new(AtomicU64::new(0));
        let c = calls.clone();
        link.attach(Box::new(move |s: &CapsuleState, _| {
            c.fetch_add(1, Ordering::Relaxed);
            assert!(s.seq < 2, "controller bug");
            Some(ActuatorForce::default())
        }))
        .expect("attach");
        assert!(link.answer(&state(1), gid).is_some());
        assert!(link.answer(&state(2), gid).is_none(), "panicked");
        assert!(link.answer(&state(1), gid).is_none(), "broken from then on");
        assert_eq!(calls.load(Ordering::Relaxed), 2);
    }
}
