//! One flow graph for every single-flow-direction consumer: receivers,
//! distances to them and the stack (Braun & Willett 2013), made by routers
//! and sink resolvers and consumed by accumulation, hydrology's D8
//! accumulation and the stream-power eroder (the model of fastscapelib:
//! one graph, updated by router and sink-resolver operators, read by
//! every eroder).
//!
//! - [`FlowGraph`] (`graph`): receivers (`u32`, a root is its own receiver,
//!   [`NONE`] outside the graph), distances, the stack built in O(n) by
//!   in-degree counting;
//! - routers: steepest-descent D8 on heights ([`route_steepest`], cells of
//!   the domain given by [`VALID`] / [`BASE`] flags) and D8 direction codes
//!   ([`route_d8_codes`], hydrology's ESRI codes);
//! - sink resolvers on [`Lakes`]: filling ([`Lakes::fill`]: priority-flood
//!   levels and flat distances) and the basin graph of Cordonnier, Bovy &
//!   Braun 2019 ([`Lakes::basin_graph`]);
//! - [`FlowGraph::accumulate`]: cell counts or weights summed in reverse
//!   stack order ([`Flux`]).
//!
//! The graph is generic over its cell type through [`FlowFloat`] (`f32` for
//! hydrology, `f64` for the eroders); slopes are compared in `f64` either
//! way. Design page: `docs/design/flow-graph.md`.

mod accumulate;
mod basin_graph;
mod d8_codes;
mod fill;
mod float;
mod graph;
mod steepest;

pub use accumulate::Flux;
pub use basin_graph::Lakes;
pub use d8_codes::{
    accumulate_d8_codes, bad_code, code_to_dir, route_d8_codes, D8_CODES, NODATA_DIR, NO_FLOW,
};
pub use float::{order_key, FlowFloat};
pub use graph::{FlowGraph, NONE};
pub use steepest::{route_steepest, BASE, VALID};
