//! Where the server listens, whether it needs a token, and where it may
//! write files.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;

/// How a server is set up.
#[derive(Clone, Debug)]
pub struct Config {
    /// The address to bind (port 0: a free one the system picks).
    pub addr: SocketAddr,
    /// The token every request must carry (`?token=` or its cookie);
    /// `None` on loopback.
    pub token: Option<String>,
    /// Host names besides the bound address and the loopback names that
    /// the `Host` header may give (`--allow-host`).
    pub extra_hosts: Vec<String>,
    /// The folder saves are also written to (`--save-dir`); without it
    /// the server writes no file.
    pub save_dir: Option<PathBuf>,
    /// Connections served at once; more are answered 503.
    pub max_connections: usize,
}

impl Config {
    /// Loopback on `port` (0: any free port), no token, no save folder.
    pub fn loopback(port: u16) -> Config {
        Config {
            addr: SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), port),
            token: None,
            extra_hosts: Vec::new(),
            save_dir: None,
            max_connections: 64,
        }
    }

    /// Listen on `addr` (`--listen`): a token is made unless it is a
    /// loopback address.
    pub fn listen(addr: SocketAddr) -> std::io::Result<Config> {
        let token = if addr.ip().is_loopback() {
            None
        } else {
            Some(new_token()?)
        };
        Ok(Config {
            addr,
            token,
            ..Config::loopback(addr.port())
        })
    }
}

/// 128 random bits from the OS as 32 hex digits.
pub fn new_token() -> std::io::Result<String> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).map_err(|e| std::io::Error::other(e.to_string()))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}
