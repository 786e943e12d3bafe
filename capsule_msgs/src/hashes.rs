//! The REP-2016 type hash (`RIHS01_...`) of every interface this package defines or uses,
//! computed at build time from the interface files (`build.rs`, `src/type_hash.rs`). rmw_zenoh
//! puts it in every key expression and liveliness token: a wrong one matches nothing.

include!(concat!(env!("OUT_DIR"), "/type_hashes.rs"));

/// The hash of a type by its ROS name (`capsule_msgs/msg/CapsuleState`, `capsule_msgs/srv/SetMode`)
/// or its DDS name (`capsule_msgs::msg::dds_::CapsuleState_`).
pub fn of(type_name: &str) -> Option<&'static str> {
    let ros = ros_name(type_name);
    let name = ros.as_deref().unwrap_or(type_name);
    TYPE_HASHES
        .binary_search_by(|(n, _)| (*n).cmp(name))
        .ok()
        .map(|i| TYPE_HASHES[i].1)
}

/// `pkg/kind/Name` from `pkg::kind::dds_::Name_` (None for anything else).
fn ros_name(dds: &str) -> Option<String> {
    let mut parts = dds.split("::");
    let (package, kind, dds_, name) = (parts.next()?, parts.next()?, parts.next()?, parts.next()?);
    (dds_ == "dds_" && parts.next().is_none())
        .then(|| name.strip_suffix('_'))
        .flatten()
        .map(|name| format!("{package}/{kind}/{name}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_sorted_and_looked_up_by_either_name() {
        assert!(TYPE_HASHES.windows(2).all(|w| w[0].0 < w[1].0));
        let by_ros = of("capsule_msgs/msg/CapsuleState");
        assert!(by_ros.is_some_and(|h| h.starts_with("RIHS01_") && h.len() == 71));
        assert_eq!(of("capsule_msgs::msg::dds_::CapsuleState_"), by_ros);
        assert_eq!(
            of("capsule_msgs::srv::dds_::SetMode_"),
            of("capsule_msgs/srv/SetMode")
        );
        assert_eq!(of("capsule_msgs/msg/Nothing"), None);
        assert_eq!(of("capsule_msgs::msg::CapsuleState_"), None);
    }
}
