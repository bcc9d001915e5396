//! The checks every request passes before it is served, on loopback
//! too: the `Host` header must name this server (a page from another
//! site cannot reach it through DNS rebinding), an `Origin` header must
//! be this server's own (another site's page cannot open the
//! WebSocket), and off loopback the request must carry the token.

use crate::http::{Head, Response};
use std::net::SocketAddr;

/// The cookie that carries the token after the page's first load.
pub const TOKEN_COOKIE: &str = "volview_token";

/// What a request must satisfy.
#[derive(Clone, Debug)]
pub struct Guard {
    port: u16,
    /// Host names (lower case, IPv6 in brackets) the `Host` header may
    /// give; `None`: any (a wildcard address, where the token guards).
    hosts: Option<Vec<String>>,
    token: Option<String>,
}

impl Guard {
    /// The checks for a server bound at `addr`: the loopback names, the
    /// bound address and `extra_hosts` as hosts, and `token` when given.
    pub fn new(addr: SocketAddr, token: Option<String>, extra_hosts: &[String]) -> Guard {
        let ip = addr.ip();
        let hosts = if ip.is_unspecified() && extra_hosts.is_empty() {
            None
        } else {
            let mut h: Vec<String> = ["localhost", "127.0.0.1", "[::1]"]
                .iter()
                .map(|s| s.to_string())
                .collect();
            if !ip.is_unspecified() {
                h.push(match ip {
                    std::net::IpAddr::V6(v6) => format!("[{v6}]"),
                    v4 => v4.to_string(),
                });
            }
            h.extend(extra_hosts.iter().map(|s| s.to_ascii_lowercase()));
            Some(h)
        };
        Guard {
            port: addr.port(),
            hosts,
            token,
        }
    }

    /// The token requests need, if any.
    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// Check `head`; the answer to send instead when it fails.
    pub fn check(&self, head: &Head) -> Result<(), Response> {
        let Some(host) = head.header("host") else {
            return Err(Response::text(400, "refused: no Host header"));
        };
        if !self.host_ok(host) {
            return Err(Response::text(
                421,
                format!(
                    "refused: Host `{}` is not this server (vol-view answers only to its own address)",
                    clip(host)
                ),
            ));
        }
        if let Some(origin) = head.header("origin") {
            let own = format!("http://{host}");
            if !origin.eq_ignore_ascii_case(&own) {
                return Err(Response::text(
                    403,
                    format!(
                        "refused: Origin `{}` is another site's (vol-view takes requests from its own page only)",
                        clip(origin)
                    ),
                ));
            }
        }
        if let Some(token) = &self.token {
            let given = head.query("token").or_else(|| head.cookie(TOKEN_COOKIE));
            match given {
                Some(g) if same(g.as_bytes(), token.as_bytes()) => {}
                Some(_) => return Err(Response::text(403, "refused: wrong token")),
                None => {
                    return Err(Response::text(
                        401,
                        "refused: this server needs the token it printed on start (?token=...)",
                    ))
                }
            }
        }
        Ok(())
    }

    /// Whether `host` (`name:port`) names this server.
    fn host_ok(&self, host: &str) -> bool {
        let host = host.trim().to_ascii_lowercase();
        let (name, port) = match host.rsplit_once(':') {
            Some((n, p)) if !p.contains(']') => (n, p.parse::<u16>().ok()),
            _ => (host.as_str(), None),
        };
        if port != Some(self.port) {
            return false;
        }
        match &self.hosts {
            None => true,
            Some(hosts) => hosts.iter().any(|h| h == name),
        }
    }
}

/// Equal bytes, compared in time that does not depend on where they
/// first differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A header value as an answer quotes it: escaped and clipped.
fn clip(s: &str) -> String {
    volcore::text::clip(&volcore::text::escape(s), 80)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(host: Option<&str>, origin: Option<&str>, target: &str) -> Head {
        let mut headers = Vec::new();
        if let Some(h) = host {
            headers.push(("Host".to_string(), h.to_string()));
        }
        if let Some(o) = origin {
            headers.push(("Origin".to_string(), o.to_string()));
        }
        Head {
            method: "GET".into(),
            target: target.into(),
            headers,
            rest: Vec::new(),
        }
    }

    #[test]
    fn loopback_takes_its_own_names_only() {
        let g = Guard::new("127.0.0.1:8123".parse().unwrap(), None, &[]);
        assert!(g.check(&head(Some("127.0.0.1:8123"), None, "/")).is_ok());
        assert!(g.check(&head(Some("localhost:8123"), None, "/")).is_ok());
        let e = g
            .check(&head(Some("evil.example:8123"), None, "/"))
            .unwrap_err();
        assert_eq!(e.status, 421);
        assert_eq!(
            g.check(&head(Some("localhost:9"), None, "/"))
                .unwrap_err()
                .status,
            421
        );
        assert_eq!(g.check(&head(None, None, "/")).unwrap_err().status, 400);
        let ok = head(Some("localhost:8123"), Some("http://localhost:8123"), "/ws");
        assert!(g.check(&ok).is_ok());
        let bad = head(Some("localhost:8123"), Some("http://evil.example"), "/ws");
        assert_eq!(g.check(&bad).unwrap_err().status, 403);
    }

    #[test]
    fn a_token_is_needed_where_one_is_set() {
        let g = Guard::new("0.0.0.0:8123".parse().unwrap(), Some("abc".into()), &[]);
        assert_eq!(
            g.check(&head(Some("host:8123"), None, "/"))
                .unwrap_err()
                .status,
            401
        );
        assert_eq!(
            g.check(&head(Some("host:8123"), None, "/?token=abd"))
                .unwrap_err()
                .status,
            403
        );
        assert!(g
            .check(&head(Some("host:8123"), None, "/?token=abc"))
            .is_ok());
        let mut with_cookie = head(Some("host:8123"), None, "/app.js");
        with_cookie
            .headers
            .push(("Cookie".into(), format!("a=1; {TOKEN_COOKIE}=abc")));
        assert!(g.check(&with_cookie).is_ok());
    }
}
