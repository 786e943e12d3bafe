//! The error of an input refused before any work started.

/// An input refused before any work started (a flag, a scene, a limit): exit status 2, as for
/// clap's own refusals, and as the node binaries do.
#[derive(Debug)]
pub struct Refused(pub String);

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Refused {}
