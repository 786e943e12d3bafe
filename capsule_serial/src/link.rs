//! A framed link over a non-blocking byte stream: frames out with their own sequence numbers,
//! decoded frames (and what was skipped) in, each read bounded by a deadline. The stream is any
//! [`Line`]: a serial line or pty ([`File`]), or one end of a socket pair (in-process tests).

use std::fs::File;
use std::io::{ErrorKind, Read, Write};
use std::os::fd::AsFd;
use std::os::unix::net::UnixStream;
use std::time::{Duration, Instant};

use capsule_device::{Decoded, Decoder, Frame};
use nix::poll::{PollFd, PollFlags};

/// Waits up to `left` for `fds`. ppoll where there is one: poll's whole milliseconds overslept a
/// device's sub-millisecond deadline by up to a period, and its next samples then went out in a
/// burst.
#[cfg(any(target_os = "linux", target_os = "android", target_os = "freebsd"))]
fn poll_for(fds: &mut [PollFd], left: Duration) -> nix::Result<nix::libc::c_int> {
    let timeout = nix::sys::time::TimeSpec::from_duration(left);
    nix::poll::ppoll(fds, Some(timeout), None)
}

/// Waits up to `left` (rounded up to whole milliseconds) for `fds`.
#[cfg(not(any(target_os = "linux", target_os = "android", target_os = "freebsd")))]
fn poll_for(fds: &mut [PollFd], left: Duration) -> nix::Result<nix::libc::c_int> {
    let ms = u16::try_from(left.as_micros().div_ceil(1000)).unwrap_or(u16::MAX);
    nix::poll::poll(fds, nix::poll::PollTimeout::from(ms))
}

/// Why a link cannot go on.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The other end is gone (end of file, hang-up, a line unplugged): reopen to go on.
    #[error("the line is gone: {0}")]
    Gone(String),
}

/// How long a write may wait for room before its frame is dropped: a device that stops
/// reading must not stop the loop that writes to it.
const WRITE_WAIT: Duration = Duration::from_millis(20);

/// A non-blocking byte stream a [`Link`] runs over: readable, writable, pollable, and
/// clonable (one clone reads on the device's thread while another writes).
pub trait Line: Read + Write + AsFd + Send + Sized + 'static {
    /// A second handle on the same stream.
    fn try_clone_line(&self) -> std::io::Result<Self>;
}

impl Line for File {
    fn try_clone_line(&self) -> std::io::Result<File> {
        self.try_clone()
    }
}

impl Line for UnixStream {
    fn try_clone_line(&self) -> std::io::Result<UnixStream> {
        self.try_clone()
    }
}

/// One end of a framed line.
pub struct Link<S: Line = File> {
    file: S,
    decoder: Decoder,
    seq: u16,
    /// Frames dropped because the line had no room for them.
    pub unsent: u64,
}

impl<S: Line> Link<S> {
    /// A link over `file`, which must be non-blocking.
    pub fn new(file: S) -> Link<S> {
        Link {
            file,
            decoder: Decoder::new(),
            seq: 0,
            unsent: 0,
        }
    }

    /// A second handle on the stream, with a decoder and sequence numbers of its own: one end
    /// reads (on a thread of its own), the other writes.
    pub fn try_clone(&self) -> std::io::Result<Link<S>> {
        Ok(Link::new(self.file.try_clone_line()?))
    }

    fn wait(&self, flags: PollFlags, until: Instant) -> Result<bool, LinkError> {
        let left = until.saturating_duration_since(Instant::now());
        let mut fds = [PollFd::new(self.file.as_fd(), flags)];
        match poll_for(&mut fds, left) {
            Ok(0) => Ok(false),
            Ok(_) => {
                let got = fds[0].revents().unwrap_or(PollFlags::empty());
                if got.intersects(PollFlags::POLLHUP | PollFlags::POLLERR | PollFlags::POLLNVAL)
                    && !got.contains(PollFlags::POLLIN)
                {
                    return Err(LinkError::Gone(format!("poll: {got:?}")));
                }
                Ok(true)
            }
            Err(nix::errno::Errno::EINTR) => Ok(false),
            Err(e) => Err(LinkError::Gone(e.to_string())),
        }
    }

    /// `frame`'s bytes with the next sequence number of this direction (taken), and that number.
    pub fn encode(&mut self, frame: &Frame) -> (Vec<u8>, u16) {
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        (frame.encode(seq), seq)
    }

