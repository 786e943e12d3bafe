//! A node's life in the phases both loop nodes live by, the skeleton they share: **build** (the
//! endpoints, services and parameters: every refusal comes before any work), **wait for the
//! graph** (the peers its first sample needs), **run the loop** (until its end), **finish**
//! (what is left to send, say and close). [`live`] runs them in that order; each node says what
//! each phase is for it ([`NodeLife`]).

use std::future::Future;

use ros2_client::dds::{Context, Node};

use crate::{error::Result, graph::Graph, ros_options::RosOptions};

/// A node as its life reads: the four phases, each a function of what the last one left.
pub trait NodeLife: Sized {
    /// What the built node holds while it waits and runs.
    type Built;
    /// What the loop leaves to finish.
    type Ended;
    /// What the node's life gives back.
    type Outcome;

    /// Build, in `context`'s participant (a composed process's) or, `None`, one of its own
    /// ([`Seat::take`]).
    fn build(self, context: Option<&Context>) -> Result<Self::Built>;

    /// Wait for the graph: until the peers the first sample needs have matched.
    fn wait_for_graph(built: &Self::Built) -> impl Future<Output = Result<()>>;

    /// Run the loop until its end.
    fn run_loop(built: Self::Built) -> impl Future<Output = Result<Self::Ended>>;

    /// Finish: what is left to send, say and close; the life's outcome.
    fn finish(ended: Self::Ended) -> impl Future<Output = Result<Self::Outcome>>;
}

/// Lives `node`'s life: build, wait for the graph, run the loop, finish.
pub async fn live<N: NodeLife>(node: N, context: Option<&Context>) -> Result<N::Outcome> {
    let built = node.build(context)?;
    N::wait_for_graph(&built).await?;
    let ended = N::run_loop(built).await?;
    N::finish(ended).await
}

/// Where a loop node sits in the graph: its participant's context, its node (no spinner: see
/// [`RosOptions::loop_node`]) and the graph it follows.
pub struct Seat {
    /// The participant's context (kept while the node lives).
    pub context: Context,
    /// The node.
    pub node: Node,
    /// Matched endpoints, followed.
    pub graph: Graph,
    /// In a composed process's participant (not one of its own).
    pub composed: bool,
}

impl Seat {
    /// The node named by `settings`, in `context`'s participant or, `None`, one of its own.
    pub fn take(context: Option<&Context>, settings: &RosOptions) -> Result<Seat> {
        let composed = context.is_some();
        let context = match context {
            Some(c) => c.clone(),
            None => settings.context()?,
        };
        let (node, graph) = settings.loop_node(&context)?;
        Ok(Seat {
            context,
            node,
            graph,
            composed,
        })
    }
}
