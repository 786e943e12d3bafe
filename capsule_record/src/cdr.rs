//! CDR with the 4-byte encapsulation header, as ROS 2 puts it on the wire and rosbag2 stores it.

use byteorder::{BigEndian, LittleEndian};
use serde::{de::DeserializeOwned, Serialize};

use crate::RecordError;

/// Encapsulation header of little-endian plain CDR (XCDR1), the one every message here uses.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Serialises a message: the encapsulation header, then the little-endian CDR body.
pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, RecordError> {
    let mut out = Vec::with_capacity(128);
    out.extend_from_slice(&CDR_LE_HEADER);
    cdr_encoding::to_writer::<T, LittleEndian, _>(&mut out, value)
        .map_err(|e| RecordError::Cdr(e.to_string()))?;
    Ok(out)
}

/// Decodes a message with its encapsulation header (plain CDR, either byte order).
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, RecordError> {
    if bytes.len() < 4 {
        return Err(RecordError::Cdr(format!(
            "{} bytes: too short for the encapsulation header",
            bytes.len()
        )));
    }
    let body = &bytes[4..];
    let result = match (bytes[0], bytes[1]) {
        (0x00, 0x01) => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        (0x00, 0x00) => cdr_encoding::from_bytes::<T, BigEndian>(body),
        (a, b) => {
            return Err(RecordError::Cdr(format!(
                "unsupported encapsulation {a:02x} {b:02x} (only plain CDR)"
            )))
        }
    };
    result
        .map(|(v, _)| v)
        .map_err(|e| RecordError::Cdr(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{ServiceEventInfo, SetModeEvent};
    use capsule_msgs::{ActuatorForce, Header, SetModeRequest, Time};

    #[test]
    fn force_round_trips_with_header_and_known_layout() {
        let f = ActuatorForce {
            header: Header {
                stamp: Time { sec: 2, nanosec: 5 },
                frame_id: "odom".into(),
            },
            state_seq: 7,
            force: -1.5,
        };
        let b = encode(&f).unwrap_or_default();
        assert_eq!(&b[..4], &CDR_LE_HEADER);
        // sec, nanosec, string length 5 ("odom\0"), pad to 8, u64, f64
        assert_eq!(&b[4..8], &2i32.to_le_bytes());
        assert_eq!(&b[12..16], &5u32.to_le_bytes());
        assert_eq!(&b[16..21], b"odom\0");
        assert_eq!(b.len(), 4 + 24 + 8 + 8);
        assert_eq!(decode::<ActuatorForce>(&b).ok(), Some(f));
    }

    #[test]
    fn service_event_round_trips() {
        let e = SetModeEvent {
            info: ServiceEventInfo {
                event_type: ServiceEventInfo::REQUEST_RECEIVED,
                stamp: Time { sec: 1, nanosec: 2 },
                client_gid: [3; 16],
                sequence_number: 4,
            },
            request: vec![SetModeRequest {
                mode: 1,
                gain: 0.5,
                effective_from: Time::ZERO,
                ..SetModeRequest::default()
            }],
            response: vec![],
        };
        let b = encode(&e).unwrap_or_default();
        assert_eq!(decode::<SetModeEvent>(&b).ok(), Some(e));
    }

    #[test]
    fn short_or_foreign_encapsulation_is_an_error() {
        assert!(decode::<ActuatorForce>(&[0, 1]).is_err());
        assert!(decode::<ActuatorForce>(&[0, 7, 0, 0, 1, 2, 3]).is_err());
        assert!(decode::<ActuatorForce>(&CDR_LE_HEADER).is_err());
    }
}
