//! Multiresolution sculpting (seed 004): UV vector maps, strokes, Jordan
//! classification, trimming, overlaps and tessellation.
pub mod document;
pub mod jordan;
pub mod stroke;
pub mod stroke_surface;
pub mod surface;
pub mod tessellate;
pub mod uvmap;
