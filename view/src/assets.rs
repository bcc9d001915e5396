//! The page's static files, embedded in the binary at build time (no
//! CDN, nothing read from disk at run time). Only these paths are served.

/// One embedded file.
#[derive(Clone, Copy, Debug)]
pub struct Asset {
    /// The path it is served at.
    pub path: &'static str,
    /// Its `Content-Type`.
    pub content_type: &'static str,
    /// Its bytes.
    pub body: &'static [u8],
}

/// Every file the server serves (`/` is the first).
pub const ASSETS: [Asset; 4] = [
    Asset {
        path: "/index.html",
        content_type: "text/html; charset=utf-8",
        body: include_bytes!("../web/index.html"),
    },
    Asset {
        path: "/app.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../web/app.js"),
    },
    Asset {
        path: "/tf.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../web/tf.js"),
    },
    Asset {
        path: "/style.css",
        content_type: "text/css; charset=utf-8",
        body: include_bytes!("../web/style.css"),
    },
];

/// The file served at `path` (`/` is the page).
pub fn find(path: &str) -> Option<&'static Asset> {
    let path = if path == "/" { "/index.html" } else { path };
    ASSETS.iter().find(|a| a.path == path)
}

/// Whether `path` tries to leave the served root (`..` segments, raw or
/// percent-encoded, or backslashes): answered as refused, not as missing.
pub fn escapes(path: &str) -> bool {
    let lower = path.to_ascii_lowercase();
    lower.contains("..")
        || lower.contains("%2e%2e")
        || lower.contains('\\')
        || lower.contains("%5c")
}
