//! Data-parallel rendering across processes (ranks), sort-last: the
//! volume is split into convex boxes, one per rank ([`partition`],
//! weighted by the cells the frame can see: [`split`]), each rank takes
//! the samples of every ray inside its box ([`share`], through
//! [`crate::frame::render_film`]), and the ranks' films are composited in
//! the visibility order the split gives ([`composite`]: `Film::composite`);
//! films travel between processes as rows of records ([`wire`]:
//! `Film::encode_rows`).

pub mod composite;
pub mod partition;
pub mod share;
pub mod split;
pub mod wire;

pub use composite::Composite;
pub use partition::{KdTree, Leaf, Viewer};
pub use share::ShareBox;
pub use split::{composite_for, strip_rows, Split};
pub use wire::Fields;
