//! Legacy VTK `STRUCTURED_GRID` files (`sculpt_core::volume::StructuredGrid::from_vtk`),
//! ASCII and BINARY.
//!
//! Checked: no panic and no allocation beyond the input's size; a grid the reader
//! accepts writes out (ASCII and BINARY) and reads back equal.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::volume::StructuredGrid;

fuzz_target!(|data: &[u8]| {
    if let Ok(grid) = StructuredGrid::from_vtk(data) {
        for binary in [false, true] {
            let bytes = grid.to_vtk("fuzz", binary);
            let again = StructuredGrid::from_vtk(&bytes).expect("a written grid must read back");
            assert_eq!(again, grid, "write-read changed the grid (binary {binary})");
        }
    }
});
