//! ROS time as a loop node sees it, without ros2-client's `Spinner` (see [`crate::graph`]).

use capsule_msgs::names::topics;
use capsule_msgs::std_types::Clock;
use capsule_msgs::Time;
use futures::StreamExt;
use ros2_client::dds::Node;
use std::sync::{
    atomic::{AtomicI64, Ordering},
    Arc,
};

use crate::error::Result;
use crate::{endpoints::subscribe, qos, ros_options::RosOptions, types};

/// ROS time as a node sees it: the wall clock, or under `use_sim_time` the latest `/clock`
/// (zero until the first one arrives, as in rclcpp).
#[derive(Clone)]
pub struct RosClock {
    sim_nanos: Option<Arc<AtomicI64>>,
}

impl RosClock {
    /// The wall clock, or (under `settings.use_sim_time`) a `/clock` subscription on `node`.
    pub fn new(settings: &RosOptions, node: &mut Node) -> Result<RosClock> {
        if !settings.use_sim_time {
            return Ok(RosClock { sim_nanos: None });
        }
        let topic = settings.topic(node, topics::CLOCK, types::clock(), &qos::clock())?;
        // best effort, like rclcpp's and rclpy's time source
        let sub = subscribe::<Clock>(node, &topic, &qos::clock_reader())?;
        let nanos = Arc::new(AtomicI64::new(0));
        let n = Arc::clone(&nanos);
        tokio::spawn(async move {
            let stream = sub.async_stream();
            futures::pin_mut!(stream);
            while let Some(msg) = stream.next().await {
                if let Ok((clock, _)) = msg {
                    n.store(clock.clock.to_nanos(), Ordering::Relaxed);
                }
            }
        });
        Ok(RosClock {
            sim_nanos: Some(nanos),
        })
    }

    /// Now, in ROS time.
    pub fn now(&self) -> Time {
        match &self.sim_nanos {
            Some(n) => Time::from_nanos(n.load(Ordering::Relaxed)),
            None => Time::from_nanos(capsule_record::writer::now_ns() as i64),
        }
    }
}
