//! A small ROS client of the capsule graph: mode requests (with retries) and the demo's
//! segment-by-segment progression measurement.

use capsule_msgs::names::topics;
use std::time::Duration;

use capsule_msgs::std_types::{ChangeStateRequest, ChangeStateResponse, LifecycleTransition};
use capsule_msgs::{CapsuleState, SetModeRequest, SetModeResponse, Time};
use capsule_ros_base::error::{bail, invalid, Context as _, Result};
use ros2_client::dds::Node;
use ros2_client::service::Client;

use capsule_ros_base::{
    endpoints::{subscribe, Wire},
    qos,
    ros_options::RosOptions,
    types,
};

/// The `effective_from` of a request to switch at sim time `at_s` \[s\] (0 = now): refused
/// unless finite, >= 0 and within `builtin_interfaces/Time` (below 2^31 s). A huge value used
/// to saturate into a time that never comes, accepted as "never".
pub fn effective_from(at_s: f64) -> Result<Time> {
    if !(at_s.is_finite() && (0.0..f64::from(i32::MAX)).contains(&at_s)) {
        bail!(
            "--at-s {at_s:?}: must be finite, >= 0 and below 2^31 s (the range of builtin_interfaces/Time)"
        );
    }
    Ok(Time::from_secs_f64(at_s))
}

/// A `set_mode` client.
pub struct ModeClient {
    client: Client<Wire<SetModeRequest>, Wire<SetModeResponse>>,
}

impl ModeClient {
    /// Creates the client on `node` for the controller's service (`service` as given, e.g.
    /// `/capsule_controller/set_mode`).
    pub fn new(node: &mut Node, settings: &RosOptions, service: &str) -> Result<Self> {
        let client = node
            .create_client::<Wire<SetModeRequest>, Wire<SetModeResponse>>(
                settings.mapping.into(),
                &settings.ros_name(service)?,
                &types::set_mode(),
                qos::service(),
                qos::service(),
            )
            .context("set_mode client")?;
        Ok(ModeClient { client })
    }

    /// Calls the service, re-sending every 500 ms until a response comes or `timeout` passes
    /// (the retries: `call_with_retries`, private to this file).
    pub async fn call(
        &self,
        node: &Node,
        req: SetModeRequest,
        timeout: Duration,
    ) -> Result<SetModeResponse> {
        call_with_retries(&self.client, node, req, timeout, "set_mode").await
    }
}

/// A managed node's `change_state` client (what `ros2 lifecycle set NODE TRANSITION` calls).
pub struct LifecycleClient {
    client: Client<Wire<ChangeStateRequest>, Wire<ChangeStateResponse>>,
}

impl LifecycleClient {
    /// Creates the client on `node` for `managed_node`'s `change_state` (e.g. `/capsule_plant`).
    pub fn new(node: &mut Node, settings: &RosOptions, managed_node: &str) -> Result<Self> {
        let (service, full) = topics::lifecycle::CHANGE_STATE;
        let (package, ty) = capsule_msgs::names::type_names::split(full);
        let name = format!(
            "{}/{}",
            managed_node.trim_end_matches('/'),
            service.trim_start_matches("~/")
        );
        let client = node
            .create_client::<Wire<ChangeStateRequest>, Wire<ChangeStateResponse>>(
                settings.mapping.into(),
                &settings.ros_name(&name)?,
                &ros2_client::ServiceTypeName::new(package, ty),
                qos::service(),
                qos::service(),
            )
            .with_context(|| format!("{name} client"))?;
        Ok(LifecycleClient { client })
    }

    /// Asks for the transition labelled `transition` (`configure`, `activate`, ...); true when
    /// it was taken and succeeded.
    pub async fn set(&self, node: &Node, transition: &str, timeout: Duration) -> Result<bool> {
        let req = ChangeStateRequest {
            transition: LifecycleTransition {
                id: 0,
                label: transition.into(),
            },
        };
        let resp = call_with_retries(&self.client, node, req, timeout, "change_state").await?;
        Ok(resp.success)
    }
}

