//! The reference gas (Span et al. 2000) tabulated once per process
//! ([`hp_core::gas::table`]): what the vehicles evaluate their units' gas
//! with. The 8x8 evaluates 64 gas states per 1 ms period at fixed steps;
//! directly that is three quarters of its time, through the table a few
//! per cent, for a pressure within 1.3e-8 of the direct evaluation.
//!
//! Built on first use (about 180,000 evaluations of the equation, some
//! tens of milliseconds) and shared by every vehicle and thread after that.

use std::sync::OnceLock;

use hp_core::gas::table::{fill, TableCell, TabulatedGas, SPAN_GRID};
use hp_core::gas::Span;

/// The reference gas's table, or None if it could not be built (then the
/// callers evaluate the equation directly).
pub fn span() -> Option<TabulatedGas<'static, Span>> {
    static NODES: OnceLock<Option<Box<[TableCell]>>> = OnceLock::new();
    let cells = NODES.get_or_init(|| {
        let mut cells = vec![TableCell::default(); SPAN_GRID.len()].into_boxed_slice();
        fill(&SPAN_GRID, &Span, &mut cells).ok().map(|()| cells)
    });
    cells.as_deref().map(|cells| TabulatedGas { grid: SPAN_GRID, cells, direct: Span })
}
