//! Where the server listens, whether it needs a token, and where it may
//! write files.

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, UdpSocket};
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

/// The addresses that reach a server bound at `ip`: `ip` itself, or for
/// a wildcard (`0.0.0.0`, `::`) the machine's primary address of that
/// family (the one its default route leaves from), when it has one, and
/// loopback.
pub fn reachable(ip: IpAddr) -> Vec<IpAddr> {
    if !ip.is_unspecified() {
        return vec![ip];
    }
    // Documentation addresses (RFC 5737, RFC 3849): routed like any
    // other address off the machine, never answered.
    let (probe, loopback): (SocketAddr, IpAddr) = match ip {
        IpAddr::V4(_) => (
            SocketAddr::from(([198, 51, 100, 1], 9)),
            Ipv4Addr::LOCALHOST.into(),
        ),
        IpAddr::V6(_) => (
            SocketAddr::from(([0x2001, 0xdb8, 0, 0, 0, 0, 0, 1], 9)),
            Ipv6Addr::LOCALHOST.into(),
        ),
    };
    let mut out: Vec<IpAddr> = primary_address(ip, probe)
        .filter(|a| !a.is_loopback() && !a.is_unspecified())
        .into_iter()
        .collect();
    out.push(loopback);
    out
}

/// The local address a UDP socket bound at `wildcard` sends from toward
/// `probe`: connecting a UDP socket sends nothing, the system only picks
/// the route and its source address.
fn primary_address(wildcard: IpAddr, probe: SocketAddr) -> Option<IpAddr> {
    let socket = UdpSocket::bind(SocketAddr::new(wildcard, 0)).ok()?;
    socket.connect(probe).ok()?;
    Some(socket.local_addr().ok()?.ip())
}

#[cfg(test)]
mod tests {
    use super::reachable;
    use std::net::{IpAddr, Ipv4Addr};

    #[test]
    fn a_bound_address_is_its_own_and_a_wildcard_adds_loopback() {
        let ip: IpAddr = Ipv4Addr::new(10, 1, 2, 3).into();
        assert_eq!(reachable(ip), [ip]);
        let all = reachable(Ipv4Addr::UNSPECIFIED.into());
        assert_eq!(all.last(), Some(&IpAddr::from(Ipv4Addr::LOCALHOST)));
        assert!(all.iter().all(|a| !a.is_unspecified()), "{all:?}");
    }
}
