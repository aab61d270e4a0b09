//! The reference gas (Span et al. 2000) tabulated once per process
//! ([`hp_core::gas::table`]): what the vehicles evaluate their units' gas
//! with. The 8x8 evaluates 64 gas states per 1 ms period at fixed steps;
//! directly that is three quarters of its time, through the table a few
//! per cent, for a pressure within 1e-9 of the direct evaluation.
//!
//! Built on first use (about 180,000 evaluations of the equation, some
//! tens of milliseconds) and shared by every vehicle and thread after that.

use std::sync::OnceLock;

use hp_core::gas::table::{fill, TableNode, TabulatedGas, SPAN_GRID};
use hp_core::gas::Span;

/// The reference gas's table, or None if it could not be built (then the
/// callers evaluate the equation directly).
pub fn span() -> Option<TabulatedGas<'static, Span>> {
    static NODES: OnceLock<Option<Box<[TableNode]>>> = OnceLock::new();
    let nodes = NODES.get_or_init(|| {
        let mut nodes = vec![TableNode::default(); SPAN_GRID.len()].into_boxed_slice();
        fill(&SPAN_GRID, &Span, &mut nodes).ok().map(|()| nodes)
    });
    nodes.as_deref().map(|nodes| TabulatedGas { grid: SPAN_GRID, nodes, direct: Span })
}
