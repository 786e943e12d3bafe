//! A flag served as `std_srvs/srv/SetBool` (true sets it, false clears it), as the emergency
//! stop and the pause are: the answer's texts, the server and its request loop, once, on DDS
//! or Zenoh ([`NodeOn`]).
//!
//! Served by its own task, never by the sample loop, which reads the flag (one atomic) per step.

use std::future::Future;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use capsule_msgs::std_types::{SetBoolRequest, SetBoolResponse};
use capsule_ros_base::error::Result;
use capsule_ros_base::node_on::NodeOn;
use capsule_ros_base::{endpoints::Wire, ros_options::RosOptions, types};
use futures::StreamExt;
use tracing::warn;

/// What a flag's service answers, by what was asked and what the flag was.
#[derive(Debug, Clone, Copy)]
pub struct FlagAnswers {
    /// Set when it was clear.
    pub set: &'static str,
    /// Set when it was set already.
    pub already_set: &'static str,
    /// Cleared when it was set.
    pub cleared: &'static str,
    /// Cleared when it was clear already.
    pub already_clear: &'static str,
}

impl FlagAnswers {
    /// The answer to a request to set the flag to `set` when it was `was`.
    pub fn answer(&self, set: bool, was: bool) -> SetBoolResponse {
        let message = match (set, was) {
            (true, false) => self.set,
            (true, true) => self.already_set,
            (false, true) => self.cleared,
            (false, false) => self.already_clear,
        };
        SetBoolResponse {
            success: true,
            message: message.to_string(),
        }
    }
}

/// Starts serving `service` on the node `on`: each request swaps `flag` to what it asks, then
/// `on_set(asked, &answer)` runs, and the answer goes out once the future it returns is done.
pub fn serve_flag<F, Fut>(
    mut on: NodeOn<'_>,
    settings: &RosOptions,
    service: &'static str,
    answers: FlagAnswers,
    flag: Arc<AtomicBool>,
    mut on_set: F,
) -> Result<()>
where
    F: FnMut(bool, &SetBoolResponse) -> Fut + Send + 'static,
    Fut: Future<Output = ()> + Send,
{
    let server = on.server::<Wire<SetBoolRequest>, Wire<SetBoolResponse>>(
        settings,
        service,
        &types::set_bool(),
    )?;
    tokio::spawn(async move {
        let mut requests = server.requests();
        while let Some(rq) = requests.next().await {
            let (id, Wire(req)) = match rq {
                Ok(r) => r,
                Err(e) => {
                    warn!("undecodable {service} request: {e:?}");
                    continue;
                }
            };
            let was = flag.swap(req.data, Ordering::SeqCst);
            let resp = answers.answer(req.data, was);
            on_set(req.data, &resp).await;
            server.answer(id, Wire(resp));
        }
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_case_has_its_own_answer() {
        let answers = FlagAnswers {
            set: "a",
            already_set: "b",
            cleared: "c",
            already_clear: "d",
        };
        let said = |set, was| answers.answer(set, was).message;
        assert_eq!(
            [
                said(true, false),
                said(true, true),
                said(false, true),
                said(false, false)
            ],
            ["a", "b", "c", "d"]
        );
        assert!(answers.answer(false, false).success);
    }

    #[test]
    fn the_stop_and_the_pause_say_what_changed() {
        // in the order set, already set, cleared, already clear
        let cases = [
            (
                crate::emergency_stop::ANSWERS,
                [
                    "engaged: zero force",
                    "already engaged",
                    "released",
                    "was not engaged",
                ],
            ),
            (
                crate::pause::ANSWERS,
                [
                    "paused: sim time",
                    "already paused",
                    "resumed",
                    "was not paused",
                ],
            ),
        ];
        for (answers, says) in cases {
            let said = [(true, false), (true, true), (false, true), (false, false)]
                .map(|(set, was)| answers.answer(set, was).message);
            for (said, says) in said.iter().zip(says) {
                assert!(said.contains(says), "{said:?} should say {says:?}");
            }
        }
    }
}
