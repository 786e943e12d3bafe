//! A service server whose answers arrive: each answer waits, on a task of its own, until the
//! asking client's reply reader has matched our reply writer.
//!
//! A client creates its request writer and its reply reader together, and sends at once. Our
//! request reader can match the client's writer, and take the request, before our reply writer
//! has matched the client's reader; the answer written then goes to no one, and the client's
//! volatile reader, matched a moment later, does not ask for it. Captured on loopback (a Cyclone
//! DDS client, our plant): the reply writer's first heartbeat announced the answer, and the
//! client's reader acknowledged it without ever receiving it. The client sees its call lost and
//! has to call again. rmw_cyclonedds and rmw_fastrtps wait for the client's reader before they
//! answer, for the same reason; so do we, bounded by [`MATCH_WAIT`], then answer anyway.
//!
//! Which reader is the client's: a request names its client's participant (the first 8 octets
//! of its id, in every mapping), not the reader. So the answer waits until that participant has
//! as many reply readers as request writers matched: one per client. Waiting for any of its
//! readers was not enough: a peer that drops a client and makes the next at once still had the
//! old client's reader matched, and 1 in 20 answers went to it (measured with
//! `cyclone_peer.py first-answers`).

use std::{sync::Arc, time::Duration};

use futures::stream::FusedStream;
use ros2_client::dds::Server;
use ros2_client::{Message, ReadResult, RmwRequestId};
use tracing::warn;

use crate::graph::Graph;

/// How long an answer waits for the client's reply reader to match, at most.
pub const MATCH_WAIT: Duration = Duration::from_secs(1);

/// A server of one service, answering as described in the [module](self) documentation.
pub struct Service<Q: Message, R: Message> {
    server: Arc<Server<Q, R>>,
    graph: Graph,
    /// The DDS topics of the requests (`rq/...Request`) and the answers (`rr/...Reply`).
    topics: Arc<(String, String)>,
    /// The service's full ROS name, for the log.
    name: Arc<str>,
}

impl<Q, R> Service<Q, R>
where
    Q: Message + Send + Sync + 'static,
    R: Message + Send + Sync + 'static,
{
    /// Wraps `server` of the service `full_name` (resolved, absolute), whose matches `graph`
    /// follows.
    pub fn new(server: Server<Q, R>, graph: Graph, full_name: &str) -> Service<Q, R> {
        Service {
            server: Arc::new(server),
            graph,
            topics: Arc::new((
                format!("rq{full_name}Request"),
                format!("rr{full_name}Reply"),
            )),
            name: full_name.into(),
        }
    }

    /// The requests, as they come: each with the id its answer must carry.
    pub fn requests(&self) -> impl FusedStream<Item = ReadResult<(RmwRequestId, Q)>> + '_ {
        self.server.receive_request_stream()
    }

    /// Sends `answer` to the client that sent request `id`: on a task of its own, once the
    /// client's reply reader has matched ours, or after [`MATCH_WAIT`].
    pub fn answer(&self, id: RmwRequestId, answer: R) {
        let server = Arc::clone(&self.server);
        let graph = self.graph.clone();
        let (topics, name) = (Arc::clone(&self.topics), Arc::clone(&self.name));
        tokio::spawn(async move {
            // the client's participant: the first 8 octets of its GUID, in every mapping
            let client = id.writer_gid.to_bytes16();
            let (requests, replies) = &*topics;
            if !graph
                .wait_client_readers(requests, replies, &client[..8], MATCH_WAIT)
                .await
            {
                warn!(
                    "{name}: the client's reply reader has not matched within {} s; answering \
                     anyway (the answer may be lost, the client will ask again)",
                    MATCH_WAIT.as_secs_f64()
                );
            }
            if let Err(e) = server.async_send_response(id, answer).await {
                warn!("{name}: response not sent: {e:?}");
            }
        });
    }
}
