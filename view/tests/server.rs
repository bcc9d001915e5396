//! The server without a browser: refusals (paths outside what it serves,
//! another site's Host or Origin, a missing token off loopback),
//! malformed WebSocket messages, stale frames cancelled, 20 clients at
//! once, path-traced passes and saves; after each refusal the server
//! still serves.

use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tungstenite::{Message, WebSocket};
use volcore::scene::{SceneSource, ShapesScene};
use volcore::{Dims, SampleType, VolumeMeta};
use volview::protocol::Out;
use volview::{Config, Server, Viewer};

/// A 64³ shapes volume in `dir`.
fn volume(dir: &Path) -> PathBuf {
    let dims = Dims::new(64, 64, 64).unwrap();
    let scene = ShapesScene::new(dims, 2, 20, 14, 100.0);
    let src = SceneSource::<u8>::new(&scene);
    let path = dir.join("shapes.vvol");
    let mut f = std::fs::File::create(&path).unwrap();
    let meta = VolumeMeta::sliced(dims, SampleType::U8);
    volformats::vvol::write(&src, meta, volformats::output::Sink::File(&mut f), &|_| {}).unwrap();
    path
}

/// A server on a free loopback port (or as `config` says) for a fresh
/// volume; its address.
fn start(config: Config) -> (SocketAddr, tempfile::TempDir, Option<String>) {
    let dir = tempfile::tempdir().unwrap();
    let viewer = Viewer::open(Some(&volume(dir.path())), None).unwrap();
    let server = Server::bind(&config, viewer).unwrap();
    let addr = server.addr().unwrap();
    let url = server.url().unwrap();
    std::thread::spawn(move || server.run());
    let token = url.split_once("?token=").map(|(_, t)| t.to_string());
    (addr, dir, token)
}

/// The loopback address of a server bound at `addr`.
fn local(addr: SocketAddr) -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], addr.port()))
}

/// Send a raw request; the status and the body.
fn http(addr: SocketAddr, request: &str) -> (u16, String) {
    let mut s = TcpStream::connect(local(addr)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let status = text
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = text
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (status, body)
}

fn get(addr: SocketAddr, target: &str) -> (u16, String) {
    http(
        addr,
        &format!(
            "GET {target} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
            addr.port()
        ),
    )
}

type Ws = WebSocket<TcpStream>;

/// A WebSocket client, its hello read.
fn connect(addr: SocketAddr, query: &str) -> (Ws, Value) {
    let stream = TcpStream::connect(local(addr)).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(120)))
        .unwrap();
    let url = format!("ws://127.0.0.1:{}/ws{query}", addr.port());
    let (mut ws, _) = tungstenite::client(url, stream).unwrap();
    let hello = next(&mut ws);
    assert_eq!(hello.header["type"], "hello", "{}", hello.header);
    (ws, hello.header)
}

fn next(ws: &mut Ws) -> Out {
    loop {
        match ws.read().unwrap() {
            Message::Binary(b) => return Out::decode(&b).unwrap(),
            Message::Text(t) => panic!("text from the server: {t}"),
            _ => {}
        }
    }
}

/// Read messages until one of `kind` (about `seq`, when given) arrives.
fn until(ws: &mut Ws, kind: &str, seq: Option<u64>) -> (Out, Vec<Out>) {
    let mut before = Vec::new();
    loop {
        let m = next(ws);
        if m.header["type"] == kind && seq.is_none_or(|s| m.header["seq"] == s) {
            return (m, before);
        }
        before.push(m);
    }
}

fn render(ws: &mut Ws, seq: u64, pairs: Value) {
    let msg = json!({"type": "render", "seq": seq, "pairs": pairs});
    ws.send(Message::Text(msg.to_string().into())).unwrap();
}

fn small(orbit: f32) -> Value {
    json!({"tf": "shapes", "size": [48, 40], "orbit": [orbit, 20, 150]})
}

