//! The listener: a thread per connection, each request checked by the
//! [`Guard`] and then answered with a page file, the WebSocket, or a
//! one-line refusal; at most `max_connections` at once.

use crate::assets;
use crate::config::Config;
use crate::guard::{Guard, TOKEN_COOKIE};
use crate::http::{self, HeadError, Response};
use crate::session::{self, Context};
use crate::viewer::Viewer;
use std::io;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// How long a client has to send its request head.
const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// A bound server.
pub struct Server {
    listener: TcpListener,
    shared: Arc<Shared>,
}

struct Shared {
    cx: Context,
    guard: Guard,
    active: AtomicUsize,
    max: usize,
}

impl Server {
    /// Bind as `config` says, to show `viewer`.
    pub fn bind(config: &Config, viewer: Viewer) -> io::Result<Server> {
        let listener = TcpListener::bind(config.addr)?;
        let addr = listener.local_addr()?;
        let guard = Guard::new(addr, config.token.clone(), &config.extra_hosts);
        Ok(Server {
            listener,
            shared: Arc::new(Shared {
                cx: Context {
                    viewer: Arc::new(viewer),
                    save_dir: config.save_dir.clone(),
                },
                guard,
                active: AtomicUsize::new(0),
                max: config.max_connections.max(1),
            }),
        })
    }

    /// The address bound (with the port the system picked).
    pub fn addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// The page's address, with the token when one is needed: the
    /// first of [`Server::urls`].
    pub fn url(&self) -> io::Result<String> {
        Ok(self.urls()?.swap_remove(0))
    }

    /// The page's addresses, with the token when one is needed: the
    /// bound one, or for a wildcard address (`0.0.0.0`, `::`) the
    /// machine's primary address and loopback
    /// ([`crate::config::reachable`]).
    pub fn urls(&self) -> io::Result<Vec<String>> {
        let addr = self.addr()?;
        let token = self
            .shared
            .guard
            .token()
            .map(|t| format!("?token={t}"))
            .unwrap_or_default();
        Ok(crate::config::reachable(addr.ip())
            .into_iter()
            .map(|ip| {
                let host = match ip {
                    std::net::IpAddr::V6(v6) => format!("[{v6}]"),
                    v4 => v4.to_string(),
                };
                format!("http://{host}:{}/{token}", addr.port())
            })
            .collect())
    }

    /// Serve until the process ends.
    pub fn run(self) {
        for stream in self.listener.incoming() {
            let Ok(stream) = stream else { continue };
            let shared = Arc::clone(&self.shared);
            if shared.active.fetch_add(1, Ordering::SeqCst) >= shared.max {
                shared.active.fetch_sub(1, Ordering::SeqCst);
                let mut stream = stream;
                let _ = Response::text(503, "busy: too many connections to vol-view")
                    .write_to(&mut stream);
                continue;
            }
            std::thread::spawn(move || {
                connection(stream, &shared);
                shared.active.fetch_sub(1, Ordering::SeqCst);
            });
        }
    }
}

/// Answer one connection.
fn connection(mut stream: TcpStream, shared: &Shared) {
    let _ = stream.set_nodelay(true);
    if stream.set_read_timeout(Some(HEAD_TIMEOUT)).is_err() {
        return;
    }
    let head = match http::read_head(&mut stream) {
        Ok(h) => h,
        Err(HeadError::Io(_)) => return,
        Err(HeadError::Malformed(e)) => {
            let _ = Response::text(400, format!("malformed request: {e}")).write_to(&mut stream);
            return;
        }
        Err(HeadError::TooLarge) => {
            let _ = Response::text(431, "the request head is too large").write_to(&mut stream);
            return;
        }
    };
    if let Err(refusal) = shared.guard.check(&head) {
        let _ = refusal.write_to(&mut stream);
        return;
    }
    if head.method != "GET" {
        let _ = Response::text(405, "vol-view answers GET requests only").write_to(&mut stream);
        return;
    }
    let path = head.path().to_string();
    if assets::escapes(&path) {
        let _ = Response::text(
            400,
            "refused: the path leaves what vol-view serves (its page and /ws)",
        )
        .write_to(&mut stream);
        return;
    }
    if path == "/ws" {
        session::serve(stream, head, shared.cx.clone());
        return;
    }
    let response = match assets::find(&path) {
        Some(asset) => {
            let mut r = Response {
                status: 200,
                content_type: asset.content_type,
                headers: Vec::new(),
                body: asset.body.to_vec(),
            };
            // The page's own requests carry the token as a cookie.
            if let (Some(t), Some(_)) = (shared.guard.token(), head.query("token")) {
                r.headers.push((
                    "Set-Cookie".into(),
                    format!("{TOKEN_COOKIE}={t}; Path=/; HttpOnly; SameSite=Strict"),
                ));
            }
            r
        }
        None => Response::text(
            404,
            format!(
                "not found: {}: vol-view serves its page (/) and its WebSocket (/ws) only",
                volcore::text::clip(&volcore::text::escape(&path), 80)
            ),
        ),
    };
    let _ = response.write_to(&mut stream);
}
