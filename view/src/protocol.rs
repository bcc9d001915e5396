//! The WebSocket messages. The page sends text messages, one JSON object
//! each; the server answers with binary messages: a 4-byte big-endian
//! length, that many bytes of a JSON header (its `type` says what it
//! is), then the payload (a PNG frame, a slice's f32 values, a file to
//! download; empty for the rest).

use serde::Deserialize;
use serde_json::{Map, Value};

/// The most a message from the page may hold.
pub const MAX_MESSAGE: usize = 1 << 20;

/// A message from the page.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ClientMessage {
    /// Render this view: vol-render's options as name/value pairs (the
    /// flags' names, JSON values). `seq` must rise from one request to
    /// the next; `preview` asks for the coarser frame shown while the
    /// camera moves.
    Render {
        /// The request's number.
        seq: u64,
        /// The options.
        pairs: Map<String, Value>,
        /// A preview while the camera moves.
        #[serde(default)]
        preview: bool,
    },
    /// Compute the PSNR of view `seq` against a reference render of it
    /// at the finest settings, in the background.
    Psnr {
        /// The view's request number.
        seq: u64,
    },
    /// Send the current full frame's file to download.
    Save {
        /// Which file.
        what: SaveKind,
    },
    /// Send a slice through the volume.
    Slice {
        /// Across which axis.
        axis: Axis,
        /// The voxel index along it.
        index: u64,
    },
}

/// The files the page can save.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum SaveKind {
    /// The 8-bit frame as shown.
    Png,
    /// The linear float image (what `vol-render --hdr` writes).
    Pfm,
    /// The view as a scene file (`vol-render --scene`).
    Scene,
}

/// An axis of the volume's voxel grid.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Across x: the sagittal slice of a volume in RAS/LPS order.
    X,
    /// Across y: coronal.
    Y,
    /// Across z: axial.
    Z,
}

impl ClientMessage {
    /// Parse a text message; the error is one line for the page.
    pub fn parse(text: &str) -> Result<ClientMessage, String> {
        serde_json::from_str(text).map_err(|e| format!("malformed message: {e}"))
    }
}

/// A message to the page: its header and payload.
#[derive(Clone, Debug, PartialEq)]
pub struct Out {
    /// The JSON header (`type` first).
    pub header: Value,
    /// The payload.
    pub payload: Vec<u8>,
}

impl Out {
    /// A message without payload.
    pub fn json(header: Value) -> Out {
        Out {
            header,
            payload: Vec::new(),
        }
    }

    /// An error for the page (`seq`: the request it answers, if any).
    pub fn error(seq: Option<u64>, message: impl Into<String>) -> Out {
        Out::json(serde_json::json!({"type": "error", "seq": seq, "message": message.into()}))
    }

    /// The bytes of the binary message.
    pub fn encode(&self) -> Vec<u8> {
        let header = self.header.to_string();
        let mut out = Vec::with_capacity(4 + header.len() + self.payload.len());
        out.extend_from_slice(&(header.len() as u32).to_be_bytes());
        out.extend_from_slice(header.as_bytes());
        out.extend_from_slice(&self.payload);
        out
    }

    /// Split a binary message into header and payload (the page's and
    /// the tests' reading of [`Out::encode`]).
    pub fn decode(bytes: &[u8]) -> Result<Out, String> {
        let len = bytes
            .get(..4)
            .map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as usize)
            .ok_or("a message shorter than its length")?;
        let header = bytes
            .get(4..4 + len)
            .ok_or("a header past the message's end")?;
        let header = serde_json::from_slice(header).map_err(|e| e.to_string())?;
        Ok(Out {
            header,
            payload: bytes[4 + len..].to_vec(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_parse_or_say_why_not() {
        let m = ClientMessage::parse(r#"{"type":"render","seq":3,"pairs":{"mode":"mip"}}"#);
        assert!(matches!(
            m,
            Ok(ClientMessage::Render {
                seq: 3,
                preview: false,
                ..
            })
        ));
        assert!(ClientMessage::parse("{")
            .unwrap_err()
            .starts_with("malformed message"));
        assert!(ClientMessage::parse(r#"{"type":"dance"}"#).is_err());
        assert!(ClientMessage::parse(r#"{"type":"save","what":"exe"}"#).is_err());
        let s = ClientMessage::parse(r#"{"type":"slice","axis":"z","index":4}"#);
        assert_eq!(
            s,
            Ok(ClientMessage::Slice {
                axis: Axis::Z,
                index: 4
            })
        );
    }

    #[test]
    fn out_round_trips() {
        let o = Out {
            header: serde_json::json!({"type": "frame", "seq": 1}),
            payload: vec![1, 2, 3],
        };
        assert_eq!(Out::decode(&o.encode()), Ok(o));
        assert!(Out::decode(&[0, 0, 0, 9, b'{']).is_err());
    }
}
