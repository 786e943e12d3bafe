//! Serial lines and pseudo-terminals in raw mode: 8N1, no echo, no line editing, no flow
//! control, bytes passed as they are.

use std::fs::File;
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};

use nix::fcntl::{open, OFlag};
use nix::sys::stat::Mode;
#[cfg(any(target_os = "linux", target_os = "android"))]
use nix::sys::termios::BaudRate;
use nix::sys::termios::{self, SetArg};

/// The baud rates a line can be opened at.
pub const BAUD_RATES: [u32; 12] = [
    9_600, 19_200, 38_400, 57_600, 115_200, 230_400, 460_800, 500_000, 921_600, 1_000_000,
    2_000_000, 4_000_000,
];

/// A rate as termios takes it. Linux has a `B...` constant for each rate above; the BSDs and
/// macOS have no constant for most of the fast ones but take the number itself (their speeds
/// are the numbers), so the same list works there (a rate the driver cannot do is then refused
/// when the line is set up).
#[cfg(any(target_os = "linux", target_os = "android"))]
type Speed = BaudRate;
#[cfg(not(any(target_os = "linux", target_os = "android")))]
type Speed = u32;

#[cfg(any(target_os = "linux", target_os = "android"))]
fn baud(rate: u32) -> Option<Speed> {
    Some(match rate {
        9_600 => BaudRate::B9600,
        19_200 => BaudRate::B19200,
        38_400 => BaudRate::B38400,
        57_600 => BaudRate::B57600,
        115_200 => BaudRate::B115200,
        230_400 => BaudRate::B230400,
        460_800 => BaudRate::B460800,
        500_000 => BaudRate::B500000,
        921_600 => BaudRate::B921600,
        1_000_000 => BaudRate::B1000000,
        2_000_000 => BaudRate::B2000000,
        4_000_000 => BaudRate::B4000000,
        _ => return None,
    })
}

#[cfg(not(any(target_os = "linux", target_os = "android")))]
fn baud(rate: u32) -> Option<Speed> {
    BAUD_RATES.contains(&rate).then_some(rate)
}

/// Puts the terminal `fd` in raw mode at `rate` baud (a pseudo-terminal ignores the rate).
fn make_raw(fd: impl AsFd, rate: Option<Speed>) -> nix::Result<()> {
    let mut t = termios::tcgetattr(&fd)?;
    termios::cfmakeraw(&mut t);
    if let Some(r) = rate {
        termios::cfsetspeed(&mut t, r)?;
    }
    termios::tcsetattr(&fd, SetArg::TCSANOW, &t)
}

/// Opens the serial line at `path` non-blocking, raw, at `rate` baud (one of [`BAUD_RATES`]).
pub fn open_line(path: &Path, rate: u32) -> std::io::Result<File> {
    let rate = baud(rate).ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("baud rate {rate} is not one of {BAUD_RATES:?}"),
        )
    })?;
    let fd: OwnedFd = open(
        path,
        OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_NONBLOCK | OFlag::O_CLOEXEC,
        Mode::empty(),
    )?;
    make_raw(&fd, Some(rate))?;
    // what the line holds from before is stale
    termios::tcflush(&fd, termios::FlushArg::TCIFLUSH)?;
    Ok(File::from(fd))
}

/// A pseudo-terminal: the device's end (`master`) and the path a driver opens.
pub struct Pty {
    /// The device's end, non-blocking.
    pub master: File,
    /// Held open so that the device's end never reads end-of-file while no driver has the line
    /// open (a device does not notice its cable either).
    _slave: File,
    /// The driver's end, `/dev/pts/N`.
    pub path: PathBuf,
}

/// A new pseudo-terminal in raw mode.
pub fn open_pty() -> std::io::Result<Pty> {
    let pair = nix::pty::openpty(None, None)?;
    make_raw(&pair.slave, None)?;
    let path = nix::unistd::ttyname(&pair.slave)?;
    let flags = OFlag::from_bits_truncate(nix::fcntl::fcntl(
        &pair.master,
        nix::fcntl::FcntlArg::F_GETFL,
    )?);
    nix::fcntl::fcntl(
        &pair.master,
        nix::fcntl::FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK),
    )?;
    Ok(Pty {
        master: File::from(pair.master),
        _slave: File::from(pair.slave),
        path,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    #[test]
    fn bytes_cross_a_pty_unchanged_both_ways() -> std::io::Result<()> {
        let mut pty = open_pty()?;
        let mut line = open_line(&pty.path, 460_800)?;
        // every byte value, including those a cooked terminal would translate or swallow
        let all: Vec<u8> = (0..=255u8).collect();
        line.write_all(&all)?;
        let mut got = Vec::new();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
        while got.len() < all.len() && std::time::Instant::now() < deadline {
            let mut buf = [0u8; 512];
            match pty.master.read(&mut buf) {
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    std::thread::sleep(std::time::Duration::from_millis(1))
                }
                Err(e) => return Err(e),
            }
        }
        assert_eq!(got, all);
        assert!(open_line(&pty.path, 12_345).is_err());
        Ok(())
    }
}
