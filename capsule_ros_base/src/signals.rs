//! The end of a node's run: Ctrl-C (SIGINT) or SIGTERM.

use crate::error::{Context as _, Result};

/// [`shutdown_signal`], logged (`SIGTERM: shutting down`): the end of a node's loop.
pub async fn shutdown() -> Result<()> {
    let sig = shutdown_signal().await?;
    tracing::info!("{sig}: shutting down");
    Ok(())
}

/// Resolves when the process gets Ctrl-C (SIGINT) or SIGTERM.
pub async fn shutdown_signal() -> Result<&'static str> {
    use tokio::signal::unix::{signal, SignalKind};
    let mut term = signal(SignalKind::terminate()).context("cannot install the SIGTERM handler")?;
    let mut int = signal(SignalKind::interrupt()).context("cannot install the SIGINT handler")?;
    tokio::select! {
        _ = term.recv() => Ok("SIGTERM"),
        _ = int.recv() => Ok("SIGINT"),
    }
}
