//! Erosion models: hydraulic (virtual pipes), thermal, hillslope diffusion,
//! stream power with uplift, and constrained erosion, tiled with halo exchange.

pub mod constrained;
pub mod multires;
pub mod stream_power;
