//! Benchmarks: the event-driven engine and both trainers on the peer benchmark's network
//! ([`engine`]), any model or NIR graph on any events ([`models`]), also in a chip's arithmetic
//! ([`chip`]), and a ResNet model file on its windows ([`resnet`]).

pub mod chip;
pub mod engine;
pub mod live;
pub mod models;
pub mod resnet;