/// Calls `client`'s service, re-sending after 0.5 s, then 1, 2 and every 4 s, until a response
/// comes or `timeout` passes (a first request can be lost while the reply path is still
/// matching; a server busy for seconds on a loaded host gets a few repeats, not one every
/// 0.5 s whose burst of answers could push the first out of the reply reader's history of
/// 10). The answer to any of
/// the requests sent counts: on a loaded host the first one's can come after the second was
/// sent, and a repeat is not always harmless (a lifecycle transition asked again is refused
/// once taken). Waits at most 2 s for the service to be matched first; a match event can be
/// missed, so it does not rely on it.
async fn call_with_retries<Q, A>(
    client: &Client<Wire<Q>, Wire<A>>,
    node: &Node,
    req: Q,
    timeout: Duration,
    what: &str,
) -> Result<A>
where
    Q: Clone + serde::Serialize + serde::de::DeserializeOwned + 'static,
    A: serde::Serialize + serde::de::DeserializeOwned + 'static,
{
    let deadline = tokio::time::Instant::now() + timeout;
    let _ = tokio::time::timeout(
        timeout.min(Duration::from_secs(2)),
        client.wait_for_service(node),
    )
    .await;
    let mut retry = Duration::from_millis(500);
    let mut sent = Vec::new();
    loop {
        let id = client
            .async_send_request(Wire(req.clone()))
            .await
            .with_context(|| format!("{what} request not sent"))?;
        sent.push(id);
        let resend = (tokio::time::Instant::now() + retry).min(deadline);
        loop {
            // every client of the service reads every reply: only ours count
            while let Some((id, Wire(resp))) = client
                .receive_response()
                .map_err(|e| invalid!("{what} response unreadable: {e:?}"))?
            {
                if sent.contains(&id) {
                    return Ok(resp);
                }
            }
            if tokio::time::Instant::now() >= resend {
                break;
            }
            tokio::time::sleep(REPLY_POLL).await;
        }
        retry = (retry * 2).min(Duration::from_secs(4));
        if tokio::time::Instant::now() >= deadline {
            bail!(
                "no {what} response within {timeout:?} ({} requests sent)",
                sent.len()
            );
        }
    }
}

/// How often a call looks for its reply: a small part of a service's round trip on a loaded
/// host, and of a core when nothing comes.
const REPLY_POLL: Duration = Duration::from_millis(1);

/// Progression of one demo segment.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentResult {
    /// Mode name.
    pub mode: String,
    /// Periods measured (after the settling periods).
    pub periods: f64,
    /// Mean progression per drive period, non-dimensional.
    pub per_period: f64,
    /// Mean progression per drive period \[m\].
    pub per_period_m: f64,
}

/// Watches the state topic and measures each segment's progression between sim times.
pub struct SegmentMeter {
    /// (mode, measure from \[s\], measure to \[s\]) per segment.
    pub windows: Vec<(String, f64, f64)>,
    /// Drive period \[s\].
    pub period_s: f64,
    /// Length scale \[m\].
    pub length_m: f64,
    marks: Vec<(Option<f64>, Option<f64>)>,
}

impl SegmentMeter {
    /// Meter for the given windows.
    pub fn new(windows: Vec<(String, f64, f64)>, period_s: f64, length_m: f64) -> Self {
        let marks = vec![(None, None); windows.len()];
        SegmentMeter {
            windows,
            period_s,
            length_m,
            marks,
        }
    }

    /// Feeds a sample: the first sample at or after each window edge marks the capsule position.
    pub fn sample(&mut self, s: &CapsuleState) {
        let t = s.header.stamp.as_secs_f64();
        for ((_, from, to), mark) in self.windows.iter().zip(self.marks.iter_mut()) {
            if mark.0.is_none() && t >= *from - 1e-9 {
                mark.0 = Some(s.capsule_position);
            }
            if mark.1.is_none() && t >= *to - 1e-9 {
                mark.1 = Some(s.capsule_position);
            }
        }
    }

