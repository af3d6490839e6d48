//! The live viewer's connection, watched so that a run whose viewer goes away says so once and
//! follows one rule (docs/guide/running.md, "When the viewer goes away"): with a file named by `--save` as well,
//! the run finishes into that file; with no file, it stops cleanly after the current frame.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use rerun::sink::{
    GrpcSink, GrpcSinkConnectionFailure, GrpcSinkConnectionState, LogSink, SinkFlushError,
};

/// How long a viewer may take to accept the connection before it counts as absent.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// A gRPC connection to a viewer, shared between the recording stream and the recorder thread.
#[derive(Clone)]
pub struct ViewerLink {
    sink: Arc<GrpcSink>,
    url: String,
}

impl std::fmt::Debug for ViewerLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ViewerLink")
            .field("url", &self.url)
            .finish()
    }
}

/// Why a viewer cannot be streamed to.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    #[error(
        "`{url}` is not a viewer address ({source}): use rerun+http://HOST:PORT/proxy, e.g. rerun+http://127.0.0.1:9876/proxy"
    )]
    NotAnAddress {
        url: String,
        source: rerun::external::re_uri::Error,
    },
}

/// What became of the viewer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkState {
    Up,
    /// Still connecting, within [`CONNECT_TIMEOUT`].
    Connecting,
    /// Gone, and why.
    Gone(Gone),
}

/// Why the viewer is gone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Gone {
    #[error("no viewer accepted the connection within {} s", CONNECT_TIMEOUT.as_secs())]
    NeverAccepted,
    #[error("the viewer closed the connection")]
    Closed,
    #[error("the connection broke: {0}")]
    Broke(GrpcSinkConnectionFailure),
}

impl ViewerLink {
    /// Start connecting to the viewer at `url` (`rerun+http://HOST:PORT/proxy`); returns the link
    /// and the sink to give the recording stream. `tolerate_loss`: a file is recorded as well, so
    /// a lost viewer is no error when the recording is flushed.
    pub fn connect(
        url: &str,
        tolerate_loss: bool,
    ) -> Result<(Self, Box<dyn LogSink>), ConnectError> {
        let uri = url.parse().map_err(|source| ConnectError::NotAnAddress {
            url: url.to_owned(),
            source,
        })?;
        let sink = Arc::new(GrpcSink::new(uri));
        let link = Self {
            sink: sink.clone(),
            url: url.to_owned(),
        };
        let shared = SharedSink {
            link: link.clone(),
            tolerate_loss,
            waiting: Mutex::new(Vec::new()),
        };
        Ok((link, Box::new(shared)))
    }

    pub fn url(&self) -> &str {
        &self.url
    }

    pub fn state(&self) -> LinkState {
        match self.sink.status() {
            GrpcSinkConnectionState::Connected => LinkState::Up,
            GrpcSinkConnectionState::Connecting { started } => {
                if started.elapsed() > CONNECT_TIMEOUT {
                    LinkState::Gone(Gone::NeverAccepted)
                } else {
                    LinkState::Connecting
                }
            }
            GrpcSinkConnectionState::Disconnected(Ok(())) => LinkState::Gone(Gone::Closed),
            GrpcSinkConnectionState::Disconnected(Err(e)) => LinkState::Gone(Gone::Broke(e)),
        }
    }
}

/// The recording stream's side of the link. Rerun's gRPC sink holds at most 100 messages until
/// it connects and then blocks the sender, for ever if no viewer comes; so messages wait here
/// until it connects, and are dropped once the viewer is gone (the recorder says so). Sending
/// never blocks on an absent viewer.
struct SharedSink {
    link: ViewerLink,
    tolerate_loss: bool,
    waiting: Mutex<Vec<rerun::log::LogMsg>>,
}

impl SharedSink {
    fn waiting(&self) -> Vec<rerun::log::LogMsg> {
        self.waiting
            .lock()
            .map(|mut w| std::mem::take(&mut *w))
            .unwrap_or_default()
    }
}

impl LogSink for SharedSink {
    fn send(&self, msg: rerun::log::LogMsg) {
        match self.link.state() {
            LinkState::Up => {
                self.link.sink.send_all(self.waiting());
                self.link.sink.send(msg);
            }
            LinkState::Connecting => {
                if let Ok(mut w) = self.waiting.lock() {
                    w.push(msg);
                }
            }
            LinkState::Gone(_) => {}
        }
    }

    fn flush_blocking(&self, timeout: Duration) -> Result<(), SinkFlushError> {
        while self.link.state() == LinkState::Connecting {
            std::thread::sleep(Duration::from_millis(50));
        }
        match self.link.state() {
            LinkState::Up => {
                self.link.sink.send_all(self.waiting());
                self.link.sink.flush_blocking(timeout)
            }
            // Reported by the recorder when it happened; the file has everything.
            _ if self.tolerate_loss => Ok(()),
            LinkState::Gone(why) => Err(SinkFlushError::failed(format!(
                "the viewer at {} went away: {why}",
                self.link.url
            ))),
            LinkState::Connecting => Ok(()),
        }
    }

    fn default_batcher_config(&self) -> rerun::log::ChunkBatcherConfig {
        self.link.sink.default_batcher_config()
    }
}
