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
//!
//! On Zenoh (`Service::on_zenoh`, feature `zenoh`) a request is a query and its answer the
//! query's reply: nothing to wait for, the answer goes at once.

use std::{pin::Pin, sync::Arc, time::Duration};

use futures::stream::FusedStream;
#[cfg(feature = "zenoh")]
use futures::StreamExt as _;
use ros2_client::dds::Server;
use ros2_client::{Message, ReadResult, RmwRequestId};
use tracing::warn;

use crate::graph::Graph;

/// How long an answer waits for the client's reply reader to match, at most.
pub const MATCH_WAIT: Duration = Duration::from_secs(1);

/// A server of one service, answering as described in the [module](self) documentation.
pub struct Service<Q: Message, R: Message> {
    server: Arc<dyn Ends<Q, R>>,
}

/// A service's requests, as they come ([`Service::requests`]).
pub type Requests<'a, Q> =
    Pin<Box<dyn FusedStream<Item = ReadResult<(RmwRequestId, Q)>> + Send + 'a>>;

/// A service's server as [`Service`] uses it, on DDS ([`DdsEnds`]) or on Zenoh.
trait Ends<Q, R>: Send + Sync {
    /// The requests, as they come.
    fn requests(&self) -> Requests<'_, Q>;
    /// Sends `answer` to the client that sent request `id`.
    fn answer(&self, id: RmwRequestId, answer: R);
}

/// A DDS server and what its answers wait for.
struct DdsEnds<Q: Message, R: Message> {
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
            server: Arc::new(DdsEnds {
                server: Arc::new(server),
                graph,
                topics: Arc::new((
                    format!("rq{full_name}Request"),
                    format!("rr{full_name}Reply"),
                )),
                name: full_name.into(),
            }),
        }
    }

    /// Wraps the Zenoh `server` of the service `full_name` (resolved, absolute).
    #[cfg(feature = "zenoh")]
    pub fn on_zenoh(server: ros2_client::zenoh::Server<Q, R>, full_name: &str) -> Service<Q, R> {
        Service {
            server: Arc::new(ZenohEnds {
                server: Arc::new(server),
                name: full_name.into(),
            }),
        }
    }

    /// The requests, as they come: each with the id its answer must carry.
    pub fn requests(&self) -> Requests<'_, Q> {
        self.server.requests()
    }

    /// Sends `answer` to the client that sent request `id`: on DDS on a task of its own, once
    /// the client's reply reader has matched ours, or after [`MATCH_WAIT`]; on Zenoh now.
    pub fn answer(&self, id: RmwRequestId, answer: R) {
        self.server.answer(id, answer)
    }
}

impl<Q, R> Ends<Q, R> for DdsEnds<Q, R>
where
    Q: Message + Send + Sync + 'static,
    R: Message + Send + Sync + 'static,
{
    fn requests(&self) -> Requests<'_, Q> {
        Box::pin(self.server.receive_request_stream())
    }

    fn answer(&self, id: RmwRequestId, answer: R) {
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

/// A Zenoh server: a request is a query, its answer the query's reply, sent at once.
#[cfg(feature = "zenoh")]
struct ZenohEnds<Q, R> {
    server: Arc<ros2_client::zenoh::Server<Q, R>>,
    name: Arc<str>,
}

#[cfg(feature = "zenoh")]
impl<Q, R> Ends<Q, R> for ZenohEnds<Q, R>
where
    Q: Message + Send + Sync + 'static,
    R: Message + Send + Sync + 'static,
{
    fn requests(&self) -> Requests<'_, Q> {
        Box::pin(zenoh_requests(Arc::clone(&self.server)))
    }

    fn answer(&self, id: RmwRequestId, answer: R) {
        if let Err(e) = self.server.send_response(id, answer) {
            warn!("{}: response not sent: {e:?}", self.name);
        }
    }
}

/// The requests of a Zenoh server, as they come; ends when its queryable closes (a request
/// that cannot be read is an error, and the next one is read).
#[cfg(feature = "zenoh")]
fn zenoh_requests<Q, R>(
    server: Arc<ros2_client::zenoh::Server<Q, R>>,
) -> impl FusedStream<Item = ReadResult<(RmwRequestId, Q)>>
where
    Q: Message + Send + Sync + 'static,
    R: Message + Send + Sync + 'static,
{
    futures::stream::unfold(server, |server| async move {
        match server.async_receive_request().await {
            Ok(got) => Some((Ok(got), server)),
            Err(ros2_client::ServiceError::NoReply) => None,
            Err(e) => {
                let reason = format!("{e:?}");
                Some((
                    Err(ros2_client::ReadError::Deserialization { reason }),
                    server,
                ))
            }
        }
    })
    .fuse()
}
