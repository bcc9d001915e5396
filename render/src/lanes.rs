//! Values of eight samples at once, laid out for AVX2 lanes.

/// Eight samples' values per component, then per lane: points, colours,
/// world gradients or shaded colours.
pub type Lanes3 = [[f32; 8]; 3];