#[test]
fn refusals_are_clear_and_the_server_goes_on() {
    let (addr, _dir, _) = start(Config::loopback(0));
    let (status, body) = get(addr, "/");
    assert_eq!(status, 200);
    assert!(body.contains("<canvas id=\"view\""));
    let (status, body) = get(addr, "/../../etc/passwd");
    assert_eq!(status, 400, "{body}");
    assert!(body.starts_with("refused: the path leaves"), "{body}");
    assert!(!body.contains("root:"));
    let (status, _) = get(addr, "/%2e%2e/%2e%2e/etc/passwd");
    assert_eq!(status, 400);
    let (status, body) = get(addr, "/etc/passwd");
    assert_eq!(status, 404);
    assert!(body.starts_with("not found: /etc/passwd"), "{body}");
    let port = addr.port();
    let (status, body) = http(
        addr,
        &format!("GET / HTTP/1.1\r\nHost: evil.example:{port}\r\n\r\n"),
    );
    assert_eq!(status, 421);
    assert!(body.contains("Host `evil.example"), "{body}");
    let (status, body) = http(
        addr,
        &format!(
            "GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://evil.example\r\n\
             Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\n\
             Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n"
        ),
    );
    assert_eq!(status, 403);
    assert!(body.contains("Origin `http://evil.example`"), "{body}");
    let (status, _) = http(
        addr,
        &format!("POST / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n"),
    );
    assert_eq!(status, 405);
    let (status, body) = http(addr, "NOT HTTP AT ALL\r\n\r\n");
    assert_eq!(status, 400, "{body}");
    let (status, body) = get(addr, "/ws");
    assert_eq!(status, 426, "{body}");
    // Still serving.
    assert_eq!(get(addr, "/app.js").0, 200);
    let (mut ws, hello) = connect(addr, "");
    assert!(hello["options"]
        .as_array()
        .unwrap()
        .iter()
        .any(|o| o["long"] == "mode"));
    render(&mut ws, 1, small(30.0));
    let (frame, _) = until(&mut ws, "frame", Some(1));
    assert!(frame.payload.starts_with(b"\x89PNG"));
}

