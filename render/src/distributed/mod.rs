//! Data-parallel rendering across processes (ranks), sort-last: the
//! volume is split into convex boxes, one per rank ([`partition`]), each
//! rank renders the ray segments inside its box, and the segments are
//! composited in the visibility order the split gives.

pub mod partition;

pub use partition::{KdTree, Leaf, Viewer};