    /// True once every window is closed.
    pub fn done(&self) -> bool {
        self.marks.iter().all(|m| m.1.is_some())
    }

    /// The results so far (complete windows only).
    pub fn results(&self) -> Vec<SegmentResult> {
        self.windows
            .iter()
            .zip(&self.marks)
            .filter_map(|((mode, from, to), m)| {
                let (a, b) = (m.0?, m.1?);
                let periods = (to - from) / self.period_s;
                let per_period_m = (b - a) / periods;
                Some(SegmentResult {
                    mode: mode.clone(),
                    periods,
                    per_period: per_period_m / self.length_m,
                    per_period_m,
                })
            })
            .collect()
    }
}

/// Subscribes to the state topic (for the demo and `switch-attractor`, which measure the run
/// from every sample): a reliable reader 2,000 samples deep (2 s at 1 kHz), as the recorder's,
/// so that a client stalled on a loaded host still sees each drive period's samples.
pub fn state_subscription(
    node: &mut Node,
    settings: &RosOptions,
) -> Result<ros2_client::dds::Subscription<CapsuleState>> {
    let topic = settings.topic(node, topics::STATE, types::state(), &qos::data())?;
    let reader_qos = qos::data().history(ros2_client::qos::History::KeepLast { depth: 2000 });
    subscribe::<CapsuleState>(node, &topic, &reader_qos)
}

/// A subscription to the status topic of the controller whose mode service is `service`
/// (`/ns/node/set_mode` -> `/ns/node/status`: the controller's `~/status`).
pub fn status_subscription(
    node: &mut Node,
    settings: &RosOptions,
    service: &str,
) -> Result<ros2_client::dds::Subscription<capsule_msgs::ControllerStatus>> {
    let (controller, _) = service
        .rsplit_once('/')
        .with_context(|| format!("service {service:?}: expected .../NODE/set_mode"))?;
    let name = format!("{controller}/status");
    let topic = settings.topic(node, &name, types::status(), &qos::data())?;
    subscribe::<capsule_msgs::ControllerStatus>(node, &topic, &qos::data_reader())
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_msgs::Header;

    #[test]
    fn effective_from_refuses_what_time_cannot_hold() {
        assert_eq!(effective_from(2.5).ok(), Some(Time::from_secs_f64(2.5)));
        assert_eq!(effective_from(0.0).ok(), Some(Time::ZERO));
        for bad in [1e308, -1.0, f64::NAN, f64::INFINITY, 2147483648.0] {
            let e = effective_from(bad).err().map(|e| e.to_string());
            assert!(
                e.as_deref().is_some_and(|e| e.contains("--at-s")),
                "{bad}: {e:?}"
            );
        }
    }

    #[test]
    fn segment_meter_takes_positions_at_window_edges() {
        let mut m = SegmentMeter::new(
            vec![("FORWARD".into(), 1.0, 3.0), ("BACKWARD".into(), 4.0, 5.0)],
            0.5,
            0.01,
        );
        for k in 0..=60 {
            let t = k as f64 * 0.1;
            let x = if t <= 3.0 {
                0.02 * t
            } else {
                0.06 - 0.01 * (t - 3.0)
            };
            let s = CapsuleState {
                header: Header {
                    stamp: Time::from_secs_f64(t),
                    frame_id: String::new(),
                },
                capsule_position: x,
                ..CapsuleState::default()
            };
            m.sample(&s);
        }
        assert!(m.done());
        let r = m.results();
        assert_eq!(r.len(), 2);
        // forward: 0.04 m over 4 periods -> 0.01 m = 1.0 non-dim per period
        assert!(
            (r[0].per_period_m - 0.01).abs() < 1e-12 && (r[0].per_period - 1.0).abs() < 1e-9,
            "{r:?}"
        );
        assert!((r[1].per_period_m + 0.005).abs() < 1e-12, "{r:?}");
    }
}
