//! Every message of a complete recording in log-time order, for `capsule replay`.

use std::{collections::BTreeMap, path::Path};

use mcap::McapError;

use crate::{
    open::{check_channel, corrupt, open_checked},
    scan::scan,
    RecordError,
};

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    /// Topic.
    pub topic: String,
    /// ROS type.
    pub type_name: String,
    /// Per-channel sequence number.
    pub sequence: u32,
    /// Log time (ns).
    pub log_time: u64,
    /// Publish time (ns).
    pub publish_time: u64,
    /// CDR bytes with the encapsulation header.
    pub data: Vec<u8>,
}

/// Every message of a complete recording in log-time order (stable: file order on ties), with the checks of
/// `info`: missing, non-MCAP, cut and foreign-schema files are errors.
pub fn messages(path: &Path) -> Result<Vec<Message>, RecordError> {
    let (_, _) = open_checked(path)?;
    let bytes = std::fs::read(path).map_err(|e| RecordError::io(path, e))?;
    let scan = scan(&bytes).map_err(|e| corrupt(path, e))?;
    let mut topics = BTreeMap::new();
    for (id, ch) in &scan.channels {
        let schema = scan.schemas.get(&ch.schema_id);
        check_channel(
            path,
            &ch.topic,
            schema.map(|s| (s.name.as_str(), s.encoding.as_str())),
            &ch.message_encoding,
        )?;
        let type_name = schema.map(|s| s.name.clone()).unwrap_or_default();
        topics.insert(*id, (ch.topic.clone(), type_name));
    }
    let mut messages = scan.messages;
    // log-time order (a recorder serving several readers may write a little out of order)
    messages.sort_by_key(|m| m.header.log_time);
    let mut out = Vec::with_capacity(messages.len());
    for m in messages {
        let Some((topic, type_name)) = topics.get(&m.header.channel_id) else {
            return Err(corrupt(
                path,
                McapError::UnknownChannel(m.header.sequence, m.header.channel_id),
            ));
        };
        out.push(Message {
            topic: topic.clone(),
            type_name: type_name.clone(),
            sequence: m.header.sequence,
            log_time: m.header.log_time,
            publish_time: m.header.publish_time,
            data: m.data,
        });
    }
    Ok(out)
}