    /// Sends `frame` with the next sequence number of this direction and returns the number. A
    /// frame the line has no room for within a short wait is dropped and counted in
    /// [`Link::unsent`].
    pub fn send(&mut self, frame: &Frame) -> Result<u16, LinkError> {
        let (bytes, seq) = self.encode(frame);
        self.write_bytes(&bytes)?;
        Ok(seq)
    }

    /// Writes raw bytes (a whole frame or, for fault injection, anything).
    pub fn write_bytes(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        let until = Instant::now() + WRITE_WAIT;
        let mut done = 0;
        while done < bytes.len() {
            match self.file.write(&bytes[done..]) {
                Ok(0) => return Err(LinkError::Gone("write returned 0".into())),
                Ok(n) => done += n,
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    if Instant::now() >= until || !self.wait(PollFlags::POLLOUT, until)? {
                        self.unsent += 1;
                        return Ok(());
                    }
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(LinkError::Gone(e.to_string())),
            }
        }
        Ok(())
    }

    /// The next frame or skip, waiting for bytes until `deadline`; `None` when it passes.
    pub fn next(&mut self, deadline: Instant) -> Result<Option<Decoded>, LinkError> {
        let mut buf = [0u8; 1024];
        loop {
            if let Some(d) = self.decoder.decode() {
                return Ok(Some(d));
            }
            match self.file.read(&mut buf) {
                Ok(0) => return Err(LinkError::Gone("end of file".into())),
                Ok(n) => self.decoder.push(&buf[..n]),
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    if Instant::now() >= deadline || !self.wait(PollFlags::POLLIN, deadline)? {
                        return Ok(None);
                    }
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(LinkError::Gone(e.to_string())),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tty::{open_line, open_pty};
    use capsule_device::Force;

    #[test]
    fn frames_cross_a_socket_pair_both_ways_from_cloned_ends(
    ) -> Result<(), Box<dyn std::error::Error>> {
        let (a, b) = UnixStream::pair()?;
        a.set_nonblocking(true)?;
        b.set_nonblocking(true)?;
        let mut reader = Link::new(a);
        // a second handle writes with its own sequence numbers while the first reads
        let mut writer = reader.try_clone()?;
        let mut device = Link::new(b);
        writer.send(&Frame::Force(Force {
            force_n: 1.5,
            answers: 7,
        }))?;
        let got = device.next(Instant::now() + Duration::from_secs(1))?;
        assert!(
            matches!(got, Some(Decoded::Frame { seq: 0, frame: Frame::Force(f), .. }) if f.answers == 7),
            "{got:?}"
        );
        device.send(&Frame::Force(Force {
            force_n: 2.0,
            answers: 1,
        }))?;
        assert!(matches!(
            reader.next(Instant::now() + Duration::from_secs(1))?,
            Some(Decoded::Frame { seq: 0, .. })
        ));
        drop(device);
        assert!(matches!(
            reader.next(Instant::now() + Duration::from_secs(1)),
            Err(LinkError::Gone(_))
        ));
        Ok(())
    }

    #[test]
    fn frames_cross_a_pty_and_a_closed_device_end_is_seen() -> Result<(), Box<dyn std::error::Error>>
    {
        let pty = open_pty()?;
        let mut driver = Link::new(open_line(&pty.path, 921_600)?);
        let mut device = Link::new(pty.master.try_clone()?);
        let soon = || Instant::now() + Duration::from_secs(2);
        for k in 0..3u16 {
            driver.send(&Frame::Force(Force {
                force_n: f32::from(k),
                answers: k,
            }))?;
        }
        for k in 0..3u16 {
            match device.next(soon())? {
                Some(Decoded::Frame { seq, frame, lost }) => {
                    assert_eq!((seq, lost), (k, 0));
                    assert_eq!(
                        frame,
                        Frame::Force(Force {
                            force_n: f32::from(k),
                            answers: k
                        })
                    );
                }
                other => panic!("{other:?}"),
            }
        }
        // nothing more: the deadline returns None
        assert!(device
            .next(Instant::now() + Duration::from_millis(20))?
            .is_none());
        // the device's end closes (its emulator ends, a USB adapter is pulled)
        drop(device);
        drop(pty);
        assert!(matches!(driver.next(soon()), Err(LinkError::Gone(_))));
        Ok(())
    }
}
