//! Multiresolution sculpting (Kwon, Kim and Chai, "NURBS surface rendering of sculpting effect using multiresolution surface trimming for spatial virtual design", 2006): UV vector maps, strokes, Jordan
//! classification, trimming, overlaps and tessellation.
pub mod conform;
pub mod document;
pub mod hidden;
pub mod ids;
pub mod jordan;
pub mod network_stroke;
pub mod ray;
pub mod stroke;
pub mod stroke_surface;
pub mod surface;
pub mod tessellate;
pub mod uvmap;
pub mod view;
