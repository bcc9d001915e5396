//! One page's WebSocket: the handshake, then a loop that reads the
//! page's messages (answering a malformed one with an error and going
//! on) and writes what the render worker produces.

use crate::http::{Head, Response};
use crate::protocol::{ClientMessage, Out, MAX_MESSAGE};
use crate::save::{self, Snapshot};
use crate::slice;
use crate::viewer::Viewer;
use crate::worker::{Job, Queue, Worker};
use serde_json::json;
use std::io::{ErrorKind, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Message, WebSocket};

/// How long a read waits before the loop looks for frames to send.
const POLL: Duration = Duration::from_millis(3);

/// What a session needs from the server.
#[derive(Clone)]
pub struct Context {
    /// The volume and the renders.
    pub viewer: Arc<Viewer>,
    /// Where saves are also written, if anywhere.
    pub save_dir: Option<PathBuf>,
}

/// Answer the WebSocket handshake in `head`, or say why not.
fn handshake(stream: &mut TcpStream, head: &Head) -> Result<(), Response> {
    if !head.has_token("upgrade", "websocket") || !head.has_token("connection", "upgrade") {
        return Err(Response::text(
            426,
            "/ws is vol-view's WebSocket: connect with a WebSocket client",
        ));
    }
    if head.header("sec-websocket-version") != Some("13") {
        let mut r = Response::text(426, "vol-view speaks WebSocket version 13");
        r.headers
            .push(("Sec-WebSocket-Version".into(), "13".into()));
        return Err(r);
    }
    let Some(key) = head.header("sec-websocket-key") else {
        return Err(Response::text(
            400,
            "a WebSocket handshake needs Sec-WebSocket-Key",
        ));
    };
    let accept = tungstenite::handshake::derive_accept_key(key.trim().as_bytes());
    let reply = format!(
        "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
         Sec-WebSocket-Accept: {accept}\r\n\r\n"
    );
    stream
        .write_all(reply.as_bytes())
        .map_err(|_| Response::text(400, "the connection closed during the handshake"))
}

/// Serve one page's WebSocket on `stream` until it closes.
pub fn serve(mut stream: TcpStream, head: Head, cx: Context) {
    if let Err(r) = handshake(&mut stream, &head) {
        let _ = r.write_to(&mut stream);
        return;
    }
    if stream.set_read_timeout(Some(POLL)).is_err() {
        return;
    }
    let config = WebSocketConfig::default()
        .max_message_size(Some(MAX_MESSAGE))
        .max_frame_size(Some(MAX_MESSAGE));
    let mut ws = WebSocket::from_partially_read(stream, head.rest, Role::Server, Some(config));
    let hello = match crate::hello::hello(&cx.viewer, cx.save_dir.is_some()) {
        Ok(h) => Out::json(h),
        Err(e) => Out::error(None, e.message()),
    };
    if send(&mut ws, &hello).is_err() {
        return;
    }
    let queue = Arc::new(Queue::default());
    let snapshot = Arc::new(Mutex::new(None));
    let (tx, rx) = mpsc::channel();
    let worker = Worker::new(
        Arc::clone(&cx.viewer),
        Arc::clone(&queue),
        tx.clone(),
        Arc::clone(&snapshot),
    );
    let handle = std::thread::spawn(move || worker.run());
    run(&mut ws, &cx, &queue, &snapshot, &rx);
    queue.close();
    let _ = handle.join();
    let _ = ws.close(None);
    let _ = ws.flush();
}

/// The session's loop: read, answer, forward the worker's messages.
fn run(
    ws: &mut WebSocket<TcpStream>,
    cx: &Context,
    queue: &Queue,
    snapshot: &Mutex<Option<Snapshot>>,
    rx: &Receiver<Out>,
) {
    loop {
        match ws.read() {
            Ok(Message::Text(text)) => {
                let answer = handle(text.as_str(), cx, queue, snapshot);
                if let Some(out) = answer {
                    if send(ws, &out).is_err() {
                        return;
                    }
                }
            }
            Ok(Message::Binary(_)) => {
                let out = Out::error(None, "vol-view takes text messages (JSON), not binary ones");
                if send(ws, &out).is_err() {
                    return;
                }
            }
            Ok(Message::Close(_)) => {}
            Ok(_) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            // Closed, or a protocol error (tungstenite has answered it).
            Err(_) => return,
        }
        while let Ok(out) = rx.try_recv() {
            if send(ws, &out).is_err() {
                return;
            }
        }
    }
}

/// Write one message and flush it.
fn send(ws: &mut WebSocket<TcpStream>, out: &Out) -> Result<(), tungstenite::Error> {
    ws.send(Message::Binary(out.encode().into()))
}

/// The answer to one text message, if it has one now (renders answer
/// later, through the worker).
fn handle(
    text: &str,
    cx: &Context,
    queue: &Queue,
    snapshot: &Mutex<Option<Snapshot>>,
) -> Option<Out> {
    let msg = match ClientMessage::parse(text) {
        Ok(m) => m,
        Err(e) => return Some(Out::error(None, e)),
    };
    match msg {
        ClientMessage::Render {
            seq,
            pairs,
            preview,
        } => queue
            .submit(Job {
                seq,
                pairs,
                preview,
            })
            .err()
            .map(|e| Out::error(Some(seq), e)),
        ClientMessage::Psnr { seq } => {
            queue.want_psnr(seq);
            None
        }
        ClientMessage::Save { what } => {
            let snap = snapshot.lock().unwrap_or_else(|p| p.into_inner()).clone();
            let Some(snap) = snap else {
                return Some(Out::error(
                    None,
                    "nothing to save yet: no full frame has been shown",
                ));
            };
            Some(match save::download(&snap, what) {
                Ok(d) => {
                    let saved = match &cx.save_dir {
                        Some(dir) => match save::write_into(dir, &d) {
                            Ok(p) => Some(p.display().to_string()),
                            Err(e) => return Some(Out::error(Some(snap.seq), e)),
                        },
                        None => None,
                    };
                    Out {
                        header: json!({"type": "download", "seq": snap.seq, "name": d.name,
                                       "mime": d.mime, "saved": saved,
                                       "command": snap.command}),
                        payload: d.bytes,
                    }
                }
                Err(e) => Out::error(Some(snap.seq), e),
            })
        }
        ClientMessage::Slice { axis, index } => Some(
            match slice::extract(&cx.viewer.source.volume, axis, index) {
                Ok(s) => Out {
                    header: json!({"type": "slice", "axis": axis_name(axis), "index": s.index,
                                   "width": s.width, "height": s.height, "stride": s.stride}),
                    payload: s.values.iter().flat_map(|v| v.to_le_bytes()).collect(),
                },
                Err(e) => Out::error(None, e),
            },
        ),
    }
}

/// The axis as the page names it.
fn axis_name(axis: crate::protocol::Axis) -> &'static str {
    match axis {
        crate::protocol::Axis::X => "x",
        crate::protocol::Axis::Y => "y",
        crate::protocol::Axis::Z => "z",
    }
}