#[test]
fn off_loopback_the_token_is_needed() {
    let config = Config::listen("0.0.0.0:0".parse().unwrap()).unwrap();
    let (addr, _dir, token) = start(config);
    let token = token.expect("a token off loopback");
    let (status, body) = get(addr, "/");
    assert_eq!(status, 401);
    assert!(body.contains("needs the token"), "{body}");
    assert_eq!(get(addr, "/?token=wrong").0, 403);
    let port = addr.port();
    let mut s = TcpStream::connect(local(addr)).unwrap();
    write!(
        s,
        "GET /?token={token} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n"
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    assert!(text.starts_with("HTTP/1.1 200"));
    assert!(text.contains(&format!("Set-Cookie: volview_token={token}")));
    // The WebSocket without the token is refused, with it served.
    let stream = TcpStream::connect(local(addr)).unwrap();
    let url = format!("ws://127.0.0.1:{port}/ws");
    assert!(tungstenite::client(url, stream).is_err());
    let (mut ws, _) = connect(addr, &format!("?token={token}"));
    render(&mut ws, 1, small(10.0));
    until(&mut ws, "frame", Some(1));
}

#[test]
fn malformed_messages_are_answered_and_the_page_goes_on() {
    let (addr, _dir, _) = start(Config::loopback(0));
    let (mut ws, _) = connect(addr, "");
    ws.send(Message::Text("{not json".into())).unwrap();
    let e = next(&mut ws);
    assert_eq!(e.header["type"], "error");
    assert!(e.header["message"]
        .as_str()
        .unwrap()
        .starts_with("malformed message"));
    ws.send(Message::Binary(vec![1, 2, 3].into())).unwrap();
    assert!(next(&mut ws).header["message"]
        .as_str()
        .unwrap()
        .contains("text messages"));
    ws.send(Message::Text(r#"{"type":"render","seq":"x"}"#.into()))
        .unwrap();
    assert_eq!(next(&mut ws).header["type"], "error");
    render(&mut ws, 1, json!({"modes": "mip"}));
    let (e, _) = until(&mut ws, "error", Some(1));
    assert_eq!(e.header["message"], "unknown option `modes`");
    render(&mut ws, 2, json!({"output": "/tmp/x.png"}));
    let (e, _) = until(&mut ws, "error", Some(2));
    assert!(e.header["message"]
        .as_str()
        .unwrap()
        .contains("does not name files"));
    render(&mut ws, 3, json!({"tf": "/etc/passwd"}));
    let (e, _) = until(&mut ws, "error", Some(3));
    assert!(e.header["message"]
        .as_str()
        .unwrap()
        .contains("not a preset"));
    render(&mut ws, 4, json!({"step": "-1"}));
    let (e, _) = until(&mut ws, "error", Some(4));
    assert!(
        e.header["message"].as_str().unwrap().contains("step"),
        "{}",
        e.header
    );
    render(&mut ws, 5, small(40.0));
    until(&mut ws, "frame", Some(5));
    render(&mut ws, 5, small(50.0));
    let (e, _) = until(&mut ws, "error", Some(5));
    assert!(e.header["message"]
        .as_str()
        .unwrap()
        .contains("seq must rise"));
    ws.send(Message::Text(
        r#"{"type":"slice","axis":"z","index":999}"#.into(),
    ))
    .unwrap();
    assert!(next(&mut ws).header["message"]
        .as_str()
        .unwrap()
        .contains("outside the volume"));
    ws.send(Message::Text(
        r#"{"type":"slice","axis":"y","index":10}"#.into(),
    ))
    .unwrap();
    let s = next(&mut ws);
    assert_eq!(s.header["type"], "slice");
    assert_eq!(s.payload.len(), 64 * 64 * 4);
    render(&mut ws, 6, small(60.0));
    let (f, _) = until(&mut ws, "frame", Some(6));
    assert_eq!(
        (f.header["width"].as_u64(), f.header["height"].as_u64()),
        (Some(48), Some(40))
    );
}

#[test]
fn a_newer_request_cancels_the_stale_frame() {
    let (addr, _dir, _) = start(Config::loopback(0));
    let (mut ws, _) = connect(addr, "");
    // Minutes of work: 4096² rays at a tiny step, nothing skipped.
    let slow = json!({"size": [4096, 4096], "step": 0.01, "no-ess": true, "no-ert": true,
                      "tf": "shapes", "orbit": [30, 20, 100]});
    let t = Instant::now();
    render(&mut ws, 1, slow);
    std::thread::sleep(Duration::from_millis(200));
    render(&mut ws, 2, small(80.0));
    let (frame, before) = until(&mut ws, "frame", Some(2));
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
    assert!(
        before.iter().all(|m| m.header["type"] != "frame"),
        "a stale frame was sent"
    );
    assert!(before
        .iter()
        .any(|m| m.header["type"] == "cancelled" && m.header["seq"] == 1));
    assert_eq!(frame.header["final"], true);
    // Nothing of request 1 follows.
    render(&mut ws, 3, small(90.0));
    let (_, between) = until(&mut ws, "frame", Some(3));
    assert!(between.iter().all(|m| m.header["seq"] != 1));
}

#[test]
fn twenty_clients_at_once() {
    let (addr, _dir, _) = start(Config::loopback(0));
    let clients: Vec<_> = (0..20)
        .map(|i| {
            std::thread::spawn(move || {
                let (mut ws, _) = connect(addr, "");
                render(&mut ws, 1, small(i as f32 * 18.0));
                let (f, _) = until(&mut ws, "frame", Some(1));
                assert!(f.payload.starts_with(b"\x89PNG"));
                f.header["cost"]["render_s"].as_f64().unwrap()
            })
        })
        .collect();
    for c in clients {
        assert!(c.join().unwrap() > 0.0);
    }
    assert_eq!(get(addr, "/").0, 200);
}

#[test]
fn path_tracing_refines_a_pass_at_a_time_to_the_cli_image() {
    let (addr, dir, _) = start(Config::loopback(0));
    let (mut ws, _) = connect(addr, "");
    let pairs = json!({"mode": "path", "tf": "shapes", "spp": 4, "size": [32, 24],
                       "orbit": [30, 20, 150], "env": 1});
    render(&mut ws, 1, pairs.clone());
    let mut spp = Vec::new();
    let mut errors = Vec::new();
    loop {
        let (f, _) = until(&mut ws, "frame", Some(1));
        spp.push(f.header["cost"]["spp"].as_u64().unwrap());
        errors.push(f.header["cost"]["relative_error"].as_f64());
        if f.header["final"] == true {
            break;
        }
    }
    assert_eq!(spp, [1, 2, 3, 4]);
    ws.send(Message::Text(r#"{"type":"save","what":"pfm"}"#.into()))
        .unwrap();
    let (pfm, _) = until(&mut ws, "download", None);
    assert_eq!(pfm.header["name"], "view-1-4spp.pfm");
    // The same render in one go through the library: the same bytes.
    let Value::Object(map) = pairs else { panic!() };
    let request = volscene::Request::from_pairs(map).unwrap();
    let options = request.options();
    let path = dir.path().join("shapes.vvol");
    let source = volscene::Source::open(options, &path).unwrap();
    let plan = volscene::Plan::for_source(options, &source).unwrap();
    let r = volscene::render(options, &source, &plan, &volscene::Cancel::new(), |_| {}).unwrap();
    let mut want = Vec::new();
    volformats::image::encode_pfm(&mut want, 32, 24, 3, &r.linear_rgb()).unwrap();
    assert!(
        pfm.payload == want,
        "the saved PFM differs from one render of 4 spp"
    );
    // The PSNR against the reference of the view.
    ws.send(Message::Text(r#"{"type":"psnr","seq":1}"#.into()))
        .unwrap();
    let (p, _) = until(&mut ws, "psnr", Some(1));
    let db = p.header["db"].as_f64().unwrap();
    assert!(db > 5.0 && db < 80.0, "{db}");
}

#[test]
fn previews_fit_their_budget_and_have_a_psnr_on_request() {
    let (addr, _dir, _) = start(Config::loopback(0));
    let (mut ws, _) = connect(addr, "");
    let pairs = json!({"tf": "shapes", "size": [256, 192], "orbit": [30, 20, 150]});
    let mut choices = Vec::new();
    for seq in 1..=3u64 {
        let msg = json!({"type": "render", "seq": seq, "pairs": pairs, "preview": true});
        ws.send(Message::Text(msg.to_string().into())).unwrap();
        let (f, _) = until(&mut ws, "frame", Some(seq));
        assert_eq!(f.header["preview"], true);
        let c = f.header["preview_choice"].clone();
        let (w, h) = (c["width"].as_u64().unwrap(), c["height"].as_u64().unwrap());
        // The image sent is the size chosen, within the full view's.
        assert_eq!(
            (f.header["width"].as_u64(), f.header["height"].as_u64()),
            (Some(w), Some(h))
        );
        assert!(w <= 256 && h <= 192 && w >= 8, "{c}");
        let factor = c["step_factor"].as_f64().unwrap();
        assert!((0.25..=8.0).contains(&factor), "{c}");
        assert!(c["expected_s"].as_f64().unwrap() > 0.0, "{c}");
        let note = f.header["note"].as_str().unwrap_or_default().to_string();
        assert!(
            note.starts_with(&format!("preview: {w}x{h}")) && note.contains("expected"),
            "the overlay states the choice: {note}"
        );
        choices.push(c);
    }
    // The PSNR of the preview shown, against the full view's reference.
    ws.send(Message::Text(r#"{"type":"psnr","seq":3}"#.into()))
        .unwrap();
    let (p, _) = until(&mut ws, "psnr", Some(3));
    assert!(
        p.header["identical"] == true || p.header["db"].as_f64().is_some_and(|db| db > 5.0),
        "{}",
        p.header
    );
    assert!(
        p.header["reference"]
            .as_str()
            .is_some_and(|r| r.contains("without early ray termination")),
        "{}",
        p.header
    );
}

#[test]
fn saves_go_to_the_page_and_to_save_dir_only_when_given() {
    let out = tempfile::tempdir().unwrap();
    let mut config = Config::loopback(0);
    config.save_dir = Some(out.path().to_path_buf());
    let (addr, _dir, _) = start(config);
    let (mut ws, _) = connect(addr, "");
    ws.send(Message::Text(r#"{"type":"save","what":"png"}"#.into()))
        .unwrap();
    assert!(next(&mut ws).header["message"]
        .as_str()
        .unwrap()
        .starts_with("nothing to save yet"));
    render(&mut ws, 7, small(20.0));
    until(&mut ws, "frame", Some(7));
    for what in ["png", "pfm", "scene"] {
        let msg = json!({"type": "save", "what": what});
        ws.send(Message::Text(msg.to_string().into())).unwrap();
        let (d, _) = until(&mut ws, "download", None);
        let saved = PathBuf::from(d.header["saved"].as_str().unwrap());
        assert_eq!(std::fs::read(&saved).unwrap(), d.payload);
    }
    let names: Vec<_> = std::fs::read_dir(out.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 3);
    ws.send(Message::Text(r#"{"type":"psnr","seq":7}"#.into()))
        .unwrap();
    let (p, _) = until(&mut ws, "psnr", Some(7));
    assert!(p.header["reference"]
        .as_str()
        .unwrap()
        .contains("without early ray termination"));
}

#[test]
fn bad_volumes_are_one_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.vvol");
    std::fs::write(&bad, b"not a volume").unwrap();
    let exe = env!("CARGO_BIN_EXE_vol-view");
    for args in [
        vec![bad.display().to_string()],
        vec![dir.path().join("missing.nrrd").display().to_string()],
    ] {
        let out = std::process::Command::new(exe)
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{out:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.starts_with("vol-view: ") && err.contains(&args[0]),
            "{err}"
        );
    }
    let out = std::process::Command::new(exe).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let help = std::process::Command::new(exe)
        .arg("--help")
        .output()
        .unwrap();
    assert!(String::from_utf8(help.stdout)
        .unwrap()
        .contains("vol-view shapes.vvol --open"));
}

/// Issue 53 §7: the hello's f32 values in their shortest form (`ert`
/// 0.99, not 0.9900000095367432), and the transfer function the view
/// starts with as points, for the editor to start from: the startup
/// scene's TF file, and each frame's.
#[test]
fn the_hello_states_f32_values_shortest_and_the_transfer_function() {
    let dir = tempfile::tempdir().unwrap();
    let tf = dir.path().join("brain.tf");
    std::fs::write(
        &tf,
        "domain 0 200\nstep 2\nrange 5 9 0 255 0 0.25\npoint 10 255 0 0 0.1\npoint 120.5 0 0 255 0.8\n",
    )
    .unwrap();
    let scene = dir.path().join("start.toml");
    let toml_path = |p: &Path| p.display().to_string().replace('\\', "\\\\");
    std::fs::write(
        &scene,
        format!(
            "volume = \"{}\"\ntf = \"{}\"\n",
            toml_path(&volume(dir.path())),
            toml_path(&tf)
        ),
    )
    .unwrap();
    let viewer = Viewer::open(None, Some(&scene)).unwrap();
    let server = Server::bind(&Config::loopback(0), viewer).unwrap();
    let addr = server.addr().unwrap();
    std::thread::spawn(move || server.run());
    let (mut ws, hello) = connect(addr, "");
    assert_eq!(
        hello["scene"]["ert"].to_string(),
        "0.99",
        "{}",
        hello["scene"]
    );
    assert_eq!(
        hello["tf"],
        json!({"domain": [0.0, 200.0], "step": 2.0,
               "points": [[10.0, 255.0, 0.0, 0.0, 0.1], [120.5, 0.0, 0.0, 255.0, 0.8]],
               "ranges": [[5.0, 9.0, 0.0, 255.0, 0.0, 0.25]]})
    );
    render(&mut ws, 1, small(10.0));
    let (f, _) = until(&mut ws, "frame", Some(1));
    // `shapes`: constant ranges only.
    let ranges = f.header["tf"]["ranges"].as_array().unwrap();
    assert_eq!(ranges.len(), 3, "{}", f.header["tf"]);
}

/// Issue 53 §7: a save during path tracing states the passes it holds:
/// the command shows `--spp N`, the scene file says `spp = N`, and the
/// image, scene and command share one stem (`view-1-Nspp`); the PFM
/// saved is what one render of N samples makes.
#[test]
fn a_save_while_path_tracing_refines_states_its_pass_count() {
    let (addr, dir, _) = start(Config::loopback(0));
    let (mut ws, _) = connect(addr, "");
    let pairs = json!({"mode": "path", "tf": "shapes", "seconds": 600, "size": [48, 40],
                       "orbit": [30, 20, 150], "env": 1});
    render(&mut ws, 1, pairs.clone());
    let (f, _) = until(&mut ws, "frame", Some(1));
    assert_eq!(f.header["final"], false);
    for what in ["pfm", "scene"] {
        let msg = json!({"type": "save", "what": what});
        ws.send(Message::Text(msg.to_string().into())).unwrap();
    }
    let mut saved = Vec::new();
    while saved.len() < 2 {
        let (d, before) = until(&mut ws, "download", None);
        for frame in before.iter().filter(|m| m.header["type"] == "frame") {
            let spp = frame.header["cost"]["spp"].as_u64().unwrap();
            let command = frame.header["command"].as_str().unwrap();
            assert!(command.contains(&format!("--spp={spp} ")), "{command}");
            assert!(!command.contains("--seconds"), "{command}");
            let scene = frame.header["scene"].as_str().unwrap();
            assert!(scene.contains(&format!("spp = {spp}\n")), "{scene}");
            assert!(!scene.contains("seconds"), "{scene}");
        }
        saved.push(d);
    }
    for d in &saved {
        let name = d.header["name"].as_str().unwrap();
        let (stem, ext) = name.rsplit_once('.').unwrap();
        let spp: u64 = stem
            .strip_prefix("view-1-")
            .and_then(|s| s.strip_suffix("spp"))
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{name}: no pass count"));
        let command = d.header["command"].as_str().unwrap();
        assert!(
            command.contains(&format!("--spp={spp} "))
                && command.ends_with(&format!("-o {stem}.png --hdr {stem}.pfm")),
            "{command}"
        );
        if ext == "toml" {
            let text = String::from_utf8(d.payload.clone()).unwrap();
            assert!(text.contains(&format!("spp = {spp}\n")), "{text}");
            continue;
        }
        let mut one = pairs.as_object().unwrap().clone();
        one.remove("seconds");
        one.insert("spp".into(), json!(spp));
        let request = volscene::Request::from_pairs(one).unwrap();
        let options = request.options();
        let source = volscene::Source::open(options, &dir.path().join("shapes.vvol")).unwrap();
        let plan = volscene::Plan::for_source(options, &source).unwrap();
        let r =
            volscene::render(options, &source, &plan, &volscene::Cancel::new(), |_| {}).unwrap();
        let mut want = Vec::new();
        volformats::image::encode_pfm(&mut want, 48, 40, 3, &r.linear_rgb()).unwrap();
        assert!(d.payload == want, "{name} is not {spp} samples per pixel");
    }
}

/// Issue 53 §7: one save is one stem: the PNG, PFM and scene of a view
/// and the command shown for it (which reads that scene file when it
/// needs one).
#[test]
fn a_views_saves_and_command_share_one_stem() {
    let (addr, _dir, _) = start(Config::loopback(0));
    let (mut ws, _) = connect(addr, "");
    let mut pairs = small(25.0);
    pairs["tf-text"] = json!("domain 0 255\npoint 0 255 255 255 0\npoint 255 255 255 255 0.5\n");
    pairs.as_object_mut().unwrap().remove("tf");
    render(&mut ws, 19, pairs);
    let (f, _) = until(&mut ws, "frame", Some(19));
    let shown = f.header["command"].as_str().unwrap().to_string();
    let mut names = Vec::new();
    for what in ["png", "pfm", "scene"] {
        let msg = json!({"type": "save", "what": what});
        ws.send(Message::Text(msg.to_string().into())).unwrap();
        let (d, _) = until(&mut ws, "download", None);
        assert_eq!(d.header["command"], shown.as_str());
        names.push(d.header["name"].as_str().unwrap().to_string());
    }
    assert_eq!(names, ["view-19.png", "view-19.pfm", "view-19.toml"]);
    for name in &names {
        assert!(
            shown.contains(&format!(" {name}")),
            "{shown} does not name {name}"
        );
    }
}

/// The lines vol-view prints on start (until "Ctrl-C"), its stderr as it
/// comes, and the process.
fn launch(
    args: &[&str],
    unset: &[&str],
) -> (Vec<String>, std::sync::mpsc::Receiver<String>, Child) {
    use std::io::BufRead;
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_vol-view"));
    let dir = tempfile::tempdir().unwrap();
    let vol = volume(dir.path());
    cmd.arg(&vol).args(args);
    for name in unset {
        cmd.env_remove(name);
    }
    let mut child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let err = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(err).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut lines = Vec::new();
    loop {
        let mut line = String::new();
        if out.read_line(&mut line).unwrap() == 0 {
            break;
        }
        let stop = line.contains("Ctrl-C");
        lines.push(line.trim_end().to_string());
        if stop {
            break;
        }
    }
    // The volume is open: the folder may go.
    drop(dir);
    (lines, rx, Child(child))
}

/// A process killed when dropped.
struct Child(std::process::Child);

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The addresses (`http://…/`) in `lines`.
fn urls(lines: &[String]) -> Vec<String> {
    lines
        .iter()
        .filter_map(|l| l.split_whitespace().find(|w| w.starts_with("http://")))
        .map(String::from)
        .collect()
}

/// Issue 53 §7: `--open` without a display says so in one line on
/// stderr, and the server goes on serving.
#[test]
fn open_without_a_display_says_so_and_serves() {
    let (lines, err, _child) = launch(&["--open"], &["DISPLAY", "WAYLAND_DISPLAY"]);
    let line = err
        .recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("nothing on stderr; stdout: {lines:?}"));
    assert!(line.starts_with("vol-view: --open: no display"), "{line}");
    let url = urls(&lines).remove(0);
    let addr: SocketAddr = url["http://".len()..]
        .trim_end_matches('/')
        .parse()
        .unwrap();
    assert_eq!(get(addr, "/").0, 200);
    assert!(err.recv_timeout(Duration::from_millis(300)).is_err());
}

/// Issue 53 §7: `--listen 0.0.0.0` prints the addresses that reach it:
/// the machine's primary address (where it has one) and loopback, never
/// the wildcard; each serves the page with its token.
#[test]
fn listen_on_every_address_prints_the_reachable_ones() {
    let (lines, _err, _child) = launch(&["--listen", "0.0.0.0"], &[]);
    let all = urls(&lines);
    assert!(all.iter().all(|u| !u.contains("0.0.0.0")), "{lines:?}");
    assert!(
        all.iter().any(|u| u.starts_with("http://127.0.0.1:")),
        "{lines:?}"
    );
    // The primary address as the system routes off the machine.
    let primary = std::net::UdpSocket::bind("0.0.0.0:0")
        .and_then(|s| s.connect("198.51.100.1:9").map(|_| s))
        .and_then(|s| s.local_addr())
        .map(|a| a.ip());
    if let Ok(ip) = primary {
        assert!(
            all.iter().any(|u| u.starts_with(&format!("http://{ip}:"))),
            "{ip} missing: {lines:?}"
        );
    }
    for url in &all {
        let rest = &url["http://".len()..];
        let (host, target) = rest.split_once('/').unwrap();
        let addr: SocketAddr = host.parse().unwrap();
        let mut s = TcpStream::connect(addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        write!(s, "GET /{target} HTTP/1.1\r\nHost: {host}\r\n\r\n").unwrap();
        let mut text = String::new();
        s.read_to_string(&mut text).unwrap();
        assert!(
            text.starts_with("HTTP/1.1 200"),
            "{url}: {}",
            text.lines().next().unwrap_or("")
        );
    }
}

/// Issue 53 §7: docs/view.md names only flags vol-view or vol-render
/// has (it named `--time`, which is `--seconds`).
#[test]
fn the_guide_names_only_real_flags() {
    use clap::CommandFactory;
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/view.md")).unwrap();
    let help = std::process::Command::new(env!("CARGO_BIN_EXE_vol-view"))
        .arg("--help")
        .output()
        .unwrap();
    let view_help = String::from_utf8(help.stdout).unwrap();
    let render = volscene::Options::command();
    let mut unknown = Vec::new();
    for (i, _) in text.match_indices("`--") {
        let flag: String = text[i + 3..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
            .collect();
        // A hidden flag is an old spelling kept to say it is gone.
        let known = render
            .get_arguments()
            .any(|a| a.get_long() == Some(flag.as_str()) && !a.is_hide_set())
            || view_help
                .match_indices(&format!("--{flag}"))
                .any(|(at, m)| {
                    !view_help[at + m.len()..]
                        .starts_with(|c: char| c.is_ascii_alphanumeric() || c == '-')
                })
            || ["help", "version"].contains(&flag.as_str());
        if !known {
            unknown.push(flag);
        }
    }
    assert!(
        unknown.is_empty(),
        "docs/view.md names flags no tool has: {unknown:?}"
    );
}
