//! Benchmarks: the event-driven engine and both trainers on the peer benchmark's network
//! ([`engine`]), and any model or NIR graph on any events ([`models`]), also in a chip's arithmetic
//! ([`chip`]).

pub mod chip;
pub mod engine;
pub mod live;
pub mod models;
