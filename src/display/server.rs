//! The page's server: its own thread with a small tokio runtime, serving
//! the page (one self-contained file: no external assets, works offline),
//! the current state as JSON, and a Server-Sent Events stream of frames
//! and sounds. A page opened mid-session gets the setup and the current
//! frame at once; a page that stops reading skips frames (the latest
//! replaces them) and loses the oldest sounds, both counted; neither
//! reaches the telemetry thread, let alone the control thread.

use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::thread::JoinHandle;
use std::time::Duration;

use axum::Router;
use axum::extract::State;
use axum::http::header;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use tokio_stream::StreamExt;
use tokio_stream::wrappers::errors::BroadcastStreamRecvError;
use tokio_stream::wrappers::{BroadcastStream, WatchStream};

use crate::display::hub::Feed;

/// The page: HTML, CSS, JavaScript and the sounds' code in one file.
pub const PAGE: &str = include_str!("page/index.html");

/// The page being served; stops when dropped.
pub struct DisplayServer {
    address: SocketAddr,
    shutdown: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl DisplayServer {
    /// Takes `address` for the page (before anything starts: a clear
    /// error if it cannot).
    pub fn bind(address: SocketAddr) -> anyhow::Result<std::net::TcpListener> {
        std::net::TcpListener::bind(address)
            .and_then(|l| l.set_nonblocking(true).map(|()| l))
            .map_err(|e| {
                let hint = if e.kind() == std::io::ErrorKind::AddrInUse {
                    "is another sipnpuff running? "
                } else {
                    ""
                };
                anyhow::anyhow!(
                    "the display cannot listen on {address}: {e} — {hint}choose another address with --display HOST:PORT, or run without the page with --no-display"
                )
            })
    }

    /// Serves `feed` on `listener` (from [`DisplayServer::bind`]) from its
    /// own thread.
    pub fn serve(
        listener: std::net::TcpListener,
        feed: Arc<Feed>,
    ) -> anyhow::Result<DisplayServer> {
        let address = listener.local_addr()?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()
            .map_err(|e| anyhow::anyhow!("the display cannot start its runtime: {e}"))?;
        let (shutdown, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name("display".into())
            .spawn(move || {
                runtime.block_on(async move {
                    let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
                        return;
                    };
                    let serve = axum::serve(listener, router(feed));
                    tokio::select! {
                        _ = serve => {}
                        _ = stopped => {}
                    }
                });
                // Open pages' streams end here (they never end by themselves).
                runtime.shutdown_timeout(Duration::from_millis(100));
            })
            .map_err(|e| anyhow::anyhow!("cannot start the display thread: {e}"))?;
        Ok(DisplayServer {
            address,
            shutdown: Some(shutdown),
            thread: Some(thread),
        })
    }

    /// Where the page is served (the port chosen, with port 0).
    pub fn address(&self) -> SocketAddr {
        self.address
    }
}

impl Drop for DisplayServer {
    fn drop(&mut self) {
        if let Some(shutdown) = self.shutdown.take() {
            let _ = shutdown.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The routes: `/` the page, `/state` the setup and the latest frame as
/// JSON, `/events` the stream.
pub fn router(feed: Arc<Feed>) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/state", get(state))
        .route("/events", get(events))
        .with_state(feed)
}

async fn page() -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        PAGE,
    )
        .into_response()
}

async fn state(State(feed): State<Arc<Feed>>) -> Response {
    let body = format!(
        "{{\"setup\":{},\"frame\":{}}}",
        feed.setup_json,
        feed.latest().json
    );
    (
        [
            (header::CONTENT_TYPE, "application/json"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        body,
    )
        .into_response()
}

/// One page's stream: the setup, the current frame, then each newer frame
/// and each sound.
async fn events(State(feed): State<Arc<Feed>>) -> impl IntoResponse {
    let open = PageOpen::new(feed.clone());
    let setup = Event::default()
        .event("setup")
        .data(feed.setup_json.clone());
    let mut last_seq = None;
    let counting = feed.clone();
    let frames = WatchStream::new(feed.frames()).map(move |published| {
        let stats = &counting.stats;
        if let Some(last) = last_seq
            && published.seq > last + 1
        {
            stats
                .counts
                .frames_skipped
                .fetch_add(published.seq - last - 1, Ordering::Relaxed);
        }
        last_seq = Some(published.seq);
        stats.counts.frames_sent.fetch_add(1, Ordering::Relaxed);
        if published.last {
            stats.last_frames_sent.fetch_add(1, Ordering::Relaxed);
        }
        // The stream owns the page's count: it ends with the stream.
        let _open = &open;
        Some(Event::default().event("frame").data(published.json.clone()))
    });
    let counting = feed.clone();
    let cues = BroadcastStream::new(feed.cues()).map(move |cue| match cue {
        Ok(cue) => Some(
            Event::default()
                .event("cue")
                .data(serde_json::to_string(&cue).unwrap_or_default()),
        ),
        Err(BroadcastStreamRecvError::Lagged(n)) => {
            counting
                .stats
                .counts
                .cues_dropped
                .fetch_add(n, Ordering::Relaxed);
            None
        }
    });
    let stream = tokio_stream::once(Some(setup))
        .chain(frames.merge(cues))
        .filter_map(|event| event.map(Ok::<_, Infallible>));
    Sse::new(stream).keep_alive(KeepAlive::new().interval(Duration::from_secs(5)))
}

/// Counts a page open while its stream lives.
struct PageOpen(Arc<Feed>);

impl PageOpen {
    fn new(feed: Arc<Feed>) -> PageOpen {
        feed.stats
            .counts
            .pages_opened
            .fetch_add(1, Ordering::Relaxed);
        feed.stats.pages_open.fetch_add(1, Ordering::Relaxed);
        PageOpen(feed)
    }
}

impl Drop for PageOpen {
    fn drop(&mut self) {
        self.0.stats.pages_open.fetch_sub(1, Ordering::Relaxed);
    }
}
