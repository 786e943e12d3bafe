//! The participant's RTPS ports, and a guard against a startup race RustDDS loses silently.
//!
//! RustDDS 0.15 picks a participant id by the first free discovery port (RTPS 9.6.1.1), then
//! binds the user-traffic port of that id; if another process took that port in between (a Fast
//! DDS participant started at the same instant chooses its user port on its own), RustDDS
//! listens on a free port instead and says so in its participant announcement, but still
//! announces every *writer* at the standard port. A reliable reader then sends its
//! acknowledgements to the other process: it never gets the samples it asks to be repaired, so
//! it delivers nothing, and our writer's window fills and blocks (seen: a Fast DDS peer read 0
//! of 200 states while the plant's state writer returned WouldBlock from sample 8,192).
//! [`holds_udp_port`] tells whether the participant got its port; when it did not,
//! `RosOptions::context` builds it again on the next id.

/// The RTPS discovery (metatraffic) unicast port of `participant_id` in `domain` (PB 7400,
/// DG 250, PG 2, d1 10).
pub fn discovery_port(domain: u16, participant_id: u16) -> u16 {
    7400 + 250 * domain + 10 + 2 * participant_id
}

/// The RTPS user-traffic unicast port of `participant_id` in `domain` (d3 11).
pub fn user_port(domain: u16, participant_id: u16) -> u16 {
    7400 + 250 * domain + 11 + 2 * participant_id
}

/// Whether this process has a UDP socket bound to `port`; `None` where it cannot tell (not
/// Linux, or /proc unreadable).
pub fn holds_udp_port(port: u16) -> Option<bool> {
    let ours = own_socket_inodes()?;
    let mut bound = Vec::new();
    for table in ["/proc/net/udp", "/proc/net/udp6"] {
        if let Ok(text) = std::fs::read_to_string(table) {
            bound.extend(inodes_bound_to(&text, port));
        }
    }
    Some(bound.iter().any(|inode| ours.contains(inode)))
}

/// The inodes of the sockets this process has open (`/proc/self/fd/N -> socket:[INODE]`).
fn own_socket_inodes() -> Option<Vec<u64>> {
    let dir = std::fs::read_dir("/proc/self/fd").ok()?;
    Some(
        dir.flatten()
            .filter_map(|e| std::fs::read_link(e.path()).ok())
            .filter_map(|target| {
                let t = target.to_string_lossy();
                t.strip_prefix("socket:[")?.strip_suffix(']')?.parse().ok()
            })
            .collect(),
    )
}

/// The inodes of the sockets bound to local `port` in a `/proc/net/udp` table.
fn inodes_bound_to(table: &str, port: u16) -> Vec<u64> {
    table
        .lines()
        .skip(1)
        .filter_map(|line| {
            let fields: Vec<&str> = line.split_whitespace().collect();
            let local_port = fields.get(1)?.rsplit(':').next()?;
            let inode = fields.get(9)?;
            (u16::from_str_radix(local_port, 16).ok()? == port).then(|| inode.parse().ok())?
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ports_follow_the_rtps_defaults() {
        assert_eq!(discovery_port(0, 0), 7410);
        assert_eq!(user_port(0, 0), 7411);
        assert_eq!(user_port(0, 1), 7413);
        assert_eq!(discovery_port(3, 2), 7400 + 750 + 14);
    }

    #[test]
    fn a_udp_table_gives_the_inodes_on_a_port() {
        let table = "  sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  timeout inode ref pointer drops
  1: 00000000:1CF3 00000000:0000 07 00000000:00000000 00:00000000 00000000     0        0 4242 2 0000000000000000 0
  2: 0100007F:1CF2 00000000:0000 07 00000000:00000000 00:00000000 00000000     0        0 77 2 0000000000000000 0";
        assert_eq!(inodes_bound_to(table, 7411), vec![4242]);
        assert_eq!(inodes_bound_to(table, 7410), vec![77]);
        assert!(inodes_bound_to(table, 7412).is_empty());
    }

    #[test]
    fn a_socket_of_ours_is_found_and_a_free_port_is_not() {
        let socket = std::net::UdpSocket::bind("127.0.0.1:0").expect("a local UDP socket");
        let port = socket.local_addr().expect("its address").port();
        assert_eq!(holds_udp_port(port), Some(true));
        drop(socket);
        assert_eq!(holds_udp_port(port), Some(false));
    }
}
