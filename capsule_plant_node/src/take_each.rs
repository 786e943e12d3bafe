//! Taking every sample a reader holds: one loop for the recorder's drains and the action
//! readers'.

use std::fmt::Display;

use capsule_ros_base::error::Result;
use ros2_client::dds::Subscription;
use ros2_client::MessageInfo;
use tracing::warn;

/// Takes every sample `sub` holds into `keep`, which says whether it kept it; returns how many
/// it kept. An undecodable sample ends the take, with a warning naming `what`.
pub fn take_each<M: serde::de::DeserializeOwned + 'static>(
    sub: &Subscription<M>,
    what: impl Display,
    mut keep: impl FnMut(M, &MessageInfo) -> Result<bool>,
) -> Result<usize> {
    let mut n = 0;
    loop {
        match sub.take() {
            Ok(Some((msg, info))) => {
                if keep(msg, &info)? {
                    n += 1;
                }
            }
            Ok(None) => return Ok(n),
            Err(e) => {
                warn!("bad {what} sample: {e:?}");
                return Ok(n);
            }
        }
    }
}
