//! Data-parallel rendering across processes (ranks), sort-last: the
//! volume is split into convex boxes, one per rank ([`partition`],
//! weighted by the cells the frame can see: [`layout`]), each rank takes
//! the samples of every ray inside its box ([`share`], through
//! [`crate::frame::render_film`]), and the ranks' films are composited in
//! the visibility order the split gives ([`composite`]: `Film::composite`);
//! films travel between processes as rows of records ([`wire`]:
//! `Film::encode_rows`).

pub mod composite;
pub mod layout;
pub mod partition;
pub mod share;
pub mod wire;

pub use composite::Composite;
pub use layout::{composite_for, strip_rows, Layout};
pub use partition::{KdTree, Leaf, Viewer};
pub use share::ShareBox;
pub use wire::Fields;
